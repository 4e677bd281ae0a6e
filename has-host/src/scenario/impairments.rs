//! The `[impairments]` table of a scenario file: what separates a terminal's frames from a base
//! station's clock and from the terminal's reported track, and whether the base station
//! compensates it. Absent, every pair is ideal
//! (perfectly synchronised) and the run is bit for bit what it was without the table.
//!
//! Units as named in each field: nanoseconds, parts per million, hertz, metres per second. The
//! table denies unknown fields; [`ImpairmentSpec::validate`] names the first bad field and its
//! value (`impairments.<field>`). The defaults are those of a 3GPP NR terminal at 10 GHz after
//! downlink synchronisation (TS 38.133 transmit timing error, TS 38.521 frequency error, a TCXO's
//! wander); the processes they drive are in [`crate::impairments`].

use serde::{Deserialize, Serialize};

use super::{ScenarioError, TableFields};

/// Fields of the `[impairments]` table named in this module's errors.
const IMPAIRMENTS: TableFields = TableFields::new("impairments");

/// `[impairments]`: the pair's synchronisation errors (module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImpairmentSpec {
    /// Half-width of the uniform initial terminal→base-station timing offset per pair,
    /// nanoseconds. Default 114.
    #[serde(default = "default_timing_offset_ns")]
    pub timing_offset_ns: f64,
    /// Sampling-clock drift, parts per million of elapsed time. Default 0.1.
    #[serde(default = "default_timing_drift_ppm")]
    pub timing_drift_ppm: f64,
    /// Standard deviation of the timing offset's random-walk step per frame, nanoseconds.
    /// Default 0.2.
    #[serde(default = "default_timing_walk_ns")]
    pub timing_walk_ns: f64,
    /// Half-width of the uniform residual carrier-frequency offset per pair, hertz (±0.1 ppm at
    /// 10 GHz). Default 1000.
    #[serde(default = "default_cfo_hz")]
    pub cfo_hz: f64,
    /// Oscillator wander: the carrier offset's random walk, Hz/√s. Default 10.
    #[serde(default = "default_cfo_walk")]
    pub cfo_walk_hz_per_sqrt_s: f64,
    /// An independent local-oscillator phase per frame (uplink phase continuity is not
    /// guaranteed between transmissions). Default true.
    #[serde(default = "default_true")]
    pub frame_phase: bool,
    /// The terminals' position error: `"none"`, `"rtk"` (the default), `"degraded"` or a table
    /// `{ bias_m, gm_m, gm_tau_s, white_m }` ([`PositionError`]).
    #[serde(default)]
    pub position_error: PositionError,
    /// The terminals' speed along their tracks, m/s: it sets the time between frames. Default 10.
    #[serde(default = "default_speed")]
    pub terminal_speed_m_per_s: f64,
    /// Whether each base station takes the terminal's line-of-sight path as its reference
    /// ([`crate::impairments`]). Default true; `reconstruct --no-compensation` turns it off.
    #[serde(default = "default_true")]
    pub compensation: bool,
    /// Seed of the draws. Default 1.
    #[serde(default = "default_seed")]
    pub seed: u64,
}

fn default_timing_offset_ns() -> f64 {
    114.0
}
fn default_timing_drift_ppm() -> f64 {
    0.1
}
fn default_timing_walk_ns() -> f64 {
    0.2
}
fn default_cfo_hz() -> f64 {
    1000.0
}
fn default_cfo_walk() -> f64 {
    10.0
}
fn default_true() -> bool {
    true
}
fn default_speed() -> f64 {
    10.0
}
fn default_seed() -> u64 {
    1
}

impl Default for ImpairmentSpec {
    fn default() -> Self {
        ImpairmentSpec {
            timing_offset_ns: default_timing_offset_ns(),
            timing_drift_ppm: default_timing_drift_ppm(),
            timing_walk_ns: default_timing_walk_ns(),
            cfo_hz: default_cfo_hz(),
            cfo_walk_hz_per_sqrt_s: default_cfo_walk(),
            frame_phase: true,
            position_error: PositionError::default(),
            terminal_speed_m_per_s: default_speed(),
            compensation: true,
            seed: default_seed(),
        }
    }
}

impl ImpairmentSpec {
    /// Checks every value (names the first bad field and its value).
    ///
    /// # Errors
    /// [`ScenarioError::Invalid`] with the field `impairments.<name>`.
    pub fn validate(&self) -> Result<(), ScenarioError> {
        for (f, v, max) in [
            ("timing_offset_ns", self.timing_offset_ns, 10_000.0),
            ("timing_drift_ppm", self.timing_drift_ppm, 100.0),
            ("timing_walk_ns", self.timing_walk_ns, 1_000.0),
            ("cfo_hz", self.cfo_hz, 1e6),
            ("cfo_walk_hz_per_sqrt_s", self.cfo_walk_hz_per_sqrt_s, 1e5),
        ] {
            if !(v.is_finite() && (0.0..=max).contains(&v)) {
                return Err(IMPAIRMENTS.invalid(f, v, "finite, ≥ 0 and within its stated bound"));
            }
        }
        let e = self.position_error.stats();
        for (f, v) in [
            ("position_error.bias_m", e.bias_m),
            ("position_error.gm_m", e.gm_m),
            ("position_error.white_m", e.white_m),
        ] {
            if !(v.is_finite() && (0.0..=10.0).contains(&v)) {
                return Err(IMPAIRMENTS.invalid(f, v, "finite, in [0, 10] m"));
            }
        }
        if e.gm_m > 0.0 {
            IMPAIRMENTS.positive("position_error.gm_tau_s", e.gm_tau_s)?;
        }
        let v = self.terminal_speed_m_per_s;
        if !(v.is_finite() && (0.01..=1000.0).contains(&v)) {
            return Err(IMPAIRMENTS.invalid(
                "terminal_speed_m_per_s",
                v,
                "finite, in [0.01, 1000] m/s",
            ));
        }
        Ok(())
    }
}

/// The error of a terminal's reported position, per axis: a bias drawn once per terminal, a
/// first-order Gauss–Markov process (standard deviation `gm_m`, correlation time `gm_tau_s`) and
/// white noise per frame, all Gaussian and independent across the three axes. The profiles of an
/// RTK receiver and of a degraded fix.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum PositionError {
    /// `"none"`, `"rtk"` or `"degraded"`.
    Profile(PositionProfile),
    /// The statistics given one by one.
    Stats(PositionStats),
}

/// A named [`PositionError`] profile.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PositionProfile {
    /// The position is exact.
    None,
    /// Bias 1 cm, Gauss–Markov 5 mm with τ 2 s, white 1 mm.
    Rtk,
    /// Bias 2 cm, Gauss–Markov 2 cm with τ 1 s, white 3 mm.
    Degraded,
}

/// The statistics of a [`PositionError`], metres and seconds (standard deviations per axis).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PositionStats {
    /// Bias drawn once per terminal.
    pub bias_m: f64,
    /// Gauss–Markov process.
    pub gm_m: f64,
    /// Its correlation time.
    pub gm_tau_s: f64,
    /// White noise per frame.
    pub white_m: f64,
}

impl Default for PositionError {
    fn default() -> Self {
        PositionError::Profile(PositionProfile::Rtk)
    }
}

impl PositionError {
    /// The statistics of the profile or table.
    pub fn stats(&self) -> PositionStats {
        let s = |bias_m, gm_m, gm_tau_s, white_m| PositionStats {
            bias_m,
            gm_m,
            gm_tau_s,
            white_m,
        };
        match self {
            PositionError::Profile(PositionProfile::None) => s(0.0, 0.0, 1.0, 0.0),
            PositionError::Profile(PositionProfile::Rtk) => s(0.01, 0.005, 2.0, 0.001),
            PositionError::Profile(PositionProfile::Degraded) => s(0.02, 0.02, 1.0, 0.003),
            PositionError::Stats(st) => *st,
        }
    }
}
