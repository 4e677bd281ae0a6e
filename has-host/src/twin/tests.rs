//! The planar twin of synthetic clouds sampled from known buildings: an L-shaped flat-roofed
//! block and a gabled (pitched) hall, beside each other. The cloud is what fusion gives: points
//! snapped to the centres of 0.5 m voxels, one per voxel.
//!
//! Tolerances: the twin's √CD against the true surfaces is bounded by one voxel (a voxel centre
//! lies up to √3/2 voxel from the surface it holds, and planes fitted through many of them
//! average that down); the volume within 10 % (each outline may sit up to half a voxel off, on
//! a 60 m perimeter of a 2300 m³ block about 5 %).

use std::collections::{HashMap, HashSet};

use glam::Vec3;

use super::*;
use crate::metrics::CloudMetrics;

const VOXEL: f64 = 0.5;

/// A vertical wall from (x0, y0) to (x1, y1) up to `top(x, y)`, and roof samples over the
/// footprint `inside`, both at spacing `s`.
fn wall(a: (f32, f32), b: (f32, f32), top: &dyn Fn(f32, f32) -> f32, s: f32, out: &mut Vec<Vec3>) {
    let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
    let n = (len / s).ceil() as usize;
    for i in 0..=n {
        let t = i as f32 / n as f32;
        let (x, y) = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
        let h = top(x, y);
        let m = (h / s).ceil() as usize;
        for k in 0..=m {
            out.push(Vec3::new(x, y, h * k as f32 / m as f32));
        }
    }
}

fn roof(
    lo: (f32, f32),
    hi: (f32, f32),
    inside: &dyn Fn(f32, f32) -> bool,
    top: &dyn Fn(f32, f32) -> f32,
    s: f32,
    out: &mut Vec<Vec3>,
) {
    let (nx, ny) = (((hi.0 - lo.0) / s) as usize, ((hi.1 - lo.1) / s) as usize);
    for i in 0..=nx {
        for j in 0..=ny {
            let (x, y) = (lo.0 + i as f32 * s, lo.1 + j as f32 * s);
            if inside(x, y) {
                out.push(Vec3::new(x, y, top(x, y)));
            }
        }
    }
}

/// Dense samples of the true surfaces (walls and roofs, no ground): the L block (20 × 20 m,
/// arms 8 m wide, 9 m high) and the gabled hall (16 × 10 m, eaves 6 m, ridge 9 m along x).
fn truth(s: f32) -> Vec<Vec3> {
    let mut t = Vec::new();
    let flat = |_: f32, _: f32| 9.0;
    let l = [
        (0.0, 0.0),
        (20.0, 0.0),
        (20.0, 8.0),
        (8.0, 8.0),
        (8.0, 20.0),
        (0.0, 20.0),
    ];
    for k in 0..l.len() {
        wall(l[k], l[(k + 1) % l.len()], &flat, s, &mut t);
    }
    roof(
        (0.0, 0.0),
        (20.0, 20.0),
        &|x, y| x <= 8.0 || y <= 8.0,
        &flat,
        s,
        &mut t,
    );
    let gable = |_: f32, y: f32| 9.0 - 3.0 * (y - 5.0).abs() / 5.0 + 0.0 * y;
    let g = [(30.0, 0.0), (46.0, 0.0), (46.0, 10.0), (30.0, 10.0)];
    for k in 0..g.len() {
        wall(g[k], g[(k + 1) % g.len()], &gable, s, &mut t);
    }
    roof((30.0, 0.0), (46.0, 10.0), &|_, _| true, &gable, s, &mut t);
    t
}

/// The truth snapped to voxel centres, one point per voxel.
fn fused(truth: &[Vec3]) -> Vec<Vec3> {
    let v = VOXEL as f32;
    let mut seen = HashSet::new();
    let mut out = Vec::new();
    for p in truth {
        let k = (p / v).floor().as_ivec3();
        if seen.insert(k) {
            out.push((k.as_vec3() + 0.5) * v);
        }
    }
    out
}

fn twin_of_synthetic() -> (Twin, Vec<Vec3>) {
    let t = truth(0.1);
    let pts = fused(&t);
    let w = vec![1.0f32; pts.len()];
    let input = TwinInput {
        points: &pts,
        weights: &w,
        voxel_m: VOXEL,
        ground_z: 0.0,
        views: &[],
    };
    (build(&input).expect("a twin"), t)
}

#[test]
fn twin_of_an_l_block_and_a_gabled_hall_is_a_closed_oriented_planar_solid_near_the_truth() {
    let (tw, truth) = twin_of_synthetic();
    let s = &tw.solid;
    assert_eq!(s.buildings, 2, "{} buildings", s.buildings);
    // Each directed edge of the polygon faces is used once, and its reverse once.
    let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
    for f in &s.faces {
        for k in 0..f.ring.len() {
            *directed
                .entry((f.ring[k], f.ring[(k + 1) % f.ring.len()]))
                .or_default() += 1;
        }
    }
    for (&(a, b), &n) in &directed {
        assert_eq!(n, 1, "edge {a}→{b} used {n} times in one direction");
        assert_eq!(
            directed.get(&(b, a)),
            Some(&1),
            "edge {a}→{b} has no opposite use"
        );
    }
    let (mesh, _) = s.triangulate(|_| true);
    let topo = mesh.topology();
    assert!(topo.watertight && topo.manifold, "{topo:?}");
    assert!(
        s.max_planarity_error_m() < 0.01,
        "{}",
        s.max_planarity_error_m()
    );
    let volume = s.signed_volume_m3();
    let true_volume = 20.0 * 8.0 * 9.0 + 8.0 * 12.0 * 9.0 + 16.0 * 10.0 * 6.0 + 16.0 * 10.0 * 1.5;
    assert!(volume > 0.0);
    assert!(
        (volume / true_volume - 1.0).abs() < 0.10,
        "volume {volume:.0} m³ vs {true_volume:.0}"
    );
    let samples = s
        .triangulate(|f| f.surface != Surface::GroundSurface)
        .0
        .sample(9.0, 3)
        .unwrap();
    let m = CloudMetrics::between(&samples, &truth).unwrap();
    eprintln!(
        "synthetic twin: {} faces ({} inferred), volume {volume:.0} of {true_volume:.0} m³, √CD {:.3} m, F(1 m) {:.1}, planarity {:.1e} m",
        s.faces.len(),
        s.inferred(),
        m.sqrt_chamfer_m,
        m.fscores.fscore_1_0m,
        s.max_planarity_error_m()
    );
    assert!(m.sqrt_chamfer_m < VOXEL, "√CD {:.3} m", m.sqrt_chamfer_m);
    assert!(
        m.fscores.fscore_1_0m > 95.0,
        "F(1 m) {:.1}",
        m.fscores.fscore_1_0m
    );
}

#[test]
fn every_face_has_provenance_and_the_gable_has_two_roof_planes() {
    let (tw, _) = twin_of_synthetic();
    let hall = tw
        .solid
        .faces
        .iter()
        .find(|f| tw.solid.vertices[f.ring[0] as usize].x > 29.0)
        .expect("a hall face")
        .building;
    let planes: HashSet<u32> = tw
        .solid
        .faces
        .iter()
        .filter(|f| f.building == hall && f.surface == Surface::RoofSurface)
        .filter_map(|f| match f.provenance {
            solid::Provenance::Plane { plane, .. } => Some(plane),
            _ => None,
        })
        .collect();
    assert_eq!(planes.len(), 2, "{planes:?}");
}

#[test]
fn cityjson_has_the_2_0_structure_with_lod2_solids_and_semantics() {
    let (tw, _) = twin_of_synthetic();
    let text = serde_json::to_string(&cityjson::document(&tw.solid)).unwrap();
    let doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(doc["type"], "CityJSON");
    assert_eq!(doc["version"], "2.0");
    let scale = doc["transform"]["scale"].as_array().unwrap();
    assert_eq!(scale.len(), 3);
    assert_eq!(doc["transform"]["translate"].as_array().unwrap().len(), 3);
    let vertices = doc["vertices"].as_array().unwrap();
    assert!(vertices
        .iter()
        .all(|v| v.as_array().unwrap().iter().all(|c| c.is_i64())));
    let objects = doc["CityObjects"].as_object().unwrap();
    assert_eq!(objects.len(), 2);
    for (name, o) in objects {
        assert_eq!(o["type"], "Building", "{name}");
        let g = &o["geometry"][0];
        assert_eq!(g["type"], "Solid");
        assert_eq!(g["lod"], "2");
        let shell = g["boundaries"][0].as_array().unwrap();
        let values = g["semantics"]["values"][0].as_array().unwrap();
        assert_eq!(
            shell.len(),
            values.len(),
            "{name}: one semantic value per surface"
        );
        let surfaces = g["semantics"]["surfaces"].as_array().unwrap();
        for v in values {
            let t = surfaces[v.as_u64().unwrap() as usize]["type"]
                .as_str()
                .unwrap();
            assert!(
                ["WallSurface", "RoofSurface", "GroundSurface"].contains(&t),
                "{t}"
            );
        }
        for surface in shell {
            for ring in surface.as_array().unwrap() {
                for i in ring.as_array().unwrap() {
                    assert!((i.as_u64().unwrap() as usize) < vertices.len());
                }
            }
        }
    }
}

#[test]
fn bad_input_is_named() {
    let pts = [Vec3::ZERO; 3];
    let e = build(&TwinInput {
        points: &pts,
        weights: &[1.0],
        voxel_m: 0.5,
        ground_z: 0.0,
        views: &[],
    })
    .unwrap_err();
    assert!(e.to_string().contains("weights"), "{e}");
    let e = build(&TwinInput {
        points: &pts,
        weights: &[1.0; 3],
        voxel_m: f64::NAN,
        ground_z: 0.0,
        views: &[],
    })
    .unwrap_err();
    assert!(e.to_string().contains("voxel_m"), "{e}");
}
