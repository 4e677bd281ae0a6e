//! The scenario file: the scene, the radio, the base stations, the terminals' virtual apertures,
//! the imaging parameters and the experiments run on the twin, in one TOML document (format in
//! `docs/scenario.md`). This module owns the file type ([`Scenario`]), its error
//! ([`ScenarioError`]) and the field validators every table shares ([`TableFields`]); the
//! pipeline stages (`imaging`, `channel_experiment`, `localize`) read it and nothing here reads
//! them.
//!
//! Every table denies unknown fields, so a typo is an error naming the field; every numeric field
//! is checked ([`Scenario::validate`]) and a bad one is reported with its name and value.
//! Units: lengths metres, frequencies GHz/MHz as named, angles degrees in the file (radians
//! inside), decibels as named. A `[quick]` table may override imaging parameters for the
//! `--quick` preset.
//!
//! Submodules: [`scene`] (the `[scene]` table), [`channel`] (`[channel]`), [`localize`]
//! (`[localize]`), [`impairments`] (`[impairments]`), [`error`].

pub mod channel;
pub mod error;
pub mod impairments;
pub mod localize;
pub mod scene;
pub mod turn;

use std::path::{Path, PathBuf};

use glam::Vec3;
use serde::{Deserialize, Serialize};

pub use channel::{ChannelOverrides, ChannelSpec};
pub(crate) use error::one_line_toml_error;
pub use error::{ScenarioError, TableFields};
pub use impairments::{ImpairmentSpec, PositionError, PositionProfile, PositionStats};
pub use localize::{LocalizeOverrides, LocalizeSpec};
pub use scene::{
    load_scene, load_scene_objects, AxisName, BuildingSpec, CylinderSpec, DirectionName,
    GroundSpec, MeshSpec, ObjectSpec, RoofSpec, SceneSpec, SceneSpecError,
};

use crate::sensors::{PlanarArray, VirtualAperture};

/// Fields of the file's top level and its `[radar]`, `[imaging]`, … tables (each error names the
/// table, e.g. `imaging.voxel_m`).
const FIELDS: TableFields = TableFields::new("");

/// The whole scenario file.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Free text shown in reports.
    #[serde(default)]
    pub description: String,
    /// The environment (see `crate::scenario`).
    pub scene: SceneSpec,
    /// The OFDM radio shared by every terminal and base station.
    pub radar: RadarSpec,
    /// The receiving base stations.
    pub base_stations: Vec<BaseStationSpec>,
    /// The terminals' virtual apertures.
    pub apertures: Vec<ApertureSpec>,
    /// Explicit (base station, aperture) pairs; empty: for each aperture the base station that
    /// sees most of the imaging region together with it (see `imaging::plan`).
    #[serde(default)]
    pub pairs: Vec<PairSpec>,
    /// Imaging parameters (the default preset).
    pub imaging: ImagingSpec,
    /// Overrides of `imaging` for `--quick`.
    #[serde(default)]
    pub quick: ImagingOverrides,
    /// `[channel]`: the channel-prediction experiment (`has-sim channel`), see [`channel`].
    #[serde(default)]
    pub channel: Option<ChannelSpec>,
    /// `[localize]`: the moving-target experiment (`has-sim localize`), if the scenario has one.
    #[serde(default)]
    pub localize: Option<LocalizeSpec>,
    /// `[impairments]`: the pairs' synchronisation errors and their compensation
    /// ([`impairments`]); absent, every pair is ideal.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub impairments: Option<ImpairmentSpec>,
    /// Directory of the scenario file (mesh paths resolve against it).
    #[serde(skip)]
    pub base_dir: PathBuf,
}

/// `[radar]`: the OFDM waveform.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RadarSpec {
    /// Carrier frequency, GHz.
    pub fc_ghz: f64,
    /// Occupied bandwidth, MHz.
    pub bandwidth_mhz: f64,
    /// Subcarriers per OFDM symbol (power of two, 64 … 4096). Default 1024: the unambiguous path
    /// length `n·c/B` (768 m at 400 MHz) then exceeds every path of the scene.
    #[serde(default = "default_subcarriers")]
    pub subcarriers: usize,
    /// Range-compression zero padding (1, 2 or 4). Default 2.
    #[serde(default = "default_zero_pad")]
    pub zero_pad: usize,
    /// Range-compression window across subcarriers: `"rectangular"`, `"hann"` or
    /// `"taylor"` (n̄ = 4, −35 dB). Default `"hann"`.
    #[serde(default = "default_window")]
    pub window: String,
    /// Per-bin signal-to-noise ratio of the range-compressed profiles before back-projection, dB,
    /// relative to the mean echo power per bin of an aperture's first frame. Default 10 dB.
    #[serde(default = "default_snr")]
    pub snr_db: f64,
}

impl RadarSpec {
    /// The carrier in Hz (validated by [`Scenario::validate`]).
    ///
    /// # Errors
    /// [`ScenarioError::Invalid`] for a carrier that is not finite and positive.
    pub fn fc_hz_checked(&self) -> Result<f64, ScenarioError> {
        FIELDS.positive("radar.fc_ghz", self.fc_ghz)?;
        Ok(self.fc_ghz * 1e9)
    }
}

/// `[[base_stations]]`: a vertical 2-D array receiving.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BaseStationSpec {
    /// Unique name (e.g. `"BS1"`).
    pub name: String,
    /// Panel centre `[x, y, z]`, metres.
    pub position: [f32; 3],
    /// Boresight azimuth, degrees from +x toward +y (the panel normal is horizontal).
    pub boresight_deg: f32,
    /// Element rows. Default 32.
    #[serde(default = "default_32")]
    pub rows: usize,
    /// Element columns. Default 32.
    #[serde(default = "default_32")]
    pub cols: usize,
    /// Panel width, metres. Default 1.0.
    #[serde(default = "default_width")]
    pub width_m: f32,
    /// Panel height, metres. Default 0.5.
    #[serde(default = "default_height")]
    pub height_m: f32,
}

/// `[[apertures]]`: a terminal transmitting along a straight track.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ApertureSpec {
    /// Unique name (e.g. `"V1"`, `"UAV"`).
    pub name: String,
    /// `"vehicle"` or `"uav"` (reports only).
    pub kind: String,
    /// First transmit position `[x, y, z]`, metres.
    pub start: [f32; 3],
    /// Last transmit position `[x, y, z]`, metres.
    pub end: [f32; 3],
    /// Transmit positions along the track (≥ 2). Default: Nyquist for the imaging region (see
    /// [`crate::sensors::nyquist_spacing_m`]), computed by the planner.
    #[serde(default)]
    pub positions: Option<usize>,
}

/// `[[pairs]]`: one explicit imaging pair.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PairSpec {
    /// Base-station name.
    pub bs: String,
    /// Aperture name.
    pub aperture: String,
}

/// `[imaging]`: the voxel grid, the scatterer model, thresholds and ground truth.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImagingSpec {
    /// Imaging region, lower corner `[x, y, z]`, metres.
    pub region_min: [f32; 3],
    /// Imaging region, upper corner `[x, y, z]`, metres.
    pub region_max: [f32; 3],
    /// Optional site outline: `[x, y]` vertices of a simple polygon (either winding), metres. The
    /// region is then this polygon × `[region_min.z, region_max.z]`; `region_min`/`region_max`
    /// must contain it (its bounding box). Lets a rotated or irregular site be imaged without a
    /// box that depends on the site's orientation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub region_polygon: Option<Vec<[f32; 2]>>,
    /// Fine voxel size, metres.
    pub voxel_m: f32,
    /// Coarse voxel size of the first (masking) pass, metres.
    pub coarse_voxel_m: f32,
    /// Coarse-pass mask threshold, dB relative to the coarse image's peak (negative); used only
    /// with `detection = "peak"`.
    #[serde(default = "default_coarse_threshold_db")]
    pub coarse_threshold_db: f32,
    /// Point threshold, dB relative to the pair's fine image peak (negative); used only with
    /// `detection = "peak"`.
    #[serde(default = "default_threshold_db")]
    pub threshold_db: f32,
    /// How a voxel is detected: `"clutter"` (default) against the clutter-plus-noise power the
    /// pair would image on the bare known terrain, at `false_alarm_probability`
    /// (`imaging::detection`); `"peak"`, the former test against the pair's peak
    /// (`threshold_db`, `coarse_threshold_db`), which depends on what else is in the region.
    #[serde(default)]
    pub detection: Detection,
    /// Design probability that a voxel of bare-site clutter or noise is detected (fine pass), at
    /// most: the fine pass uses `false_alarms_per_image` over the image's independent resolution
    /// cells when that is smaller.
    #[serde(default = "default_pfa")]
    pub false_alarm_probability: f64,
    /// Expected false detections (bare-site clutter and noise) per pair image in the fine pass:
    /// the per-voxel false-alarm probability is this over the number of resolution cells the
    /// pass tests (imaged volume / cell volume), so a larger region does not bring more false
    /// points (`imaging::driver`).
    #[serde(default = "default_false_alarms_per_image")]
    pub false_alarms_per_image: f64,
    /// The same for the coarse pass's mask, per coarse voxel. Each detection opens its
    /// 3 × 3 × 3 coarse neighbourhood to the fine pass, so the default 10⁻³ opens ≈ 2.7 % of a
    /// region with nothing in it; the coarse pass reads the fine pass's own frames
    /// (`coarse_step` 1), so what the fine pass would detect is as strong in the coarse image
    /// (`imaging::driver`).
    #[serde(default = "default_mask_pfa")]
    pub mask_false_alarm_probability: f64,
    /// With `detection = "clutter"`: a voxel must also be focused by each of the pair's two
    /// apertures on its own — the receive array in every snapshot and the transmit positions
    /// across snapshots — at the same false-alarm probability (`imaging::detection`). Rejects a
    /// sidelobe of one aperture that the other focuses.
    #[serde(default = "default_true")]
    pub coherence_test: bool,
    /// Drop a detected voxel whose grating-lobe alias for the pair's panel (element pitch above
    /// λ/2: the same range and array phases, [`crate::sensors::PlanarArray::grating_aliases`])
    /// holds a stronger echo in the same image: the pair cannot tell the two apart, and the weaker
    /// is the lobe.
    #[serde(default = "default_true")]
    pub alias_test: bool,
    /// Keep only voxels that are local maxima along the bistatic range direction.
    #[serde(default = "default_true")]
    pub local_max: bool,
    /// Drop each pair's detections in its direct-path zone: where the bistatic path exceeds the
    /// transmitter–receiver baseline by less than the range profile's main-lobe half-width
    /// (`imaging::detection::direct_path_guard_m`).
    #[serde(default = "default_true")]
    pub direct_path_guard: bool,
    /// Drop each pair's detections in the bistatic-range band of the ground beneath either of
    /// its ends that lie farther from the ends than that ground
    /// (`imaging::detection::NadirBand`): the ground under a terminal is the pair's strongest
    /// clutter, in the same range cells.
    #[serde(default = "default_true")]
    pub nadir_guard: bool,
    /// Move each pair's detections that lie in the skirt of a stronger echo's point-spread
    /// function (below half its power, within the pair's resolution along the direction it
    /// resolves worst) to that echo's power centroid ([`crate::imaging::centroid`]).
    #[serde(default = "default_true")]
    pub skirt_centroid: bool,
    /// Move each pair's detections on a surface that crosses the direction it resolves worst
    /// (its own points' normal within 45° of that direction) to their column's power centroid
    /// along it: a surface crossing a pair's long resolution axis is imaged as a slab one extent
    /// thick ([`crate::imaging::centroid`]).
    #[serde(default = "default_true")]
    pub smear_centroid: bool,
    /// A pair's detection confirms a fused point only at an offset its own resolution cell
    /// cannot tell from the point: across the point's surface where it has one, in every
    /// direction otherwise ([`crate::imaging::confirmation`]); off, any detection within the
    /// support distance confirms.
    #[serde(default = "default_true")]
    pub resolved_confirmation: bool,
    /// How the fine pass back-projects: `"exact"` (default) per element over the
    /// `element_step`-thinned panel; `"factorised"` over every element of the panel, cut into
    /// `subarray × subarray` subarrays whose beams are formed once per snapshot
    /// ([`has_dsp::bp::factorised`], its error stated there and measured by `has-sim bench dsp`).
    /// The coarse pass stays exact on the thinned panel either way.
    #[serde(default)]
    pub backprojection: Backprojection,
    /// Subarray side (elements) of the factorised back-projection; divides every panel's rows
    /// and columns.
    #[serde(default = "default_subarray")]
    pub subarray: usize,
    /// Beam samples per subarray beamwidth `O` of the factorised back-projection (direction
    /// sampling error ≤ π²/(4O²) per term, rms about a third of it).
    #[serde(default = "default_beam_oversample")]
    pub beam_oversample: usize,
    /// Use every n-th element of each array in both directions (1: all).
    #[serde(default = "default_one")]
    pub element_step: usize,
    /// Use every n-th transmit position of each aperture (1: all).
    #[serde(default = "default_one")]
    pub position_step: usize,
    /// Coarse pass: use every n-th of the fine pass's elements (rows and columns) and positions
    /// (1: all; the frames are synthesised once for both passes). Thinning costs the coarse
    /// image processing gain, so a surface the fine pass detects may miss the mask.
    #[serde(default = "default_coarse_step")]
    pub coarse_step: usize,
    /// Surface scatterers per m² on every object except those listed in `ground_objects`.
    pub scatterer_density_per_m2: f64,
    /// Objects treated as ground (clutter, not imaged as the target).
    #[serde(default)]
    pub ground_objects: Vec<String>,
    /// Scatterers per m² on ground objects; only inside the disc around the region's footprint
    /// that reaches `ground_margin_m` past its farthest corner
    /// ([`Scenario::scatters_as_ground`]).
    #[serde(default = "default_ground_density")]
    pub ground_density_per_m2: f64,
    /// How far past the region footprint's farthest corner the ground scatters, metres.
    #[serde(default = "default_ground_margin")]
    pub ground_margin_m: f32,
    /// What the ground's scatterers stand for ([`GroundClutter`]): by default developed clutter
    /// (a Rayleigh patch, at least one per finest resolution cell); `"points"` makes each a point
    /// echo of its area, the same echoes as the terrain model's.
    #[serde(default)]
    pub ground_clutter: GroundClutter,
    /// Objects whose surfaces are the ground truth (the building).
    pub truth_objects: Vec<String>,
    /// Ground-truth samples per m² on the truth objects' surfaces.
    #[serde(default = "default_truth_density")]
    pub truth_density_per_m2: f64,
    /// Aperture positions across which one visibility list is shared, metres.
    #[serde(default = "default_vis_shift")]
    pub visibility_shift_m: f32,
    /// Fusion: keep a fused point when its weighted support reaches this fraction of the
    /// strongest point's (0 keeps all).
    #[serde(default = "default_fusion_min")]
    pub fusion_min_weight: f32,
    /// Cross-pair confirmation ([`crate::imaging::confirmation`]): drop a fused point that at least this
    /// many pairs per confirming pair see and did not detect (0 keeps every point).
    #[serde(default = "default_cross_pair_denials")]
    pub cross_pair_denials: u8,
    /// Drop fused points that lie within the vertical resolution of their pairs above the known
    /// terrain with nothing of the cloud rising above that layer around them: the terrain's own
    /// echoes ([`crate::imaging::terrain_echo`]).
    #[serde(default = "default_true")]
    pub terrain_echo_test: bool,
    /// A pair confirms a fused point only when neither of its legs crosses a surface patch of the
    /// cloud on the way to it: a pair cannot image what it cannot see
    /// ([`crate::imaging::confirmation`]).
    #[serde(default = "default_true")]
    pub own_sight_test: bool,
    /// A pair denies a fused point that one of its legs to a point two pairs kept farther on
    /// passed through, across the layer the point's surface may lie in: free space
    /// ([`crate::imaging::free_space`]). The mesh's inferred samples are not placed there
    /// either.
    #[serde(default = "default_true")]
    pub free_space_test: bool,
    /// Drop a pair's detections that are no stronger than the sidelobe a stronger echo of its
    /// own image puts there, by the pair's point-spread function
    /// ([`crate::imaging::sidelobes`]).
    #[serde(default = "default_true")]
    pub sidelobe_test: bool,
    /// Image a band past the region (the pair's coarsest horizontal resolution cell) whose
    /// detections serve only as the sources of the sidelobe test: what stands outside the
    /// region is judged where its echo peaks ([`crate::imaging::driver`]). Off by default: it cost
    /// the quick cloud's and mesh's √CD 0.05 m on a procedural site, and recall on a real one.
    #[serde(default)]
    pub guard_band: bool,
    /// Drop fused points that a finer pair places at another height: copies of a roof (a
    /// surface crossing the vertical) within the vertical resolution of the coarse pairs that
    /// detected them, which the finer pair resolves from its own placement; and move such a
    /// copy that no finer pair resolves to the information-weighted height of its surface's
    /// placements ([`crate::imaging::finer_height`]).
    #[serde(default = "default_true")]
    pub finer_height_test: bool,
    /// Which pairs are imaged when `[[pairs]]` is not given, among the base stations whose
    /// panel faces the region's centre: `"every"` (default), every such base station with every
    /// aperture — each base station receives every terminal's transmission, and each pairing
    /// sees faces the others miss; `"resolution"`, per aperture the one base station of the
    /// finest resolution cell at the region's centre; `"survey"`, per aperture the one whose
    /// coarse pass detects the most of the site (`imaging::survey_pair`).
    #[serde(default)]
    pub pairing: Pairing,
    /// Seed of the scatterer sampling and the noise.
    #[serde(default = "default_one_u64")]
    pub seed: u64,
}

/// How an aperture's base station is chosen (see [`ImagingSpec::pairing`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Pairing {
    /// The finest resolution cell at the region's centre.
    Resolution,
    /// The most coarse-pass detections ([`crate::imaging::survey_pair`]).
    Survey,
    /// Every base station whose panel faces the region: each receives every terminal's
    /// transmission, so each such pair is imaged ([`crate::imaging::every_facing_pair`]).
    #[default]
    Every,
}

/// How the fine pass back-projects (see [`ImagingSpec::backprojection`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Backprojection {
    /// Every (thinned) element, exact ranges and phases.
    #[default]
    Exact,
    /// Every element, in subarrays beamformed once per snapshot.
    Factorised,
}

/// What the ground's scatterers stand for (see [`ImagingSpec::ground_clutter`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GroundClutter {
    /// Each scatterer echoes as a point reflector of the area it stands for, at
    /// `ground_density_per_m2`. The terrain model the detector holds voxels against is then the
    /// same set of echoes as the data's ground, so the detector knows the clutter's very draw: a
    /// world easier than a real one, kept to compare with earlier runs.
    Points,
    /// Developed clutter: the ground is rough on the wavelength's scale, so the echo of each
    /// patch is the sum of many unresolved facets with random phases, a circular complex
    /// Gaussian whose power is exponentially distributed about the patch's mean (Rayleigh
    /// amplitude). Each scatterer stands for such a patch: its power is its area's mean times an
    /// independent Exp(1) draw, its phase the path's (random across patches at a 3 cm
    /// wavelength). The patches are at least one per finest resolution cell of the image
    /// ([`Scenario::ground_density_per_m2`]), so no cell of the ground is empty and every cell's
    /// echo is Rayleigh whatever the number of patches in it. The default: the terrain model
    /// keeps each patch's mean power, so the detector knows the clutter's statistics, not its
    /// draw, as a real one does.
    #[default]
    Developed,
}

/// How the imaging driver detects surface voxels (see [`ImagingSpec::detection`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Detection {
    /// Against the predicted bare-terrain clutter plus noise (CFAR).
    #[default]
    Clutter,
    /// Against the pair's image peak (relative thresholds).
    Peak,
}

/// `[quick]`: fields of `[imaging]` replaced by the `--quick` preset (all optional).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImagingOverrides {
    /// See [`ImagingSpec::voxel_m`].
    pub voxel_m: Option<f32>,
    /// See [`ImagingSpec::coarse_voxel_m`].
    pub coarse_voxel_m: Option<f32>,
    /// See [`ImagingSpec::element_step`].
    pub element_step: Option<usize>,
    /// See [`ImagingSpec::position_step`].
    pub position_step: Option<usize>,
    /// See [`ImagingSpec::coarse_step`].
    pub coarse_step: Option<usize>,
    /// See [`ImagingSpec::scatterer_density_per_m2`].
    pub scatterer_density_per_m2: Option<f64>,
    /// See [`ImagingSpec::threshold_db`].
    pub threshold_db: Option<f32>,
    /// See [`ImagingSpec::truth_density_per_m2`].
    pub truth_density_per_m2: Option<f64>,
}

fn default_subcarriers() -> usize {
    1024
}
fn default_zero_pad() -> usize {
    2
}
fn default_window() -> String {
    "hann".into()
}
fn default_snr() -> f64 {
    10.0
}
fn default_32() -> usize {
    32
}
fn default_width() -> f32 {
    1.0
}
fn default_height() -> f32 {
    0.5
}
fn default_true() -> bool {
    true
}
fn default_one() -> usize {
    1
}
fn default_one_u64() -> u64 {
    1
}
fn default_coarse_step() -> usize {
    1
}
fn default_subarray() -> usize {
    8
}
fn default_beam_oversample() -> usize {
    8
}
fn default_coarse_threshold_db() -> f32 {
    -20.0
}
fn default_threshold_db() -> f32 {
    -15.0
}
fn default_pfa() -> f64 {
    1e-4
}
fn default_false_alarms_per_image() -> f64 {
    1.0
}
fn default_mask_pfa() -> f64 {
    1e-3
}
fn default_ground_density() -> f64 {
    2.0
}
fn default_ground_margin() -> f32 {
    10.0
}
/// Samples per m² of a surface scored against the truth (the truth itself, and a mesh in
/// `reconstruct` and `has-sim mesh`), unless a scenario says otherwise.
pub const DEFAULT_TRUTH_DENSITY_PER_M2: f64 = 16.0;

fn default_truth_density() -> f64 {
    DEFAULT_TRUTH_DENSITY_PER_M2
}
fn default_vis_shift() -> f32 {
    0.5
}
/// The mean of a polygon's vertices (the origin for none).
/// The area centroid of a simple polygon (shoelace formula, in f64 about its first vertex); the
/// vertex mean where the polygon encloses no area. Unlike the vertex mean it does not lean toward
/// where the outline was drawn with more vertices.
fn area_centroid(poly: &[[f32; 2]]) -> glam::Vec2 {
    let Some(&[x0, y0]) = poly.first() else {
        return glam::Vec2::ZERO;
    };
    let (mut a2, mut cx, mut cy) = (0.0f64, 0.0f64, 0.0f64);
    for (p, q) in poly.iter().zip(poly.iter().cycle().skip(1)) {
        let (px, py) = ((p[0] - x0) as f64, (p[1] - y0) as f64);
        let (qx, qy) = ((q[0] - x0) as f64, (q[1] - y0) as f64);
        let c = px * qy - qx * py;
        a2 += c;
        cx += (px + qx) * c;
        cy += (py + qy) * c;
    }
    if a2.abs() <= f64::EPSILON * poly.len() as f64 {
        let n = poly.len() as f32;
        return poly
            .iter()
            .fold(glam::Vec2::ZERO, |a, v| a + glam::Vec2::from(*v))
            / n;
    }
    glam::Vec2::new(x0 + (cx / (3.0 * a2)) as f32, y0 + (cy / (3.0 * a2)) as f32)
}
fn default_cross_pair_denials() -> u8 {
    2
}
fn default_fusion_min() -> f32 {
    0.0
}

/// The largest coordinate magnitude at which f32 positions keep back-projection phases within
/// 2π/64: rounding a coordinate `x` to f32 moves it by at most `|x|·2⁻²⁴`, a range error of as
/// much, so `|x| ≤ 2²⁴·λ/64 = 2¹⁸·λ` (7.9 km at 10 GHz). Sites are given in a local frame.
pub fn coherent_extent_m(wavelength_m: f64) -> f64 {
    wavelength_m * (1u64 << 18) as f64
}

/// Bytes one panel element costs before the imaging's own estimate
/// (`imaging::run::check_memory`) is asked: its position and gain, in each of the arrays built
/// from the panel; generous.
const BYTES_PER_ELEMENT: f64 = 256.0;

impl Scenario {
    /// Reads and validates a scenario file.
    ///
    /// # Errors
    /// [`ScenarioError`] naming the file, field and value.
    pub fn load(path: &Path) -> Result<Scenario, ScenarioError> {
        let text = crate::io::guard::read_input_string(path).map_err(|e| ScenarioError::Io {
            path: path.to_path_buf(),
            source: e,
        })?;
        let mut s = Self::from_toml_str(&text).map_err(|e| match e {
            ScenarioError::Toml { msg, .. } => ScenarioError::Toml {
                path: path.to_path_buf(),
                msg,
            },
            other => other,
        })?;
        let dir = path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."))
            .to_path_buf();
        s.scene.set_base_dir(dir.clone());
        s.base_dir = dir;
        Ok(s)
    }

    /// Parses and validates TOML text (mesh paths resolve against `.`).
    ///
    /// # Errors
    /// As [`Scenario::load`].
    pub fn from_toml_str(text: &str) -> Result<Scenario, ScenarioError> {
        let mut s: Scenario = toml::from_str(text).map_err(|e| ScenarioError::Toml {
            path: PathBuf::from("<string>"),
            msg: one_line_toml_error(text, &e),
        })?;
        s.scene.set_base_dir(".");
        s.base_dir = PathBuf::from(".");
        s.validate()?;
        Ok(s)
    }

    /// A digest of what the scenario's pair images depend on (its TOML with any preset and seed
    /// applied; how the fine pass back-projects left out, as `--fixed-point` is, and so are the
    /// switches of the fusion that reads the pair clouds: `smear_centroid`,
    /// `resolved_confirmation`, `fusion_min_weight`, `cross_pair_denials`, `terrain_echo_test`,
    /// `own_sight_test`, `free_space_test`, `finer_height_test`; and the downstream experiments'
    /// `[channel]` and `[localize]` tables): 16 hex digits of FNV-1a over the text. Mesh
    /// objects count by their path and offset, not their file's bytes. Two runs with the same
    /// digest imaged the same site with the same draw, so `--from-pairs` may fuse one run's pair
    /// clouds under the other's fusion switches.
    ///
    /// # Errors
    /// [`ScenarioError::Toml`] if serialisation fails.
    pub fn digest(&self) -> Result<String, ScenarioError> {
        let mut s = self.clone();
        s.imaging.backprojection = Backprojection::default();
        // The experiments that use the twin do not touch the pair images.
        (s.channel, s.localize) = (None, None);
        // The fusion's switches at one fixed setting: they do not touch the pair images.
        let im = &mut s.imaging;
        (im.smear_centroid, im.resolved_confirmation) = (true, true);
        (im.fusion_min_weight, im.cross_pair_denials) = (0.0, 0);
        (
            im.terrain_echo_test,
            im.own_sight_test,
            im.free_space_test,
            im.finer_height_test,
        ) = (true, true, true, true);
        let text = s.to_toml_string()?;
        let h = text.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
            (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
        });
        Ok(format!("{h:016x}"))
    }

    /// Applies the `[quick]` overrides to `imaging`.
    pub fn apply_quick(&mut self) {
        let q = self.quick.clone();
        let im = &mut self.imaging;
        if let Some(v) = q.voxel_m {
            im.voxel_m = v;
        }
        if let Some(v) = q.coarse_voxel_m {
            im.coarse_voxel_m = v;
        }
        if let Some(v) = q.element_step {
            im.element_step = v;
        }
        if let Some(v) = q.position_step {
            im.position_step = v;
        }
        if let Some(v) = q.coarse_step {
            im.coarse_step = v;
        }
        if let Some(v) = q.scatterer_density_per_m2 {
            im.scatterer_density_per_m2 = v;
        }
        if let Some(v) = q.threshold_db {
            im.threshold_db = v;
        }
        if let Some(v) = q.truth_density_per_m2 {
            im.truth_density_per_m2 = v;
        }
    }

    /// Every base station's panel centre and every aperture's ends, each with its field name
    /// (`base_stations[i].position`, `apertures[i].start`, `apertures[i].end`).
    pub fn sensor_positions(&self) -> impl Iterator<Item = (String, [f32; 3])> + '_ {
        let stations = self
            .base_stations
            .iter()
            .enumerate()
            .map(|(i, b)| (format!("base_stations[{i}].position"), b.position));
        let apertures = self.apertures.iter().enumerate().flat_map(|(i, a)| {
            [
                (format!("apertures[{i}].start"), a.start),
                (format!("apertures[{i}].end"), a.end),
            ]
        });
        stations.chain(apertures)
    }

    /// Every sensor position and the region within [`coherent_extent_m`] of the origin at the
    /// scenario's wavelength. [`crate::imaging::build_world`] checks it once the carrier is known to lie
    /// in the scene's materials' range.
    ///
    /// # Errors
    /// [`ScenarioError::FarFromOrigin`] naming the first position beyond it.
    pub fn check_extent(&self) -> Result<(), ScenarioError> {
        let wavelength_m = self.wavelength_m();
        let limit_m = coherent_extent_m(wavelength_m);
        let im = &self.imaging;
        let named = self.sensor_positions().chain([
            ("imaging.region_min".to_string(), im.region_min),
            ("imaging.region_max".to_string(), im.region_max),
        ]);
        for (field, v) in named {
            let distance_m = v.iter().fold(0.0f64, |m, &x| m.max((x as f64).abs()));
            if distance_m > limit_m {
                return Err(ScenarioError::FarFromOrigin {
                    field,
                    value: format!("{v:?}"),
                    distance_m,
                    limit_m,
                    wavelength_m,
                });
            }
        }
        Ok(())
    }

    /// The longest bistatic path `|p − tx| + |p − rx|` over the region's box, metres: at one of
    /// its corners (the path is convex in `p`).
    pub fn longest_path_m(&self, tx: Vec3, rx: Vec3) -> f64 {
        let (lo, hi) = self.region();
        (0..8)
            .map(|i| {
                let c = Vec3::new(
                    if i & 1 == 0 { lo.x } else { hi.x },
                    if i & 2 == 0 { lo.y } else { hi.y },
                    if i & 4 == 0 { lo.z } else { hi.z },
                );
                has_dsp::geometry::bistatic_range(c, tx, rx) as f64
            })
            .fold(0.0, f64::max)
    }

    /// The range profiles hold every path the region can echo on: an OFDM profile's bins wrap
    /// after `n·c/B` of path, and an echo from farther folds onto a nearer path. Asked after
    /// [`Self::check_extent`] (a site far from the origin is refused there, by its position).
    ///
    /// # Errors
    /// [`ScenarioError::Ambiguous`] with the longest path, its sensors and the subcarriers it
    /// needs.
    pub fn check_unambiguous(&self) -> Result<(), ScenarioError> {
        let r = &self.radar;
        // The longest bistatic path through the region: at its box's corners (the path is
        // convex in the point), from any base station via any terminal position.
        let unambiguous =
            r.subcarriers as f64 * has_dsp::geometry::C_M_PER_S / (r.bandwidth_mhz * 1e6);
        let mut longest = (0.0f64, String::new());
        for b in &self.base_stations {
            for a in &self.apertures {
                for t in [a.start, a.end] {
                    let path = self.longest_path_m(Vec3::from(t), Vec3::from(b.position));
                    if path > longest.0 {
                        longest = (
                            path,
                            format!("from {} via the region to {}", b.name, a.name),
                        );
                    }
                }
            }
        }
        if longest.0 > unambiguous {
            let needed = (longest.0 * r.bandwidth_mhz * 1e6 / has_dsp::geometry::C_M_PER_S).ceil();
            return Err(ScenarioError::Ambiguous {
                subcarriers: r.subcarriers,
                unambiguous_m: unambiguous,
                longest_m: longest.0,
                via: longest.1,
                needed: (needed as usize).next_power_of_two(),
            });
        }
        Ok(())
    }

    /// Checks every value (names the first bad field).
    ///
    /// # Errors
    /// [`ScenarioError::Invalid`].
    pub fn validate(&self) -> Result<(), ScenarioError> {
        let r = &self.radar;
        FIELDS.positive("radar.fc_ghz", r.fc_ghz)?;
        FIELDS.positive("radar.bandwidth_mhz", r.bandwidth_mhz)?;
        if r.bandwidth_mhz * 1e6 >= r.fc_ghz * 1e9 {
            return Err(FIELDS.invalid(
                "radar.bandwidth_mhz",
                r.bandwidth_mhz,
                "below the carrier",
            ));
        }
        if !(r.subcarriers.is_power_of_two() && (64..=4096).contains(&r.subcarriers)) {
            return Err(FIELDS.invalid(
                "radar.subcarriers",
                r.subcarriers,
                "a power of two, 64 … 4096",
            ));
        }
        if !matches!(r.zero_pad, 1 | 2 | 4) || r.subcarriers * r.zero_pad > 4096 {
            return Err(FIELDS.invalid(
                "radar.zero_pad",
                r.zero_pad,
                "1, 2 or 4, with subcarriers·zero_pad ≤ 4096",
            ));
        }
        self.window()?;
        if !r.snr_db.is_finite() {
            return Err(FIELDS.invalid("radar.snr_db", r.snr_db, "finite"));
        }
        for (i, o) in self.scene.objects.iter().enumerate() {
            if let ObjectSpec::Mesh(m) = o {
                if let Err(SceneSpecError::NotFinite {
                    index,
                    field,
                    value,
                }) = m.check_placement(i)
                {
                    let field = format!("scene.objects[{index}].{field}");
                    return Err(FIELDS.invalid(field, value, "finite"));
                }
            }
        }
        if self.base_stations.is_empty() {
            return Err(FIELDS.invalid("base_stations", "[]", "at least one base station"));
        }
        for (i, b) in self.base_stations.iter().enumerate() {
            FIELDS.name_component(format!("base_stations[{i}].name"), &b.name)?;
            FIELDS.finite(format!("base_stations[{i}].position"), b.position)?;
            if !b.boresight_deg.is_finite() {
                return Err(FIELDS.invalid(
                    format!("base_stations[{i}].boresight_deg"),
                    b.boresight_deg,
                    "finite",
                ));
            }
            if b.rows == 0 || b.cols == 0 {
                return Err(FIELDS.invalid(
                    format!("base_stations[{i}].rows/cols"),
                    (b.rows, b.cols),
                    "≥ 1",
                ));
            }
            FIELDS.size(
                format!("base_stations[{i}].rows × cols"),
                (b.rows, b.cols),
                b.rows as f64 * b.cols as f64 * BYTES_PER_ELEMENT,
            )?;
            FIELDS.positive(format!("base_stations[{i}].width_m"), b.width_m as f64)?;
            FIELDS.positive(format!("base_stations[{i}].height_m"), b.height_m as f64)?;
            if self.base_stations[..i].iter().any(|o| o.name == b.name) {
                return Err(FIELDS.invalid(
                    format!("base_stations[{i}].name"),
                    &b.name,
                    "unique: an earlier base station has it",
                ));
            }
        }
        if self.apertures.is_empty() {
            return Err(FIELDS.invalid("apertures", "[]", "at least one aperture"));
        }
        for (i, a) in self.apertures.iter().enumerate() {
            FIELDS.name_component(format!("apertures[{i}].name"), &a.name)?;
            FIELDS.finite(format!("apertures[{i}].start"), a.start)?;
            FIELDS.finite(format!("apertures[{i}].end"), a.end)?;
            let length = (Vec3::from(a.end) - Vec3::from(a.start)).length() as f64;
            if length < self.wavelength_m() {
                return Err(FIELDS.invalid(
                    format!("apertures[{i}].end"),
                    a.end,
                    "at least a wavelength from start: a virtual aperture of no length resolves \
                     nothing across range",
                ));
            }
            if self.apertures[..i].iter().any(|o| o.name == a.name) {
                return Err(FIELDS.invalid(
                    format!("apertures[{i}].name"),
                    &a.name,
                    "unique: an earlier aperture has it",
                ));
            }
            if let Some(n) = a.positions {
                if n < 2 {
                    return Err(FIELDS.invalid(format!("apertures[{i}].positions"), n, "≥ 2"));
                }
            }
        }
        for (i, p) in self.pairs.iter().enumerate() {
            if self.pairs[..i]
                .iter()
                .any(|o| o.bs == p.bs && o.aperture == p.aperture)
            {
                return Err(FIELDS.invalid(
                    format!("pairs[{i}]"),
                    format!("{}-{}", p.bs, p.aperture),
                    "unique: an earlier pair has the same bs and aperture",
                ));
            }
            if !self.base_stations.iter().any(|b| b.name == p.bs) {
                return Err(FIELDS.invalid(
                    format!("pairs[{i}].bs"),
                    &p.bs,
                    "the name of a base station",
                ));
            }
            if !self.apertures.iter().any(|a| a.name == p.aperture) {
                return Err(FIELDS.invalid(
                    format!("pairs[{i}].aperture"),
                    &p.aperture,
                    "the name of an aperture",
                ));
            }
        }
        let im = &self.imaging;
        FIELDS.finite("imaging.region_min", im.region_min)?;
        FIELDS.finite("imaging.region_max", im.region_max)?;
        for k in 0..3 {
            if im.region_max[k] <= im.region_min[k] {
                return Err(FIELDS.invalid(
                    "imaging.region_max",
                    im.region_max,
                    "above region_min on every axis",
                ));
            }
        }
        if let Some(poly) = &im.region_polygon {
            if poly.len() < 3 {
                return Err(FIELDS.invalid(
                    "imaging.region_polygon",
                    poly.len(),
                    "at least 3 vertices",
                ));
            }
            for (i, v) in poly.iter().enumerate() {
                let inside = v.iter().all(|c| c.is_finite())
                    && (0..2).all(|k| {
                        v[k] >= im.region_min[k] - 1e-3 && v[k] <= im.region_max[k] + 1e-3
                    });
                if !inside {
                    return Err(FIELDS.invalid(
                        format!("imaging.region_polygon[{i}]"),
                        v,
                        "finite and inside region_min … region_max",
                    ));
                }
            }
            if let Some((i, j)) = crossing_edges(poly) {
                return Err(FIELDS.invalid(
                    "imaging.region_polygon",
                    format!("edges {i} and {j} cross"),
                    "a simple polygon (no edge crosses another)",
                ));
            }
            if polygon_area(poly).abs() < 1e-6 {
                return Err(FIELDS.invalid(
                    "imaging.region_polygon",
                    "zero area",
                    "a polygon with area",
                ));
            }
        }
        for (f, v) in [
            (
                "imaging.false_alarm_probability",
                im.false_alarm_probability,
            ),
            (
                "imaging.mask_false_alarm_probability",
                im.mask_false_alarm_probability,
            ),
        ] {
            if !(v > 0.0 && v < 1.0) {
                return Err(FIELDS.invalid(f, v, "a probability in (0, 1)"));
            }
        }
        FIELDS.positive("imaging.false_alarms_per_image", im.false_alarms_per_image)?;
        FIELDS.positive("imaging.voxel_m", im.voxel_m as f64)?;
        FIELDS.positive("imaging.coarse_voxel_m", im.coarse_voxel_m as f64)?;
        if im.coarse_voxel_m < im.voxel_m {
            return Err(FIELDS.invalid(
                "imaging.coarse_voxel_m",
                im.coarse_voxel_m,
                "at least voxel_m: the coarse pass masks the finer one",
            ));
        }
        for (f, v) in [
            ("imaging.coarse_threshold_db", im.coarse_threshold_db),
            ("imaging.threshold_db", im.threshold_db),
        ] {
            if !(v.is_finite() && v <= 0.0) {
                return Err(FIELDS.invalid(f, v, "finite and ≤ 0 dB"));
            }
        }
        for (f, v) in [
            ("imaging.element_step", im.element_step),
            ("imaging.position_step", im.position_step),
            ("imaging.coarse_step", im.coarse_step),
        ] {
            if v == 0 {
                return Err(FIELDS.invalid(f, v, "≥ 1"));
            }
        }
        if im.backprojection == Backprojection::Factorised {
            if !(1..=4096).contains(&im.beam_oversample) {
                return Err(FIELDS.invalid(
                    "imaging.beam_oversample",
                    im.beam_oversample,
                    "in 1..=4096",
                ));
            }
            for (i, b) in self.base_stations.iter().enumerate() {
                if im.subarray == 0
                    || !b.rows.is_multiple_of(im.subarray)
                    || !b.cols.is_multiple_of(im.subarray)
                {
                    return Err(FIELDS.invalid(
                        format!(
                            "imaging.subarray (base_stations[{i}] is {}×{})",
                            b.rows, b.cols
                        ),
                        im.subarray,
                        "≥ 1 and dividing every panel's rows and cols (factorised)",
                    ));
                }
            }
        }
        FIELDS.positive(
            "imaging.scatterer_density_per_m2",
            im.scatterer_density_per_m2,
        )?;
        FIELDS.positive("imaging.ground_density_per_m2", im.ground_density_per_m2)?;
        FIELDS.positive("imaging.truth_density_per_m2", im.truth_density_per_m2)?;
        if !(im.ground_margin_m.is_finite() && im.ground_margin_m >= 0.0) {
            return Err(FIELDS.invalid(
                "imaging.ground_margin_m",
                im.ground_margin_m,
                "finite and ≥ 0",
            ));
        }
        if !(im.visibility_shift_m.is_finite() && im.visibility_shift_m >= 0.0) {
            return Err(FIELDS.invalid(
                "imaging.visibility_shift_m",
                im.visibility_shift_m,
                "finite and ≥ 0",
            ));
        }
        if !(0.0..=1.0).contains(&im.fusion_min_weight) {
            return Err(FIELDS.invalid(
                "imaging.fusion_min_weight",
                im.fusion_min_weight,
                "in [0, 1]",
            ));
        }
        if im.truth_objects.is_empty() {
            return Err(FIELDS.invalid("imaging.truth_objects", "[]", "at least one object name"));
        }
        if let Some(imp) = &self.impairments {
            imp.validate()?;
        }
        Ok(())
    }

    /// The range-compression window.
    ///
    /// # Errors
    /// [`ScenarioError::Invalid`] for an unknown window name.
    pub fn window(&self) -> Result<has_dsp::window::Window, ScenarioError> {
        use has_dsp::window::Window;
        match self.radar.window.to_ascii_lowercase().as_str() {
            "rectangular" | "rect" => Ok(Window::Rectangular),
            "hann" => Ok(Window::Hann),
            "taylor" => Ok(Window::Taylor {
                nbar: 4,
                sll_db: -35.0,
            }),
            _ => Err(FIELDS.invalid(
                "radar.window",
                &self.radar.window,
                "rectangular, hann or taylor",
            )),
        }
    }

    /// The finest range resolution of any pair, metres: `c/(2B)`, a path resolution of `c/B`
    /// ([`has_dsp::ofdm::range_bin_spacing_m`] without zero padding) halved where the bistatic
    /// range grows at its fastest (transmitter and receiver on the same side).
    ///
    /// # Errors
    /// [`ScenarioError`] naming `radar.bandwidth_mhz` if it is not finite and positive.
    pub fn range_resolution_m(&self) -> Result<f64, ScenarioError> {
        has_dsp::ofdm::range_bin_spacing_m(self.radar.bandwidth_mhz * 1e6, 1)
            .map(|d| 0.5 * d)
            .map_err(|_| {
                FIELDS.invalid("radar.bandwidth_mhz", self.radar.bandwidth_mhz, "positive")
            })
    }

    /// Carrier wavelength, metres.
    pub fn wavelength_m(&self) -> f64 {
        crate::wavelength_m(self.radar.fc_ghz * 1e9)
    }

    /// The base station `i` as a [`PlanarArray`].
    pub fn array(&self, i: usize) -> PlanarArray {
        let b = &self.base_stations[i];
        PlanarArray {
            centre: Vec3::from(b.position),
            boresight_az_rad: b.boresight_deg.to_radians(),
            rows: b.rows,
            cols: b.cols,
            width_m: b.width_m,
            height_m: b.height_m,
        }
    }

    /// Aperture `i` with `positions` transmit positions.
    pub fn aperture(&self, i: usize, positions: usize) -> VirtualAperture {
        let a = &self.apertures[i];
        VirtualAperture {
            start: Vec3::from(a.start),
            end: Vec3::from(a.end),
            positions,
        }
    }

    /// The imaging region's bounding box `(min, max)`.
    pub fn region(&self) -> (Vec3, Vec3) {
        (
            Vec3::from(self.imaging.region_min),
            Vec3::from(self.imaging.region_max),
        )
    }

    /// Whether `p` lies in the imaging region: inside the box and, when the scenario gives a
    /// `region_polygon`, inside that polygon (even–odd rule) in xy.
    pub fn in_region(&self, p: Vec3) -> bool {
        let (lo, hi) = self.region();
        if !(p.cmpge(lo).all() && p.cmple(hi).all()) {
            return false;
        }
        match &self.imaging.region_polygon {
            None => true,
            Some(poly) => point_in_polygon(poly, p.x, p.y),
        }
    }

    /// The region's footprint in xy, metres: its `region_polygon`, else the box's four corners
    /// (counter-clockwise).
    pub fn region_footprint(&self) -> Vec<[f32; 2]> {
        let (lo, hi) = self.region();
        match &self.imaging.region_polygon {
            Some(poly) => poly.clone(),
            None => vec![[lo.x, lo.y], [hi.x, lo.y], [hi.x, hi.y], [lo.x, hi.y]],
        }
    }

    /// The region's centre, metres: its footprint's area centroid
    /// ([`Scenario::region_footprint_centre`]) at the middle of its height. It turns with a turned site, where the centre of the region's
    /// axis-aligned box does not (the box of a turned polygon is another box).
    pub fn region_centre(&self) -> Vec3 {
        let (lo, hi) = self.region();
        self.region_footprint_centre().extend(0.5 * (lo.z + hi.z))
    }

    /// The area centroid of the region's footprint, metres (xy): the box's centre for a box
    /// region.
    pub fn region_footprint_centre(&self) -> glam::Vec2 {
        match &self.imaging.region_polygon {
            Some(poly) => area_centroid(poly),
            None => {
                let (lo, hi) = self.region();
                (0.5 * (lo + hi)).truncate()
            }
        }
    }

    /// Scatterers per m² on the ground: `ground_density_per_m2`, and with
    /// [`GroundClutter::Developed`] at least one per finest resolution cell of the image, the
    /// finest range resolution ([`Scenario::range_resolution_m`]) by the voxel (a finer
    /// cross-range cell is sampled by the voxel lattice, not resolved by it).
    ///
    /// # Errors
    /// As [`Scenario::range_resolution_m`].
    pub fn ground_density_per_m2(&self) -> Result<f64, ScenarioError> {
        let im = &self.imaging;
        Ok(match im.ground_clutter {
            GroundClutter::Points => im.ground_density_per_m2,
            GroundClutter::Developed => im
                .ground_density_per_m2
                .max(1.0 / (self.range_resolution_m()? * im.voxel_m as f64)),
        })
    }

    /// Whether a ground point at `p` scatters in the simulated world: inside the disc centred on
    /// the region's footprint centre ([`Scenario::region_footprint_centre`]) whose radius
    /// reaches `ground_margin_m` past the farthest vertex. A disc, so that the world's
    /// ground is the same whichever way the site and its region are turned (the region's
    /// axis-aligned box grown by the margin held 1.7 × the ground of the unrotated factory site
    /// for the site turned by 37°, and its larger range-bin power hid roof detections).
    pub fn scatters_as_ground(&self, p: Vec3) -> bool {
        let footprint = self.region_footprint();
        let c = self.region_footprint_centre();
        let r = footprint
            .iter()
            .map(|v| glam::Vec2::from(*v).distance(c))
            .fold(0.0f32, f32::max)
            + self.imaging.ground_margin_m;
        glam::Vec2::new(p.x, p.y).distance_squared(c) <= r * r
    }

    /// Whether the axis-aligned box `[lo, hi]` touches the imaging region (conservative: true
    /// when any part of the box may be inside).
    pub fn box_touches_region(&self, lo: Vec3, hi: Vec3) -> bool {
        let (rlo, rhi) = self.region();
        if hi.cmplt(rlo).any() || lo.cmpgt(rhi).any() {
            return false;
        }
        match &self.imaging.region_polygon {
            None => true,
            Some(poly) => {
                // The box's xy rectangle meets the polygon if a polygon vertex is inside the
                // rectangle, a rectangle corner is inside the polygon, or an edge pair crosses.
                let corners = [[lo.x, lo.y], [hi.x, lo.y], [hi.x, hi.y], [lo.x, hi.y]];
                poly.iter()
                    .any(|v| v[0] >= lo.x && v[0] <= hi.x && v[1] >= lo.y && v[1] <= hi.y)
                    || corners.iter().any(|c| point_in_polygon(poly, c[0], c[1]))
                    || (0..poly.len()).any(|i| {
                        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
                        (0..4).any(|j| segments_cross(a, b, corners[j], corners[(j + 1) % 4]))
                    })
            }
        }
    }
}

impl Scenario {
    /// The scenario with its imaging region grown outward by `guard_m` horizontally (its height
    /// range unchanged): the box's sides moved out by it, and the `region_polygon` offset
    /// outward edge by edge (mitred corners, each at most `2·guard_m` from its vertex). An offset
    /// polygon that is not simple or does not hold every vertex of the original gives way to the
    /// grown box. The imaging driver images this guard band past the region so that an echo just
    /// outside is imaged where it peaks, and its image inside the region can be judged against it
    /// ([`crate::imaging::sidelobes`]); only the region's own detections are kept.
    pub(crate) fn with_region_grown(&self, guard_m: f32) -> Scenario {
        let mut out = self.clone();
        if !(guard_m.is_finite() && guard_m > 0.0) {
            return out;
        }
        let g = Vec3::new(guard_m, guard_m, 0.0);
        let (mut lo, mut hi) = (self.region().0 - g, self.region().1 + g);
        out.imaging.region_polygon = self.imaging.region_polygon.as_ref().and_then(|poly| {
            let grown = offset_polygon(poly, guard_m)?;
            for v in &grown {
                lo = lo.min(Vec3::new(v[0], v[1], lo.z));
                hi = hi.max(Vec3::new(v[0], v[1], hi.z));
            }
            Some(grown)
        });
        out.imaging.region_min = lo.into();
        out.imaging.region_max = hi.into();
        out
    }
}

/// `poly` offset outward by `d` (module item [`Scenario::with_region_grown`]); `None` when the
/// result is not a simple polygon holding every vertex of `poly`.
fn offset_polygon(poly: &[[f32; 2]], d: f32) -> Option<Vec<[f32; 2]>> {
    let n = poly.len();
    if n < 3 {
        return None;
    }
    // Outward normal of edge a→b: to the right of the edge for a counter-clockwise polygon.
    let ccw = polygon_area(poly) > 0.0;
    let normal = |a: [f32; 2], b: [f32; 2]| {
        let e = glam::Vec2::new(b[0] - a[0], b[1] - a[1]).normalize_or_zero();
        if ccw {
            glam::Vec2::new(e.y, -e.x)
        } else {
            glam::Vec2::new(-e.y, e.x)
        }
    };
    let grown: Vec<[f32; 2]> = (0..n)
        .map(|i| {
            let (a, v, b) = (poly[(i + n - 1) % n], poly[i], poly[(i + 1) % n]);
            let (n1, n2) = (normal(a, v), normal(v, b));
            let miter = (n1 + n2) / (1.0 + n1.dot(n2)).max(1e-6);
            let step = miter * d;
            let step = if step.length() > 2.0 * d {
                step.normalize_or_zero() * 2.0 * d
            } else {
                step
            };
            [v[0] + step.x, v[1] + step.y]
        })
        .collect();
    let simple = (0..n).all(|i| {
        (i + 2..n).all(|j| {
            (i == 0 && j == n - 1)
                || !segments_cross(grown[i], grown[(i + 1) % n], grown[j], grown[(j + 1) % n])
        })
    });
    let holds = poly.iter().all(|v| point_in_polygon(&grown, v[0], v[1]));
    (simple && holds && grown.iter().flatten().all(|c| c.is_finite())).then_some(grown)
}

/// Signed area of a polygon (shoelace), m².
fn polygon_area(poly: &[[f32; 2]]) -> f32 {
    (0..poly.len())
        .map(|i| {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f32>()
        * 0.5
}

/// The first two edges of the closed polygon that cross or touch (edge `i` runs from vertex
/// `i` to `i + 1`), other than neighbours meeting at their shared vertex; None for a simple
/// polygon. Exact in f64 for f32 input.
fn crossing_edges(poly: &[[f32; 2]]) -> Option<(usize, usize)> {
    let n = poly.len();
    let p = |i: usize| {
        let v = poly[i % n];
        [v[0] as f64, v[1] as f64]
    };
    let orient = side;
    let on = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        c[0] >= a[0].min(b[0])
            && c[0] <= a[0].max(b[0])
            && c[1] >= a[1].min(b[1])
            && c[1] <= a[1].max(b[1])
    };
    let meet = |a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]| {
        let (o1, o2, o3, o4) = (
            orient(a, b, c),
            orient(a, b, d),
            orient(c, d, a),
            orient(c, d, b),
        );
        (o1 * o2 < 0 && o3 * o4 < 0)
            || (o1 == 0 && on(a, b, c))
            || (o2 == 0 && on(a, b, d))
            || (o3 == 0 && on(c, d, a))
            || (o4 == 0 && on(c, d, b))
    };
    for i in 0..n {
        for j in i + 1..n {
            let neighbours = j == i + 1 || (i == 0 && j == n - 1);
            if neighbours {
                // Adjacent edges share a vertex; they overlap only when folded back onto each
                // other (the far end of one lies on the other).
                let (a, b, c) = if j == i + 1 {
                    (p(i), p(i + 1), p(j + 1))
                } else {
                    (p(j), p(0), p(1))
                };
                if orient(a, b, c) == 0
                    && ((c[0] - b[0]) * (a[0] - b[0]) + (c[1] - b[1]) * (a[1] - b[1])) > 0.0
                {
                    return Some((i, j));
                }
                continue;
            }
            if meet(p(i), p(i + 1), p(j), p(j + 1)) {
                return Some((i, j));
            }
        }
    }
    None
}

/// Even–odd point-in-polygon test.
fn point_in_polygon(poly: &[[f32; 2]], x: f32, y: f32) -> bool {
    let mut inside = false;
    let mut j = poly.len() - 1;
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[j]);
        if (a[1] > y) != (b[1] > y) && x < (b[0] - a[0]) * (y - a[1]) / (b[1] - a[1]) + a[0] {
            inside = !inside;
        }
        j = i;
    }
    inside
}

/// The side of `c` from the line `a → b`: −1, 0 or 1 (`signum` would call 0 positive). Exact in
/// f64 for f32 input.
fn side(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> i8 {
    let cross = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    (cross > 0.0) as i8 - (cross < 0.0) as i8
}

/// Whether the segments `a–b` and `c–d` cross: each has the other's ends on opposite sides (an
/// end on the other's line counts on the negative side).
fn segments_cross(a: [f32; 2], b: [f32; 2], c: [f32; 2], d: [f32; 2]) -> bool {
    let w = |p: [f32; 2]| [p[0] as f64, p[1] as f64];
    let (a, b, c, d) = (w(a), w(b), w(c), w(d));
    (side(c, d, a) > 0) != (side(c, d, b) > 0) && (side(a, b, c) > 0) != (side(a, b, d) > 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn factory() -> Scenario {
        Scenario::from_toml_str(include_str!("../../../fixtures/factory.toml")).unwrap()
    }

    #[test]
    fn a_grown_region_holds_the_region_and_a_band_of_the_guard_around_it() {
        // An L-shaped polygon region (a reflex corner at (10, 10)), grown by 2 m.
        let mut sc = factory();
        sc.imaging.region_min = [0.0, 0.0, 0.5];
        sc.imaging.region_max = [20.0, 20.0, 16.0];
        sc.imaging.region_polygon = Some(vec![
            [0.0, 0.0],
            [20.0, 0.0],
            [20.0, 10.0],
            [10.0, 10.0],
            [10.0, 20.0],
            [0.0, 20.0],
        ]);
        let g = sc.with_region_grown(2.0);
        let at = |x: f32, y: f32| Vec3::new(x, y, 5.0);
        for p in [
            at(1.0, 1.0),
            at(19.0, 9.0),
            at(-1.9, 5.0),
            at(15.0, 11.9),
            at(21.9, -1.5),
        ] {
            assert!(g.in_region(p), "{p} in the grown region");
        }
        for p in [
            at(-2.1, 5.0),
            at(15.0, 12.1),
            at(15.0, 15.0),
            at(5.0, 22.1),
            at(5.0, 5.0 + 20.0),
        ] {
            assert!(!g.in_region(p), "{p} outside the grown region");
        }
        assert!(g.in_region(at(5.0, 5.0)) && !sc.in_region(at(15.0, 11.0)));
        // Heights are not grown; a box region grows its sides.
        assert!(!g.in_region(Vec3::new(5.0, 5.0, 16.5)));
        sc.imaging.region_polygon = None;
        let g = sc.with_region_grown(2.0);
        assert!(g.in_region(at(-1.9, 21.9)) && !g.in_region(at(-2.1, 5.0)));
    }

    #[test]
    fn the_coherent_extent_keeps_f32_rounding_within_a_64th_of_a_wavelength() {
        let lambda = 0.03;
        let limit = coherent_extent_m(lambda);
        // The worst rounding at the limit, |x|·2⁻²⁴, is λ/64.
        assert!((limit * 2f64.powi(-24) - lambda / 64.0).abs() < 1e-12);
        // And an f32 coordinate just inside it rounds by no more.
        let x = (limit * 0.999) as f32;
        let err = ((limit * 0.999) - x as f64).abs();
        assert!(err <= lambda / 64.0, "{err}");
    }

    #[test]
    fn sensor_and_object_names_that_cannot_be_file_names_are_refused_naming_the_field() {
        for bad in ["../../../tmp/x", "", "a/b", "a\0b"] {
            let mut sc = factory();
            sc.base_stations[0].name = bad.into();
            let e = sc.validate().unwrap_err().to_string();
            assert!(e.starts_with("base_stations[0].name:"), "{e}");
            let mut sc = factory();
            sc.apertures[1].name = bad.into();
            let e = sc.validate().unwrap_err().to_string();
            assert!(e.starts_with("apertures[1].name:"), "{e}");
            let mut sc = factory();
            match &mut sc.scene.objects[0] {
                ObjectSpec::Building(b) | ObjectSpec::Box(b) => b.name = bad.into(),
                ObjectSpec::Ground(g) => g.name = bad.into(),
                ObjectSpec::Cylinder(c) => c.name = bad.into(),
                ObjectSpec::Mesh(m) => m.name = Some(bad.into()),
            }
            let e = sc.scene.build_objects().unwrap_err().to_string();
            assert!(e.starts_with("scene.objects[0].name:"), "{e}");
        }
    }

    #[test]
    fn the_region_centre_is_the_footprints_area_centroid_not_its_vertex_mean() {
        // An L, [0,2]×[0,1] and [0,1]×[1,2]: area 3, centroid
        // (5/6, 5/6); its east side drawn with many extra vertices moves the vertex mean, not the
        // centroid.
        let mut l = vec![[0.0f32, 0.0], [2.0, 0.0]];
        l.extend((1..10).map(|k| [2.0, k as f32 * 0.1]));
        l.extend([[2.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]]);
        let c = area_centroid(&l);
        assert!((c - glam::Vec2::splat(5.0 / 6.0)).length() < 1e-5, "{c}");
        // Either winding; a polygon with no area falls back to its vertex mean.
        let rev: Vec<[f32; 2]> = l.iter().rev().copied().collect();
        assert!((area_centroid(&rev) - c).length() < 1e-5);
        let flat = [[0.0f32, 0.0], [1.0, 0.0], [3.0, 0.0]];
        assert!((area_centroid(&flat) - glam::Vec2::new(4.0 / 3.0, 0.0)).length() < 1e-6);
        // A box region's centre is its box's; a polygon region's, its centroid at mid-height.
        let mut sc = factory();
        let (lo, hi) = sc.region();
        assert_eq!(sc.region_centre(), 0.5 * (lo + hi));
        sc.imaging.region_polygon = Some(l.iter().map(|v| [v[0] - 10.0, v[1]]).collect());
        let c = sc.region_centre();
        assert!(
            (c.x + 10.0 - 5.0 / 6.0).abs() < 1e-4 && (c.y - 5.0 / 6.0).abs() < 1e-4,
            "{c}"
        );
    }

    #[test]
    fn developed_ground_holds_a_patch_per_resolution_cell_and_is_its_own_digest() {
        let mut sc = factory();
        assert_eq!(sc.imaging.ground_clutter, GroundClutter::Developed);
        sc.imaging.ground_clutter = GroundClutter::Points;
        sc.imaging.ground_density_per_m2 = 2.0;
        assert_eq!(sc.ground_density_per_m2().unwrap(), 2.0);
        let d = sc.digest().unwrap();
        sc.imaging.ground_clutter = GroundClutter::Developed;
        // 400 MHz: c/(2B) = 0.375 m; a 0.25 m voxel: 10.7 patches per m².
        let (dr, v) = (sc.range_resolution_m().unwrap(), sc.imaging.voxel_m as f64);
        assert!((dr - 0.375).abs() < 1e-3 && v == 0.25, "{dr} {v}");
        let rho = sc.ground_density_per_m2().unwrap();
        assert!((rho * dr * v - 1.0).abs() < 1e-12, "{rho}");
        assert_ne!(sc.digest().unwrap(), d);
        // A density already finer than the cell is kept.
        sc.imaging.ground_density_per_m2 = 40.0;
        assert_eq!(sc.ground_density_per_m2().unwrap(), 40.0);
        // Spelled in the TOML as documented.
        let toml = include_str!("../../../fixtures/factory.toml")
            .replace("[imaging]\n", "[imaging]\nground_clutter = \"points\"\n");
        let parsed = Scenario::from_toml_str(&toml).unwrap();
        assert_eq!(parsed.imaging.ground_clutter, GroundClutter::Points);
    }

    #[test]
    fn the_digest_follows_the_imaging_and_not_the_fusions_switches_or_the_experiments() {
        let sc = factory();
        let d = sc.digest().unwrap();
        let mut fusion = sc.clone();
        fusion.imaging.smear_centroid = !fusion.imaging.smear_centroid;
        fusion.imaging.resolved_confirmation = !fusion.imaging.resolved_confirmation;
        fusion.imaging.cross_pair_denials += 1;
        fusion.imaging.own_sight_test = !fusion.imaging.own_sight_test;
        fusion.imaging.free_space_test = !fusion.imaging.free_space_test;
        assert_eq!(fusion.digest().unwrap(), d);
        // The downstream experiments read the twin, not the pair images.
        let mut downstream = sc.clone();
        assert!(downstream.channel.is_some() && downstream.localize.is_some());
        (downstream.channel, downstream.localize) = (None, None);
        assert_eq!(downstream.digest().unwrap(), d);
        let mut imaging = sc.clone();
        imaging.imaging.sidelobe_test = !imaging.imaging.sidelobe_test;
        assert_ne!(imaging.digest().unwrap(), d);
        let mut seed = sc;
        seed.imaging.seed += 1;
        assert_ne!(seed.digest().unwrap(), d);
    }

    #[test]
    fn the_impairments_table_parses_with_its_defaults_and_names_a_bad_field() {
        let toml = include_str!("../../../fixtures/factory.toml");
        let ideal = Scenario::from_toml_str(toml).unwrap();
        assert!(ideal.impairments.is_none());
        let with =
            Scenario::from_toml_str(&format!("{toml}\n[impairments]\ncfo_hz = 500\n")).unwrap();
        let imp = with.impairments.clone().unwrap();
        assert_eq!(imp.cfo_hz, 500.0);
        assert_eq!(
            ImpairmentSpec {
                cfo_hz: 500.0,
                ..imp.clone()
            },
            ImpairmentSpec {
                cfo_hz: 500.0,
                ..ImpairmentSpec::default()
            }
        );
        // The table enters the digest; its absence leaves an ideal scenario's digest alone.
        assert_ne!(with.digest().unwrap(), ideal.digest().unwrap());
        let mut back = with.clone();
        back.impairments = None;
        assert_eq!(back.digest().unwrap(), ideal.digest().unwrap());
        let bad = format!("{toml}\n[impairments]\ntiming_offset_ns = -1\n");
        let e = Scenario::from_toml_str(&bad).unwrap_err().to_string();
        assert!(
            e.contains("impairments.timing_offset_ns") && e.contains("-1"),
            "{e}"
        );
        let degraded = format!("{toml}\n[impairments]\nposition_error = \"degraded\"\n");
        let e = Scenario::from_toml_str(&degraded)
            .unwrap()
            .impairments
            .unwrap();
        assert_eq!(e.position_error.stats().gm_m, 0.02);
        let table = format!(
            "{toml}\n[impairments]\nposition_error = {{ bias_m = 0.1, gm_m = 0.0, gm_tau_s = 1.0, white_m = 0.0 }}\n"
        );
        let e = Scenario::from_toml_str(&table)
            .unwrap()
            .impairments
            .unwrap();
        assert_eq!(e.position_error.stats().bias_m, 0.1);
        let bad = format!("{toml}\n[impairments]\nposition_error = {{ bias_m = -0.1, gm_m = 0.0, gm_tau_s = 1.0, white_m = 0.0 }}\n");
        let e = Scenario::from_toml_str(&bad).unwrap_err().to_string();
        assert!(e.contains("impairments.position_error.bias_m"), "{e}");
        let unknown = format!("{toml}\n[impairments]\nphase_noise = \"3gpp-c\"\n");
        assert!(Scenario::from_toml_str(&unknown)
            .unwrap_err()
            .to_string()
            .contains("phase_noise"));
    }

    #[test]
    fn a_pair_given_twice_is_refused_naming_it() {
        let mut sc = factory();
        let p = PairSpec {
            bs: sc.base_stations[0].name.clone(),
            aperture: sc.apertures[0].name.clone(),
        };
        sc.pairs = vec![p.clone()];
        sc.validate().unwrap();
        sc.pairs.push(p);
        let e = sc.validate().unwrap_err().to_string();
        assert!(e.starts_with("pairs[1]:") && e.contains("unique"), "{e}");
    }

    #[test]
    fn a_self_intersecting_region_polygon_is_refused() {
        let mut sc = factory();
        // A bow tie: area 0 by the signed formula would catch only the symmetric one; this one
        // has non-zero signed area.
        sc.imaging.region_polygon = Some(vec![
            [-30.0, -20.0],
            [30.0, 20.0],
            [30.0, -10.0],
            [-30.0, 20.0],
        ]);
        assert!(polygon_area(sc.imaging.region_polygon.as_ref().unwrap()).abs() > 1.0);
        let e = sc.validate().unwrap_err().to_string();
        assert!(
            e.starts_with("imaging.region_polygon:") && e.contains("cross"),
            "{e}"
        );
        // A polygon folded back along an edge is not simple either.
        sc.imaging.region_polygon = Some(vec![
            [-30.0, -20.0],
            [30.0, -20.0],
            [0.0, -20.0],
            [0.0, 20.0],
        ]);
        sc.validate().unwrap_err();
        // A concave simple polygon is fine.
        sc.imaging.region_polygon = Some(vec![
            [-30.0, -20.0],
            [30.0, -20.0],
            [30.0, 20.0],
            [0.0, 0.0],
            [-30.0, 20.0],
        ]);
        sc.validate().unwrap();
    }

    #[test]
    fn a_coarse_voxel_finer_than_the_fine_one_is_refused() {
        let mut sc = factory();
        sc.imaging.coarse_voxel_m = 0.01;
        let e = sc.validate().unwrap_err().to_string();
        assert!(e.starts_with("imaging.coarse_voxel_m: 0.01"), "{e}");
    }

    #[test]
    fn a_site_in_georeferenced_coordinates_is_refused_naming_the_field_and_the_limit() {
        let mut sc = factory();
        sc.base_stations[1].position[1] += 5.0e6;
        let e = sc.check_extent().unwrap_err().to_string();
        assert!(e.starts_with("base_stations[1].position:"), "{e}");
        let limit = format!("±{:.0} m", coherent_extent_m(sc.wavelength_m()));
        assert!(e.contains(&limit) && e.contains("local site frame"), "{e}");
        let mut sc = factory();
        sc.imaging.region_max[0] += 9.0e3;
        let e = sc.check_extent().unwrap_err().to_string();
        assert!(e.starts_with("imaging.region_max:"), "{e}");
    }

    #[test]
    fn profiles_shorter_than_the_regions_longest_path_are_refused_with_the_subcarriers_needed() {
        let mut sc = factory();
        sc.radar.subcarriers = 64;
        sc.validate().unwrap();
        let e = sc.check_unambiguous().unwrap_err();
        let ScenarioError::Ambiguous {
            needed, longest_m, ..
        } = e
        else {
            panic!("{e}")
        };
        assert!(e.to_string().starts_with("radar.subcarriers: 64 "), "{e}");
        // n·c/B holds the longest path at the count it names, not at half of it.
        let path =
            |n: usize| n as f64 * has_dsp::geometry::C_M_PER_S / (sc.radar.bandwidth_mhz * 1e6);
        assert!(
            path(needed) >= longest_m && path(needed / 2) < longest_m,
            "{e}"
        );
        sc.radar.subcarriers = needed;
        sc.check_unambiguous().unwrap();
    }

    #[test]
    fn a_site_a_few_kilometres_from_the_origin_is_accepted() {
        let mut sc = factory();
        for b in &mut sc.base_stations {
            b.position[0] += 2000.0;
        }
        for a in &mut sc.apertures {
            a.start[0] += 2000.0;
            a.end[0] += 2000.0;
        }
        sc.imaging.region_min[0] += 2000.0;
        sc.imaging.region_max[0] += 2000.0;
        sc.validate().unwrap();
        sc.check_extent().unwrap();
    }

    #[test]
    fn a_factorised_subarray_that_does_not_tile_the_panel_is_refused_by_name() {
        let mut sc = factory();
        sc.imaging.backprojection = Backprojection::Factorised;
        sc.validate().unwrap();
        sc.imaging.subarray = 5;
        let e = sc.validate().unwrap_err().to_string();
        assert!(
            e.starts_with("imaging.subarray (base_stations[0] is 32×32)"),
            "{e}"
        );
        assert!(e.contains('5'), "{e}");
        sc.imaging.subarray = 8;
        sc.imaging.beam_oversample = 0;
        let e = sc.validate().unwrap_err().to_string();
        assert!(e.starts_with("imaging.beam_oversample"), "{e}");
        // Exact back-projection does not read either.
        sc.imaging.backprojection = Backprojection::Exact;
        sc.validate().unwrap();
    }
}
