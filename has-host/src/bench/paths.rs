//! Paths per second of the channel-prediction tracer ([`crate::paths`]) with one base station at
//! (0, 0, 25) m (raised above whatever covers that spot) and [`UES`] UEs at seeded random street
//! positions 1.5 m above ground, order 3, default tracer settings (200 000 SBR rays). One row per
//! thread count; the time includes the candidate search (once per base station) and the tracing
//! of every UE; `count` is the number of paths found.

use std::time::Instant;

use glam::DVec3;

use super::{pool, BenchError, BenchRow};
use crate::paths::{Tracer, TracerConfig};
use crate::scene::PROBE_UP;
use crate::Scene;

/// Number of UEs of the measurement.
pub const UES: usize = 500;

/// Base-station position of the measurement, metres, unless something covers it
/// ([`bs_position`]).
pub const BS: DVec3 = DVec3::new(0.0, 0.0, 25.0);

/// [`BS`], or, where a roof or anything else lies above it (munich: 1 m under a roof, which gave
/// 0 paths), 5 m above the highest surface straight over it.
pub fn bs_position(scene: &Scene) -> DVec3 {
    let mut p = BS;
    while let Some(h) = scene.closest_hit(p.as_vec3(), PROBE_UP, 0.0, f32::INFINITY) {
        p.z = h.point.z as f64 + 5.0;
    }
    p
}

/// `n` UE positions, uniformly in the scene's extent (inset 10 m) at `height` above its lowest
/// point, outside and not under any object ([`Scene::uncovered_positions`]).
pub fn random_ues(scene: &Scene, n: usize, height: f64, seed: u64) -> Vec<DVec3> {
    let (lo, hi) = scene.bounds();
    scene.uncovered_positions(
        [lo.x as f64 + 10.0, lo.y as f64 + 10.0],
        [hi.x as f64 - 10.0, hi.y as f64 - 10.0],
        lo.z as f64 + height,
        n,
        seed,
    )
}

/// Paths per second on `scene` with each thread count of `threads`, UEs from `seed`.
pub fn bench_paths(
    scene: &Scene,
    threads: &[usize],
    seed: u64,
) -> Result<Vec<BenchRow>, BenchError> {
    let tracer = Tracer::new(scene, TracerConfig::default())?;
    let ues = random_ues(scene, UES, 1.5, seed);
    let bs = bs_position(scene);
    let mut rows = Vec::new();
    for &t in threads {
        let (candidates, prepare_s, paths, seconds) =
            pool(t)?.install(|| -> Result<_, BenchError> {
                let t0 = Instant::now();
                let cand = tracer.prepare_tx(bs)?;
                let prepare_s = t0.elapsed().as_secs_f64();
                let all = tracer.trace_many(&cand, &ues)?;
                let n: usize = all.iter().map(Vec::len).sum();
                Ok((cand.len(), prepare_s, n, t0.elapsed().as_secs_f64()))
            })?;
        rows.push(BenchRow::new(
            "paths (500 UEs, order 3)",
            t,
            paths,
            seconds,
            format!(
                "BS at ({}, {}, {}), {} UEs, {} facets, {} candidate sequences in {:.3} s, {:.0} UEs/s",
                bs.x,
                bs.y,
                bs.z,
                ues.len(),
                tracer.facets().facets.len(),
                candidates,
                prepare_s,
                ues.len() as f64 / seconds.max(1e-12)
            ),
        ));
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::axis_box;
    use crate::Material;
    use glam::Vec3;

    #[test]
    fn the_base_station_is_raised_above_a_roof_that_covers_it() {
        let open = Scene::new(vec![axis_box(
            "hut",
            Material::Concrete,
            Vec3::new(20.0, 20.0, 0.0),
            Vec3::new(30.0, 30.0, 8.0),
        )
        .unwrap()])
        .unwrap();
        assert_eq!(bs_position(&open), BS);
        let tower = Scene::new(vec![axis_box(
            "tower",
            Material::Concrete,
            Vec3::new(-5.0, -5.0, 0.0),
            Vec3::new(5.0, 5.0, 26.0),
        )
        .unwrap()])
        .unwrap();
        let p = bs_position(&tower);
        assert_eq!((p.x, p.y), (0.0, 0.0));
        assert!((p.z - 31.0).abs() < 1e-4, "{p}");
    }
}
