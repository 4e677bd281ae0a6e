//! Environment-template subtraction: fit the complex gains of predicted static responses to a
//! measured frame by least squares and subtract them.
//!
//! A *template* `t` is the static (clutter) response predicted for one frame — a range profile
//! (one entry per range bin) or a channel (one entry per subcarrier) — e.g. from ray tracing the
//! reconstructed environment. For a measured frame `y` of the same length the single-template fit
//! is `g = tᴴy / tᴴt` and the residual `y − g·t` is orthogonal to `t`. With `P` templates
//! `T = [t₁ … t_P]` the gains solve the normal equations `(TᴴT)·g = Tᴴy` (Cholesky, see
//! [`crate::linalg`]) and the residual is `y − T·g`, the projection of `y` off the span of the
//! templates. The gain is dimensionless (frame units per template unit) and is fitted per frame, so
//! a drift of the static response's amplitude or phase between frames (gain, clock) is absorbed.
//!
//! Layout: `P` templates are one slice of `P · bins` samples, template `p` at
//! `[p·bins, (p+1)·bins)`; a block of frames is one slice of `frames · bins` samples, frame `f` at
//! `[f·bins, (f+1)·bins)`, and its gains `[f·P, (f+1)·P)`. Residuals overwrite the frames.
//!
//! Two data paths with the same maths:
//! * [`TemplateSet`]: `f32` samples; correlations summed in `f32` chunks of 64 and `f64` across
//!   chunks; the `P × P` system in `f64` (factored once, when the set is built).
//! * [`TemplateSetQ15`]: Q15 samples; correlations exact in `i64` (Q30, at most
//!   [`MAX_Q15_CORR_LEN`] bins), solve in `f64`, gains quantised to `i32` mantissas with one shared
//!   exponent ([`BlockWeights`]) and applied with integer multiply-accumulate, rounding to nearest
//!   and saturation back to Q15.
//!
//! Who runs which path: the host pipeline (`has_host::localize`) runs [`TemplateSet`] (its
//! echoes are synthesised in f32); [`TemplateSetQ15`] is for firmware fed by a Q15 front end,
//! held to the f32 path by `tests/eca_template.rs` (residual error power within the rounding
//! budget). The two are not one generic type: the f32 path guards the `f32` range (gains and
//! residuals that would overflow are refused), the Q15 path saturates, and their gains differ in
//! form (`f32` against block floating point).
//!
//! Constructors copy nothing: a set borrows its templates.

use crate::error::{check_len, DspError};
use crate::fixed::CQ15;
use crate::linalg::{
    cholesky_in_place, cholesky_solve, dot_conj_c32, dot_conj_q15, q15_sub_weighted, q30_to_f64,
    BlockWeights, MAX_Q15_CORR_LEN,
};
use num_complex::Complex;

type C32 = Complex<f32>;
type C64 = Complex<f64>;

/// Checks the template layout and returns nothing; shared by both paths.
fn check_layout<const P: usize>(len: usize, bins: usize) -> Result<(), DspError> {
    if P == 0 {
        return Err(DspError::UnsupportedLength {
            what: "template count P",
            len: P,
        });
    }
    if bins == 0 {
        return Err(DspError::UnsupportedLength {
            what: "template bins",
            len: 0,
        });
    }
    check_len("templates (P · bins)", P.saturating_mul(bins), len)
}

/// Factors the templates' Gram matrix, after checking every template has non-zero finite energy.
fn factor_gram<const P: usize>(gram: &mut [[C64; P]; P], loading: f64) -> Result<(), DspError> {
    for (p, row) in gram.iter().enumerate() {
        let e = row[p].re;
        if !e.is_finite() {
            return Err(DspError::NonFinite { what: "template" });
        }
        if e <= 0.0 {
            return Err(DspError::OutOfRange {
                what: "template energy (tᴴt, must be > 0)",
                value: e as f32,
            });
        }
    }
    cholesky_in_place(gram, P, loading).map_err(|e| match e {
        DspError::NotPositiveDefinite { .. } => DspError::NotPositiveDefinite {
            what: "templates (linearly dependent)",
        },
        other => other,
    })
}

/// Checks a block of frames against its gains buffer and returns the number of frames.
fn check_block<const P: usize>(
    bins: usize,
    frames_len: usize,
    gains_len: usize,
) -> Result<usize, DspError> {
    if gains_len.checked_rem(P) != Some(0) {
        return Err(DspError::LengthMismatch {
            what: "gains (frames · P)",
            expected: (gains_len / P + 1) * P,
            got: gains_len,
        });
    }
    let n = gains_len / P;
    check_len("frames (frames · bins)", n.saturating_mul(bins), frames_len)?;
    Ok(n)
}

/// Checks a block for a common fit and returns the number of frames (≥ 1).
fn check_common(bins: usize, len: usize) -> Result<usize, DspError> {
    let count = len / bins;
    if count == 0 || len.checked_rem(bins) != Some(0) {
        return Err(DspError::LengthMismatch {
            what: "frames (a non-zero multiple of bins)",
            expected: count.max(1) * bins,
            got: len,
        });
    }
    Ok(count)
}

/// Largest component magnitude `max(|re|, |im|)` over `v`, in `f64` (0 for an empty slice).
fn component_peak(v: &[C32]) -> f64 {
    v.iter()
        .fold(0.0f32, |m, z| m.max(z.re.abs()).max(z.im.abs())) as f64
}

/// `P` environment templates of `bins` `f32` samples each, with their factored Gram matrix.
/// `P = 1` is the single-template fit `g = tᴴy / tᴴt` (alias [`Template`]).
#[derive(Clone, Debug)]
pub struct TemplateSet<'a, const P: usize> {
    templates: &'a [C32],
    bins: usize,
    chol: [[C64; P]; P],
    /// Largest component magnitude `max_n max(|re|, |im|)` of each template (overflow bound).
    peak: [f64; P],
}

/// One `f32` template.
pub type Template<'a> = TemplateSet<'a, 1>;

impl<'a, const P: usize> TemplateSet<'a, P> {
    /// Builds the set from `P · bins` samples (template `p` at `[p·bins, (p+1)·bins)`) and factors
    /// `TᴴT` with relative diagonal `loading` (0 for an exact least-squares fit; see
    /// [`crate::linalg`]).
    ///
    /// # Errors
    /// [`DspError::UnsupportedLength`] for `P = 0` or `bins = 0`; [`DspError::LengthMismatch`] if
    /// `templates.len() ≠ P · bins`; [`DspError::NonFinite`] for a non-finite template sample;
    /// [`DspError::OutOfRange`] (`"template energy"`) for a template of zero energy or a bad
    /// `loading`; [`DspError::NotPositiveDefinite`] if the templates are linearly dependent.
    pub fn new(templates: &'a [C32], bins: usize, loading: f64) -> Result<Self, DspError> {
        check_layout::<P>(templates.len(), bins)?;
        let mut chol = [[C64::new(0.0, 0.0); P]; P];
        for i in 0..P {
            for j in 0..=i {
                chol[i][j] = dot_conj_c32(
                    &templates[i * bins..(i + 1) * bins],
                    &templates[j * bins..(j + 1) * bins],
                );
            }
        }
        factor_gram(&mut chol, loading)?;
        let mut peak = [0.0f64; P];
        for (p, m) in peak.iter_mut().enumerate() {
            *m = component_peak(&templates[p * bins..(p + 1) * bins]);
        }
        Ok(Self {
            templates,
            bins,
            chol,
            peak,
        })
    }

    /// Samples per template (and per frame).
    pub fn bins(&self) -> usize {
        self.bins
    }

    /// `Tᴴy` of one frame, checked finite.
    fn correlate(&self, frame: &[C32]) -> Result<[C64; P], DspError> {
        check_len("frame", self.bins, frame.len())?;
        let mut g = [C64::new(0.0, 0.0); P];
        for (p, gp) in g.iter_mut().enumerate() {
            *gp = dot_conj_c32(&self.templates[p * self.bins..(p + 1) * self.bins], frame);
            if !(gp.re.is_finite() && gp.im.is_finite()) {
                return Err(DspError::NonFinite { what: "frame" });
            }
        }
        Ok(g)
    }

    /// Solves `(TᴴT)·g = r / frames` and rounds the gains to `f32`; a gain beyond the `f32` range
    /// (a frame enormous against a tiny template) is an error.
    fn solve(&self, mut r: [C64; P], frames: usize) -> Result<[C32; P], DspError> {
        cholesky_solve(&self.chol, P, &mut r)?;
        let inv = 1.0 / frames as f64;
        let mut out = [C32::new(0.0, 0.0); P];
        for (o, z) in out.iter_mut().zip(&r) {
            *o = C32::new((z.re * inv) as f32, (z.im * inv) as f32);
            for c in [o.re, o.im] {
                if !c.is_finite() {
                    return Err(DspError::OutOfRange {
                        what: "gains (beyond the f32 range)",
                        value: c,
                    });
                }
            }
        }
        Ok(out)
    }

    /// Checks, before anything is written, that [`Self::apply`] of the finite gains `g` to every
    /// frame of `frames` (finite samples) gives a finite residual. Cheap bound first: every
    /// partial result of `y − Σ_p g_p·t_p` has components at most
    /// `max|y| + Σ_p 2·max|g_p|·max|t_p|` (times `1 + O(P·2⁻²⁴)` of rounding), so below
    /// `f32::MAX / 2` nothing can overflow. Otherwise the residual is evaluated exactly as `apply`
    /// will (same operations, same order) without writing it.
    fn check_residual(&self, frames: &[C32], g: &[C32; P]) -> Result<(), DspError> {
        let mut bound = component_peak(frames);
        for (gp, tp) in g.iter().zip(&self.peak) {
            bound += 2.0 * (gp.re.abs().max(gp.im.abs()) as f64) * tp;
        }
        if bound <= f32::MAX as f64 / 2.0 {
            return Ok(());
        }
        for frame in frames.chunks_exact(self.bins) {
            for (n, &y) in frame.iter().enumerate() {
                let mut r = y;
                for (p, gp) in g.iter().enumerate() {
                    r -= gp * self.templates[p * self.bins + n];
                }
                if !(r.re.is_finite() && r.im.is_finite()) {
                    return Err(DspError::NonFinite {
                        what: "residual (y − T·g beyond the f32 range)",
                    });
                }
            }
        }
        Ok(())
    }

    /// `y ← y − T·g`.
    fn apply(&self, frame: &mut [C32], g: &[C32; P]) {
        for (p, gp) in g.iter().enumerate() {
            let t = &self.templates[p * self.bins..(p + 1) * self.bins];
            for (y, tv) in frame.iter_mut().zip(t) {
                *y -= gp * tv;
            }
        }
    }

    /// The least-squares gains of the templates in `frame` (no subtraction).
    ///
    /// # Errors
    /// [`DspError::LengthMismatch`] if `frame.len() ≠ bins`; [`DspError::NonFinite`] if the frame
    /// holds a NaN or infinity (detected through the correlation, no extra pass);
    /// [`DspError::OutOfRange`] (`gains`) if a gain is beyond the `f32` range.
    pub fn fit(&self, frame: &[C32]) -> Result<[C32; P], DspError> {
        self.solve(self.correlate(frame)?, 1)
    }

    /// Fits the gains and replaces `frame` by the residual `y − T·g`; returns the gains.
    ///
    /// # Errors
    /// As [`TemplateSet::fit`]; [`DspError::NonFinite`] (`residual`) if the residual would
    /// overflow `f32` (only for samples near the `f32` range; `frame` is then left untouched).
    pub fn subtract_in_place(&self, frame: &mut [C32]) -> Result<[C32; P], DspError> {
        let g = self.fit(frame)?;
        self.check_residual(frame, &g)?;
        self.apply(frame, &g);
        Ok(g)
    }

    /// Fits **one** set of gains to a whole block of frames (`frames · bins` samples, all frames
    /// sharing the gains: `g = (TᴴT)⁻¹·Σ_f Tᴴy_f / F`, the least-squares fit of a static response
    /// over the CPI) and subtracts it from every frame; returns the gains. Compared with per-frame
    /// fitting ([`TemplateSet::subtract_block`]) a target moving across the CPI leaks less into
    /// the fit, but a drift of the static response between frames is not absorbed.
    ///
    /// # Errors
    /// [`DspError::LengthMismatch`] if `frames.len()` is not a non-zero multiple of `bins`;
    /// [`DspError::NonFinite`] for a NaN or infinity, or a residual that would overflow, and
    /// [`DspError::OutOfRange`] for a gain beyond the `f32` range (nothing is modified then).
    pub fn subtract_block_common(&self, frames: &mut [C32]) -> Result<[C32; P], DspError> {
        let count = check_common(self.bins, frames.len())?;
        let mut r = [C64::new(0.0, 0.0); P];
        for frame in frames.chunks_exact(self.bins) {
            for (a, b) in r.iter_mut().zip(&self.correlate(frame)?) {
                *a += b;
            }
        }
        let g = self.solve(r, count)?;
        self.check_residual(frames, &g)?;
        for frame in frames.chunks_exact_mut(self.bins) {
            self.apply(frame, &g);
        }
        Ok(g)
    }

    /// [`TemplateSet::subtract_in_place`] for a block of frames (`frames · bins` samples), gains
    /// fitted per frame and written to `gains` (`frames · P`, frame-major).
    ///
    /// # Errors
    /// [`DspError::LengthMismatch`] if `gains.len()` is not a multiple of `P` or
    /// `frames.len() ≠ (gains.len()/P) · bins`; [`DspError::NonFinite`] as for one frame (frames
    /// before the bad one are already processed).
    pub fn subtract_block(&self, frames: &mut [C32], gains: &mut [C32]) -> Result<(), DspError> {
        check_block::<P>(self.bins, frames.len(), gains.len())?;
        for (frame, g) in frames
            .chunks_exact_mut(self.bins)
            .zip(gains.chunks_exact_mut(P))
        {
            g.copy_from_slice(&self.subtract_in_place(frame)?);
        }
        Ok(())
    }
}

/// `P` environment templates of `bins` Q15 samples each, with their exact (`i64`) Gram matrix
/// factored in `f64`. See the module docs for the fixed-point arithmetic.
#[derive(Clone, Debug)]
pub struct TemplateSetQ15<'a, const P: usize> {
    templates: &'a [CQ15],
    bins: usize,
    chol: [[C64; P]; P],
}

/// One Q15 template.
pub type TemplateQ15<'a> = TemplateSetQ15<'a, 1>;

impl<'a, const P: usize> TemplateSetQ15<'a, P> {
    /// Builds the set (layout as [`TemplateSet::new`]); `bins` may not exceed
    /// [`MAX_Q15_CORR_LEN`] (2³¹), the longest exact `i64` correlation.
    ///
    /// # Errors
    /// As [`TemplateSet::new`], plus [`DspError::UnsupportedLength`] for `bins > 2³¹`.
    pub fn new(templates: &'a [CQ15], bins: usize, loading: f64) -> Result<Self, DspError> {
        check_layout::<P>(templates.len(), bins)?;
        if bins > MAX_Q15_CORR_LEN {
            return Err(DspError::UnsupportedLength {
                what: "template bins (Q15 path, at most 2^31)",
                len: bins,
            });
        }
        let mut chol = [[C64::new(0.0, 0.0); P]; P];
        for i in 0..P {
            for j in 0..=i {
                chol[i][j] = q30_to_f64(dot_conj_q15(
                    &templates[i * bins..(i + 1) * bins],
                    &templates[j * bins..(j + 1) * bins],
                ));
            }
        }
        factor_gram(&mut chol, loading)?;
        Ok(Self {
            templates,
            bins,
            chol,
        })
    }

    /// Samples per template (and per frame).
    pub fn bins(&self) -> usize {
        self.bins
    }

    /// Exact `Tᴴy` of one frame (Q30 in `i64`).
    fn correlate(&self, frame: &[CQ15]) -> Result<[Complex<i64>; P], DspError> {
        check_len("frame", self.bins, frame.len())?;
        let mut r = [Complex::new(0i64, 0i64); P];
        for (p, rp) in r.iter_mut().enumerate() {
            *rp = dot_conj_q15(&self.templates[p * self.bins..(p + 1) * self.bins], frame);
        }
        Ok(r)
    }

    /// Solves `(TᴴT)·g = r / frames` in `f64`.
    fn solve(&self, r: [Complex<i64>; P], frames: usize) -> Result<[C64; P], DspError> {
        let mut g = [C64::new(0.0, 0.0); P];
        for (gp, rp) in g.iter_mut().zip(&r) {
            *gp = q30_to_f64(*rp) / frames as f64;
        }
        cholesky_solve(&self.chol, P, &mut g)?;
        Ok(g)
    }

    /// `y ← y − T·g` with block-floating-point gains; returns the gains as applied.
    fn apply(&self, frame: &mut [CQ15], w: &BlockWeights<P>) -> [C32; P] {
        for (n, y) in frame.iter_mut().enumerate() {
            let basis = (0..P).map(|p| self.templates[p * self.bins + n]);
            *y = q15_sub_weighted(*y, &w.mant, basis, w.frac_bits);
        }
        let scale = 1.0 / (1u64 << w.frac_bits) as f32;
        let mut out = [C32::new(0.0, 0.0); P];
        for (o, m) in out.iter_mut().zip(&w.mant) {
            *o = C32::new(m.re as f32 * scale, m.im as f32 * scale);
        }
        out
    }

    /// The least-squares gains of the templates in `frame`, exact correlations solved in `f64`.
    ///
    /// # Errors
    /// [`DspError::LengthMismatch`] if `frame.len() ≠ bins`.
    pub fn fit(&self, frame: &[CQ15]) -> Result<[C64; P], DspError> {
        self.solve(self.correlate(frame)?, 1)
    }

    /// Fits the gains and replaces `frame` by the residual `y − T·g`, computed per sample in `i64`
    /// from the block-floating-point gains, rounded and saturated to Q15. Returns the gains as
    /// applied (the quantised values).
    ///
    /// # Errors
    /// As [`TemplateSetQ15::fit`]; [`DspError::OutOfRange`] if a gain reaches 2³⁰ (impossible for
    /// templates with at least one LSB of energy and Q15 frames unless `loading` is 0 and the set is
    /// nearly dependent).
    pub fn subtract_in_place(&self, frame: &mut [CQ15]) -> Result<[C32; P], DspError> {
        let g = self.fit(frame)?;
        let w = BlockWeights::<P>::quantize(&g, P)?;
        Ok(self.apply(frame, &w))
    }

    /// One set of gains for a whole block of frames, as [`TemplateSet::subtract_block_common`];
    /// the correlations are summed exactly over all frames, so `frames · bins` may not exceed
    /// [`MAX_Q15_CORR_LEN`] (2³¹).
    ///
    /// # Errors
    /// As [`TemplateSet::subtract_block_common`], plus [`DspError::UnsupportedLength`] for more
    /// than 2³¹ samples and [`DspError::OutOfRange`] as [`TemplateSetQ15::subtract_in_place`].
    pub fn subtract_block_common(&self, frames: &mut [CQ15]) -> Result<[C32; P], DspError> {
        let count = check_common(self.bins, frames.len())?;
        if frames.len() > MAX_Q15_CORR_LEN {
            return Err(DspError::UnsupportedLength {
                what: "frames (Q15 common fit, at most 2^31 samples)",
                len: frames.len(),
            });
        }
        let mut r = [Complex::new(0i64, 0i64); P];
        for frame in frames.chunks_exact(self.bins) {
            for (a, b) in r.iter_mut().zip(&self.correlate(frame)?) {
                *a += b;
            }
        }
        let w = BlockWeights::<P>::quantize(&self.solve(r, count)?, P)?;
        let mut g = [C32::new(0.0, 0.0); P];
        for frame in frames.chunks_exact_mut(self.bins) {
            g = self.apply(frame, &w);
        }
        Ok(g)
    }

    /// [`TemplateSetQ15::subtract_in_place`] for a block of frames; layout and errors as
    /// [`TemplateSet::subtract_block`].
    pub fn subtract_block(&self, frames: &mut [CQ15], gains: &mut [C32]) -> Result<(), DspError> {
        check_block::<P>(self.bins, frames.len(), gains.len())?;
        for (frame, g) in frames
            .chunks_exact_mut(self.bins)
            .zip(gains.chunks_exact_mut(P))
        {
            g.copy_from_slice(&self.subtract_in_place(frame)?);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixed::{cq15_from_c32, cq15_to_c32};

    use crate::test_util::{db, energy, lcg_signal};

    #[test]
    fn exact_scaled_rotated_template_leaves_residual_below_minus_60_db() {
        let bins = 1024;
        let t = lcg_signal(1, bins, 1.0);
        // The frame is g·t formed in f64 and rounded to f32 once (g = 3.7·e^{j2.1} is not an f32
        // value), so the f32 path cannot reproduce it bit for bit.
        let g = C64::from_polar(3.7, 2.1);
        let mut y: Vec<C32> = t
            .iter()
            .map(|v| {
                let z = g * C64::new(v.re as f64, v.im as f64);
                C32::new(z.re as f32, z.im as f32)
            })
            .collect();
        let e_in = energy(&y);
        let set = Template::new(&t, bins, 0.0).unwrap();
        let gain = set.subtract_in_place(&mut y).unwrap()[0];
        let r = db(energy(&y) / e_in);
        // f32 arithmetic: the frame's rounding, the gain's rounding to f32 and each product g·t
        // and subtraction round at ≤ 2⁻²⁴ relative (uniform: rms ≈ −149 dB each), so the
        // residual is ≈ −145 dB; the specification asks for ≤ −60 dB.
        std::println!("exact template: residual {r:.1} dB");
        assert!(r <= -60.0, "residual {r:.1} dB");
        let g = C32::new(g.re as f32, g.im as f32);
        assert!((gain - g).norm() < 1e-5 * g.norm());
    }

    #[test]
    fn target_survives_template_subtraction() {
        // Clutter = 2.5·e^{j0.4}·t; target: a point response in bin 300 (a unit impulse), 20 dB
        // below the clutter's per-bin power. Its projection on t removes |t[300]|²/‖t‖² ≈ 1/bins
        // of its energy (≈ −0.004 dB) and the fitted gain moves by target·conj(t[300])/‖t‖².
        let bins = 1024;
        let t = lcg_signal(2, bins, 1.0);
        let clutter_gain = C32::from_polar(2.5, 0.4);
        let a_t = C32::new(0.25, 0.1);
        let mut y: Vec<C32> = t.iter().map(|v| clutter_gain * v).collect();
        y[300] += a_t;
        Template::new(&t, bins, 0.0)
            .unwrap()
            .subtract_in_place(&mut y)
            .unwrap();
        let loss_db = db(y[300].norm_sqr() as f64 / a_t.norm_sqr() as f64);
        assert!(loss_db.abs() < 0.1, "target changed by {loss_db:.3} dB");
        // Everything else is only the target's leakage a_t·conj(t[300])·t[n]/‖t‖².
        let rest: f64 = y
            .iter()
            .enumerate()
            .filter(|(n, _)| *n != 300)
            .map(|(_, z)| z.norm_sqr() as f64)
            .sum();
        assert!(rest < 2.0 * a_t.norm_sqr() as f64 / bins as f64 * 2.0);
    }

    #[test]
    fn two_templates_are_both_removed_and_gains_recovered() {
        let bins = 512;
        let mut ts = lcg_signal(3, bins, 1.0);
        ts.extend(lcg_signal(4, bins, 0.5));
        let (g0, g1) = (C32::new(1.0, -2.0), C32::new(-0.5, 0.25));
        let mut y: Vec<C32> = (0..bins).map(|n| g0 * ts[n] + g1 * ts[bins + n]).collect();
        let e_in = energy(&y);
        let g = TemplateSet::<2>::new(&ts, bins, 0.0)
            .unwrap()
            .subtract_in_place(&mut y)
            .unwrap();
        assert!(db(energy(&y) / e_in) <= -60.0);
        assert!((g[0] - g0).norm() < 1e-4 && (g[1] - g1).norm() < 1e-4);
    }

    #[test]
    fn block_api_fits_a_gain_per_frame() {
        let bins = 256;
        let t = lcg_signal(5, bins, 0.8);
        let frames = 4;
        let mut y = Vec::new();
        let truth: Vec<C32> = (0..frames)
            .map(|f| C32::from_polar(1.0 + f as f32, 0.3 * f as f32))
            .collect();
        for g in &truth {
            y.extend(t.iter().map(|v| g * v));
        }
        let mut gains = [C32::new(0.0, 0.0); 4];
        Template::new(&t, bins, 0.0)
            .unwrap()
            .subtract_block(&mut y, &mut gains)
            .unwrap();
        for (g, tr) in gains.iter().zip(&truth) {
            assert!((g - tr).norm() < 1e-5 * tr.norm());
        }
        assert!(y.iter().all(|z| z.norm() < 1e-5));
    }

    #[test]
    fn common_block_fit_recovers_the_static_gain_under_a_moving_target() {
        // Eight frames of the same static response g·t plus a target moving 10 bins per frame.
        // The common gain is off by δ = Σ_f a·conj(t[b_f]) / (F·‖t‖²), |δ| ≤ a·max|t|/‖t‖²
        // = 0.3·(0.8·√2)/109 = 3.1·10⁻³ for components of t uniform in ±0.8
        // (‖t‖² ≈ 256·2·0.8²/3 = 109): assert < 4·10⁻³. The target loses g's error times t at its
        // bin, ≤ |δ|·1.13 ≈ 3.5·10⁻³ of 0.3 → 0.10 dB at worst; assert < 0.11 dB.
        let bins = 256;
        let frames = 8;
        let t = lcg_signal(21, bins, 0.8);
        let g = C32::from_polar(1.3, -0.6);
        let a = C32::new(0.3, 0.0);
        let mut y = Vec::new();
        for f in 0..frames {
            let mut fr: Vec<C32> = t.iter().map(|v| g * v).collect();
            fr[20 + 10 * f] += a;
            y.extend(fr);
        }
        let mut yq: Vec<CQ15> = y.iter().map(|&v| cq15_from_c32(v * 0.5)).collect();
        let got = Template::new(&t, bins, 0.0)
            .unwrap()
            .subtract_block_common(&mut y)
            .unwrap()[0];
        assert!((got - g).norm() < 4e-3, "{got} vs {g}");
        for f in 0..frames {
            let v = y[f * bins + 20 + 10 * f];
            assert!(db(v.norm_sqr() as f64 / a.norm_sqr() as f64).abs() < 0.11);
        }
        // Q15, same data at half scale: the same gain (within the f32 bound above plus the
        // quantisation of t, y: relative ≈ LSB/0.4 per sample, averaged over 2048 samples).
        let tq: Vec<CQ15> = t.iter().map(|&v| cq15_from_c32(v)).collect();
        let gq = TemplateQ15::new(&tq, bins, 0.0)
            .unwrap()
            .subtract_block_common(&mut yq)
            .unwrap()[0];
        assert!((gq - g * 0.5).norm() < 0.5 * 4e-3 + 1e-4, "{gq}");
    }

    #[test]
    fn q15_exact_template_leaves_only_rounding() {
        // Template at −6 dBFS; frame = g·t rounded to Q15. After subtraction each residual sample
        // is the frame's rounding error (≤ ½ LSB per part) plus the output rounding (≤ ½ LSB)
        // plus g's quantisation: |residual part| ≤ 1 LSB + |t|·2⁻²⁹ → at most 2 LSB.
        let bins = 512;
        let tf = lcg_signal(6, bins, 0.5);
        let t: Vec<CQ15> = tf.iter().map(|&v| cq15_from_c32(v)).collect();
        let g = C32::from_polar(0.9, -1.0);
        let mut y: Vec<CQ15> = t
            .iter()
            .map(|&v| cq15_from_c32(g * cq15_to_c32(v)))
            .collect();
        let set = TemplateQ15::new(&t, bins, 0.0).unwrap();
        let gain = set.subtract_in_place(&mut y).unwrap()[0];
        assert!((gain - g).norm() < 1e-4);
        for z in &y {
            assert!(z.re.0.abs() <= 2 && z.im.0.abs() <= 2, "{z:?}");
        }
    }

    #[test]
    fn q15_residual_saturates_instead_of_wrapping() {
        // Template +t, frame = −t at full scale with one bin forced to the opposite sign: that
        // bin's residual y − g·t = 2·full scale must clamp to the Q15 range, not wrap.
        let bins = 64;
        let t: Vec<CQ15> = lcg_signal(7, bins, 0.99)
            .iter()
            .map(|&v| cq15_from_c32(v))
            .collect();
        let mut y: Vec<CQ15> = t.iter().map(|v| Complex::new(-v.re, -v.im)).collect();
        y[0] = Complex::new(crate::fixed::Q15::MAX, crate::fixed::Q15::MAX);
        let t0 = cq15_to_c32(t[0]);
        let set = TemplateQ15::new(&t, bins, 0.0).unwrap();
        let g = set.subtract_in_place(&mut y).unwrap()[0];
        // g ≈ −1 + small; residual[0] ≈ (1 + t0.re, 1 + t0.im): saturated where it exceeds 1.
        let expect = C32::new(1.0, 1.0) - g * t0;
        let got = cq15_to_c32(y[0]);
        for (e, v) in [(expect.re, got.re), (expect.im, got.im)] {
            let clamped = e.clamp(-1.0, 1.0 - 1.0 / 32768.0);
            assert!((clamped - v).abs() <= 2.0 / 32768.0, "{e} → {v}");
        }
    }

    /// A frame enormous against a tiny template used to give gains beyond `f32` and a residual
    /// of −∞ + NaN·j, returned as `Ok`. Now a gain beyond `f32` is an error naming `gains` with
    /// its (infinite) value, a residual that would overflow is an error naming `residual`, and
    /// neither touches the frame.
    #[test]
    fn a_result_beyond_the_f32_range_is_an_error_not_ok() {
        let t = [C32::new(1e-19, 0.0); 64];
        let set = Template::new(&t, 64, 0.0).unwrap();
        let mut y = [C32::new(1e20, 0.0); 64];
        let before = y;
        match set.subtract_in_place(&mut y) {
            Err(DspError::OutOfRange { what, value }) => {
                assert!(what.starts_with("gains"), "{what}");
                assert!(value.is_infinite(), "{value}");
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(y, before);
        assert!(set.fit(&y).is_err());
        let mut block = [C32::new(1e20, 0.0); 128];
        assert!(set.subtract_block_common(&mut block).is_err());
        assert!(block.iter().all(|z| *z == C32::new(1e20, 0.0)));
        let mut gains = [C32::new(0.0, 0.0); 2];
        assert!(set.subtract_block(&mut block, &mut gains).is_err());

        // Finite gains whose residual overflows: y = (3, −3, −3)·10³⁸ against t = (1, 1, 1). The
        // correlation stays finite (partial sums 3e38, 0, −3e38) and g = −10³⁸, but
        // y₀ − g·t₀ = 4·10³⁸ exceeds f32 (the residual is contracting only in the 2-norm).
        let t = [C32::new(1.0, 0.0); 3];
        let set = Template::new(&t, 3, 0.0).unwrap();
        let mut y: Vec<C32> = [3e38f32, -3e38, -3e38]
            .iter()
            .map(|&v| C32::new(v, 0.0))
            .collect();
        let before = y.clone();
        let g = set.fit(&y).unwrap();
        assert!(g[0].re.is_finite());
        assert_eq!(
            set.subtract_in_place(&mut y),
            Err(DspError::NonFinite {
                what: "residual (y − T·g beyond the f32 range)"
            })
        );
        assert_eq!(y, before);

        // Large but representable: the exact check passes and the result is finite and right.
        let mut y: Vec<C32> = t.iter().map(|v| v * 1e38).collect();
        let g = set.subtract_in_place(&mut y).unwrap();
        assert!((g[0].re - 1e38).abs() <= 1e32, "{g:?}");
        assert!(y.iter().all(|z| z.re.is_finite() && z.im.is_finite()));
    }

    #[test]
    fn bad_inputs_are_errors_not_panics() {
        let t = lcg_signal(8, 16, 0.5);
        let zero = [C32::new(0.0, 0.0); 16];
        assert!(matches!(
            Template::new(&zero, 16, 0.0),
            Err(DspError::OutOfRange {
                what: "template energy (tᴴt, must be > 0)",
                ..
            })
        ));
        assert!(matches!(
            Template::new(&t, 15, 0.0),
            Err(DspError::LengthMismatch { .. })
        ));
        assert!(matches!(
            Template::new(&t[..0], 0, 0.0),
            Err(DspError::UnsupportedLength { .. })
        ));
        let mut nan_t = t.clone();
        nan_t[3].re = f32::NAN;
        assert!(matches!(
            Template::new(&nan_t, 16, 0.0),
            Err(DspError::NonFinite { what: "template" })
        ));
        assert!(matches!(
            Template::new(&t, 16, -1.0),
            Err(DspError::OutOfRange { .. })
        ));
        let mut dup = t.clone();
        dup.extend_from_slice(&t);
        assert!(matches!(
            TemplateSet::<2>::new(&dup, 16, 0.0),
            Err(DspError::NotPositiveDefinite { .. })
        ));
        let set = Template::new(&t, 16, 0.0).unwrap();
        let mut y = lcg_signal(9, 16, 0.5);
        y[5].im = f32::INFINITY;
        assert_eq!(
            set.subtract_in_place(&mut y),
            Err(DspError::NonFinite { what: "frame" })
        );
        assert!(matches!(
            set.fit(&y[..8]),
            Err(DspError::LengthMismatch { .. })
        ));
        let mut frames = lcg_signal(10, 48, 0.5);
        let mut gains = [C32::new(0.0, 0.0); 2];
        assert!(matches!(
            set.subtract_block(&mut frames, &mut gains),
            Err(DspError::LengthMismatch { .. })
        ));
        let mut gains3 = [C32::new(0.0, 0.0); 3];
        let t2 = lcg_signal(11, 32, 0.5);
        let set2 = TemplateSet::<2>::new(&t2, 16, 0.0).unwrap();
        assert!(matches!(
            set2.subtract_block(&mut frames, &mut gains3),
            Err(DspError::LengthMismatch { .. })
        ));

        // Common fit: empty, not a multiple, non-finite (frames untouched).
        assert!(matches!(
            set.subtract_block_common(&mut []),
            Err(DspError::LengthMismatch { .. })
        ));
        let mut odd = lcg_signal(12, 20, 0.5);
        assert!(matches!(
            set.subtract_block_common(&mut odd),
            Err(DspError::LengthMismatch { .. })
        ));
        let mut bad = lcg_signal(13, 32, 0.5);
        bad[20].re = f32::NAN;
        let before = bad.clone();
        assert_eq!(
            set.subtract_block_common(&mut bad),
            Err(DspError::NonFinite { what: "frame" })
        );
        assert_eq!(bad[..20], before[..20]);

        // Q15.
        let tq: Vec<CQ15> = t.iter().map(|&v| cq15_from_c32(v)).collect();
        let zq = [cq15_from_c32(C32::new(0.0, 0.0)); 16];
        assert!(matches!(
            TemplateQ15::new(&zq, 16, 0.0),
            Err(DspError::OutOfRange { .. })
        ));
        assert!(matches!(
            TemplateQ15::new(&tq, 17, 0.0),
            Err(DspError::LengthMismatch { .. })
        ));
        let setq = TemplateQ15::new(&tq, 16, 0.0).unwrap();
        let mut yq = tq.clone();
        assert!(matches!(
            setq.subtract_in_place(&mut yq[..15]),
            Err(DspError::LengthMismatch { .. })
        ));
        assert!(matches!(
            setq.fit(&yq[..1]),
            Err(DspError::LengthMismatch { .. })
        ));
        let mut oddq = tq[..10].to_vec();
        assert!(matches!(
            setq.subtract_block_common(&mut oddq),
            Err(DspError::LengthMismatch { .. })
        ));
        let mut fq = tq.clone();
        let mut g2 = [C32::new(0.0, 0.0); 2];
        assert!(matches!(
            setq.subtract_block(&mut fq, &mut g2),
            Err(DspError::LengthMismatch { .. })
        ));
    }
}
