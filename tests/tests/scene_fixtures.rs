//! The bundled scene fixtures load and have the geometry their comments state: the Sionna RT
//! (Mitsuba XML + PLY) sample scene and the city-block TOML used by the paths benchmark.

use std::path::PathBuf;

use glam::Vec3;
use has_host::io::mitsuba::read_mitsuba;
use has_host::scenario::SceneSpec;
use has_host::shapes::{signed_volume, surface_area};
use has_host::Material;

fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures")
}

fn bounds(tris: &[[Vec3; 3]]) -> (Vec3, Vec3) {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for v in tris.iter().flatten() {
        lo = lo.min(*v);
        hi = hi.max(*v);
    }
    (lo, hi)
}

#[test]
fn sionna_sample_scene_loads_with_materials_and_transforms() {
    let objs = read_mitsuba(&fixtures().join("sionna_small/scene.xml")).unwrap();
    let names: Vec<_> = objs.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["floor", "wall", "shed"]);
    let mats: Vec<_> = objs.iter().map(|o| o.material).collect();
    assert_eq!(mats, [Material::Concrete, Material::Brick, Material::Metal]);
    // Floor: one ASCII quad, 40 m x 40 m, facing up.
    assert_eq!(objs[0].triangles.len(), 2);
    assert!((surface_area(&objs[0].triangles) - 1600.0).abs() < 1e-3);
    // Wall: closed 10 x 2 x 6 box from a binary PLY with normals (exact small integers, so
    // the divergence-theorem volume is exact up to f64 rounding).
    assert_eq!(objs[1].triangles.len(), 12);
    assert!((signed_volume(&objs[1].triangles) - 120.0).abs() < 1e-9);
    // Shed: the wall rotated by 90° about z ((x, y) → (−y, x)) then moved by (−12, 5, 0):
    // x ∈ [−5, −3] − 12, y ∈ [−5, 5] + 5. cos/sin(90°) in f64 are exact to 6e-17.
    let (lo, hi) = bounds(&objs[2].triangles);
    assert!(
        (lo - Vec3::new(-17.0, 0.0, 0.0)).abs().max_element() < 1e-5,
        "{lo}"
    );
    assert!(
        (hi - Vec3::new(-15.0, 10.0, 6.0)).abs().max_element() < 1e-5,
        "{hi}"
    );
    assert!((signed_volume(&objs[2].triangles) - 120.0).abs() < 1e-3);
}

#[test]
fn sionna_scene_can_be_embedded_in_a_toml_scene() {
    let mut spec = SceneSpec::from_toml_str(
        r#"
[scene]
[[scene.objects]]
kind = "mesh"
path = "sionna_small/scene.xml"
name = "imported"
offset = [100.0, 0.0, 0.0]

[[scene.objects]]
kind = "cylinder"
name = "target"
material = "metal"
center = [100.0, -10.0]
radius = 3.0
height = 3.0
"#,
    )
    .unwrap();
    spec.set_base_dir(fixtures());
    let scene = spec.build().unwrap();
    let names: Vec<_> = scene.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(
        names,
        ["imported/floor", "imported/wall", "imported/shed", "target"]
    );
    // A ray down onto the moved floor hits it at z = 0 and reports concrete.
    let hit = scene
        .closest_hit(Vec3::new(110.0, -15.0, 10.0), Vec3::NEG_Z, 0.0, 100.0)
        .unwrap();
    assert!((hit.t - 10.0).abs() < 1e-4);
    assert_eq!(scene.material_of(hit.triangle), Material::Concrete);
}

#[test]
fn city_block_fixture_builds_and_the_suggested_bs_is_in_the_open() {
    let spec = SceneSpec::load(&fixtures().join("city_block.toml")).unwrap();
    let scene = spec.build().unwrap();
    assert_eq!(scene.objects.len(), 15);
    let buildings = scene
        .objects
        .iter()
        .filter(|o| o.name.starts_with('b'))
        .count();
    assert_eq!(buildings, 14);
    // The suggested BS at (0, 0, 25) sees the ground below it and open sky above.
    let bs = Vec3::new(0.0, 0.0, 25.0);
    let down = scene.closest_hit(bs, Vec3::NEG_Z, 0.0, 100.0).unwrap();
    assert_eq!(scene.objects[down.object as usize].name, "ground");
    assert!((down.t - 25.0).abs() < 1e-4);
    assert!(scene.closest_hit(bs, Vec3::Z, 0.0, 1e4).is_none());
    // It sees down all four streets.
    for d in [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y] {
        assert!(scene.visible(bs, bs + 140.0 * d + Vec3::new(0.0, 0.0, -23.5)));
    }
}

#[test]
fn documented_example_scene_builds() {
    let doc = std::fs::read_to_string(fixtures().join("../docs/scenario.md")).unwrap();
    let start = doc
        .find("```toml\n")
        .expect("docs/scenario.md has a toml example")
        + 8;
    let len = doc[start..].find("```").unwrap();
    let mut spec = SceneSpec::from_toml_str(&doc[start..start + len]).unwrap();
    spec.set_base_dir(fixtures());
    let scene = spec.build().unwrap();
    assert_eq!(scene.objects.len(), 6);
}

#[test]
fn the_simulated_ground_is_the_same_when_the_site_is_turned() {
    // factory_rotated is factory_site turned by 37° about z, its region a turned polygon: every
    // ground point scatters in one exactly when its turned image does in the other (the disc
    // around the region's footprint), away from the disc's rim where f32 rounding decides.
    use has_host::scenario::Scenario;
    let site = Scenario::load(&fixtures().join("suite/factory_site.toml")).unwrap();
    let turned = Scenario::load(&fixtures().join("suite/factory_rotated.toml")).unwrap();
    let (s, c) = 37f32.to_radians().sin_cos();
    let (mut inside, mut total) = (0, 0);
    for i in -40..=40 {
        for j in -40..=40 {
            let p = Vec3::new(i as f32 * 1.9, j as f32 * 1.9, 0.0);
            let q = Vec3::new(c * p.x - s * p.y, s * p.x + c * p.y, 0.0);
            let a = site.scatters_as_ground(p);
            // The rotated fixture's polygon vertices are rounded to 1 cm.
            let rim = [0.97f32, 1.03].map(|f| site.scatters_as_ground(p * f));
            if rim[0] == rim[1] {
                assert_eq!(a, turned.scatters_as_ground(q), "{p} vs {q}");
            }
            inside += a as usize;
            total += 1;
        }
    }
    // The disc reaches past the region (80 m × 64 m, radius 51.2 m + 10 m margin) but not to
    // the edge of the test grid (76 m).
    assert!(inside > total / 3 && inside < total, "{inside} of {total}");
}

#[test]
fn a_missing_mesh_names_the_xml_file_its_line_and_the_shape() {
    let dir = std::env::temp_dir().join(format!("has-mitsuba-missing-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("meshes")).unwrap();
    for f in ["floor.ply", "wall.ply"] {
        std::fs::copy(
            fixtures().join("sionna_small/meshes").join(f),
            dir.join("meshes").join(f),
        )
        .unwrap();
    }
    let xml = std::fs::read_to_string(fixtures().join("sionna_small/scene.xml")).unwrap();
    std::fs::write(
        dir.join("scene.xml"),
        xml.replace("meshes/wall.ply", "meshes/nothere.ply"),
    )
    .unwrap();
    let e = read_mitsuba(&dir.join("scene.xml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("scene.xml:"), "{e}");
    assert!(e.contains("shape 'mesh-wall'"), "{e}");
    assert!(e.contains("nothere.ply"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn every_bundled_scenario_loads_and_its_scene_builds() {
    // The suite, the held-out sites (random, courtyard, …) and the bundled factory: each file
    // parses, validates, and its scene's objects (generated buildings, loaded meshes) build with
    // every truth object among them, as `has-sim reconstruct` and `has-sim suite` need.
    use has_host::scenario::Scenario;
    fn scenarios(dir: &std::path::Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                scenarios(&p, out);
            } else if p.extension().is_some_and(|x| x == "toml") {
                out.push(p);
            }
        }
    }
    let mut files = vec![fixtures().join("factory.toml")];
    scenarios(&fixtures().join("suite"), &mut files);
    scenarios(&fixtures().join("holdout"), &mut files);
    files.sort();
    assert!(files.len() >= 25, "{} scenario files", files.len());
    for f in &files {
        let sc = Scenario::load(f).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        let objects = sc
            .scene
            .build_objects()
            .unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        for t in &sc.imaging.truth_objects {
            assert!(
                objects.iter().any(|o| o.name == *t),
                "{}: truth object {t} not in the scene",
                f.display()
            );
        }
    }
}
