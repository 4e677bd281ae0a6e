//! The twin as a Sionna RT / Mitsuba 3 XML scene: one PLY mesh per building (its walls and
//! roofs as triangles; the base is left out, it lies on the terrain), each shape with one ITU
//! radio material.
//!
//! The twin estimates no material: the caller names one (the scenario's, or concrete), and it
//! is written as Sionna ≥ 1.0 writes a radio material (`itu-radio-material` with its `type` and
//! Sionna's default thickness, [`crate::io::mitsuba::SIONNA_DEFAULT_THICKNESS_M`]). Coordinates
//! are the run's frame in metres, z up, as Sionna RT's scenes are. [`crate::io::mitsuba`] reads
//! the file back, so `has-sim paths --scene twin.xml` traces on the twin.

use glam::Vec3;

use super::solid::{Solid, Surface};
use crate::io::mitsuba::SIONNA_DEFAULT_THICKNESS_M;
use crate::io::PlyData;
use crate::material::Material;

/// The scene: the XML text and, per building, the mesh file name (`twin_building_B.ply`, beside
/// the XML file) and its triangles.
#[derive(Clone, Debug)]
pub struct SionnaScene {
    /// Mitsuba 3 XML.
    pub xml: String,
    /// `(relative path, mesh)` per building.
    pub meshes: Vec<(String, PlyData)>,
}

/// The scene of `solid` with every face of `material`.
pub fn scene(solid: &Solid, material: Material) -> SionnaScene {
    let id = format!("mat-itu_{}", material.name());
    let mut xml = String::from("<scene version=\"2.1.0\">\n");
    xml += &format!(
        "  <bsdf type=\"itu-radio-material\" id=\"{id}\">\n    <string name=\"type\" value=\"{}\"/>\n    <float name=\"thickness\" value=\"{}\"/>\n  </bsdf>\n",
        material.name(),
        SIONNA_DEFAULT_THICKNESS_M
    );
    let mut meshes = Vec::new();
    for b in 0..solid.buildings as u32 {
        let (tri, _) =
            solid.triangulate(|f| f.building == b && f.surface != Surface::GroundSurface);
        // Keep only the vertices this building's triangles use.
        let mut map = vec![u32::MAX; tri.vertices.len()];
        let mut vertices: Vec<Vec3> = Vec::new();
        let faces: Vec<[u32; 3]> = tri
            .faces
            .iter()
            .map(|t| {
                t.map(|v| {
                    if map[v as usize] == u32::MAX {
                        map[v as usize] = vertices.len() as u32;
                        vertices.push(tri.vertices[v as usize]);
                    }
                    map[v as usize]
                })
            })
            .collect();
        if faces.is_empty() {
            continue;
        }
        let file = format!("twin_building_{b}.ply");
        xml += &format!(
            "  <shape type=\"ply\" id=\"mesh-building_{b}\">\n    <string name=\"filename\" value=\"{file}\"/>\n    <boolean name=\"face_normals\" value=\"true\"/>\n    <ref id=\"{id}\" name=\"bsdf\"/>\n  </shape>\n"
        );
        meshes.push((
            file,
            PlyData {
                vertices,
                properties: Vec::new(),
                faces,
            },
        ));
    }
    xml += "</scene>\n";
    SionnaScene { xml, meshes }
}
