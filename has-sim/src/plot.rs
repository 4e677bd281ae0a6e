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
