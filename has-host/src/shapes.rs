//! Shape generators: buildings (boxes with flat, pitched or sawtooth roofs, optionally yawed),
//! ground rectangles, vertical cylinders, and small helpers (translate, area, volume).
//!
//! Every generator returns an [`Object`] whose triangles are wound counter-clockwise seen from
//! outside, so the geometric normal `(v1 − v0) × (v2 − v0)` points out of the solid (up for the
//! ground). Units are metres; yaw is in radians, counter-clockwise about +z seen from above.
//!
//! A building is described in its *local* frame: footprint `size.x` along local x by `size.y`
//! along local y, centred on `base_center` (x, y of the footprint centre, z of the base), walls
//! `size.z` high up to the eaves, roof above the eaves. The local frame is then rotated by
//! `yaw_rad` about the vertical axis through `base_center`. Buildings standing on a ground plane
//! need no bottom face (it would only be hit from below the ground); [`Building::bottom`] adds it
//! to make a closed solid.

use glam::{Vec2, Vec3};

use crate::material::Material;
use crate::scene::Object;

/// A horizontal axis of a building's local frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    /// Local x (the `size.x` side).
    X,
    /// Local y (the `size.y` side).
    Y,
}

/// A horizontal direction in a building's local frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// +x (local).
    PosX,
    /// −x (local).
    NegX,
    /// +y (local).
    PosY,
    /// −y (local).
    NegY,
}

impl Direction {
    fn axis(self) -> Axis {
        match self {
            Direction::PosX | Direction::NegX => Axis::X,
            Direction::PosY | Direction::NegY => Axis::Y,
        }
    }

    fn positive(self) -> bool {
        matches!(self, Direction::PosX | Direction::PosY)
    }
}

/// Roof of a [`Building`]; heights are metres above the eaves (`size.z`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Roof {
    /// Flat roof at the eaves.
    Flat,
    /// Gable roof: two slopes meeting at a ridge that runs along `ridge` through the middle of
    /// the footprint, `height` above the eaves; the two walls across the ridge are gables.
    Pitched {
        /// Axis the ridge runs along.
        ridge: Axis,
        /// Ridge height above the eaves, metres (> 0).
        height: f32,
    },
    /// Sawtooth (north-light) roof: `teeth` equal teeth repeating along `facing`'s axis, each a
    /// slope rising by `height` toward `facing` followed by a vertical face (the glazing) that
    /// looks toward `facing`.
    Sawtooth {
        /// Number of teeth (≥ 1).
        teeth: u32,
        /// Tooth height above the eaves, metres (> 0).
        height: f32,
        /// Direction the vertical faces look (and the slopes rise toward).
        facing: Direction,
    },
}

/// A building: a box footprint with walls and a roof. See the module docs for the frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Building {
    /// Footprint centre (x, y) and base height (z), metres.
    pub base_center: Vec3,
    /// Footprint along local x, along local y, and eave (wall) height, metres (all > 0).
    pub size: Vec3,
    /// Rotation about the vertical through `base_center`, radians, counter-clockwise from above.
    pub yaw_rad: f32,
    /// Roof shape.
    pub roof: Roof,
    /// Whether to add the bottom face (closed solid).
    pub bottom: bool,
}

/// Bad shape parameters.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ShapeError {
    /// A length that must be positive and finite was not.
    #[error("{shape} '{name}': {field} must be positive and finite, got {value}")]
    NotPositive {
        /// Shape kind (`"building"`, `"ground"`, `"cylinder"`).
        shape: &'static str,
        /// Object name.
        name: String,
        /// Parameter name.
        field: &'static str,
        /// Offending value.
        value: f64,
    },
    /// A coordinate or angle was NaN or infinite.
    #[error("{shape} '{name}': {field} must be finite, got {value}")]
    NotFinite {
        /// Shape kind.
        shape: &'static str,
        /// Object name.
        name: String,
        /// Parameter name.
        field: &'static str,
        /// Offending value.
        value: f64,
    },
    /// A count was out of range.
    #[error("{shape} '{name}': {field} must be at least {min}, got {value}")]
    TooFew {
        /// Shape kind.
        shape: &'static str,
        /// Object name.
        name: String,
        /// Parameter name.
        field: &'static str,
        /// Smallest allowed value.
        min: u32,
        /// Offending value.
        value: u32,
    },
    /// A count whose triangles would not fit in memory ([`crate::memory::check_size`]).
    #[error("{shape} '{name}': {source}")]
    TooLarge {
        /// Shape kind.
        shape: &'static str,
        /// Object name.
        name: String,
        /// The count, its estimate and the room.
        source: crate::memory::TooLarge,
    },
}

/// Bytes a generated triangle costs by the time a scene is traced or imaged: its three corners
/// (36 B), the scene's copy with its normal and object index, its share of the bounding-volume
/// hierarchy and of the facet and scatterer tables; generous, so that a count the guard passes
/// fits.
pub(crate) const BYTES_PER_TRIANGLE: f64 = 256.0;

struct Check<'a> {
    shape: &'static str,
    name: &'a str,
}

impl Check<'_> {
    fn positive(&self, field: &'static str, v: f32) -> Result<(), ShapeError> {
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            Err(ShapeError::NotPositive {
                shape: self.shape,
                name: self.name.to_string(),
                field,
                value: v as f64,
            })
        }
    }

    fn finite(&self, field: &'static str, v: f32) -> Result<(), ShapeError> {
        if v.is_finite() {
            Ok(())
        } else {
            Err(ShapeError::NotFinite {
                shape: self.shape,
                name: self.name.to_string(),
                field,
                value: v as f64,
            })
        }
    }

    fn vec3(&self, fields: [&'static str; 3], v: Vec3) -> Result<(), ShapeError> {
        for (f, c) in fields.into_iter().zip(v.to_array()) {
            self.finite(f, c)?;
        }
        Ok(())
    }

    /// Refuses `field` = `value` when the `triangles` it generates would not fit in memory.
    fn size(
        &self,
        field: &'static str,
        value: impl std::fmt::Debug,
        triangles: f64,
    ) -> Result<(), ShapeError> {
        crate::memory::check_size(field, format!("{value:?}"), triangles * BYTES_PER_TRIANGLE)
            .map_err(|source| ShapeError::TooLarge {
                shape: self.shape,
                name: self.name.to_string(),
                source,
            })
    }

    fn at_least(&self, field: &'static str, v: u32, min: u32) -> Result<(), ShapeError> {
        if v >= min {
            Ok(())
        } else {
            Err(ShapeError::TooFew {
                shape: self.shape,
                name: self.name.to_string(),
                field,
                min,
                value: v,
            })
        }
    }
}

/// Appends the two triangles of quad `a b c d` (in order around it), wound so that their normal
/// has a positive component along `outward`.
fn push_quad(out: &mut Vec<[Vec3; 3]>, q: [Vec3; 4], outward: Vec3) {
    push_tri(out, [q[0], q[1], q[2]], outward);
    push_tri(out, [q[0], q[2], q[3]], outward);
}

/// Appends a triangle, flipping its winding if its normal points against `outward`. Degenerate
/// triangles (zero area) are dropped.
fn push_tri(out: &mut Vec<[Vec3; 3]>, t: [Vec3; 3], outward: Vec3) {
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    if n.length_squared() == 0.0 {
        return;
    }
    if n.dot(outward) >= 0.0 {
        out.push(t);
    } else {
        out.push([t[0], t[2], t[1]]);
    }
}

/// Top outline of the roof profile: points `(u, z)` with non-decreasing `u` from `0` to `len_u`,
/// `z` measured from the base. Vertical steps appear as two points with equal `u`.
fn roof_profile(roof: Roof, len_u: f32, eave: f32) -> Vec<Vec2> {
    match roof {
        Roof::Flat => vec![Vec2::new(0.0, eave), Vec2::new(len_u, eave)],
        Roof::Pitched { height, .. } => {
            vec![
                Vec2::new(0.0, eave),
                Vec2::new(0.5 * len_u, eave + height),
                Vec2::new(len_u, eave),
            ]
        }
        Roof::Sawtooth {
            teeth,
            height,
            facing,
        } => {
            let n = teeth.max(1);
            let pitch = len_u / n as f32;
            let mut p = Vec::with_capacity(2 * n as usize + 1);
            p.push(Vec2::new(0.0, eave));
            for k in 1..=n {
                let u = if k == n { len_u } else { pitch * k as f32 };
                p.push(Vec2::new(u, eave + height));
                if k < n {
                    p.push(Vec2::new(u, eave));
                }
            }
            if !facing.positive() {
                // Mirror u → len_u − u and restore increasing order.
                p = p
                    .into_iter()
                    .rev()
                    .map(|q| Vec2::new(len_u - q.x, q.y))
                    .collect();
            }
            p
        }
    }
}

/// Generates a building. Errors name the object and the offending parameter.
pub fn building(
    name: impl Into<String>,
    material: Material,
    b: &Building,
) -> Result<Object, ShapeError> {
    let name = name.into();
    let c = Check {
        shape: "building",
        name: &name,
    };
    c.vec3(
        ["base_center.x", "base_center.y", "base_center.z"],
        b.base_center,
    )?;
    c.positive("size.x", b.size.x)?;
    c.positive("size.y", b.size.y)?;
    c.positive("size.z", b.size.z)?;
    c.finite("yaw", b.yaw_rad)?;
    // The profile runs along `u_axis`; the solid is its extrusion along the other axis.
    let u_axis = match b.roof {
        Roof::Flat => Axis::X,
        Roof::Pitched { ridge, height } => {
            c.positive("roof.height", height)?;
            // Profile across the ridge.
            match ridge {
                Axis::X => Axis::Y,
                Axis::Y => Axis::X,
            }
        }
        Roof::Sawtooth {
            teeth,
            height,
            facing,
        } => {
            c.at_least("roof.teeth", teeth, 1)?;
            // Each tooth: two steps of the profile, each a roof quad and two gable quads.
            c.size("roof.teeth", teeth, 8.0 * teeth as f64)?;
            c.positive("roof.height", height)?;
            facing.axis()
        }
    };
    let (len_u, len_v) = match u_axis {
        Axis::X => (b.size.x, b.size.y),
        Axis::Y => (b.size.y, b.size.x),
    };
    let profile = roof_profile(b.roof, len_u, b.size.z);

    // Local (u, v, z) → world. u, v ∈ [0, len] are shifted to be centred on the footprint.
    let (sin, cos) = b.yaw_rad.sin_cos();
    let half = Vec2::new(b.size.x, b.size.y) * 0.5;
    let to_world = |u: f32, v: f32, z: f32| -> Vec3 {
        let (x, y) = match u_axis {
            Axis::X => (u, v),
            Axis::Y => (v, u),
        };
        let lx = x - half.x;
        let ly = y - half.y;
        b.base_center + Vec3::new(cos * lx - sin * ly, sin * lx + cos * ly, z)
    };
    let dir_world = |du: f32, dv: f32, dz: f32| -> Vec3 {
        let (x, y) = match u_axis {
            Axis::X => (du, dv),
            Axis::Y => (dv, du),
        };
        Vec3::new(cos * x - sin * y, sin * x + cos * y, dz)
    };

    let mut tris = Vec::new();
    // Gable / end caps at v = 0 (outward −v) and v = len_v (outward +v): vertical strips under
    // each roof segment.
    for (v, sign) in [(0.0, -1.0f32), (len_v, 1.0)] {
        let out = dir_world(0.0, sign, 0.0);
        for w in profile.windows(2) {
            let (p, q) = (w[0], w[1]);
            if q.x <= p.x {
                continue;
            }
            push_quad(
                &mut tris,
                [
                    to_world(p.x, v, 0.0),
                    to_world(q.x, v, 0.0),
                    to_world(q.x, v, q.y),
                    to_world(p.x, v, p.y),
                ],
                out,
            );
        }
    }
    // Roof segments (slopes, flats and vertical steps), extruded along v.
    for w in profile.windows(2) {
        let (p, q) = (w[0], w[1]);
        let d = q - p;
        // Left normal of the segment direction in the (u, z) plane points out of the solid.
        let out = dir_world(-d.y, 0.0, d.x);
        push_quad(
            &mut tris,
            [
                to_world(p.x, 0.0, p.y),
                to_world(q.x, 0.0, q.y),
                to_world(q.x, len_v, q.y),
                to_world(p.x, len_v, p.y),
            ],
            out,
        );
    }
    // End walls at u = 0 and u = len_u, from the base to the first / last profile point.
    let first = profile[0];
    let last = profile[profile.len() - 1];
    for (u, top, sign) in [(0.0, first.y, -1.0f32), (len_u, last.y, 1.0)] {
        push_quad(
            &mut tris,
            [
                to_world(u, 0.0, 0.0),
                to_world(u, len_v, 0.0),
                to_world(u, len_v, top),
                to_world(u, 0.0, top),
            ],
            dir_world(sign, 0.0, 0.0),
        );
    }
    if b.bottom {
        push_quad(
            &mut tris,
            [
                to_world(0.0, 0.0, 0.0),
                to_world(len_u, 0.0, 0.0),
                to_world(len_u, len_v, 0.0),
                to_world(0.0, len_v, 0.0),
            ],
            Vec3::NEG_Z,
        );
    }
    Ok(Object {
        thickness_m: None,
        name,
        material,
        triangles: tris,
    })
}

/// The meshing proxy building: 40 m × 24 m × 10 m, a sawtooth roof of 4 teeth 3 m high facing
/// +x, yawed 0.3 rad, open at the bottom (a sensed building standing on the ground), concrete.
/// One definition for the meshing test, the `mesh_fixture` example and `has-sim bench mesh`.
///
/// # Errors
/// None in practice (fixed valid parameters); [`ShapeError`] from [`building`].
pub fn mesh_proxy_building() -> Result<Object, ShapeError> {
    building(
        "factory",
        Material::Concrete,
        &Building {
            base_center: Vec3::ZERO,
            size: Vec3::new(40.0, 24.0, 10.0),
            yaw_rad: 0.3,
            roof: Roof::Sawtooth {
                teeth: 4,
                height: 3.0,
                facing: Direction::PosX,
            },
            bottom: false,
        },
    )
}

/// A closed axis-aligned box from `min` to `max` (all six faces).
pub fn axis_box(
    name: impl Into<String>,
    material: Material,
    min: Vec3,
    max: Vec3,
) -> Result<Object, ShapeError> {
    let size = max - min;
    building(
        name,
        material,
        &Building {
            base_center: Vec3::new(0.5 * (min.x + max.x), 0.5 * (min.y + max.y), min.z),
            size,
            yaw_rad: 0.0,
            roof: Roof::Flat,
            bottom: true,
        },
    )
}

/// A horizontal ground rectangle `[min.x, max.x] × [min.y, max.y]` at height `z`, facing up,
/// split into `cells.0 × cells.1` cells (two triangles each).
pub fn ground(
    name: impl Into<String>,
    material: Material,
    min: Vec2,
    max: Vec2,
    z: f32,
    cells: (u32, u32),
) -> Result<Object, ShapeError> {
    let name = name.into();
    let c = Check {
        shape: "ground",
        name: &name,
    };
    c.finite("min.x", min.x)?;
    c.finite("min.y", min.y)?;
    c.finite("z", z)?;
    c.positive("size.x", max.x - min.x)?;
    c.positive("size.y", max.y - min.y)?;
    c.at_least("cells.x", cells.0, 1)?;
    c.at_least("cells.y", cells.1, 1)?;
    c.size(
        "cells",
        [cells.0, cells.1],
        2.0 * cells.0 as f64 * cells.1 as f64,
    )?;
    let (nx, ny) = cells;
    let step = (max - min) / Vec2::new(nx as f32, ny as f32);
    let at = |i: u32, j: u32| -> Vec3 {
        // Exact edges at the last index, so that neighbouring rectangles meet without gaps.
        let x = if i == nx {
            max.x
        } else {
            min.x + step.x * i as f32
        };
        let y = if j == ny {
            max.y
        } else {
            min.y + step.y * j as f32
        };
        Vec3::new(x, y, z)
    };
    let mut tris = Vec::with_capacity(2 * (nx * ny) as usize);
    for j in 0..ny {
        for i in 0..nx {
            push_quad(
                &mut tris,
                [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)],
                Vec3::Z,
            );
        }
    }
    Ok(Object {
        thickness_m: None,
        name,
        material,
        triangles: tris,
    })
}

/// A heightfield over `[min.x, max.x] × [min.y, max.y]`: `z = height(x, y)` sampled on a grid of
/// `cells.0 × cells.1` cells (two triangles each), facing up.
pub fn heightfield(
    name: impl Into<String>,
    material: Material,
    min: Vec2,
    max: Vec2,
    cells: (u32, u32),
    height: impl Fn(f32, f32) -> f32,
) -> Result<Object, ShapeError> {
    let mut g = ground(name, material, min, max, 0.0, cells)?;
    for t in &mut g.triangles {
        for v in t.iter_mut() {
            v.z = height(v.x, v.y);
        }
    }
    let c = Check {
        shape: "heightfield",
        name: &g.name,
    };
    for v in g.triangles.iter().flatten() {
        c.finite("height(x, y)", v.z)?;
    }
    Ok(g)
}

/// A vertical cylinder standing on `base_center`, approximated by a `segments`-sided prism
/// (vertices on the circle), with top and bottom caps if `caps`.
pub fn cylinder(
    name: impl Into<String>,
    material: Material,
    base_center: Vec3,
    radius: f32,
    height: f32,
    segments: u32,
    caps: bool,
) -> Result<Object, ShapeError> {
    let name = name.into();
    let c = Check {
        shape: "cylinder",
        name: &name,
    };
    c.vec3(
        ["base_center.x", "base_center.y", "base_center.z"],
        base_center,
    )?;
    c.positive("radius", radius)?;
    c.positive("height", height)?;
    c.at_least("segments", segments, 3)?;
    c.size("segments", segments, 4.0 * segments as f64)?;
    let ring = |k: u32| {
        let a = std::f32::consts::TAU * (k % segments) as f32 / segments as f32;
        Vec3::new(radius * a.cos(), radius * a.sin(), 0.0)
    };
    let up = Vec3::new(0.0, 0.0, height);
    let mut tris = Vec::with_capacity(4 * segments as usize);
    for k in 0..segments {
        let (p, q) = (ring(k), ring(k + 1));
        let out = (p + q).normalize_or_zero();
        let (p, q) = (base_center + p, base_center + q);
        push_quad(&mut tris, [p, q, q + up, p + up], out);
        if caps {
            push_tri(&mut tris, [base_center + up, p + up, q + up], Vec3::Z);
            push_tri(&mut tris, [base_center, q, p], Vec3::NEG_Z);
        }
    }
    Ok(Object {
        thickness_m: None,
        name,
        material,
        triangles: tris,
    })
}

/// Moves every vertex of `obj` by `offset` metres.
pub fn translate(obj: &mut Object, offset: Vec3) {
    for t in &mut obj.triangles {
        for v in t {
            *v += offset;
        }
    }
}

/// Turns `obj`'s vertices by `rad` radians counter-clockwise (seen from above) about the vertical
/// axis through x = y = 0; heights are kept. The sine and cosine are taken in f64 once.
pub fn rotate_z(obj: &mut Object, rad: f64) {
    let (sin, cos) = rad.sin_cos();
    for t in &mut obj.triangles {
        for v in t {
            let (x, y) = (v.x as f64, v.y as f64);
            v.x = (cos * x - sin * y) as f32;
            v.y = (sin * x + cos * y) as f32;
        }
    }
}

/// `obj` moved by `offset` metres.
pub fn translated(mut obj: Object, offset: Vec3) -> Object {
    translate(&mut obj, offset);
    obj
}

/// Total area of the triangles, m².
pub fn surface_area(tris: &[[Vec3; 3]]) -> f64 {
    tris.iter()
        .map(|t| {
            0.5 * (t[1] - t[0])
                .as_dvec3()
                .cross((t[2] - t[0]).as_dvec3())
                .length()
        })
        .sum()
}

/// Signed volume enclosed by the triangles (divergence theorem, `Σ v0 · (v1 × v2) / 6`), m³;
/// positive for a closed outward-wound surface.
pub fn signed_volume(tris: &[[Vec3; 3]]) -> f64 {
    tris.iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| v.as_dvec3());
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn centroid(t: &[Vec3; 3]) -> Vec3 {
        (t[0] + t[1] + t[2]) / 3.0
    }

    /// For a convex solid, every outward normal points away from an interior point.
    fn assert_outward_from(tris: &[[Vec3; 3]], inside: Vec3) {
        for t in tris {
            let n = (t[1] - t[0]).cross(t[2] - t[0]);
            assert!(n.dot(centroid(t) - inside) > 0.0, "inward face {t:?}");
        }
    }

    fn bld(size: Vec3, yaw: f32, roof: Roof, bottom: bool) -> Object {
        building(
            "b",
            Material::Concrete,
            &Building {
                base_center: Vec3::new(3.0, -7.0, 1.5),
                size,
                yaw_rad: yaw,
                roof,
                bottom,
            },
        )
        .unwrap()
    }

    // Volumes and areas are sums of O(10) f64 products of f32 coordinates of magnitude ≤ 30 m;
    // f32 rounding of the rotated vertices (relative 6e-8 on 30 m → 2e-6 m) times face areas of
    // ≤ 1000 m² bounds the error by ~1e-2 m³ even summed over all faces; 1e-3 relative is safe.

    #[test]
    fn closed_box_volume_equals_w_d_h_and_faces_point_outward() {
        for yaw in [0.0, 0.3, -2.0] {
            let b = bld(Vec3::new(20.0, 10.0, 6.0), yaw, Roof::Flat, true);
            assert_eq!(b.triangles.len(), 12);
            let v = signed_volume(&b.triangles);
            assert!((v - 1200.0).abs() < 1.2, "volume {v}");
            assert_outward_from(&b.triangles, Vec3::new(3.0, -7.0, 4.5));
            let a = surface_area(&b.triangles);
            let want = 2.0 * (200.0 + 60.0 + 120.0);
            assert!((a - want).abs() < 1e-3 * want, "area {a}");
        }
    }

    #[test]
    fn pitched_roof_volume_adds_the_prism_and_is_outward() {
        for (ridge, w_across) in [(Axis::X, 10.0), (Axis::Y, 20.0)] {
            let b = bld(
                Vec3::new(20.0, 10.0, 6.0),
                0.7,
                Roof::Pitched { ridge, height: 4.0 },
                true,
            );
            // Box 20·10·6 plus triangular prism ½·w_across·4·(length along ridge).
            let along = 200.0 / w_across;
            let want = 1200.0 + 0.5 * w_across * 4.0 * along;
            let v = signed_volume(&b.triangles);
            assert!(
                (v - want).abs() < 1e-3 * want,
                "{ridge:?}: volume {v} want {want}"
            );
            // Convex: every face faces away from an interior point.
            assert_outward_from(&b.triangles, Vec3::new(3.0, -7.0, 5.0));
            let top = b
                .triangles
                .iter()
                .flatten()
                .map(|v| v.z)
                .fold(f32::MIN, f32::max);
            assert!((top - (1.5 + 6.0 + 4.0)).abs() < 1e-5);
        }
    }

    #[test]
    fn sawtooth_roof_area_and_volume_match_the_profile() {
        for facing in [
            Direction::PosX,
            Direction::NegX,
            Direction::PosY,
            Direction::NegY,
        ] {
            let (n, th) = (4u32, 3.0f32);
            let b = bld(
                Vec3::new(40.0, 24.0, 8.0),
                0.25,
                Roof::Sawtooth {
                    teeth: n,
                    height: th,
                    facing,
                },
                true,
            );
            let (len_u, len_v) = match facing.axis() {
                Axis::X => (40.0f64, 24.0f64),
                Axis::Y => (24.0, 40.0),
            };
            let pitch = len_u / n as f64;
            let th = th as f64;
            // Each tooth adds a triangular prism ½·pitch·th·len_v.
            let want_v = 40.0 * 24.0 * 8.0 + n as f64 * 0.5 * pitch * th * len_v;
            let v = signed_volume(&b.triangles);
            assert!(
                (v - want_v).abs() < 1e-3 * want_v,
                "{facing:?}: {v} vs {want_v}"
            );
            // Roof surface: n slopes of hypot(pitch, th)·len_v plus n−1 inner vertical faces.
            let roof: Vec<_> = b
                .triangles
                .iter()
                .copied()
                .filter(|t| t.iter().all(|v| v.z >= 1.5 + 8.0 - 1e-4))
                .collect();
            let want_a = n as f64 * pitch.hypot(th) * len_v + (n - 1) as f64 * th * len_v;
            let a = surface_area(&roof);
            assert!(
                (a - want_a).abs() < 1e-3 * want_a,
                "{facing:?}: {a} vs {want_a}"
            );
            // Vertical roof faces look toward `facing` (rotated by the yaw).
            let (s, c) = 0.25f32.sin_cos();
            let local = match facing {
                Direction::PosX => Vec3::X,
                Direction::NegX => Vec3::NEG_X,
                Direction::PosY => Vec3::Y,
                Direction::NegY => Vec3::NEG_Y,
            };
            let world = Vec3::new(c * local.x - s * local.y, s * local.x + c * local.y, 0.0);
            let mut vertical = 0;
            for t in &roof {
                let nrm = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
                if nrm.z.abs() < 1e-4 {
                    vertical += 1;
                    assert!(nrm.dot(world) > 0.999, "{facing:?}: {nrm}");
                } else {
                    assert!(nrm.z > 0.0);
                }
            }
            assert_eq!(vertical, 2 * (n as usize - 1));
        }
    }

    #[test]
    fn open_bottom_building_leaves_out_exactly_the_base() {
        let closed = bld(Vec3::new(5.0, 4.0, 3.0), 0.0, Roof::Flat, true);
        let open = bld(Vec3::new(5.0, 4.0, 3.0), 0.0, Roof::Flat, false);
        assert_eq!(closed.triangles.len() - open.triangles.len(), 2);
        let da = surface_area(&closed.triangles) - surface_area(&open.triangles);
        assert!((da - 20.0).abs() < 1e-4);
        assert!(open.triangles.iter().all(|t| t.iter().any(|v| v.z > 1.5)));
    }

    #[test]
    fn ground_is_up_facing_and_covers_the_rectangle() {
        let g = ground(
            "g",
            Material::MediumDryGround,
            Vec2::new(-10.0, -5.0),
            Vec2::new(30.0, 15.0),
            0.5,
            (4, 3),
        )
        .unwrap();
        assert_eq!(g.triangles.len(), 24);
        assert!((surface_area(&g.triangles) - 800.0).abs() < 1e-3);
        for t in &g.triangles {
            assert!((t[1] - t[0]).cross(t[2] - t[0]).z > 0.0);
        }
    }

    #[test]
    fn heightfield_follows_the_function_and_faces_up() {
        let h = heightfield(
            "hf",
            Material::WetGround,
            Vec2::new(0.0, 0.0),
            Vec2::new(10.0, 10.0),
            (5, 5),
            |x, y| 0.1 * x + 0.2 * y,
        )
        .unwrap();
        assert_eq!(h.triangles.len(), 50);
        for t in &h.triangles {
            assert!((t[1] - t[0]).cross(t[2] - t[0]).z > 0.0);
            for v in t {
                assert_eq!(v.z, 0.1 * v.x + 0.2 * v.y);
            }
        }
        let e = heightfield(
            "hf",
            Material::WetGround,
            Vec2::ZERO,
            Vec2::ONE,
            (1, 1),
            |_, _| f32::NAN,
        )
        .unwrap_err();
        assert!(
            e.to_string().contains("heightfield 'hf': height(x, y)"),
            "{e}"
        );
    }

    #[test]
    fn cylinder_volume_is_the_inscribed_prism() {
        let (r, h, n) = (3.0f32, 3.0f32, 32u32);
        let cyl = cylinder(
            "t",
            Material::Metal,
            Vec3::new(5.0, 5.0, 0.0),
            r,
            h,
            n,
            true,
        )
        .unwrap();
        // Regular n-gon area = ½·n·r²·sin(2π/n).
        let want =
            0.5 * n as f64 * (r * r) as f64 * (std::f64::consts::TAU / n as f64).sin() * h as f64;
        let v = signed_volume(&cyl.triangles);
        assert!((v - want).abs() < 1e-4 * want, "{v} vs {want}");
        assert_outward_from(&cyl.triangles, Vec3::new(5.0, 5.0, 1.5));
    }

    #[test]
    fn translate_moves_every_vertex_and_keeps_volume() {
        let b = bld(Vec3::new(2.0, 3.0, 4.0), 0.0, Roof::Flat, true);
        let v0 = signed_volume(&b.triangles);
        let m = translated(b.clone(), Vec3::new(100.0, -50.0, 2.0));
        for (t, u) in b.triangles.iter().zip(&m.triangles) {
            for (p, q) in t.iter().zip(u) {
                assert_eq!(*q - *p, Vec3::new(100.0, -50.0, 2.0));
            }
        }
        assert!((signed_volume(&m.triangles) - v0).abs() < 1e-2);
    }

    #[test]
    fn bad_parameters_are_errors_naming_field_and_value() {
        let e = building(
            "hall",
            Material::Concrete,
            &Building {
                base_center: Vec3::ZERO,
                size: Vec3::new(10.0, -2.0, 5.0),
                yaw_rad: 0.0,
                roof: Roof::Flat,
                bottom: false,
            },
        )
        .unwrap_err();
        let s = e.to_string();
        assert!(
            s.contains("hall") && s.contains("size.y") && s.contains("-2"),
            "{s}"
        );
        let e = building(
            "hall",
            Material::Concrete,
            &Building {
                base_center: Vec3::new(f32::NAN, 0.0, 0.0),
                size: Vec3::ONE,
                yaw_rad: 0.0,
                roof: Roof::Flat,
                bottom: false,
            },
        )
        .unwrap_err();
        assert!(e.to_string().contains("base_center.x"), "{e}");
        let e = building(
            "hall",
            Material::Concrete,
            &Building {
                base_center: Vec3::ZERO,
                size: Vec3::ONE,
                yaw_rad: 0.0,
                roof: Roof::Sawtooth {
                    teeth: 0,
                    height: 1.0,
                    facing: Direction::PosX,
                },
                bottom: false,
            },
        )
        .unwrap_err();
        assert!(e.to_string().contains("roof.teeth"), "{e}");
        let e = cylinder("t", Material::Metal, Vec3::ZERO, 1.0, 1.0, 2, true).unwrap_err();
        assert!(e.to_string().contains("segments"), "{e}");
        let e = cylinder("t", Material::Metal, Vec3::ZERO, 0.0, 1.0, 8, true).unwrap_err();
        assert!(e.to_string().contains("radius"), "{e}");
        let e = ground(
            "g",
            Material::Concrete,
            Vec2::ZERO,
            Vec2::new(1.0, 1.0),
            0.0,
            (0, 1),
        )
        .unwrap_err();
        assert!(e.to_string().contains("cells.x"), "{e}");
    }
    #[test]
    fn counts_whose_triangles_would_not_fit_are_refused_before_allocating() {
        if crate::memory::room().is_none() {
            return;
        }
        let e = ground(
            "g",
            Material::Concrete,
            Vec2::ZERO,
            Vec2::new(1.0, 1.0),
            0.0,
            (200_000, 200_000),
        )
        .unwrap_err();
        assert!(matches!(e, ShapeError::TooLarge { .. }), "{e}");
        assert!(e.to_string().contains("cells: [200000, 200000]"), "{e}");
        let e = cylinder(
            "t",
            Material::Metal,
            Vec3::ZERO,
            1.0,
            1.0,
            4_000_000_000,
            true,
        )
        .unwrap_err();
        assert!(e.to_string().contains("segments: 4000000000 needs"), "{e}");
        let e = building(
            "hall",
            Material::Concrete,
            &Building {
                base_center: Vec3::ZERO,
                size: Vec3::ONE,
                yaw_rad: 0.0,
                roof: Roof::Sawtooth {
                    teeth: 4_000_000_000,
                    height: 1.0,
                    facing: Direction::PosX,
                },
                bottom: false,
            },
        )
        .unwrap_err();
        assert!(
            e.to_string().contains("roof.teeth: 4000000000 needs"),
            "{e}"
        );
    }
}
