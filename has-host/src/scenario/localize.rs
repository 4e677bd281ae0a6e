//! The `[localize]` table of a scenario file: the monostatic base station, the OFDM sensing
//! waveform, the moving target, the clutter model, the processing chain and the environment prior
//! (paper §3), with a `[localize.quick]` table of overrides for the `--quick` preset.
//!
//! Units as named in each field: metres, GHz / MHz, milliseconds, metres per second, dBm / dB,
//! degrees in the file (radians inside). Every table denies unknown fields; [`LocalizeSpec::validate`]
//! names the first bad field and its value (`localize.<field>`).

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::{ScenarioError, TableFields};
use crate::material::Material;
use crate::sensors::PlanarArray;

/// Fields of the `[localize]` table named in this module's errors.
const LOCALIZE: TableFields = TableFields::new("localize");

/// `[localize]`: everything the moving-target experiment needs besides the scene.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LocalizeSpec {
    /// Array centre `[x, y, z]` of the monostatic base station (the single transmit element sits
    /// at the centre of the receive panel), metres.
    pub position: [f32; 3],
    /// Boresight azimuth, degrees from +x toward +y; 0 is the paper's normal (1, 0, 0), the panel
    /// then lies in the YZ plane.
    #[serde(default)]
    pub boresight_deg: f32,
    /// Receive rows (vertical). Default 32.
    #[serde(default = "d32")]
    pub rows: usize,
    /// Receive columns (horizontal). Default 32.
    #[serde(default = "d32")]
    pub cols: usize,
    /// Element spacing in wavelengths (both directions). Default 0.5.
    #[serde(default = "d_half")]
    pub spacing_wavelengths: f32,
    /// Carrier, GHz.
    pub fc_ghz: f64,
    /// Occupied bandwidth, MHz.
    pub bandwidth_mhz: f64,
    /// Subcarriers per OFDM symbol (power of two, 64 … 2048).
    pub subcarriers: usize,
    /// Range-compression zero padding (1, 2 or 4).
    #[serde(default = "d2")]
    pub zero_pad: usize,
    /// Range-compression window: `"rectangular"`, `"hann"` or `"taylor"` (n̄ 4, −35 dB).
    #[serde(default = "d_hann")]
    pub window: String,
    /// Sensing symbols per coherent processing interval (slow-time samples), 8 … 64.
    pub symbols: usize,
    /// Time between sensing symbols (slow-time sampling interval), milliseconds.
    pub symbol_interval_ms: f64,
    /// Frames (CPIs) along the track, evenly spaced from its start to its end (≥ 2).
    pub frames: usize,
    /// Transmit power, dBm (sets the noise level with `noise_figure_db`).
    pub tx_power_dbm: f64,
    /// Receiver noise figure, dB (noise `k·T0·B·F` per element, T0 = 290 K).
    pub noise_figure_db: f64,
    /// Target cylinder radius, metres.
    pub target_radius_m: f32,
    /// Target cylinder height, metres.
    pub target_height_m: f32,
    /// Track start (base centre of the cylinder), metres.
    pub track_start: [f32; 3],
    /// Track end, metres.
    pub track_end: [f32; 3],
    /// Constant target speed along the track, m/s.
    pub target_speed_mps: f32,
    /// Target material name (ITU-R P.2040, e.g. `"metal"`).
    #[serde(default = "d_metal")]
    pub target_material: String,
    /// Scatterers per m² on the target's surface.
    pub target_density_per_m2: f64,
    /// Scene objects treated as ground (sampled at `ground_density_per_m2`); the rest at
    /// `building_density_per_m2`.
    pub ground_objects: Vec<String>,
    /// Objects of the true scene the twin carries as they are (the map's buildings outside the
    /// reconstructed region, from a survey or OpenStreetMap): the prior is the twin's mesh plus
    /// these. Default: none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub known_objects: Vec<String>,
    /// Scatterers per m² on the non-ground objects.
    pub building_density_per_m2: f64,
    /// Scatterers per m² on the ground objects.
    pub ground_density_per_m2: f64,
    /// Clutter (true scene and twin) is sampled within this horizontal distance of the base
    /// station, metres.
    pub clutter_range_m: f32,
    /// Processed range window (monostatic range, metres): lower end.
    pub range_min_m: f32,
    /// Processed range window: upper end.
    pub range_max_m: f32,
    /// Beams searched: azimuth within ± this of boresight, degrees.
    pub fov_azimuth_deg: f32,
    /// Beams searched: elevation interval `[low, high]`, degrees.
    pub fov_elevation_deg: [f32; 2],
    /// Angle FFT size per array axis (≥ rows, cols; 64 … 256).
    #[serde(default = "d64")]
    pub angle_fft: usize,
    /// Doppler FFT size (≥ symbols; 64 … 1024).
    #[serde(default = "d64")]
    pub doppler_fft: usize,
    /// ECA-B / ECA-S batch length, symbols (divides `symbols`).
    pub eca_batch: usize,
    /// ECA-S extra estimation symbols on each side of a batch.
    pub eca_extra: usize,
    /// CA-CFAR training cells per side (along range).
    pub cfar_train: usize,
    /// CA-CFAR guard cells per side.
    pub cfar_guard: usize,
    /// CA-CFAR design false-alarm probability per cell.
    pub cfar_pfa: f64,
    /// Extent test of the detector: a CFAR hit counts only within this many dB of the strongest
    /// cell of its (range, Doppler) slice, dB (> 0).
    pub extent_db: f32,
    /// A detection farther than this from the target's true surface (at its frame) is a false
    /// alarm, metres.
    pub false_alarm_gate_m: f32,
    /// Environment prior: height of the flat ground added under the twin mesh (site survey),
    /// metres.
    #[serde(default)]
    pub twin_ground_z: f32,
    /// Environment prior: scatterers per m² sampled on the twin (mesh and ground).
    pub twin_density_per_m2: f64,
    /// Environment prior: number of range-segment templates fitted per CPI (1, 2, 4, 8 or 16).
    pub templates: usize,
    /// Environment prior: cells whose predicted static clutter exceeds the noise at zero Doppler
    /// by this many dB get the ECA notch, dB.
    pub gate_cnr_db: f64,
    /// Environment prior: outside the notched cells a detection must exceed the twin's predicted
    /// static clutter (at its Doppler bin) by this margin, dB.
    pub clutter_margin_db: f64,
    /// Seed of every random draw (scatterers, symbols, noise).
    pub seed: u64,
    /// Overrides for `--quick`.
    #[serde(default)]
    pub quick: LocalizeOverrides,
}

/// `[localize.quick]`: fields of `[localize]` replaced by the `--quick` preset.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LocalizeOverrides {
    /// See [`LocalizeSpec::subcarriers`].
    pub subcarriers: Option<usize>,
    /// See [`LocalizeSpec::symbols`].
    pub symbols: Option<usize>,
    /// See [`LocalizeSpec::frames`].
    pub frames: Option<usize>,
    /// See [`LocalizeSpec::eca_batch`].
    pub eca_batch: Option<usize>,
    /// See [`LocalizeSpec::eca_extra`].
    pub eca_extra: Option<usize>,
    /// See [`LocalizeSpec::target_density_per_m2`].
    pub target_density_per_m2: Option<f64>,
    /// See [`LocalizeSpec::building_density_per_m2`].
    pub building_density_per_m2: Option<f64>,
    /// See [`LocalizeSpec::ground_density_per_m2`].
    pub ground_density_per_m2: Option<f64>,
    /// See [`LocalizeSpec::twin_density_per_m2`].
    pub twin_density_per_m2: Option<f64>,
}

fn d32() -> usize {
    32
}
fn d64() -> usize {
    64
}
fn d2() -> usize {
    2
}
fn d_half() -> f32 {
    0.5
}
fn d_hann() -> String {
    "hann".into()
}
fn d_metal() -> String {
    "metal".into()
}

impl LocalizeSpec {
    /// Applies the `[localize.quick]` overrides.
    pub fn apply_quick(&mut self) {
        let q = self.quick.clone();
        macro_rules! set {
            ($($f:ident),*) => { $( if let Some(v) = q.$f { self.$f = v; } )* };
        }
        set!(
            subcarriers,
            symbols,
            frames,
            eca_batch,
            eca_extra,
            target_density_per_m2,
            building_density_per_m2,
            ground_density_per_m2,
            twin_density_per_m2
        );
    }

    /// Checks every value (names the first bad field and its value).
    ///
    /// # Errors
    /// [`ScenarioError::Invalid`] with the field `localize.<name>`.
    pub fn validate(&self) -> Result<(), ScenarioError> {
        LOCALIZE.finite("position", self.position)?;
        if !self.boresight_deg.is_finite() {
            return Err(LOCALIZE.invalid("boresight_deg", self.boresight_deg, "finite"));
        }
        for (f, v) in [("rows", self.rows), ("cols", self.cols)] {
            if !(2..=64).contains(&v) {
                return Err(LOCALIZE.invalid(f, v, "2 … 64"));
            }
        }
        LOCALIZE.positive("spacing_wavelengths", self.spacing_wavelengths as f64)?;
        LOCALIZE.positive("fc_ghz", self.fc_ghz)?;
        LOCALIZE.positive("bandwidth_mhz", self.bandwidth_mhz)?;
        if self.bandwidth_mhz * 1e6 >= self.fc_ghz * 1e9 {
            return Err(LOCALIZE.invalid("bandwidth_mhz", self.bandwidth_mhz, "below the carrier"));
        }
        LOCALIZE.pow2_in("subcarriers", self.subcarriers, 64, 2048)?;
        if !matches!(self.zero_pad, 1 | 2 | 4) || self.subcarriers * self.zero_pad > 4096 {
            return Err(LOCALIZE.invalid(
                "zero_pad",
                self.zero_pad,
                "1, 2 or 4 with subcarriers · zero_pad ≤ 4096",
            ));
        }
        self.window()?;
        if !(8..=64).contains(&self.symbols) {
            return Err(LOCALIZE.invalid("symbols", self.symbols, "8 … 64"));
        }
        LOCALIZE.positive("symbol_interval_ms", self.symbol_interval_ms)?;
        if self.frames < 2 {
            return Err(LOCALIZE.invalid("frames", self.frames, "≥ 2"));
        }
        for (f, v) in [
            ("tx_power_dbm", self.tx_power_dbm),
            ("noise_figure_db", self.noise_figure_db),
            ("gate_cnr_db", self.gate_cnr_db),
            ("clutter_margin_db", self.clutter_margin_db),
        ] {
            if !v.is_finite() {
                return Err(LOCALIZE.invalid(f, v, "finite"));
            }
        }
        LOCALIZE.positive("target_radius_m", self.target_radius_m as f64)?;
        LOCALIZE.positive("target_height_m", self.target_height_m as f64)?;
        LOCALIZE.finite("track_start", self.track_start)?;
        LOCALIZE.finite("track_end", self.track_end)?;
        if Vec3::from(self.track_start).distance(Vec3::from(self.track_end)) <= 0.0 {
            return Err(LOCALIZE.invalid(
                "track_end",
                self.track_end,
                "different from track_start",
            ));
        }
        LOCALIZE.positive("target_speed_mps", self.target_speed_mps as f64)?;
        self.target_material()?;
        LOCALIZE.positive("target_density_per_m2", self.target_density_per_m2)?;
        LOCALIZE.positive("building_density_per_m2", self.building_density_per_m2)?;
        LOCALIZE.positive("ground_density_per_m2", self.ground_density_per_m2)?;
        LOCALIZE.positive("twin_density_per_m2", self.twin_density_per_m2)?;
        LOCALIZE.positive("clutter_range_m", self.clutter_range_m as f64)?;
        LOCALIZE.positive("range_min_m", self.range_min_m as f64)?;
        if !(self.range_max_m.is_finite() && self.range_max_m > self.range_min_m) {
            return Err(LOCALIZE.invalid("range_max_m", self.range_max_m, "above range_min_m"));
        }
        if !(self.fov_azimuth_deg > 0.0 && self.fov_azimuth_deg < 90.0) {
            return Err(LOCALIZE.invalid("fov_azimuth_deg", self.fov_azimuth_deg, "in (0, 90)"));
        }
        let [lo, hi] = self.fov_elevation_deg;
        if !(lo.is_finite() && hi.is_finite() && lo < hi && lo > -90.0 && hi < 90.0) {
            return Err(LOCALIZE.invalid(
                "fov_elevation_deg",
                self.fov_elevation_deg,
                "low < high within (−90, 90)",
            ));
        }
        LOCALIZE.pow2_in("angle_fft", self.angle_fft, 64, 256)?;
        if self.angle_fft < self.rows.max(self.cols) {
            return Err(LOCALIZE.invalid("angle_fft", self.angle_fft, "≥ rows and cols"));
        }
        LOCALIZE.pow2_in("doppler_fft", self.doppler_fft, 64, 1024)?;
        if self.doppler_fft < self.symbols {
            return Err(LOCALIZE.invalid("doppler_fft", self.doppler_fft, "≥ symbols"));
        }
        if self.eca_batch < 2 || !self.symbols.is_multiple_of(self.eca_batch) {
            return Err(LOCALIZE.invalid("eca_batch", self.eca_batch, "≥ 2 and dividing symbols"));
        }
        if self.eca_extra > self.symbols {
            return Err(LOCALIZE.invalid("eca_extra", self.eca_extra, "≤ symbols"));
        }
        if !(1..=has_dsp::cfar::MAX_CFAR_TRAIN).contains(&self.cfar_train) {
            return Err(LOCALIZE.invalid("cfar_train", self.cfar_train, "1 … 64"));
        }
        if !(self.cfar_pfa > 0.0 && self.cfar_pfa < 1.0) {
            return Err(LOCALIZE.invalid("cfar_pfa", self.cfar_pfa, "in (0, 1)"));
        }
        LOCALIZE.positive("extent_db", self.extent_db as f64)?;
        LOCALIZE.positive("false_alarm_gate_m", self.false_alarm_gate_m as f64)?;
        if !self.twin_ground_z.is_finite() {
            return Err(LOCALIZE.invalid("twin_ground_z", self.twin_ground_z, "finite"));
        }
        if !matches!(self.templates, 1 | 2 | 4 | 8 | 16) {
            return Err(LOCALIZE.invalid("templates", self.templates, "1, 2, 4, 8 or 16"));
        }
        Ok(())
    }

    /// The range-compression window.
    ///
    /// # Errors
    /// [`ScenarioError::Invalid`] (`localize.window`) for an unknown name.
    pub fn window(&self) -> Result<has_dsp::window::Window, ScenarioError> {
        use has_dsp::window::Window;
        match self.window.to_ascii_lowercase().as_str() {
            "rectangular" | "rect" => Ok(Window::Rectangular),
            "hann" => Ok(Window::Hann),
            "taylor" => Ok(Window::Taylor {
                nbar: 4,
                sll_db: -35.0,
            }),
            _ => Err(LOCALIZE.invalid("window", &self.window, "rectangular, hann or taylor")),
        }
    }

    /// The target's material.
    ///
    /// # Errors
    /// [`ScenarioError::Invalid`] (`localize.target_material`) for an unknown name.
    pub fn target_material(&self) -> Result<Material, ScenarioError> {
        Material::from_name(&self.target_material).ok_or_else(|| {
            LOCALIZE.invalid(
                "target_material",
                &self.target_material,
                "an ITU-R P.2040 material name (has-sim materials)",
            )
        })
    }

    /// Carrier, Hz.
    pub fn fc_hz(&self) -> f64 {
        self.fc_ghz * 1e9
    }

    /// Bandwidth, Hz.
    pub fn bandwidth_hz(&self) -> f64 {
        self.bandwidth_mhz * 1e6
    }

    /// Carrier wavelength, metres.
    pub fn wavelength_m(&self) -> f64 {
        crate::wavelength_m(self.fc_hz())
    }

    /// The receive panel.
    pub fn array(&self) -> PlanarArray {
        let d = self.spacing_wavelengths * self.wavelength_m() as f32;
        PlanarArray {
            centre: Vec3::from(self.position),
            boresight_az_rad: self.boresight_deg.to_radians(),
            rows: self.rows,
            cols: self.cols,
            width_m: d * self.cols as f32,
            height_m: d * self.rows as f32,
        }
    }

    /// Track length, metres.
    pub fn track_length_m(&self) -> f32 {
        Vec3::from(self.track_start).distance(Vec3::from(self.track_end))
    }

    /// Target velocity vector, m/s.
    pub fn velocity(&self) -> Vec3 {
        (Vec3::from(self.track_end) - Vec3::from(self.track_start)).normalize()
            * self.target_speed_mps
    }

    /// Base centre of the target at the centre of frame `f` (frames evenly spaced from the start
    /// to the end of the track).
    pub fn frame_centre(&self, f: usize) -> Vec3 {
        let t = f as f32 / (self.frames - 1).max(1) as f32;
        Vec3::from(self.track_start).lerp(Vec3::from(self.track_end), t)
    }

    /// Noise power per subcarrier relative to a unit-amplitude transmitted subcarrier:
    /// `k·T0·B·F / P_tx` (the echo amplitudes are for unit transmit amplitude, so this is the
    /// per-subcarrier `σ²` of the OFDM synthesis).
    pub fn noise_power(&self) -> f64 {
        const K_T0: f64 = 1.380_649e-23 * 290.0;
        let p_tx_w = 10f64.powf((self.tx_power_dbm - 30.0) / 10.0);
        K_T0 * self.bandwidth_hz() * 10f64.powf(self.noise_figure_db / 10.0) / p_tx_w
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::scenario::Scenario;

    pub(crate) fn factory_spec() -> LocalizeSpec {
        Scenario::from_toml_str(include_str!("../../../fixtures/factory.toml"))
            .expect("bundled scenario parses")
            .localize
            .expect("bundled scenario has [localize]")
    }

    #[test]
    fn bundled_spec_is_valid_and_quick_overrides_apply() {
        let mut s = factory_spec();
        s.validate().unwrap();
        assert_eq!((s.rows, s.cols), (32, 32));
        let a = s.array();
        // λ/2 spacing at 10 GHz, panel normal (1, 0, 0): the YZ plane.
        assert!((a.spacing_m().0 - 0.5 * s.wavelength_m() as f32).abs() < 1e-6);
        assert!((a.boresight() - Vec3::X).length() < 1e-6);
        assert!((s.track_length_m() - 30.0).abs() < 1e-4);
        let full_frames = s.frames;
        s.apply_quick();
        s.validate().unwrap();
        assert!(s.frames < full_frames);
        assert_eq!((s.rows, s.cols), (32, 32), "quick keeps the 32 × 32 array");
    }

    #[test]
    fn bad_fields_are_errors_naming_field_and_value() {
        type Edit = Box<dyn Fn(&mut LocalizeSpec)>;
        let cases: Vec<(&str, Edit)> = vec![
            ("localize.subcarriers", Box::new(|s| s.subcarriers = 100)),
            ("localize.symbols", Box::new(|s| s.symbols = 4)),
            ("localize.frames", Box::new(|s| s.frames = 1)),
            ("localize.window", Box::new(|s| s.window = "kaiser".into())),
            (
                "localize.target_material",
                Box::new(|s| s.target_material = "cheese".into()),
            ),
            (
                "localize.target_radius_m",
                Box::new(|s| s.target_radius_m = -3.0),
            ),
            (
                "localize.track_end",
                Box::new(|s| s.track_end = s.track_start),
            ),
            (
                "localize.range_max_m",
                Box::new(|s| s.range_max_m = s.range_min_m),
            ),
            ("localize.eca_batch", Box::new(|s| s.eca_batch = 5)),
            ("localize.cfar_pfa", Box::new(|s| s.cfar_pfa = 1.5)),
            ("localize.cfar_train", Box::new(|s| s.cfar_train = 0)),
            ("localize.templates", Box::new(|s| s.templates = 3)),
            ("localize.position", Box::new(|s| s.position[1] = f32::NAN)),
            ("localize.doppler_fft", Box::new(|s| s.doppler_fft = 32)),
        ];
        for (field, f) in cases {
            let mut s = factory_spec();
            f(&mut s);
            let e = s.validate().expect_err(field).to_string();
            assert!(e.starts_with(field), "{field}: {e}");
        }
    }

    #[test]
    fn unknown_fields_are_rejected() {
        let text = include_str!("../../../fixtures/factory.toml")
            .replace("[localize]\n", "[localize]\nspeed_of_light = 3.0\n");
        let e = Scenario::from_toml_str(&text).unwrap_err().to_string();
        assert!(e.contains("speed_of_light"), "{e}");
    }
}
