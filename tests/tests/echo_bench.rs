//! Throughput of direct profile synthesis (ignored by default; run with
//! `cargo test --release -p has-tests --test echo_bench -- --ignored --nocapture`).

use std::time::Instant;

use glam::Vec3;
use has_dsp::window::Window;
use has_host::echo::{visible_for, EchoConfig, EchoSynth, ScattererSet};
use has_host::{Material, Object, Scene};
use num_complex::Complex32;

/// CPU seconds (user + system) of this process so far, from /proc/self/stat (Linux; 0 elsewhere):
/// throughput per CPU-second does not depend on how busy the shared machine is.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks: f64 = f.get(11).and_then(|v| v.parse().ok()).unwrap_or(0.0)
        + f.get(12).and_then(|v| v.parse().ok()).unwrap_or(0.0);
    ticks / 100.0
}

#[test]
#[ignore]
fn profile_synthesis_throughput() {
    // A 60 m × 40 m × 12 m box building on a 100 m ground square.
    let (x0, x1, y0, y1, h) = (-30.0f32, 30.0, -20.0, 20.0, 12.0);
    let v = |x, y, z| Vec3::new(x, y, z);
    let quad = |a: Vec3, b: Vec3, c: Vec3, d: Vec3| vec![[a, b, c], [a, c, d]];
    let mut walls = Vec::new();
    walls.extend(quad(
        v(x0, y0, 0.),
        v(x1, y0, 0.),
        v(x1, y0, h),
        v(x0, y0, h),
    ));
    walls.extend(quad(
        v(x1, y0, 0.),
        v(x1, y1, 0.),
        v(x1, y1, h),
        v(x1, y0, h),
    ));
    walls.extend(quad(
        v(x1, y1, 0.),
        v(x0, y1, 0.),
        v(x0, y1, h),
        v(x1, y1, h),
    ));
    walls.extend(quad(
        v(x0, y1, 0.),
        v(x0, y0, 0.),
        v(x0, y0, h),
        v(x0, y1, h),
    ));
    walls.extend(quad(v(x0, y0, h), v(x1, y0, h), v(x1, y1, h), v(x0, y1, h)));
    let ground = quad(
        v(-50., -50., 0.),
        v(50., -50., 0.),
        v(50., 50., 0.),
        v(-50., 50., 0.),
    );
    let scene = Scene::new(vec![
        Object {
            name: "factory".into(),
            material: Material::Concrete,
            triangles: walls,
        },
        Object {
            name: "ground".into(),
            material: Material::MediumDryGround,
            triangles: ground,
        },
    ])
    .unwrap();
    let t = Instant::now();
    let set = ScattererSet::sample(&scene, 4.0, 1).unwrap();
    let t_sample = t.elapsed();
    let tx = Vec3::new(10.0, -60.0, 1.5);
    let centre = Vec3::new(-40.0, -70.0, 10.0);
    let t = Instant::now();
    let vis = visible_for(&set, &scene, tx, centre).unwrap();
    let t_vis = t.elapsed();
    let rx: Vec<Vec3> = (0..1024)
        .map(|i| centre + Vec3::new(0.0, (i % 32) as f32 * 0.03, (i / 32) as f32 * 0.015))
        .collect();
    let mut cfg = EchoConfig::new(10e9, 400e6, 2048, 1)
        .with_window(Window::Hann)
        .unwrap();
    cfg.kernel_half_width_cells = 8;
    cfg.r0_m = 60.0;
    cfg.n_bins = 512;
    let synth = EchoSynth::new(cfg).unwrap();
    let mut out = vec![Complex32::new(0.0, 0.0); rx.len() * 512];
    let t = Instant::now();
    let c0 = cpu_seconds();
    synth.synth_profiles(&set, &vis, tx, &rx, &mut out).unwrap();
    let t_syn = t.elapsed().as_secs_f64();
    let cpu = cpu_seconds() - c0;
    let updates = (vis.len() * rx.len()) as f64;
    println!(
        "scatterers {} (sampled in {:?}), visible {} ({:?} for 2 rays each), kernel {} taps, \
         truncation {:.1e}: {} profiles in {:.3} s = {:.0} profiles/s, {:.1} M scatterer-element \
         updates/s wall; {:.1} M updates per CPU-second ({:.2} CPU s)",
        set.len(),
        t_sample,
        vis.len(),
        t_vis,
        2 * synth.kernel().half_width_bins(),
        synth.kernel().truncation_error(),
        rx.len(),
        t_syn,
        rx.len() as f64 / t_syn,
        updates / t_syn / 1e6,
        updates / cpu / 1e6,
        cpu
    );
    assert!(out.iter().any(|v| v.norm() > 0.0));
}
