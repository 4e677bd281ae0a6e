//! Detection of surface voxels in one pair's image, referenced to the clutter and noise that pair
//! would image on the bare known terrain, never to the image's own peak.
//!
//! **What is known.** The operator knows the terrain (its height and material: the scenario's
//! `ground_objects`), not the buildings. [`crate::imaging::World::terrain`] holds the terrain
//! alone and an independent realisation of its scatterers (the same density and material, another
//! seed). The driver images that model through the same pair, frames, grid, back-projection and
//! noise variance as the real data, so `|I_m(v)|²` is one speckled realisation of the
//! clutter-plus-noise power voxel `v` would hold if the site were bare: the ground's own image,
//! its layover up the panel's elevation beam, the sidelobes and grating lobes of the strong ground
//! next to a vehicle's track, and the receiver noise — each through the pair's real point-spread
//! function.
//!
//! **The test.** `C(v)`, the mean of `|I_m|²` over the voxels within ± one mean resolution cell
//! (`∛(δr·δx_V·δz_R)`, [`super::sensors::pair_resolution_m`]) of `v`, estimates that power from
//! about `N = V_window / V_cell` independent looks. A voxel is detected when
//! `|I(v)|² ≥ α·C(v)` with `α = N·(pfa^{−1/N} − 1)` ([`has_dsp::cfar::mean_level_factor`]): the
//! cell-averaging CFAR factor for which exponential clutter of the predicted mean crosses the
//! threshold with probability `pfa`. A wall, a roof or any other structure not in the terrain
//! model must stand out of the bare site's clutter by that factor, wherever the pair's peak is.
//!
//! Units: powers in the image's units (`|I|²`), lengths in metres, voxels indexed `x + nx·(y +
//! ny·z)` on the fine (or coarse) lattice of the region's bounding box.

/// The effective number of independent looks of a cube of `window_voxels` voxels of edge
/// `voxel_m` over a resolution cell of volume `cell_m3`: `V_window / V_cell`, at least 1 and at
/// most the voxel count (voxels finer than the cell are correlated, coarser ones independent).
pub fn effective_looks(window_voxels: usize, voxel_m: f32, cell_m3: f32) -> f64 {
    let v = window_voxels as f64 * (voxel_m as f64).powi(3);
    (v / (cell_m3 as f64).max(1e-12)).clamp(1.0, window_voxels.max(1) as f64)
}

/// Half-width in voxels of the reference window: the mean resolution cell `cell_m` rounded to
/// whole voxels, at least one.
pub fn window_radius(cell_m: f32, voxel_m: f32) -> usize {
    ((cell_m / voxel_m).round() as usize).max(1)
}

/// The mean of `power` over the cube of half-width `radius` voxels around every voxel of a
/// `dims` lattice, counting only known voxels (`power` finite; unknown ones are NaN). A voxel
/// with no known neighbour gets NaN. Separable running sums: `O(voxels)` whatever the radius.
pub fn local_mean(power: &[f32], dims: [usize; 3], radius: usize) -> Vec<f32> {
    let n = dims[0] * dims[1] * dims[2];
    debug_assert_eq!(power.len(), n);
    let mut sum: Vec<f32> = power
        .iter()
        .map(|&p| if p.is_finite() { p } else { 0.0 })
        .collect();
    let mut cnt: Vec<f32> = power
        .iter()
        .map(|&p| if p.is_finite() { 1.0 } else { 0.0 })
        .collect();
    let strides = [1, dims[0], dims[0] * dims[1]];
    let mut prefix: Vec<f64> = Vec::new();
    for axis in 0..3 {
        let len = dims[axis];
        let stride = strides[axis];
        for buf in [&mut sum, &mut cnt] {
            for start in 0..n {
                // Lines start at the voxels whose coordinate along `axis` is 0.
                if !(start / stride).is_multiple_of(len) {
                    continue;
                }
                // Prefix sums of the line: prefix[i] = Σ_{j<i} value_j.
                prefix.clear();
                prefix.push(0.0f64);
                let mut acc = 0.0f64;
                for i in 0..len {
                    acc += buf[start + i * stride] as f64;
                    prefix.push(acc);
                }
                for i in 0..len {
                    let a = i.saturating_sub(radius);
                    let b = (i + radius + 1).min(len);
                    buf[start + i * stride] = (prefix[b] - prefix[a]) as f32;
                }
            }
        }
    }
    sum.iter()
        .zip(&cnt)
        .map(|(&s, &c)| if c > 0.0 { s / c } else { f32::NAN })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn local_mean_of_a_constant_field_is_that_constant_even_at_the_edges() {
        let dims = [5, 4, 3];
        let p = vec![2.5f32; 60];
        let m = local_mean(&p, dims, 2);
        assert!(m.iter().all(|&x| (x - 2.5).abs() < 1e-6));
    }

    #[test]
    fn local_mean_ignores_unknown_voxels_and_matches_a_direct_sum() {
        let dims = [6, 5, 4];
        let n = 120;
        let p: Vec<f32> = (0..n)
            .map(|i| {
                if i % 7 == 3 {
                    f32::NAN
                } else {
                    (i * 37 % 11) as f32
                }
            })
            .collect();
        let r = 1usize;
        let m = local_mean(&p, dims, r);
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    let (mut s, mut c) = (0.0f64, 0usize);
                    for zz in z.saturating_sub(r)..(z + r + 1).min(dims[2]) {
                        for yy in y.saturating_sub(r)..(y + r + 1).min(dims[1]) {
                            for xx in x.saturating_sub(r)..(x + r + 1).min(dims[0]) {
                                let v = p[xx + dims[0] * (yy + dims[1] * zz)];
                                if v.is_finite() {
                                    s += v as f64;
                                    c += 1;
                                }
                            }
                        }
                    }
                    let got = m[x + dims[0] * (y + dims[1] * z)];
                    assert!(
                        (got as f64 - s / c as f64).abs() < 1e-4,
                        "{got} vs {}",
                        s / c as f64
                    );
                }
            }
        }
    }

    #[test]
    fn exponential_clutter_crosses_the_cfar_threshold_at_the_design_rate() {
        // Cell under test and an n-look reference mean, both exponential of mean 1.
        use rand::SeedableRng;
        use rand_distr::{Distribution, Exp1};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let (pfa, n) = (1e-2, 8usize);
        let alpha = has_dsp::cfar::mean_level_factor(pfa, n as f64) as f32;
        let trials = 200_000;
        let mut hits = 0;
        for _ in 0..trials {
            let reference: f32 = (0..n)
                .map(|_| -> f32 { Exp1.sample(&mut rng) })
                .sum::<f32>()
                / n as f32;
            let cut: f32 = Exp1.sample(&mut rng);
            if cut >= alpha * reference {
                hits += 1;
            }
        }
        let rate = hits as f64 / trials as f64;
        // Binomial standard deviation at 200 k trials is 2.2e-4; allow 5 of them.
        assert!(
            (rate - pfa).abs() < 5.0 * (pfa * (1.0 - pfa) / trials as f64).sqrt(),
            "{rate}"
        );
    }

    #[test]
    fn effective_looks_are_bounded_by_one_and_the_voxel_count() {
        assert_eq!(effective_looks(27, 0.25, 10.0), 1.0);
        assert_eq!(effective_looks(27, 1.0, 1e-3), 27.0);
        assert!((effective_looks(125, 0.5, 1.0) - 15.625).abs() < 1e-9);
    }
}
