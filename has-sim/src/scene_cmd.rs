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
        /// Scene file: .toml, .xml (Mitsuba / Sionna RT) or .obj.
        #[arg(long)]
        scene: PathBuf,
        /// Output file, .obj or .ply.
        #[arg(long)]
        out: PathBuf,
    },
    /// Print the objects with materials, triangle counts and bounds.
    Info {
        /// Scene file: .toml, .xml (Mitsuba / Sionna RT) or .obj.
        #[arg(long)]
        scene: PathBuf,
    },
}

/// Runs a scene subcommand.
pub fn run(cmd: SceneCmd) -> anyhow::Result<()> {
    match cmd {
        SceneCmd::Export { scene, out } => {
            let objects = load_scene_objects(&scene)?;
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
        SceneCmd::Info { scene } => {
            let objects = load_scene_objects(&scene)?;
            println!(
                "{:<24} {:<18} {:>9}  {:>28}  {:>28}",
                "object", "material", "triangles", "min (m)", "max (m)"
            );
            for o in &objects {
                let mut lo = glam::Vec3::splat(f32::INFINITY);
                let mut hi = glam::Vec3::splat(f32::NEG_INFINITY);
                for v in o.triangles.iter().flatten() {
                    lo = lo.min(*v);
                    hi = hi.max(*v);
                }
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
