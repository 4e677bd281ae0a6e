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
/// x from 0 to the largest value of any series (at least `x_min_max`), y the fraction of values
/// ≤ x; a dashed line marks the 90th percentile level. Written to `path`.
pub fn cdf(
    path: &Path,
    title: &str,
    x_label: &str,
    series: &[(&str, &[f64], RGBColor)],
    x_min_max: f64,
) -> Result<()> {
    let mut x_max = x_min_max;
    for (_, v, _) in series {
        for &x in v.iter() {
            if x.is_finite() {
                x_max = x_max.max(x);
            }
        }
    }
    let x_max = if x_max.is_finite() && x_max > 0.0 {
        x_max * 1.02
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
