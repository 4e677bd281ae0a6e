//! The data exports of a channel experiment ([`super::ChannelExperiment`]) beside its report:
//! the per-pair and per-UE tables (`errors.csv`, `ues.csv` of `has-sim channel`, built here as
//! strings with their headers), the matched pairs' errors by parameter (the error CDFs) and the
//! points of the top-view UE map ([`UeMap`]: the unknown objects' surface samples, the kept and
//! the dropped UEs, the BS). Plotting and writing files is the caller's.
//!
//! Units as in the report: metres, dB, ns for delays, degrees for angle errors ([`super::KEYS`]).
//! CSV numbers are fixed-point (positions and gains to 3 decimals, delays to 4, the distance to
//! 4 and the errors to 5); an absent value (no true path, no beam, no prediction) is an empty
//! field.

use glam::{DVec3, Vec3};
use serde::Serialize;

use super::{MatchedPair, PerParam};
use crate::channel_experiment::comparison::UeOutcome;
use crate::knn::GeometryError;
use crate::metrics::sample_triangles;
use crate::scene::Scene;

/// The header line of [`errors_csv`] (with its newline): one column per field of
/// [`MatchedPair::csv_line`].
pub const ERRORS_CSV_HEADER: &str = "ue,direction,path,order,via_building,gain_db,delay_ns,matched_path,matched_order,distance,delay_err_ns,aoa_err_deg,aod_err_deg,zoa_err_deg,zod_err_deg\n";

/// The header line of [`ues_csv`] (with its newline).
pub const UES_CSV_HEADER: &str = "ue,x,y,z,kept,strongest_true_db,true_paths,twin_paths,true_best_beam,predicted_beam,beam_loss_db\n";

/// Density of the surface samples of [`UeMap::buildings`], per m².
pub const MAP_SAMPLE_DENSITY_PER_M2: f64 = 2.0;

/// Seed of the surface samples of [`UeMap::buildings`].
pub const MAP_SAMPLE_SEED: u64 = 1;

impl MatchedPair {
    /// The pair's line of [`errors_csv`] (the columns of [`ERRORS_CSV_HEADER`]), with its
    /// newline: UE, direction, the source path (index in its windowed set, order, via the
    /// building as 0/1, gain dB, delay ns), its match (index, order, distance) and the five
    /// errors in [`super::KEYS`] order.
    pub fn csv_line(&self) -> String {
        let (m, a, b) = (&self.matched, &self.source, &self.target);
        let e = self.errors();
        format!(
            "{},{},{},{},{},{:.3},{:.4},{},{},{:.4},{:.5},{:.5},{:.5},{:.5},{:.5}\n",
            self.ue,
            self.direction.name(),
            m.from,
            a.order,
            u8::from(self.via_building),
            a.gain_db,
            a.delay_s * 1e9,
            m.to,
            b.order,
            m.distance,
            e[0],
            e[1],
            e[2],
            e[3],
            e[4]
        )
    }
}

/// `errors.csv`: [`ERRORS_CSV_HEADER`] and one [`MatchedPair::csv_line`] per pair, in order.
pub fn errors_csv(pairs: &[MatchedPair]) -> String {
    let mut csv = String::from(ERRORS_CSV_HEADER);
    for p in pairs {
        csv.push_str(&p.csv_line());
    }
    csv
}

/// `ues.csv`: [`UES_CSV_HEADER`] and one line per UE (`ues[i]` with `outcomes[i]`): its index
/// and position, kept (0/1), the strongest true path's gain, the windowed path counts of both
/// models, the true best beam, the predicted beam and the beam loss (dB; `inf` when the twin has
/// no path).
pub fn ues_csv(ues: &[DVec3], outcomes: &[UeOutcome]) -> String {
    let mut s = String::from(UES_CSV_HEADER);
    for (i, (p, o)) in ues.iter().zip(outcomes).enumerate() {
        let opt = |v: Option<String>| v.unwrap_or_default();
        s.push_str(&format!(
            "{i},{:.3},{:.3},{:.3},{},{},{},{},{},{},{}\n",
            p.x,
            p.y,
            p.z,
            u8::from(o.kept),
            opt(o.strongest_true_db.map(|g| format!("{g:.3}"))),
            o.true_paths.len(),
            o.twin_paths.len(),
            opt(o.beam.map(|b| b.true_best.to_string())),
            opt(o.beam.and_then(|b| b.predicted).map(|b| b.to_string())),
            opt(o.beam.map(|b| format!("{:.3}", b.loss_db()))),
        ));
    }
    s
}

/// The errors of every pair by parameter, in pair order ([`MatchedPair::errors`]): the samples of
/// the error CDFs.
pub fn errors_by_param(pairs: &[MatchedPair]) -> PerParam<Vec<f64>> {
    PerParam::from_array(std::array::from_fn(|k| {
        pairs.iter().map(|p| p.errors()[k]).collect()
    }))
}

/// The points of the top-view UE map.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct UeMap {
    /// Surface samples of every object of the true scene that is not known (the buildings), at
    /// [`MAP_SAMPLE_DENSITY_PER_M2`]; empty when every object is known.
    pub buildings: Vec<Vec3>,
    /// The kept UEs, in UE order.
    pub kept: Vec<Vec3>,
    /// The dropped UEs, in UE order.
    pub dropped: Vec<Vec3>,
    /// The BS.
    pub bs: Vec3,
}

/// The [`UeMap`] of an experiment: `truth` and its `known_objects` (by name), the UEs
/// `ues[i]` with `outcomes[i]`, the BS at `bs`.
///
/// # Errors
/// [`GeometryError`] from [`sample_triangles`]: a non-finite vertex, too many samples.
pub fn ue_map(
    truth: &Scene,
    known_objects: &[String],
    ues: &[DVec3],
    outcomes: &[UeOutcome],
    bs: DVec3,
) -> Result<UeMap, GeometryError> {
    let tris: Vec<[Vec3; 3]> = truth
        .objects
        .iter()
        .filter(|o| !known_objects.contains(&o.name))
        .flat_map(|o| o.triangles.iter().copied())
        .collect();
    let buildings = if tris.is_empty() {
        Vec::new()
    } else {
        sample_triangles(&tris, MAP_SAMPLE_DENSITY_PER_M2, MAP_SAMPLE_SEED)?
    };
    let (kept, dropped): (Vec<_>, Vec<_>) = ues.iter().zip(outcomes).partition(|(_, o)| o.kept);
    Ok(UeMap {
        buildings,
        kept: kept.iter().map(|(p, _)| p.as_vec3()).collect(),
        dropped: dropped.iter().map(|(p, _)| p.as_vec3()).collect(),
        bs: bs.as_vec3(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::channel_experiment::comparison::BeamOutcome;
    use crate::channel_experiment::MatchDirection;
    use crate::material::Material;
    use crate::multipath::{ChamferMatch, Match, ParamErrors, PathParams};
    use crate::paths::MAX_ORDER;
    use crate::scene::Object;

    fn path(order: usize) -> PathParams {
        let mut objects = [u32::MAX; MAX_ORDER];
        objects[..order].fill(1);
        PathParams {
            delay_s: 123.456_78e-9,
            gain_db: -87.654_32,
            aod: 0.1,
            zod: 1.2,
            aoa: -0.3,
            zoa: 1.4,
            order,
            objects,
        }
    }

    fn outcome(kept: bool, beam: Option<BeamOutcome>) -> UeOutcome {
        UeOutcome {
            strongest_true_db: kept.then_some(-80.0),
            kept,
            true_paths: vec![path(0), path(1)],
            twin_paths: vec![path(0)],
            matches: ChamferMatch {
                forward: Vec::new(),
                backward: Vec::new(),
            },
            beam,
        }
    }

    fn columns(line: &str) -> usize {
        line.trim_end_matches('\n').split(',').count()
    }

    #[test]
    fn every_csv_line_has_the_columns_of_its_header() {
        let pair = MatchedPair {
            ue: 7,
            direction: MatchDirection::TwinToTrue,
            matched: Match {
                from: 2,
                to: 0,
                distance: 1.25,
                errors: ParamErrors {
                    delay_s: 0.5e-9,
                    aoa: 1f64.to_radians(),
                    aod: 2f64.to_radians(),
                    zoa: 0.0,
                    zod: 0.25f64.to_radians(),
                },
            },
            source: path(2),
            target: path(1),
            via_building: true,
        };
        let csv = errors_csv(std::slice::from_ref(&pair));
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines.len(), 2);
        assert_eq!(format!("{}\n", lines[0]), ERRORS_CSV_HEADER);
        assert_eq!(columns(lines[1]), columns(ERRORS_CSV_HEADER));
        assert_eq!(
            lines[1],
            "7,twin_to_true,2,2,1,-87.654,123.4568,0,1,1.2500,0.50000,1.00000,2.00000,0.00000,0.25000"
        );

        let beam = BeamOutcome {
            true_best: 3,
            true_best_gain: 10.0,
            predicted: Some(4),
            predicted_gain_on_true: 1.0,
        };
        let no_prediction = BeamOutcome {
            predicted: None,
            ..beam
        };
        let ues = [DVec3::new(1.0, 2.0, 1.5); 3];
        let outcomes = [
            outcome(true, Some(beam)),
            outcome(true, Some(no_prediction)),
            outcome(false, None),
        ];
        let csv = ues_csv(&ues, &outcomes);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(format!("{}\n", lines[0]), UES_CSV_HEADER);
        assert_eq!(lines.len(), 4);
        for l in &lines[1..] {
            assert_eq!(columns(l), columns(UES_CSV_HEADER), "{l}");
        }
        assert_eq!(lines[1], "0,1.000,2.000,1.500,1,-80.000,2,1,3,4,10.000");
        assert_eq!(lines[2], "1,1.000,2.000,1.500,1,-80.000,2,1,3,,inf");
        assert_eq!(lines[3], "2,1.000,2.000,1.500,0,,2,1,,,");
    }

    #[test]
    fn the_ue_map_splits_the_ues_and_samples_only_the_unknown_objects() {
        // The known ground at z = 0 and a 10 m × 10 m wall in the plane x = 5.
        let ground = Object {
            thickness_m: None,
            name: "ground".into(),
            material: Material::Concrete,
            triangles: vec![[
                Vec3::new(-20.0, -20.0, 0.0),
                Vec3::new(20.0, -20.0, 0.0),
                Vec3::new(0.0, 20.0, 0.0),
            ]],
        };
        let (a, b, c, d) = (
            Vec3::new(5.0, 0.0, 0.0),
            Vec3::new(5.0, 10.0, 0.0),
            Vec3::new(5.0, 10.0, 10.0),
            Vec3::new(5.0, 0.0, 10.0),
        );
        let wall = Object {
            thickness_m: None,
            name: "wall".into(),
            material: Material::Concrete,
            triangles: vec![[a, b, c], [a, c, d]],
        };
        let scene = Scene::new(vec![ground, wall]).expect("a valid scene");
        let ues: Vec<DVec3> = (0..5).map(|i| DVec3::new(i as f64, 0.0, 1.5)).collect();
        let outcomes: Vec<UeOutcome> = [true, false, true, true, false]
            .iter()
            .map(|&k| outcome(k, None))
            .collect();
        let bs = DVec3::new(0.0, -5.0, 10.0);
        let map = ue_map(&scene, &["ground".into()], &ues, &outcomes, bs).expect("samples");
        assert_eq!(map.kept.len(), 3);
        assert_eq!(map.dropped.len(), 2);
        assert_eq!(map.kept[1], Vec3::new(2.0, 0.0, 1.5));
        assert_eq!(map.dropped[0], Vec3::new(1.0, 0.0, 1.5));
        assert_eq!(map.bs, bs.as_vec3());
        // 100 m² at 2 per m², all on the wall.
        assert!(
            (190..=210).contains(&map.buildings.len()),
            "{}",
            map.buildings.len()
        );
        assert!(map.buildings.iter().all(|p| (p.x - 5.0).abs() < 1e-4));
        let all_known = ue_map(
            &scene,
            &["ground".into(), "wall".into()],
            &ues,
            &outcomes,
            bs,
        )
        .expect("no samples");
        assert!(all_known.buildings.is_empty());
    }

    #[test]
    fn errors_by_param_are_the_pairs_errors_column_by_column() {
        let mk = |delay_ns: f64| MatchedPair {
            ue: 0,
            direction: MatchDirection::TrueToTwin,
            matched: Match {
                from: 0,
                to: 0,
                distance: 0.0,
                errors: ParamErrors {
                    delay_s: delay_ns * 1e-9,
                    aoa: 0.0,
                    aod: std::f64::consts::PI,
                    zoa: 0.0,
                    zod: 0.0,
                },
            },
            source: path(0),
            target: path(0),
            via_building: false,
        };
        let e = errors_by_param(&[mk(1.0), mk(2.0)]);
        assert_eq!(e.delay_ns.len(), 2);
        assert!((e.delay_ns[1] - 2.0).abs() < 1e-9);
        assert!(e.aod_deg.iter().all(|&x| (x - 180.0).abs() < 1e-9));
        assert!(errors_by_param(&[]).zoa_deg.is_empty());
    }
}
