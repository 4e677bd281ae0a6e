//! The per-frame signal chain of moving-target sensing (paper Fig. 10), driving has-dsp: range
//! compression → clutter suppression → Doppler processing → 2-D beamforming → CA-CFAR → points.
//!
//! **Data layout.** A frame (one CPI) is `M` sensing symbols × `E = rows·cols` receive elements ×
//! `nb` range bins of the processed window, stored `[m][e][b]` (element `e = row·cols + col`, row 0
//! at the bottom, column along the panel's horizontal tangent, see
//! [`crate::imaging::PlanarArray`]). Range bin `b` is the profile bin `bin0 + b` of has-dsp's range
//! compressor, bistatic path `(bin0 + b)·c/(B·zero_pad)`; with the transmit element at the array
//! centre the monostatic range is half of it.
//!
//! **Clutter suppression** ([`Suppression`]):
//! * ECA. For OFDM with a cyclic prefix and a unit-modulus sensing symbol repeated every slot,
//!   the fast-time ECA basis `{S[m,k]·e^{−j2πkℓ/n}·e^{j2πdm/M}}` over all delays `ℓ < n` is
//!   orthogonal, and projecting the CPI off it is exactly, after matched-filter range
//!   compression, projecting every range bin's slow-time sequence off the `D` lowest Doppler
//!   harmonics (range compression acts on `k`, the projection on `m`: they commute). The chain
//!   therefore runs has-dsp's [`Eca`] per element and range bin on the `M` slow-time samples with
//!   a reference of ones (`K = 1`), in its Block / Batched (ECA-B) / Sliding (ECA-S) forms.
//! * Gated ECA (environment prior). The same projection is linear and identical for every
//!   element, so it commutes with beamforming too; the environment mode applies it after
//!   beamforming, only in the (range, beam) cells where the twin predicts static clutter
//!   ([`Chain::gate_from_prediction`]), so a target crossing at zero Doppler elsewhere survives.
//! * Template subtraction ([`subtract_templates`]): the static response predicted from the twin,
//!   split into range segments, fitted by complex gains over the CPI (has-dsp
//!   [`TemplateSet::subtract_block_common`]) and subtracted before anything else.
//!
//! **Beamforming.** Per range bin and symbol a 2-D FFT of the tapered element grid (Taylor
//! n̄ = 4, −35 dB per axis), zero-padded to `angle_fft`; bin `k` (signed) of an axis with spacing
//! `d` looks along direction cosine `u = k·λ/(angle_fft·d)` on that axis (a source at `û` gives
//! the element phase `e^{+j2π û·Δe/λ}`, matched by the forward FFT's `e^{−j2πkc/N}`). Normalised
//! by the taper's sum, so a unit plane wave from the beam's direction gives 1. Only the beams of
//! the searched field of view (a rectangle in `(u_t, u_z)`) are kept.
//!
//! **Doppler.** Hann over the `M` symbols, zero-padded to `doppler_fft`, power normalised by
//! `(Σw)²` (a static unit echo gives 1 at Doppler 0). Doppler bin `d` (signed) is
//! `d/(doppler_fft·T)` Hz.
//!
//! **Detection.** CA-CFAR ([`has_dsp::cfar::CaCfar`]) along range for every (Doppler, beam) line,
//! told the power correlation of neighbouring range bins (zero-padded, windowed profiles) so that
//! it holds its design false-alarm rate.
//! An extended target fills many resolution cells, and its strong echo also crosses the CFAR
//! threshold in the angle sidelobes of the beamformer (Taylor −35 dB) and in the range sidelobes;
//! a hit therefore counts only if it lies within `extent_db` of the strongest cell of its
//! (range, Doppler) slice (the target's image extent; the sidelobes lie below it). A (range, beam)
//! cell is detected when any of its Doppler bins is; each detected cell is one point, at the cell
//! centre `centre + R·û` (the extended target's image, as in the paper's Fig. 11).

use glam::Vec3;
use has_dsp::cfar::CaCfar;
use has_dsp::eca::{Eca, EcaFactor, EcaVariant};
use has_dsp::fft::fft_c32;
use has_dsp::range::{RangeCompressor, RangeConfig, RangeMode};
use has_dsp::template::TemplateSet;
use has_dsp::window::Window;
use has_dsp::DspError;
use num_complex::Complex32 as C32;
use rayon::prelude::*;

use super::LocalizeError;
use crate::imaging::PlanarArray;
use crate::scenario::LocalizeSpec;

/// Columns of the ECA basis used here (`K = 1` delay × up to 3 Doppler bins).
pub const ECA_M: usize = 4;

/// A clutter-suppression configuration of the slow-time projection.
#[derive(Clone, Debug)]
pub struct SlowTimeEca {
    eca: Eca<ECA_M>,
    factors: Vec<EcaFactor<ECA_M>>,
    ones: Vec<C32>,
    /// Label for reports (`"ECA"`, `"ECA-B"`, ...).
    pub label: String,
}

impl SlowTimeEca {
    /// ECA over `m` symbols with `dopplers` (odd) Doppler columns and the variant, factored once
    /// (the reference, all ones, is shared by every element, range bin and beam).
    ///
    /// # Errors
    /// [`LocalizeError::Dsp`] from has-dsp for a bad configuration.
    pub fn new(
        m: usize,
        dopplers: usize,
        variant: EcaVariant,
        label: impl Into<String>,
    ) -> Result<Self, LocalizeError> {
        let eca = Eca::<ECA_M>::new(1, dopplers, variant, 0.0).map_err(dsp("eca"))?;
        let ones = vec![C32::new(1.0, 0.0); eca.reference_len(m)];
        let mut factors = vec![EcaFactor::new(); eca.windows(m).map_err(dsp("eca"))?];
        eca.factor_f32(&ones, m, &mut factors).map_err(dsp("eca"))?;
        Ok(Self {
            eca,
            factors,
            ones,
            label: label.into(),
        })
    }

    /// Projects one slow-time sequence in place (`buf` is scratch of the same length).
    fn apply(&self, seq: &mut [C32], buf: &mut [C32]) -> Result<(), DspError> {
        self.eca
            .cancel_with_f32(&self.factors, &self.ones, seq, buf)?;
        seq.copy_from_slice(buf);
        Ok(())
    }
}

/// Which suppression a pass applies.
#[derive(Clone, Copy, Debug)]
pub enum Suppression<'a> {
    /// None (the map before suppression).
    None,
    /// ECA per element and range bin.
    PerElement(&'a SlowTimeEca),
    /// ECA after beamforming, in the cells where `gate[b·beams + beam]` is true.
    Gated(&'a SlowTimeEca, &'a [bool]),
}

/// One pass's range × Doppler × beam power cube and its energy.
#[derive(Clone, Debug)]
pub struct Cube {
    /// Power, `[b][d][beam]` (Doppler in FFT order), linear.
    pub power: Vec<f32>,
    /// Energy of the beamformed slow-time data after suppression (Σ|y|² over range bins, symbols
    /// and beams of the field of view).
    pub energy: f64,
}

/// The environment's clutter map: the twin's smoothed static power per (range, beam) cell and
/// the Doppler response of a static echo; a CFAR hit must also exceed the predicted static
/// clutter at its Doppler bin by `margin_db`.
#[derive(Clone, Debug)]
pub struct ClutterMap {
    /// Smoothed predicted static power per cell (`[b][beam]`, per-symbol units).
    pub level: Vec<f32>,
    /// Static response per Doppler bin ([`Chain::static_doppler_response`]).
    pub doppler: Vec<f32>,
    /// Margin, linear.
    pub margin: f32,
}

impl ClutterMap {
    /// The map's threshold for cell `cell` at Doppler bin `d`.
    #[inline]
    pub fn threshold(&self, cell: usize, d: usize) -> f32 {
        self.level[cell] * self.doppler[d] * self.margin
    }
}

/// One detected point.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Detection {
    /// Position, metres.
    pub pos: Vec3,
    /// Monostatic range, metres.
    pub range_m: f32,
    /// Doppler of the strongest detected bin, Hz.
    pub doppler_hz: f32,
    /// Doppler-maximum power of the cell, relative to the noise power per cell (dB).
    pub snr_db: f32,
}

/// The chain's fixed configuration (`&self` everywhere; per-frame buffers are the caller's or
/// per worker).
#[derive(Clone, Debug)]
pub struct Chain {
    /// The range compressor.
    pub rc: RangeCompressor,
    reference: Vec<C32>,
    /// The sensing symbol `S` (repeated every slot).
    pub symbol: Vec<C32>,
    /// First profile bin of the processed window.
    pub bin0: usize,
    /// Range bins processed.
    pub nb: usize,
    /// Bistatic path per bin, metres.
    pub bin_m: f64,
    /// Symbols per CPI.
    pub m: usize,
    /// Slow-time interval, seconds.
    pub t_sym_s: f64,
    /// Doppler FFT size.
    pub nd: usize,
    w_dop: Vec<f32>,
    dop_norm: f32,
    /// The receive panel.
    pub array: PlanarArray,
    na: usize,
    w_row: Vec<f32>,
    w_col: Vec<f32>,
    bf_norm: f32,
    /// Signed azimuth FFT bins of the field of view, first.
    pub kc0: i32,
    /// Number of azimuth beams.
    pub n_az: usize,
    /// Signed elevation FFT bins of the field of view, first.
    pub kr0: i32,
    /// Number of elevation beams.
    pub n_el: usize,
    u_step_t: f32,
    u_step_z: f32,
    valid: Vec<bool>,
    /// The detector.
    pub cfar: CaCfar,
    /// Extent test: a CFAR hit counts only within this many dB of the strongest cell of its
    /// (range, Doppler) slice.
    pub extent_db: f32,
    /// Noise power per (range bin, beam) cell and symbol, before Doppler processing.
    pub noise_cell: f64,
    /// Doppler integration gain for a static echo, `(Σw)²/Σw²`.
    pub doppler_gain: f64,
    lambda: f32,
}

fn dsp(what: &'static str) -> impl Fn(DspError) -> LocalizeError {
    move |e| LocalizeError::Dsp { what, source: e }
}

/// A symmetric taper over `n` samples from has-dsp's FFT-order window (peak at the centre).
fn taper(window: Window, n: usize) -> Result<Vec<f32>, LocalizeError> {
    let mut w = vec![0.0f32; n];
    window.fill_f32(&mut w).map_err(dsp("taper"))?;
    Ok((0..n).map(|i| w[(i + n - n / 2) % n]).collect())
}

impl Chain {
    /// Builds the chain of a validated spec; `symbol` is the sensing symbol (unit modulus).
    ///
    /// # Errors
    /// [`LocalizeError`] from has-dsp or a field of the spec.
    pub fn new(spec: &LocalizeSpec, symbol: Vec<C32>) -> Result<Self, LocalizeError> {
        let rc = RangeCompressor::new(RangeConfig {
            n_subcarriers: spec.subcarriers,
            bandwidth_hz: spec.bandwidth_hz(),
            zero_pad: spec.zero_pad,
            mode: RangeMode::Matched,
            window: spec.window()?,
            q15_scaling: has_dsp::fft::Q15Scaling::Block,
        })
        .map_err(dsp("range compressor"))?;
        let mut reference = vec![C32::new(0.0, 0.0); spec.subcarriers];
        rc.prepare_reference(&symbol, &mut reference)
            .map_err(dsp("range reference"))?;
        let bin_m = rc.bin_spacing_m();
        let bin0 = (2.0 * spec.range_min_m as f64 / bin_m).floor() as usize;
        let bin1 =
            ((2.0 * spec.range_max_m as f64 / bin_m).ceil() as usize).min(rc.profile_len() - 1);
        // The CFAR window, 2·(guard + train) + 1 bins: longer than the whole profile, no range
        // window can hold it and the guard is what is wrong.
        let window = spec
            .cfar_guard
            .checked_add(spec.cfar_train)
            .and_then(|h| h.checked_mul(2))
            .filter(|&w| w < rc.profile_len());
        let Some(window) = window else {
            return Err(LocalizeError::Config(
                crate::scenario::ScenarioError::Invalid {
                    field: "localize.cfar_guard".into(),
                    value: format!("{}", spec.cfar_guard),
                    expected:
                        "a CFAR window (2·(guard + train) + 1 bins) shorter than the range profile",
                },
            ));
        };
        if bin1 <= bin0 + window {
            return Err(LocalizeError::Config(crate::scenario::ScenarioError::Invalid {
                field: "localize.range_max_m".into(),
                value: format!("{}", spec.range_max_m),
                expected: "a range window longer than the CFAR window and inside the unambiguous range",
            }));
        }
        let nb = bin1 - bin0 + 1;
        let array = spec.array();
        let lambda = spec.wavelength_m() as f32;
        let (dt, dz) = array.spacing_m();
        let na = spec.angle_fft;
        let u_step_t = lambda / (na as f32 * dt);
        let u_step_z = lambda / (na as f32 * dz);
        let ut_max = spec.fov_azimuth_deg.to_radians().sin();
        let [el_lo, el_hi] = spec.fov_elevation_deg;
        let half = (na / 2) as i32;
        let kc0 = (-(ut_max / u_step_t).floor() as i32).max(-half);
        let kc1 = ((ut_max / u_step_t).floor() as i32).min(half - 1);
        let kr0 = ((el_lo.to_radians().sin() / u_step_z).ceil() as i32).max(-half);
        let kr1 = ((el_hi.to_radians().sin() / u_step_z).floor() as i32).min(half - 1);
        if kc1 < kc0 || kr1 < kr0 {
            return Err(LocalizeError::Config(
                crate::scenario::ScenarioError::Invalid {
                    field: "localize.fov_elevation_deg".into(),
                    value: format!("{:?}", spec.fov_elevation_deg),
                    expected: "a field of view holding at least one beam",
                },
            ));
        }
        let n_az = (kc1 - kc0 + 1) as usize;
        let n_el = (kr1 - kr0 + 1) as usize;
        let mut valid = vec![false; n_az * n_el];
        for ie in 0..n_el {
            for ia in 0..n_az {
                let ut = (kc0 + ia as i32) as f32 * u_step_t;
                let uz = (kr0 + ie as i32) as f32 * u_step_z;
                valid[ie * n_az + ia] = ut * ut + uz * uz < 0.98;
            }
        }
        let taylor = Window::Taylor {
            nbar: 4,
            sll_db: -35.0,
        };
        let w_row = taper(taylor, spec.rows)?;
        let w_col = taper(taylor, spec.cols)?;
        let sum_s: f64 = w_row.iter().map(|&a| a as f64).sum::<f64>()
            * w_col.iter().map(|&a| a as f64).sum::<f64>();
        let sum_s2: f64 = w_row.iter().map(|&a| (a * a) as f64).sum::<f64>()
            * w_col.iter().map(|&a| (a * a) as f64).sum::<f64>();
        let w_dop = taper(Window::Hann, spec.symbols)?;
        let sd: f64 = w_dop.iter().map(|&a| a as f64).sum();
        let sd2: f64 = w_dop.iter().map(|&a| (a * a) as f64).sum();
        // Range-compressed noise per bin: σ²·Σw²/(Σw)² with the compressor's weights.
        let mut wr = vec![0.0f32; spec.subcarriers];
        rc.fill_weights(&mut wr).map_err(dsp("range weights"))?;
        let sr: f64 = wr.iter().map(|&a| a as f64).sum();
        let sr2: f64 = wr.iter().map(|&a| (a * a) as f64).sum();
        let noise_cell = spec.noise_power() * sr2 / (sr * sr) * sum_s2 / (sum_s * sum_s);
        // The CFAR runs along range over zero-padded, windowed profiles: neighbouring bins are
        // correlated, which the detector must know to hold its design false-alarm rate.
        let mut power_corr = vec![0.0f64; spec.cfar_train.saturating_sub(1)];
        rc.noise_power_correlation(&mut power_corr);
        let cfar = CaCfar::with_power_correlation(
            spec.cfar_train,
            spec.cfar_guard,
            spec.cfar_pfa,
            &power_corr,
        )
        .map_err(dsp("cfar"))?;
        Ok(Chain {
            rc,
            reference,
            symbol,
            bin0,
            nb,
            bin_m,
            m: spec.symbols,
            t_sym_s: spec.symbol_interval_ms * 1e-3,
            nd: spec.doppler_fft,
            dop_norm: (1.0 / (sd * sd)) as f32,
            w_dop,
            array,
            na,
            w_row,
            w_col,
            bf_norm: (1.0 / sum_s) as f32,
            kc0,
            n_az,
            kr0,
            n_el,
            u_step_t,
            u_step_z,
            valid,
            cfar,
            extent_db: spec.extent_db,
            noise_cell,
            doppler_gain: sd * sd / sd2,
            lambda,
        })
    }

    /// Receive elements.
    pub fn elements(&self) -> usize {
        self.array.rows * self.array.cols
    }

    /// Beams of the field of view (`n_az · n_el`, index `ie·n_az + ia`).
    pub fn beams(&self) -> usize {
        self.n_az * self.n_el
    }

    /// Samples of one frame, `M·E·nb`.
    pub fn frame_len(&self) -> usize {
        self.m * self.elements() * self.nb
    }

    /// Range-compresses one received OFDM symbol `y` (subcarriers, FFT order) of one element
    /// into `out` (`nb` bins of the processed window), using `profile` as scratch (`n·zero_pad`).
    ///
    /// # Errors
    /// [`LocalizeError::Dsp`] from has-dsp (lengths).
    pub fn compress(
        &self,
        y: &[C32],
        profile: &mut [C32],
        out: &mut [C32],
    ) -> Result<(), LocalizeError> {
        self.rc
            .compress(y, &self.reference, profile)
            .map_err(dsp("range compression"))?;
        let src = profile
            .get(self.bin0..self.bin0 + self.nb)
            .ok_or(LocalizeError::Internal("profile window"))?;
        if out.len() != self.nb {
            return Err(LocalizeError::Internal("compressed row length"));
        }
        out.copy_from_slice(src);
        Ok(())
    }

    /// Direction cosines `(u_t, u_z)` of beam `(ia, ie)` (fractional indices allowed).
    pub fn beam_u(&self, ia: f32, ie: f32) -> (f32, f32) {
        (
            (self.kc0 as f32 + ia) * self.u_step_t,
            (self.kr0 as f32 + ie) * self.u_step_z,
        )
    }

    /// The beam whose direction is closest to `p` (a point in the scene).
    pub fn beam_towards(&self, p: Vec3) -> usize {
        let d = (p - self.array.centre).normalize_or_zero();
        let ut = d.dot(self.array.tangent());
        let uz = d.z;
        let ia = ((ut / self.u_step_t).round() as i32 - self.kc0).clamp(0, self.n_az as i32 - 1);
        let ie = ((uz / self.u_step_z).round() as i32 - self.kr0).clamp(0, self.n_el as i32 - 1);
        ie as usize * self.n_az + ia as usize
    }

    /// Position of fractional cell (range bin, azimuth, elevation).
    pub fn cell_position(&self, b: f32, ia: f32, ie: f32) -> Vec3 {
        let range = ((self.bin0 as f64 + b as f64) * self.bin_m * 0.5) as f32;
        let (ut, uz) = self.beam_u(ia, ie);
        let un = (1.0 - ut * ut - uz * uz).max(0.0).sqrt();
        let dir = self.array.boresight() * un + self.array.tangent() * ut + Vec3::Z * uz;
        self.array.centre + dir * range
    }

    /// Doppler frequency of FFT bin `d`, Hz.
    pub fn doppler_hz(&self, d: usize) -> f32 {
        let s = if d < self.nd / 2 {
            d as f64
        } else {
            d as f64 - self.nd as f64
        };
        (s / (self.nd as f64 * self.t_sym_s)) as f32
    }

    /// Beamforms one element grid (`E` samples) into the field-of-view beams (`out`, `beams()`),
    /// with scratch `rows_fft` (`rows · na`) and `col` (`na`).
    fn beamform(
        &self,
        x: &[C32],
        rows_fft: &mut [C32],
        col: &mut [C32],
        out: &mut [C32],
    ) -> Result<(), DspError> {
        let (rows, cols, na) = (self.array.rows, self.array.cols, self.na);
        for r in 0..rows {
            let row = &mut rows_fft[r * na..(r + 1) * na];
            row.fill(C32::new(0.0, 0.0));
            let wr = self.w_row[r] * self.bf_norm;
            for c in 0..cols {
                row[c] = x[r * cols + c] * (wr * self.w_col[c]);
            }
            fft_c32(row)?;
        }
        for ia in 0..self.n_az {
            let kc = (self.kc0 + ia as i32).rem_euclid(na as i32) as usize;
            col.fill(C32::new(0.0, 0.0));
            for r in 0..rows {
                col[r] = rows_fft[r * na + kc];
            }
            fft_c32(col)?;
            for ie in 0..self.n_el {
                let kr = (self.kr0 + ie as i32).rem_euclid(na as i32) as usize;
                out[ie * self.n_az + ia] = col[kr];
            }
        }
        Ok(())
    }

    /// Beamforms one static prediction (`E·nb`, layout `[e][b]`) into `[b][beam]` powers.
    ///
    /// # Errors
    /// [`LocalizeError`] for a wrong length.
    pub fn beam_power_static(&self, x: &[C32]) -> Result<Vec<f32>, LocalizeError> {
        let (e_n, nb, beams) = (self.elements(), self.nb, self.beams());
        if x.len() != e_n * nb {
            return Err(LocalizeError::Internal("static prediction length"));
        }
        let mut out = vec![0.0f32; nb * beams];
        out.par_chunks_mut(beams)
            .enumerate()
            .try_for_each(|(b, o)| -> Result<(), DspError> {
                let grid: Vec<C32> = (0..e_n).map(|e| x[e * nb + b]).collect();
                let mut rows_fft = vec![C32::new(0.0, 0.0); self.array.rows * self.na];
                let mut col = vec![C32::new(0.0, 0.0); self.na];
                let mut y = vec![C32::new(0.0, 0.0); beams];
                self.beamform(&grid, &mut rows_fft, &mut col, &mut y)?;
                for (p, v) in o.iter_mut().zip(&y) {
                    *p = v.norm_sqr();
                }
                Ok(())
            })
            .map_err(dsp("beamforming"))?;
        Ok(out)
    }

    /// The speckle average of a predicted static power map (`[b][beam]`): the mean over each
    /// cell's 3 × 3 × 3 (range, azimuth, elevation) neighbourhood, an estimate of the expected
    /// clutter power there (one realisation of diffuse clutter fluctuates around it).
    pub fn smooth_prediction(&self, predicted: &[f32]) -> Vec<f32> {
        let (nb, na, ne) = (self.nb, self.n_az, self.n_el);
        let idx = |b: usize, ia: usize, ie: usize| (b * ne + ie) * na + ia;
        let mut out = vec![0.0f32; predicted.len()];
        for b in 0..nb {
            for ie in 0..ne {
                for ia in 0..na {
                    let (mut s, mut n) = (0.0f64, 0usize);
                    for bb in b.saturating_sub(1)..(b + 2).min(nb) {
                        for ee in ie.saturating_sub(1)..(ie + 2).min(ne) {
                            for aa in ia.saturating_sub(1)..(ia + 2).min(na) {
                                s += predicted[idx(bb, aa, ee)] as f64;
                                n += 1;
                            }
                        }
                    }
                    out[idx(b, ia, ie)] = (s / n as f64) as f32;
                }
            }
        }
        out
    }

    /// The environment gate: cells whose smoothed predicted static power (from
    /// [`Chain::smooth_prediction`]) times the Doppler integration gain exceeds the noise at zero
    /// Doppler by `gate_db`, dilated by one cell in range and both angles (the twin's
    /// registration error).
    pub fn gate_from_prediction(&self, smoothed: &[f32], gate_db: f64) -> Vec<bool> {
        let (nb, na, ne) = (self.nb, self.n_az, self.n_el);
        let idx = |b: usize, ia: usize, ie: usize| (b * ne + ie) * na + ia;
        let thr = self.noise_cell * 10f64.powf(gate_db / 10.0) / self.doppler_gain;
        let hot: Vec<bool> = smoothed.iter().map(|&p| p as f64 > thr).collect();
        let mut gate = hot.clone();
        for b in 0..nb {
            for ie in 0..ne {
                for ia in 0..na {
                    if !hot[idx(b, ia, ie)] {
                        continue;
                    }
                    for bb in b.saturating_sub(1)..(b + 2).min(nb) {
                        for ee in ie.saturating_sub(1)..(ie + 2).min(ne) {
                            for aa in ia.saturating_sub(1)..(ia + 2).min(na) {
                                gate[idx(bb, aa, ee)] = true;
                            }
                        }
                    }
                }
            }
        }
        gate
    }

    /// Power response of the Doppler processing to a static unit echo at FFT bin `d`:
    /// `|Σ_m w_m e^{−j2πdm/nd}|² / (Σw)²` (1 at `d = 0`).
    pub fn static_doppler_response(&self) -> Vec<f32> {
        let sum: f64 = self.w_dop.iter().map(|&w| w as f64).sum();
        (0..self.nd)
            .map(|d| {
                let (mut re, mut im) = (0.0f64, 0.0f64);
                for (mi, &w) in self.w_dop.iter().enumerate() {
                    let ph = -std::f64::consts::TAU * (d * mi) as f64 / self.nd as f64;
                    re += w as f64 * ph.cos();
                    im += w as f64 * ph.sin();
                }
                ((re * re + im * im) / (sum * sum)) as f32
            })
            .collect()
    }

    /// One pass: suppression, beamforming and Doppler processing of a frame (`[m][e][b]`).
    ///
    /// # Errors
    /// [`LocalizeError`] for a wrong frame length or a has-dsp error.
    pub fn process(&self, frame: &[C32], sup: Suppression<'_>) -> Result<Cube, LocalizeError> {
        let (m, e_n, nb, beams, nd) = (self.m, self.elements(), self.nb, self.beams(), self.nd);
        if frame.len() != self.frame_len() {
            return Err(LocalizeError::Internal("frame length"));
        }
        if let Suppression::Gated(_, g) = sup {
            if g.len() != nb * beams {
                return Err(LocalizeError::Internal("gate length"));
            }
        }
        let mut power = vec![0.0f32; nb * nd * beams];
        // Per-bin energies are collected in bin order and summed sequentially: a parallel
        // reduction's association depends on the thread count, and so did the last bits of the
        // cancellation it feeds.
        let energies: Vec<f64> = power
            .par_chunks_mut(nd * beams)
            .enumerate()
            .map(|(b, out)| -> Result<f64, DspError> {
                // x[m][e] of this range bin.
                let mut x = vec![C32::new(0.0, 0.0); m * e_n];
                for mi in 0..m {
                    for e in 0..e_n {
                        x[mi * e_n + e] = frame[(mi * e_n + e) * nb + b];
                    }
                }
                let mut seq = vec![C32::new(0.0, 0.0); m];
                let mut buf = vec![C32::new(0.0, 0.0); m];
                if let Suppression::PerElement(eca) = sup {
                    for e in 0..e_n {
                        for mi in 0..m {
                            seq[mi] = x[mi * e_n + e];
                        }
                        eca.apply(&mut seq, &mut buf)?;
                        for mi in 0..m {
                            x[mi * e_n + e] = seq[mi];
                        }
                    }
                }
                let mut rows_fft = vec![C32::new(0.0, 0.0); self.array.rows * self.na];
                let mut col = vec![C32::new(0.0, 0.0); self.na];
                let mut y = vec![C32::new(0.0, 0.0); m * beams];
                for mi in 0..m {
                    self.beamform(
                        &x[mi * e_n..(mi + 1) * e_n],
                        &mut rows_fft,
                        &mut col,
                        &mut y[mi * beams..(mi + 1) * beams],
                    )?;
                }
                let mut energy = 0.0f64;
                let mut dop = vec![C32::new(0.0, 0.0); nd];
                for beam in 0..beams {
                    if !self.valid[beam] {
                        continue;
                    }
                    for mi in 0..m {
                        seq[mi] = y[mi * beams + beam];
                    }
                    if let Suppression::Gated(eca, gate) = sup {
                        if gate[b * beams + beam] {
                            eca.apply(&mut seq, &mut buf)?;
                        }
                    }
                    dop.fill(C32::new(0.0, 0.0));
                    for mi in 0..m {
                        energy += seq[mi].norm_sqr() as f64;
                        dop[mi] = seq[mi] * self.w_dop[mi];
                    }
                    fft_c32(&mut dop)?;
                    for (d, v) in dop.iter().enumerate() {
                        out[d * beams + beam] = v.norm_sqr() * self.dop_norm;
                    }
                }
                Ok(energy)
            })
            .collect::<Result<_, _>>()
            .map_err(dsp("frame processing"))?;
        let energy = energies.iter().sum();
        Ok(Cube { power, energy })
    }

    /// Range × Doppler power of one beam, `[b][d]` with Doppler in FFT order.
    pub fn range_doppler(&self, cube: &Cube, beam: usize) -> Vec<f32> {
        let (nd, beams) = (self.nd, self.beams());
        (0..self.nb * nd)
            .map(|i| cube.power[i * beams + beam])
            .collect()
    }

    /// CA-CFAR along range per (Doppler, beam), then the extent test (module docs): one point
    /// per detected (range, beam) cell.
    ///
    /// # Errors
    /// [`LocalizeError::Dsp`] from the detector.
    pub fn detect(
        &self,
        cube: &Cube,
        map: Option<&ClutterMap>,
    ) -> Result<Vec<Detection>, LocalizeError> {
        let (nb, nd, beams) = (self.nb, self.nd, self.beams());
        // Strongest cell of every (range, Doppler) slice over the field of view.
        let mut slice_max = vec![0.0f32; nb * nd];
        for (s, row) in slice_max.iter_mut().zip(cube.power.chunks_exact(beams)) {
            *s = row
                .iter()
                .zip(&self.valid)
                .filter(|(_, &v)| v)
                .fold(0.0f32, |a, (&p, _)| a.max(p));
        }
        let extent = 10f32.powf(-self.extent_db / 10.0);
        // Per (d, beam) line: CFAR hits along range that pass the extent test.
        let hits: Vec<Vec<(usize, usize, usize)>> = (0..nd)
            .into_par_iter()
            .map(|d| -> Result<Vec<(usize, usize, usize)>, DspError> {
                let mut line = vec![0.0f32; nb];
                let mut th = vec![0.0f32; nb];
                let mut out = Vec::new();
                for beam in 0..beams {
                    if !self.valid[beam] {
                        continue;
                    }
                    for (b, l) in line.iter_mut().enumerate() {
                        *l = cube.power[(b * nd + d) * beams + beam];
                    }
                    if self.cfar.thresholds(&line, &mut th)? == 0 {
                        continue;
                    }
                    for b in 0..nb {
                        if line[b] > th[b]
                            && line[b] >= extent * slice_max[b * nd + d]
                            && map.is_none_or(|m| line[b] > m.threshold(b * beams + beam, d))
                        {
                            out.push((b, beam, d));
                        }
                    }
                }
                Ok(out)
            })
            .collect::<Result<_, _>>()
            .map_err(dsp("cfar"))?;
        // The strongest detected Doppler bin of every detected cell.
        let mut best: Vec<Option<(f32, usize)>> = vec![None; nb * beams];
        for &(b, beam, d) in hits.iter().flatten() {
            let p = cube.power[(b * nd + d) * beams + beam];
            let slot = &mut best[b * beams + beam];
            if slot.is_none_or(|(q, _)| p > q) {
                *slot = Some((p, d));
            }
        }
        let noise_db = 10.0 * ((self.noise_cell / self.doppler_gain) as f32).log10();
        let mut out = Vec::new();
        for b in 0..nb {
            for beam in 0..beams {
                if let Some((p, d)) = best[b * beams + beam] {
                    let (ia, ie) = (beam % self.n_az, beam / self.n_az);
                    out.push(Detection {
                        pos: self.cell_position(b as f32, ia as f32, ie as f32),
                        range_m: ((self.bin0 + b) as f64 * self.bin_m * 0.5) as f32,
                        doppler_hz: self.doppler_hz(d),
                        snr_db: 10.0 * p.max(1e-30).log10() - noise_db,
                    });
                }
            }
        }
        Ok(out)
    }

    /// Wavelength, metres.
    pub fn wavelength_m(&self) -> f32 {
        self.lambda
    }
}

/// Fits the `templates` (`P` range segments of one static prediction, each `E·nb` long,
/// concatenated) to the frame by common complex gains over the CPI and subtracts them
/// (has-dsp [`TemplateSet::subtract_block_common`]); returns the gains.
///
/// # Errors
/// [`LocalizeError::Dsp`] from has-dsp (e.g. an empty template); `P` must be 1, 2, 4, 8 or 16.
pub fn subtract_templates(
    templates: &[C32],
    count: usize,
    frame: &mut [C32],
) -> Result<Vec<C32>, LocalizeError> {
    fn run<const P: usize>(t: &[C32], frame: &mut [C32]) -> Result<Vec<C32>, DspError> {
        let bins = t.len() / P;
        let set = TemplateSet::<P>::new(t, bins, 0.0)?;
        Ok(set.subtract_block_common(frame)?.to_vec())
    }
    match count {
        1 => run::<1>(templates, frame),
        2 => run::<2>(templates, frame),
        4 => run::<4>(templates, frame),
        8 => run::<8>(templates, frame),
        16 => run::<16>(templates, frame),
        _ => return Err(LocalizeError::Internal("template count (1, 2, 4, 8 or 16)")),
    }
    .map_err(dsp("template subtraction"))
}

/// Splits one static prediction (`[e][b]`, `E·nb`) into `count` templates of contiguous range
/// segments (template `p` keeps bins `[p·nb/count, (p+1)·nb/count)`, zero elsewhere).
pub fn range_segment_templates(pred: &[C32], nb: usize, count: usize) -> Vec<C32> {
    let e_n = pred.len() / nb;
    let mut out = vec![C32::new(0.0, 0.0); count * pred.len()];
    for p in 0..count {
        let (lo, hi) = (p * nb / count, (p + 1) * nb / count);
        let t = &mut out[p * pred.len()..(p + 1) * pred.len()];
        for e in 0..e_n {
            t[e * nb + lo..e * nb + hi].copy_from_slice(&pred[e * nb + lo..e * nb + hi]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::echo::{EchoConfig, EchoSynth, PointScatterer};
    use crate::scenario::localize::tests::factory_spec;

    fn quick_chain() -> Chain {
        let mut s = factory_spec();
        s.apply_quick();
        Chain::new(&s, crate::echo::qpsk_symbols(s.subcarriers, 1)).unwrap()
    }

    #[test]
    fn slow_time_eca_block_subtracts_the_cpi_mean() {
        // With a reference of ones, K = 1, D = 1, the ECA projection is y − mean(y) exactly.
        let m = 16;
        let eca = SlowTimeEca::new(m, 1, EcaVariant::Block, "ECA").unwrap();
        let y: Vec<C32> = (0..m)
            .map(|i| {
                let ph = 0.7 * i as f32;
                C32::new(2.0, -1.0) + C32::new(0.3 * ph.cos(), 0.3 * ph.sin())
            })
            .collect();
        let mean = y.iter().sum::<C32>() / m as f32;
        let mut seq = y.clone();
        let mut buf = vec![C32::new(0.0, 0.0); m];
        eca.apply(&mut seq, &mut buf).unwrap();
        for (o, i) in seq.iter().zip(&y) {
            // f32 data, f64 solve: error a few ulp of |y| ≈ 2.3.
            assert!((o - (i - mean)).norm() < 1e-5, "{o} vs {}", i - mean);
        }
    }

    #[test]
    fn noise_alone_stays_near_the_design_false_alarm_rate() {
        // A frame of receiver noise only (white complex Gaussian per subcarrier, element and
        // symbol), range-compressed like an echo: the detector tests nb × beams × Doppler cells
        // at the design pfa, so it should report about cells·pfa false alarms (≈ 0.09 for the
        // quick chain at 1e-8); the extent test and one point per (range, beam) cell only remove
        // hits. With the CFAR blind to the correlation of the zero-padded range bins, this frame
        // gives 41. Poisson with mean ≤ 0.1: more than 3 has probability < 1e-5.
        let mut spec = factory_spec();
        spec.apply_quick();
        spec.cfar_pfa = 1e-8;
        let chain = Chain::new(&spec, crate::echo::qpsk_symbols(spec.subcarriers, 1)).unwrap();
        let n = chain.symbol.len();
        let mut s: u64 = 2024;
        let mut uniform = move || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 11) as f64 + 1.0) / (1u64 << 53) as f64
        };
        let mut y = vec![C32::new(0.0, 0.0); n];
        let mut profile = vec![C32::new(0.0, 0.0); chain.rc.profile_len()];
        let mut frame = vec![C32::new(0.0, 0.0); chain.frame_len()];
        for row in frame.chunks_exact_mut(chain.nb) {
            for v in y.iter_mut() {
                let (u, w) = (uniform(), uniform());
                let r = (-u.ln()).sqrt();
                let a = std::f64::consts::TAU * w;
                *v = C32::new((r * a.cos()) as f32, (r * a.sin()) as f32);
            }
            chain.compress(&y, &mut profile, row).unwrap();
        }
        let cube = chain.process(&frame, Suppression::None).unwrap();
        // The same bits at one thread as at two, with range bins 2⁰…2⁴⁰ apart in amplitude so
        // that the f64 sum over bins rounds (the energy was a parallel reduction whose
        // association followed the thread count).
        let scaled: Vec<C32> = frame
            .iter()
            .enumerate()
            .map(|(i, v)| v * 2f32.powi(((i % chain.nb) * 7 % 41) as i32))
            .collect();
        let at = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| chain.process(&scaled, Suppression::None).unwrap())
        };
        let (one, two) = (at(1), at(2));
        assert!(one.energy.is_finite());
        assert_eq!(one.energy.to_bits(), two.energy.to_bits());
        assert!(one.power == two.power);
        let cells = chain.nb * chain.beams() * chain.nd;
        let det = chain.detect(&cube, None).unwrap();
        assert!(
            det.len() <= 3,
            "{} detections on noise alone over {cells} cells at pfa {}",
            det.len(),
            chain.cfar.pfa()
        );
    }

    #[test]
    fn a_static_point_is_detected_at_its_position() {
        // One point scatterer in front of the panel, synthesized as compressed profiles (model
        // (a)) for every element and symbol, plus weak LCG noise: the no-suppression pass must
        // detect it, and the detected cell nearest to it must lie within half a cell diagonal
        // (range bin c/(2B·zero_pad) = 0.75 m, beam grid λ/(64·d)·R ≈ 0.69 m per axis at 22 m).
        let chain = quick_chain();
        let p = Vec3::new(-34.0, 2.5, 1.5);
        let mut cfg = EchoConfig::for_compressor(10e9, &chain.rc).unwrap();
        cfg.r0_m = chain.bin0 as f64 * chain.bin_m;
        cfg.n_bins = chain.nb;
        let synth = EchoSynth::new(cfg).unwrap();
        let elements = chain.array.elements(1);
        let e_n = elements.len();
        let mut row = vec![C32::new(0.0, 0.0); e_n * chain.nb];
        synth
            .synth_profiles_points(
                &[PointScatterer {
                    pos: p,
                    amp: C32::new(1.0, 0.0),
                }],
                chain.array.centre,
                &elements,
                &mut row,
            )
            .unwrap();
        let mut frame = Vec::with_capacity(chain.frame_len());
        let mut s: u64 = 9;
        for _ in 0..chain.m {
            for v in &row {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let a = ((s >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 1e-3;
                frame.push(v + C32::new(a, -a));
            }
        }
        let cube = chain.process(&frame, Suppression::None).unwrap();
        let det = chain.detect(&cube, None).unwrap();
        assert!(!det.is_empty());
        let best = det
            .iter()
            .map(|d| d.pos.distance(p))
            .fold(f32::INFINITY, f32::min);
        let r = p.distance(chain.array.centre);
        let cell = Vec3::new(
            (chain.bin_m * 0.5) as f32,
            chain.wavelength_m() / (64.0 * chain.array.spacing_m().0) * r,
            chain.wavelength_m() / (64.0 * chain.array.spacing_m().1) * r,
        );
        assert!(
            best <= 0.5 * cell.length() + 1e-3,
            "nearest detection {best} m"
        );
        // The strongest detection is the point itself, at Doppler 0, far above the noise.
        let top = det
            .iter()
            .max_by(|a, b| a.snr_db.total_cmp(&b.snr_db))
            .unwrap();
        assert!(top.pos.distance(p) <= cell.length());
        assert_eq!(top.doppler_hz, 0.0);
        // A static echo is removed by ECA: nothing is left to detect at the point.
        let eca = SlowTimeEca::new(chain.m, 1, EcaVariant::Block, "ECA").unwrap();
        let cube = chain
            .process(&frame, Suppression::PerElement(&eca))
            .unwrap();
        let det = chain.detect(&cube, None).unwrap();
        assert!(
            det.iter().all(|d| d.pos.distance(p) > cell.length()),
            "{det:?}"
        );
    }

    #[test]
    fn beams_and_positions_are_consistent() {
        let chain = quick_chain();
        let p = Vec3::new(-30.0, -6.0, 2.0);
        let beam = chain.beam_towards(p);
        let (ia, ie) = (beam % chain.n_az, beam / chain.n_az);
        let r = p.distance(chain.array.centre);
        let b = (2.0 * r as f64 / chain.bin_m) as f32 - chain.bin0 as f32;
        let q = chain.cell_position(b, ia as f32, ie as f32);
        // Within half a beam step per axis of the direction: ≤ ½·√2·0.69 m at ≈ 26 m.
        assert!(q.distance(p) < 0.6, "{q} vs {p}");
    }

    #[test]
    fn wrong_lengths_are_errors() {
        let chain = quick_chain();
        assert!(chain
            .process(&[C32::new(0.0, 0.0); 3], Suppression::None)
            .is_err());
        assert!(chain.beam_power_static(&[C32::new(0.0, 0.0); 3]).is_err());
        let mut out = vec![C32::new(0.0, 0.0); chain.nb];
        let mut prof = vec![C32::new(0.0, 0.0); chain.rc.profile_len()];
        assert!(chain
            .compress(&[C32::new(0.0, 0.0); 5], &mut prof, &mut out)
            .is_err());
        let t = vec![C32::new(0.0, 0.0); 8];
        let mut f = vec![C32::new(0.0, 0.0); 8];
        assert!(subtract_templates(&t, 3, &mut f).is_err());
        // An all-zero template has no energy: has-dsp refuses it.
        assert!(subtract_templates(&t, 2, &mut f).is_err());
    }

    #[test]
    fn a_cfar_guard_longer_than_the_profile_is_named_not_the_range() {
        for guard in [100_000, usize::MAX] {
            let mut s = factory_spec();
            s.apply_quick();
            s.cfar_guard = guard;
            let Err(e) = Chain::new(&s, crate::echo::qpsk_symbols(s.subcarriers, 1)) else {
                panic!("cfar_guard {guard} accepted");
            };
            let e = e.to_string();
            assert!(e.starts_with("localize.cfar_guard"), "{e}");
            assert!(e.contains(&guard.to_string()), "{e}");
        }
        // A range window too short for a sane CFAR window still names the range.
        let mut s = factory_spec();
        s.apply_quick();
        s.range_max_m = s.range_min_m + 0.1;
        let Err(e) = Chain::new(&s, crate::echo::qpsk_symbols(s.subcarriers, 1)) else {
            panic!("a 0.1 m range window accepted");
        };
        let e = e.to_string();
        assert!(e.starts_with("localize.range_max_m"), "{e}");
    }
}
