//! The typed report of a localization run ([`super::run_localize`]): the ECA baseline against the
//! environment prior and the improvement between them, per-frame figures, and the range–Doppler
//! maps a reader looks at.
//!
//! Units: metres, seconds, hertz, dB; the improvement in percent of the ECA baseline's √CD
//! (positive: the prior localizes better). Range–Doppler maps in dB relative to the noise power
//! of one cell, Doppler bins shifted so that zero Doppler is in the middle.

use std::collections::BTreeMap;

use serde::Serialize;

use super::run::{LocalizeResult, ModeSummary};
use crate::scenario::LocalizeSpec;

/// Percentage by which the environment prior's √CD improves on the ECA baseline's,
/// `100·(eca − env)/eca`; `None` when either is undefined or the baseline is zero.
pub fn improvement_pct(eca: &ModeSummary, env: &ModeSummary) -> Option<f64> {
    match (eca.sqrt_chamfer_m, env.sqrt_chamfer_m) {
        (Some(a), Some(b)) if a > 0.0 => Some(100.0 * (a - b) / a),
        _ => None,
    }
}

/// One frame (CPI) of a [`LocalizeReport`].
#[derive(Clone, Debug, Serialize)]
pub struct FrameReport {
    /// Frame index.
    pub index: usize,
    /// The target's base centre at the CPI centre, metres.
    pub target_base: [f32; 3],
    /// Radial speed toward the base station, m/s.
    pub radial_speed_mps: f32,
    /// Its Doppler shift, Hz.
    pub doppler_hz: f32,
    /// True scattering points of the frame.
    pub truth_points: usize,
    /// Detections per pass (by pass name).
    pub detections: BTreeMap<String, usize>,
    /// Cancellation depth per pass, dB.
    pub cancellation_db: BTreeMap<String, f64>,
    /// Energy removed by the template subtraction, dB.
    pub template_db: f64,
}

/// Where the time went, seconds.
#[derive(Clone, Debug, Serialize)]
pub struct LocalizeTimings {
    /// The whole command (the caller fills it; the library gives `run`).
    pub wall: f64,
    /// Building the twin, when it was built for this run.
    pub twin_reconstruction: Option<f64>,
    /// [`super::run_localize`].
    pub run: f64,
    /// Its setup.
    pub setup: f64,
    /// Echo synthesis.
    pub synthesis: f64,
    /// has-dsp processing.
    pub processing: f64,
}

/// How the figures are defined.
#[derive(Clone, Debug, Serialize)]
pub struct LocalizeConventions {
    /// √CD.
    pub chamfer: &'static str,
    /// S1.
    pub s1: &'static str,
    /// S2.
    pub s2: &'static str,
    /// The accuracy/completeness split.
    pub accuracy_completeness: &'static str,
    /// A false alarm.
    pub false_alarm: &'static str,
    /// Cancellation depth.
    pub cancellation_db: &'static str,
    /// Template depth.
    pub template_depth_db: &'static str,
}

/// Everything a localization run measured.
#[derive(Clone, Debug, Serialize)]
pub struct LocalizeReport {
    /// The reported ECA baseline (the best ECA variant).
    pub eca: ModeSummary,
    /// The environment prior.
    pub env: ModeSummary,
    /// [`improvement_pct`] of `env` over `eca`.
    pub improvement_pct: Option<f64>,
    /// Every ECA variant.
    pub eca_variants: Vec<ModeSummary>,
    /// No clutter suppression.
    pub no_suppression: ModeSummary,
    /// Mean template depth over frames, dB.
    pub template_depth_db: f64,
    /// Share of (range, beam) cells the twin's clutter map notches.
    pub env_gate_fraction: Option<f64>,
    /// Per frame.
    pub frames: Vec<FrameReport>,
    /// Visible clutter scatterers.
    pub clutter_scatterers: usize,
    /// Twin scatterers.
    pub twin_scatterers: usize,
    /// Mean target scatterers per frame.
    pub target_scatterers_per_frame: f64,
    /// True scattering points over all frames.
    pub truth_points: usize,
    /// Range bins × beams × Doppler bins.
    pub cube_range_beams_doppler: [usize; 3],
    /// Processed range window, metres.
    pub range_window_m: [f64; 2],
    /// The experiment.
    pub spec: LocalizeSpec,
    /// Timings.
    pub timings_s: LocalizeTimings,
    /// Rayon threads.
    pub threads: usize,
    /// Definitions.
    pub conventions: LocalizeConventions,
}

/// The whole `report.json` of `has-sim localize`: a [`LocalizeReport`] with what only the caller
/// knows.
#[derive(Clone, Debug, Serialize)]
pub struct LocalizeRunReport {
    /// The scenario's name (its file, or the bundled one).
    pub scenario: String,
    /// The preset, `"quick"` or `"default"`.
    pub preset: String,
    /// The twin: its mesh file, or what stood in for it.
    pub twin: String,
    /// The run's report.
    pub localize: LocalizeReport,
}

impl LocalizeReport {
    /// The report of `r`, a run of `spec` that took `run_s` seconds after a twin built in
    /// `twin_reconstruction_s` (`None`: given). `timings_s.wall` is `run_s` plus the twin's time;
    /// a caller that does more may raise it.
    pub fn new(
        spec: &LocalizeSpec,
        r: &LocalizeResult,
        run_s: f64,
        twin_reconstruction_s: Option<f64>,
    ) -> LocalizeReport {
        let eca = &r.summaries[r.eca_best];
        let env = &r.summaries[r.env_pass];
        let frames = r
            .frames
            .iter()
            .map(|f| FrameReport {
                index: f.index,
                target_base: f.centre.to_array(),
                radial_speed_mps: f.radial_speed_mps,
                doppler_hz: f.doppler_hz,
                truth_points: f.truth.len(),
                detections: r
                    .passes
                    .iter()
                    .zip(&f.detections)
                    .map(|(p, d)| (p.clone(), d.len()))
                    .collect(),
                cancellation_db: r
                    .passes
                    .iter()
                    .zip(&f.cancellation_db)
                    .map(|(p, &d)| (p.clone(), d))
                    .collect(),
                template_db: f.template_db,
            })
            .collect();
        LocalizeReport {
            eca: eca.clone(),
            env: env.clone(),
            improvement_pct: improvement_pct(eca, env),
            eca_variants: r.eca_passes.iter().map(|&p| r.summaries[p].clone()).collect(),
            no_suppression: r.summaries[0].clone(),
            template_depth_db: r.frames.iter().map(|f| f.template_db).sum::<f64>()
                / r.frames.len() as f64,
            env_gate_fraction: r.frames.first().map(|f| f.gate_fraction),
            frames,
            clutter_scatterers: r.clutter_scatterers,
            twin_scatterers: r.twin_scatterers,
            target_scatterers_per_frame: r.target_scatterers,
            truth_points: r.frames.iter().map(|f| f.truth.len()).sum(),
            cube_range_beams_doppler: r.cube,
            range_window_m: r.range_window_m,
            spec: spec.clone(),
            timings_s: LocalizeTimings {
                wall: run_s + twin_reconstruction_s.unwrap_or(0.0),
                twin_reconstruction: twin_reconstruction_s,
                run: run_s,
                setup: r.timings_s.setup,
                synthesis: r.timings_s.synthesis,
                processing: r.timings_s.processing,
            },
            threads: rayon::current_num_threads(),
            conventions: LocalizeConventions {
                chamfer: "paper eq. 2 (squared distances, mean each way, summed), reported as sqrt, metres",
                s1: "detections within false_alarm_gate_m of the target's surface in their frame, pooled over frames",
                s2: "the target's true scattering points: its surface scatterers facing the base station at each CPI centre, pooled over frames",
                accuracy_completeness: "√CD² = accuracy² + completeness² (rms S1→S2 and S2→S1); completeness is also given on the truth points within 60° of their normal (cos ≥ 0.5)",
                false_alarm: "a detection farther than false_alarm_gate_m from the target cylinder's surface in its frame",
                cancellation_db: "energy of the beamformed slow-time data (range window × field of view) without suppression over with it",
                template_depth_db: "energy of the range-compressed frame before over after the environment template subtraction",
            },
        }
    }
}

impl LocalizeResult {
    /// The frames with the slowest and the fastest radial speed (where the clutter notch hurts
    /// most and least); `(0, 0)` without frames.
    pub fn slowest_and_fastest_frames(&self) -> (usize, usize) {
        let speed = |f: &&super::FrameResult| f.radial_speed_mps.abs();
        let slow = self
            .frames
            .iter()
            .min_by(|a, b| speed(a).total_cmp(&speed(b)))
            .map_or(0, |f| f.index);
        let fast = self
            .frames
            .iter()
            .max_by(|a, b| speed(a).total_cmp(&speed(b)))
            .map_or(0, |f| f.index);
        (slow, fast)
    }

    /// The range–Doppler map of `frame` after `pass` at the target's beam: `[Doppler][range]`
    /// (Doppler shifted so that zero is in the middle row), dB relative to the noise power of one
    /// cell. Size `cube[2] × cube[0]`.
    pub fn range_doppler_db(&self, frame: usize, pass: usize) -> Vec<f32> {
        let (nb, nd) = (self.cube[0], self.cube[2]);
        let rd = &self.frames[frame].range_doppler[pass];
        let noise_db = 10.0 * self.noise_cell.log10() as f32;
        let mut v = vec![0.0f32; nb * nd];
        for d in 0..nd {
            let ds = (d + nd / 2) % nd;
            for b in 0..nb {
                v[ds * nb + b] = 10.0 * rd[b * nd + d].max(1e-30).log10() - noise_db;
            }
        }
        v
    }
}

impl LocalizeSpec {
    /// The unambiguous Doppler half-span of a CPI, `1/(2·T_symbol)`, Hz.
    pub fn doppler_max_hz(&self) -> f64 {
        0.5 / (self.symbol_interval_ms * 1e-3)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mode(sqrt_chamfer_m: Option<f64>) -> ModeSummary {
        ModeSummary {
            label: "m".into(),
            sqrt_chamfer_m,
            sqrt_chamfer_all_m: None,
            accuracy_rms_m: None,
            completeness_rms_m: None,
            completeness_strong_rms_m: None,
            detections: 0,
            false_alarms: 0,
            frames_detected: 0,
            cancellation_db: 0.0,
        }
    }

    #[test]
    fn improvement_is_the_share_of_the_baseline_chamfer_removed() {
        let got = improvement_pct(&mode(Some(2.0)), &mode(Some(1.5))).unwrap();
        assert!((got - 25.0).abs() < 1e-12);
        // Worse than the baseline is a negative improvement, not clamped.
        assert!(improvement_pct(&mode(Some(1.0)), &mode(Some(1.5))).unwrap() < 0.0);
        assert_eq!(improvement_pct(&mode(None), &mode(Some(1.0))), None);
        assert_eq!(improvement_pct(&mode(Some(1.0)), &mode(None)), None);
        assert_eq!(improvement_pct(&mode(Some(0.0)), &mode(Some(0.0))), None);
    }
}
