//! The hot loops of back-projection: chunked, `r_V` reused across a snapshot's elements.
//!
//! Per chunk of [`CHUNK`] voxels: grid-local coordinates and `r_V` go to stack arrays
//! (struct of arrays). Per element, pass A computes for every voxel of the chunk the bistatic
//! range, the fractional bin and the rotor (no gathers, no branches: it vectorises); pass B reads
//! the profile (a gather) and accumulates. Inputs were validated by the caller (`mod.rs`): finite
//! positions, `profiles.len() == rx.len() · profile_len`, the tile inside the grid.
//!
//! With feature `std` on x86-64, [`run_f32`] and [`run_q15`] run the same code compiled for AVX2
//! when the CPU has it (checked at run time, cached by std): 8-wide passes instead of 4-wide SSE2.
//! The arithmetic is the same IEEE operations in the same order (Rust never contracts to FMA), so
//! both builds give the same bits; `tests.rs` checks it.

use super::{Backprojector, Interp, PhaseEval, Snapshot, VoxelGrid, CHUNK};
use crate::fixed::CQ15;
use crate::float;
use crate::phase::{
    floor_small_f32, phase_word, rotor_f32, rotor_f32_libm, rotor_q15_word, small_int,
};
use num_complex::Complex;

/// Fills grid-local coordinates of voxels `start .. start + px.len()` (all slices equal length).
#[inline(always)]
fn fill_positions(grid: &VoxelGrid, start: usize, px: &mut [f32], py: &mut [f32], pz: &mut [f32]) {
    let [nx, ny, _] = grid.dims;
    let mut ix = start % nx;
    let mut iy = (start / nx) % ny;
    let mut iz = start / (nx * ny);
    for ((x, y), z) in px.iter_mut().zip(py.iter_mut()).zip(pz.iter_mut()) {
        *x = grid.spacing.x * ix as f32;
        *y = grid.spacing.y * iy as f32;
        *z = grid.spacing.z * iz as f32;
        ix += 1;
        if ix == nx {
            ix = 0;
            iy += 1;
            if iy == ny {
                iy = 0;
                iz += 1;
            }
        }
    }
}

/// Chunk geometry: grid-local coordinates and `r_V` of up to [`CHUNK`] voxels.
pub(super) struct Geo {
    pub(super) px: [f32; CHUNK],
    pub(super) py: [f32; CHUNK],
    pub(super) pz: [f32; CHUNK],
    pub(super) rv: [f32; CHUNK],
}

impl Geo {
    pub(super) fn new() -> Self {
        Self {
            px: [0.0; CHUNK],
            py: [0.0; CHUNK],
            pz: [0.0; CHUNK],
            rv: [0.0; CHUNK],
        }
    }

    /// Coordinates and `r_V` of voxels `start .. start + n` (`n ≤ CHUNK`).
    #[inline(always)]
    pub(super) fn load(&mut self, grid: &VoxelGrid, start: usize, n: usize, tx: glam::Vec3) {
        let (px, py, pz) = (&mut self.px[..n], &mut self.py[..n], &mut self.pz[..n]);
        fill_positions(grid, start, px, py, pz);
        for (((rv, &x), &y), &z) in self.rv[..n].iter_mut().zip(&*px).zip(&*py).zip(&*pz) {
            let (dx, dy, dz) = (x - tx.x, y - tx.y, z - tx.z);
            *rv = float::sqrt(dx * dx + dy * dy + dz * dz);
        }
    }

    /// Pass A of both paths: `r[k] = r_V + r_R` of voxel `k < n` for receiver `a`. Three loops so
    /// that the squares and sums vectorise around the square root (scalar in libm, `sqrtps` with `std`).
    #[inline(always)]
    fn ranges(&self, n: usize, a: glam::Vec3, r: &mut [f32; CHUNK]) {
        let (px, py, pz, rv) = (&self.px[..n], &self.py[..n], &self.pz[..n], &self.rv[..n]);
        let r = &mut r[..n];
        for k in 0..n {
            let (dx, dy, dz) = (px[k] - a.x, py[k] - a.y, pz[k] - a.z);
            r[k] = dx * dx + dy * dy + dz * dz;
        }
        for x in r.iter_mut() {
            *x = float::sqrt(*x);
        }
        for (x, &v) in r.iter_mut().zip(rv) {
            *x += v;
        }
    }
}

/// `acc += Σ_rx` of the snapshot; with `power` non-empty (same length as `acc`) also
/// `power += |Σ_rx …|²`, the snapshot's own image power, summed separately so that `acc` gets the
/// same arithmetic, bit for bit, either way.
pub(super) fn run_f32(
    bp: &Backprojector,
    first: usize,
    acc: &mut [Complex<f32>],
    power: &mut [f32],
    snap: &Snapshot<'_, Complex<f32>>,
) {
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    if avx2::run_f32(bp, first, acc, power, snap) {
        return;
    }
    run_f32_portable(bp, first, acc, power, snap)
}

/// [`run_f32`] for the build's baseline target features.
#[inline(always)]
pub(super) fn run_f32_portable(
    bp: &Backprojector,
    first: usize,
    acc: &mut [Complex<f32>],
    power: &mut [f32],
    snap: &Snapshot<'_, Complex<f32>>,
) {
    macro_rules! run {
        ($l:literal, $p:literal) => {
            if power.is_empty() {
                run_f32_impl::<$l, $p, false>(bp, first, acc, power, snap)
            } else {
                run_f32_impl::<$l, $p, true>(bp, first, acc, power, snap)
            }
        };
    }
    match (bp.cfg.interp, bp.cfg.phase) {
        (Interp::Linear, PhaseEval::Poly) => run!(true, true),
        (Interp::Linear, PhaseEval::Libm) => run!(true, false),
        (Interp::Nearest, PhaseEval::Poly) => run!(false, true),
        (Interp::Nearest, PhaseEval::Libm) => run!(false, false),
    }
}

#[inline(always)]
fn run_f32_impl<const LINEAR: bool, const POLY: bool, const POWER: bool>(
    bp: &Backprojector,
    first: usize,
    acc: &mut [Complex<f32>],
    power: &mut [f32],
    snap: &Snapshot<'_, Complex<f32>>,
) {
    let (r0, inv_dr) = (bp.cfg.r0_m, bp.inv_dr);
    let len = snap.profile_len;
    let zero = Complex::new(0.0f32, 0.0);
    let mut geo = Geo::new();
    let mut rs = [0f32; CHUNK];
    // Per element: the index of the first of the two samples read (clamped into the profile),
    // their weights (zero for a sample outside the profile), the rotor, the gathered samples.
    let (mut idx, mut wa, mut wb, mut c_re, mut c_im) = (
        [0u32; CHUNK],
        [0f32; CHUNK],
        [0f32; CHUNK],
        [0f32; CHUNK],
        [0f32; CHUNK],
    );
    let (mut s0, mut s1) = ([zero; CHUNK], [zero; CHUNK]);
    // The chunk's accumulators as struct of arrays, kept across the snapshot's elements.
    let (mut a_re, mut a_im) = ([0f32; CHUNK], [0f32; CHUNK]);
    // With POWER: the snapshot's own sum over its elements.
    let (mut j_re, mut j_im) = ([0f32; CHUNK], [0f32; CHUNK]);
    for (ci, acc) in acc.chunks_mut(CHUNK).enumerate() {
        let n = acc.len();
        geo.load(&bp.cfg.grid, first + ci * CHUNK, n, snap.tx);
        for ((re, im), z) in a_re.iter_mut().zip(a_im.iter_mut()).zip(acc.iter()) {
            (*re, *im) = (z.re, z.im);
        }
        if POWER {
            j_re[..n].fill(0.0);
            j_im[..n].fill(0.0);
        }
        for (a, profile) in snap.rx.iter().zip(snap.profiles.chunks_exact(len)) {
            // Linear reads a pair of adjacent samples: a one-sample profile is read as itself
            // and a zero after it (the zero is outside the profile: it adds nothing).
            let pad;
            let profile = if LINEAR && profile.len() == 1 {
                pad = [profile[0], zero];
                &pad[..]
            } else {
                profile
            };
            // The highest first index read: the last sample (nearest), the last pair (linear).
            let Some(hi) = profile.len().checked_sub(if LINEAR { 2 } else { 1 }) else {
                continue;
            };
            let hi_f = hi as f32;
            // Pass A (vectorises, no branches): range → bin `fl`, fraction, rotor; then the
            // first index read, `ic = clamp(fl, 0, hi)`, and the weights of samples `ic` and
            // `ic + 1`: sample `j` carries 1 − fraction where `j = fl`, the fraction where
            // `j = fl + 1` and nothing otherwise, so a bin partly or wholly outside the profile
            // reads zero there, and inside it is `s[fl]·(1 − w) + s[fl + 1]·w`.
            geo.ranges(n, *a, &mut rs);
            for k in 0..n {
                let r = rs[k];
                let x = (r - r0) * inv_dr;
                // Exact below 2²² bins; beyond, within 2 of `x`: clamped away either way.
                let fl = floor_small_f32(if LINEAR { x } else { x + 0.5 });
                let f = x - fl;
                let ic = fl.clamp(0.0, hi_f);
                // `ic` is an integer in [0, hi], hi < 2²² (`MAX_PROFILE_LEN`): `small_int` reads
                // it without a float-to-int conversion (whose saturation and NaN checks would
                // not vectorise). The comparisons are exact: integers < 2²⁴.
                idx[k] = small_int(ic) as u32;
                if LINEAR {
                    let (lo, up) = (1.0 - f, f);
                    wa[k] = if ic == fl { lo } else { 0.0 } + if ic == fl + 1.0 { up } else { 0.0 };
                    wb[k] = if ic + 1.0 == fl { lo } else { 0.0 }
                        + if ic + 1.0 == fl + 1.0 { up } else { 0.0 };
                } else {
                    wa[k] = if ic == fl { 1.0 } else { 0.0 };
                }
                let z = if POLY {
                    rotor_f32(bp.cycles(r))
                } else {
                    rotor_f32_libm(bp.cycles(r))
                };
                c_re[k] = z.re;
                c_im[k] = z.im;
            }
            // Pass B1 (scalar loads, no branches): the samples at `ic` and `ic + 1`.
            for k in 0..n {
                let i = (idx[k] as usize).min(hi);
                s0[k] = profile[i];
                if LINEAR {
                    s1[k] = profile[i + 1];
                }
            }
            // Pass B2 (vectorises): interpolate, rotate, accumulate.
            let (a_re, a_im) = (&mut a_re[..n], &mut a_im[..n]);
            let (j_re, j_im) = (&mut j_re[..n], &mut j_im[..n]);
            let (s0, s1, wa, wb) = (&s0[..n], &s1[..n], &wa[..n], &wb[..n]);
            let (c_re, c_im) = (&c_re[..n], &c_im[..n]);
            for k in 0..n {
                let s = if LINEAR {
                    s0[k] * wa[k] + s1[k] * wb[k]
                } else {
                    s0[k] * wa[k]
                };
                let (re, im) = (
                    s.re * c_re[k] - s.im * c_im[k],
                    s.re * c_im[k] + s.im * c_re[k],
                );
                a_re[k] += re;
                a_im[k] += im;
                if POWER {
                    j_re[k] += re;
                    j_im[k] += im;
                }
            }
        }
        for ((z, &re), &im) in acc.iter_mut().zip(&a_re[..n]).zip(&a_im[..n]) {
            *z = Complex::new(re, im);
        }
        if POWER {
            let p = &mut power[ci * CHUNK..ci * CHUNK + n];
            for ((p, &re), &im) in p.iter_mut().zip(&j_re[..n]).zip(&j_im[..n]) {
                *p += re * re + im * im;
            }
        }
    }
}

/// Q15 sample `(re, im)` of `profile` at bin `i` + Q15 fraction `w` (linear) or at bin `i`
/// (nearest), zero outside; branch free. Linear: `s0 + round((s1 − s0)·w)`
/// with `w` in \[0, 32767\] (`(s1 − s0)·w` < 2¹⁶·2¹⁵ fits `i32`); the result lies between `s0`
/// and `s1`, so within `i16` range.
#[inline(always)]
fn interp_q15<const LINEAR: bool>(profile: &[CQ15], i: i32, w: i32) -> (i32, i32) {
    let Some(last) = profile.len().checked_sub(1) else {
        return (0, 0);
    };
    let at = |i: usize| {
        let valid = (i <= last) as i32;
        profile.get(i.min(last)).map_or((0, 0), |z| {
            (z.re.to_bits() as i32 * valid, z.im.to_bits() as i32 * valid)
        })
    };
    // A negative index wraps to a huge usize: out of range like one past the end.
    let i = i as isize as usize;
    if LINEAR {
        let (a_re, a_im) = at(i);
        let (b_re, b_im) = at(i.wrapping_add(1));
        (
            a_re + (((b_re - a_re) * w + (1 << 14)) >> 15),
            a_im + (((b_im - a_im) * w + (1 << 14)) >> 15),
        )
    } else {
        at(i)
    }
}

pub(super) fn run_q15(
    bp: &Backprojector,
    first: usize,
    acc: &mut [Complex<i64>],
    acc_exp: i32,
    snap: &Snapshot<'_, CQ15>,
    exponents: &[i32],
) {
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    if avx2::run_q15(bp, first, acc, acc_exp, snap, exponents) {
        return;
    }
    run_q15_portable(bp, first, acc, acc_exp, snap, exponents)
}

/// [`run_q15`] for the build's baseline target features.
#[inline(always)]
pub(super) fn run_q15_portable(
    bp: &Backprojector,
    first: usize,
    acc: &mut [Complex<i64>],
    acc_exp: i32,
    snap: &Snapshot<'_, CQ15>,
    exponents: &[i32],
) {
    if bp.cfg.interp == Interp::Linear {
        run_q15_impl::<true>(bp, first, acc, acc_exp, snap, exponents)
    } else {
        run_q15_impl::<false>(bp, first, acc, acc_exp, snap, exponents)
    }
}

#[inline(always)]
fn run_q15_impl<const LINEAR: bool>(
    bp: &Backprojector,
    first: usize,
    acc: &mut [Complex<i64>],
    acc_exp: i32,
    snap: &Snapshot<'_, CQ15>,
    exponents: &[i32],
) {
    let (r0, inv_dr) = (bp.cfg.r0_m, bp.inv_dr);
    let len = snap.profile_len;
    let mut geo = Geo::new();
    let mut rs = [0f32; CHUNK];
    // Per element: bin, fraction (Q15) and phase word, as integers.
    let (mut bins, mut ws, mut words) = ([0i32; CHUNK], [0i32; CHUNK], [0u32; CHUNK]);
    // Interpolated samples and rotors (struct of arrays), then the chunk's i64 accumulators.
    let (mut s_re, mut s_im, mut c_re, mut c_im) =
        ([0i32; CHUNK], [0i32; CHUNK], [0i32; CHUNK], [0i32; CHUNK]);
    let (mut a_re, mut a_im) = ([0i64; CHUNK], [0i64; CHUNK]);
    for (ci, acc) in acc.chunks_mut(CHUNK).enumerate() {
        let n = acc.len();
        geo.load(&bp.cfg.grid, first + ci * CHUNK, n, snap.tx);
        for ((re, im), z) in a_re.iter_mut().zip(a_im.iter_mut()).zip(acc.iter()) {
            (*re, *im) = (z.re, z.im);
        }
        for ((a, profile), &e) in snap
            .rx
            .iter()
            .zip(snap.profiles.chunks_exact(len))
            .zip(exponents)
        {
            // acc_exp ≥ e (the state was raised to the snapshot's largest exponent). A shift of
            // 32 or more rounds every |product| < 2³¹ to zero: skip the element.
            let shift = (acc_exp - e) as u32;
            if shift >= 32 {
                continue;
            }
            let half = if shift == 0 { 0 } else { 1i64 << (shift - 1) };
            geo.ranges(n, *a, &mut rs);
            // Pass A (vectorises: float operations, and float-to-int conversions of values
            // known to fit): bin, Q15 fraction, phase word.
            let len_f = profile.len() as f32;
            for k in 0..n {
                let r = rs[k];
                let x = (r - r0) * inv_dr;
                // Exact below 2²² bins; beyond, within 2 of `x`: clamped away either way.
                let fl = floor_small_f32(if LINEAR { x } else { x + 0.5 });
                // In [0, 32767]: x − fl < 1 exactly (unused for nearest).
                let w = floor_small_f32((x - fl) * 32768.0);
                // Clamped to [−2, len]: every bin outside reads zero at both samples, as the bin
                // itself would; an integer below 2²², read by `small_int`.
                let b = fl.clamp(-2.0, len_f);
                bins[k] = small_int(b);
                ws[k] = small_int(w);
                words[k] = phase_word(bp.cycles(r));
            }
            // Pass B1 (scalar: gathers): interpolated sample and table rotor.
            for k in 0..n {
                (s_re[k], s_im[k]) = interp_q15::<LINEAR>(profile, bins[k], ws[k]);
                let (re, im) = rotor_q15_word(words[k]);
                (c_re[k], c_im[k]) = (re as i32, im as i32);
            }
            // Pass B2: exact Q30 product, aligned and accumulated in i64. |s| components
            // ≤ 2¹⁵, rotor components ≤ 32767: each sum < 2³¹.
            let (a_re, a_im) = (&mut a_re[..n], &mut a_im[..n]);
            let (s_re, s_im, c_re, c_im) = (&s_re[..n], &s_im[..n], &c_re[..n], &c_im[..n]);
            for k in 0..n {
                let p_re = s_re[k] * c_re[k] - s_im[k] * c_im[k];
                let p_im = s_re[k] * c_im[k] + s_im[k] * c_re[k];
                a_re[k] += (p_re as i64 + half) >> shift;
                a_im[k] += (p_im as i64 + half) >> shift;
            }
        }
        for ((z, &re), &im) in acc.iter_mut().zip(&a_re[..n]).zip(&a_im[..n]) {
            *z = Complex::new(re, im);
        }
    }
}

/// The kernels compiled for AVX2, entered only after the CPU was found to have it.
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[allow(unsafe_code)]
pub(super) mod avx2 {
    use super::{Backprojector, Complex, Snapshot, CQ15};

    /// `true` if this CPU runs the AVX2 build (std caches the CPUID answer).
    pub(in super::super) fn available() -> bool {
        std::is_x86_feature_detected!("avx2")
    }

    /// [`super::run_f32`] in the AVX2 build; `false` (nothing done) if the CPU lacks AVX2.
    pub(in super::super) fn run_f32(
        bp: &Backprojector,
        first: usize,
        acc: &mut [Complex<f32>],
        power: &mut [f32],
        snap: &Snapshot<'_, Complex<f32>>,
    ) -> bool {
        if !available() {
            return false;
        }
        // SAFETY: `run_f32_avx2` needs AVX2 and nothing else; the CPU has it (checked above).
        unsafe { run_f32_avx2(bp, first, acc, power, snap) };
        true
    }

    /// [`super::run_q15`] in the AVX2 build; `false` (nothing done) if the CPU lacks AVX2.
    pub(in super::super) fn run_q15(
        bp: &Backprojector,
        first: usize,
        acc: &mut [Complex<i64>],
        acc_exp: i32,
        snap: &Snapshot<'_, CQ15>,
        exponents: &[i32],
    ) -> bool {
        if !available() {
            return false;
        }
        // SAFETY: `run_q15_avx2` needs AVX2 and nothing else; the CPU has it (checked above).
        unsafe { run_q15_avx2(bp, first, acc, acc_exp, snap, exponents) };
        true
    }

    #[target_feature(enable = "avx2")]
    fn run_f32_avx2(
        bp: &Backprojector,
        first: usize,
        acc: &mut [Complex<f32>],
        power: &mut [f32],
        snap: &Snapshot<'_, Complex<f32>>,
    ) {
        super::run_f32_portable(bp, first, acc, power, snap)
    }

    #[target_feature(enable = "avx2")]
    fn run_q15_avx2(
        bp: &Backprojector,
        first: usize,
        acc: &mut [Complex<i64>],
        acc_exp: i32,
        snap: &Snapshot<'_, CQ15>,
        exponents: &[i32],
    ) {
        super::run_q15_portable(bp, first, acc, acc_exp, snap, exponents)
    }
}
