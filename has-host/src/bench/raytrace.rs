//! Ray-tracing throughput: BVH build time, closest-hit and visibility (any-hit) throughput on a
//! deterministic city of ≥ 100k triangles (at the default 240 cells), with one thread and with
//! all threads.
//!
//! The scene: a gently undulating ground heightfield (`cells`² cells, two triangles each) and a
//! 16 × 16 grid of buildings (random sizes and yaws, some pitched and sawtooth roofs) from a
//! fixed seed. Closest-hit rays start 2–80 m above the ground anywhere over the city with
//! directions uniform on the lower hemisphere tilted up to 10° above the horizon; visibility
//! segments join a point 20–60 m up to a point 1.5 m above the ground. Every measurement is one
//! function returning a [`BenchRow`]; [`run`] makes the whole `has-sim bench raytrace` table.

use glam::{Vec2, Vec3};

use super::{pool, timed, BenchError, BenchRow};
use crate::shapes::{self, Building, Direction, Roof, ShapeError};
use crate::{Material, Object, Scene, SceneError};

/// The benchmark city of a raytrace run.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BenchScene {
    /// Triangles.
    pub triangles: usize,
    /// Objects (the ground and the buildings).
    pub objects: usize,
    /// Ground heightfield cells per side.
    pub cells: u32,
    /// Seed of the scene and rays.
    pub seed: u64,
}

/// The whole raytrace benchmark (`has-sim bench raytrace --json`).
#[derive(Clone, Debug, serde::Serialize)]
pub struct RaytraceReport {
    /// The scene.
    pub scene: BenchScene,
    /// The measurements, in table order.
    pub rows: Vec<BenchRow>,
}

/// SplitMix64: a small deterministic generator for the scene and the rays.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [lo, hi).
    fn uniform(&mut self, lo: f32, hi: f32) -> f32 {
        let u = (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32;
        lo + (hi - lo) * u
    }
}

/// Half extent of the generated city, metres (the city spans ±`HALF` in x and y).
pub const HALF: f32 = 480.0;

/// Buildings of the generated city (a 16 × 16 grid).
pub const BUILDINGS: usize = 256;

/// Ground height of the generated city, metres.
fn terrain(x: f32, y: f32) -> f32 {
    1.5 * (x / 57.0).sin() * (y / 43.0).cos() + 0.5 * (0.11 * x + 0.07 * y).sin()
}

/// The deterministic benchmark city: the ground heightfield of `cells`² cells, then the
/// [`BUILDINGS`] buildings, all from `seed`.
pub fn bench_city(cells: u32, seed: u64) -> Result<Vec<Object>, ShapeError> {
    let mut rng = Rng(seed);
    let mut objects = vec![shapes::heightfield(
        "terrain",
        Material::MediumDryGround,
        Vec2::splat(-HALF),
        Vec2::splat(HALF),
        (cells, cells),
        terrain,
    )?];
    let n = 16;
    let pitch = 2.0 * HALF / n as f32;
    for j in 0..n {
        for i in 0..n {
            let c = Vec2::new(
                -HALF + pitch * (i as f32 + 0.5),
                -HALF + pitch * (j as f32 + 0.5),
            );
            let roof = match rng.next_u64() % 4 {
                0 => Roof::Pitched {
                    ridge: shapes::Axis::X,
                    height: rng.uniform(2.0, 6.0),
                },
                1 => Roof::Sawtooth {
                    teeth: 3 + (rng.next_u64() % 6) as u32,
                    height: rng.uniform(1.5, 4.0),
                    facing: Direction::PosY,
                },
                _ => Roof::Flat,
            };
            let b = Building {
                // Sunk 2 m so the undulating ground (±2 m) never shows under a wall.
                base_center: Vec3::new(c.x, c.y, terrain(c.x, c.y) - 2.0),
                size: Vec3::new(
                    rng.uniform(15.0, 0.6 * pitch),
                    rng.uniform(15.0, 0.6 * pitch),
                    rng.uniform(8.0, 60.0),
                ),
                yaw_rad: rng.uniform(-0.4, 0.4),
                roof,
                bottom: false,
            };
            objects.push(shapes::building(
                format!("b{i:02}_{j:02}"),
                Material::Concrete,
                &b,
            )?);
        }
    }
    Ok(objects)
}

/// BVH build: the best of `repeats` builds of the scene; returns the last scene built and the
/// row (`count` = triangles, so `per_second` is triangles per second).
pub fn bench_build(objects: &[Object], repeats: usize) -> Result<(Scene, BenchRow), SceneError> {
    let mut best = f64::INFINITY;
    let mut scene = None;
    for _ in 0..repeats.max(1) {
        let s = Scene::new(objects.to_vec())?;
        best = best.min(s.build_time.as_secs_f64());
        scene = Some(s);
    }
    let scene = scene.expect("at least one build");
    let row = BenchRow::new(
        "BVH build (CWBVH)",
        1,
        scene.triangle_count(),
        best,
        format!("best of {repeats}, per-second = triangles/s"),
    );
    Ok((scene, row))
}

/// `n` closest-hit rays (origin, unit direction) over the city, from `seed`.
pub fn closest_rays(n: usize, seed: u64) -> Vec<(Vec3, Vec3)> {
    let mut rng = Rng(seed ^ 0xC105E57);
    (0..n)
        .map(|_| {
            let x = rng.uniform(-HALF, HALF);
            let y = rng.uniform(-HALF, HALF);
            let o = Vec3::new(x, y, terrain(x, y) + rng.uniform(2.0, 80.0));
            let az = rng.uniform(0.0, std::f32::consts::TAU);
            // Elevation from −90° to +10°, uniform in sin(elevation).
            let s = rng.uniform(-1.0, 0.17);
            let c = (1.0 - s * s).sqrt();
            (o, Vec3::new(c * az.cos(), c * az.sin(), s))
        })
        .collect()
}

/// Closest-hit throughput with `threads` workers; the note is the fraction of rays that hit.
pub fn bench_closest(
    scene: &Scene,
    rays: &[(Vec3, Vec3)],
    threads: usize,
) -> Result<BenchRow, BenchError> {
    let p = pool(threads)?;
    let (hits, secs, cpu) = timed(|| p.install(|| scene.closest_hits(rays, f32::INFINITY)));
    let hit = hits.iter().filter(|h| h.is_some()).count();
    let mut row = BenchRow::new(
        "closest hit",
        threads,
        rays.len(),
        secs,
        format!("{:.1} % hit", 100.0 * hit as f64 / rays.len().max(1) as f64),
    );
    row.cpu_seconds = cpu;
    Ok(row)
}

/// `n` visibility segments from 20–60 m up to 1.5 m above the ground, from `seed`.
pub fn visibility_segments(n: usize, seed: u64) -> Vec<(Vec3, Vec3)> {
    let mut rng = Rng(seed ^ 0x5E6);
    (0..n)
        .map(|_| {
            let (x, y) = (rng.uniform(-HALF, HALF), rng.uniform(-HALF, HALF));
            let a = Vec3::new(x, y, terrain(x, y) + rng.uniform(20.0, 60.0));
            let (u, v) = (rng.uniform(-HALF, HALF), rng.uniform(-HALF, HALF));
            let b = Vec3::new(u, v, terrain(u, v) + 1.5);
            (a, b)
        })
        .collect()
}

/// Visibility (any-hit) throughput with `threads` workers; the note is the fraction visible.
pub fn bench_visibility(
    scene: &Scene,
    segments: &[(Vec3, Vec3)],
    threads: usize,
) -> Result<BenchRow, BenchError> {
    let p = pool(threads)?;
    let (vis, secs, cpu) = timed(|| p.install(|| scene.visible_many(segments)));
    let seen = vis.iter().filter(|&&v| v).count();
    let mut row = BenchRow::new(
        "visibility (any hit)",
        threads,
        segments.len(),
        secs,
        format!(
            "{:.1} % visible",
            100.0 * seen as f64 / segments.len().max(1) as f64
        ),
    );
    row.cpu_seconds = cpu;
    Ok(row)
}

/// The whole raytrace benchmark: the city of `cells`² ground cells from `seed`, its BVH build
/// (best of 3), `rays` closest-hit rays and `rays` visibility segments with one thread and with
/// all of rayon's threads, then paths per second on `paths_scene` ([`super::paths::bench_paths`])
/// with the same thread counts.
pub fn run(
    cells: u32,
    rays: usize,
    seed: u64,
    paths_scene: &Scene,
) -> Result<RaytraceReport, BenchError> {
    let objects = bench_city(cells, seed)?;
    let (scene, build) = bench_build(&objects, 3)?;
    let all = rayon::current_num_threads();
    let mut rows = vec![build];
    let closest = closest_rays(rays, seed);
    let segs = visibility_segments(rays, seed);
    let mut threads = vec![1];
    if all > 1 {
        threads.push(all);
    }
    for &t in &threads {
        rows.push(bench_closest(&scene, &closest, t)?);
    }
    for &t in &threads {
        rows.push(bench_visibility(&scene, &segs, t)?);
    }
    rows.extend(super::paths::bench_paths(paths_scene, &threads, seed)?);
    Ok(RaytraceReport {
        scene: BenchScene {
            triangles: scene.triangle_count(),
            objects: scene.objects.len(),
            cells,
            seed,
        },
        rows,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_bench_city_has_at_least_100k_triangles_and_is_deterministic() {
        let a = bench_city(240, 1).unwrap();
        assert_eq!(a.len(), 1 + BUILDINGS);
        let n: usize = a.iter().map(|o| o.triangles.len()).sum();
        assert!(n >= 100_000, "{n}");
        let b = bench_city(240, 1).unwrap();
        assert!(a
            .iter()
            .zip(&b)
            .all(|(x, y)| x.triangles == y.triangles && x.name == y.name));
        assert_eq!(closest_rays(10, 3), closest_rays(10, 3));
        assert_eq!(visibility_segments(10, 3), visibility_segments(10, 3));
        assert_ne!(closest_rays(10, 3), closest_rays(10, 4));
    }

    #[test]
    fn small_bench_runs_and_steep_rays_inside_the_city_all_hit() {
        let objects = bench_city(16, 2).unwrap();
        let (scene, build) = bench_build(&objects, 1).unwrap();
        assert_eq!(build.count, scene.triangle_count());
        // A ray at least 45° below the horizon from ≤ 82 m up travels ≤ 82 m horizontally
        // before reaching the ground, so from ≥ 100 m inside the edge it must hit something.
        let rays: Vec<_> = closest_rays(4000, 2)
            .into_iter()
            .filter(|(o, d)| o.x.abs().max(o.y.abs()) < HALF - 100.0 && d.z < -0.7072)
            .collect();
        assert!(rays.len() > 500, "{}", rays.len());
        let row = bench_closest(&scene, &rays, 1).unwrap();
        assert_eq!(row.note, "100.0 % hit");
        let segs = visibility_segments(100, 2);
        let row = bench_visibility(&scene, &segs, 2).unwrap();
        assert_eq!(row.count, 100);
    }
}
