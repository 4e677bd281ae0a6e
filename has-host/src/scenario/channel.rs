//! The channel-prediction experiment of a scenario file (paper §2): the `[channel]` table
//! ([`ChannelSpec`]), its validation, the UE placement and the two scenes that are ray-traced
//! (the true scene and the digital twin), both all concrete.
//!
//! Units as in the rest of the scenario file: metres, degrees, decibels. The UEs are drawn
//! uniformly (seeded ChaCha8) in the horizontal rectangle `ue_region_min … ue_region_max` at
//! height `ue_height_m` above z = 0; a draw is rejected when a ray straight up from it hits the
//! true scene (inside or under a building; [`Scene::uncovered_positions`]). The twin is the reconstructed mesh plus the true
//! scene's `known_objects` (the ground: the imaging region starts 1 m above it, so the ground is
//! never reconstructed and is taken as known and flat).

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::{ScenarioError, TableFields};
use crate::scene::Scene;

/// Fields of the `[channel]` table named in this module's errors.
const CHANNEL: TableFields = TableFields::new("channel");

/// `[channel]`: one BS, the UEs, the thresholds, the tracer and the codebook.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelSpec {
    /// BS (transmitter, array centre) `[x, y, z]`, metres.
    pub bs_position: [f64; 3],
    /// Azimuth of the BS array normal (horizontal), degrees from +x toward +y: the codebook's
    /// orientation, facing the served area.
    pub bs_boresight_deg: f64,
    /// Number of UEs.
    #[serde(default = "default_ues")]
    pub ues: usize,
    /// UE antenna height above z = 0, metres. Default 1.5.
    #[serde(default = "default_ue_height")]
    pub ue_height_m: f64,
    /// UE region, lower corner `[x, y]`, metres.
    pub ue_region_min: [f64; 2],
    /// UE region, upper corner `[x, y]`, metres.
    pub ue_region_max: [f64; 2],
    /// Seed of the UE placement.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Keep a UE if its strongest true path loses less than this, dB. Default 110.
    #[serde(default = "default_max_loss")]
    pub max_loss_db: f64,
    /// Per UE and model keep the paths within this of the strongest, dB. Default 20.
    #[serde(default = "default_window")]
    pub window_db: f64,
    /// Highest reflection order of the tracer (both scenes). Default 3.
    #[serde(default = "default_order")]
    pub max_order: usize,
    /// Shoot-and-bounce rays of the candidate search (both scenes). Default 200 000.
    #[serde(default = "default_rays")]
    pub sbr_rays: usize,
    /// Facet clustering of the tracer (both scenes): largest angle between a triangle's normal
    /// and its facet's, degrees. Default: the tracer's (15°).
    #[serde(default = "default_facet_angle")]
    pub facet_angle_deg: f64,
    /// Facet clustering (both scenes): largest distance of a vertex from its facet's plane,
    /// metres. Default: the tracer's (0.15 m).
    #[serde(default = "default_facet_dist")]
    pub facet_dist_m: f64,
    /// Codebook rows (vertical elements). Default 32.
    #[serde(default = "default_32")]
    pub codebook_rows: usize,
    /// Codebook columns (horizontal elements). Default 32.
    #[serde(default = "default_32")]
    pub codebook_cols: usize,
    /// Element spacing, wavelengths. Default 0.5.
    #[serde(default = "default_spacing")]
    pub codebook_spacing_wl: f64,
    /// Matching distance: delay difference counted as one unit, ns. Default 1.
    #[serde(default = "default_one")]
    pub match_delay_ns: f64,
    /// Matching distance: angle difference counted as one unit, degrees. Default 1.
    #[serde(default = "default_one")]
    pub match_angle_deg: f64,
    /// Objects of the true scene added to the twin as known (default: none).
    #[serde(default)]
    pub known_objects: Vec<String>,
    /// Overrides for `--quick`.
    #[serde(default)]
    pub quick: ChannelOverrides,
}

/// `[channel.quick]`: fields of `[channel]` replaced by the `--quick` preset.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelOverrides {
    /// See [`ChannelSpec::ues`].
    pub ues: Option<usize>,
    /// See [`ChannelSpec::max_order`].
    pub max_order: Option<usize>,
    /// See [`ChannelSpec::sbr_rays`].
    pub sbr_rays: Option<usize>,
}

/// Bytes one UE costs the channel experiment: its position, the multipath sets traced on the
/// true scene and on the twin (a few dozen paths of ≈ 200 B each), their matching and the
/// report's rows; generous, so that a count the guard passes fits.
const BYTES_PER_UE: f64 = 64.0 * 1024.0;

fn default_ues() -> usize {
    500
}
fn default_ue_height() -> f64 {
    1.5
}
fn default_seed() -> u64 {
    1
}
fn default_max_loss() -> f64 {
    110.0
}
fn default_window() -> f64 {
    20.0
}
fn default_order() -> usize {
    3
}
fn default_rays() -> usize {
    200_000
}
fn default_facet_angle() -> f64 {
    crate::paths::TracerConfig::default()
        .facet_angle_tol_rad
        .to_degrees()
}
fn default_facet_dist() -> f64 {
    crate::paths::TracerConfig::default().facet_dist_tol_m
}
fn default_32() -> usize {
    32
}
fn default_spacing() -> f64 {
    0.5
}
fn default_one() -> f64 {
    1.0
}

impl ChannelSpec {
    /// Replaces fields by the `[channel.quick]` overrides.
    pub fn apply_quick(&mut self) {
        let q = self.quick.clone();
        if let Some(v) = q.ues {
            self.ues = v;
        }
        if let Some(v) = q.max_order {
            self.max_order = v;
        }
        if let Some(v) = q.sbr_rays {
            self.sbr_rays = v;
        }
    }

    /// Checks every value; the error names the first bad field (`channel.<name>`) and its value.
    ///
    /// # Errors
    /// [`ScenarioError::Invalid`].
    pub fn validate(&self) -> Result<(), ScenarioError> {
        if !self.bs_position.iter().all(|x| x.is_finite()) {
            return Err(CHANNEL.invalid("bs_position", self.bs_position, "finite coordinates"));
        }
        if !self.bs_boresight_deg.is_finite() {
            return Err(CHANNEL.invalid("bs_boresight_deg", self.bs_boresight_deg, "finite"));
        }
        if self.ues == 0 {
            return Err(CHANNEL.invalid("ues", self.ues, "at least 1"));
        }
        CHANNEL.size("ues", self.ues, self.ues as f64 * BYTES_PER_UE)?;
        if !(self.ue_height_m.is_finite() && self.ue_height_m >= 0.0) {
            return Err(CHANNEL.invalid("ue_height_m", self.ue_height_m, "finite and >= 0"));
        }
        for (f, v) in [
            ("ue_region_min", self.ue_region_min),
            ("ue_region_max", self.ue_region_max),
        ] {
            if !v.iter().all(|x| x.is_finite()) {
                return Err(CHANNEL.invalid(f, v, "finite coordinates"));
            }
        }
        if (0..2).any(|k| self.ue_region_max[k] <= self.ue_region_min[k]) {
            return Err(CHANNEL.invalid(
                "ue_region_max",
                self.ue_region_max,
                "above ue_region_min on both axes",
            ));
        }
        CHANNEL.positive("max_loss_db", self.max_loss_db)?;
        if !(self.window_db.is_finite() && self.window_db >= 0.0) {
            return Err(CHANNEL.invalid("window_db", self.window_db, "finite and >= 0"));
        }
        if self.max_order > crate::paths::MAX_ORDER {
            return Err(CHANNEL.invalid("max_order", self.max_order, "at most 8"));
        }
        if self.sbr_rays == 0 {
            return Err(CHANNEL.invalid("sbr_rays", self.sbr_rays, "at least 1"));
        }
        for (f, v) in [
            ("facet_angle_deg", self.facet_angle_deg),
            ("facet_dist_m", self.facet_dist_m),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(CHANNEL.invalid(f, v, "finite and >= 0"));
            }
        }
        if self.codebook_rows == 0 {
            return Err(CHANNEL.invalid("codebook_rows", self.codebook_rows, "at least 1"));
        }
        if self.codebook_cols == 0 {
            return Err(CHANNEL.invalid("codebook_cols", self.codebook_cols, "at least 1"));
        }
        let beams = self.codebook_rows as f64 * self.codebook_cols as f64;
        CHANNEL.size(
            "codebook_rows × codebook_cols",
            (self.codebook_rows, self.codebook_cols),
            // Each beam's weights (complex64 per element) and its gain at every UE.
            beams * (beams * 8.0 + self.ues as f64 * 8.0),
        )?;
        CHANNEL.positive("codebook_spacing_wl", self.codebook_spacing_wl)?;
        CHANNEL.positive("match_delay_ns", self.match_delay_ns)?;
        CHANNEL.positive("match_angle_deg", self.match_angle_deg)?;
        let q = &self.quick;
        if q.ues == Some(0) {
            return Err(CHANNEL.invalid("quick.ues", 0, "at least 1"));
        }
        if let Some(n) = q.ues {
            CHANNEL.size("quick.ues", n, n as f64 * BYTES_PER_UE)?;
        }
        if let Some(o) = q.max_order.filter(|&o| o > crate::paths::MAX_ORDER) {
            return Err(CHANNEL.invalid("quick.max_order", o, "at most 8"));
        }
        if q.sbr_rays == Some(0) {
            return Err(CHANNEL.invalid("quick.sbr_rays", 0, "at least 1"));
        }
        Ok(())
    }

    /// The BS position.
    pub fn bs(&self) -> DVec3 {
        DVec3::from_array(self.bs_position)
    }

    /// The tracer settings of both scenes at carrier `frequency_hz`: order, SBR rays and facet
    /// tolerances from this spec, facets within `resolution_m` of plumb made vertical
    /// ([`crate::paths::TracerConfig::vertical_tol_m`]; the twin's imaging range resolution: a
    /// wall's tilt below it was not observed), the rest the tracer's defaults (line of sight on,
    /// vertical polarisation).
    pub fn tracer_config(
        &self,
        frequency_hz: f64,
        resolution_m: f64,
    ) -> crate::paths::TracerConfig {
        crate::paths::TracerConfig {
            frequency_hz,
            max_order: self.max_order,
            candidates: crate::paths::CandidateMode::Sbr {
                rays: self.sbr_rays,
            },
            facet_angle_tol_rad: self.facet_angle_deg.to_radians(),
            facet_dist_tol_m: self.facet_dist_m,
            vertical_tol_m: resolution_m,
            ..crate::paths::TracerConfig::default()
        }
    }

    /// The matching scale of [`crate::multipath`].
    pub fn match_scale(&self) -> crate::multipath::MatchScale {
        crate::multipath::MatchScale {
            delay_s: self.match_delay_ns * 1e-9,
            angle_rad: self.match_angle_deg.to_radians(),
        }
    }

    /// `ues` UE positions (see module docs), deterministic for the seed.
    ///
    /// # Errors
    /// [`ScenarioError::Invalid`] naming `channel.ue_region_min` when fewer than `ues` free
    /// positions are found in `1000·ues` draws (the region is covered by buildings).
    pub fn ue_positions(&self, truth: &Scene) -> Result<Vec<DVec3>, ScenarioError> {
        self.validate()?;
        let (lo, hi) = (self.ue_region_min, self.ue_region_max);
        let out = truth.uncovered_positions(lo, hi, self.ue_height_m, self.ues, self.seed);
        if out.len() < self.ues {
            return Err(CHANNEL.invalid(
                "ue_region_min",
                (lo, hi),
                "a region with room for the UEs outside buildings",
            ));
        }
        Ok(out)
    }
}
#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::material::Material;
    use crate::shapes;
    use glam::Vec3;

    /// A `[channel]` table with the paper's defaults around a hall (shared with the comparison's tests).
    pub(crate) fn spec() -> ChannelSpec {
        toml::from_str(
            r#"
            bs_position = [-45.0, -40.0, 20.0]
            bs_boresight_deg = 41.6
            ue_region_min = [-60.0, -50.0]
            ue_region_max = [60.0, 50.0]
            "#,
        )
        .unwrap()
    }

    /// A yard and a 40 m × 24 m × 8 m hall.
    pub(crate) fn factory_scene() -> Scene {
        let g = shapes::ground(
            "yard",
            Material::Concrete,
            glam::Vec2::new(-100.0, -100.0),
            glam::Vec2::new(100.0, 100.0),
            0.0,
            (1, 1),
        )
        .unwrap();
        let b = shapes::axis_box(
            "hall",
            Material::Concrete,
            Vec3::new(-20.0, -12.0, 0.0),
            Vec3::new(20.0, 12.0, 8.0),
        )
        .unwrap();
        Scene::new(vec![g, b]).unwrap()
    }

    #[test]
    fn defaults_are_the_papers() {
        let s = spec();
        assert_eq!(s.ues, 500);
        assert_eq!(s.ue_height_m, 1.5);
        assert_eq!(s.max_loss_db, 110.0);
        assert_eq!(s.window_db, 20.0);
        assert_eq!((s.codebook_rows, s.codebook_cols), (32, 32));
        assert_eq!(s.codebook_spacing_wl, 0.5);
        s.validate().unwrap();
    }

    #[test]
    fn ues_are_seeded_outside_buildings_in_the_region() {
        let scene = factory_scene();
        let s = spec();
        let a = s.ue_positions(&scene).unwrap();
        assert_eq!(a.len(), 500);
        assert_eq!(a, s.ue_positions(&scene).unwrap(), "deterministic");
        for p in &a {
            assert!((-60.0..60.0).contains(&p.x) && (-50.0..50.0).contains(&p.y));
            assert_eq!(p.z, 1.5);
            let inside = p.x.abs() <= 20.0 && p.y.abs() <= 12.0;
            assert!(!inside, "{p} is inside the hall");
        }
        let mut other = s.clone();
        other.seed = 2;
        assert_ne!(a, other.ue_positions(&scene).unwrap());
        // A region entirely under the hall has no room.
        let mut full = s;
        full.ue_region_min = [-10.0, -5.0];
        full.ue_region_max = [10.0, 5.0];
        let e = full.ue_positions(&scene).unwrap_err().to_string();
        assert!(e.starts_with("channel.ue_region_min"), "{e}");
    }

    #[test]
    fn bad_values_name_field_and_value() {
        type Edit = Box<dyn Fn(&mut ChannelSpec)>;
        let cases: Vec<(Edit, &str)> = vec![
            (
                Box::new(|s| s.bs_position[1] = f64::NAN),
                "channel.bs_position: [-45.0, NaN, 20.0]",
            ),
            (Box::new(|s| s.ues = 0), "channel.ues: 0"),
            (
                Box::new(|s| s.max_loss_db = -3.0),
                "channel.max_loss_db: -3.0",
            ),
            (
                Box::new(|s| s.window_db = f64::NAN),
                "channel.window_db: NaN",
            ),
            (Box::new(|s| s.window_db = -1.0), "channel.window_db: -1.0"),
            (
                Box::new(|s| s.ue_region_max = [60.0, -50.0]),
                "channel.ue_region_max: [60.0, -50.0]",
            ),
            (
                Box::new(|s| s.ue_height_m = f64::INFINITY),
                "channel.ue_height_m: inf",
            ),
            (Box::new(|s| s.max_order = 9), "channel.max_order: 9"),
            (Box::new(|s| s.sbr_rays = 0), "channel.sbr_rays: 0"),
            (
                Box::new(|s| s.codebook_rows = 0),
                "channel.codebook_rows: 0",
            ),
            (
                Box::new(|s| s.match_angle_deg = 0.0),
                "channel.match_angle_deg: 0.0",
            ),
            (Box::new(|s| s.quick.ues = Some(0)), "channel.quick.ues: 0"),
        ];
        for (edit, want) in cases {
            let mut s = spec();
            edit(&mut s);
            let e = s.validate().unwrap_err().to_string();
            assert!(e.starts_with(want), "{e} (want {want})");
        }
    }

    #[test]
    fn unknown_field_is_rejected_by_name() {
        let e = toml::from_str::<ChannelSpec>(
            "bs_position = [0.0, 0.0, 1.0]\nbs_boresight_deg = 0.0\nue_region_min = [0.0, 0.0]\nue_region_max = [1.0, 1.0]\nwindow = 3\n",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("window"), "{e}");
    }
}
