//! `has-sim scene ...`: inspect a scene file and export it as a mesh for viewing.
//!
//! A scene file is a TOML scenario (its `[scene]` table), a Mitsuba XML scene (Sionna RT) or an
//! OBJ file with `usemtl` materials; see `docs/scenario.md`.

use std::path::PathBuf;

use anyhow::Context;
use clap::Subcommand;
use has_host::scenario::load_scene_objects;
use has_host::Scene;

/// Scene subcommands.
#[derive(Subcommand)]
pub enum SceneCmd {
    /// Write the scene's triangles to an OBJ (objects and materials kept) or PLY file.
    Export {
        /// Scene file: .toml, .xml (Mitsuba / Sionna RT), .obj or .ply.
        #[arg(long)]
        scene: PathBuf,
        /// Output file, .obj or .ply.
        #[arg(long)]
        out: PathBuf,
        /// For a mesh scene file: every object's material (a PLY file carries none).
        #[arg(long, value_parser = parse_material)]
        material: Option<has_host::Material>,
    },
    /// Print the objects with materials, triangle counts and bounds.
    Info {
        /// Scene file: .toml, .xml (Mitsuba / Sionna RT), .obj or .ply.
        #[arg(long)]
        scene: PathBuf,
        /// For a mesh scene file: every object's material (a PLY file carries none).
        #[arg(long, value_parser = parse_material)]
        material: Option<has_host::Material>,
    },
}

/// A radio material by its ITU-R P.2040 name (`concrete` or `itu_concrete`), for clap.
pub fn parse_material(s: &str) -> Result<has_host::Material, String> {
    has_host::Material::from_name(s).ok_or_else(|| {
        format!(
            "unknown material '{s}'; known: {}",
            has_host::io::known_material_names()
        )
    })
}

/// Runs a scene subcommand.
pub fn run(cmd: SceneCmd) -> anyhow::Result<()> {
    match cmd {
        SceneCmd::Export {
            scene,
            out,
            material,
        } => {
            let objects = load_scene_objects(&scene, material)?;
            let tris: usize = objects.iter().map(|o| o.triangles.len()).sum();
            has_host::io::save_objects(&out, &objects)
                .with_context(|| format!("exporting {}", scene.display()))?;
            println!(
                "wrote {} ({} objects, {tris} triangles)",
                out.display(),
                objects.len()
            );
            Ok(())
        }
        SceneCmd::Info { scene, material } => {
            let objects = load_scene_objects(&scene, material)?;
            println!(
                "{:<24} {:<18} {:>9}  {:>28}  {:>28}",
                "object", "material", "triangles", "min (m)", "max (m)"
            );
            for o in &objects {
                let (lo, hi) = o.bounds();
                println!(
                    "{:<24} {:<18} {:>9}  {:>28}  {:>28}",
                    o.name,
                    format!("itu_{}", o.material.name()),
                    o.triangles.len(),
                    format!("({:.1}, {:.1}, {:.1})", lo.x, lo.y, lo.z),
                    format!("({:.1}, {:.1}, {:.1})", hi.x, hi.y, hi.z),
                );
            }
            let s = Scene::new(objects)?;
            println!(
                "{} triangles in the BVH, built in {:.1} ms",
                s.triangle_count(),
                s.build_time.as_secs_f64() * 1e3
            );
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fixture(name: &str) -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../fixtures")
            .join(name)
    }

    #[test]
    fn export_writes_obj_and_ply_that_load_back() {
        let dir = std::env::temp_dir().join(format!("has-scene-cmd-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let scene = fixture("city_block.toml");
        let want = load_scene_objects(&scene, None).unwrap();
        let n: usize = want.iter().map(|o| o.triangles.len()).sum();
        for ext in ["obj", "ply"] {
            let out = dir.join(format!("city.{ext}"));
            run(SceneCmd::Export {
                scene: scene.clone(),
                out: out.clone(),
                material: None,
            })
            .unwrap();
            let back =
                has_host::io::load_objects(&out, Some(has_host::Material::Concrete)).unwrap();
            assert_eq!(back.iter().map(|o| o.triangles.len()).sum::<usize>(), n);
        }
        run(SceneCmd::Info {
            scene: fixture("sionna_small/scene.xml"),
            material: None,
        })
        .unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn export_errors_name_the_bad_file_or_extension() {
        let e = run(SceneCmd::Export {
            scene: fixture("no_such_scene.toml"),
            out: std::env::temp_dir().join("x.obj"),
            material: None,
        })
        .unwrap_err();
        assert!(format!("{e:#}").contains("no_such_scene.toml"), "{e:#}");
        let e = run(SceneCmd::Export {
            scene: fixture("city_block.toml"),
            out: std::env::temp_dir().join("x.stl"),
            material: None,
        })
        .unwrap_err();
        assert!(format!("{e:#}").contains("'stl'"), "{e:#}");
    }
}
