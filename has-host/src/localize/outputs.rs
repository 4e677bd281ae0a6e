//! The data behind the files of a localization run ([`super::run_localize`]) beside its report:
//! the oracle twin (the true scene's buildings, [`LocalizeSpec::true_buildings`]), the target's
//! true scattering points pooled over frames ([`LocalizeResult::truth_points`]), the detections
//! of one pass as a point cloud with per-point columns ([`DetectionCloud`]), and the
//! range–Doppler maps a reader looks at ([`RangeDopplerMap`]: the frames with the slowest and the
//! fastest radial speed, before suppression, after the best ECA variant and after the
//! environment prior). Writing PLY files and plotting is the caller's.
//!
//! Units: metres, hertz, dB; range–Doppler maps as [`LocalizeResult::range_doppler_db`] (dB over
//! the noise power of one cell, zero Doppler in the middle row).

use glam::Vec3;
use serde::Serialize;

use super::run::LocalizeResult;
use crate::scenario::LocalizeSpec;
use crate::scene::{Object, Scene};

impl LocalizeSpec {
    /// The objects of `scene` that are not in `ground_objects` (the buildings), in scene order:
    /// the oracle twin, the environment prior's ceiling with a perfect reconstruction.
    pub fn true_buildings(&self, scene: &Scene) -> Vec<Object> {
        scene
            .objects
            .iter()
            .filter(|o| !self.ground_objects.contains(&o.name))
            .cloned()
            .collect()
    }
}

/// The detections of one pass over all frames, in frame order, with one value per point in each
/// column.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct DetectionCloud {
    /// Positions, metres.
    pub points: Vec<Vec3>,
    /// The frame index of each detection.
    pub frame: Vec<f32>,
    /// Its SNR, dB.
    pub snr_db: Vec<f32>,
    /// Its Doppler shift, Hz.
    pub doppler_hz: Vec<f32>,
}

/// Which frame a [`RangeDopplerMap`] shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RdFrame {
    /// The frame with the slowest radial speed (where the clutter notch hurts most).
    Slow,
    /// The frame with the fastest radial speed.
    Fast,
}

/// Which processing stage a [`RangeDopplerMap`] shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RdStage {
    /// Before clutter suppression (pass 0).
    Before,
    /// After the reported ECA baseline ([`LocalizeResult::eca_best`]).
    Eca,
    /// After the environment prior ([`LocalizeResult::env_pass`]).
    Env,
}

impl RdFrame {
    /// `"slow"` or `"fast"`.
    pub fn name(self) -> &'static str {
        match self {
            RdFrame::Slow => "slow",
            RdFrame::Fast => "fast",
        }
    }
}

impl RdStage {
    /// `"before"`, `"eca"` or `"env"`.
    pub fn name(self) -> &'static str {
        match self {
            RdStage::Before => "before",
            RdStage::Eca => "eca",
            RdStage::Env => "env",
        }
    }
}

/// One range–Doppler map at the beam towards the target.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RangeDopplerMap {
    /// Which frame.
    pub which: RdFrame,
    /// Which stage.
    pub stage: RdStage,
    /// The frame's index.
    pub frame: usize,
    /// The target's radial speed in that frame, m/s.
    pub radial_speed_mps: f32,
    /// The pass shown (index into [`LocalizeResult::passes`]).
    pub pass: usize,
    /// Range axis: the processed window, metres.
    pub range_m: [f64; 2],
    /// Doppler axis, Hz: ± [`LocalizeSpec::doppler_max_hz`].
    pub doppler_hz: [f64; 2],
    /// Range bins and Doppler bins.
    pub bins: [usize; 2],
    /// `[Doppler][range]`, dB ([`LocalizeResult::range_doppler_db`]).
    pub db: Vec<f32>,
}

impl LocalizeResult {
    /// The target's true scattering points of every frame, frame by frame.
    pub fn truth_points(&self) -> Vec<Vec3> {
        self.frames.iter().flat_map(|f| f.truth.clone()).collect()
    }

    /// The detections of `pass` (an index into [`LocalizeResult::passes`]) over all frames.
    pub fn detection_cloud(&self, pass: usize) -> DetectionCloud {
        let mut c = DetectionCloud::default();
        for f in &self.frames {
            for d in &f.detections[pass] {
                c.points.push(d.pos);
                c.frame.push(f.index as f32);
                c.snr_db.push(d.snr_db);
                c.doppler_hz.push(d.doppler_hz);
            }
        }
        c
    }

    /// The six range–Doppler maps of a run of `spec`: the slowest frame before suppression,
    /// after the ECA baseline and after the environment prior, then the same for the fastest
    /// frame ([`LocalizeResult::slowest_and_fastest_frames`]). Empty without frames.
    pub fn range_doppler_maps(&self, spec: &LocalizeSpec) -> Vec<RangeDopplerMap> {
        if self.frames.is_empty() {
            return Vec::new();
        }
        let (slow, fast) = self.slowest_and_fastest_frames();
        let fmax = spec.doppler_max_hz();
        let mut maps = Vec::with_capacity(6);
        for (which, fi) in [(RdFrame::Slow, slow), (RdFrame::Fast, fast)] {
            for (stage, pass) in [
                (RdStage::Before, 0usize),
                (RdStage::Eca, self.eca_best),
                (RdStage::Env, self.env_pass),
            ] {
                maps.push(RangeDopplerMap {
                    which,
                    stage,
                    frame: fi,
                    radial_speed_mps: self.frames[fi].radial_speed_mps,
                    pass,
                    range_m: self.range_window_m,
                    doppler_hz: [-fmax, fmax],
                    bins: [self.cube[0], self.cube[2]],
                    db: self.range_doppler_db(fi, pass),
                });
            }
        }
        maps
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::localize::run::{FrameResult, ModeSummary, Timings};
    use crate::localize::Detection;

    fn summary(label: &str) -> ModeSummary {
        ModeSummary {
            label: label.into(),
            sqrt_chamfer_m: None,
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

    fn detection(x: f32, snr_db: f32) -> Detection {
        Detection {
            pos: Vec3::new(x, 0.0, 1.0),
            range_m: x,
            doppler_hz: -x,
            snr_db,
        }
    }

    /// Two passes (`none`, `env`), three frames, a 4-bin range × 2-bin Doppler cube.
    fn result() -> LocalizeResult {
        let frame = |index: usize, speed: f32, dets: Vec<Vec<Detection>>| FrameResult {
            index,
            centre: Vec3::ZERO,
            radial_speed_mps: speed,
            doppler_hz: 0.0,
            truth: vec![Vec3::splat(index as f32); index + 1],
            truth_cos: vec![1.0; index + 1],
            detections: dets,
            cancellation_db: vec![0.0, 0.0],
            template_db: 0.0,
            gate_fraction: 0.0,
            // [b][d]: power b + 4·d + 1 + 10·pass.
            range_doppler: (0..2)
                .map(|pass| {
                    (0..8)
                        .map(|i| (i / 2 + 4 * (i % 2)) as f32 + 1.0 + 10.0 * pass as f32)
                        .collect()
                })
                .collect(),
        };
        LocalizeResult {
            passes: vec!["none".into(), "env".into()],
            env_pass: 1,
            eca_passes: vec![],
            frames: vec![
                frame(0, -2.0, vec![vec![detection(1.0, 10.0)], vec![]]),
                frame(
                    1,
                    0.5,
                    vec![vec![], vec![detection(2.0, 20.0), detection(3.0, 30.0)]],
                ),
                frame(
                    2,
                    3.0,
                    vec![vec![detection(4.0, 40.0)], vec![detection(5.0, 50.0)]],
                ),
            ],
            summaries: vec![summary("none"), summary("env")],
            eca_best: 0,
            clutter_scatterers: 0,
            twin_scatterers: 0,
            target_scatterers: 0.0,
            cube: [4, 1, 2],
            range_window_m: [10.0, 20.0],
            noise_cell: 1.0,
            timings_s: Timings::default(),
            rd_beam: vec![0; 3],
        }
    }

    #[test]
    fn detection_clouds_and_truth_are_pooled_frame_by_frame() {
        let r = result();
        assert_eq!(r.truth_points().len(), 1 + 2 + 3);
        assert_eq!(r.truth_points()[5], Vec3::splat(2.0));
        let env = r.detection_cloud(1);
        assert_eq!(env.points.len(), 3);
        assert_eq!(env.frame, [1.0, 1.0, 2.0]);
        assert_eq!(env.snr_db, [20.0, 30.0, 50.0]);
        assert_eq!(env.doppler_hz, [-2.0, -3.0, -5.0]);
        let none = r.detection_cloud(0);
        assert_eq!(none.frame, [0.0, 2.0]);
        assert_eq!(none.points[1], Vec3::new(4.0, 0.0, 1.0));
    }

    #[test]
    fn range_doppler_maps_are_the_slowest_then_the_fastest_frame_at_three_stages() {
        let r = result();
        let spec: LocalizeSpec = crate::scenario::Scenario::from_toml_str(include_str!(
            "../../../fixtures/factory.toml"
        ))
        .expect("the bundled scenario")
        .localize
        .expect("a [localize] table");
        let maps = r.range_doppler_maps(&spec);
        let got: Vec<(&str, &str, usize, usize)> = maps
            .iter()
            .map(|m| (m.which.name(), m.stage.name(), m.frame, m.pass))
            .collect();
        assert_eq!(
            got,
            [
                ("slow", "before", 1, 0),
                ("slow", "eca", 1, 0),
                ("slow", "env", 1, 1),
                ("fast", "before", 2, 0),
                ("fast", "eca", 2, 0),
                ("fast", "env", 2, 1),
            ]
        );
        let m = &maps[2];
        assert_eq!(m.radial_speed_mps, 0.5);
        assert_eq!(m.bins, [4, 2]);
        assert_eq!(m.range_m, [10.0, 20.0]);
        assert_eq!(
            m.doppler_hz,
            [-spec.doppler_max_hz(), spec.doppler_max_hz()]
        );
        assert_eq!(m.db, r.range_doppler_db(1, 1));
        assert_eq!(m.db.len(), 8);
        let none = LocalizeResult {
            frames: vec![],
            ..r
        };
        assert!(none.range_doppler_maps(&spec).is_empty());
    }

    #[test]
    fn the_true_buildings_are_every_object_but_the_ground() {
        let sc = crate::scenario::Scenario::from_toml_str(include_str!(
            "../../../fixtures/factory.toml"
        ))
        .expect("the bundled scenario");
        let spec = sc.localize.clone().expect("a [localize] table");
        let scene = sc.scene.build().expect("the scene");
        let kept = spec.true_buildings(&scene);
        assert!(!spec.ground_objects.is_empty());
        assert_eq!(kept.len() + spec.ground_objects.len(), scene.objects.len());
        assert!(kept.iter().all(|o| !spec.ground_objects.contains(&o.name)));
    }
}
