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
//! **The test.** `C(v)`, the mean of `|I_m|²` over the voxels of `v`'s own horizontal layer within
//! ± two mean resolution cells (`∛(δr·δx_V·δz_R)`, [`super::sensors::pair_resolution_m`]) of `v`
//! ([`layer_window`]), estimates that power from about `N = A_window / (δr·δx_V)` independent
//! looks. The window stays in the layer because the terrain's image is stationary along the
//! ground but not upwards: there it follows the panel's elevation beam down to the terrain, and a
//! window reaching up from the region's lowest layer under-estimated that layer's clutter by
//! 1.5–2 × (the ground's strong discrete echoes then crossed the threshold far from any building:
//! the cloud's farthest points). `P(v) = Σ_tx Σ_rx (|s(r(v))|² − |m(r(v))|²)`, the
//! back-projection with no phase of the power the data's profiles `s` hold beyond the terrain
//! model's `m`, is what `|I(v)|²` would hold if every echo in the range cells through `v` that the
//! terrain does not explain added incoherently: the floor of a building's sidelobes. The terrain's
//! own share is left out of `P` because `C` already holds it (its focused image at `v` is its
//! sidelobes there); counted in both, the ground's floor was doubled, and a larger simulated
//! ground hid roofs (factory_site, quick: F 90.1 → 84.7 when the ground grew from the region's
//! box to the disc around it). A voxel is detected when `|I(v)|² ≥ α·(C(v) + P(v))` with
//! `α = N·(pfa^{−1/N} − 1)` ([`has_dsp::cfar::mean_level_factor`]): the cell-averaging CFAR
//! factor for which exponential clutter of the predicted mean crosses the threshold with
//! probability `pfa`. A wall, a roof or any other structure not in the terrain model must stand out
//! of the bare site's clutter by that factor, wherever the pair's peak is.
//!
//! **Receive coherence** (`imaging.coherence_test`). A pair has two apertures: the transmit
//! positions (a vehicle's or UAV's track) and the base station's receive array. A linear track
//! focuses a scatterer onto a whole ring (its range and its cone angle about the track), and only
//! the array picks the place on the ring; where the array's sidelobe lies on that ring, the
//! track's full coherent gain lifts the sidelobe over `P` (measured: the UAV pair of the suite's
//! office imaged a copy of the gable roof 20 m away, on the roof's range and cone, 10–40° off in
//! the array's view: a quarter of that pair's points). `R(v) = Σ_rx |Σ_tx s·e^{jφ}|²`, each
//! element's image focused by the track alone, summed in power, is what `|I(v)|²` would hold if
//! the echoes were coherent across the track but not across the array: then `|I|²` is exponential
//! of mean `R`, while a scatterer at `v` gives `|I|² = N_rx·R` (all elements in phase). The test
//! `|I(v)|² ≥ ln(1/pfa)·R(v)` (known mean, one look) rejects the sidelobe at the design `pfa`.
//! The driver gets `R` at no extra back-projection: by reciprocity one element with every
//! transmit position is a has-dsp snapshot, and
//! [`has_dsp::bp::Backprojector::push_snapshot_with_power`] sums each snapshot's own power
//! (the data's frames are held, element-major, for this). The transposed test — each
//! snapshot's array-focused power against `P`, for a sidelobe of the track that the array
//! focuses — was measured and dropped: the thinned array alone has too little gain against the
//! power of a whole range bin, so walls failed it as well (suite office, quick: 238 points).
//!
//! Units: powers in the image's units (`|I|²`), lengths in metres, voxels indexed `x + nx·(y +
//! ny·z)` on the fine (or coarse) lattice of the region's bounding box.

/// The detection test of one voxel (module docs): image power `i2 = |I|²`, bare-terrain local
/// mean `c = C`, incoherent power `p = P` and, with the coherence test, the track-focused power
/// `r = R`; `alpha` the mean-level factor of the window's looks, `beta = ln(1/pfa)`.
pub fn detected(i2: f32, c: f32, p: f32, r: Option<f32>, alpha: f32, beta: f32) -> bool {
    i2 >= alpha * (c + p.max(0.0)) && r.is_none_or(|r| i2 >= beta * r)
}

/// The grating-lobe test of one detected voxel (`imaging.alias_test`,
/// [`crate::sensors::PlanarArray::grating_aliases`]): `true` when the image's peak within the
/// box of half-extents `half` (metres, at least one voxel of edge `voxel_m` on each axis) around
/// any of the voxel's `aliases` (each `(alias, half)`) is stronger than `own`, the image's peak
/// within the voxel's own box (at least the voxel's `|I|`) — the pair cannot tell the two
/// apart, and the weaker is the lobe. `lookup` gives `|I|` at a position, or `None` where
/// nothing was imaged (an alias there decides nothing).
///
/// The box is the pair's resolution cell at the alias ([`alias_window_m`],
/// [`crate::imaging::driver::alias_boxes`]), not one voxel: the alias is exact only for a
/// far-field panel and one transmit position, and the suite's panels (1 m wide at 40–75 m, far
/// field `2D²/λ` ≈ 67 m) see the buildings in their Fresnel zone, where the lobe is displaced and
/// defocused by up to its own width. Peak is compared with peak, each over its cell ([`cell_peak`]):
/// a surface's voxels are not all as strong as its peak, and the box at its alias holds the
/// defocused lobe of that peak — stronger than the surface's weaker voxels, weaker than the peak.
/// Compared with the voxel itself, a hall's lobes outside the region dropped 17 of a hall's 30
/// detections (has-host/tests/alias_outside.rs).
pub fn alias_is_stronger(
    aliases: &[(glam::Vec3, glam::Vec3)],
    own: f32,
    voxel_m: f32,
    lookup: impl Fn(glam::Vec3) -> Option<f32>,
) -> bool {
    aliases
        .iter()
        .any(|&(q, half_m)| cell_peak(q, half_m, voxel_m, &lookup).is_some_and(|b| b > own))
}

/// The largest `|I|` that `lookup` gives on the voxel lattice (edge `voxel_m`) within
/// half-extents `half_m` of `centre`, at least one voxel each way; `None` where nothing there
/// was imaged.
pub fn cell_peak(
    centre: glam::Vec3,
    half_m: glam::Vec3,
    voxel_m: f32,
    lookup: impl Fn(glam::Vec3) -> Option<f32>,
) -> Option<f32> {
    let n = |h: f32| ((h / voxel_m).round() as i32).max(1);
    let (nx, ny, nz) = (n(half_m.x), n(half_m.y), n(half_m.z));
    let mut peak: Option<f32> = None;
    for k in -nz..=nz {
        for j in -ny..=ny {
            for i in -nx..=nx {
                let o = glam::Vec3::new(i as f32, j as f32, k as f32) * voxel_m;
                if let Some(b) = lookup(centre + o) {
                    peak = Some(peak.map_or(b, |m| m.max(b)));
                }
            }
        }
    }
    peak
}

/// Half-extents of the grating-lobe test's box ([`alias_is_stronger`]) from the pair's
/// resolution at the voxel ([`crate::sensors::pair_resolution_m`]: range, the virtual
/// aperture's and the panel's horizontal cross-ranges, the panel's vertical cross-range): half
/// the coarsest horizontal extent on x and y, half the vertical one on z — the cell within which
/// the pair cannot separate two echoes.
pub fn alias_window_m(range_m: f32, xv_m: f32, xh_m: f32, xz_m: f32) -> glam::Vec3 {
    let h = 0.5 * range_m.max(xv_m).max(xh_m);
    glam::Vec3::new(h, h, 0.5 * xz_m)
}

/// The direct-path zone of a pair, metres of bistatic excess: voxels whose bistatic path
/// `|p − tx| + |p − rx|` exceeds the baseline `|tx − rx|` by less than this are not imaged
/// (`imaging.direct_path_guard`). It is the main-lobe half-width of the range profile
/// (`main_lobe_cells · c/B`; Hann: 2 cells, 1.5 m at 400 MHz), for two reasons that hold on any
/// site. A real receiver gets the transmitter's direct signal at zero excess, and its main lobe
/// fills these bins (the simulator leaves the direct signal out; a pair of the field does not
/// have that choice). And there the iso-range ellipsoids collapse onto the baseline — the
/// bistatic angle nears 180°, the range gradient `2 cos(β/2)` nears zero — so the strongest
/// clutter of the pair, the ground next to the transmitter (whose excess is also small), is
/// spread along a cigar around the baseline that the panel's beam cannot cut: measured on the
/// street site's default preset, the BS4-V4 pair imaged a 15 m line of points 13–20 m from any
/// building at excess 0.4–0.9 m (0.38 of the cloud's accuracy term), and no pair of the suite's
/// default clouds had a point within 1.5 m of a true surface in its zone.
pub fn direct_path_guard_m(main_lobe_cells: f64, bandwidth_hz: f64) -> f32 {
    (main_lobe_cells * has_dsp::geometry::C_M_PER_S / bandwidth_hz) as f32
}

/// Peak sidelobe ratio of a uniformly weighted aperture, dB: the first sidelobe of
/// `sin(πNx)/(N sin(πx))` for large N (the panels and the tracks are back-projected unweighted).
pub const UNIFORM_APERTURE_PSLR_DB: f32 = 13.26;

/// The ground beneath one end of a pair, as the pair's range profiles see it
/// (`imaging.nadir_guard`): the bistatic excess `|g − end| + |g − other| − |end − other|` the
/// ground takes within one end-height `h` of the end's nadir `n` (the disc where the end's leg is
/// within √2 of its height, the echo within 3 dB of the nadir's), widened on both sides by
/// `guard_m` (the range main lobe's half-width, as [`direct_path_guard_m`]); and the nadir's leg
/// product `h·|n − other|`, which sets its echo's amplitude (`∝ 1/(r_tx·r_rx)`).
///
/// A terminal 1.5 m above the ground has that ground 1.5–2.1 m away: each of its scatterers
/// echoes 20·log(R/h) dB stronger than a like one at R, and the disc fills a band of excess
/// (0–5.6 m with the main lobe on the suite's vehicle pairs) that also holds every voxel on those
/// ellipsoids, out to tens of metres from the terminal. The range cell cannot separate the two;
/// only the panel's and the track's angles can, down to their sidelobes. A voxel in the band
/// whose leg product exceeds the nadir's by the peak sidelobe ratio of a uniform aperture
/// ([`UNIFORM_APERTURE_PSLR_DB`]) — where the nadir's echo through that sidelobe is as strong as
/// a like scatterer at the voxel — is not imaged ([`NadirBand::covers`]). Measured on the factory
/// site at the quick preset, turned by 0° and 90° with a polygon region: clusters of 17 and 14
/// points more than 3 m from a true surface (one pair each, 12–17 m from the terminal on open
/// ground, excess 1.8–4 m) lay in their vehicle's band at 5.2–7.2 × the nadir's product; no
/// point within 3 m of the truth of any pair did (in the band at most 1 ×).
///
/// A high end (a base station, a UAV) has its nadir about as far as what it images: its band
/// then covers nothing closer than 4.6 × the nadir's leg product.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NadirBand {
    /// The end above the ground.
    pub end: glam::Vec3,
    /// The pair's other end.
    pub other: glam::Vec3,
    /// Band of bistatic excess, metres (main-lobe guard included).
    pub excess_m: [f32; 2],
    /// The nadir's leg product `h·|n − other|`, m².
    pub nadir_product_m2: f32,
    /// The leg product above which a voxel in the band is covered: the nadir's times the
    /// uniform aperture's peak sidelobe ratio, m².
    pub covered_product_m2: f32,
}

impl NadirBand {
    /// The band of `end` over the ground point `nadir` below it (flat around it), for the pair
    /// whose other end is `other`; `None` when the end is not above its nadir.
    pub fn new(
        end: glam::Vec3,
        other: glam::Vec3,
        nadir: glam::Vec3,
        guard_m: f32,
    ) -> Option<Self> {
        let h = end.z - nadir.z;
        if h.is_nan() || h <= 0.0 || !guard_m.is_finite() {
            return None;
        }
        let baseline = end.distance(other);
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        // Rings of the disc ρ ≤ h, 32 azimuths each; the excess varies by at most
        // ρ·(2π/32) ≈ 0.2·h between two azimuths (its gradient is at most 2 in the plane).
        const AZIMUTHS: usize = 32;
        for ring in 0..=4 {
            let rho = h * ring as f32 / 4.0;
            let n = if ring == 0 { 1 } else { AZIMUTHS };
            for k in 0..n {
                let phi = std::f32::consts::TAU * k as f32 / n as f32;
                let g = nadir + glam::Vec3::new(rho * phi.cos(), rho * phi.sin(), 0.0);
                let e = crate::bistatic_range(g, end, other) - baseline;
                lo = lo.min(e);
                hi = hi.max(e);
            }
        }
        let nadir_product_m2 = h * nadir.distance(other);
        Some(NadirBand {
            end,
            other,
            excess_m: [lo - guard_m, hi + guard_m],
            nadir_product_m2,
            covered_product_m2: 10f32.powf(UNIFORM_APERTURE_PSLR_DB / 20.0) * nadir_product_m2,
        })
    }

    /// Whether `p` lies in the band with a leg product `|p − end|·|p − other|` above the nadir's
    /// by the uniform aperture's peak sidelobe ratio (type docs).
    pub fn covers(&self, p: glam::Vec3) -> bool {
        let (a, b) = (p.distance(self.end), p.distance(self.other));
        let e = a + b - self.end.distance(self.other);
        e >= self.excess_m[0] && e <= self.excess_m[1] && a * b >= self.covered_product_m2
    }
}

/// The per-voxel false-alarm probability of an image for `false_alarms` expected false
/// detections: that count over the independent resolution cells of `voxels` voxels of edge
/// `voxel_m` (cells of `cell_m3`, at least one), at most `cap`. A region twice as large halves it,
/// so the count of false points per image stays as stated.
pub fn image_false_alarm_probability(
    false_alarms: f64,
    voxels: usize,
    voxel_m: f32,
    cell_m3: f32,
    cap: f64,
) -> f64 {
    let cells = (voxels as f64 * (voxel_m as f64).powi(3) / (cell_m3 as f64).max(1e-12)).max(1.0);
    (false_alarms / cells).min(cap)
}

/// The receive-coherence factor for a false-alarm probability: `ln(1/pfa)`, the threshold over
/// its known mean that an exponential variable crosses with probability `pfa`.
pub fn coherence_factor(pfa: f64) -> f32 {
    (1.0 / pfa).ln() as f32
}

/// The effective number of independent looks of a window of `window_voxels` voxels, each holding
/// `looks_per_voxel` resolution cells ([`layer_looks_per_voxel`]): at least 1 and at most the
/// voxel count (voxels finer than the cell are correlated, coarser ones independent).
pub fn effective_looks(window_voxels: usize, looks_per_voxel: f64) -> f64 {
    (window_voxels as f64 * looks_per_voxel).clamp(1.0, window_voxels.max(1) as f64)
}

/// Half-widths in voxels of the reference window: the voxel's own horizontal layer, two mean
/// resolution cells `cell_m` on either side (rounded to whole voxels, at least one), one voxel
/// thick. The terrain's image is stationary along the ground over a few cells but not up the
/// panel's elevation beam: there it falls from the terrain by the beam's shape, so a window that
/// reached up from the region's lowest layer averaged weaker layers into that layer's reference
/// (measured on the suite's factory_site, quick: the bare-terrain image's power in the lowest layer
/// was 1.5–2.1 × the mean of a ±1-cell cube around it, 0.94–1.04 × the mean of its layer).
pub fn layer_window(cell_m: f32, voxel_m: f32) -> [usize; 3] {
    let w = ((2.0 * cell_m / voxel_m).round() as usize).max(1);
    [w, w, 0]
}

/// Independent looks per voxel of a layer window: the voxel's area `voxel_m²` over the
/// resolution cell's horizontal cross-section `cell_m3 / max(cell_vertical_m, voxel_m)` (a cell
/// taller than the voxel is cut by the layer; one shorter fits in it), at most 1.
pub fn layer_looks_per_voxel(voxel_m: f32, cell_m3: f32, cell_vertical_m: f32) -> f64 {
    let v = voxel_m as f64;
    let section = cell_m3 as f64 / (cell_vertical_m as f64).max(v);
    (v * v / section.max(1e-12)).min(1.0)
}

/// The threshold factor for spiky clutter: where the bare-terrain model's power is not
/// exponential (few terrain scatterers per resolution cell — next to a terminal's track the
/// track resolves the ground into centimetre cells, each holding one scatterer or none), a mean
/// level times the exponential factor is crossed by single strong ground echoes far more often
/// than `pfa`. The clutter is then modelled as generalised-Pareto (exponential speckle on an
/// inverse-gamma texture of shape `ν`): `P(I > t) = (1 + t/((ν − 1)μ))^{−ν}`, so the factor over
/// the mean `μ` is `(ν − 1)(pfa^{−1/ν} − 1)` (`ν → ∞`: `−ln pfa`, the exponential case). Its
/// normalised second moment is `κ = ⟨I²⟩/⟨I⟩² = 2(ν − 1)/(ν − 2)` (2 for exponential power), so
/// `ν = 2(κ − 1)/(κ − 2)`. `kappa` is measured on the model over the reference window, from
/// `looks` independent looks; an exponential field's sample `κ` scatters by about
/// `√(20/looks)` (`Var(I²) = 20μ⁴`), so only the excess beyond two such deviations counts as
/// texture. Returns 0 where the window is consistent with exponential clutter (the mean-level
/// factor then applies alone).
pub fn pareto_factor(kappa: f64, looks: f64, pfa: f64) -> f64 {
    let k = kappa - 2.0 * (20.0 / looks.max(1.0)).sqrt();
    if !k.is_finite() || k <= 2.0 {
        return 0.0;
    }
    let nu = 2.0 * (k - 1.0) / (k - 2.0);
    (nu - 1.0) * (pfa.powf(-1.0 / nu) - 1.0)
}

/// The reference of every voxel: the mean of the known voxels around it and how many there were.
#[derive(Clone, Debug)]
pub struct LocalMean {
    /// Mean power (NaN where no known voxel is in the window).
    pub mean: Vec<f32>,
    /// Known voxels in the window (the window is cut by the lattice's faces and by unknown
    /// voxels: fewer looks, a larger factor, [`CfarFactors`]).
    pub count: Vec<f32>,
}

/// The mean of `power` over the box around every voxel of a
/// `dims` lattice (half-width `radius[axis]` along each axis), counting only known voxels (`power` finite; unknown ones are NaN). A voxel
/// with no known neighbour gets NaN. Separable running sums: `O(voxels)` whatever the radius.
pub fn local_mean(power: &[f32], dims: [usize; 3], radius: [usize; 3]) -> LocalMean {
    local_mean_of(power.to_vec(), dims, radius)
}

/// [`local_mean`] of a lattice the caller no longer needs: its buffer becomes the mean's (one
/// lattice-sized buffer less at the peak).
pub fn local_mean_of(power: Vec<f32>, dims: [usize; 3], radius: [usize; 3]) -> LocalMean {
    let n = dims[0] * dims[1] * dims[2];
    debug_assert_eq!(power.len(), n);
    let mut cnt: Vec<f32> = power
        .iter()
        .map(|&p| if p.is_finite() { 1.0 } else { 0.0 })
        .collect();
    let mut sum = power;
    sum.iter_mut().for_each(|p| {
        if !p.is_finite() {
            *p = 0.0
        }
    });
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
                    let a = i.saturating_sub(radius[axis]);
                    let b = (i + radius[axis] + 1).min(len);
                    buf[start + i * stride] = (prefix[b] - prefix[a]) as f32;
                }
            }
        }
    }
    for (s, &c) in sum.iter_mut().zip(&cnt) {
        *s = if c > 0.0 { *s / c } else { f32::NAN };
    }
    LocalMean {
        mean: sum,
        count: cnt,
    }
}

/// Mean-level factors `α` of a reference window, by how many of its voxels are known: a window
/// cut by the region's sides and corners or by unimaged voxels averages fewer looks, so its mean
/// fluctuates more and needs a larger factor for the same `pfa` (a corner's layer window holds
/// 1/4 of the voxels).
#[derive(Clone, Debug)]
pub struct CfarFactors {
    alpha: Vec<f32>,
}

impl CfarFactors {
    /// Factors at `pfa` for every count of known voxels up to `window_voxels`, each voxel worth
    /// `looks_per_voxel` independent looks ([`effective_looks`]).
    pub fn new(pfa: f64, window_voxels: usize, looks_per_voxel: f64) -> Self {
        let alpha = (0..=window_voxels)
            .map(|k| {
                let looks = effective_looks(k.max(1), looks_per_voxel);
                has_dsp::cfar::mean_level_factor(pfa, looks) as f32
            })
            .collect();
        Self { alpha }
    }

    /// The factor for a window of `count` known voxels (clamped to the window's size).
    pub fn alpha(&self, count: f32) -> f32 {
        let k = (count.max(1.0) as usize).min(self.alpha.len() - 1);
        self.alpha[k]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spiky_clutter_needs_a_higher_threshold_and_exponential_clutter_none() {
        let pfa = 1e-5;
        // Exponential power: κ = 2, nothing to add; nor for a κ within the sampling scatter.
        assert_eq!(pareto_factor(2.0, 100.0, pfa), 0.0);
        assert_eq!(pareto_factor(2.8, 100.0, pfa), 0.0);
        assert_eq!(pareto_factor(f64::NAN, 100.0, pfa), 0.0);
        // A texture of shape ν has κ = 2(ν − 1)/(ν − 2); its factor is (ν − 1)(pfa^(−1/ν) − 1),
        // which a direct tail computation confirms: (1 + α/(ν − 1))^(−ν) = pfa.
        let looks = f64::INFINITY; // no sampling allowance
        for nu in [2.5f64, 4.0, 10.0] {
            let kappa = 2.0 * (nu - 1.0) / (nu - 2.0);
            let a = pareto_factor(kappa, looks, pfa);
            let tail = (1.0 + a / (nu - 1.0)).powf(-nu);
            assert!((tail / pfa - 1.0).abs() < 1e-6, "ν {nu}: tail {tail}");
            assert!(
                a > -pfa.ln(),
                "ν {nu}: {a} not above the exponential factor"
            );
        }
        // Spikier clutter, higher factor.
        assert!(pareto_factor(10.0, looks, pfa) > pareto_factor(4.0, looks, pfa));
    }

    #[test]
    fn local_mean_of_a_constant_field_is_that_constant_even_at_the_edges() {
        let dims = [5, 4, 3];
        let p = vec![2.5f32; 60];
        let m = local_mean(&p, dims, [2; 3]).mean;
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
        let LocalMean { mean: m, count } = local_mean(&p, dims, [r; 3]);
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
                    assert_eq!(count[x + dims[0] * (y + dims[1] * z)], c as f32);
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

    /// Images of one point scatterer through a linear transmit track (24 positions, 3 m along x)
    /// and an 8 × 8 half-wavelength receive array 36 m away: `(|I|², R)` at the scatterer's voxel and at a voxel
    /// on the same range and the same cone angle about the track, 90° round the track axis
    /// (the track alone cannot tell them apart; the array can).
    fn scatterer_and_track_ambiguity() -> ([f32; 2], [f32; 2], usize) {
        use glam::Vec3;
        use has_dsp::bp::{
            add_point_echo, AccF32, Backprojector, BpConfig, Interp, PhaseEval, Snapshot, VoxelGrid,
        };
        use num_complex::Complex;
        let (lambda, dr, bins) = (0.03f32, 0.05f32, 2400usize);
        let target = Vec3::new(0.0, 10.0, 0.0);
        // The point with the target's distance from the track axis (x), rotated 90° about it.
        let ghost = Vec3::new(0.0, 0.0, 10.0);
        let tx: Vec<Vec3> = (0..24)
            .map(|k| Vec3::new(-1.5 + 3.0 * k as f32 / 23.0, 0.0, 0.0))
            .collect();
        // The array is equidistant from target and ghost, so both share its ranges too.
        let rx: Vec<Vec3> = (0..64)
            .map(|k| Vec3::new(0.015 * (k % 8) as f32, 30.0, 30.0 + 0.015 * (k / 8) as f32))
            .collect();
        let grid = |p: Vec3| VoxelGrid {
            origin: p,
            spacing: Vec3::splat(0.1),
            dims: [1, 1, 1],
        };
        let mut out = [[0f32; 2]; 2];
        for (o, p) in out.iter_mut().zip([target, ghost]) {
            let bp = Backprojector::new(BpConfig {
                grid: grid(p),
                wavelength_m: lambda,
                r0_m: 0.0,
                dr_m: dr,
                interp: Interp::Linear,
                phase: PhaseEval::Libm,
            })
            .unwrap();
            let (mut img, mut r) = ([Complex::new(0.0f32, 0.0)], [0f32]);
            let mut acc = AccF32::new(&bp, &mut img).unwrap();
            // Element-major: one receive element and every transmit position per snapshot.
            for &a in &rx {
                let mut profiles = vec![Complex::new(0.0f32, 0.0); tx.len() * bins];
                for (&t, prof) in tx.iter().zip(profiles.chunks_exact_mut(bins)) {
                    let range = crate::bistatic_range(target, t, a) as f64;
                    add_point_echo(
                        prof,
                        0.0,
                        dr as f64,
                        lambda as f64,
                        0.375,
                        range,
                        1.0.into(),
                    )
                    .unwrap();
                }
                let local: Vec<Vec3> = tx.iter().map(|&t| t - p).collect();
                let snap = Snapshot {
                    tx: a - p,
                    rx: &local,
                    profiles: &profiles,
                    profile_len: bins,
                };
                bp.push_snapshot_with_power(&mut acc, &mut r, &snap)
                    .unwrap();
            }
            *o = [img[0].norm_sqr(), r[0]];
        }
        (out[0], out[1], rx.len())
    }

    #[test]
    fn a_scatterer_is_coherent_across_the_array_and_its_track_ambiguity_is_not() {
        let ([i_t, r_t], [i_g, r_g], n_rx) = scatterer_and_track_ambiguity();
        let beta = coherence_factor(1e-4);
        // At the scatterer every element is in phase: |I|² = N_rx·R (linear interpolation of the
        // pulse loses a little of both alike).
        assert!(
            (i_t / r_t - n_rx as f32).abs() < 0.05 * n_rx as f32,
            "{}",
            i_t / r_t
        );
        assert!(i_t >= beta * r_t);
        // On the track's ambiguity the track focuses just as well (R as large), the array does not.
        assert!(r_g > 0.5 * r_t, "R {r_g} vs {r_t}");
        assert!(i_g < beta * r_g, "|I|²/R {}", i_g / r_g);
        // Without the coherence test both pass the incoherent-floor test alone.
        // P = R/N_tx at the scatterer (each element's track focus holds its 24 positions in
        // phase), the same P at the ghost (same ranges).
        let p = r_t / 24.0;
        assert!(detected(i_t, 0.0, p, None, 10.0, beta));
        assert!(detected(i_g, 0.0, p, None, 10.0, beta));
        assert!(!detected(i_g, 0.0, p, Some(r_g), 10.0, beta));
        assert!(detected(i_t, 0.0, p, Some(r_t), 10.0, beta));
    }

    #[test]
    fn a_voxel_weaker_than_its_grating_alias_is_the_lobe() {
        use glam::Vec3;
        let alias = Vec3::new(10.0, 0.0, 5.0);
        // One strong echo half a voxel off the alias (the alias is approximate); nothing else.
        let image = |p: Vec3| -> Option<f32> {
            if p.distance(alias + Vec3::new(0.5, 0.0, 0.0)) < 0.1 {
                Some(4.0)
            } else if p.x.abs() < 100.0 {
                Some(0.0)
            } else {
                None
            }
        };
        let one = Vec3::splat(0.5);
        assert!(alias_is_stronger(&[(alias, one)], 3.0, 0.5, image));
        // The true echo is the stronger one: it stays.
        assert!(!alias_is_stronger(&[(alias, one)], 5.0, 0.5, image));
        // Equal strength cannot be told apart: both stay.
        assert!(!alias_is_stronger(&[(alias, one)], 4.0, 0.5, image));
        // No alias (a λ/2 panel), or an alias nowhere imaged: nothing to compare.
        assert!(!alias_is_stronger(&[], 0.1, 0.5, image));
        assert!(!alias_is_stronger(
            &[(Vec3::new(500.0, 0.0, 0.0), one)],
            0.1,
            0.5,
            image
        ));
        // An echo 2 m below the alias (a lobe displaced in the panel's Fresnel zone) is outside
        // a one-voxel box and inside a box of the pair's 4.4 m vertical cell.
        let low = |p: Vec3| -> Option<f32> {
            (p.distance(alias - Vec3::new(0.0, 0.0, 2.0)) < 0.1).then_some(4.0)
        };
        assert!(!alias_is_stronger(&[(alias, one)], 3.0, 0.5, low));
        let cell = alias_window_m(0.4, 0.2, 1.8, 4.4);
        assert!(alias_is_stronger(&[(alias, cell)], 3.0, 0.5, low));
        assert!(!alias_is_stronger(&[(alias, cell)], 5.0, 0.5, low));
    }

    #[test]
    fn the_ground_under_a_low_terminal_hides_its_band_and_a_high_ones_nothing_below_it() {
        use glam::Vec3;
        // BS3 and V3 of the factory site (quick ghost at (20.4, 28.9, 0.8), excess ≈ 2 m).
        let (bs, v) = (Vec3::new(48.0, 42.0, 18.0), Vec3::new(6.5, 27.0, 1.5));
        let band = NadirBand::new(v, bs, Vec3::new(6.5, 27.0, 0.0), 1.5).unwrap();
        // The nadir itself: excess h + (|n − bs| − |v − bs|); the band reaches past it.
        let e_nadir = 1.5 + Vec3::new(6.5, 27.0, 0.0).distance(bs) - v.distance(bs);
        assert!(band.excess_m[0] < e_nadir - 1.5 && band.excess_m[1] > e_nadir + 1.5);
        assert!(band.covers(Vec3::new(20.4, 28.9, 0.8)), "{band:?}");
        // A wall of the hall (y = 12) the pair images, far outside the band.
        assert!(!band.covers(Vec3::new(10.0, 12.0, 4.0)));
        // The disc's own ground is nearer than itself: not covered.
        assert!(!band.covers(Vec3::new(6.5, 27.0, 0.0)));
        // A UAV 40 m up: the roof under it (8 m) is nearer to both ends than its nadir's ground.
        let (bs1, uav) = (Vec3::new(-45.0, -40.0, 20.0), Vec3::new(0.0, -6.0, 40.0));
        let high = NadirBand::new(uav, bs1, Vec3::new(0.0, -6.0, 0.0), 1.5).unwrap();
        for x in [-20.0f32, -10.0, 0.0, 10.0, 20.0] {
            for y in [-12.0f32, 0.0, 12.0] {
                assert!(
                    !high.covers(Vec3::new(x, y, 8.0)),
                    "roof point ({x}, {y}) covered"
                );
            }
        }
        // The base station's own band (20 m up) covers none of the hall it images.
        let bs_band = NadirBand::new(bs, v, Vec3::new(48.0, 42.0, 0.0), 1.5).unwrap();
        for x in [-20.0f32, 0.0, 20.0] {
            for z in [1.0f32, 4.0, 8.0] {
                assert!(
                    !bs_band.covers(Vec3::new(x, 12.0, z)),
                    "wall point ({x}, 12, {z})"
                );
            }
        }
        // An end at or below its nadir has no band.
        assert!(NadirBand::new(v, bs, Vec3::new(6.5, 27.0, 2.0), 1.5).is_none());
    }

    #[test]
    fn the_direct_path_zone_is_the_ellipsoid_one_main_lobe_beyond_the_baseline() {
        use glam::Vec3;
        // Hann at 400 MHz: two cells of c/B = 0.749 m.
        let g = direct_path_guard_m(2.0, 400e6);
        assert!((g - 1.499).abs() < 1e-3, "{g}");
        // A 47 m baseline: the zone's half-width at its middle is √((L + g)² − L²)/2 ≈ 5.98 m.
        let (tx, rx) = (Vec3::ZERO, Vec3::new(47.0, 0.0, 0.0));
        let excess = |p: Vec3| has_dsp::geometry::bistatic_range(p, tx, rx) - tx.distance(rx);
        assert!(excess(Vec3::new(23.5, 5.9, 0.0)) < g);
        assert!(excess(Vec3::new(23.5, 6.1, 0.0)) > g);
        // Near an end the zone is narrow: 2 m beside the transmitter is outside it.
        assert!(excess(Vec3::new(0.0, 2.0, 0.0)) > g);
    }

    #[test]
    fn coherence_factor_is_the_exponential_tail() {
        assert!((coherence_factor(1e-4) - 9.2103).abs() < 1e-3);
        assert!((coherence_factor((-1.0f64).exp()) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn a_cut_window_gets_the_factor_of_its_own_looks() {
        // Exponential clutter of mean 1 referenced by the mean of the k known voxels of a window:
        // with the factor for k looks it crosses at the design rate; with the full window's
        // factor (what a face or corner voxel got before) far more often.
        use rand::SeedableRng;
        use rand_distr::{Distribution, Exp1};
        let pfa = 1e-2;
        let f = CfarFactors::new(pfa, 27, 1.0);
        assert!(f.alpha(8.0) > f.alpha(18.0) && f.alpha(18.0) > f.alpha(27.0));
        assert_eq!(f.alpha(0.0), f.alpha(1.0));
        assert_eq!(f.alpha(1e9), f.alpha(27.0));
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let trials = 200_000;
        let (mut own, mut full) = (0, 0);
        for _ in 0..trials {
            // A corner voxel: 8 of the 27 window voxels known, independent looks.
            let reference: f32 = (0..8)
                .map(|_| -> f32 { Exp1.sample(&mut rng) })
                .sum::<f32>()
                / 8.0;
            let cut: f32 = Exp1.sample(&mut rng);
            own += (cut >= f.alpha(8.0) * reference) as usize;
            full += (cut >= f.alpha(27.0) * reference) as usize;
        }
        let (own, full) = (own as f64 / trials as f64, full as f64 / trials as f64);
        let sd = (pfa * (1.0 - pfa) / trials as f64).sqrt();
        assert!((own - pfa).abs() < 5.0 * sd, "{own}");
        assert!(full > 1.5 * pfa, "{full}");
    }

    #[test]
    fn the_layer_reference_holds_the_false_alarm_rate_over_the_terrains_elevation_lobe() {
        // Clutter whose mean falls by 4× per layer up from the terrain (the ground's image up the
        // panel's elevation beam), homogeneous along the ground; the reference is an independent
        // realisation (the terrain model). In the lowest layer the layer window's mean crosses at
        // the design rate; a cube reaching up into weaker layers under-estimates the clutter and
        // crosses far more often.
        use rand::SeedableRng;
        use rand_distr::{Distribution, Exp1};
        let (pfa, dims) = (1e-2, [48usize, 48, 4]);
        let mean = |z: usize| 0.25f32.powi(z as i32);
        let n = dims.iter().product::<usize>();
        let layer = [2, 2, 0];
        let cube = [1, 1, 1];
        let f_layer = CfarFactors::new(pfa, 25, 1.0);
        let f_cube = CfarFactors::new(pfa, 27, 1.0);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let (mut hits_layer, mut hits_cube, mut trials) = (0usize, 0usize, 0usize);
        for _ in 0..24 {
            let mut draw = || -> Vec<f32> {
                (0..n)
                    .map(|i| {
                        let e: f32 = Exp1.sample(&mut rng);
                        e * mean(i / (dims[0] * dims[1]))
                    })
                    .collect()
            };
            let (data, model) = (draw(), draw());
            let ml = local_mean(&model, dims, layer);
            let mc = local_mean(&model, dims, cube);
            for (i, &d) in data.iter().enumerate().take(dims[0] * dims[1]) {
                trials += 1;
                hits_layer += (d >= f_layer.alpha(ml.count[i]) * ml.mean[i]) as usize;
                hits_cube += (d >= f_cube.alpha(mc.count[i]) * mc.mean[i]) as usize;
            }
        }
        let (layer, cube) = (
            hits_layer as f64 / trials as f64,
            hits_cube as f64 / trials as f64,
        );
        let sd = (pfa * (1.0 - pfa) / trials as f64).sqrt();
        assert!((layer - pfa).abs() < 5.0 * sd, "layer window: {layer}");
        assert!(cube > 3.0 * pfa, "cube window: {cube}");
    }

    #[test]
    fn a_larger_image_is_tested_at_a_smaller_false_alarm_probability_for_the_same_false_points() {
        let (v, cell) = (0.5f32, 0.3f32);
        let small = image_false_alarm_probability(1.0, 100_000, v, cell, 1e-2);
        let large = image_false_alarm_probability(1.0, 400_000, v, cell, 1e-2);
        // Expected false detections = pfa × cells, the same for both.
        let cells = |n: f64| n * 0.125 / 0.3;
        assert!((small * cells(1e5) - 1.0).abs() < 1e-6);
        assert!((large * cells(4e5) - 1.0).abs() < 1e-6);
        assert!((small / large - 4.0).abs() < 1e-9);
        // A tiny image is capped; an empty one counts one cell.
        assert_eq!(image_false_alarm_probability(1.0, 10, v, cell, 1e-2), 1e-2);
        assert_eq!(image_false_alarm_probability(1e-3, 0, v, cell, 1.0), 1e-3);
    }

    #[test]
    fn effective_looks_are_bounded_by_one_and_the_voxel_count() {
        assert_eq!(effective_looks(27, 0.001), 1.0);
        assert_eq!(effective_looks(27, 1.0), 27.0);
        assert!((effective_looks(125, 0.125) - 15.625).abs() < 1e-9);
        // A 0.25 m layer through a 0.5 × 0.5 × 1.5 m cell: 1/4 look per voxel.
        assert!((layer_looks_per_voxel(0.25, 0.375, 1.5) - 0.25).abs() < 1e-9);
        // Voxels coarser than the cell's cross-section are independent looks.
        assert_eq!(layer_looks_per_voxel(2.0, 0.375, 1.5), 1.0);
        assert_eq!(layer_window(0.6, 0.25), [5, 5, 0]);
        assert_eq!(layer_window(0.1, 0.5), [1, 1, 0]);
    }
}
