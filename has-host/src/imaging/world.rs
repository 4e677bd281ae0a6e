//! The world a run images: the scene with its BVH, the surface scatterers, the ground truth, and
//! the terrain the operator knows before imaging (built by [`super::build_world`]). Positions
//! `glam::Vec3` in metres, z up.

use glam::Vec3;

use crate::echo::ScattererSet;
use crate::scene::Scene;

/// The world a run images.
pub struct World {
    /// The scene with its BVH.
    pub scene: Scene,
    /// Surface scatterers (building density on objects, ground density near the region).
    pub scatterers: ScattererSet,
    /// Ground-truth points on the truth objects.
    pub truth: Vec<Vec3>,
    /// Each truth point's unit normal, its triangle's (outward).
    pub truth_normals: Vec<Vec3>,
    /// Triangles of the truth objects (for plots).
    pub truth_triangles: Vec<[Vec3; 3]>,
    /// Per object: is it ground.
    pub is_ground: Vec<bool>,
    /// What the operator knows of the site before imaging it: the terrain (the `ground_objects`
    /// alone, no buildings) and an independent realisation of its scatterers (same density,
    /// footprint and material, another seed). Imaged through the same chain, it predicts the
    /// clutter-plus-noise power each voxel would hold if the site were bare (see
    /// [`super::detection`]).
    pub terrain: Terrain,
}

/// The known terrain of a site: its scene and a model realisation of its scatterers.
pub struct Terrain {
    /// The ground objects alone (or, without any, the full scene with no model scatterers).
    pub scene: Scene,
    /// Model scatterers on the terrain (empty when the scenario names no ground object).
    pub scatterers: ScattererSet,
    /// Whether the scenario names its ground (`imaging.ground_objects`): without, the terrain's
    /// height is not known and [`Terrain::below`] answers `None` everywhere.
    pub known: bool,
}

impl Terrain {
    /// The terrain's point straight below `p` (the first terrain surface a ray down from `p`
    /// meets), `None` where there is none or the terrain is not known.
    pub fn below(&self, p: Vec3) -> Option<Vec3> {
        if !self.known {
            return None;
        }
        self.scene
            .closest_hit(p, Vec3::NEG_Z, 0.0, f32::INFINITY)
            .map(|h| h.point)
    }
}
