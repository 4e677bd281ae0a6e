//! Plots written as SVG (plotters): projections of point clouds over a reference cloud. Files are written atomically (temporary file, then rename).

use std::path::Path;

use anyhow::{Context, Result};
use glam::Vec3;
use plotters::prelude::*;

/// Which two coordinates a projection shows.
#[derive(Clone, Copy, Debug)]
pub enum View {
    /// x–y (seen from above).
    Top,
    /// x–z (seen from −y).
    Side,
}

fn coords(v: View, p: Vec3) -> (f32, f32) {
    match v {
        View::Top => (p.x, p.y),
        View::Side => (p.x, p.z),
    }
}

fn write_atomic(path: &Path, svg: String) -> Result<()> {
    has_host::io::atomic_write(path, |w| std::io::Write::write_all(w, svg.as_bytes()))
        .with_context(|| format!("writing {}", path.display()))
}

/// A projection of `layers` (each `(label, points, colour)`, drawn in order) with equal axis
/// scales, written to `path`.
pub fn projection(
    path: &Path,
    title: &str,
    view: View,
    layers: &[(&str, &[Vec3], RGBColor, u32)],
) -> Result<()> {
    let mut lo = (f32::INFINITY, f32::INFINITY);
    let mut hi = (f32::NEG_INFINITY, f32::NEG_INFINITY);
    for (_, pts, _, _) in layers {
        for p in pts.iter() {
            let (a, b) = coords(view, *p);
            lo = (lo.0.min(a), lo.1.min(b));
            hi = (hi.0.max(a), hi.1.max(b));
        }
    }
    if !lo.0.is_finite() {
        lo = (0.0, 0.0);
        hi = (1.0, 1.0);
    }
    let pad = 1.0;
    let (w, h) = (
        (hi.0 - lo.0 + 2.0 * pad).max(1.0),
        (hi.1 - lo.1 + 2.0 * pad).max(1.0),
    );
    let px_w = 1000u32;
    let px_h = ((px_w as f32) * h / w).clamp(200.0, 1000.0) as u32 + 80;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (px_w, px_h)).into_drawing_area();
        root.fill(&WHITE)?;
        let (xl, yl) = match view {
            View::Top => ("x (m)", "y (m)"),
            View::Side => ("x (m)", "z (m)"),
        };
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(45)
            .build_cartesian_2d(lo.0 - pad..hi.0 + pad, lo.1 - pad..hi.1 + pad)?;
        chart
            .configure_mesh()
            .x_desc(xl)
            .y_desc(yl)
            .light_line_style(WHITE)
            .draw()?;
        for (label, pts, colour, size) in layers {
            let c = *colour;
            let s = *size;
            chart
                .draw_series(pts.iter().map(|p| {
                    let (a, b) = coords(view, *p);
                    Circle::new((a, b), s, c.mix(0.6).filled())
                }))?
                .label(*label)
                .legend(move |(x, y)| Circle::new((x, y), 4, c.filled()));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()?;
        root.present()?;
    }
    write_atomic(path, svg)
}

/// Empirical CDFs (paper Fig. 9 style): one step curve per series `(label, values, colour)`,
/// x from 0 to the largest 98th percentile of the series (at least `x_min_max`; larger values run
/// off the right edge), y the fraction of values ≤ x; a dashed line marks the 90th percentile
/// level. Written to `path`.
pub fn cdf(
    path: &Path,
    title: &str,
    x_label: &str,
    series: &[(&str, &[f64], RGBColor)],
    x_min_max: f64,
) -> Result<()> {
    // The x axis ends at the largest 98th percentile of the series (a few unmatched pairs tens
    // of ns or degrees away would otherwise squeeze the curves against the y axis).
    let mut x_max = x_min_max;
    for (_, v, _) in series {
        let mut s: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
        s.sort_by(f64::total_cmp);
        if let Some(&x) = s.get((s.len() * 98 / 100).min(s.len().saturating_sub(1))) {
            x_max = x_max.max(x);
        }
    }
    let x_max = if x_max.is_finite() && x_max > 0.0 {
        x_max * 1.05
    } else {
        1.0
    };
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (800, 560)).into_drawing_area();
        root.fill(&WHITE)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..x_max, 0.0..1.0)?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc("CDF")
            .draw()?;
        chart.draw_series(DashedLineSeries::new(
            [(0.0, 0.9), (x_max, 0.9)],
            6,
            4,
            BLACK.mix(0.5).stroke_width(1),
        ))?;
        for (label, values, colour) in series {
            let mut s: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
            s.sort_by(f64::total_cmp);
            let n = s.len().max(1) as f64;
            let mut pts = vec![(0.0, 0.0)];
            for (i, &x) in s.iter().enumerate() {
                pts.push((x, i as f64 / n));
                pts.push((x, (i + 1) as f64 / n));
            }
            if let Some(&last) = s.last() {
                pts.push((x_max.max(last), 1.0));
            }
            let pts: Vec<(f64, f64)> = pts.into_iter().map(|(x, y)| (x.min(x_max), y)).collect();
            let c = *colour;
            chart
                .draw_series(LineSeries::new(pts, c.stroke_width(2)))?
                .label(*label)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2))
                });
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()?;
        root.present()?;
    }
    write_atomic(path, svg)
}

/// A heat map of `values` (row-major `[iy][ix]`, `nx · ny` cells, in dB) over the axis ranges
/// `x` and `y`, clipped to `[vmin, vmax]` and coloured from dark blue (vmin) through green to
/// yellow (vmax), written to `path`. Used for range–Doppler maps.
#[allow(clippy::too_many_arguments)]
pub fn heatmap(
    path: &Path,
    title: &str,
    (x_label, y_label): (&str, &str),
    x: (f64, f64),
    y: (f64, f64),
    (nx, ny): (usize, usize),
    values: &[f32],
    (vmin, vmax): (f32, f32),
) -> Result<()> {
    if values.len() != nx * ny || nx == 0 || ny == 0 {
        anyhow::bail!(
            "heatmap {}: {} values for {nx} × {ny} cells",
            path.display(),
            values.len()
        );
    }
    let colour = |v: f32| -> RGBColor {
        let t = ((v - vmin) / (vmax - vmin).max(1e-6)).clamp(0.0, 1.0);
        // A viridis-like ramp through four anchors.
        let anchors = [
            (68.0, 1.0, 84.0),
            (59.0, 82.0, 139.0),
            (33.0, 145.0, 140.0),
            (253.0, 231.0, 37.0),
        ];
        let s = t * 3.0;
        let i = (s.floor() as usize).min(2);
        let f = s - i as f32;
        let (a, b) = (anchors[i], anchors[i + 1]);
        let l = |p: f32, q: f32| (p + (q - p) * f) as u8;
        RGBColor(l(a.0, b.0), l(a.1, b.1), l(a.2, b.2))
    };
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (900, 600)).into_drawing_area();
        root.fill(&WHITE)?;
        let (main, bar) = root.split_horizontally(800);
        let mut chart = ChartBuilder::on(&main)
            .caption(title, ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(50)
            .build_cartesian_2d(x.0..x.1, y.0..y.1)?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .disable_mesh()
            .draw()?;
        let (dx, dy) = ((x.1 - x.0) / nx as f64, (y.1 - y.0) / ny as f64);
        chart.draw_series((0..ny).flat_map(|iy| {
            (0..nx).map(move |ix| {
                let v = values[iy * nx + ix];
                let (x0, y0) = (x.0 + ix as f64 * dx, y.0 + iy as f64 * dy);
                Rectangle::new([(x0, y0), (x0 + dx, y0 + dy)], colour(v).filled())
            })
        }))?;
        let mut cb = ChartBuilder::on(&bar)
            .margin_top(40)
            .margin_bottom(45)
            .margin_right(45)
            .y_label_area_size(0)
            .right_y_label_area_size(40)
            .build_cartesian_2d(0.0..1.0, vmin as f64..vmax as f64)?
            .set_secondary_coord(0.0..1.0, vmin as f64..vmax as f64);
        cb.configure_secondary_axes().y_desc("dB").draw()?;
        let steps = 64;
        let h = (vmax - vmin) as f64 / steps as f64;
        cb.draw_series((0..steps).map(|i| {
            let v0 = vmin as f64 + i as f64 * h;
            Rectangle::new(
                [(0.0, v0), (1.0, v0 + h)],
                colour(v0 as f32 + 0.5 * h as f32).filled(),
            )
        }))?;
        root.present()?;
    }
    write_atomic(path, svg)
}
