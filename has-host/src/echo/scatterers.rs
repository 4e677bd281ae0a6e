//! Point scatterers sampled on a scene's surfaces, and their visibility from a transmitter and a
//! receive array.
//!
//! Sampling: triangle `t` of area `A` gets `⌊A·ρ⌋` or `⌈A·ρ⌉` points (`ρ` the density per m²;
//! the fraction decided by a seeded coin, so the expected count is exactly `A·ρ`). The points
//! follow a randomly shifted R2 low-discrepancy sequence (Roberts' plastic-number Kronecker
//! sequence, Cranley–Patterson shift) mapped onto the triangle by the area-preserving square-root
//! map, so they are evenly spread rather than clumped. Area weight: `A/count` when `A·ρ ≥ 1`
//! (areas add up exactly per triangle), else `1/ρ` (exact in expectation). Each triangle has its
//! own ChaCha8 stream (`seed`, stream = triangle index): the same seed gives the same bits,
//! whatever the thread count.
//!
//! Visibility ([`visible_for`]): a scatterer is kept when its face points toward both ends (back
//! faces dropped, see [`ScattererSet::two_sided`]) and the BVH finds both legs clear, cast from the
//! scatterer lifted [`SURFACE_EPS_M`] off its face to the transmitter and to the array centre
//! (segments shortened by [`SURFACE_EPS_M`] at both ends by [`Scene::visible`]). The array-centre
//! approximation is exact for arrays small against the distance to any shadow edge; elsewhere a
//! scatterer within roughly (array size × range to the occluder / range to the array) of a shadow
//! edge may be wrongly kept or dropped for some elements.

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::{check_pos, EchoError};
use crate::material::Material;
use crate::scene::{Scene, SURFACE_EPS_M};

/// One surface scatterer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scatterer {
    /// Position on the surface, metres.
    pub pos: Vec3,
    /// Unit normal of the face (winding order: the front side).
    pub normal: Vec3,
    /// Area the sample stands for, m².
    pub area_m2: f32,
    /// Owning object (index into [`ScattererSet::object_materials`] / `Scene::objects`).
    pub object: u32,
}

/// Scatterers sampled from a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct ScattererSet {
    /// The scatterers, triangle by triangle in scene order.
    pub points: Vec<Scatterer>,
    /// Material of each object of the scene the set was sampled from.
    pub object_materials: Vec<Material>,
    /// Thickness of each object's material, metres (`None`: infinitely thick), as
    /// [`crate::scene::Object::thickness_m`].
    pub object_thickness_m: Vec<Option<f64>>,
    /// When true either side of a face is its front (for meshes with inconsistent winding);
    /// default false: only the winding-order side scatters.
    pub two_sided: bool,
    /// Density used, points per m².
    pub density_per_m2: f64,
    /// Seed used.
    pub seed: u64,
}

const PLASTIC: f64 = 1.324_717_957_244_746;

impl ScattererSet {
    /// Samples every triangle of `scene` at `density_per_m2` (see module docs).
    ///
    /// # Errors
    /// `InvalidParameter` for a density that is not finite and positive; `TooLarge` when the
    /// scatterers it asks for on the whole scene would not fit in the memory available.
    pub fn sample(scene: &Scene, density_per_m2: f64, seed: u64) -> Result<Self, EchoError> {
        Self::sample_where(scene, density_per_m2, seed, |_, _| true)
    }

    /// As [`ScattererSet::sample`], keeping only points where `keep(object, position)` is true
    /// (e.g. ground only near the building). The decision does not disturb the other points.
    ///
    /// # Errors
    /// As [`ScattererSet::sample`].
    pub fn sample_where(
        scene: &Scene,
        density_per_m2: f64,
        seed: u64,
        keep: impl Fn(u32, Vec3) -> bool + Sync,
    ) -> Result<Self, EchoError> {
        if !(density_per_m2.is_finite() && density_per_m2 > 0.0) {
            return Err(EchoError::invalid("density_per_m2", density_per_m2));
        }
        // Every triangle draws about area × density points before `keep` (work), and at worst
        // keeps them all (memory): refuse what would not fit before drawing any.
        let area: f64 = scene
            .objects
            .iter()
            .map(|o| crate::shapes::surface_area(&o.triangles))
            .sum();
        let count = area * density_per_m2 + scene.triangles.len() as f64;
        let need = count * std::mem::size_of::<Scatterer>() as f64;
        if let Some((need_gib, have_gib)) = crate::memory::shortfall(need) {
            return Err(EchoError::TooLarge {
                field: "density_per_m2",
                count,
                need_gib,
                have_gib,
            });
        }
        let a1 = 1.0 / PLASTIC;
        let a2 = 1.0 / (PLASTIC * PLASTIC);
        let per_tri: Vec<Vec<Scatterer>> = (0..scene.triangles.len())
            .into_par_iter()
            .map(|ti| {
                let tri = &scene.triangles[ti];
                let (v0, v1, v2) = (Vec3::from(tri.v0), Vec3::from(tri.v1), Vec3::from(tri.v2));
                let cross = (v1 - v0).cross(v2 - v0);
                let area = 0.5 * cross.length() as f64;
                let normal = cross.normalize_or_zero();
                let mut rng = ChaCha8Rng::seed_from_u64(seed);
                rng.set_stream(ti as u64);
                let expect = area * density_per_m2;
                let base = expect.floor();
                let extra = rng.random::<f64>() < expect - base;
                let count = base as usize + usize::from(extra);
                let weight = if expect >= 1.0 {
                    area / count as f64
                } else {
                    1.0 / density_per_m2
                } as f32;
                let (s1, s2): (f64, f64) = (rng.random(), rng.random());
                let object = scene.tri_object[ti];
                (0..count)
                    .filter_map(|i| {
                        let i = (i + 1) as f64;
                        let u1 = (s1 + i * a1).fract();
                        let u2 = (s2 + i * a2).fract();
                        let r = u1.sqrt();
                        let (b1, b2) = ((r * (1.0 - u2)) as f32, (r * u2) as f32);
                        let pos = v0 + (v1 - v0) * b1 + (v2 - v0) * b2;
                        keep(object, pos).then_some(Scatterer {
                            pos,
                            normal,
                            area_m2: weight,
                            object,
                        })
                    })
                    .collect()
            })
            .collect();
        Ok(ScattererSet {
            points: per_tri.into_iter().flatten().collect(),
            object_materials: scene.objects.iter().map(|o| o.material).collect(),
            object_thickness_m: scene.objects.iter().map(|o| o.thickness_m).collect(),
            two_sided: false,
            density_per_m2,
            seed,
        })
    }

    /// The same scatterers as patches of developed clutter: each one's area weight (its mean
    /// echo power) times an independent Exp(1) draw, so its echo's power is exponentially
    /// distributed about the mean and its amplitude Rayleigh (the sum of a patch's many
    /// unresolved facets; [`crate::scenario::GroundClutter::Developed`]). One ChaCha8 stream of
    /// `seed` drawn in the points' order: the same seed gives the same bits whatever the thread
    /// count.
    pub fn speckled(mut self, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        for p in &mut self.points {
            // 1 − u lies in (0, 1], so the draw is finite.
            let u: f64 = rng.random();
            p.area_m2 *= (-(1.0 - u).ln()) as f32;
        }
        self
    }

    /// Number of scatterers.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when there are no scatterers.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Total area the samples stand for, m².
    pub fn total_area_m2(&self) -> f64 {
        self.points.iter().map(|p| p.area_m2 as f64).sum()
    }

    /// The same set moved by `offset` (a moving target at another instant).
    pub fn translated(&self, offset: Vec3) -> Self {
        let mut s = self.clone();
        for p in &mut s.points {
            p.pos += offset;
        }
        s
    }

    /// The normal of `p` turned toward `toward` for two-sided sets; `None` if `p` faces away from
    /// `toward` (one-sided set) or is edge-on.
    #[inline]
    pub(crate) fn front_normal(&self, p: &Scatterer, toward: Vec3) -> Option<Vec3> {
        let c = p.normal.dot(toward - p.pos);
        if c > 0.0 {
            Some(p.normal)
        } else if self.two_sided && c < 0.0 {
            Some(-p.normal)
        } else {
            None
        }
    }
}

/// Indices of the scatterers of `set` that face and see both `tx` and `rx_centre` in `scene`
/// (ascending; rayon across scatterers). See module docs for the array-centre approximation.
///
/// # Errors
/// `InvalidParameter` for a non-finite `tx` or `rx_centre`.
pub fn visible_for(
    set: &ScattererSet,
    scene: &Scene,
    tx: Vec3,
    rx_centre: Vec3,
) -> Result<Vec<u32>, EchoError> {
    check_pos("tx", tx)?;
    check_pos("rx_centre", rx_centre)?;
    Ok(set
        .points
        .par_iter()
        .enumerate()
        .filter_map(|(i, p)| {
            let n = set.front_normal(p, tx)?;
            if n.dot(rx_centre - p.pos) <= 0.0 {
                return None;
            }
            let lifted = p.pos + n * SURFACE_EPS_M;
            (scene.visible(lifted, tx) && scene.visible(lifted, rx_centre)).then_some(i as u32)
        })
        .collect())
}

/// One visibility list reused while the transmitter and the array centre stay within
/// `max_shift_m` of the position where it was computed (e.g. along a virtual aperture; 0 casts at
/// every position). The error this allows is confined to scatterers whose shadow boundary moves
/// by more than their spacing over `max_shift_m`.
#[derive(Clone, Debug)]
pub struct VisibilityCache {
    /// Largest movement of either end before the list is recomputed, metres.
    pub max_shift_m: f32,
    anchor: Option<(Vec3, Vec3)>,
    list: Vec<u32>,
    recomputes: usize,
}

impl VisibilityCache {
    /// An empty cache.
    pub fn new(max_shift_m: f32) -> Self {
        VisibilityCache {
            max_shift_m,
            anchor: None,
            list: Vec::new(),
            recomputes: 0,
        }
    }

    /// The visible list for (`tx`, `rx_centre`), recomputed with [`visible_for`] if either moved
    /// more than `max_shift_m` since the last computation.
    ///
    /// # Errors
    /// As [`visible_for`].
    pub fn get(
        &mut self,
        set: &ScattererSet,
        scene: &Scene,
        tx: Vec3,
        rx_centre: Vec3,
    ) -> Result<&[u32], EchoError> {
        let stale = match self.anchor {
            None => true,
            Some((t, r)) => {
                t.distance(tx) > self.max_shift_m || r.distance(rx_centre) > self.max_shift_m
            }
        };
        if stale {
            self.list = visible_for(set, scene, tx, rx_centre)?;
            self.anchor = Some((tx, rx_centre));
            self.recomputes += 1;
        }
        Ok(&self.list)
    }

    /// How many times the list was (re)computed.
    pub fn recomputes(&self) -> usize {
        self.recomputes
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    #[test]
    fn speckled_patches_keep_the_mean_power_with_exponential_spread_and_the_same_bits_per_seed() {
        let g = crate::shapes::ground(
            "ground",
            Material::MediumDryGround,
            Vec2::splat(-20.0),
            Vec2::splat(20.0),
            0.0,
            (8, 8),
        )
        .unwrap();
        let scene = Scene::new(vec![g]).unwrap();
        let flat = ScattererSet::sample(&scene, 5.0, 3).unwrap();
        let speckled = flat.clone().speckled(9);
        assert_eq!(speckled, flat.clone().speckled(9));
        assert_ne!(speckled, flat.clone().speckled(10));
        let n = flat.len() as f64;
        assert!(n > 7000.0, "{n}");
        // Positions unchanged; power ratios Exp(1): mean 1 and P(ratio > 1) = 1/e, each within
        // five standard errors of its estimate over n draws.
        let ratios: Vec<f64> = flat
            .points
            .iter()
            .zip(&speckled.points)
            .map(|(a, b)| {
                assert_eq!(a.pos, b.pos);
                b.area_m2 as f64 / a.area_m2 as f64
            })
            .collect();
        let mean = ratios.iter().sum::<f64>() / n;
        assert!((mean - 1.0).abs() < 5.0 / n.sqrt(), "mean {mean}");
        let above = ratios.iter().filter(|&&r| r > 1.0).count() as f64 / n;
        let e = (-1.0f64).exp();
        assert!(
            (above - e).abs() < 5.0 * (e * (1.0 - e) / n).sqrt(),
            "{above}"
        );
        // The deep fades a Rayleigh amplitude has: P(ratio < 0.1) = 1 − e^−0.1.
        let faded = ratios.iter().filter(|&&r| r < 0.1).count() as f64 / n;
        let f = 1.0 - (-0.1f64).exp();
        assert!(
            (faded - f).abs() < 5.0 * (f * (1.0 - f) / n).sqrt(),
            "{faded}"
        );
    }
}
