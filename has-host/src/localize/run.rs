//! A whole localization run: the world (true clutter, target, twin prediction), frame synthesis,
//! the processing passes of both modes on the same frames, and the metrics.

use std::time::Instant;

use glam::{Vec2, Vec3};
use has_dsp::eca::EcaVariant;
use num_complex::Complex32 as C32;
use rayon::prelude::*;
use serde::Serialize;

use super::chain::{
    range_segment_templates, subtract_templates, Chain, ClutterMap, Detection, SlowTimeEca,
};
use super::{LocalizeError, Suppression};
use crate::echo::{qpsk_symbols, visible_for, EchoConfig, EchoSynth, ScattererSet};
use crate::material::Material;
use crate::metrics::CloudComparison;
use crate::scenario::LocalizeSpec;
use crate::scene::{Object, Scene};

/// Results of one frame.
#[derive(Clone, Debug, Serialize)]
pub struct FrameResult {
    /// Frame index.
    pub index: usize,
    /// Target base centre at the CPI centre, metres.
    pub centre: Vec3,
    /// Radial speed of the target's centre (positive receding), m/s.
    pub radial_speed_mps: f32,
    /// Its Doppler, Hz.
    pub doppler_hz: f32,
    /// The target's true scattering points (facing the base station) at the CPI centre.
    pub truth: Vec<Vec3>,
    /// Cosine of each truth point's angle between its normal and the direction to the base
    /// station (the monostatic Lambertian echo power goes with its square).
    pub truth_cos: Vec<f32>,
    /// Detections of each pass (same order as [`LocalizeResult::passes`]).
    pub detections: Vec<Vec<Detection>>,
    /// Cancellation depth of each pass, dB (0 for the pass without suppression).
    pub cancellation_db: Vec<f64>,
    /// Depth of the environment template subtraction alone (element domain), dB.
    pub template_db: f64,
    /// Fraction of (range, beam) cells the environment gate notches.
    pub gate_fraction: f64,
    /// Range × Doppler power at the beam towards the target (`[b][d]`, Doppler in FFT order) of
    /// each pass.
    #[serde(skip)]
    pub range_doppler: Vec<Vec<f32>>,
}

/// Aggregate of one mode (pass) over all frames.
#[derive(Clone, Debug, Serialize)]
pub struct ModeSummary {
    /// Pass label (`"ECA"`, `"ECA-B"`, `"env"`, ...).
    pub label: String,
    /// √CD between the on-target detections and the truth, metres (`None`: no detection).
    pub sqrt_chamfer_m: Option<f64>,
    /// √CD with every detection of the searched volume (false alarms included), metres.
    #[serde(rename = "sqrt_chamfer_all_detections_m")]
    pub sqrt_chamfer_all_m: Option<f64>,
    /// RMS distance from the on-target detections to the truth (accuracy), metres.
    pub accuracy_rms_m: Option<f64>,
    /// RMS distance from the truth to the on-target detections (completeness), metres.
    pub completeness_rms_m: Option<f64>,
    /// Completeness on the truth points seen within 60° of their normal (cos ≥ 0.5, the part
    /// returning at least a quarter of the normal-incidence power), metres.
    pub completeness_strong_rms_m: Option<f64>,
    /// Detections on the target (within the gate).
    pub detections: usize,
    /// Detections outside the gate.
    pub false_alarms: usize,
    /// Frames with at least one on-target detection.
    pub frames_detected: usize,
    /// Mean cancellation depth over frames, dB.
    pub cancellation_db: f64,
}

/// A whole run.
#[derive(Clone, Debug, Serialize)]
pub struct LocalizeResult {
    /// Pass labels: `none`, the ECA variants, `env`.
    pub passes: Vec<String>,
    /// Index of the pass `env`.
    pub env_pass: usize,
    /// Indices of the ECA passes.
    pub eca_passes: Vec<usize>,
    /// Per frame.
    pub frames: Vec<FrameResult>,
    /// Per pass.
    pub summaries: Vec<ModeSummary>,
    /// The ECA pass with the smallest √CD (the reported baseline).
    pub eca_best: usize,
    /// Visible true clutter scatterers.
    pub clutter_scatterers: usize,
    /// Visible twin scatterers (prediction).
    pub twin_scatterers: usize,
    /// Target scatterers facing the base station, mean per frame.
    pub target_scatterers: f64,
    /// Range bins, beams, Doppler bins of the processed cube.
    pub cube: [usize; 3],
    /// Processed range window, metres.
    pub range_window_m: [f64; 2],
    /// Noise power per Doppler cell (linear, chain units).
    pub noise_cell: f64,
    /// Timings, seconds: setup, synthesis, processing.
    pub timings_s: Timings,
    /// Beam index towards the target per frame (the range–Doppler maps).
    pub rd_beam: Vec<usize>,
}

/// Wall-clock split.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Timings {
    /// World, twin prediction, chain setup.
    pub setup: f64,
    /// Echo synthesis and range compression.
    pub synthesis: f64,
    /// Suppression, beamforming, Doppler, CFAR.
    pub processing: f64,
}

/// The target's true surface gate: is `p` within `gate` of the cylinder standing at `base`?
fn on_target(spec: &LocalizeSpec, base: Vec3, p: Vec3, gate: f32) -> bool {
    let r = Vec2::new(p.x - base.x, p.y - base.y).length();
    r <= spec.target_radius_m + gate
        && p.z >= base.z - gate
        && p.z <= base.z + spec.target_height_m + gate
}

/// Scatterers of `scene` for clutter: non-ground objects at `building_density`, ground objects
/// at `ground_density`, both within `range` (horizontal) of `bs` and in front of the panel.
fn clutter_set(
    scene: &Scene,
    is_ground: &[bool],
    building_density: f64,
    ground_density: f64,
    seed: u64,
    (bs, boresight, range): (Vec3, Vec3, f32),
) -> Result<ScattererSet, LocalizeError> {
    let near = move |p: Vec3| {
        Vec2::new(p.x - bs.x, p.y - bs.y).length() <= range && (p - bs).dot(boresight) > 0.0
    };
    let mut set = ScattererSet::sample_where(scene, building_density, seed, |o, p| {
        !is_ground[o as usize] && near(p)
    })?;
    let ground =
        ScattererSet::sample_where(scene, ground_density, seed.wrapping_add(1), |o, p| {
            is_ground[o as usize] && near(p)
        })?;
    set.points.extend(ground.points);
    Ok(set)
}

/// Runs the experiment. `scene` is the true environment (its objects named in
/// `spec.ground_objects` are ground); `twin` the reconstructed mesh's objects (the prior, to which
/// the scene's `spec.known_objects` are added as they are).
/// `progress(done, total)` is called after each frame.
///
/// # Errors
/// [`LocalizeError`] naming the failing stage or field.
pub fn run_localize(
    spec: &LocalizeSpec,
    scene: &Scene,
    twin: Vec<Object>,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<LocalizeResult, LocalizeError> {
    spec.validate()?;
    let t0 = Instant::now();
    let symbol = qpsk_symbols(spec.subcarriers, spec.seed);
    let chain = Chain::new(spec, symbol.clone())?;
    let array = chain.array.clone();
    let tx = array.centre;
    let elements = array.elements(1);
    let e_n = elements.len();
    let nb = chain.nb;

    // True static clutter, compressed profiles [e][b] (model (a), see module docs).
    let names: Vec<&str> = scene.objects.iter().map(|o| o.name.as_str()).collect();
    for (field, list) in [
        ("ground_objects", &spec.ground_objects),
        ("known_objects", &spec.known_objects),
    ] {
        if let Some(g) = list.iter().find(|g| !names.contains(&g.as_str())) {
            return Err(LocalizeError::UnknownObject {
                field,
                name: g.clone(),
            });
        }
    }
    let is_ground: Vec<bool> = scene
        .objects
        .iter()
        .map(|o| spec.ground_objects.contains(&o.name))
        .collect();
    let mut pcfg = EchoConfig::for_compressor(spec.fc_hz(), &chain.rc)?;
    pcfg.r0_m = chain.bin0 as f64 * chain.bin_m;
    pcfg.n_bins = nb;
    pcfg.kernel_half_width_cells = 8;
    let psynth = EchoSynth::new(pcfg)?;
    let clutter = clutter_set(
        scene,
        &is_ground,
        spec.building_density_per_m2,
        spec.ground_density_per_m2,
        spec.seed.wrapping_add(1),
        (tx, array.boresight(), spec.clutter_range_m),
    )?;
    let clutter_vis = visible_for(&clutter, scene, tx, tx)?;
    let mut clutter_profiles = vec![C32::new(0.0, 0.0); e_n * nb];
    psynth.synth_profiles(&clutter, &clutter_vis, tx, &elements, &mut clutter_profiles)?;

    // The twin's prediction: its mesh plus a flat ground at the surveyed height.
    let reach = spec.clutter_range_m;
    let material = twin
        .first()
        .map(|o| o.material)
        .unwrap_or(Material::Concrete);
    let mut twin_objects = twin;
    // Known objects the twin does not already hold (an oracle twin holds them all).
    let known: Vec<Object> = scene
        .objects
        .iter()
        .filter(|o| spec.known_objects.contains(&o.name))
        .filter(|o| !twin_objects.iter().any(|t| t.name == o.name))
        .cloned()
        .collect();
    twin_objects.extend(known);
    let twin_ground_index = twin_objects.len();
    twin_objects.push(crate::shapes::ground(
        "twin_ground",
        material,
        Vec2::new(tx.x - reach, tx.y - reach),
        Vec2::new(tx.x + reach, tx.y + reach),
        spec.twin_ground_z,
        (16, 16),
    )?);
    let twin_scene = Scene::new(twin_objects)?;
    let twin_is_ground: Vec<bool> = (0..twin_scene.objects.len())
        .map(|i| i == twin_ground_index)
        .collect();
    let mut twin_set = clutter_set(
        &twin_scene,
        &twin_is_ground,
        spec.twin_density_per_m2,
        spec.twin_density_per_m2.min(spec.ground_density_per_m2),
        spec.seed.wrapping_add(4),
        (tx, array.boresight(), spec.clutter_range_m),
    )?;
    // A reconstructed mesh may wind some faces inward; closed surfaces hide their inner side.
    twin_set.two_sided = true;
    let twin_vis = visible_for(&twin_set, &twin_scene, tx, tx)?;
    let mut predicted = vec![C32::new(0.0, 0.0); e_n * nb];
    psynth.synth_profiles(&twin_set, &twin_vis, tx, &elements, &mut predicted)?;
    let templates = range_segment_templates(&predicted, nb, spec.templates);
    let smoothed = chain.smooth_prediction(&chain.beam_power_static(&predicted)?);
    let gate = chain.gate_from_prediction(&smoothed, spec.gate_cnr_db);
    let clutter_map = ClutterMap {
        level: smoothed,
        doppler: chain.static_doppler_response(),
        margin: 10f32.powf(spec.clutter_margin_db as f32 / 10.0),
    };
    let gate_fraction = gate.iter().filter(|&&g| g).count() as f64 / gate.len() as f64;

    // The target: a cylinder sampled once at the origin, moved per symbol.
    let target_obj = crate::shapes::cylinder(
        "target",
        spec.target_material()?,
        Vec3::ZERO,
        spec.target_radius_m,
        spec.target_height_m,
        48,
        true,
    )?;
    let target_scene = Scene::new(vec![target_obj])?;
    let target = ScattererSet::sample(
        &target_scene,
        spec.target_density_per_m2,
        spec.seed.wrapping_add(3),
    )?;
    let grid = super::target::OfdmGrid {
        fc_hz: spec.fc_hz(),
        df_hz: spec.bandwidth_hz() / spec.subcarriers as f64,
        n: spec.subcarriers,
    };
    let sigma2 = spec.noise_power();

    // Passes.
    let m = spec.symbols;
    let ecas = [
        SlowTimeEca::new(m, 1, EcaVariant::Block, "ECA")?,
        SlowTimeEca::new(m, 3, EcaVariant::Block, "ECA (D = 3)")?,
        SlowTimeEca::new(
            m,
            1,
            EcaVariant::Batched {
                batch: spec.eca_batch,
            },
            "ECA-B",
        )?,
        SlowTimeEca::new(
            m,
            1,
            EcaVariant::Sliding {
                batch: spec.eca_batch,
                extra: spec.eca_extra,
            },
            "ECA-S",
        )?,
    ];
    let env_eca = SlowTimeEca::new(m, 1, EcaVariant::Block, "env")?;
    let mut passes = vec!["none".to_string()];
    passes.extend(ecas.iter().map(|e| e.label.clone()));
    passes.push("env".into());
    let env_pass = passes.len() - 1;
    let eca_passes: Vec<usize> = (1..env_pass).collect();
    let mut timings = Timings {
        setup: t0.elapsed().as_secs_f64(),
        ..Timings::default()
    };

    let velocity = spec.velocity();
    let t_sym = spec.symbol_interval_ms as f32 * 1e-3;
    let lambda = spec.wavelength_m() as f32;
    let mut frames = Vec::with_capacity(spec.frames);
    let mut rd_beam = Vec::with_capacity(spec.frames);
    let mut target_count = 0usize;
    for f in 0..spec.frames {
        let t1 = Instant::now();
        let centre = spec.frame_centre(f);
        let axis_mid = centre + Vec3::Z * (0.5 * spec.target_height_m);
        let los = (axis_mid - tx).normalize();
        let radial = velocity.dot(los);
        // Facing the base station at the CPI centre: the target is convex, so facing = visible.
        let vis: Vec<u32> = target
            .points
            .iter()
            .enumerate()
            .filter(|(_, p)| p.normal.dot(tx - (p.pos + centre)) > 0.0)
            .map(|(i, _)| i as u32)
            .collect();
        target_count += vis.len();
        let truth: Vec<Vec3> = vis
            .iter()
            .map(|&i| target.points[i as usize].pos + centre)
            .collect();
        let truth_cos: Vec<f32> = vis
            .iter()
            .map(|&i| {
                let p = &target.points[i as usize];
                p.normal.dot((tx - (p.pos + centre)).normalize_or_zero())
            })
            .collect();
        let mut frame = vec![C32::new(0.0, 0.0); chain.frame_len()];
        let mut y = vec![C32::new(0.0, 0.0); e_n * spec.subcarriers];
        for (mi, slab) in frame.chunks_exact_mut(e_n * nb).enumerate() {
            let t = (mi as f32 - 0.5 * (m as f32 - 1.0)) * t_sym;
            let seed = spec
                .seed
                .wrapping_mul(1_000_003)
                .wrapping_add((f * m + mi) as u64 + 100);
            super::target::synth_symbol(
                &target,
                &vis,
                centre + velocity * t,
                tx,
                &elements,
                &symbol,
                grid,
                sigma2,
                seed,
                &mut y,
            )?;
            slab.par_chunks_mut(nb)
                .zip(y.par_chunks(spec.subcarriers))
                .zip(clutter_profiles.par_chunks(nb))
                .try_for_each(|((row, ye), ce)| -> Result<(), LocalizeError> {
                    let mut profile = vec![C32::new(0.0, 0.0); chain.rc.profile_len()];
                    chain.compress(ye, &mut profile, row)?;
                    for (r, c) in row.iter_mut().zip(ce) {
                        *r += c;
                    }
                    Ok(())
                })?;
        }
        timings.synthesis += t1.elapsed().as_secs_f64();

        let t2 = Instant::now();
        let beam = chain.beam_towards(axis_mid);
        rd_beam.push(beam);
        let mut detections = Vec::with_capacity(passes.len());
        let mut energies = Vec::with_capacity(passes.len());
        let mut rds = Vec::with_capacity(passes.len());
        let mut run_pass = |frame: &[C32],
                            sup: Suppression<'_>,
                            map: Option<&ClutterMap>|
         -> Result<(), LocalizeError> {
            let cube = chain.process(frame, sup)?;
            detections.push(chain.detect(&cube, map)?);
            energies.push(cube.energy);
            rds.push(chain.range_doppler(&cube, beam));
            Ok(())
        };
        run_pass(&frame, Suppression::None, None)?;
        for e in &ecas {
            run_pass(&frame, Suppression::PerElement(e), None)?;
        }
        let before: f64 = frame.iter().map(|z| z.norm_sqr() as f64).sum();
        subtract_templates(&templates, spec.templates, &mut frame)?;
        let after: f64 = frame.iter().map(|z| z.norm_sqr() as f64).sum();
        run_pass(
            &frame,
            Suppression::Gated(&env_eca, &gate),
            Some(&clutter_map),
        )?;
        timings.processing += t2.elapsed().as_secs_f64();
        let cancellation_db = energies
            .iter()
            .map(|&e| 10.0 * (energies[0] / e.max(1e-300)).log10())
            .collect();
        frames.push(FrameResult {
            index: f,
            centre,
            radial_speed_mps: radial,
            doppler_hz: -2.0 * radial / lambda,
            truth,
            truth_cos,
            detections,
            cancellation_db,
            template_db: 10.0 * (before / after.max(1e-300)).log10(),
            gate_fraction,
            range_doppler: rds,
        });
        progress(f + 1, spec.frames);
    }

    let truth_all: Vec<Vec3> = frames.iter().flat_map(|f| f.truth.clone()).collect();
    let summaries = (0..passes.len())
        .map(|p| summarize(spec, &passes[p], p, &frames, &truth_all))
        .collect::<Result<Vec<_>, _>>()?;
    let eca_best = *eca_passes
        .iter()
        .min_by(|&&a, &&b| {
            let v = |i: usize| summaries[i].sqrt_chamfer_m.unwrap_or(f64::INFINITY);
            v(a).total_cmp(&v(b))
        })
        .ok_or(LocalizeError::Internal("no ECA pass"))?;
    Ok(LocalizeResult {
        passes,
        env_pass,
        eca_passes,
        frames,
        summaries,
        eca_best,
        clutter_scatterers: clutter_vis.len(),
        twin_scatterers: twin_vis.len(),
        target_scatterers: target_count as f64 / spec.frames as f64,
        cube: [nb, chain.beams(), chain.nd],
        range_window_m: [
            chain.bin0 as f64 * chain.bin_m * 0.5,
            (chain.bin0 + nb - 1) as f64 * chain.bin_m * 0.5,
        ],
        noise_cell: chain.noise_cell / chain.doppler_gain,
        timings_s: timings,
        rd_beam,
    })
}

fn summarize(
    spec: &LocalizeSpec,
    label: &str,
    pass: usize,
    frames: &[FrameResult],
    truth: &[Vec3],
) -> Result<ModeSummary, LocalizeError> {
    let mut on = Vec::new();
    let mut all = Vec::new();
    let mut frames_detected = 0;
    for f in frames {
        let mut any = false;
        for d in &f.detections[pass] {
            all.push(d.pos);
            if on_target(spec, f.centre, d.pos, spec.false_alarm_gate_m) {
                on.push(d.pos);
                any = true;
            }
        }
        frames_detected += usize::from(any);
    }
    let cmp = |pts: &[Vec3]| -> Result<Option<CloudComparison>, LocalizeError> {
        if pts.is_empty() || truth.is_empty() {
            Ok(None)
        } else {
            Ok(Some(CloudComparison::new(pts, truth)?))
        }
    };
    let strong: Vec<bool> = frames
        .iter()
        .flat_map(|f| f.truth_cos.iter().map(|&c| c >= 0.5))
        .collect();
    let on_cmp = cmp(&on)?;
    let depth = frames.iter().map(|f| f.cancellation_db[pass]).sum::<f64>() / frames.len() as f64;
    Ok(ModeSummary {
        label: label.to_string(),
        sqrt_chamfer_m: on_cmp.as_ref().map(|c| c.sqrt_chamfer_m()),
        sqrt_chamfer_all_m: cmp(&all)?.map(|c| c.sqrt_chamfer_m()),
        accuracy_rms_m: on_cmp.as_ref().map(|c| c.rms_s1_to_s2_m()),
        completeness_rms_m: on_cmp.as_ref().map(|c| c.rms_s2_to_s1_m()),
        completeness_strong_rms_m: on_cmp
            .as_ref()
            .and_then(|c| c.completeness_on(&strong, 1.0))
            .map(|(rms, _)| rms),
        detections: on.len(),
        false_alarms: all.len() - on.len(),
        frames_detected,
        cancellation_db: depth,
    })
}
