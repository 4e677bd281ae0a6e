//! Where a reconstruction's wall time went, stage by stage ([`StageTimes`], `has-sim bench
//! pipeline`), from the timings its [`ReconstructReport`] records: the run's setup, wall and
//! imaging time, each pair's echo-synthesis and back-projection seconds, the mesher's seconds.
//! The coarse and the fine back-projection pass are timed together, and detection (the clutter
//! test, the sidelobe test, point extraction) together with the fusion (smearing, confirmation,
//! the terrain-echo and finer-height tests): the run records no finer split.

use std::fmt::Write;

use serde::Serialize;

use super::ReconstructReport;

/// The figures a report records, seconds.
struct Recorded {
    wall: f64,
    setup: f64,
    imaging: f64,
    synthesis: f64,
    backprojection: f64,
    surface: f64,
    threads: usize,
    pairs: usize,
}

/// One stage of [`StageTimes`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StageTime {
    /// Its name.
    pub stage: &'static str,
    /// What it covers.
    pub covers: &'static str,
    /// Wall seconds.
    pub seconds: f64,
    /// Its share of the run's wall time, %.
    pub share_pct: f64,
}

/// A reconstruction's wall time by stage (module docs); the stages add up to the wall time.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StageTimes {
    /// The run's wall time, seconds.
    pub wall_s: f64,
    /// Rayon threads.
    pub threads: usize,
    /// Pairs imaged.
    pub pairs: usize,
    /// The stages, in the order the run goes through them.
    pub stages: Vec<StageTime>,
}

impl StageTimes {
    /// The stages of `report`'s run. What the recorded figures leave of the imaging time after
    /// synthesis and back-projection is detection and fusion; what they leave of the wall time
    /// after setup, imaging and the mesher is scoring (and, in `has-sim`, writing the files).
    /// A stage whose remainder comes out negative (timer overlap) is shown as 0.
    pub fn of(report: &ReconstructReport) -> StageTimes {
        let t = &report.timings_s;
        let stats = report.imaging.pairs.iter().map(|p| &p.stats);
        StageTimes::from_recorded(Recorded {
            wall: t.wall,
            setup: t.setup,
            imaging: t.imaging,
            synthesis: stats.clone().map(|s| s.synth_s).sum(),
            backprojection: stats.map(|s| s.bp_s).sum(),
            surface: report.mesh.as_ref().map_or(0.0, |m| m.seconds),
            threads: report.threads,
            pairs: report.imaging.pairs.len(),
        })
    }

    fn from_recorded(t: Recorded) -> StageTimes {
        let rows = [
            (
                "setup",
                "scene and BVH, scatterers, truth samples, terrain, pair plan",
                t.setup,
            ),
            (
                "synthesis",
                "echo synthesis, summed over the pairs",
                t.synthesis,
            ),
            (
                "back-projection",
                "coarse and fine passes, summed over the pairs",
                t.backprojection,
            ),
            (
                "detection + fusion",
                "clutter and sidelobe tests, points; fusion and confirmation",
                t.imaging - t.synthesis - t.backprojection,
            ),
            (
                "surface",
                "screened Poisson and the wall and roof rules",
                t.surface,
            ),
            (
                "scoring",
                "cloud and mesh metrics, mesh samples, files",
                t.wall - t.setup - t.imaging - t.surface,
            ),
        ];
        let wall = t.wall.max(f64::MIN_POSITIVE);
        StageTimes {
            wall_s: t.wall,
            threads: t.threads,
            pairs: t.pairs,
            stages: rows
                .into_iter()
                .map(|(stage, covers, s)| {
                    let seconds = if s.is_finite() { s.max(0.0) } else { 0.0 };
                    StageTime {
                        stage,
                        covers,
                        seconds,
                        share_pct: 100.0 * seconds / wall,
                    }
                })
                .collect(),
        }
    }

    /// The stages as an aligned text table, one row per stage and one for the wall time.
    pub fn table(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "{:<20} {:>10} {:>7}  covers",
            "stage", "wall (s)", "share"
        );
        for r in &self.stages {
            let _ = writeln!(
                s,
                "{:<20} {:>10.2} {:>6.1}%  {}",
                r.stage, r.seconds, r.share_pct, r.covers
            );
        }
        let _ = writeln!(
            s,
            "{:<20} {:>10.2} {:>6.1}%  {} pairs, {} threads",
            "wall", self.wall_s, 100.0, self.pairs, self.threads
        );
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn recorded(imaging: f64, surface: f64) -> Recorded {
        Recorded {
            wall: 100.0,
            setup: 5.0,
            imaging,
            synthesis: 20.0,
            backprojection: 40.0,
            surface,
            threads: 2,
            pairs: 24,
        }
    }

    #[test]
    fn the_stages_add_up_to_the_wall_time_and_a_negative_remainder_is_zero() {
        let st = StageTimes::from_recorded(recorded(70.0, 15.0));
        let secs: Vec<f64> = st.stages.iter().map(|r| r.seconds).collect();
        assert_eq!(secs, vec![5.0, 20.0, 40.0, 10.0, 15.0, 10.0]);
        let share: f64 = st.stages.iter().map(|r| r.share_pct).sum();
        assert!((share - 100.0).abs() < 1e-9, "{share}");
        let table = st.table();
        assert_eq!(table.lines().count(), 8, "{table}");
        assert!(table.contains("detection + fusion") && table.contains("24 pairs"));
        // Timers that overlap (synthesis and back-projection over the imaging time).
        let st = StageTimes::from_recorded(recorded(50.0, 0.0));
        assert_eq!(st.stages[3].seconds, 0.0);
        assert!(st.stages.iter().all(|r| r.seconds >= 0.0));
    }
}
