//! Echo synthesis for sensing: the scene's surfaces sampled into point scatterers, their
//! visibility from a transmitter and a receive array, a bistatic diffuse amplitude, and two ways
//! of producing the echo of one frame:
//!
//! * **(a) range-compressed profiles directly** ([`EchoSynth::synth_profiles`]): for each receive
//!   element, `s(r_i) = Σ_p a_p · p(r_i − r_p) · e^{−j2π r_p/λ}` on the bin grid
//!   `r_i = r0 + i·dr`, `dr = c/(B·zero_pad)`, where `p` is *exactly* the pulse that range
//!   compression (`Y·conj(S)`, window, zero-padded inverse FFT, divided by `Σ w`) makes of the
//!   same OFDM grid (see [`PulseKernel`] for how it is tabulated and its stated error);
//! * **(b) raw OFDM subcarriers** ([`EchoSynth::synth_ofdm`]):
//!   `Y[k] = S[k]·H[k] + n[k]`, `H[k] = Σ_p a_p·e^{−j2π(fc + f_k)τ_p}`, `τ_p = r_p/c`, with `f_k`
//!   from [`has_dsp::ofdm::subcarrier_offset_hz`] (FFT order) and seeded complex white Gaussian
//!   noise ([`Noise`]).
//!
//! (a) is what large imaging runs use; (b) exercises range compression for real. A unit point
//! scatterer at bistatic path length `r` gives, in both, a peak of magnitude 1 at `r` with phase
//! `−2π r/λ`.
//!
//! # Scattering model
//! Each scatterer stands for a patch of area `A` (its area weight) of a rough surface. Its bistatic
//! radar cross-section is Lambertian with the material's Fresnel power reflectivity as albedo,
//! `σ = 4·|Γ(θi)|²·cos θi·cos θs·A` (m²), `θi`, `θs` the angles of the transmitter and receiver
//! from the normal, `|Γ|² = (|Γ_TE|² + |Γ_TM|²)/2` (unpolarised) from
//! [`crate::propagation::fresnel_reflection`] at `θi`. The echo amplitude (isotropic antennas, unit
//! transmit amplitude) follows the bistatic radar equation,
//! `a = √σ · λ / ((4π)^{3/2}·rV·rR)`, written with [`crate::propagation::free_space_amplitude`]
//! (see [`bistatic_amplitude`]). The amplitude is real and positive; the phase is the propagation
//! phase only. Because samples lie many wavelengths apart their sum is a random-phase (speckle)
//! sum, so the received *power* is `Σ σ_p ∝` total area, independent of the sampling density — the
//! reason the amplitude goes with `√A` rather than `A`. A scatterer whose face points away from
//! the transmitter or the receiver (back face) contributes nothing; `two_sided` sets treat either
//! side as the front.
//!
//! # Approximations (stated)
//! * Visibility (both legs cast through the BVH) and `θi` are evaluated once per (transmitter,
//!   receive array) from the array **centre** and shared by all its elements; `rR`, `cos θs` and
//!   the phase are exact per element. [`VisibilityCache`] further shares one visibility list across
//!   aperture positions within a chosen distance.
//! * Geometry and phase are computed in `f64` from the `f32` positions (phase error < 1e-6 rad);
//!   pulse taps, amplitudes and the output are `f32` (relative rounding ≈ 1e-7 per term).
//! * No range ambiguity in (a): a scatterer beyond `c/Δf` is not folded back as it is in (b).
//!
//! # Cost
//! (a) costs one `f64` distance, one table phasor and `2L` complex taps per (scatterer, element),
//! the receive legs computed a block of scatterers at a time (vectorised) with the bits of one
//! path at a time: `has-sim bench echo` measures both on 16 k visible scatterers × 1024
//! elements with 24 taps (2.9–3.3·10⁷ pairs/s on one thread, 1.5× the plain path, on this shared
//! 2-core machine). Pick
//! `kernel_half_width_cells` from [`PulseKernel::truncation_error`] (Hann: 8 cells ⇒ 5.5e-4).
//!
//! Units: metres, hertz, radians; positions `Vec3` in the scene frame.

mod kernel;
pub mod noise;
mod scatterers;
mod synth;

pub(crate) use kernel::floor_small;
pub use kernel::PulseKernel;
pub use scatterers::{visible_for, Scatterer, ScattererSet, VisibilityCache};
pub use synth::{bistatic_amplitude, qpsk_symbols, zadoff_chu, EchoSynth, Noise, PointScatterer};

/// Configuration of one OFDM frame and of the range-profile grid it is compressed onto.
#[derive(Clone, Debug, PartialEq)]
pub struct EchoConfig {
    /// Carrier frequency, Hz.
    pub fc_hz: f64,
    /// Occupied bandwidth `B = n·Δf`, Hz.
    pub bandwidth_hz: f64,
    /// Number of subcarriers `n` (FFT order, see [`has_dsp::ofdm`]).
    pub n_subcarriers: usize,
    /// Zero-padding factor of the range-compression inverse FFT (profile length `n·zero_pad`).
    pub zero_pad: usize,
    /// Range-compression window, one real weight per subcarrier in FFT order (`n_subcarriers`
    /// long). Must equal the window the range compressor applies.
    pub window: Vec<f32>,
    /// Bistatic path length of profile bin 0, metres.
    pub r0_m: f64,
    /// Number of profile bins synthesised by (a).
    pub n_bins: usize,
    /// Half-width of the tabulated pulse, in resolution cells `c/B` (taps beyond are dropped;
    /// the dropped magnitude is [`PulseKernel::truncation_error`]).
    pub kernel_half_width_cells: usize,
    /// Pulse-table samples per profile bin (linear interpolation between them).
    pub kernel_oversample: usize,
}

impl EchoConfig {
    /// A rectangular-window configuration with profile bins covering the whole unambiguous path
    /// length (`n·zero_pad` bins from 0), a 16-cell pulse half-width and 256× oversampled table.
    pub fn new(fc_hz: f64, bandwidth_hz: f64, n_subcarriers: usize, zero_pad: usize) -> Self {
        EchoConfig {
            fc_hz,
            bandwidth_hz,
            n_subcarriers,
            zero_pad,
            window: vec![1.0; n_subcarriers],
            r0_m: 0.0,
            n_bins: n_subcarriers * zero_pad,
            kernel_half_width_cells: 16,
            kernel_oversample: 256,
        }
    }

    /// The same configuration with `window`'s weights (FFT order) in place of the current ones,
    /// the unpaired Nyquist subcarrier `n/2` set to 0 as has-dsp range compression does
    /// ([`has_dsp::range::RangeCompressor::fill_weights`]).
    ///
    /// # Errors
    /// `InvalidParameter` (`window`) for bad Taylor parameters or `n_subcarriers == 0`.
    pub fn with_window(mut self, window: has_dsp::window::Window) -> Result<Self, EchoError> {
        let mut w = vec![0.0f32; self.n_subcarriers];
        window
            .fill_f32(&mut w)
            .map_err(|e| EchoError::invalid("window", format!("{window:?}: {e}")))?;
        let half = self.n_subcarriers / 2;
        if 2 * half == self.n_subcarriers {
            w[half] = 0.0;
        }
        self.window = w;
        Ok(self)
    }

    /// The configuration matching a has-dsp range compressor (`n`, `B`, zero-padding and the
    /// exact weights it applies), profile bins `0 … n·zero_pad − 1` from path 0 like its output,
    /// at carrier `fc_hz`. Direct synthesis (a) then reproduces its profiles within
    /// [`EchoSynth::error_bound`].
    ///
    /// # Errors
    /// `InvalidParameter` for a bad `fc_hz`.
    pub fn for_compressor(
        fc_hz: f64,
        rc: &has_dsp::range::RangeCompressor,
    ) -> Result<Self, EchoError> {
        let c = rc.config();
        let mut cfg = EchoConfig::new(fc_hz, c.bandwidth_hz, c.n_subcarriers, c.zero_pad);
        rc.fill_weights(&mut cfg.window)
            .map_err(|e| EchoError::invalid("window", e))?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// Profile bin spacing `c/(B·zero_pad)` in metres of bistatic path.
    pub fn bin_spacing_m(&self) -> f64 {
        has_dsp::ofdm::bin_spacing_m(self.bandwidth_hz, self.zero_pad)
    }

    /// Carrier wavelength, metres.
    pub fn wavelength_m(&self) -> f64 {
        has_dsp::geometry::wavelength_m(self.fc_hz)
    }

    /// Subcarrier spacing `Δf = B/n`, Hz.
    pub fn subcarrier_spacing_hz(&self) -> f64 {
        self.bandwidth_hz / self.n_subcarriers as f64
    }

    /// Checks every field.
    ///
    /// # Errors
    /// [`EchoError::InvalidParameter`] naming the first bad field.
    pub fn validate(&self) -> Result<(), EchoError> {
        let pos = |field: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(EchoError::invalid(field, v))
            }
        };
        pos("fc_hz", self.fc_hz)?;
        pos("bandwidth_hz", self.bandwidth_hz)?;
        if self.bandwidth_hz >= 2.0 * self.fc_hz {
            return Err(EchoError::invalid("bandwidth_hz", self.bandwidth_hz));
        }
        let nonzero = |field: &'static str, v: usize| {
            if v == 0 {
                Err(EchoError::invalid(field, 0))
            } else {
                Ok(())
            }
        };
        nonzero("n_subcarriers", self.n_subcarriers)?;
        nonzero("zero_pad", self.zero_pad)?;
        nonzero("n_bins", self.n_bins)?;
        nonzero("kernel_half_width_cells", self.kernel_half_width_cells)?;
        nonzero("kernel_oversample", self.kernel_oversample)?;
        if self.window.len() != self.n_subcarriers {
            return Err(EchoError::LengthMismatch {
                field: "window",
                expected: self.n_subcarriers,
                got: self.window.len(),
            });
        }
        if let Some(i) = self.window.iter().position(|w| !w.is_finite()) {
            return Err(EchoError::invalid(
                "window",
                format!("[{i}] = {}", self.window[i]),
            ));
        }
        let sum: f64 = self.window.iter().map(|&w| w as f64).sum();
        if sum.abs() <= 0.0 {
            return Err(EchoError::invalid("window", "sum of weights is 0"));
        }
        if !self.r0_m.is_finite() {
            return Err(EchoError::invalid("r0_m", self.r0_m));
        }
        Ok(())
    }
}

/// Why echo synthesis refused its input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum EchoError {
    /// A parameter outside its valid range (zero bandwidth, NaN position, ...).
    #[error("invalid {field}: {value}")]
    InvalidParameter {
        /// The field or argument.
        field: &'static str,
        /// The offending value, printed.
        value: String,
    },
    /// A slice of the wrong length.
    #[error("{field}: expected length {expected}, got {got}")]
    LengthMismatch {
        /// The field or argument.
        field: &'static str,
        /// Length required.
        expected: usize,
        /// Length given.
        got: usize,
    },
    /// Sampling would need more memory than the machine has.
    #[error(
        "{field}: up to {count:.3e} scatterers need {need_gib:.1} GiB, {have_gib:.1} GiB available"
    )]
    TooLarge {
        /// The density's field.
        field: &'static str,
        /// Scatterers the density asks for on the whole scene.
        count: f64,
        /// Their memory, GiB.
        need_gib: f64,
        /// Memory available, GiB.
        have_gib: f64,
    },
    /// A visibility index that does not name a scatterer of the set.
    #[error("visible[{position}] = {index} is out of range for {len} scatterers")]
    BadIndex {
        /// Position in the `visible` list.
        position: usize,
        /// The index found there.
        index: u32,
        /// Number of scatterers in the set.
        len: usize,
    },
}

impl EchoError {
    pub(crate) fn invalid(field: &'static str, value: impl std::fmt::Display) -> Self {
        EchoError::InvalidParameter {
            field,
            value: value.to_string(),
        }
    }
}

/// Checks that a position is finite.
pub(crate) fn check_pos(field: &'static str, v: glam::Vec3) -> Result<(), EchoError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(EchoError::invalid(field, format!("{v:?}")))
    }
}
