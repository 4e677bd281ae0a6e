//! The coarse pass's range resolution, matched to its lattice.
//!
//! The coarse pass (`imaging.coarse_voxel_m`) samples each pair's focused image at the centres of
//! a lattice several times coarser than the pair's range resolution, and the fine pass images only
//! the bricks around what it detects there. A point sample of a focused image sees a surface only
//! as far as the point-spread function reaches from the surface to the nearest sample, and across
//! a surface facing the pair that reach is the range profile's main lobe: a plane always has a
//! lattice centre within half a spacing `cv/2` of it along its normal, and there the bistatic path
//! `|p − tx| + |p − rx|` differs from the surface's by up to `|∇r|·cv/2 ≤ cv` (the path's gradient
//! is `2 cos(β/2) ≤ 2`, β the bistatic angle). At 400 MHz with a Hann window the compressed pulse
//! is down 3 dB at 0.54 m of path and 15 dB at 1.1 m: on the quick preset's 1.5 m lattice a
//! wall could fall between the samples with most of its power lost, and the mask then missed
//! surfaces the fine pass would have detected — a wall seen by one pair went undetected, a
//! 2 m-wide panel (finer range-independent resolution, same range) imaged nothing at all.
//!
//! So the coarse pass also reads each profile low-passed along range: convolved with the
//! smallest Gaussian for which the filtered pulse keeps half its peak power out to `cv` of path
//! either side, so that a surface anywhere between the samples keeps half its (filtered) power at
//! the nearest one. A real, symmetric kernel in the profile's bins is a coherent sub-band filter:
//! it multiplies the subcarriers by a Gaussian taper about the carrier, so the back-projection's
//! phase at the carrier stays exact; only the range resolution coarsens to the lattice's. The
//! filter costs the pulse's peak (spread over the wider lobe), so a surface right at a sample is
//! weaker in the filtered image than in the full-band one: the driver images both from the same
//! snapshots and the mask is their union, each tested at half the mask's false-alarm probability
//! (a union bound on the stated rate). The data's profiles and the terrain model's go through the
//! same filter, so each image's clutter reference is the image of the same processing. The fine
//! pass reads the full band.
//!
//! Units: bins of the range profile (`dr` metres of bistatic path each), metres of path.

use num_complex::Complex32;

/// Half-power full width of the compressed pulse, in bins, from its magnitude `p(x)` at `x` bins
/// off the peak (`p(0)` the peak): twice the smallest `x` at which `|p(x)|² ≤ |p(0)|²/2`, found
/// on a grid of 1/64 bin and refined linearly. `max_bins` bounds the search (returned when the
/// pulse stays above half power that far).
pub fn half_power_width_bins(p: impl Fn(f64) -> f32, max_bins: f64) -> f64 {
    let peak = p(0.0);
    if peak.is_nan() || peak <= 0.0 {
        return 0.0;
    }
    let half = peak * std::f32::consts::FRAC_1_SQRT_2;
    let step = 1.0 / 64.0;
    let mut x0 = 0.0;
    let mut v0 = peak;
    while x0 < max_bins {
        let x1 = x0 + step;
        let v1 = p(x1);
        if v1 <= half {
            let t = if v0 > v1 {
                ((v0 - half) / (v0 - v1)) as f64
            } else {
                0.0
            };
            return 2.0 * (x0 + t * step);
        }
        x0 = x1;
        v0 = v1;
    }
    2.0 * max_bins
}

/// Gaussian taps of standard deviation `sigma` bins, normalised to sum 1, cut at ±3 σ.
fn gaussian_taps(sigma: f64) -> Vec<f32> {
    let half = (3.0 * sigma).ceil() as usize;
    let taps: Vec<f64> = (0..=2 * half)
        .map(|j| {
            let x = j as f64 - half as f64;
            (-0.5 * (x / sigma).powi(2)).exp()
        })
        .collect();
    let sum: f64 = taps.iter().sum();
    taps.iter().map(|&t| (t / sum) as f32).collect()
}

/// The range filter of the coarse pass (module docs): Gaussian taps (normalised to sum 1, cut at
/// ±3 σ) with the smallest σ for which the filtered pulse `Σ_j h_j·p(x − j)` keeps half its peak
/// power out to `coarse_voxel_m` of path either side (`pulse(x)` the compressed pulse at `x`
/// bins, `dr_m` metres of path per bin); σ is found by bisection to 1 % of a bin. `[1.0]` (no
/// filter) when the pulse is already that wide.
pub fn coarse_range_kernel(
    pulse: impl Fn(f64) -> Complex32,
    dr_m: f64,
    coarse_voxel_m: f64,
) -> Vec<f32> {
    let target = 2.0 * coarse_voxel_m / dr_m;
    if !target.is_finite() || target <= 0.0 {
        return vec![1.0];
    }
    let width = |taps: &[f32]| {
        let half = (taps.len() / 2) as f64;
        half_power_width_bins(
            |x| {
                taps.iter()
                    .enumerate()
                    .map(|(j, &h)| pulse(x - (j as f64 - half)) * h)
                    .sum::<Complex32>()
                    .norm()
            },
            target,
        )
    };
    if width(&[1.0]) >= target {
        return vec![1.0];
    }
    let (mut lo, mut hi) = (0.0f64, target);
    while hi - lo > 0.01 {
        let mid = 0.5 * (lo + hi);
        if width(&gaussian_taps(mid)) >= target {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    gaussian_taps(hi)
}

/// Convolves every row of `rows` (`row_len` bins each) with the odd-length, centred `kernel`;
/// bins beyond a row's ends count as zero. `scratch` holds one row.
pub fn filter_rows(
    rows: &mut [Complex32],
    row_len: usize,
    kernel: &[f32],
    scratch: &mut Vec<Complex32>,
) {
    if kernel.len() <= 1 || row_len == 0 {
        return;
    }
    let half = kernel.len() / 2;
    scratch.resize(row_len, Complex32::new(0.0, 0.0));
    for row in rows.chunks_exact_mut(row_len) {
        for (i, out) in scratch.iter_mut().enumerate() {
            let lo = i.saturating_sub(half);
            let hi = (i + half).min(row_len - 1);
            let mut acc = Complex32::new(0.0, 0.0);
            for (j, z) in row.iter().enumerate().take(hi + 1).skip(lo) {
                acc += z * kernel[j + half - i];
            }
            *out = acc;
        }
        row.copy_from_slice(scratch);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::echo::{EchoConfig, PulseKernel};

    /// The quick preset's pulse: 400 MHz, 1024 subcarriers, Hann, zero padding 2.
    fn hann_pulse() -> (PulseKernel, f64) {
        let cfg = EchoConfig::new(10e9, 400e6, 1024, 2)
            .with_window(has_dsp::window::Window::Hann)
            .unwrap();
        let dr = has_dsp::ofdm::bin_spacing_m(400e6, 2);
        (PulseKernel::new(&cfg).unwrap(), dr)
    }

    /// A unit scatterer's profile at `u` bins, `n` bins long, low-passed by `kernel`.
    fn profile(k: &PulseKernel, n: usize, u: f64, kernel: &[f32]) -> Vec<Complex32> {
        let mut row = vec![Complex32::new(0.0, 0.0); n];
        k.deposit(&mut row, u, Complex32::new(1.0, 0.0));
        filter_rows(&mut row, n, kernel, &mut Vec::new());
        row
    }

    #[test]
    fn the_hann_pulses_half_power_width_is_1_44_resolution_cells() {
        let (k, dr) = hann_pulse();
        let w = half_power_width_bins(|x| k.eval(x).norm(), 64.0);
        // Hann: 1.44 c/B of path; a bin is c/(B·zero_pad).
        let cells = w * dr / (has_dsp::geometry::C_M_PER_S / 400e6);
        assert!((cells - 1.44).abs() < 0.02, "{cells}");
    }

    #[test]
    fn a_surface_anywhere_between_coarse_samples_keeps_half_its_power() {
        let (k, dr) = hann_pulse();
        for cv in [1.0, 1.5, 2.0] {
            let kernel = coarse_range_kernel(|x| k.eval(x), dr, cv);
            let (n, u) = (256, 128.0);
            let row = profile(&k, n, u, &kernel);
            let peak = row[u as usize].norm_sqr();
            // A path offset of up to cv (half a lattice spacing, path gradient ≤ 2).
            let off = cv / dr;
            let at = |x: f64| {
                let (i, t) = (x.floor() as usize, (x - x.floor()) as f32);
                (row[i] * (1.0 - t) + row[i + 1] * t).norm_sqr()
            };
            for x in [u - off, u + off] {
                assert!(
                    at(x) >= 0.49 * peak,
                    "cv {cv}: {} of the peak",
                    at(x) / peak
                );
            }
            // Without the filter the pulse has fallen well below half power there.
            let bare = profile(&k, n, u, &[1.0]);
            let b = |x: f64| bare[x.round() as usize].norm_sqr();
            assert!(
                b(u + off.round()) < 0.25 * bare[u as usize].norm_sqr(),
                "cv {cv}"
            );
        }
    }

    #[test]
    fn the_filter_keeps_the_carrier_phase_of_a_scatterer() {
        // A scatterer's profile is e^{−jφ}·p(i − u); the filter is real and symmetric, so the
        // phase at the peak is still −φ (p is real and positive at its peak for a symmetric
        // window).
        let (k, dr) = hann_pulse();
        let kernel = coarse_range_kernel(|x| k.eval(x), dr, 1.5);
        let phi = 0.7f32;
        let mut row = vec![Complex32::new(0.0, 0.0); 128];
        k.deposit(&mut row, 64.0, Complex32::from_polar(1.0, -phi));
        filter_rows(&mut row, 128, &kernel, &mut Vec::new());
        assert!((row[64].arg() + phi).abs() < 1e-4, "{}", row[64].arg());
    }

    #[test]
    fn a_pulse_already_as_wide_as_the_lattice_is_not_filtered() {
        let (k, dr) = hann_pulse();
        // The Hann pulse keeps half power out to 0.54 m of path either side: a lattice of
        // 0.25 m (path offsets up to 0.25 m) needs no filter, one of 1.5 m does.
        assert_eq!(coarse_range_kernel(|x| k.eval(x), dr, 0.25), vec![1.0]);
        let taps = coarse_range_kernel(|x| k.eval(x), dr, 1.5);
        assert!(taps.len() > 1 && taps.len() % 2 == 1);
        assert!((taps.iter().sum::<f32>() - 1.0).abs() < 1e-6);
    }
}
