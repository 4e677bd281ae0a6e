//! Stage 5 of the planar twin: the solid as CityJSON 2.0 — one LoD2 `Building` per connected
//! footprint, its boundary a `Solid` whose surfaces carry the semantics `WallSurface`,
//! `RoofSurface` and `GroundSurface`.
//!
//! Vertices are the ones the faces use, integers under `transform` (scale 0.1 mm, below the
//! partition's weld, so distinct vertices stay distinct; translate the smallest corner), as the
//! specification requires; the run's frame is local metres, so no `referenceSystem` is claimed.
//! Where two parts of a building touch along an edge, the solid holds one copy of that edge's
//! vertices per part ([`super::solid`]); a validator reports those as duplicate vertices.
//! Each semantic surface object also carries the face's provenance (`inferred`, `plane`,
//! `evidence`), an extra attribute CityJSON allows on semantic objects.

use serde_json::{json, Value};

use super::solid::{Provenance, Solid};

/// Vertex quantum of the file, metres.
pub const SCALE_M: f64 = 0.0001;

/// The CityJSON 2.0 document of `solid`.
pub fn document(solid: &Solid) -> Value {
    let lo = solid
        .vertices
        .iter()
        .fold(glam::DVec3::splat(f64::MAX), |m, &v| m.min(v));
    let lo = if solid.vertices.is_empty() {
        glam::DVec3::ZERO
    } else {
        lo
    };
    // Only the vertices some face uses (merging faces leaves interior vertices behind), in
    // first-use order.
    let mut index = vec![u32::MAX; solid.vertices.len()];
    let mut vertices: Vec<Value> = Vec::new();
    let rings: Vec<Vec<u32>> = solid
        .faces
        .iter()
        .map(|f| {
            f.ring
                .iter()
                .map(|&v| {
                    if index[v as usize] == u32::MAX {
                        index[v as usize] = vertices.len() as u32;
                        let q = ((solid.vertices[v as usize] - lo) / SCALE_M).round();
                        vertices.push(json!([q.x as i64, q.y as i64, q.z as i64]));
                    }
                    index[v as usize]
                })
                .collect()
        })
        .collect();
    let mut objects = serde_json::Map::new();
    for b in 0..solid.buildings as u32 {
        let faces: Vec<_> = solid
            .faces
            .iter()
            .zip(&rings)
            .filter(|(f, _)| f.building == b)
            .collect();
        if faces.is_empty() {
            continue;
        }
        let boundaries: Vec<Value> = faces.iter().map(|(_, r)| json!([r])).collect();
        let surfaces: Vec<Value> = faces
            .iter()
            .map(|(f, _)| {
                let mut s = json!({ "type": format!("{:?}", f.surface) });
                match &f.provenance {
                    Provenance::Plane { plane, points } => {
                        s["inferred"] = json!(false);
                        s["plane"] = json!(plane);
                        s["points"] = json!(points);
                    }
                    Provenance::Inferred { evidence } => {
                        s["inferred"] = json!(true);
                        s["evidence"] = json!(evidence);
                    }
                }
                s
            })
            .collect();
        let values: Vec<usize> = (0..faces.len()).collect();
        objects.insert(
            format!("building_{b}"),
            json!({
                "type": "Building",
                "geometry": [{
                    "type": "Solid",
                    "lod": "2",
                    "boundaries": [boundaries],
                    "semantics": { "surfaces": surfaces, "values": [values] },
                }],
            }),
        );
    }
    json!({
        "type": "CityJSON",
        "version": "2.0",
        "transform": { "scale": [SCALE_M, SCALE_M, SCALE_M], "translate": [lo.x, lo.y, lo.z] },
        "metadata": { "title": "has planar twin (local metres, no reference system)" },
        "CityObjects": objects,
        "vertices": vertices,
    })
}
