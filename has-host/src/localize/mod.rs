//! Moving-target sensing with environment-assisted clutter suppression (paper §3, Fig. 10–11).
//!
//! A monostatic base station (one transmit element at the centre of a 32 × 32 λ/2 receive panel)
//! watches a cylinder (the extended target) cross a yard along a straight track among strong
//! static clutter (ground and buildings). Each frame is one CPI of `M` OFDM sensing symbols,
//! synthesized per element ([`crate::echo`]) and pushed through has-dsp frame by frame
//! ([`chain`]): range compression, clutter suppression, Doppler, 2-D beamforming, CA-CFAR, points.
//! Two clutter-suppression modes run on the same data:
//!
//! * **`eca`** — ECA alone, in its Block (D = 1 and D = 3), ECA-B and ECA-S forms; the variant
//!   with the best localization is the reported baseline.
//! * **`env`** — the environment prior: the static response predicted from the *reconstructed*
//!   mesh (scatterers sampled on the twin plus a flat ground at the surveyed height, synthesized
//!   through the same echo model; never the true scene) is (1) fitted by complex gains per range
//!   segment and subtracted, and (2) beamformed into a clutter map that confines the ECA notch to
//!   the cells where static clutter is predicted; ECA then runs on the residual in those cells.
//!
//! Metrics ([`run::ModeSummary`]): √CD (paper eq. 2) between the detections on the target and
//! the target's true scattering points (the scatterers facing the base station, pooled over all
//! frames), the detection count, false alarms (detections farther than
//! `false_alarm_gate_m` from the target's surface in their frame) and the clutter-cancellation
//! depth (energy of the beamformed slow-time data before / after suppression, dB).
//!
//! Approximations (stated): echoes are single-bounce diffuse scattering (the
//! [`crate::echo`] model), no specular multipath; the target does not shadow the clutter and the
//! clutter does not shadow the target; elements are isotropic over the front half-space (the
//! panel's backplane hides the rear); the target's own motion within a CPI is synthesized exactly
//! per symbol (stop-and-hop within a symbol). The static clutter's compressed profile is
//! synthesized directly by [`crate::echo::EchoSynth::synth_profiles`], which equals has-dsp's
//! compression of its OFDM echo within [`crate::echo::EchoSynth::error_bound`]; the target and the
//! receiver noise are synthesized as OFDM subcarriers and range-compressed by has-dsp per symbol.

pub mod chain;
mod markdown;
pub mod outputs;
pub mod report;
pub mod run;
pub mod target;

pub use crate::scenario::{LocalizeOverrides, LocalizeSpec};
pub use chain::{Chain, ClutterMap, Cube, Detection, SlowTimeEca, Suppression};
pub use outputs::{DetectionCloud, RangeDopplerMap, RdFrame, RdStage};
pub use report::{improvement_pct, FrameReport, LocalizeReport, LocalizeRunReport};
pub use run::{run_localize, FrameResult, LocalizeResult, ModeSummary};

/// Why the localization run failed.
#[derive(Debug, thiserror::Error)]
pub enum LocalizeError {
    /// A bad scenario field.
    #[error(transparent)]
    Config(#[from] crate::scenario::ScenarioError),
    /// has-dsp refused its input.
    #[error("{what}: {source}")]
    Dsp {
        /// The stage.
        what: &'static str,
        /// The has-dsp error.
        source: has_dsp::DspError,
    },
    /// Echo synthesis refused its input.
    #[error("echo: {0}")]
    Echo(#[from] crate::echo::EchoError),
    /// A scene (true, target or twin) could not be built.
    #[error("scene: {0}")]
    Scene(#[from] crate::scene::SceneError),
    /// A shape could not be built.
    #[error("shape: {0}")]
    Shape(#[from] crate::shapes::ShapeError),
    /// A metric could not be computed.
    #[error("metrics: {0}")]
    Metric(#[from] crate::knn::GeometryError),
    /// An object named in `[localize]` does not exist.
    #[error("localize.{field}: no object named '{name}' in the scene")]
    UnknownObject {
        /// The list that names it: `ground_objects` or `known_objects`.
        field: &'static str,
        /// The name.
        name: String,
    },
    /// An internal invariant (a bug).
    #[error("internal: {0}")]
    Internal(&'static str),
}
