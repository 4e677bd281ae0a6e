//! `has-sim twin RUN_DIR --out DIR`: the planar twin (`has_host::twin`) of a finished
//! `reconstruct` run, written as OBJ, PLY and CityJSON 2.0, scored against the run's truth as
//! the run scored its Poisson mesh.
//!
//! Reads `RUN_DIR/report.json` (the voxel, the scenario file, the seed and sampling density of
//! the mesh's scoring, the mesh's figures), `RUN_DIR/fused.ply` (points and their `weight`) and,
//! for the metrics only, `RUN_DIR/ground_truth.ply` and the scenario's truth objects. The
//! scenario also gives the ground height (its ground objects under the cloud's centre). The
//! run's pair clouds (`RUN_DIR/pair_*.ply`) with their base station's and terminal's positions
//! from the scenario orient the walls (`has_host::twin::enclosure`); a run without them gives
//! a twin whose footprint rests on roof evidence alone.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};
use glam::Vec3;
use has_host::io::ply::{self, PlyData, PlyFormat};
use has_host::scenario::Scenario;
use has_host::twin::{self, cityjson, solid::Surface, MeshFigures, TwinInput, TwinReport};
use serde_json::Value;

use crate::run_dir::RunDir;

/// Options of the `twin` subcommand.
#[derive(clap::Args, Debug)]
pub struct TwinArgs {
    /// A finished `reconstruct` run directory (report.json, fused.ply, ground_truth.ply).
    pub run_dir: PathBuf,
    /// Output directory (twin.obj, twin.ply, twin.city.json, twin.xml with twin_building_*.ply,
    /// twin_report.json, twin_report.md, twin_top.png, twin_side.png, report.html).
    #[arg(long)]
    pub out: PathBuf,
    /// The run's scenario file, when the path report.json records does not resolve from here.
    #[arg(long)]
    pub scenario: Option<PathBuf>,
    /// The ITU radio material of every face of the Sionna RT scene (`twin.xml`): the twin
    /// estimates none (`concrete`, `itu_metal`, … as Sionna RT names them).
    #[arg(long, default_value = "concrete")]
    pub material: String,
}

const OUTPUTS: [&str; 10] = [
    "twin_top.png",
    "twin_side.png",
    "report.html",
    "twin.xml",
    "twin_building_*.ply",
    "twin.obj",
    "twin.ply",
    "twin.city.json",
    "twin_report.json",
    "twin_report.md",
];

fn field<'a>(report: &'a Value, path: &Path, key: &str) -> Result<&'a Value> {
    key.split('.')
        .try_fold(report, |v, k| v.get(k))
        .ok_or_else(|| anyhow!("{}: field {key} is missing", path.display()))
}

fn number(report: &Value, path: &Path, key: &str) -> Result<f64> {
    let v = field(report, path, key)?;
    v.as_f64().filter(|x| x.is_finite()).ok_or_else(|| {
        anyhow!(
            "{}: field {key} = {v} is not a finite number",
            path.display()
        )
    })
}

/// The twin of one run (module docs).
///
/// # Errors
/// One line naming the file and field or value at fault.
pub fn run(a: TwinArgs) -> Result<()> {
    let material = has_host::material::Material::from_name(&a.material).ok_or_else(|| {
        anyhow!(
            "--material = {}: not an ITU radio material (one of {})",
            a.material,
            has_host::material::Material::all()
                .map(|m| m.name())
                .collect::<Vec<_>>()
                .join(", ")
        )
    })?;
    let report_path = a.run_dir.join("report.json");
    let text = has_host::io::guard::read_input_string(&report_path)
        .with_context(|| format!("reading {}", report_path.display()))?;
    let report: Value = serde_json::from_str(&text)
        .with_context(|| format!("{}: not JSON", report_path.display()))?;
    let voxel_m = number(&report, &report_path, "imaging.voxel_m")?;
    if voxel_m <= 0.0 {
        bail!(
            "{}: field imaging.voxel_m = {voxel_m} must be > 0",
            report_path.display()
        );
    }
    // The imaging seed (older reports do not record it: the scenario's, which they used).
    let seed = match report.get("seed") {
        Some(v) => Some(v.as_u64().ok_or_else(|| {
            anyhow!(
                "{}: field seed = {v} is not an unsigned integer",
                report_path.display()
            )
        })?),
        None => None,
    };
    let density = number(&report, &report_path, "mesh.sample_density_per_m2")
        .or_else(|_| number(&report, &report_path, "imaging.ground_truth.density_per_m2"))?;
    let mesh = report
        .get("mesh")
        .and_then(|m| serde_json::from_value::<MeshFigures>(m.clone()).ok());
    let scenario_path = match &a.scenario {
        Some(p) => p.clone(),
        None => PathBuf::from(
            field(&report, &report_path, "scenario")?
                .as_str()
                .ok_or_else(|| {
                    anyhow!("{}: field scenario is not a path", report_path.display())
                })?,
        ),
    };
    // A run of the bundled scenario records the bundled scenario's name, not a file.
    let (bundled, bundled_name) = crate::reconstruct_cmd::load_scenario(None)?;
    let mut sc = if a.scenario.is_none() && scenario_path == Path::new(&bundled_name) {
        bundled
    } else {
        Scenario::load(&scenario_path).with_context(|| {
            format!(
                "{}: field scenario = {} (give --scenario FILE if it moved)",
                report_path.display(),
                scenario_path.display()
            )
        })?
    };
    if report.get("preset").and_then(Value::as_str) == Some("quick") {
        sc.apply_quick();
    }
    let seed = seed.unwrap_or(sc.imaging.seed);

    let fused_path = a.run_dir.join("fused.ply");
    let fused = ply::read_ply(&fused_path)?;
    let weights = fused
        .property("weight")
        .ok_or_else(|| anyhow!("{}: no per-point property weight", fused_path.display()))?
        .to_vec();
    let truth_path = a.run_dir.join("ground_truth.ply");
    let truth = ply::read_ply(&truth_path)?.vertices;

    // Every input is read before the output directory is made.
    let views = pair_views(&a.run_dir, &sc)?;
    let run_dir = RunDir::start(&a.out, &OUTPUTS)?;
    let objects = sc
        .scene
        .build_objects()
        .with_context(|| format!("{}: scene", scenario_path.display()))?;
    let ground_z = ground_height(&sc, &objects, &fused.vertices)
        .with_context(|| format!("{}: imaging.ground_objects", scenario_path.display()))?;
    // The truth's triangles as `imaging::build_world` takes them: the truth objects' faces that
    // do not face down.
    let truth_triangles: Vec<[Vec3; 3]> = objects
        .iter()
        .filter(|o| sc.imaging.truth_objects.contains(&o.name))
        .flat_map(|o| o.triangles.iter().copied())
        .filter(|t| (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero().z > -0.5)
        .collect();

    let input = TwinInput {
        points: &fused.vertices,
        weights: &weights,
        voxel_m,
        ground_z,
        views: &views,
    };
    let t0 = std::time::Instant::now();
    let tw = twin::build(&input).with_context(|| format!("{}", fused_path.display()))?;
    let build_s = t0.elapsed().as_secs_f64();
    let mut rep = TwinReport::new(a.run_dir.display().to_string(), &input, &tw);
    rep.twin = Some(
        twin::score(
            &tw.solid,
            &truth,
            &truth_triangles,
            density,
            seed.wrapping_add(3),
        )
        .with_context(|| format!("scoring against {}", truth_path.display()))?,
    );
    rep.mesh = mesh;

    let json =
        serde_json::to_vec_pretty(&serde_json::json!({ "twin": rep, "build_seconds": build_s }))?;
    let md = rep.render();
    write_twin_files(
        &a.out,
        &tw.solid,
        material,
        vec![
            (a.out.join("twin_report.json"), json),
            (a.out.join("twin_report.md"), md.clone().into_bytes()),
        ],
    )?;
    write_views(&a.out, &tw.solid, &truth, density, seed, &md)?;
    run_dir.finish()?;
    print!("{md}");
    println!("built in {build_s:.1} s; wrote {}", a.out.display());
    Ok(())
}

/// `twin.obj` (one object per building, a group per semantic surface, each with `usemtl
/// itu_<material>` as `mesh.obj` has), `twin.ply`,
/// `twin.city.json` (CityJSON 2.0, LoD2), and the Sionna RT scene `twin.xml` with its
/// `twin_building_*.ply`, every face of `material`; `with` (files and their bytes) are written
/// together with `twin.obj` and `twin.city.json`, checked before any of them is.
pub fn write_twin_files(
    out: &Path,
    solid: &twin::solid::Solid,
    material: has_host::material::Material,
    with: Vec<(PathBuf, Vec<u8>)>,
) -> Result<()> {
    let (tri, owner) = solid.triangulate(|_| true);
    let mut obj = Vec::new();
    writeln!(
        obj,
        "# has planar twin: {} planar faces as {} triangles, {} buildings",
        solid.faces.len(),
        tri.faces.len(),
        solid.buildings
    )?;
    for v in &tri.vertices {
        writeln!(obj, "v {} {} {}", v.x, v.y, v.z)?;
    }
    for b in 0..solid.buildings as u32 {
        writeln!(obj, "o building_{b}")?;
        for s in [
            Surface::WallSurface,
            Surface::RoofSurface,
            Surface::GroundSurface,
        ] {
            writeln!(obj, "g building_{b}_{s:?}")?;
            writeln!(obj, "usemtl itu_{}", material.name())?;
            // Triangles (a merged face need not be convex, and readers fan polygons).
            for (t, &fi) in tri.faces.iter().zip(&owner) {
                let f = &solid.faces[fi as usize];
                if f.building == b && f.surface == s {
                    writeln!(obj, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
                }
            }
        }
    }
    let ply_data = PlyData {
        vertices: tri.vertices.clone(),
        properties: Vec::new(),
        faces: tri.faces.clone(),
    };
    let city = serde_json::to_vec(&cityjson::document(solid))?;
    let radio = twin::sionna::scene(solid, material);
    let mut first = vec![
        (out.join("twin.obj"), obj),
        (out.join("twin.city.json"), city),
    ];
    first.extend(with);
    has_host::io::write_files(&first)?;
    ply::write_ply(
        &out.join("twin.ply"),
        &ply_data,
        PlyFormat::BinaryLittleEndian,
    )?;
    for (file, mesh) in &radio.meshes {
        ply::write_ply(&out.join(file), mesh, PlyFormat::BinaryLittleEndian)?;
    }
    // The scene last: it names the meshes.
    has_host::io::write_files(&[(out.join("twin.xml"), radio.xml.into_bytes())])?;
    Ok(())
}

/// The ground objects' height under the centre of the cloud's ground extent, metres.
fn ground_height(sc: &Scenario, objects: &[has_host::Object], points: &[Vec3]) -> Result<f64> {
    let ground: Vec<has_host::Object> = objects
        .iter()
        .filter(|o| sc.imaging.ground_objects.contains(&o.name))
        .cloned()
        .collect();
    if ground.is_empty() || points.is_empty() {
        bail!("no ground object to stand the twin on");
    }
    let scene = has_host::Scene::new(ground)?;
    twin::ground_height_under(&scene, points)
        .ok_or_else(|| anyhow!("no ground under the fused cloud's centre"))
}

/// `twin_top.png`, `twin_side.png` (area samples of the faces on a detected plane, red, and of
/// the inferred faces, orange, over the true surfaces, grey) and `report.html` (the report, the
/// truth and the twin's two kinds of faces in 3D, the views).
fn write_views(
    out: &Path,
    solid: &twin::solid::Solid,
    truth: &[Vec3],
    density: f64,
    seed: u64,
    md: &str,
) -> Result<()> {
    use crate::plot::{self, View};
    use has_host::html::{Layer, MESH_COLOUR};
    use plotters::style::RGBColor;
    let inferred =
        |f: &twin::solid::Face| matches!(f.provenance, twin::solid::Provenance::Inferred { .. });
    let shown = |f: &twin::solid::Face| f.surface != Surface::GroundSurface;
    let (on_plane, _) = solid.triangulate(|f| shown(f) && !inferred(f));
    let (guessed, _) = solid.triangulate(|f| shown(f) && inferred(f));
    let sample = |m: &has_host::mesh::TriMesh| -> Result<Vec<Vec3>> {
        if m.faces.is_empty() {
            return Ok(Vec::new());
        }
        Ok(m.sample(density, seed)?)
    };
    let (a, b) = (sample(&on_plane)?, sample(&guessed)?);
    let grey = RGBColor(170, 170, 170);
    let red = RGBColor(200, 40, 40);
    let orange = RGBColor(240, 150, 20);
    for (file, view, title) in [
        ("twin_top.png", View::Top, "Planar twin: faces on a detected plane (red), inferred faces (orange), over the true surfaces (grey), top view"),
        ("twin_side.png", View::Side, "Planar twin: faces on a detected plane (red), inferred faces (orange), over the true surfaces (grey), side view from −y"),
    ] {
        plot::projection(
            &out.join(file),
            title,
            view,
            &[
                ("ground truth", truth, grey, 1),
                ("faces on a plane", &a, red, 1),
                ("inferred faces", &b, orange, 1),
            ],
        )?;
    }
    let layers = [
        Layer::points("ground truth (area samples)", [150, 150, 150], truth, 2),
        Layer::mesh("twin: faces on a detected plane", MESH_COLOUR, &on_plane),
        Layer::mesh("twin: inferred faces", [240, 150, 20], &guessed),
    ];
    crate::html_report::write(
        out,
        "has-sim twin",
        md,
        &layers,
        &[
            (
                "twin_top.png",
                "The twin's area samples over the truth, top view",
            ),
            (
                "twin_side.png",
                "The twin's area samples over the truth, side view",
            ),
        ],
    )
}

/// The run's pair clouds (`pair_BS-AP.ply`) with the positions of their base station and the
/// centre of their terminal's track, from the scenario; a file whose name names no pair of the
/// scenario is an error.
fn pair_views(run_dir: &Path, sc: &Scenario) -> Result<Vec<twin::enclosure::PairView>> {
    let mut names: Vec<String> = std::fs::read_dir(run_dir)
        .with_context(|| format!("reading {}", run_dir.display()))?
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.starts_with("pair_") && n.ends_with(".ply"))
        .collect();
    names.sort();
    let mut views = Vec::with_capacity(names.len());
    for file in names {
        let pair = &file["pair_".len()..file.len() - ".ply".len()];
        let ends = pair.split_once('-').and_then(|(bs, ap)| {
            let b = sc.base_stations.iter().find(|b| b.name == bs)?;
            let i = sc.apertures.iter().position(|a| a.name == ap)?;
            Some((
                glam::Vec3::from(b.position).as_dvec3(),
                sc.aperture(i, 2).centre().as_dvec3(),
            ))
        });
        let Some((receiver, transmitter)) = ends else {
            anyhow::bail!(
                "{}: file {file} names no base station–aperture pair of the scenario",
                run_dir.display()
            );
        };
        let points = ply::read_ply(&run_dir.join(&file))?.vertices;
        views.push(twin::enclosure::PairView {
            points,
            receiver,
            transmitter,
        });
    }
    Ok(views)
}
