//! A scene: named objects made of triangles, each object one [`Material`], and a BVH over all
//! triangles for closest-hit and visibility queries.
//!
//! Triangles are stored flat (`triangles[i]`, owned by `objects[tri_object[i]]`); normals follow
//! the counter-clockwise winding `(v1 − v0) × (v2 − v0)`, but queries are two-sided. The BVH is
//! obvhs' compressed-wide BVH (CWBVH). Batched queries run across rays with rayon. Distances in
//! metres.

use std::time::Duration;

use glam::{DVec3, Vec3, Vec3A};
use obvhs::{
    cwbvh::{builder::build_cwbvh_from_tris, CwBvh},
    ray::{Ray, RayHit},
    triangle::Triangle,
    BvhBuildParams,
};
use rand::{Rng, SeedableRng};
use rayon::prelude::*;

use crate::material::Material;

/// "Straight up" for probing what covers a point: tilted by about 1.4° so that the ray neither
/// runs along a vertical wall nor passes exactly through the shared edge of two triangles
/// (a roof's diagonal over a symmetric point), where a hit test may miss.
pub const PROBE_UP: Vec3 = Vec3::new(0.013, 0.021, 0.999_694_7);

/// Largest coordinate magnitude (m) of a position the host accepts (a transmitter, a receiver,
/// a point of a cloud): scenes and clouds are `f32`, whose spacing at 10⁶ m is 6 cm, two
/// wavelengths at 10 GHz; farther out a ray test or a voxel resolves nothing of a building.
pub const MAX_COORD_M: f64 = 1e6;

/// Offset, in metres, by which secondary rays start off a surface and visibility rays stop
/// short of their end point, so that a surface does not hide itself.
pub const SURFACE_EPS_M: f32 = 1e-3;

/// One object of a scene.
#[derive(Clone, Debug)]
pub struct Object {
    /// Name, unique within the scene (e.g. `"factory"`, `"ground"`).
    pub name: String,
    /// Radio material of every face.
    pub material: Material,
    /// Thickness of the material, metres: each face reflects as a slab of it
    /// ([`crate::propagation::slab_coefficients`], as Sionna RT applies a material's
    /// `thickness`); `None`, an infinitely thick material (the half-space,
    /// [`crate::propagation::fresnel_reflection`]).
    pub thickness_m: Option<f64>,
    /// Faces, counter-clockwise seen from outside, in metres.
    pub triangles: Vec<[Vec3; 3]>,
}

impl Object {
    /// Axis-aligned bounds `(min, max)` of the object's vertices, metres; `(+∞, −∞)` without
    /// triangles.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for v in self.triangles.iter().flatten() {
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
        (lo, hi)
    }
}

/// Result of a closest-hit query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the (unit) ray direction, metres.
    pub t: f32,
    /// Index into [`Scene::triangles`].
    pub triangle: u32,
    /// Index into [`Scene::objects`].
    pub object: u32,
    /// Hit point.
    pub point: Vec3,
    /// Unit geometric normal of the hit face (winding order, not flipped toward the ray).
    pub normal: Vec3,
}

/// Triangles of several objects with a BVH over them.
pub struct Scene {
    /// The objects (names, materials, faces as given).
    pub objects: Vec<Object>,
    /// Every triangle of every object, flattened.
    pub triangles: Vec<Triangle>,
    /// Owning object of each triangle.
    pub tri_object: Vec<u32>,
    bvh: CwBvh,
    /// Time spent building the BVH.
    pub build_time: Duration,
}

/// Why a scene could not be built.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A vertex coordinate was NaN or infinite.
    #[error("object '{object}': vertex {vertex} of triangle {triangle} is not finite ({value:?})")]
    NonFiniteVertex {
        /// Object name.
        object: String,
        /// Triangle index within the object.
        triangle: usize,
        /// Vertex 0..3.
        vertex: usize,
        /// The vertex.
        value: Vec3,
    },
    /// The scene has no triangles.
    #[error("scene has no triangles")]
    Empty,
}

impl Scene {
    /// Builds the scene and its BVH. Degenerate (zero-area) triangles are kept in `objects` but
    /// left out of the BVH; non-finite vertices are an error.
    pub fn new(objects: Vec<Object>) -> Result<Scene, SceneError> {
        let mut triangles = Vec::new();
        let mut tri_object = Vec::new();
        for (oi, obj) in objects.iter().enumerate() {
            for (ti, tri) in obj.triangles.iter().enumerate() {
                for (vi, v) in tri.iter().enumerate() {
                    if !v.is_finite() {
                        return Err(SceneError::NonFiniteVertex {
                            object: obj.name.clone(),
                            triangle: ti,
                            vertex: vi,
                            value: *v,
                        });
                    }
                }
                if (tri[1] - tri[0]).cross(tri[2] - tri[0]).length_squared() <= 0.0 {
                    continue;
                }
                triangles.push(Triangle {
                    v0: tri[0].into(),
                    v1: tri[1].into(),
                    v2: tri[2].into(),
                });
                tri_object.push(oi as u32);
            }
        }
        if triangles.is_empty() {
            return Err(SceneError::Empty);
        }
        let start = std::time::Instant::now();
        let mut core = Duration::default();
        let bvh = build_cwbvh_from_tris(&triangles, BvhBuildParams::medium_build(), &mut core);
        let build_time = start.elapsed();
        Ok(Scene {
            objects,
            triangles,
            tri_object,
            bvh,
            build_time,
        })
    }

    /// Number of triangles in the BVH.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Material of triangle `tri`.
    pub fn material_of(&self, tri: u32) -> Material {
        self.objects[self.tri_object[tri as usize] as usize].material
    }

    /// Unit geometric normal of triangle `tri` (winding order).
    pub fn normal_of(&self, tri: u32) -> Vec3 {
        Vec3::from(self.triangles[tri as usize].compute_normal())
    }

    /// Closest hit along `origin + t·dir` for `t` in `[tmin, tmax]`; `dir` need not be unit
    /// length but `t` is then in units of `|dir|`.
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        let ray = Ray::new(Vec3A::from(origin), Vec3A::from(dir), tmin, tmax);
        let mut hit = RayHit::none();
        let tris = &self.triangles;
        let idx = &self.bvh.primitive_indices;
        if self
            .bvh
            .ray_traverse(ray, &mut hit, |r, id| tris[idx[id] as usize].intersect(r))
        {
            let tri = idx[hit.primitive_id as usize];
            Some(Hit {
                t: hit.t,
                triangle: tri,
                object: self.tri_object[tri as usize],
                point: origin + dir * hit.t,
                normal: self.normal_of(tri),
            })
        } else {
            None
        }
    }

    /// [`Scene::closest_hit`] ignoring every triangle for which `skip(triangle)` is true (e.g. the
    /// facet a reflected ray leaves from).
    pub fn closest_hit_skipping(
        &self,
        origin: Vec3,
        dir: Vec3,
        tmin: f32,
        tmax: f32,
        skip: impl Fn(u32) -> bool,
    ) -> Option<Hit> {
        let ray = Ray::new(Vec3A::from(origin), Vec3A::from(dir), tmin, tmax);
        let mut hit = RayHit::none();
        let tris = &self.triangles;
        let idx = &self.bvh.primitive_indices;
        if self.bvh.ray_traverse(ray, &mut hit, |r, id| {
            let tri = idx[id];
            if skip(tri) {
                f32::INFINITY
            } else {
                tris[tri as usize].intersect(r)
            }
        }) {
            let tri = idx[hit.primitive_id as usize];
            Some(Hit {
                t: hit.t,
                triangle: tri,
                object: self.tri_object[tri as usize],
                point: origin + dir * hit.t,
                normal: self.normal_of(tri),
            })
        } else {
            None
        }
    }

    /// True if the open segment from `a` to `b` (shortened by [`SURFACE_EPS_M`] at both ends)
    /// crosses no triangle.
    pub fn visible(&self, a: Vec3, b: Vec3) -> bool {
        let d = b - a;
        let len = d.length();
        if len <= 2.0 * SURFACE_EPS_M {
            return true;
        }
        let dir = d / len;
        let ray = Ray::new(
            Vec3A::from(a),
            Vec3A::from(dir),
            SURFACE_EPS_M,
            len - SURFACE_EPS_M,
        );
        let tris = &self.triangles;
        let idx = &self.bvh.primitive_indices;
        self.bvh
            .ray_traverse_miss(ray, |r, id| tris[idx[id] as usize].intersect(r))
    }

    /// The first object whose material's ITU-R P.2040 fit is not stated at `freq_hz`: its
    /// index and the stated range, GHz ([`Material::valid_range_ghz`]). Sionna RT refuses such
    /// a frequency too.
    pub fn material_outside(&self, freq_hz: f64) -> Option<(usize, (f64, f64))> {
        let g = freq_hz / 1e9;
        self.objects.iter().enumerate().find_map(|(i, o)| {
            let (lo, hi) = o.material.valid_range_ghz();
            (!(lo..=hi).contains(&g)).then_some((i, (lo, hi)))
        })
    }

    /// The object that encloses `p`, if any: `p` is inside a closed object, or under an open
    /// sheet such as the ground, when the ray straight up hits something and every one of five
    /// rays (up and four horizontal, tilted slightly off the axes so that none runs along a
    /// wall or through an edge) that hits something first meets a face from behind (the ray
    /// along the outward normal `(v1 − v0) × (v2 − v0)`). Returns the object of the upward hit.
    /// No ray looks down: a building's floor and the ground under it coincide, and which of the
    /// two a ray meets first is a tie.
    /// Under a bridge or an overhang the upward ray meets a face's front: not enclosed. Assumes
    /// outward normals, as the scene's shapes, OBJ/PLY meshes from the meshing and Sionna's
    /// scenes have.
    pub fn enclosing_object(&self, p: Vec3) -> Option<u32> {
        const DIRS: [[f32; 3]; 5] = [
            [PROBE_UP.x, PROBE_UP.y, PROBE_UP.z],
            [1.0, 0.019, 0.007],
            [-1.0, -0.023, 0.011],
            [0.015, 1.0, -0.009],
            [-0.021, -1.0, 0.013],
        ];
        let mut up = None;
        for (k, d) in DIRS.iter().enumerate() {
            let d = Vec3::from(*d).normalize();
            match self.closest_hit(p, d, 0.0, f32::INFINITY) {
                // From behind: the first (upward) one names the object.
                Some(h) if h.normal.dot(d) > 0.0 => up = up.or(Some(h.object)),
                Some(_) => return None,
                None if k == 0 => return None,
                None => {}
            }
        }
        up
    }

    /// [`Scene::closest_hit`] for many rays `(origin, unit dir)` at once, in parallel.
    pub fn closest_hits(&self, rays: &[(Vec3, Vec3)], tmax: f32) -> Vec<Option<Hit>> {
        rays.par_iter()
            .map(|&(o, d)| self.closest_hit(o, d, 0.0, tmax))
            .collect()
    }

    /// [`Scene::visible`] for many segments at once, in parallel.
    pub fn visible_many(&self, segments: &[(Vec3, Vec3)]) -> Vec<bool> {
        segments
            .par_iter()
            .map(|&(a, b)| self.visible(a, b))
            .collect()
    }

    /// Up to `n` positions drawn uniformly (ChaCha8 seeded with `seed`) in the horizontal
    /// rectangle `lo … hi` (x, y, metres) at height `z`, each rejected when a ray straight up
    /// (+z) from it hits the scene, i.e. inside or under an object. At most `1000·n` draws are
    /// made, so fewer than `n` come back when the rectangle is (almost) covered; none when it is
    /// empty or not finite. Deterministic for the seed: the UEs of the channel experiment
    /// ([`crate::scenario::ChannelSpec::ue_positions`]) and of the paths benchmark.
    pub fn uncovered_positions(
        &self,
        lo: [f64; 2],
        hi: [f64; 2],
        z: f64,
        n: usize,
        seed: u64,
    ) -> Vec<DVec3> {
        if !(0..2).all(|k| lo[k].is_finite() && hi[k].is_finite() && lo[k] < hi[k]) {
            return Vec::new();
        }
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut out = Vec::with_capacity(n);
        let mut tries = 0usize;
        while out.len() < n && tries < 1000 * n {
            tries += 1;
            let x = rng.random_range(lo[0]..hi[0]);
            let y = rng.random_range(lo[1]..hi[1]);
            let p = DVec3::new(x, y, z);
            if self
                .closest_hit(p.as_vec3(), Vec3::Z, 0.0, f32::INFINITY)
                .is_none()
            {
                out.push(p);
            }
        }
        out
    }

    /// Axis-aligned bounds `(min, max)` of all triangles.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for t in &self.triangles {
            for v in [t.v0, t.v1, t.v2] {
                lo = lo.min(v.into());
                hi = hi.max(v.into());
            }
        }
        (lo, hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(z: f32, half: f32) -> Vec<[Vec3; 3]> {
        let a = Vec3::new(-half, -half, z);
        let b = Vec3::new(half, -half, z);
        let c = Vec3::new(half, half, z);
        let d = Vec3::new(-half, half, z);
        vec![[a, b, c], [a, c, d]]
    }

    fn plate() -> Scene {
        Scene::new(vec![Object {
            thickness_m: None,
            name: "plate".into(),
            material: Material::Concrete,
            triangles: quad(0.0, 10.0),
        }])
        .unwrap()
    }

    #[test]
    fn closest_hit_finds_plate_below() {
        let s = plate();
        let h = s
            .closest_hit(Vec3::new(1.0, 2.0, 5.0), Vec3::NEG_Z, 0.0, f32::INFINITY)
            .unwrap();
        assert!((h.t - 5.0).abs() < 1e-5);
        assert!(h.point.z.abs() < 1e-5);
        assert_eq!(h.normal, Vec3::Z);
        assert_eq!(s.material_of(h.triangle), Material::Concrete);
        assert!(s
            .closest_hit(Vec3::new(1.0, 2.0, 5.0), Vec3::Z, 0.0, f32::INFINITY)
            .is_none());
    }

    #[test]
    fn a_point_inside_a_building_or_under_the_ground_is_enclosed_and_one_beside_or_below_a_bridge_is_not(
    ) {
        use crate::shapes::{axis_box, ground};
        let s = Scene::new(vec![
            ground(
                "ground",
                Material::Concrete,
                glam::Vec2::splat(-50.0),
                glam::Vec2::splat(50.0),
                0.0,
                (4, 4),
            )
            .unwrap(),
            axis_box(
                "hall",
                Material::Concrete,
                Vec3::ZERO,
                Vec3::new(10.0, 8.0, 6.0),
            )
            .unwrap(),
            axis_box(
                "bridge",
                Material::Concrete,
                Vec3::new(20.0, -5.0, 6.0),
                Vec3::new(24.0, 5.0, 7.0),
            )
            .unwrap(),
        ])
        .unwrap();
        let name = |p: Vec3| {
            s.enclosing_object(p)
                .map(|o| s.objects[o as usize].name.clone())
        };
        assert_eq!(name(Vec3::new(5.0, 4.0, 3.0)).as_deref(), Some("hall"));
        assert_eq!(name(Vec3::new(-20.0, 0.0, -2.0)).as_deref(), Some("ground"));
        assert_eq!(name(Vec3::new(22.0, 0.0, 6.5)).as_deref(), Some("bridge"));
        assert_eq!(name(Vec3::new(-5.0, 4.0, 3.0)), None);
        assert_eq!(name(Vec3::new(22.0, 0.0, 3.0)), None, "under the bridge");
        assert_eq!(name(Vec3::new(5.0, 4.0, 30.0)), None, "above the hall");
    }

    #[test]
    fn object_bounds_span_its_vertices() {
        let s = plate();
        let b = (Vec3::new(-10.0, -10.0, 0.0), Vec3::new(10.0, 10.0, 0.0));
        assert_eq!(s.objects[0].bounds(), b);
        assert_eq!(s.bounds(), b);
    }

    #[test]
    fn plate_blocks_visibility_between_its_sides() {
        let s = plate();
        assert!(!s.visible(Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.5, 0.0, -1.0)));
        assert!(s.visible(Vec3::new(0.0, 0.0, 1.0), Vec3::new(5.0, 0.0, 2.0)));
        // Points on the surface see each other along it is not asked; a point just above sees
        // a point on the surface (the end is shortened by SURFACE_EPS_M).
        assert!(s.visible(Vec3::new(0.0, 0.0, 1.0), Vec3::new(3.0, 0.0, 0.0)));
        let batch = s.visible_many(&[
            (Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.5, 0.0, -1.0)),
            (Vec3::new(0.0, 0.0, 1.0), Vec3::new(5.0, 0.0, 2.0)),
        ]);
        assert_eq!(batch, vec![false, true]);
    }

    #[test]
    fn uncovered_positions_avoid_what_is_overhead_and_stop_after_1000_draws_each() {
        // The plate covers |x|, |y| <= 10 at z = 0; draws at z = -1 under it are rejected.
        let s = plate();
        let p = s.uncovered_positions([-20.0, -20.0], [20.0, 20.0], -1.0, 200, 7);
        assert_eq!(p.len(), 200);
        assert!(p.iter().all(|q| q.x.abs() > 10.0 || q.y.abs() > 10.0));
        assert!(p
            .iter()
            .all(|q| q.z == -1.0 && q.x.abs() < 20.0 && q.y.abs() < 20.0));
        assert_eq!(
            p,
            s.uncovered_positions([-20.0, -20.0], [20.0, 20.0], -1.0, 200, 7)
        );
        assert!(s
            .uncovered_positions([-9.0, -9.0], [9.0, 9.0], -1.0, 3, 7)
            .is_empty());
        assert!(s
            .uncovered_positions([1.0, 0.0], [1.0, 5.0], 0.0, 3, 7)
            .is_empty());
    }

    #[test]
    fn non_finite_vertex_is_an_error_naming_object() {
        let mut tris = quad(0.0, 1.0);
        tris[1][2].x = f32::NAN;
        let err = Scene::new(vec![Object {
            thickness_m: None,
            name: "wall".into(),
            material: Material::Brick,
            triangles: tris,
        }])
        .err()
        .unwrap();
        assert!(err.to_string().contains("object 'wall'"), "{err}");
    }
}
