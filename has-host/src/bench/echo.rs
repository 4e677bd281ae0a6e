//! Throughput of echo synthesis ([`crate::echo::EchoSynth::synth_profiles`]): scatterer × element
//! pairs per second, one thread and all threads, against the plain one-path-at-a-time
//! reference ([`crate::echo::EchoSynth::synth_profiles_reference`]), with the largest difference
//! between the two (they are meant to agree bit for bit).
//!
//! The case is the imaging driver's: a 1024-subcarrier Hann frame at 10 GHz / 400 MHz,
//! zero-padded ×2, pulse kernel ±6 cells at 64 phases; a 60 m × 40 m × 12 m box hall on a
//! 100 m ground square, sampled at 4 scatterers/m² (quick: 1), the scatterers visible from a
//! transmitter at ground level and a `side × side` panel 40 m beyond a corner (bistatic: many
//! face the transmitter and not the panel, as in the imaging runs).

use std::time::Duration;

use glam::Vec3;
use num_complex::Complex32;

use has_dsp::window::Window;

use super::{pool, rate, BenchError};
use crate::echo::{visible_for, EchoConfig, EchoSynth, ScattererSet};
use crate::material::Material;
use crate::scene::{Object, Scene};

/// The hall (five faces of a box) and the ground square of the case.
fn hall_scene() -> Result<Scene, BenchError> {
    let (x0, x1, y0, y1, h) = (-30.0f32, 30.0, -20.0, 20.0, 12.0);
    let v = Vec3::new;
    let quad = |a: Vec3, b: Vec3, c: Vec3, d: Vec3| [[a, b, c], [a, c, d]];
    let corners = [v(x0, y0, 0.), v(x1, y0, 0.), v(x1, y1, 0.), v(x0, y1, 0.)];
    let up = v(0., 0., h);
    let mut hall: Vec<[Vec3; 3]> = (0..4)
        .flat_map(|i| {
            let (a, b) = (corners[i], corners[(i + 1) % 4]);
            quad(a, b, b + up, a + up)
        })
        .collect();
    hall.extend(quad(
        corners[0] + up,
        corners[1] + up,
        corners[2] + up,
        corners[3] + up,
    ));
    let ground = quad(
        v(-50., -50., 0.),
        v(50., -50., 0.),
        v(50., 50., 0.),
        v(-50., 50., 0.),
    );
    Ok(Scene::new(vec![
        Object {
            thickness_m: None,
            name: "hall".into(),
            material: Material::Concrete,
            triangles: hall,
        },
        Object {
            thickness_m: None,
            name: "ground".into(),
            material: Material::MediumDryGround,
            triangles: ground.to_vec(),
        },
    ])?)
}

/// One synthesis path: its rates.
#[derive(Clone, Debug, serde::Serialize)]
pub struct EchoRow {
    /// The path.
    pub name: &'static str,
    /// Scatterer × element pairs per second, one thread.
    pub one_thread: f64,
    /// Scatterer × element pairs per second, all of rayon's threads.
    pub all_threads: f64,
}

/// The synthesis benchmark: the case's size and both paths.
#[derive(Clone, Debug, serde::Serialize)]
pub struct EchoReport {
    /// Scatterers visible from the transmitter and the panel centre (per element, those facing
    /// away from it are skipped).
    pub scatterers: usize,
    /// Receive elements.
    pub elements: usize,
    /// Profile bins.
    pub bins: usize,
    /// Largest `|fast − reference|` over every bin, relative to the largest `|reference|`.
    pub max_rel_difference: f64,
    /// The fast path first, the plain reference (the baseline) last.
    pub rows: Vec<EchoRow>,
}

/// Measures both paths over `budget` each, with one thread and with all threads (quick: a
/// 16 × 16 panel and a sparser sampling; otherwise 32 × 32).
pub fn echo_rates(quick: bool, budget: Duration) -> Result<EchoReport, BenchError> {
    let side = if quick { 16 } else { 32 };
    let density = if quick { 1.0 } else { 4.0 };
    let scene = hall_scene()?;
    let all = ScattererSet::sample(&scene, density, 1)?;
    let tx = Vec3::new(10.0, -60.0, 1.5);
    let centre = Vec3::new(-40.0, -70.0, 10.0);
    let visible = visible_for(&all, &scene, tx, centre)?;
    let elements: Vec<Vec3> = (0..side * side)
        .map(|i| {
            let (u, v) = ((i % side) as f32, (i / side) as f32);
            centre + Vec3::new(0.0, 0.015 * u, 0.015 * v)
        })
        .collect();
    let mut cfg = EchoConfig::new(10e9, 400e6, 1024, 2).with_window(Window::Hann)?;
    cfg.kernel_half_width_cells = 6;
    cfg.kernel_oversample = 64;
    cfg.r0_m = 60.0;
    cfg.n_bins = 512;
    let synth = EchoSynth::new(cfg)?;
    let bins = synth.config().n_bins;
    let mut fast = vec![Complex32::new(0.0, 0.0); elements.len() * bins];
    let mut plain = fast.clone();
    synth.synth_profiles(&all, &visible, tx, &elements, &mut fast)?;
    synth.synth_profiles_reference(&all, &visible, tx, &elements, &mut plain)?;
    let peak = plain.iter().map(|z| z.norm()).fold(0f32, f32::max) as f64;
    let diff = fast
        .iter()
        .zip(&plain)
        .map(|(a, b)| (a - b).norm())
        .fold(0f32, f32::max) as f64;
    let per_call = (visible.len() * elements.len()) as f64;
    let one = pool(1)?;
    let mut rows = Vec::new();
    for name in ["blocked (fast)", "plain (one path at a time)"] {
        let mut run = || {
            let r = if name.starts_with("plain") {
                synth.synth_profiles_reference(&all, &visible, tx, &elements, &mut plain)
            } else {
                synth.synth_profiles(&all, &visible, tx, &elements, &mut fast)
            };
            r.expect("validated case")
        };
        let r1 = one.install(|| rate(budget, &mut run));
        let rn = rate(budget, &mut run);
        rows.push(EchoRow {
            name,
            one_thread: r1 * per_call,
            all_threads: rn * per_call,
        });
    }
    Ok(EchoReport {
        scatterers: visible.len(),
        elements: elements.len(),
        bins,
        max_rel_difference: if peak > 0.0 { diff / peak } else { diff },
        rows,
    })
}
