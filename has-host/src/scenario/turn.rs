//! Turning a scenario about a vertical axis: the same site in another orientation, to check that
//! a result does not depend on which way the site faces (issue 13: rotating the whole scenario
//! changes every metric by less than 5 %).
//!
//! [`Scenario::turned`] turns everything placed in the plane by an angle, counter-clockwise seen
//! from above, about the vertical axis through a point (x, y): building centres and yaws,
//! cylinder centres, mesh objects (their `yaw_deg` and `offset`), base-station positions and
//! boresights, the terminals' tracks, the imaging region (its rectangle becomes a
//! `region_polygon`, its bounding box the new `region_min`/`region_max`; a polygon turns vertex
//! by vertex), the `[channel]` base station and the `[localize]` base station and track. Heights do not change. Two things cannot turn and
//! are kept or refused:
//! - a ground rectangle is axis-aligned in the file format: it stays as it is; where the grounds
//!   covered every corner of the imaging region before the turn, a turned corner no ground covers
//!   is an error naming the corner (the site would stand partly on no ground: enlarge the ground
//!   or turn about the site's centre);
//! - the `[channel]` UE rectangle is axis-aligned too: it becomes the turned rectangle's bounding
//!   box, so the channel experiment draws other UEs (its result is not expected to turn with the
//!   site).
//!
//! Units: degrees in the call as in the file, metres.

use glam::Vec2;

use super::{ObjectSpec, Scenario, ScenarioError};

/// A turn by `deg` about the vertical axis through `about`.
#[derive(Clone, Copy, Debug)]
struct Turn {
    about: Vec2,
    cos: f64,
    sin: f64,
    deg: f64,
}

impl Turn {
    fn xy(&self, p: [f64; 2]) -> [f64; 2] {
        let (x, y) = (p[0] - self.about.x as f64, p[1] - self.about.y as f64);
        [
            self.about.x as f64 + self.cos * x - self.sin * y,
            self.about.y as f64 + self.sin * x + self.cos * y,
        ]
    }

    fn f32_2(&self, p: [f32; 2]) -> [f32; 2] {
        let q = self.xy([p[0] as f64, p[1] as f64]);
        [q[0] as f32, q[1] as f32]
    }

    fn f32_3(&self, p: [f32; 3]) -> [f32; 3] {
        let q = self.f32_2([p[0], p[1]]);
        [q[0], q[1], p[2]]
    }

    fn f64_3(&self, p: [f64; 3]) -> [f64; 3] {
        let q = self.xy([p[0], p[1]]);
        [q[0], q[1], p[2]]
    }

    /// An azimuth in degrees, turned and wrapped to (−180°, 180°].
    fn azimuth(&self, deg: f64) -> f64 {
        let a = (deg + self.deg).rem_euclid(360.0);
        if a > 180.0 {
            a - 360.0
        } else {
            a
        }
    }
}

impl Scenario {
    /// The scenario turned by `deg` degrees counter-clockwise (seen from above) about the
    /// vertical axis through `about` (x, y, metres), validated (module docs).
    ///
    /// # Errors
    /// [`ScenarioError::Invalid`] naming `deg` or `about` when not finite; any error
    /// [`Scenario::validate`] finds in the turned scenario.
    pub fn turned(&self, deg: f64, about: Vec2) -> Result<Scenario, ScenarioError> {
        let invalid = |field: &str, value: String, expected: &'static str| ScenarioError::Invalid {
            field: field.into(),
            value,
            expected,
        };
        if !deg.is_finite() {
            return Err(invalid("turn.deg", format!("{deg:?}"), "a finite angle"));
        }
        if !about.is_finite() {
            return Err(invalid(
                "turn.about",
                format!("{about:?}"),
                "a finite point",
            ));
        }
        // One reduced angle for positions and azimuths alike: `to_radians` of a huge angle and
        // its `rem_euclid(360)` are different turns.
        let deg = deg.rem_euclid(360.0);
        let (sin, cos) = deg.to_radians().sin_cos();
        let t = Turn {
            about,
            cos,
            sin,
            deg,
        };
        let mut s = self.clone();
        for o in s.scene.objects.iter_mut() {
            match o {
                ObjectSpec::Building(b) | ObjectSpec::Box(b) => {
                    b.center = t.f32_2(b.center);
                    b.yaw_deg = t.azimuth(b.yaw_deg as f64) as f32;
                }
                ObjectSpec::Cylinder(c) => c.center = t.f32_2(c.center),
                ObjectSpec::Ground(_) => {}
                ObjectSpec::Mesh(m) => {
                    // v ↦ R(θ)(R(yaw)v + offset − about) + about: the yaw grows by θ, the
                    // offset turns like a position.
                    m.offset = t.f32_3(m.offset);
                    m.yaw_deg = t.azimuth(m.yaw_deg as f64) as f32;
                }
            }
        }
        for b in &mut s.base_stations {
            b.position = t.f32_3(b.position);
            b.boresight_deg = t.azimuth(b.boresight_deg as f64) as f32;
        }
        for a in &mut s.apertures {
            a.start = t.f32_3(a.start);
            a.end = t.f32_3(a.end);
        }
        let grounds: Vec<([f32; 2], [f32; 2])> = s
            .scene
            .objects
            .iter()
            .filter_map(|o| match o {
                ObjectSpec::Ground(g) => Some((g.min, g.max)),
                _ => None,
            })
            .collect();
        let on_ground = |v: &[f32; 2]| {
            grounds
                .iter()
                .any(|(lo, hi)| (lo[0]..=hi[0]).contains(&v[0]) && (lo[1]..=hi[1]).contains(&v[1]))
        };
        let corners = s.region_footprint();
        let im = &mut s.imaging;
        let polygon: Vec<[f32; 2]> = corners.iter().map(|&v| t.f32_2(v)).collect();
        if corners.iter().all(on_ground) {
            if let Some(v) = polygon.iter().find(|v| !on_ground(v)) {
                return Err(invalid(
                    "imaging.region (turned)",
                    format!("corner {v:?}"),
                    "on a ground rectangle as before the turn: enlarge the ground or turn about \
                     the site's centre",
                ));
            }
        }
        let (lo, hi) = polygon.iter().fold(
            (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY)),
            |(lo, hi), v| (lo.min(Vec2::from(*v)), hi.max(Vec2::from(*v))),
        );
        im.region_min = [lo.x, lo.y, im.region_min[2]];
        im.region_max = [hi.x, hi.y, im.region_max[2]];
        im.region_polygon = Some(polygon);
        if let Some(c) = &mut s.channel {
            c.bs_position = t.f64_3(c.bs_position);
            c.bs_boresight_deg = t.azimuth(c.bs_boresight_deg);
            let (lo, hi) = (c.ue_region_min, c.ue_region_max);
            let corners = [
                [lo[0], lo[1]],
                [hi[0], lo[1]],
                [hi[0], hi[1]],
                [lo[0], hi[1]],
            ]
            .map(|v| t.xy(v));
            c.ue_region_min = [0, 1].map(|k| corners.iter().map(|v| v[k]).fold(f64::MAX, f64::min));
            c.ue_region_max = [0, 1].map(|k| corners.iter().map(|v| v[k]).fold(f64::MIN, f64::max));
        }
        if let Some(l) = &mut s.localize {
            l.position = t.f32_3(l.position);
            l.boresight_deg = t.azimuth(l.boresight_deg as f64) as f32;
            l.track_start = t.f32_3(l.track_start);
            l.track_end = t.f32_3(l.track_end);
        }
        s.validate()?;
        Ok(s)
    }

    /// The scenario as TOML text that [`Scenario::from_toml_str`] reads back to the same
    /// scenario (comments are not kept).
    ///
    /// # Errors
    /// [`ScenarioError::Toml`] if serialisation fails.
    pub fn to_toml_string(&self) -> Result<String, ScenarioError> {
        toml::to_string(self).map_err(|e| ScenarioError::Toml {
            path: "<string>".into(),
            msg: e.to_string(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use std::path::Path;

    fn fixture(name: &str) -> Scenario {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        Scenario::load(&root.join(name)).expect("fixture loads")
    }

    #[test]
    fn the_factory_site_turned_37_degrees_is_the_suites_rotated_factory() {
        let turned = fixture("fixtures/suite/factory_site.toml")
            .turned(37.0, Vec2::ZERO)
            .unwrap();
        let want = fixture("fixtures/suite/factory_rotated.toml");
        let close = |a: &[f32], b: &[f32], tol: f32| {
            a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol) && a.len() == b.len()
        };
        for (a, b) in turned.base_stations.iter().zip(&want.base_stations) {
            assert!(close(&a.position, &b.position, 0.01), "{a:?} vs {b:?}");
            assert!((a.boresight_deg - b.boresight_deg).abs() < 0.01);
        }
        for (a, b) in turned.apertures.iter().zip(&want.apertures) {
            assert!(
                close(&a.start, &b.start, 0.01) && close(&a.end, &b.end, 0.01),
                "{}",
                a.name
            );
        }
        let hall = |s: &Scenario| {
            s.scene.objects.iter().find_map(|o| match o {
                ObjectSpec::Building(b) => Some(b.clone()),
                _ => None,
            })
        };
        let (a, b) = (hall(&turned).unwrap(), hall(&want).unwrap());
        assert!(close(&a.center, &b.center, 0.01) && (a.yaw_deg - b.yaw_deg).abs() < 0.01);
        let (pa, pb) = (
            turned.imaging.region_polygon.unwrap(),
            want.imaging.region_polygon.unwrap(),
        );
        for (a, b) in pa.iter().zip(&pb) {
            assert!(close(a, b, 0.01), "{a:?} vs {b:?}");
        }
        let (ca, cb) = (turned.channel.unwrap(), want.channel.unwrap());
        assert!((ca.bs_boresight_deg - cb.bs_boresight_deg).abs() < 0.01);
        let (la, lb) = (turned.localize.unwrap(), want.localize.unwrap());
        assert!(close(&la.track_start, &lb.track_start, 0.01));
        assert!(close(&la.track_end, &lb.track_end, 0.01));
    }

    #[test]
    fn a_full_turn_is_the_identity_and_two_quarter_turns_a_half_turn() {
        let s = fixture("fixtures/suite/office_pair.toml");
        let about = Vec2::new(3.0, -7.0);
        let full = s.turned(360.0, about).unwrap();
        for (a, b) in full.base_stations.iter().zip(&s.base_stations) {
            for k in 0..3 {
                assert!((a.position[k] - b.position[k]).abs() < 1e-3);
            }
        }
        let twice = s.turned(90.0, about).unwrap().turned(90.0, about).unwrap();
        let half = s.turned(180.0, about).unwrap();
        for (a, b) in twice.apertures.iter().zip(&half.apertures) {
            for k in 0..3 {
                assert!((a.start[k] - b.start[k]).abs() < 1e-3, "{}", a.name);
            }
        }
        // Distances between placed things do not change.
        let d = |s: &Scenario| {
            Vec3::from(s.base_stations[0].position).distance(Vec3::from(s.apertures[0].end))
        };
        assert!((d(&s.turned(23.0, about).unwrap()) - d(&s)).abs() < 1e-3);
    }

    #[test]
    fn a_huge_angle_turns_positions_and_boresights_by_the_same_angle() {
        let s = fixture("fixtures/suite/office_pair.toml");
        for deg in [1e30, -7.5e17, 1e9 + 0.5] {
            let t = s.turned(deg, Vec2::ZERO).unwrap();
            let want = deg.rem_euclid(360.0);
            for (a, b) in t.base_stations.iter().zip(&s.base_stations) {
                let az = |p: [f32; 3]| (p[1] as f64).atan2(p[0] as f64).to_degrees();
                let moved = (az(a.position) - az(b.position)).rem_euclid(360.0);
                let turned = (a.boresight_deg as f64 - b.boresight_deg as f64).rem_euclid(360.0);
                let diff = |x: f64, y: f64| ((x - y + 180.0).rem_euclid(360.0) - 180.0).abs();
                assert!(diff(moved, want) < 0.01, "{deg}: {moved} vs {want}");
                assert!(diff(turned, want) < 0.01, "{deg}: {turned} vs {want}");
            }
        }
    }

    #[test]
    fn a_turned_scenario_written_as_toml_reads_back_the_same() {
        let s = fixture("fixtures/suite/street_row.toml")
            .turned(23.0, Vec2::new(1.0, 2.0))
            .unwrap();
        let text = s.to_toml_string().unwrap();
        let back = Scenario::from_toml_str(&text).unwrap();
        assert_eq!(back.to_toml_string().unwrap(), text);
    }

    #[test]
    fn a_mesh_object_turns_with_the_site() {
        let dir = std::env::temp_dir().join(format!("has-turn-mesh-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join("kiosk.obj"),
            "v 1 0 0\nv 4 1 0\nv 2 3 5\nf 1 2 3\n",
        )
        .unwrap();
        let mut s = fixture("fixtures/suite/street_row.toml");
        s.scene.set_base_dir(&dir);
        s.scene
            .objects
            .push(ObjectSpec::Mesh(super::super::MeshSpec {
                name: Some("kiosk".into()),
                path: "kiosk.obj".into(),
                material: Some(crate::Material::Metal),
                offset: [5.0, -2.0, 1.0],
                yaw_deg: 10.0,
            }));
        let kiosk = |s: &Scenario| -> [Vec3; 3] {
            let objs = s.scene.build_objects().unwrap();
            objs.iter().find(|o| o.name == "kiosk").unwrap().triangles[0]
        };
        let (deg, about) = (-137.0f64, Vec2::new(2.0, 3.0));
        let turned = s.turned(deg, about).unwrap();
        let (before, after) = (kiosk(&s), kiosk(&turned));
        let (sin, cos) = (deg.to_radians().sin() as f32, deg.to_radians().cos() as f32);
        for (b, a) in before.iter().zip(&after) {
            let d = Vec2::new(b.x, b.y) - about;
            let want = about + Vec2::new(cos * d.x - sin * d.y, sin * d.x + cos * d.y);
            assert!(
                (Vec2::new(a.x, a.y) - want).length() < 1e-4 && (a.z - b.z).abs() < 1e-6,
                "{a} vs {want} (from {b})"
            );
        }
        // Written and read back, the yaw and offset carry the turn.
        let text = turned.to_toml_string().unwrap();
        assert!(text.contains("yaw_deg"), "{text}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_turn_that_moves_the_region_off_its_ground_is_refused_naming_the_corner() {
        // factory_site's ground is ±100 m; turned 45° about (90, 0) the region reaches y ≈ −115.
        let s = fixture("fixtures/suite/factory_site.toml");
        let e = s
            .turned(45.0, Vec2::new(90.0, 0.0))
            .unwrap_err()
            .to_string();
        assert!(e.contains("imaging.region") && e.contains("corner"), "{e}");
        assert!(s.turned(45.0, Vec2::ZERO).is_ok());
    }

    #[test]
    fn a_non_finite_angle_is_refused_naming_it() {
        let s = fixture("fixtures/suite/street_row.toml");
        let e = s.turned(f64::NAN, Vec2::ZERO).unwrap_err().to_string();
        assert!(e.contains("turn.deg"), "{e}");
    }
}
