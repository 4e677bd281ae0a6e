//! Plots: projections of point clouds over a reference cloud and heat maps as PNG (dense
//! views: a file's size follows its pixels, not its points), empirical CDFs as SVG (line plots).
//! One drawing per figure, over any plotters backend ([`Figure`]); the file name's extension
//! picks the format ([`write_figure`]). Text is set in a subset of DejaVu Sans compiled into the
//! binary (`assets/`, its licence beside it), so a PNG looks the same on every machine, fonts
//! installed or not. Files are written atomically (temporary file, then rename).

use std::path::Path;
use std::sync::Once;

use anyhow::{Context, Result};
use glam::Vec3;
use plotters::coord::Shift;
use plotters::prelude::*;

/// DejaVu Sans, cut to Latin-1 letters and the symbols the titles use (see `assets/`).
const FONT: &[u8] = include_bytes!("../assets/DejaVuSans-subset.ttf");

/// Makes [`FONT`] plotters' "sans-serif", once per process.
fn register_font() -> Result<()> {
    static ONCE: Once = Once::new();
    let mut result = Ok(());
    ONCE.call_once(|| {
        result = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT)
            .map_err(|_| anyhow::anyhow!("the compiled-in plot font does not parse"));
    });
    result
}

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

/// A figure drawn the same way on any plotters backend.
trait Figure {
    /// Pixel size.
    fn size(&self) -> (u32, u32);
    /// Draws onto `root` (already filled white).
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()>
    where
        DB::ErrorType: 'static;
}

/// Draws `fig` into `path`: PNG (8-bit RGB) when the name ends in `.png`, else SVG.
fn write_figure(path: &Path, fig: &impl Figure) -> Result<()> {
    register_font()?;
    let (w, h) = fig.size();
    let ctx = || format!("writing {}", path.display());
    if path.extension().is_some_and(|e| e == "png") {
        let mut rgb = vec![0u8; w as usize * h as usize * 3];
        {
            let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
            root.fill(&WHITE)?;
            fig.draw(&root)?;
            root.present()?;
        }
        has_host::io::atomic_write(path, |file| {
            let mut enc = png::Encoder::new(file, w, h);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            let mut writer = enc.write_header().map_err(std::io::Error::other)?;
            writer
                .write_image_data(&rgb)
                .map_err(std::io::Error::other)?;
            writer.finish().map_err(std::io::Error::other)
        })
        .with_context(ctx)
    } else {
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
            root.fill(&WHITE)?;
            fig.draw(&root)?;
            root.present()?;
        }
        has_host::io::atomic_write(path, |file| std::io::Write::write_all(file, svg.as_bytes()))
            .with_context(ctx)
    }
}

/// A projection of `layers` (each `(label, points, colour, radius in pixels)`, drawn in order)
/// with equal axis scales, written to `path` (PNG or SVG by its extension).
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
    write_figure(
        path,
        &Projection {
            title,
            view,
            layers,
            x: (lo.0 - pad, hi.0 + pad),
            y: (lo.1 - pad, hi.1 + pad),
            size: (px_w, px_h),
        },
    )
}

struct Projection<'a> {
    title: &'a str,
    view: View,
    layers: &'a [(&'a str, &'a [Vec3], RGBColor, u32)],
    x: (f32, f32),
    y: (f32, f32),
    size: (u32, u32),
}

impl Figure for Projection<'_> {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()>
    where
        DB::ErrorType: 'static,
    {
        let (xl, yl) = match self.view {
            View::Top => ("x (m)", "y (m)"),
            View::Side => ("x (m)", "z (m)"),
        };
        let mut chart = ChartBuilder::on(root)
            .caption(self.title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(45)
            .build_cartesian_2d(self.x.0..self.x.1, self.y.0..self.y.1)?;
        chart
            .configure_mesh()
            .x_desc(xl)
            .y_desc(yl)
            .light_line_style(WHITE)
            .draw()?;
        for (label, pts, colour, size) in self.layers {
            let (c, s, view) = (*colour, *size, self.view);
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
        Ok(())
    }
}

/// Empirical CDFs (paper Fig. 9 style): one step curve per series `(label, values, colour)`,
/// x from 0 to the largest 98th percentile of the series (at least `x_min_max`; larger values run
/// off the right edge), y the fraction of values ≤ x; a dashed line marks the 90th percentile
/// level. Written to `path` (SVG or PNG by its extension).
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
    write_figure(
        path,
        &Cdf {
            title,
            x_label,
            series,
            x_max,
        },
    )
}

struct Cdf<'a> {
    title: &'a str,
    x_label: &'a str,
    series: &'a [(&'a str, &'a [f64], RGBColor)],
    x_max: f64,
}

impl Figure for Cdf<'_> {
    fn size(&self) -> (u32, u32) {
        (800, 560)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()>
    where
        DB::ErrorType: 'static,
    {
        let x_max = self.x_max;
        let mut chart = ChartBuilder::on(root)
            .caption(self.title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..x_max, 0.0..1.0)?;
        chart
            .configure_mesh()
            .x_desc(self.x_label)
            .y_desc("CDF")
            .draw()?;
        chart.draw_series(DashedLineSeries::new(
            [(0.0, 0.9), (x_max, 0.9)],
            6,
            4,
            BLACK.mix(0.5).stroke_width(1),
        ))?;
        for (label, values, colour) in self.series {
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
        Ok(())
    }
}

/// A heat map of `values` (row-major `[iy][ix]`, `nx · ny` cells, in dB) over the axis ranges
/// `x` and `y`, clipped to `[vmin, vmax]` and coloured from dark blue (vmin) through green to
/// yellow (vmax), written to `path` (PNG or SVG by its extension). Used for range–Doppler maps.
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
    write_figure(
        path,
        &Heatmap {
            title,
            labels: (x_label, y_label),
            x,
            y,
            cells: (nx, ny),
            values,
            range: (vmin, vmax),
        },
    )
}

struct Heatmap<'a> {
    title: &'a str,
    labels: (&'a str, &'a str),
    x: (f64, f64),
    y: (f64, f64),
    cells: (usize, usize),
    values: &'a [f32],
    range: (f32, f32),
}

impl Heatmap<'_> {
    /// A viridis-like ramp through four anchors, `range.0` to `range.1`.
    fn colour(&self, v: f32) -> RGBColor {
        let (vmin, vmax) = self.range;
        let t = ((v - vmin) / (vmax - vmin).max(1e-6)).clamp(0.0, 1.0);
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
    }
}

impl Figure for Heatmap<'_> {
    fn size(&self) -> (u32, u32) {
        (900, 600)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()>
    where
        DB::ErrorType: 'static,
    {
        let (x, y, (nx, ny), (vmin, vmax)) = (self.x, self.y, self.cells, self.range);
        let (main, bar) = root.split_horizontally(800);
        let mut chart = ChartBuilder::on(&main)
            .caption(self.title, ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(50)
            .build_cartesian_2d(x.0..x.1, y.0..y.1)?;
        chart
            .configure_mesh()
            .x_desc(self.labels.0)
            .y_desc(self.labels.1)
            .disable_mesh()
            .draw()?;
        let (dx, dy) = ((x.1 - x.0) / nx as f64, (y.1 - y.0) / ny as f64);
        chart.draw_series((0..ny).flat_map(|iy| {
            (0..nx).map(move |ix| {
                let v = self.values[iy * nx + ix];
                let (x0, y0) = (x.0 + ix as f64 * dx, y.0 + iy as f64 * dy);
                Rectangle::new([(x0, y0), (x0 + dx, y0 + dy)], self.colour(v).filled())
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
                self.colour(v0 as f32 + 0.5 * h as f32).filled(),
            )
        }))?;
        Ok(())
    }
}
