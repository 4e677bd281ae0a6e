//! The imaging driver: for one base station–terminal pair, synthesise each frame (one transmit
//! position, every receive element), and push it through has-dsp back-projection exactly as
//! firmware would — one snapshot at a time, every active voxel updated, the snapshot discarded.
//!
//! Two passes keep the work proportional to the surfaces rather than to the whole volume:
//!
//! Each frame is synthesised once and kept (the data's and the terrain model's profiles) for
//! both passes and the receive-coherence pass.
//!
//! 1. **Coarse pass**: the region on a coarse grid (`imaging.coarse_voxel_m`) from the fine pass's
//!    frames (every `coarse_step`-th element and position; default all, so a surface the fine
//!    pass detects has the same processing gain here); voxels detected at
//!    `mask_false_alarm_probability` against the bare-terrain prediction ([`super::detection`]),
//!    dilated by one coarse voxel, form the mask (with `detection = "peak"`: voxels within
//!    `coarse_threshold_db` of the coarse peak). With the clutter test the mask is the union of
//!    two coarse images of the same snapshots, the full band and the profiles low-passed along
//!    range to the lattice's resolution ([`super::coarse_range`]), each at half the mask's
//!    false-alarm probability: a point sample of the full-band image misses a surface that falls
//!    between the samples (on a 1.5 m lattice at 400 MHz a wall half a spacing from the nearest
//!    centre can keep −15 dB of its power, and the mask lost surfaces the fine pass would have
//!    detected). The coarse grid costs (fine / coarse voxel)³ less
//!    per frame than the fine one. It is turned to the region's footprint (`CoarseFrame`: a
//!    `region_polygon` askew to the world axes is covered by a grid of its own size, not by its
//!    axis-aligned box), and of it only the columns the detection reads are imaged (a
//!    non-rectangular footprint). On the quick factory site turned by 37° this halved the coarse
//!    voxels (1.22 M → 0.61 M, the unturned site's count) and cut back-projection time by a fifth.
//! 2. **Fine pass**: the region on the fine grid (`imaging.voxel_m`), cut into bricks of
//!    [`BRICK`]³ voxels; only bricks that touch the mask are imaged, each its own has-dsp voxel grid
//!    (positions relative to the brick origin, so `f32` keeps phase accuracy), all bricks updated
//!    in parallel (rayon) from the same snapshot. Voxels are detected against the bare-terrain
//!    prediction, imaged alongside from the terrain model's echoes with the same noise variance
//!    ([`super::detection`]), at `false_alarms_per_image` expected false detections over the
//!    resolution cells the pass tests (at most `false_alarm_probability` per voxel). The
//!    incoherent image `P` of that test only raises a voxel's threshold, so on the exact path it
//!    is formed last, over the bricks holding a voxel that passes without it (a third of the
//!    fine voxels on the quick bundled site), from the frames' excess power packed two to a slot.
//!    With the receive-coherence test the terrain model's image is formed after the data image
//!    too: it is read only through the window means of voxels that pass that test, which reads
//!    no model, so it is formed over the bricks those windows reach and nowhere else.
//!
//! Only bricks and points inside the region (its `region_polygon`, if any) are imaged, and a
//! pair keeps only detections in front of its panel ([`in_front_of_panel`]): a panel with a
//! backplane receives nothing from behind, and a planar array cannot tell a direction from its
//! mirror image through the array plane, so the image behind the panel is the alias of what lies
//! in front. A region that reaches past a base station (the site the sensors surround) otherwise
//! holds that alias: the bundled factory with its region widened to ±55 × ±48 m put 9 points
//! 40–48 m from the hall, 5–12 m behind BS1's panel (the mirror of the yard's echo at the same
//! bistatic range), which alone raised the quick cloud's √CD from 1.27 to 2.41 m.
//! The echoes are synthesised the same way: a pair's frames hold only the visible scatterers in
//! front of its panel (the ground behind a base station does not reach it).
//!
//! Profiles are the range-compressed echoes of [`crate::echo`] (path (a): the exact pulse of
//! has-dsp range compression, tabulated), or with `raw_ofdm` the raw subcarriers of path (b) pushed
//! through [`has_dsp::range::RangeCompressor`] frame by frame. Complex white Gaussian noise is added
//! to the profiles at `radar.snr_db` per bin (relative to the mean echo power per bin of the pair's
//! first frame); with `raw_ofdm` the same SNR is set per subcarrier before compression.

use std::time::Instant;

use glam::Vec3;
use has_dsp::bp::factorised::{grid_box, BeamWindow, Factorisation, Factorised};
use has_dsp::bp::{
    AccF32, AccQ15, Backprojector, BpConfig, Interp, PhaseEval, Snapshot, VoxelGrid,
};
use has_dsp::fixed::{cq15_block_from_c32, CQ15};
use has_dsp::range::{RangeCompressor, RangeConfig, RangeMode};
use num_complex::Complex32;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::centroid::skirt_to_centroid;
use super::coarse_range::{coarse_range_kernel, filter_rows};
use super::detection::{
    alias_is_stronger, alias_window_m, cell_peak, coherence_factor, detected, direct_path_guard_m,
    effective_looks, image_false_alarm_probability, layer_looks_per_voxel, layer_window,
    local_mean, local_mean_of, pareto_factor, CfarFactors, NadirBand,
};
use super::sidelobes::{sidelobes, PairPsf};
use super::world::World;
use crate::echo::noise::ComplexGaussian;
use crate::echo::{EchoConfig, EchoError, EchoSynth, Noise, ScattererSet, VisibilityCache};
use crate::impairments::{PairSync, ReferenceRadio};
use crate::scenario::{Backprojection, Detection, Scenario};
use crate::scene::Scene;
use crate::sensors::{pair_cell_m3, pair_resolution_m, PlanarArray, VirtualAperture};

/// Wavelength of the incoherent pass: phases `2π r/λ` below 10⁻⁶ rad for any path of the scene.
const INCOHERENT_WAVELENGTH_M: f32 = 1e9;

/// Mixed into a pair's seed for the jittered thinning of its panel and aperture.
const THIN_SEED: u64 = 0x5A4D_F00D_0000_0000;

/// Seed offset of the terrain model's noise (independent of the data's).
const MODEL_NOISE_SEED: u64 = 0x0D15_EA5E_0000_7E22;

/// Fine voxels per brick side.
pub const BRICK: usize = 8;

/// Why imaging failed.
#[derive(Debug, thiserror::Error)]
pub enum ImagingError {
    /// A has-dsp kernel refused its input.
    #[error("has-dsp: {0}")]
    Dsp(#[from] has_dsp::DspError),
    /// Echo synthesis refused its input.
    #[error("echo synthesis: {0}")]
    Echo(#[from] EchoError),
    /// A scenario value that the driver cannot use.
    #[error("{0}")]
    Scenario(#[from] crate::scenario::ScenarioError),
    /// The factorised back-projection's beam tables of one snapshot would not fit in memory.
    #[error(
        "pair {pair}: the factorised beam tables of one snapshot need {need_gib:.1} GiB, \
         {have_gib:.1} GiB available: a smaller imaging.beam_oversample or imaging.subarray, or \
         imaging.backprojection = \"exact\""
    )]
    BeamTables {
        /// The pair.
        pair: String,
        /// GiB the tables need.
        need_gib: f64,
        /// GiB available.
        have_gib: f64,
    },
    /// An option the chosen back-projection does not support.
    #[error("{0}")]
    Unsupported(&'static str),
    /// The `[impairments]` of a pair could not be drawn or compensated (one line).
    #[error("{0}")]
    Impairments(String),
}

/// Options of a run that are not part of the scenario.
#[derive(Clone, Copy, Debug, Default)]
pub struct RunOptions {
    /// Q15 profiles and the fixed-point back-projection path instead of `f32`.
    pub fixed_point: bool,
    /// Raw OFDM subcarriers through has-dsp range compression instead of direct profiles.
    pub raw_ofdm: bool,
}

/// One imaging pair as planned.
#[derive(Clone, Debug)]
pub struct PairPlan {
    /// `"BS1-V1"`.
    pub name: String,
    /// Base-station index.
    pub bs: usize,
    /// Aperture index.
    pub aperture: usize,
    /// Transmit positions of the aperture (before `position_step`).
    pub positions: usize,
}

/// The image of one pair, as points.
#[derive(Clone, Debug, Default)]
pub struct PairImage {
    /// Voxel positions above threshold, metres.
    pub points: Vec<Vec3>,
    /// `|I|` of each point relative to the pair's peak (0 … 1].
    pub intensity: Vec<f32>,
    /// Work and timing.
    pub stats: PairStats,
}

/// Work done for one pair.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct PairStats {
    /// Frames (transmit positions) pushed in the fine pass.
    pub frames: usize,
    /// Receive elements per frame.
    pub elements: usize,
    /// Bins per profile.
    pub profile_bins: usize,
    /// Visible scatterers (first frame).
    pub visible_scatterers: usize,
    /// Coarse-pass voxels.
    pub coarse_voxels: usize,
    /// Fine voxels imaged (active bricks).
    pub fine_voxels: usize,
    /// Fine voxels of the incoherent image `P` of the clutter test: the bricks holding a voxel
    /// that could pass it (all of them on the factorised path).
    pub incoherent_voxels: usize,
    /// Fine voxels of the terrain model's image: the bricks a coherent voxel's CFAR window
    /// reaches on the exact `f32` path with the receive-coherence test, else every brick (0
    /// without the clutter test).
    pub model_voxels: usize,
    /// Fine voxels of the whole region.
    pub region_voxels: usize,
    /// Voxel × profile updates of both passes.
    pub backprojections: f64,
    /// Seconds spent synthesising echoes.
    pub synth_s: f64,
    /// Seconds spent in back-projection.
    pub bp_s: f64,
    /// Pulse-table error bound of the echo synthesis (relative to the peak).
    pub pulse_error: f32,
    /// Per-voxel false-alarm probability of the fine pass's detection test
    /// (`imaging.false_alarms_per_image` over its resolution cells; 0 without the clutter test).
    pub false_alarm_probability: f64,
    /// Detections in the region dropped as sidelobes of a stronger echo of the same image
    /// (`imaging.sidelobe_test`, [`super::sidelobes`]).
    pub sidelobes: usize,
    /// Voxels imaged past the lattice where the detections' grating-lobe aliases fall
    /// (`imaging.alias_test`, [`AliasImage`]).
    pub alias_voxels: usize,
    /// Largest `|I|` of the coarse image (full band) over the region, in the data's units. The
    /// coarse pass images the same voxels in every run of a site, so against the same pair's in
    /// an ideal run this is the peak that `[impairments]` cost it.
    pub coarse_peak: f32,
}

/// Per-pair constants derived from the scenario.
struct PairGeometry {
    array: PlanarArray,
    aperture: VirtualAperture,
    r0_m: f64,
    dr_m: f64,
    n_bins: usize,
    /// Volume of the pair's resolution cell at the region centre, m³.
    cell_m3: f32,
    /// Its vertical extent, m.
    cell_vertical_m: f32,
}

fn pair_geometry(sc: &Scenario, plan: &PairPlan) -> PairGeometry {
    let array = sc.array(plan.bs);
    let aperture = sc.aperture(plan.aperture, plan.positions);
    let (lo, hi) = sc.region();
    let (r_res, xv_res, _, xz_res) = pair_resolution_m(
        sc.region_centre(),
        &array,
        &aperture,
        sc.wavelength_m() as f32,
        (sc.radar.bandwidth_mhz * 1e6) as f32,
    );
    let cell_m3 = r_res * xv_res * xz_res;
    let dr = has_dsp::ofdm::bin_spacing_m(sc.radar.bandwidth_mhz * 1e6, sc.radar.zero_pad);
    // Bistatic range is convex in the point, so over the box its maximum is at a corner; its
    // minimum is bounded below by the distances to the box. Margins cover the array's and the
    // aperture's extent and the pulse's tails.
    let clamp = |p: Vec3| p.clamp(lo, hi);
    let half_array = 0.5 * (array.width_m.hypot(array.height_m));
    let mut rmin = f64::INFINITY;
    let mut rmax = 0.0f64;
    for tx in [aperture.start, aperture.end] {
        let r = (clamp(tx).distance(tx) + clamp(array.centre).distance(array.centre)) as f64;
        rmin = rmin.min(r - 0.5 * aperture.length_m() as f64 - half_array as f64);
        rmax = rmax.max(sc.longest_path_m(tx, array.centre));
    }
    rmax += half_array as f64;
    let margin = 4.0 * dr;
    let i0 = ((rmin - margin) / dr).floor().max(0.0);
    let n_bins = (((rmax + margin) / dr).ceil() - i0).max(1.0) as usize;
    PairGeometry {
        array,
        aperture,
        r0_m: i0 * dr,
        dr_m: dr,
        n_bins,
        cell_m3,
        cell_vertical_m: xz_res,
    }
}

/// Bytes of the frames a pair's imaging holds for `plan`: every thinned element × transmit
/// position × profile bin, 8 B each, for the data and (with `detection = "clutter"`) the terrain
/// model.
pub fn held_frames_bytes(sc: &Scenario, plan: &PairPlan) -> u64 {
    let im = &sc.imaging;
    let copies = if im.detection == Detection::Clutter {
        2
    } else {
        1
    };
    let geo = pair_geometry(sc, plan);
    // The factorised fine pass reads every element of the panel.
    let step = match im.backprojection {
        Backprojection::Exact => im.element_step.max(1),
        Backprojection::Factorised => 1,
    };
    let rx = geo.array.rows.div_ceil(step) as u64 * geo.array.cols.div_ceil(step) as u64;
    let tx = plan.positions.div_ceil(im.position_step.max(1)) as u64;
    rx.saturating_mul(tx)
        .saturating_mul(geo.n_bins as u64)
        .saturating_mul(8 * copies)
}

/// Adds complex white Gaussian noise of power `var` ([`ComplexGaussian`]) to `rows` (one row per
/// element), seeded per (seed, frame, element) so the result does not depend on thread
/// scheduling. (The frame and element are mixed into the seed, not a stream of
/// [`crate::echo::noise::noise_stream`]: kept, so the imaging frames keep their bits.)
fn add_noise(rows: &mut [Complex32], row_len: usize, var: f64, seed: u64, frame: usize) {
    if var <= 0.0 {
        return;
    }
    let noise = ComplexGaussian::with_power(var);
    rows.par_chunks_mut(row_len)
        .enumerate()
        .for_each(|(e, row)| {
            let mut rng = ChaCha8Rng::seed_from_u64(
                seed ^ (frame as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ ((e as u64) << 40),
            );
            for z in row {
                *z += noise.sample(&mut rng);
            }
        });
}

/// The mean `|z|²` of a frame's profiles (0 for none): the signal power its SNR refers to.
fn mean_power(out: &[Complex32]) -> f64 {
    out.iter().map(|z| z.norm_sqr() as f64).sum::<f64>() / out.len().max(1) as f64
}

/// Produces the range-compressed frames of one pair.
struct FrameSource<'a> {
    scene: &'a Scene,
    set: &'a ScattererSet,
    synth: EchoSynth,
    /// The receiving panel: it receives only from the half-space in front of it.
    array: PlanarArray,
    cache: VisibilityCache,
    /// The cached visible scatterers in front of the panel, and the cache recompute they follow.
    in_front: Vec<u32>,
    in_front_of: usize,
    noise_var: Option<f64>,
    snr_db: f64,
    seed: u64,
    raw: Option<RawOfdm>,
    /// The pair's synchronisation errors and their compensation (`[impairments]`); `None` for
    /// the ideal pair and for the terrain model, which is a prediction.
    sync: Option<PairSync>,
    synth_s: f64,
    first_visible: usize,
}

struct RawOfdm {
    rc: RangeCompressor,
    symbols: Vec<Complex32>,
    reference: Vec<Complex32>,
    first_bin: usize,
}

impl FrameSource<'_> {
    /// Fills `out` (`rx.len() × n_bins`) with the profiles of transmit position `tx`, frame `f`.
    fn frame(
        &mut self,
        f: usize,
        tx: Vec3,
        rx: &[Vec3],
        out: &mut [Complex32],
    ) -> Result<(), ImagingError> {
        let t = Instant::now();
        let (set, scene, centre) = (self.set, self.scene, self.array.centre);
        self.cache.get(set, scene, tx, centre)?;
        // The panel's backplane: a scatterer behind the array plane does not reach the elements
        // (without it, a planar array images it as its mirror in front; module docs).
        if self.cache.recomputes() != self.in_front_of {
            let visible = self.cache.get(set, scene, tx, centre)?;
            self.in_front = visible
                .iter()
                .copied()
                .filter(|&i| in_front_of_panel(&self.array, set.points[i as usize].pos))
                .collect();
            self.in_front_of = self.cache.recomputes();
        }
        let visible = &self.in_front;
        if self.first_visible == 0 {
            self.first_visible = visible.len();
        }
        let n_bins = self.synth.config().n_bins;
        match &self.raw {
            None if self.sync.is_some() => {
                if self.noise_var.is_none() {
                    // The noise level is the ideal frame's, as for an ideal pair: a frame moved
                    // out of its range window by the timing offset would lower it.
                    self.synth.synth_profiles(self.set, visible, tx, rx, out)?;
                    self.noise_var = Some(mean_power(out) / 10f64.powf(self.snr_db / 10.0));
                }
                let var = self.noise_var.unwrap_or(0.0);
                let sync = self
                    .sync
                    .as_mut()
                    .ok_or(ImagingError::Unsupported("impairments"))?;
                let off = sync
                    .residual(f, var, centre, scene)
                    .map_err(ImagingError::Impairments)?;
                // Sent from where the terminal really was; imaged from where it said it was.
                let tx_true = tx + sync.position_error(f);
                self.synth.synth_profiles_delayed(
                    self.set,
                    visible,
                    tx_true,
                    rx,
                    off.delay_m,
                    out,
                )?;
                let rot = Complex32::from_polar(1.0, off.phase_rad as f32);
                out.par_iter_mut().for_each(|z| *z *= rot);
                add_noise(out, n_bins, var, self.seed, f);
            }
            None => {
                self.synth.synth_profiles(self.set, visible, tx, rx, out)?;
                let var = match self.noise_var {
                    Some(v) => v,
                    None => {
                        let v = mean_power(out) / 10f64.powf(self.snr_db / 10.0);
                        self.noise_var = Some(v);
                        v
                    }
                };
                add_noise(out, n_bins, var, self.seed, f);
            }
            Some(raw) => {
                let n = raw.symbols.len();
                let mut y = vec![Complex32::new(0.0, 0.0); rx.len() * n];
                self.synth.synth_ofdm(
                    self.set,
                    visible,
                    tx,
                    rx,
                    &raw.symbols,
                    Noise::SnrDb(self.snr_db),
                    self.seed ^ f as u64,
                    &mut y,
                )?;
                let len = raw.rc.profile_len();
                out.par_chunks_mut(n_bins)
                    .zip(y.par_chunks(n))
                    .try_for_each(|(row, ye)| -> Result<(), has_dsp::DspError> {
                        let mut prof = vec![Complex32::new(0.0, 0.0); len];
                        raw.rc.compress(ye, &raw.reference, &mut prof)?;
                        for (i, z) in row.iter_mut().enumerate() {
                            *z = prof[(raw.first_bin + i) % len];
                        }
                        Ok(())
                    })?;
                if self.noise_var.is_none() {
                    // The profile-domain noise power at the same SNR definition as the direct
                    // path (the terrain model's noise; the data's own noise is per subcarrier).
                    self.noise_var = Some(mean_power(out) / 10f64.powf(self.snr_db / 10.0));
                }
            }
        }
        self.synth_s += t.elapsed().as_secs_f64();
        Ok(())
    }
}

/// One brick of the fine grid: its has-dsp configuration and receive elements in its frame.
struct Brick {
    bp: Backprojector,
    /// The same grid for the incoherent pass.
    bp_inc: Backprojector,
    rx_local: Vec<Vec3>,
    /// The transmit positions, grid-local (the receive-coherence pass swaps the roles).
    tx_local: Vec<Vec3>,
    offset: usize,
    /// First fine voxel of the brick on the region's lattice.
    start: [usize; 3],
}

enum Accs<'a> {
    F32(Vec<AccF32<'a>>),
    Q15(Vec<AccQ15<'a>>),
}

/// The frame sources of pair `plan`: the data (the scene, its noise seeded per pair) and, with
/// `detection = "clutter"`, the bare known terrain through the same pair (module docs of
/// `super::detection`).
fn frame_sources<'a>(
    sc: &Scenario,
    world: &'a World,
    plan: &PairPlan,
    geo: &PairGeometry,
    opts: RunOptions,
) -> Result<(FrameSource<'a>, Option<FrameSource<'a>>), ImagingError> {
    let im = &sc.imaging;
    let window = sc.window()?;
    let n_sc = sc.radar.subcarriers;
    let rc = RangeCompressor::new(RangeConfig {
        n_subcarriers: n_sc,
        bandwidth_hz: sc.radar.bandwidth_mhz * 1e6,
        zero_pad: sc.radar.zero_pad,
        mode: RangeMode::Matched,
        window,
        q15_scaling: Default::default(),
    })?;
    // The exact weights the compressor applies, so direct synthesis equals its output.
    let mut echo_cfg = EchoConfig::for_compressor(sc.radar.fc_hz_checked()?, &rc)?;
    echo_cfg.r0_m = geo.r0_m;
    echo_cfg.n_bins = geo.n_bins;
    // Hann/Taylor sidelobes fall below −70 dB within 6 cells; the rectangular pulse needs more.
    echo_cfg.kernel_half_width_cells = if matches!(window, has_dsp::window::Window::Rectangular) {
        16
    } else {
        6
    };
    echo_cfg.kernel_oversample = 64;
    let synth = EchoSynth::new(echo_cfg.clone())?;
    let raw = if opts.raw_ofdm {
        let symbols = crate::echo::qpsk_symbols(n_sc, im.seed);
        let mut reference = vec![Complex32::new(0.0, 0.0); n_sc];
        rc.prepare_reference(&symbols, &mut reference)?;
        Some(RawOfdm {
            rc,
            symbols,
            reference,
            first_bin: (geo.r0_m / geo.dr_m).round() as usize,
        })
    } else {
        None
    };
    let (scene, set) = (&world.scene, &world.scatterers);
    let seed = im.seed ^ ((plan.bs as u64) << 32) ^ ((plan.aperture as u64) << 48);
    let sync = match &sc.impairments {
        None => None,
        Some(_) if opts.raw_ofdm => {
            return Err(ImagingError::Unsupported(
                "[impairments] with raw OFDM synthesis: the direct profiles carry them",
            ))
        }
        Some(spec) => {
            let (_, tx_fine) = thinned_sensors(sc, geo, seed);
            let radio = ReferenceRadio {
                fc_hz: echo_cfg.fc_hz,
                bandwidth_hz: echo_cfg.bandwidth_hz,
                symbols: crate::echo::qpsk_symbols(n_sc, im.seed),
                weights: echo_cfg.window.clone(),
                elements: geo.array.rows * geo.array.cols,
            };
            // The position error is the terminal's, whichever base station hears it.
            let terminal_seed = im.seed ^ ((plan.aperture as u64) << 48);
            Some(
                PairSync::new(spec, seed, terminal_seed, &tx_fine, radio)
                    .map_err(ImagingError::Impairments)?,
            )
        }
    };
    let src = FrameSource {
        scene,
        set,
        synth,
        array: geo.array.clone(),
        cache: VisibilityCache::new(im.visibility_shift_m),
        in_front: Vec::new(),
        in_front_of: 0,
        noise_var: None,
        snr_db: sc.radar.snr_db,
        seed,
        raw,
        sync,
        synth_s: 0.0,
        first_visible: 0,
    };
    // The bare known terrain through the same pair (module docs of `super::detection`).
    let model = if im.detection == Detection::Clutter {
        Some(FrameSource {
            scene: &world.terrain.scene,
            set: &world.terrain.scatterers,
            synth: EchoSynth::new(echo_cfg)?,
            array: geo.array.clone(),
            cache: VisibilityCache::new(im.visibility_shift_m),
            in_front: Vec::new(),
            in_front_of: 0,
            noise_var: None,
            snr_db: sc.radar.snr_db,
            seed: src.seed ^ MODEL_NOISE_SEED,
            raw: None,
            sync: None,
            synth_s: 0.0,
            first_visible: 0,
        })
    } else {
        None
    };
    Ok((src, model))
}

/// The pair's receive elements and transmit positions after `imaging.element_step` and
/// `position_step`. Thinned arrays and apertures are jittered, not periodic (no grating lobes;
/// see [`PlanarArray::elements_jittered`]), with a draw of their own per pair (`seed`, the
/// pair's data seed).
fn thinned_sensors(sc: &Scenario, geo: &PairGeometry, seed: u64) -> (Vec<Vec3>, Vec<Vec3>) {
    let im = &sc.imaging;
    let thin_seed = seed ^ THIN_SEED;
    let rx = geo.array.elements_jittered(im.element_step, thin_seed);
    let tx = geo
        .aperture
        .positions_jittered(im.position_step, thin_seed ^ 1);
    (rx, tx)
}

/// The fine pass's receive elements and, as indices into them, the `element_step`-thinned panel
/// (jittered, as [`thinned_sensors`]) that the coarse pass reads: with exact back-projection the
/// fine pass reads the thinned panel itself; with `imaging.backprojection = "factorised"` every
/// element, row-major (the subarrays need the whole lattice).
fn receive_elements(sc: &Scenario, geo: &PairGeometry, seed: u64) -> (Vec<Vec3>, Vec<usize>) {
    let im = &sc.imaging;
    let (rx, _) = thinned_sensors(sc, geo, seed);
    match im.backprojection {
        Backprojection::Exact => {
            let n = rx.len();
            (rx, (0..n).collect())
        }
        Backprojection::Factorised => (
            geo.array.elements(1),
            geo.array
                .jittered_indices(im.element_step, seed ^ THIN_SEED),
        ),
    }
}

/// Indices of every `step`-th row and column of the `ne` thinned receive elements and of every
/// `step`-th of the `nt` thinned transmit positions.
fn every_nth(
    sc: &Scenario,
    geo: &PairGeometry,
    ne: usize,
    nt: usize,
    step: usize,
) -> (Vec<usize>, Vec<usize>) {
    let step = step.max(1);
    let cols = geo.array.cols.div_ceil(sc.imaging.element_step.max(1));
    let rx = (0..ne)
        .filter(|&e| (e / cols).is_multiple_of(step) && (e % cols).is_multiple_of(step))
        .collect();
    (rx, (0..nt).step_by(step).collect())
}

/// How much a pair sees of the site, from its own data (`imaging.pairing = "survey"`): the
/// coarse voxels of the region in front of its panel that its coarse pass detects (the coarse
/// pass of [`image_pair`], the same frames and stated false-alarm probability). A detection is an
/// echo above the bare known terrain's, so the count grows with the surface both legs see —
/// the observability of the pairing, measured without knowing where anything stands. Costs the
/// pair's frames and coarse pass; with an eighth of the frames (every second element row and
/// column and transmit position) the count was 0–39 voxels per candidate on a held-out site and
/// chose no better than the resolution cell (docs/journal/results.md).
///
/// # Errors
/// [`ImagingError`] from has-dsp or echo synthesis.
pub fn survey_pair(sc: &Scenario, world: &World, plan: &PairPlan) -> Result<usize, ImagingError> {
    let geo = pair_geometry(sc, plan);
    let clutter_ref = sc.imaging.detection == Detection::Clutter;
    let (mut src, mut model) = frame_sources(sc, world, plan, &geo, RunOptions::default())?;
    let (rx_fine, tx_fine) = thinned_sensors(sc, &geo, src.seed);
    let step = sc.imaging.coarse_step.max(1);
    let (rx_idx, tx_idx) = every_nth(sc, &geo, rx_fine.len(), tx_fine.len(), step);
    let rx: Vec<Vec3> = rx_idx.iter().map(|&e| rx_fine[e]).collect();
    let tx: Vec<Vec3> = tx_idx.iter().map(|&f| tx_fine[f]).collect();
    let mut stats = PairStats::default();
    let range_kernel = coarse_kernel(sc, &geo, &src.synth);
    let coarse = coarse_pass(
        sc,
        &geo,
        &range_kernel,
        clutter_ref,
        &tx,
        &rx,
        &mut |k, prof, mprof| {
            src.frame(tx_idx[k], tx[k], &rx, prof)?;
            if let Some(m) = model.as_mut() {
                m.noise_var = src.noise_var;
                m.frame(tx_idx[k], tx[k], &rx, mprof)?;
            }
            Ok(())
        },
        &mut stats,
        &mut || {},
    )?;
    Ok(coarse
        .detected
        .iter()
        .enumerate()
        .filter(|&(i, &d)| d && in_front_of_panel(&geo.array, coarse.frame.world(i)))
        .count())
}

/// Images one pair; `progress(done, total)` is called after every frame of both passes.
///
/// # Errors
/// [`ImagingError`] from has-dsp or echo synthesis (bad geometry, lengths).
pub fn image_pair(
    sc: &Scenario,
    world: &World,
    plan: &PairPlan,
    opts: RunOptions,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<PairImage, ImagingError> {
    let guard_m = if sc.imaging.guard_band {
        region_guard_m(sc, plan)
    } else {
        0.0
    };
    image_guarded(
        &sc.with_region_grown(guard_m),
        sc,
        world,
        plan,
        opts,
        progress,
    )
}

/// The width of the band a pair images past the region, metres: the coarser of its range and
/// panel's horizontal cross-range resolution at the region's centre, plus one coarse voxel. An
/// echo outside the region lays its main lobe into it no farther than that; imaged, it is found
/// where it peaks and explains its image inside ([`super::sidelobes`]). At most the region's
/// own larger horizontal side: a pair that resolves less than the region cannot image it anyway.
pub(crate) fn region_guard_m(sc: &Scenario, plan: &PairPlan) -> f32 {
    let (lo, hi) = sc.region();
    let side = (hi.x - lo.x).max(hi.y - lo.y).max(0.0);
    let (r, _, xh, _) = pair_resolution_m(
        sc.region_centre(),
        &sc.array(plan.bs),
        &sc.aperture(plan.aperture, plan.positions),
        sc.wavelength_m() as f32,
        (sc.radar.bandwidth_mhz * 1e6) as f32,
    );
    (r.max(xh) + sc.imaging.coarse_voxel_m).min(side)
}

/// [`image_pair`] over the region grown by the guard band (`sc`), keeping only the detections
/// in `region`'s own region.
fn image_guarded(
    sc: &Scenario,
    region: &Scenario,
    world: &World,
    plan: &PairPlan,
    opts: RunOptions,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<PairImage, ImagingError> {
    let im = &sc.imaging;
    let geo = pair_geometry(sc, plan);
    let (lo, hi) = sc.region();
    let clutter_ref = im.detection == Detection::Clutter;
    // The receive-coherence test (module docs of `super::detection`): one more f32 pass in a
    // fixed-point run, none in an f32 one.
    let coherence = clutter_ref && im.coherence_test;
    let (mut src, mut model) = frame_sources(sc, world, plan, &geo, opts)?;
    let pulse_error = src.synth.kernel().error_bound();
    let factorised = im.backprojection == Backprojection::Factorised;
    if factorised && opts.fixed_point {
        return Err(ImagingError::Unsupported(
            "fixed point: the factorised back-projection has no Q15 path yet; use \
             imaging.backprojection = \"exact\" with --fixed-point",
        ));
    }
    let (_, tx_fine) = thinned_sensors(sc, &geo, src.seed);
    let (rx_fine, thinned) = receive_elements(sc, &geo, src.seed);
    // The coarse pass reads every `coarse_step`-th of the thinned panel's element rows and
    // columns and of the transmit positions, from the fine pass's frames: each frame is
    // synthesised once.
    let (nt, ne, nb) = (tx_fine.len(), rx_fine.len(), geo.n_bins);
    let (rx_c_sub, tx_c_idx) = every_nth(sc, &geo, thinned.len(), nt, im.coarse_step);
    let rx_c_idx: Vec<usize> = rx_c_sub.iter().map(|&i| thinned[i]).collect();
    // The receive-coherence reference R = Σ_rx |Σ_tx …|² needs each element's own image: exact
    // back-projection, one element at a time. With the factorised fine pass it is estimated from
    // the thinned panel, `ne / thinned` × its sum (an unbiased estimate of the whole panel's: its
    // elements are a jittered draw of one per block). From the subarrays instead (16 of 4 × 4 on
    // a 16 × 16 panel), a wall's ratio |I|²/R falls by the subarray's width in elements (its beam
    // gathers that much more of the track's focusing ring): measured, it kept 79 of the exact
    // pass's 262 points on the block of has-host/tests/factorised_imaging.rs.
    let coherence_elems: Vec<usize> = if factorised {
        thinned.clone()
    } else {
        (0..ne).collect()
    };
    // With the clutter test on the exact path the incoherent image `P` is formed after the
    // others, over the bricks where a voxel could still pass (see below): one more pass over
    // the frames.
    let defer_incoherent = clutter_ref && !factorised;
    let total = (2 * nt + tx_c_idx.len()) as u64
        + if defer_incoherent { nt as u64 } else { 0 }
        + if coherence {
            coherence_elems.len() as u64
        } else {
            0
        };
    let mut done = 0u64;
    let mut stats = PairStats {
        frames: nt,
        elements: ne,
        profile_bins: nb,
        pulse_error,
        ..PairStats::default()
    };
    // ---- The frames: the data's element-major (the receive-coherence pass reads one element's
    // profiles over every transmit position), the terrain model's frame-major.
    let mut frames = vec![Complex32::new(0.0, 0.0); nt * ne * nb];
    let mut mframes = vec![Complex32::new(0.0, 0.0); if clutter_ref { nt * ne * nb } else { 0 }];
    {
        let mut prof = vec![Complex32::new(0.0, 0.0); ne * nb];
        for (f, &tx) in tx_fine.iter().enumerate() {
            src.frame(f, tx, &rx_fine, &mut prof)?;
            for (e, p) in prof.chunks_exact(nb).enumerate() {
                frames[(e * nt + f) * nb..(e * nt + f + 1) * nb].copy_from_slice(p);
            }
            if let Some(m) = model.as_mut() {
                m.noise_var = src.noise_var;
                m.frame(
                    f,
                    tx,
                    &rx_fine,
                    &mut mframes[f * ne * nb..(f + 1) * ne * nb],
                )?;
            }
            done += 1;
            progress(done, total);
        }
    }
    // Frame `f`'s profiles of the elements `elems`, data and terrain model, into `out`, `mout`.
    let gather = |f: usize,
                  elems: &mut dyn Iterator<Item = usize>,
                  out: &mut [Complex32],
                  mout: &mut [Complex32]| {
        for (k, e) in elems.enumerate() {
            out[k * nb..(k + 1) * nb]
                .copy_from_slice(&frames[(e * nt + f) * nb..(e * nt + f + 1) * nb]);
            if !mout.is_empty() {
                mout[k * nb..(k + 1) * nb]
                    .copy_from_slice(&mframes[(f * ne + e) * nb..(f * ne + e + 1) * nb]);
            }
        }
    };

    // ---- Coarse pass: the mask.
    let rx_c: Vec<Vec3> = rx_c_idx.iter().map(|&e| rx_fine[e]).collect();
    let tx_c: Vec<Vec3> = tx_c_idx.iter().map(|&f| tx_fine[f]).collect();
    let range_kernel = coarse_kernel(sc, &geo, &src.synth);
    let coarse = coarse_pass(
        sc,
        &geo,
        &range_kernel,
        clutter_ref,
        &tx_c,
        &rx_c,
        &mut |k, prof, mprof| {
            gather(tx_c_idx[k], &mut rx_c_idx.iter().copied(), prof, mprof);
            Ok(())
        },
        &mut stats,
        &mut || {
            done += 1;
            progress(done, total);
        },
    )?;
    let (cframe, coarse_detected) = (coarse.frame, coarse.detected);
    let [cx, cy, cz] = cframe.dims;
    let mut mask = vec![false; coarse_detected.len()];
    for (i, _) in coarse_detected.iter().enumerate().filter(|(_, &d)| d) {
        let (x, y, zz) = (i % cx, (i / cx) % cy, i / (cx * cy));
        for dz in -1i64..=1 {
            for dy in -1i64..=1 {
                for dx in -1i64..=1 {
                    let (a, b, c) = (x as i64 + dx, y as i64 + dy, zz as i64 + dz);
                    if a >= 0
                        && b >= 0
                        && c >= 0
                        && (a as usize) < cx
                        && (b as usize) < cy
                        && (c as usize) < cz
                    {
                        mask[a as usize + cx * (b as usize + cy * c as usize)] = true;
                    }
                }
            }
        }
    }

    // ---- Fine pass over the bricks that touch the mask.
    let v = im.voxel_m;
    let fdims = dims_of(lo, hi, v);
    stats.region_voxels = fdims.iter().product();
    let n_bricks = [
        fdims[0].div_ceil(BRICK),
        fdims[1].div_ceil(BRICK),
        fdims[2].div_ceil(BRICK),
    ];
    let in_mask = |p: Vec3| cframe.index_of(p).is_some_and(|i| mask[i]);
    let mut bricks = Vec::new();
    let mut offset = 0usize;
    for bz in 0..n_bricks[2] {
        for by in 0..n_bricks[1] {
            for bx in 0..n_bricks[0] {
                let start = [bx * BRICK, by * BRICK, bz * BRICK];
                let dims = [
                    BRICK.min(fdims[0] - start[0]),
                    BRICK.min(fdims[1] - start[1]),
                    BRICK.min(fdims[2] - start[2]),
                ];
                let origin = lo + Vec3::new(start[0] as f32, start[1] as f32, start[2] as f32) * v;
                let ext = Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32) * v;
                // Active if any of its corners or centre lies in the (dilated) mask.
                let probes = (0..8)
                    .map(|i| {
                        origin
                            + Vec3::new(
                                if i & 1 == 0 { 0.0 } else { ext.x },
                                if i & 2 == 0 { 0.0 } else { ext.y },
                                if i & 4 == 0 { 0.0 } else { ext.z },
                            )
                    })
                    .chain(std::iter::once(origin + ext * 0.5));
                if !probes.into_iter().any(in_mask) || !sc.box_touches_region(origin, origin + ext)
                {
                    continue;
                }
                let grid = VoxelGrid {
                    origin,
                    spacing: Vec3::splat(v),
                    dims,
                };
                let bp = Backprojector::new(bp_config(sc, &geo, grid, false))?;
                let bp_inc = Backprojector::new(bp_config(sc, &geo, grid, true))?;
                let n = bp.voxels();
                bricks.push(Brick {
                    rx_local: rx_fine.iter().map(|&p| grid.local(p)).collect(),
                    tx_local: if coherence {
                        tx_fine.iter().map(|&p| grid.local(p)).collect()
                    } else {
                        Vec::new()
                    },
                    bp,
                    bp_inc,
                    offset,
                    start,
                });
                offset += n;
            }
        }
    }
    stats.fine_voxels = offset;
    let mut img = vec![Complex32::new(0.0, 0.0); offset];
    let mut raw_q =
        vec![num_complex::Complex::<i64>::new(0, 0); if opts.fixed_point { offset } else { 0 }];
    let mut prof = vec![Complex32::new(0.0, 0.0); rx_fine.len() * geo.n_bins];
    let mut prof_q = vec![CQ15::default(); if opts.fixed_point { prof.len() } else { 0 }];
    let mut exps = vec![0i32; rx_fine.len()];
    let mut qimg = vec![Complex32::new(0.0, 0.0); if opts.fixed_point { offset } else { 0 }];
    let mut img_m = vec![Complex32::new(0.0, 0.0); if clutter_ref { offset } else { 0 }];
    let mut img_i = img_m.clone();
    // With the coherence test, in f32 the receive-coherence pass is the data image itself.
    let mut img_r = vec![0f32; if coherence { offset } else { 0 }];
    let data_per_frame = !coherence || opts.fixed_point || factorised;
    // The terrain model's image is read only through `C`, the mean of its power over the CFAR
    // window of a voxel that passes the receive-coherence test, which reads no model: on the
    // exact f32 path it is formed after that test, over the bricks such windows touch
    // ([`model_bricks`]); elsewhere it stays unformed (NaN in the window means), and no voxel
    // there can be detected.
    let defer_model = clutter_ref && !data_per_frame;
    let fz = if factorised {
        let fact = Factorisation {
            sub_rows: im.subarray,
            sub_cols: im.subarray,
            oversample: im.beam_oversample,
        };
        let lattice = geo.array.lattice();
        Some((
            Factorised::new(lattice, fact, sc.wavelength_m() as f32)?,
            Factorised::new(lattice, fact, INCOHERENT_WAVELENGTH_M)?,
        ))
    } else {
        None
    };
    let mut table = Vec::new();
    let mut mprof = vec![Complex32::new(0.0, 0.0); if clutter_ref { prof.len() } else { 0 }];
    let mut iprof = mprof.clone();
    {
        let mut accs_i = brick_accs_f32(&bricks, &mut img_i, |b| &b.bp_inc)?;
        let mut accs_m = if defer_model {
            Vec::new()
        } else {
            brick_accs_f32(&bricks, &mut img_m, |b| &b.bp)?
        };
        let mut accs = if opts.fixed_point {
            let mut v = Vec::with_capacity(bricks.len());
            let mut rest: &mut [num_complex::Complex<i64>] = &mut raw_q;
            for b in &bricks {
                let (head, tail) = rest.split_at_mut(b.bp.voxels());
                v.push(AccQ15::tile(&b.bp, 0, head)?);
                rest = tail;
            }
            Accs::Q15(v)
        } else if data_per_frame {
            Accs::F32(brick_accs_f32(&bricks, &mut img, |b| &b.bp)?)
        } else {
            Accs::F32(Vec::new())
        };
        let frame_loop = if defer_model {
            &tx_fine[..0]
        } else {
            &tx_fine[..]
        };
        for (f, &tx) in frame_loop.iter().enumerate() {
            gather(f, &mut (0..ne), &mut prof, &mut mprof);
            if clutter_ref && !defer_incoherent {
                excess_power_of(&prof, &mprof, &mut iprof);
            }
            let t = Instant::now();
            if let Some((fz, fz_inc)) = &fz {
                let Accs::F32(accs) = &mut accs else {
                    unreachable!("fixed point is refused with the factorised path")
                };
                for (fz, bp_of, profiles, accs) in [
                    (
                        fz_inc,
                        (|b| &b.bp_inc) as fn(&Brick) -> &Backprojector,
                        &iprof,
                        &mut accs_i,
                    ),
                    (fz, |b| &b.bp, &mprof, &mut accs_m),
                    (fz, |b| &b.bp, &prof, accs),
                ] {
                    if !accs.is_empty() {
                        push_bricks_factorised(
                            fz, &bricks, bp_of, accs, tx, profiles, nb, &mut table, &plan.name,
                        )?;
                    }
                }
                stats.bp_s += t.elapsed().as_secs_f64();
                done += 1;
                progress(done, total);
                continue;
            }
            if !defer_incoherent {
                push_bricks_f32(&mut accs_i, &bricks, |b| &b.bp_inc, tx, &iprof, geo.n_bins)?;
            }
            push_bricks_f32(&mut accs_m, &bricks, |b| &b.bp, tx, &mprof, geo.n_bins)?;
            match &mut accs {
                Accs::F32(v) => push_bricks_f32(v, &bricks, |b| &b.bp, tx, &prof, geo.n_bins)?,
                Accs::Q15(v) => {
                    prof_q
                        .par_chunks_mut(geo.n_bins)
                        .zip(prof.par_chunks(geo.n_bins))
                        .zip(exps.par_iter_mut())
                        .try_for_each(|((q, p), e)| -> Result<(), has_dsp::DspError> {
                            *e = cq15_block_from_c32(p, q)?;
                            Ok(())
                        })?;
                    v.par_iter_mut()
                        .zip(bricks.par_iter())
                        .try_for_each(|(acc, b)| {
                            b.bp.push_snapshot_q15(
                                acc,
                                &Snapshot {
                                    tx: b.bp.grid().local(tx),
                                    rx: &b.rx_local,
                                    profiles: &prof_q,
                                    profile_len: geo.n_bins,
                                },
                                &exps,
                            )
                        })?
                }
            }
            stats.bp_s += t.elapsed().as_secs_f64();
            done += 1;
            progress(done, total);
        }
        if let Accs::Q15(v) = &accs {
            for (acc, b) in v.iter().zip(&bricks) {
                acc.to_image_f32(&mut qimg[b.offset..b.offset + b.bp.voxels()])?;
            }
        }
    }
    drop(table);
    // The incoherent pass below reads only the excess power `|s|² − |m|²` of each frame: packed
    // two to a slot into the front of the terrain model's frames (frame-major, as they are),
    // and the rest of that buffer released, so that the pass holds half of it.
    // With the model deferred, after its pass below.
    let mut excess: Vec<Complex32> = if defer_incoherent && !defer_model {
        pack_excess(&frames, std::mem::take(&mut mframes), [nt, ne, nb])
    } else {
        Vec::new()
    };
    if coherence {
        // The receive-coherence pass: by reciprocity (the bistatic range is symmetric in its two
        // ends) one receive element with every transmit position is a snapshot of has-dsp, and
        // its own image power, summed over the elements, is R(v) = Σ_rx |Σ_tx …|².
        // The data image of a fixed-point or factorised run was made per frame: this pass's
        // image then goes to scratch.
        let own_image = opts.fixed_point || factorised;
        let mut scratch = vec![Complex32::new(0.0, 0.0); if own_image { offset } else { 0 }];
        let target: &mut [Complex32] = if own_image { &mut scratch } else { &mut img };
        let mut accs = brick_accs_f32(&bricks, target, |b| &b.bp)?;
        let mut pows = brick_slices(&bricks, &mut img_r);
        for &e in &coherence_elems {
            let (rx, profiles) = (rx_fine[e], &frames[e * nt * nb..(e + 1) * nt * nb]);
            let t = Instant::now();
            accs.par_iter_mut()
                .zip(pows.par_iter_mut())
                .zip(bricks.par_iter())
                .try_for_each(|((acc, r), b)| {
                    b.bp.push_snapshot_with_power(
                        acc,
                        r,
                        &Snapshot {
                            tx: b.bp.grid().local(rx),
                            rx: &b.tx_local,
                            profiles,
                            profile_len: nb,
                        },
                    )
                })?;
            stats.bp_s += t.elapsed().as_secs_f64();
            done += 1;
            progress(done, total);
        }
        if coherence_elems.len() < ne {
            let scale = ne as f32 / coherence_elems.len() as f32;
            img_r.par_iter_mut().for_each(|r| *r *= scale);
        }
        if own_image {
            stats.backprojections += (offset * coherence_elems.len() * tx_fine.len()) as f64;
        }
    }
    // The per-voxel false-alarm probability of the fine pass's tests: the stated false
    // detections per image over the resolution cells this pass tests, at most
    // `false_alarm_probability`.
    let pfa = image_false_alarm_probability(
        im.false_alarms_per_image,
        offset,
        v,
        geo.cell_m3,
        im.false_alarm_probability,
    );
    let (radius, alpha) = cfar_window(&geo, v, pfa);
    let beta = coherence_factor(pfa);
    let model_formed: Vec<bool> = if defer_model {
        let chosen = model_bricks(&bricks, &img, &img_r, beta, radius, n_bricks);
        let mut accs_m = kept(brick_accs_f32(&bricks, &mut img_m, |b| &b.bp)?, &chosen);
        let picked = kept(&bricks, &chosen);
        let model_voxels: usize = picked.iter().map(|b| b.bp.voxels()).sum();
        stats.model_voxels = model_voxels;
        stats.backprojections += (model_voxels * ne * nt) as f64;
        for (f, &tx) in tx_fine.iter().enumerate() {
            let t = Instant::now();
            let mprof = &mframes[f * ne * nb..(f + 1) * ne * nb];
            push_bricks_f32(&mut accs_m, &picked, |b| &b.bp, tx, mprof, nb)?;
            stats.bp_s += t.elapsed().as_secs_f64();
            done += 1;
            progress(done, total);
        }
        drop(accs_m);
        if defer_incoherent {
            excess = pack_excess(&frames, std::mem::take(&mut mframes), [nt, ne, nb]);
        }
        chosen
    } else {
        if clutter_ref {
            stats.model_voxels = offset;
            stats.backprojections += (offset * ne * nt) as f64;
        }
        vec![true; bricks.len()]
    };
    // The terrain model's frames are read no more (on the exact path their excess power was
    // packed above).
    drop(mframes);
    if opts.fixed_point {
        img = qimg;
    }
    // The data image; the model's is counted above, the incoherent one where it is formed.
    stats.backprojections += (offset * rx_fine.len() * tx_fine.len()) as f64;
    if clutter_ref && !defer_incoherent {
        stats.incoherent_voxels = offset;
        stats.backprojections += (offset * rx_fine.len() * tx_fine.len()) as f64;
    }
    stats.synth_s = src.synth_s + model.as_ref().map_or(0.0, |m| m.synth_s);
    stats.visible_scatterers = src.first_visible;

    let detected: Vec<bool> = if clutter_ref {
        // The predicted bare-terrain power's local mean on the region lattice (NaN where no brick
        // was imaged or the model was not formed), then the CFAR test voxel by voxel.
        stats.false_alarm_probability = pfa;
        let gidx = |b: &Brick, i: usize| {
            let d = b.bp.grid().dims;
            let (x, y, z) = (i % d[0], (i / d[0]) % d[1], i / (d[0] * d[1]));
            (b.start[0] + x) + fdims[0] * ((b.start[1] + y) + fdims[1] * (b.start[2] + z))
        };
        // `f(|I_m|²)` of the terrain model's image on the region lattice, NaN where no brick was
        // imaged.
        let model_lattice = |f: fn(f32) -> f32| {
            let mut pm = vec![f32::NAN; stats.region_voxels];
            for b in bricks
                .iter()
                .zip(&model_formed)
                .filter_map(|(b, &k)| k.then_some(b))
            {
                for i in 0..b.bp.voxels() {
                    pm[gidx(b, i)] = f(img_m[b.offset + i].norm_sqr());
                }
            }
            pm
        };
        let c = local_mean_of(model_lattice(|p| p), fdims, radius);
        if defer_incoherent {
            // `P ≥ 0` only raises the threshold: a voxel below `α·C` (or the coherence test)
            // fails whatever `P` is. `P` is imaged over the bricks holding a voxel that passes
            // both, frame by frame in the same order as the other images (its bits there are
            // those of the pass over every brick); elsewhere it stays 0 and is never read.
            let could_pass: Vec<bool> = bricks
                .par_iter()
                .map(|b| {
                    (0..b.bp.voxels()).any(|i| {
                        let (j, g) = (b.offset + i, gidx(b, i));
                        let q = img_r.get(j).copied();
                        detected(
                            img[j].norm_sqr(),
                            c.mean[g],
                            0.0,
                            q,
                            alpha.alpha(c.count[g]),
                            beta,
                        )
                    })
                })
                .collect();
            let chosen = kept(&bricks, &could_pass);
            let mut accs_i = kept(
                brick_accs_f32(&bricks, &mut img_i, |b| &b.bp_inc)?,
                &could_pass,
            );
            stats.incoherent_voxels = chosen.iter().map(|b| b.bp.voxels()).sum();
            stats.backprojections += (stats.incoherent_voxels * ne * nt) as f64;
            for (f, &tx) in tx_fine.iter().enumerate() {
                for (k, z) in iprof.iter_mut().enumerate() {
                    let i = f * ne * nb + k;
                    let pair = excess[i / 2];
                    *z = Complex32::new(if i % 2 == 0 { pair.re } else { pair.im }, 0.0);
                }
                let t = Instant::now();
                push_bricks_f32(&mut accs_i, &chosen, |b| &b.bp_inc, tx, &iprof, geo.n_bins)?;
                stats.bp_s += t.elapsed().as_secs_f64();
                done += 1;
                progress(done, total);
            }
        }
        drop(excess);
        // The model's second moment over the same window: how spiky the terrain's clutter is
        // there ([`super::detection::pareto_factor`]).
        let c2 = local_mean_of(model_lattice(|p| p * p), fdims, radius).mean;
        let looks_per_voxel = layer_looks_per_voxel(v, geo.cell_m3, geo.cell_vertical_m);
        let (lambda, bandwidth_hz) = (
            sc.wavelength_m() as f32,
            (sc.radar.bandwidth_mhz * 1e6) as f32,
        );
        let mut det = vec![false; offset];
        for b in &bricks {
            for i in 0..b.bp.voxels() {
                let j = b.offset + i;
                let q = img_r.get(j).copied();
                let g = gidx(b, i);
                let (i2, cm, p) = (img[j].norm_sqr(), c.mean[g], img_i[j].re);
                let a = alpha.alpha(c.count[g]);
                // The spiky-clutter factor only ever raises the threshold: test it only on
                // what passes the exponential one.
                det[j] = detected(i2, cm, p, q, a, beta) && {
                    // The window's looks with the resolution cell at this voxel, where it is
                    // larger than at the region's centre (a track's endfire): fewer looks, a
                    // higher factor for the same pfa.
                    let at = b.bp.grid().voxel_world(i).unwrap_or(b.bp.grid().origin);
                    let (cell, vertical) =
                        pair_cell_m3(at, &geo.array, &geo.aperture, lambda, bandwidth_hz);
                    let per_voxel = layer_looks_per_voxel(v, cell, vertical).min(looks_per_voxel);
                    let looks = effective_looks(c.count[g].max(1.0) as usize, per_voxel);
                    let kappa = c2[g] as f64 / (cm as f64).powi(2);
                    let a = a
                        .max(has_dsp::cfar::mean_level_factor(pfa, looks) as f32)
                        .max(pareto_factor(kappa, looks, pfa) as f32);
                    detected(i2, cm, p, q, a, beta)
                };
            }
        }
        det
    } else {
        let peak = img.iter().map(|z| z.norm()).fold(0.0f32, f32::max);
        let thr = peak * 10f32.powf(im.threshold_db / 20.0);
        img.iter().map(|z| peak > 0.0 && z.norm() >= thr).collect()
    };
    drop(img_m);
    drop(img_i);
    drop(img_r);
    let aliases = if im.alias_test {
        let t = Instant::now();
        let a = AliasImage::new(
            sc,
            &geo,
            &bricks,
            &detected,
            AliasFrames {
                frames: &frames,
                tx: &tx_fine,
                rx: &rx_fine,
                bins: nb,
            },
            stats.region_voxels,
        )?;
        stats.bp_s += t.elapsed().as_secs_f64();
        stats.alias_voxels = a.img.len();
        stats.backprojections += (a.img.len() * ne * nt) as f64;
        a
    } else {
        AliasImage::default()
    };
    drop(frames);
    let nadir_bands = if im.nadir_guard {
        nadir_bands(sc, world, &geo)
    } else {
        Vec::new()
    };
    let Extracted {
        mut points,
        mut intensity,
        outside,
        outside_intensity,
    } = extract_points(
        sc,
        region,
        (&bricks, &img),
        &aliases,
        &detected,
        &geo,
        &nadir_bands,
    );
    if im.sidelobe_test {
        let psf = PairPsf {
            tx: &tx_fine,
            rx: &rx_fine,
            pulse: src.synth.kernel(),
            bin_m: geo.dr_m as f32,
            wavelength_m: sc.wavelength_m() as f32,
            array: &geo.array,
            aperture: &geo.aperture,
            bandwidth_hz: (sc.radar.bandwidth_mhz * 1e6) as f32,
            range_main_lobe_cells: sc
                .window()
                .ok()
                .and_then(|w| w.main_lobe_half_width_cells())
                .unwrap_or(1.0) as f32,
        };
        let lobes = sidelobes(&psf, &points, &intensity, &outside, &outside_intensity);
        stats.sidelobes = lobes.iter().filter(|&&l| l).count();
        (points, intensity) = points
            .into_iter()
            .zip(intensity)
            .zip(lobes)
            .filter(|(_, l)| !l)
            .map(|(pi, _)| pi)
            .unzip();
    }
    if im.skirt_centroid {
        points = skirt_to_centroid(
            &points,
            &intensity,
            &geo.array,
            &geo.aperture,
            sc.wavelength_m() as f32,
            (sc.radar.bandwidth_mhz * 1e6) as f32,
            v,
        );
    }
    Ok(PairImage {
        points,
        intensity,
        stats,
    })
}

/// The coarse pass's range filter for the pair's pulse and the coarse lattice
/// ([`super::coarse_range`]).
fn coarse_kernel(sc: &Scenario, geo: &PairGeometry, synth: &EchoSynth) -> Vec<f32> {
    let k = synth.kernel();
    coarse_range_kernel(|x| k.eval(x), geo.dr_m, sc.imaging.coarse_voxel_m as f64)
}

/// Fills snapshot `k`'s profiles of the data and of the terrain model (see [`coarse_pass`]).
type SnapshotFill<'a> =
    dyn FnMut(usize, &mut [Complex32], &mut [Complex32]) -> Result<(), ImagingError> + 'a;

/// The coarse pass's outcome: its grid and, per coarse voxel (x fastest), whether it was detected
/// inside the region.
struct CoarseDetections {
    frame: CoarseFrame,
    detected: Vec<bool>,
}

/// The coarse grid, turned about z to the region's footprint: its x axis along the side of the
/// footprint whose direction gives the smallest enclosing rectangle (a polygon region askew to
/// the world axes is then covered by a grid of its own size, not by its axis-aligned box, which
/// for a rectangle turned 37° holds twice its area). A box region, or a footprint whose sides
/// run along the axes, keeps the world axes: then `local` is exactly `p − lo`.
#[derive(Clone, Copy, Debug)]
struct CoarseFrame {
    /// World position of voxel (0, 0, 0).
    origin: Vec3,
    /// Cosine and sine of the grid's turn about z.
    cos: f32,
    sin: f32,
    /// Voxel size, metres.
    cv: f32,
    dims: [usize; 3],
}

impl CoarseFrame {
    fn of(sc: &Scenario, cv: f32) -> Self {
        let (lo, hi) = sc.region();
        let foot = sc.region_footprint();
        // The turn in (−45°, 45°] of each side; the one whose enclosing rectangle is smallest.
        let turn = |a: [f32; 2], b: [f32; 2]| {
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            if dx.abs() >= dy.abs() {
                if dx == 0.0 {
                    0.0
                } else {
                    (dy / dx).atan()
                }
            } else {
                -(dx / dy).atan()
            }
        };
        let extent = |t: f32| {
            let (c, s) = (t.cos(), t.sin());
            let (mut a, mut b) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
            for v in &foot {
                let u = Vec3::new(c * v[0] + s * v[1], -s * v[0] + c * v[1], 0.0);
                (a, b) = (a.min(u), b.max(u));
            }
            (a, b)
        };
        let area = |t: f32| {
            let (a, b) = extent(t);
            (b.x - a.x) * (b.y - a.y)
        };
        let mut best = 0.0f32;
        for i in 0..foot.len() {
            let t = turn(foot[i], foot[(i + 1) % foot.len()]);
            if t.is_finite() && area(t) < area(best) * (1.0 - 1e-4) {
                best = t;
            }
        }
        if best == 0.0 {
            return Self {
                origin: lo,
                cos: 1.0,
                sin: 0.0,
                cv,
                dims: dims_of(lo, hi, cv),
            };
        }
        let (c, s) = (best.cos(), best.sin());
        let (a, b) = extent(best);
        let (a, b) = (Vec3::new(a.x, a.y, lo.z), Vec3::new(b.x, b.y, hi.z));
        Self {
            origin: Vec3::new(c * a.x - s * a.y, s * a.x + c * a.y, lo.z),
            cos: c,
            sin: s,
            cv,
            dims: dims_of(a, b, cv),
        }
    }

    /// Grid-local position (metres, in the grid's axes) of a world position.
    fn local(&self, p: Vec3) -> Vec3 {
        let d = p - self.origin;
        if self.sin == 0.0 {
            return d;
        }
        Vec3::new(
            self.cos * d.x + self.sin * d.y,
            -self.sin * d.x + self.cos * d.y,
            d.z,
        )
    }

    /// World position of voxel `i`.
    fn world(&self, i: usize) -> Vec3 {
        let [cx, cy, _] = self.dims;
        let q = Vec3::new(
            (i % cx) as f32,
            ((i / cx) % cy) as f32,
            (i / (cx * cy)) as f32,
        ) * self.cv;
        if self.sin == 0.0 {
            return self.origin + q;
        }
        self.origin
            + Vec3::new(
                self.cos * q.x - self.sin * q.y,
                self.sin * q.x + self.cos * q.y,
                q.z,
            )
    }

    /// The voxel nearest to world position `p`, if inside the grid.
    fn index_of(&self, p: Vec3) -> Option<usize> {
        let q = (self.local(p) / self.cv).round();
        let [cx, cy, cz] = self.dims;
        let (a, b, c) = (q.x as usize, q.y as usize, q.z as usize);
        (q.cmpge(Vec3::ZERO).all() && a < cx && b < cy && c < cz).then(|| a + cx * (b + cy * c))
    }

    /// Whether the world-axes box around voxel `i` reaching `half` in each axis of the grid
    /// (widened to its world-axes bounding box when the grid is turned) touches the region.
    fn touches_region(&self, sc: &Scenario, i: usize, half: Vec3) -> bool {
        let p = self.world(i);
        let h = Vec3::new(
            self.cos.abs() * half.x + self.sin.abs() * half.y,
            self.sin.abs() * half.x + self.cos.abs() * half.y,
            half.z,
        );
        sc.box_touches_region(p - h, p + h)
    }
}

/// The has-dsp configuration of a pair's back-projection on `grid`: coherent at the carrier's
/// wavelength, or with `incoherent` the incoherent pass — the profiles' power |s|² with no
/// carrier phase (a wavelength far beyond any path, [`INCOHERENT_WAVELENGTH_M`]), i.e.
/// Σ_k |s_k(r_k(v))|², the expected |I(v)|² if the echoes in the range cells that focus at v
/// were incoherent with respect to v.
fn bp_config(sc: &Scenario, geo: &PairGeometry, grid: VoxelGrid, incoherent: bool) -> BpConfig {
    BpConfig {
        grid,
        wavelength_m: if incoherent {
            INCOHERENT_WAVELENGTH_M
        } else {
            sc.wavelength_m() as f32
        },
        r0_m: geo.r0_m as f32,
        dr_m: geo.dr_m as f32,
        interp: Interp::Linear,
        phase: PhaseEval::Poly,
    }
}

/// The detection test's reference window (voxels each side) and CFAR factors on a lattice of
/// `voxel_m` at per-voxel false-alarm probability `pfa`, from the pair's resolution cell at the
/// region centre.
fn cfar_window(geo: &PairGeometry, voxel_m: f32, pfa: f64) -> ([usize; 3], CfarFactors) {
    let radius = layer_window(geo.cell_m3.cbrt(), voxel_m);
    let voxels = radius.iter().map(|&w| 2 * w + 1).product();
    let looks = layer_looks_per_voxel(voxel_m, geo.cell_m3, geo.cell_vertical_m);
    (radius, CfarFactors::new(pfa, voxels, looks))
}

/// The coarse pass (module docs): the region on the `imaging.coarse_voxel_m` grid from snapshots
/// at transmit positions `tx` with receive elements `rx`; `frame(k, data, model)` fills the
/// `k`-th snapshot's profiles of the data and (with `clutter_ref`) of the terrain model, one row
/// of `geo.n_bins` per element. Detection against the terrain model at
/// `mask_false_alarm_probability` (with `detection = "peak"`: within `coarse_threshold_db` of
/// the coarse peak), only voxels whose neighbourhood touches the region. `tick` is called after
/// every snapshot; work and time go to `stats`.
#[allow(clippy::too_many_arguments)]
fn coarse_pass(
    sc: &Scenario,
    geo: &PairGeometry,
    range_kernel: &[f32],
    clutter_ref: bool,
    tx: &[Vec3],
    rx: &[Vec3],
    frame: &mut SnapshotFill<'_>,
    stats: &mut PairStats,
    tick: &mut dyn FnMut(),
) -> Result<CoarseDetections, ImagingError> {
    let im = &sc.imaging;
    let nb = geo.n_bins;
    let cv = im.coarse_voxel_m;
    let cframe = CoarseFrame::of(sc, cv);
    let cdims = cframe.dims;
    let cgrid = VoxelGrid {
        origin: cframe.origin,
        spacing: Vec3::splat(cv),
        dims: cdims,
    };
    let cbp = Backprojector::new(bp_config(sc, geo, cgrid, false))?;
    let cbp_inc = Backprojector::new(bp_config(sc, geo, cgrid, true))?;
    // Two images of the same snapshots: the full band, and (with the clutter test, when the
    // lattice is coarser than the pulse) the profiles low-passed to the lattice
    // (`super::coarse_range`). The mask is their union, each tested at half the stated
    // false-alarm probability (a union bound): the full band keeps its gain where a surface falls
    // near a lattice centre, the low-passed image holds a surface anywhere between them.
    let filtered = clutter_ref && range_kernel.len() > 1;
    let bands = if filtered { 2 } else { 1 };
    let voxels = cbp.voxels();
    let mut cimg = vec![Complex32::new(0.0, 0.0); bands * voxels];
    let mut cimg_m = vec![Complex32::new(0.0, 0.0); if clutter_ref { bands * voxels } else { 0 }];
    let mut cimg_i = vec![Complex32::new(0.0, 0.0); if clutter_ref { bands * voxels } else { 0 }];
    let rx_local: Vec<Vec3> = rx.iter().map(|&p| cframe.local(p)).collect();
    let mut prof = vec![Complex32::new(0.0, 0.0); rx.len() * nb];
    let mut mprof = vec![Complex32::new(0.0, 0.0); if clutter_ref { prof.len() } else { 0 }];
    let mut iprof = mprof.clone();
    let (mut fprof, mut fmprof) = if filtered {
        (prof.clone(), mprof.clone())
    } else {
        (Vec::new(), Vec::new())
    };
    let mask_pfa = im.mask_false_alarm_probability / bands as f64;
    let window = clutter_ref.then(|| cfar_window(geo, cv, mask_pfa));
    let mut scratch = Vec::new();
    // Only the coarse voxels the detection below can read: those whose neighbourhood touches
    // the region, and with the clutter test their CFAR windows. The grid is the region's
    // bounding box; a polygon region askew to the axes covers as little as half of it.
    let reach = window.as_ref().map_or([0, 0], |(r, _)| [r[0], r[1]]);
    let tile = voxels.div_ceil(rayon::current_num_threads() * 4).max(1);
    let runs = coarse_runs(sc, &cframe, reach, tile);
    {
        let (img_full, img_low) = cimg.split_at_mut(voxels);
        let (nm, ni) = (cimg_m.len().min(voxels), cimg_i.len().min(voxels));
        let (m_full, m_low) = cimg_m.split_at_mut(nm);
        let (i_full, i_low) = cimg_i.split_at_mut(ni);
        let mut accs = [
            coarse_tiles(&cbp, img_full, &runs, tile)?,
            coarse_tiles(&cbp, img_low, &runs, tile)?,
        ];
        let mut accs_m = [
            coarse_tiles(&cbp, m_full, &runs, tile)?,
            coarse_tiles(&cbp, m_low, &runs, tile)?,
        ];
        let mut accs_i = [
            coarse_tiles(&cbp_inc, i_full, &runs, tile)?,
            coarse_tiles(&cbp_inc, i_low, &runs, tile)?,
        ];
        for (k, &t_pos) in tx.iter().enumerate() {
            frame(k, &mut prof, &mut mprof)?;
            if filtered {
                fprof.copy_from_slice(&prof);
                fmprof.copy_from_slice(&mprof);
                filter_rows(&mut fprof, nb, range_kernel, &mut scratch);
                filter_rows(&mut fmprof, nb, range_kernel, &mut scratch);
            }
            let t = Instant::now();
            for band in 0..bands {
                let (p, m) = if band == 0 {
                    (&prof, &mprof)
                } else {
                    (&fprof, &fmprof)
                };
                if clutter_ref {
                    excess_power_of(p, m, &mut iprof);
                }
                let snap = Snapshot {
                    tx: cframe.local(t_pos),
                    rx: &rx_local,
                    profiles: &iprof,
                    profile_len: nb,
                };
                let push =
                    |bp: &Backprojector, accs: &mut [Vec<AccF32<'_>>], snap: &Snapshot<'_, _>| {
                        accs.par_iter_mut().try_for_each(|group| {
                            group
                                .iter_mut()
                                .try_for_each(|acc| bp.push_snapshot(acc, snap))
                        })
                    };
                push(&cbp_inc, &mut accs_i[band], &snap)?;
                push(
                    &cbp,
                    &mut accs_m[band],
                    &Snapshot {
                        profiles: m,
                        ..snap
                    },
                )?;
                push(
                    &cbp,
                    &mut accs[band],
                    &Snapshot {
                        profiles: p,
                        ..snap
                    },
                )?;
            }
            stats.bp_s += t.elapsed().as_secs_f64();
            tick();
        }
    }
    let imaged: usize = runs.iter().map(|r| r.1).sum();
    stats.coarse_voxels = imaged;
    stats.coarse_peak = cimg[..voxels]
        .iter()
        .map(|z| z.norm())
        .fold(0.0f32, f32::max);
    let passes = if clutter_ref { 3 * bands } else { 1 };
    stats.backprojections += (passes * imaged * rx.len() * tx.len()) as f64;
    let coarse_in_region = |i: usize| cframe.touches_region(sc, i, Vec3::splat(cv));
    let detected: Vec<bool> = if let Some((radius, alpha)) = window {
        let means: Vec<_> = (0..bands)
            .map(|b| {
                let pm: Vec<f32> = cimg_m[b * voxels..(b + 1) * voxels]
                    .iter()
                    .map(|z| z.norm_sqr())
                    .collect();
                local_mean(&pm, cdims, radius)
            })
            .collect();
        (0..voxels)
            .map(|i| {
                (0..bands).any(|b| {
                    let (c, j) = (&means[b], b * voxels + i);
                    let a = alpha.alpha(c.count[i]);
                    detected(cimg[j].norm_sqr(), c.mean[i], cimg_i[j].re, None, a, 0.0)
                }) && coarse_in_region(i)
            })
            .collect()
    } else {
        let cmax = cimg.iter().map(|z| z.norm()).fold(0.0f32, f32::max);
        let cthr = cmax * 10f32.powf(im.coarse_threshold_db / 20.0);
        cimg.iter()
            .map(|z| cmax > 0.0 && z.norm() >= cthr)
            .collect()
    };
    Ok(CoarseDetections {
        frame: cframe,
        detected,
    })
}

/// The items whose entry of `keep` is true, in order.
fn kept<T>(items: impl IntoIterator<Item = T>, keep: &[bool]) -> Vec<T> {
    items
        .into_iter()
        .zip(keep)
        .filter_map(|(x, &k)| k.then_some(x))
        .collect()
}

/// `f32` accumulators of every brick, on the back-projector `bp_of(brick)`, over consecutive
/// slices of `img` (none when `img` is empty: a pass that is not run).
fn brick_accs_f32<'a>(
    bricks: &'a [Brick],
    img: &'a mut [Complex32],
    bp_of: fn(&Brick) -> &Backprojector,
) -> Result<Vec<AccF32<'a>>, has_dsp::DspError> {
    let mut v = Vec::new();
    if img.is_empty() {
        return Ok(v);
    }
    let mut rest = img;
    for b in bricks {
        let (head, tail) = rest.split_at_mut(b.bp.voxels());
        v.push(AccF32::tile(bp_of(b), 0, head)?);
        rest = tail;
    }
    Ok(v)
}

/// Consecutive slices of `buf`, one per brick (none when `buf` is empty).
fn brick_slices<'a>(bricks: &[Brick], buf: &'a mut [f32]) -> Vec<&'a mut [f32]> {
    let mut v = Vec::new();
    if buf.is_empty() {
        return v;
    }
    let mut rest = buf;
    for b in bricks {
        let (head, tail) = rest.split_at_mut(b.bp.voxels());
        v.push(head);
        rest = tail;
    }
    v
}

/// Pushes one snapshot (transmit position `tx`, `profiles` of every receive element) into every
/// brick's accumulator, bricks in parallel.
fn push_bricks_f32<B: std::borrow::Borrow<Brick> + Sync>(
    accs: &mut [AccF32<'_>],
    bricks: &[B],
    bp_of: fn(&Brick) -> &Backprojector,
    tx: Vec3,
    profiles: &[Complex32],
    profile_len: usize,
) -> Result<(), has_dsp::DspError> {
    accs.par_iter_mut()
        .zip(bricks.par_iter())
        .try_for_each(|(acc, b)| {
            let b: &Brick = b.borrow();
            bp_of(b).push_snapshot(
                acc,
                &Snapshot {
                    tx: b.bp.grid().local(tx),
                    rx: &b.rx_local,
                    profiles,
                    profile_len,
                },
            )
        })
}

/// Pushes one snapshot through the factorised back-projection `fz` into every brick's
/// accumulator: the beam table is built once, over
/// the union of the bricks' windows (each computed in its brick's frame, as the push checks
/// it), its subarrays in parallel, and read by the bricks in parallel. `table` is reused across
/// snapshots; its size is checked against the memory available first.
#[allow(clippy::too_many_arguments)]
fn push_bricks_factorised(
    fz: &Factorised,
    bricks: &[Brick],
    bp_of: fn(&Brick) -> &Backprojector,
    accs: &mut [AccF32<'_>],
    tx: Vec3,
    profiles: &[Complex32],
    profile_len: usize,
    table: &mut Vec<Complex32>,
    pair: &str,
) -> Result<(), ImagingError> {
    let first = fz.lattice().first;
    let mut w: Option<BeamWindow> = None;
    for b in bricks {
        let bp = bp_of(b);
        let g = bp.grid();
        let (lo, hi) = grid_box(g);
        let wb = fz.window_for_box(bp, lo, hi, g.local(first), g.local(tx))?;
        w = Some(w.map_or(wb, |a| fz.union(&a, &wb)));
    }
    let Some(w) = w else {
        return Ok(());
    };
    let too_large = has_dsp::DspError::UnsupportedLength {
        what: "beam table",
        len: usize::MAX,
    };
    let len = fz.table_len(&w).ok_or(too_large)?;
    let per = fz.subarray_table_len(&w).ok_or(too_large)?;
    let bytes = len as f64 * std::mem::size_of::<Complex32>() as f64;
    if bytes > table.capacity() as f64 * 8.0 {
        if let Some((need_gib, have_gib)) = crate::memory::shortfall(bytes) {
            return Err(ImagingError::BeamTables {
                pair: pair.to_string(),
                need_gib,
                have_gib,
            });
        }
    }
    table.clear();
    table.resize(len, Complex32::new(0.0, 0.0));
    table.par_chunks_mut(per).enumerate().try_for_each_init(
        || vec![Complex32::new(0.0, 0.0); fz.scratch_len(&w)],
        |scratch, (k, part)| fz.build_part(&w, profiles, profile_len, k, part, scratch),
    )?;
    let table = &table[..];
    accs.par_iter_mut()
        .zip(bricks.par_iter())
        .try_for_each(|(acc, b)| {
            let bp = bp_of(b);
            let g = bp.grid();
            fz.push(bp, acc, &w, table, g.local(first), g.local(tx))
        })?;
    Ok(())
}

/// `out[i] = |p[i]|² − |m[i]|²` (as a real-valued complex profile, for the incoherent pass): the
/// power of the data's profile `p` beyond the terrain model's `m` ([`super::detection`]).
/// The excess power `|s|² − |m|²` of every sample of the frames, the data's `frames`
/// element-major and the terrain model's `m` frame-major, `[frames, elements, bins]` in `dims`:
/// packed two to a slot (real, imaginary) into the front of `m`'s own buffer, frame-major, and
/// the rest of that buffer released, so that the incoherent pass holds half of it.
fn pack_excess(frames: &[Complex32], mut m: Vec<Complex32>, dims: [usize; 3]) -> Vec<Complex32> {
    let [nt, ne, nb] = dims;
    for i in 0..m.len() {
        let (f, k) = (i / (ne * nb), i % (ne * nb));
        let (e, bin) = (k / nb, k % nb);
        let x = frames[(e * nt + f) * nb + bin].norm_sqr() - m[i].norm_sqr();
        // Slot i/2 ≤ i was read before (in-place, forward).
        let slot = &mut m[i / 2];
        if i % 2 == 0 {
            slot.re = x;
        } else {
            slot.im = x;
        }
    }
    m.truncate(m.len().div_ceil(2));
    m.shrink_to_fit();
    m
}

/// The bricks on which a deferred terrain model's image is formed: those that the CFAR window
/// (`radius` voxels each side on the region lattice, as [`local_mean_of`] reads it) of some
/// voxel passing the receive-coherence test `|I|² ≥ β·R` reaches. Only such voxels can be
/// detected, and their window means read the model nowhere else, so they are the same as over
/// every brick. `img` and `img_r` are the data image and `R` of the bricks, in brick order;
/// `n_bricks` the brick lattice of the region.
fn model_bricks(
    bricks: &[Brick],
    img: &[Complex32],
    img_r: &[f32],
    beta: f32,
    radius: [usize; 3],
    n_bricks: [usize; 3],
) -> Vec<bool> {
    let mut at = vec![usize::MAX; n_bricks.iter().product()];
    for (k, b) in bricks.iter().enumerate() {
        let [x, y, z] = b.start.map(|s| s / BRICK);
        at[x + n_bricks[0] * (y + n_bricks[1] * z)] = k;
    }
    // Per brick, the lattice box (inclusive) of its passing voxels.
    let boxes: Vec<Option<([usize; 3], [usize; 3])>> = bricks
        .par_iter()
        .map(|b| {
            let d = b.bp.grid().dims;
            let mut hull: Option<([usize; 3], [usize; 3])> = None;
            for i in 0..b.bp.voxels() {
                let j = b.offset + i;
                if img[j].norm_sqr() >= beta * img_r[j] {
                    let g = [
                        b.start[0] + i % d[0],
                        b.start[1] + (i / d[0]) % d[1],
                        b.start[2] + i / (d[0] * d[1]),
                    ];
                    hull = Some(match hull {
                        None => (g, g),
                        Some((lo, hi)) => (
                            [0, 1, 2].map(|a| lo[a].min(g[a])),
                            [0, 1, 2].map(|a| hi[a].max(g[a])),
                        ),
                    });
                }
            }
            hull
        })
        .collect();
    let mut chosen = vec![false; bricks.len()];
    for (lo, hi) in boxes.into_iter().flatten() {
        let first = [0, 1, 2].map(|a| lo[a].saturating_sub(radius[a]) / BRICK);
        let last = [0, 1, 2].map(|a| ((hi[a] + radius[a]) / BRICK).min(n_bricks[a] - 1));
        for z in first[2]..=last[2] {
            for y in first[1]..=last[1] {
                for x in first[0]..=last[0] {
                    let k = at[x + n_bricks[0] * (y + n_bricks[1] * z)];
                    if k != usize::MAX {
                        chosen[k] = true;
                    }
                }
            }
        }
    }
    chosen
}

fn excess_power_of(p: &[Complex32], m: &[Complex32], out: &mut [Complex32]) {
    out.par_iter_mut()
        .zip(p.par_iter().zip(m.par_iter()))
        .for_each(|(o, (z, w))| *o = Complex32::new(z.norm_sqr() - w.norm_sqr(), 0.0));
}

/// The coarse voxels to image as runs `(first, len)` of consecutive indices (x fastest), each at
/// most `tile` long, in increasing order: every voxel of an `(x, y)` column whose box, widened by
/// one coarse voxel and by `reach` voxels in x and y (a CFAR window's half-width), touches the
/// region. Every voxel the coarse detection tests, and every voxel its local means read, is in
/// a run; with a box region (no polygon) that is the whole grid.
fn coarse_runs(
    sc: &Scenario,
    frame: &CoarseFrame,
    reach: [usize; 2],
    tile: usize,
) -> Vec<(usize, usize)> {
    let [cx, cy, cz] = frame.dims;
    let cv = frame.cv;
    // The columns' boxes reach over the whole height (the region is a prism in z).
    let half = Vec3::new(
        (reach[0] + 1) as f32 * cv,
        (reach[1] + 1) as f32 * cv,
        cz as f32 * cv,
    );
    let column: Vec<bool> = (0..cx * cy)
        .map(|j| frame.touches_region(sc, j, half))
        .collect();
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for i in (0..cx * cy * cz).filter(|i| column[i % (cx * cy)]) {
        match runs.last_mut() {
            Some((first, len)) if *first + *len == i && *len < tile.max(1) => *len += 1,
            _ => runs.push((i, 1)),
        }
    }
    runs
}

/// Accumulators over the `runs` ([`coarse_runs`]) of `img` on the coarse grid `bp`, in groups of
/// consecutive runs of at most `tile` voxels in all (one task each: a polygon's rows are short),
/// none when `img` is empty (a pass that is not run); voxels outside the runs stay zero.
fn coarse_tiles<'a>(
    bp: &'a Backprojector,
    img: &'a mut [Complex32],
    runs: &[(usize, usize)],
    tile: usize,
) -> Result<Vec<Vec<AccF32<'a>>>, has_dsp::DspError> {
    let mut groups: Vec<(usize, Vec<AccF32<'a>>)> = Vec::new();
    if img.is_empty() {
        return Ok(Vec::new());
    }
    let (mut rest, mut at) = (img, 0);
    for &(first, len) in runs {
        let (_, tail) = rest.split_at_mut(first - at);
        let (head, tail) = tail.split_at_mut(len);
        let acc = AccF32::tile(bp, first, head)?;
        match groups.last_mut() {
            Some((n, g)) if *n + len <= tile => {
                *n += len;
                g.push(acc);
            }
            _ => groups.push((len, vec![acc])),
        }
        (rest, at) = (tail, first + len);
    }
    Ok(groups.into_iter().map(|(_, g)| g).collect())
}

fn dims_of(lo: Vec3, hi: Vec3, v: f32) -> [usize; 3] {
    let d = ((hi - lo) / v).floor() + Vec3::ONE;
    [d.x as usize, d.y as usize, d.z as usize]
}

/// The ground bands of a pair's ends (`imaging.nadir_guard`, [`NadirBand`]): the aperture's
/// first, middle and last transmit positions against the panel's centre, and the panel's centre
/// against the aperture's middle, each over the terrain point straight below it. None without a
/// known terrain.
fn nadir_bands(sc: &Scenario, world: &World, geo: &PairGeometry) -> Vec<NadirBand> {
    if !world.is_ground.iter().any(|&g| g) {
        return Vec::new();
    }
    let guard = main_lobe_guard_m(sc);
    let (tx_c, rx_c) = (geo.aperture.centre(), geo.array.centre);
    [
        (geo.aperture.start, rx_c),
        (tx_c, rx_c),
        (geo.aperture.end, rx_c),
        (rx_c, tx_c),
    ]
    .into_iter()
    .filter_map(|(end, other)| NadirBand::new(end, other, world.terrain.below(end)?, guard))
    .collect()
}

/// The range profile's main-lobe half-width in metres of bistatic path
/// ([`direct_path_guard_m`]).
fn main_lobe_guard_m(sc: &Scenario) -> f32 {
    let cells = sc
        .window()
        .ok()
        .and_then(|w| w.main_lobe_half_width_cells())
        .unwrap_or(1.0);
    direct_path_guard_m(cells, sc.radar.bandwidth_mhz * 1e6)
}

/// The detected voxels of the fine image, optionally only those that are local maxima of `|I|`
/// along the bistatic range gradient (the direction the pair resolves best) and not weaker than
/// anything at their grating-lobe aliases (`imaging.alias_test`), outside the pair's direct-path
/// zone (`imaging.direct_path_guard`) and its ends' ground bands (`imaging.nadir_guard`).
fn extract_points(
    sc: &Scenario,
    region: &Scenario,
    (bricks, img): (&[Brick], &[Complex32]),
    aliases: &AliasImage,
    detected: &[bool],
    geo: &PairGeometry,
    nadir_bands: &[NadirBand],
) -> Extracted {
    let (local_max, alias_test) = (sc.imaging.local_max, sc.imaging.alias_test);
    let lambda = sc.wavelength_m() as f32;
    let bandwidth_hz = (sc.radar.bandwidth_mhz * 1e6) as f32;
    // Lookup of |I| at any world position imaged (nearest voxel; None outside active bricks).
    let v = bricks.first().map(|b| b.bp.grid().spacing.x).unwrap_or(1.0);
    let mut index = std::collections::HashMap::new();
    for (bi, b) in bricks.iter().enumerate() {
        let o = b.bp.grid().origin;
        index.insert(key(o, v), bi);
    }
    let lookup = |p: Vec3| -> Option<f32> {
        // Find the brick by its origin: bricks tile the grid at multiples of BRICK·v from the
        // first brick's grid, so round down to the brick lattice relative to any brick origin.
        let base = bricks.first()?.bp.grid().origin;
        let rel = ((p - base) / v).round();
        let bs = BRICK as f32;
        let bo = Vec3::new(
            (rel.x / bs).floor() * bs,
            (rel.y / bs).floor() * bs,
            (rel.z / bs).floor() * bs,
        );
        let origin = base + bo * v;
        let Some(&bi) = index.get(&key(origin, v)) else {
            return aliases.at(p);
        };
        let b = &bricks[bi];
        let local = rel - bo;
        let d = b.bp.grid().dims;
        let (x, y, z) = (local.x as usize, local.y as usize, local.z as usize);
        if x >= d[0] || y >= d[1] || z >= d[2] {
            return None;
        }
        Some(img[b.offset + x + d[0] * (y + d[1] * z)].norm())
    };
    let tx_c = geo.aperture.centre();
    let rx_c = geo.array.centre;
    // The direct-path zone (`detection::direct_path_guard_m`), from every transmit position's
    // baseline: the track's ends and centre bound it.
    let guard = if sc.imaging.direct_path_guard {
        main_lobe_guard_m(sc)
    } else {
        f32::NEG_INFINITY
    };
    let in_direct_zone = |p: Vec3| {
        [geo.aperture.start, tx_c, geo.aperture.end]
            .iter()
            .any(|&t| has_dsp::geometry::bistatic_range(p, t, rx_c) - t.distance(rx_c) < guard)
    };
    let (mut points, mut intensity) = (Vec::new(), Vec::new());
    let (mut outside, mut outside_intensity) = (Vec::new(), Vec::new());
    for b in bricks {
        let g = b.bp.grid();
        for i in 0..b.bp.voxels() {
            let a = img[b.offset + i].norm();
            if !detected[b.offset + i] {
                continue;
            }
            let p = g.voxel_world(i).unwrap_or(g.origin);
            if in_direct_zone(p)
                || !in_front_of_panel(&geo.array, p)
                || nadir_bands.iter().any(|b| b.covers(p))
            {
                continue;
            }
            if local_max {
                let grad = ((p - tx_c).normalize_or_zero() + (p - rx_c).normalize_or_zero())
                    .normalize_or_zero();
                let step = grad * v;
                let before = lookup(p - step).unwrap_or(0.0);
                let after = lookup(p + step).unwrap_or(0.0);
                if a < before || a < after {
                    continue;
                }
            }
            if alias_test {
                let boxes = alias_boxes(&geo.array, &geo.aperture, p, lambda, bandwidth_hz);
                if !boxes.is_empty() {
                    let (r, xv, xh, xz) =
                        pair_resolution_m(p, &geo.array, &geo.aperture, lambda, bandwidth_hz);
                    let own = cell_peak(p, alias_window_m(r, xv, xh, xz), v, lookup)
                        .map_or(a, |m| m.max(a));
                    if alias_is_stronger(&boxes, own, v, lookup) {
                        continue;
                    }
                }
            }
            if region.in_region(p) {
                points.push(p);
                intensity.push(a);
            } else {
                outside.push(p);
                outside_intensity.push(a);
            }
        }
    }
    // Relative to the strongest detection in the region (fusion weights).
    let peak = intensity.iter().copied().fold(0.0f32, f32::max);
    if peak > 0.0 {
        intensity.iter_mut().for_each(|i| *i /= peak);
        outside_intensity.iter_mut().for_each(|i| *i /= peak);
    }
    Extracted {
        points,
        intensity,
        outside,
        outside_intensity,
    }
}

/// A pair's detections ([`extract_points`]): those in the region, and those of the imaged
/// lattice outside it, which only serve as the sources of sidelobes
/// ([`super::sidelobes`]). Intensities `|I|` relative to the strongest in the region.
struct Extracted {
    points: Vec<Vec3>,
    intensity: Vec<f32>,
    outside: Vec<Vec3>,
    outside_intensity: Vec<f32>,
}

/// A pair's frames as the alias image reads them: element-major profiles (`bins` per element
/// and frame), with the transmit positions and receive elements they were taken at.
struct AliasFrames<'a> {
    frames: &'a [Complex32],
    tx: &'a [Vec3],
    rx: &'a [Vec3],
    bins: usize,
}

/// The pair's image where its detections' grating-lobe aliases fall outside the lattice it
/// imaged (`imaging.alias_test`).
///
/// **Why.** The alias test ([`alias_is_stronger`]) keeps the better focused of a voxel and its
/// aliases: the panel gives both the same phases, and only the Fresnel zone and the track
/// defocus the lobe. A neighbour outside the region has its aliases inside it; there, with
/// nothing imaged at the neighbour, the test had nothing to compare against and the lobe stood
/// as a ghost facade in the street (a grating lobe of a 1.04 λ panel lies 0.96 in direction sine
/// from its source: 50–75° away, far beyond any guard band). So the pair is also imaged, with the
/// same frames and back-projection, on the bricks of the same lattice that the aliases' test
/// boxes touch outside the lattice's own bricks (those the coarse mask judged are left to it).
///
/// **Bound.** At most as many voxels as the region's lattice, 8 B each: the fine pass's worst
/// case already counts that much per voxel many times over, so the memory estimate holds. The
/// bricks asked for by the most detections go first; the rest decide nothing, as before.
#[derive(Default)]
struct AliasImage {
    /// Brick index (multiples of `BRICK` voxels from `lo`) → position in `bricks`.
    index: std::collections::HashMap<[i64; 3], usize>,
    bricks: Vec<Brick>,
    img: Vec<Complex32>,
    lo: Vec3,
    voxel_m: f32,
}

impl AliasImage {
    fn new(
        sc: &Scenario,
        geo: &PairGeometry,
        bricks: &[Brick],
        detected: &[bool],
        frames: AliasFrames<'_>,
        max_voxels: usize,
    ) -> Result<AliasImage, ImagingError> {
        let (lo, hi) = sc.region();
        let v = sc.imaging.voxel_m;
        let (lambda, bandwidth_hz) = (
            sc.wavelength_m() as f32,
            (sc.radar.bandwidth_mhz * 1e6) as f32,
        );
        let side = BRICK as f32 * v;
        let fdims = dims_of(lo, hi, v);
        let n_bricks = fdims.map(|d| d.div_ceil(BRICK) as i64);
        // Bricks of the lattice's own extent are the coarse mask's to judge.
        let judged = |k: [i64; 3]| (0..3).all(|a| k[a] >= 0 && k[a] < n_bricks[a]);
        let mut asked = std::collections::BTreeMap::<[i64; 3], u64>::new();
        for b in bricks {
            let g = b.bp.grid();
            for i in 0..b.bp.voxels() {
                if !detected[b.offset + i] {
                    continue;
                }
                let p = g.voxel_world(i).unwrap_or(g.origin);
                if !in_front_of_panel(&geo.array, p) {
                    continue;
                }
                for (q, half) in alias_boxes(&geo.array, &geo.aperture, p, lambda, bandwidth_hz) {
                    // The box `alias_is_stronger` reads: whole voxels, at least one each way.
                    let reach = half.map(|h| (h / v).round().max(1.0) * v);
                    let k0 = ((q - reach - lo) / side).floor();
                    let k1 = ((q + reach - lo) / side).floor();
                    if !(k0.is_finite() && k1.is_finite()) {
                        continue;
                    }
                    for kz in k0.z as i64..=k1.z as i64 {
                        for ky in k0.y as i64..=k1.y as i64 {
                            for kx in k0.x as i64..=k1.x as i64 {
                                let k = [kx, ky, kz];
                                if !judged(k) {
                                    *asked.entry(k).or_default() += 1;
                                }
                            }
                        }
                    }
                }
            }
        }
        let mut order: Vec<([i64; 3], u64)> = asked.into_iter().collect();
        order.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
        let per_brick = BRICK * BRICK * BRICK;
        order.truncate(max_voxels / per_brick);
        order.sort_by_key(|&(k, _)| k);
        let mut out = AliasImage {
            lo,
            voxel_m: v,
            ..AliasImage::default()
        };
        for (n, &(k, _)) in order.iter().enumerate() {
            let origin = lo + Vec3::new(k[0] as f32, k[1] as f32, k[2] as f32) * side;
            let grid = VoxelGrid {
                origin,
                spacing: Vec3::splat(v),
                dims: [BRICK; 3],
            };
            out.bricks.push(Brick {
                rx_local: frames.rx.iter().map(|&p| grid.local(p)).collect(),
                tx_local: Vec::new(),
                bp: Backprojector::new(bp_config(sc, geo, grid, false))?,
                bp_inc: Backprojector::new(bp_config(sc, geo, grid, true))?,
                offset: n * per_brick,
                start: [0; 3],
            });
            out.index.insert(k, n);
        }
        out.img = vec![Complex32::new(0.0, 0.0); out.bricks.len() * per_brick];
        if out.bricks.is_empty() {
            return Ok(out);
        }
        let (nt, nb) = (frames.tx.len(), frames.bins);
        let mut prof = vec![Complex32::new(0.0, 0.0); frames.rx.len() * nb];
        let mut accs = brick_accs_f32(&out.bricks, &mut out.img, |b| &b.bp)?;
        for (f, &tx) in frames.tx.iter().enumerate() {
            for (e, row) in prof.chunks_exact_mut(nb).enumerate() {
                row.copy_from_slice(&frames.frames[(e * nt + f) * nb..(e * nt + f + 1) * nb]);
            }
            push_bricks_f32(&mut accs, &out.bricks, |b| &b.bp, tx, &prof, nb)?;
        }
        drop(accs);
        Ok(out)
    }

    /// `|I|` at the nearest voxel of an alias brick holding `p`; `None` elsewhere.
    fn at(&self, p: Vec3) -> Option<f32> {
        if self.bricks.is_empty() {
            return None;
        }
        let rel = ((p - self.lo) / self.voxel_m).round();
        if !rel.is_finite() {
            return None;
        }
        let b = BRICK as i64;
        let r = [rel.x as i64, rel.y as i64, rel.z as i64];
        let k = r.map(|x| x.div_euclid(b));
        let l = r.map(|x| x.rem_euclid(b) as usize);
        let n = *self.index.get(&k)?;
        let i = n * BRICK * BRICK * BRICK + l[0] + BRICK * (l[1] + BRICK * l[2]);
        self.img.get(i).map(|z| z.norm())
    }
}

/// The grating-lobe aliases of voxel `p` for the pair's panel and the aperture's centre
/// ([`PlanarArray::grating_aliases`]), each with the half-extents of its test box
/// ([`alias_window_m`]): the pair's resolution cell *at the alias*, not at the voxel. The echo
/// that lends the voxel its lobe sits at the alias, and what the panel cannot separate from the
/// exact alias is a cell of direction sines (`λ/W` across, `λ/H` up), which spans the alias's own
/// distance times that — larger than at the voxel when the alias is the farther. Measured on
/// the held-out office_sparse (quick): a BS3-V5 lobe 23 m from any building at the region's edge,
/// 36 m from the panel, had its alias 78 m away at the foot of the gable's wall, at z = −1.2 m;
/// the voxel's cell (±1.1 m vertical) lay wholly below the region's floor (0.5 m), the alias's
/// (±2.3 m) reaches the wall's foot above it.
pub fn alias_boxes(
    array: &PlanarArray,
    aperture: &VirtualAperture,
    p: Vec3,
    wavelength_m: f32,
    bandwidth_hz: f32,
) -> Vec<(Vec3, Vec3)> {
    array
        .grating_aliases(wavelength_m, p, aperture.centre())
        .into_iter()
        .map(|q| {
            let (r, xv, xh, xz) = pair_resolution_m(q, array, aperture, wavelength_m, bandwidth_hz);
            (q, alias_window_m(r, xv, xh, xz))
        })
        .collect()
}

/// Whether `p` lies in the half-space the panel faces (`(p − centre)·boresight > 0`), the only
/// one a panel with a backplane receives from (module docs).
pub fn in_front_of_panel(array: &PlanarArray, p: Vec3) -> bool {
    (p - array.centre).dot(array.boresight()) > 0.0
}

fn key(p: Vec3, v: f32) -> [i64; 3] {
    let q = (p / v).round();
    [q.x as i64, q.y as i64, q.z as i64]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// BS1 of the bundled factory: at (−45, −40, 20), facing 41.6° (toward the hall).
    fn bs1() -> PlanarArray {
        PlanarArray {
            centre: Vec3::new(-45.0, -40.0, 20.0),
            boresight_az_rad: 41.6f32.to_radians(),
            rows: 32,
            cols: 32,
            width_m: 1.0,
            height_m: 0.5,
        }
    }

    #[test]
    fn a_grating_lobe_is_tested_over_the_resolution_cell_where_its_echo_is() {
        // The held-out office_sparse's BS3 and V5 (quick): a lobe at the region's edge, 36 m from
        // the panel, whose echo is the foot of a wall 78 m away (module docs of `alias_boxes`).
        let array = PlanarArray {
            centre: Vec3::new(22.54, 55.03, 20.0),
            boresight_az_rad: (-112.3f32).to_radians(),
            rows: 32,
            cols: 32,
            width_m: 1.0,
            height_m: 0.5,
        };
        let aperture = VirtualAperture {
            start: Vec3::new(-13.93, 11.96, 1.5),
            end: Vec3::new(-16.75, 10.93, 1.5),
            positions: 64,
        };
        let (lambda, bw) = (has_dsp::geometry::wavelength_m(10e9) as f32, 400e6);
        let p = Vec3::new(39.5, 25.0, 10.0);
        let boxes = alias_boxes(&array, &aperture, p, lambda, bw);
        let (q, half) = *boxes
            .iter()
            .find(|(q, _)| q.distance(Vec3::new(-18.9, -5.0, -1.2)) < 1.0)
            .expect("the alias at the wall's foot");
        // The box at the alias reaches above the region's floor (0.5 m) to the wall's foot; the
        // voxel's own cell, half as tall, would not.
        assert!(q.z + half.z > 0.5, "{q} ± {half}");
        let (r, xv, xh, xz) = pair_resolution_m(p, &array, &aperture, lambda, bw);
        assert!(q.z + alias_window_m(r, xv, xh, xz).z < 0.5);
        // Each box grows with its alias's distance from the panel.
        assert!(half.z > 1.8 * alias_window_m(r, xv, xh, xz).z);
    }

    #[test]
    fn the_model_is_formed_on_every_brick_a_coherent_voxels_window_reaches_and_no_other() {
        let v = 0.25f32;
        let brick = |start: [usize; 3], n: usize| {
            let grid = VoxelGrid {
                origin: Vec3::new(start[0] as f32, start[1] as f32, start[2] as f32) * v,
                spacing: Vec3::splat(v),
                dims: [BRICK; 3],
            };
            let cfg = BpConfig {
                grid,
                wavelength_m: 0.03,
                r0_m: 0.0,
                dr_m: 0.375,
                interp: Interp::Linear,
                phase: PhaseEval::Poly,
            };
            Brick {
                bp: Backprojector::new(cfg).expect("grid"),
                bp_inc: Backprojector::new(cfg).expect("grid"),
                rx_local: Vec::new(),
                tx_local: Vec::new(),
                offset: n * BRICK * BRICK * BRICK,
                start,
            }
        };
        // Four bricks along x, one beside the first along y; brick lattice 4 × 2 × 1.
        let starts = [[0, 0, 0], [8, 0, 0], [16, 0, 0], [24, 0, 0], [0, 8, 0]];
        let bricks: Vec<Brick> = starts
            .iter()
            .enumerate()
            .map(|(n, &s)| brick(s, n))
            .collect();
        let voxels = starts.len() * BRICK * BRICK * BRICK;
        let mut img = vec![Complex32::new(0.1, 0.0); voxels];
        let img_r = vec![1.0f32; voxels];
        let (beta, n_bricks) = (2.0f32, [4, 2, 1]);
        // Nothing coherent: no model anywhere.
        let none = model_bricks(&bricks, &img, &img_r, beta, [2, 2, 0], n_bricks);
        assert_eq!(none, vec![false; 5]);
        // One coherent voxel at x = 7, y = 0 of the first brick: its window (x 5..9, y 0..2)
        // reaches the second brick, not the third nor the one beside along y.
        img[7] = Complex32::new(1.5, 0.0);
        let one = model_bricks(&bricks, &img, &img_r, beta, [2, 2, 0], n_bricks);
        assert_eq!(one, vec![true, true, false, false, false]);
        // A wider window along y reaches the brick beside (y 8..): x 7 lies in its 0..8.
        let wide = model_bricks(&bricks, &img, &img_r, beta, [2, 8, 0], n_bricks);
        assert_eq!(wide, vec![true, true, false, false, true]);
        // Just below the factor: not coherent.
        img[7] = Complex32::new(1.41, 0.0);
        let below = model_bricks(&bricks, &img, &img_r, beta, [2, 8, 0], n_bricks);
        assert_eq!(below, vec![false; 5]);
    }

    #[test]
    fn the_coarse_pass_images_every_voxel_its_detection_reads_and_not_the_rest_of_the_box() {
        let mut sc =
            Scenario::from_toml_str(include_str!("../../../fixtures/factory.toml")).unwrap();
        let (cv, reach) = (1.5f32, [2usize, 1]);
        let cover = |sc: &Scenario, tile: usize| {
            let frame = CoarseFrame::of(sc, cv);
            let runs = coarse_runs(sc, &frame, reach, tile);
            let mut imaged = vec![false; frame.dims.iter().product()];
            let mut end = 0;
            for &(first, len) in &runs {
                assert!(
                    first >= end && (1..=tile).contains(&len),
                    "{first} {len} {end}"
                );
                imaged[first..first + len].fill(true);
                end = first + len;
            }
            (frame, imaged)
        };
        // A box region: the whole grid, in tiles, on the world axes from the region's corner.
        let (frame, imaged) = cover(&sc, 1000);
        assert!(imaged.iter().all(|&b| b));
        assert_eq!((frame.sin, frame.origin), (0.0, sc.region().0));
        // A diamond inside the same box (a turned square): every voxel the detection tests (its
        // neighbourhood touches the region) and every voxel of its CFAR window is imaged.
        let (lo, hi) = sc.region();
        let c = (lo + hi) * 0.5;
        let a = 0.5 * (hi.x - lo.x).min(hi.y - lo.y);
        sc.imaging.region_polygon = Some(vec![
            [c.x - a, c.y],
            [c.x, c.y - a],
            [c.x + a, c.y],
            [c.x, c.y + a],
        ]);
        let (frame, imaged) = cover(&sc, 7);
        let [cx, cy, cz] = frame.dims;
        let at = |x: usize, y: usize, z: usize| x + cx * (y + cy * z);
        for z in 0..cz {
            for y in 0..cy {
                for x in 0..cx {
                    if !frame.touches_region(&sc, at(x, y, z), Vec3::splat(cv)) {
                        continue;
                    }
                    for dy in -(reach[1] as i64)..=reach[1] as i64 {
                        for dx in -(reach[0] as i64)..=reach[0] as i64 {
                            let (u, v) = (x as i64 + dx, y as i64 + dy);
                            if (0..cx as i64).contains(&u) && (0..cy as i64).contains(&v) {
                                assert!(imaged[at(u as usize, v as usize, z)], "{x} {y} {z}");
                            }
                        }
                    }
                }
            }
        }
        // The grid is turned 45° to the square's sides and is the square's size, half of the
        // region's box (which would hold 2a × 2a).
        assert!(
            (frame.sin.abs() - 0.5f32.sqrt()).abs() < 1e-4,
            "{}",
            frame.sin
        );
        let side = a * 2f32.sqrt();
        for d in &frame.dims[..2] {
            assert!((*d as f32 - 1.0) * cv <= side + 1e-3 && *d as f32 * cv > side - 1e-3);
        }
        // Voxel positions map back to their own index.
        for i in (0..imaged.len()).step_by(97) {
            assert_eq!(frame.index_of(frame.world(i)), Some(i));
        }
    }

    #[test]
    fn a_panel_keeps_what_lies_in_front_of_it_and_not_its_mirror_behind() {
        let a = bs1();
        let n = a.boresight();
        // The hall and the yard between the panel and the hall are in front.
        assert!(in_front_of_panel(&a, Vec3::new(0.0, 0.0, 8.0)));
        assert!(in_front_of_panel(&a, Vec3::new(-36.0, -42.0, 0.0)));
        // A point's mirror image through the array plane (the direction a planar array cannot
        // tell from it) is behind: the alias the widened factory imaged at (−44.5, −45, 9).
        for p in [Vec3::new(-36.0, -42.0, 0.0), Vec3::new(-40.1, -41.1, 9.0)] {
            let mirror = p - 2.0 * (p - a.centre).dot(n) * n;
            assert!(!in_front_of_panel(&a, mirror), "{p} -> {mirror}");
        }
        assert!(!in_front_of_panel(&a, Vec3::new(-44.5, -45.0, 9.0)));
        // The array plane itself is not in front.
        assert!(!in_front_of_panel(&a, a.centre + Vec3::Z));
    }
}
