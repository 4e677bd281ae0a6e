//! The tracer (step 3, see [`crate::paths`]): for each receiver the image method back-traces the
//! transmitter's candidates, the BVH validates every leg, and the field is carried through each
//! bounce (Fresnel, polarisation, spreading). Positions metres, angles radians, delays seconds.

use glam::DVec3;
use num_complex::Complex64;
use rayon::prelude::*;

use super::candidates::{
    exhaustive_sequences, Search, TxCandidates, EXHAUSTIVE_BYTES_PER_SEQUENCE, ROOT,
};
use super::facets::{tri_vertices, Facets};
use super::{
    CandidateMode, Interaction, Path, PathError, Polarization, TracerConfig, MAX_COORD_M,
    MAX_ORDER, MAX_SBR_RAYS,
};
use crate::propagation::{free_space_amplitude, reflection};
use crate::scene::{Scene, SURFACE_EPS_M};
use crate::C_M_PER_S;

/// Ray tracer of propagation paths over one scene.
pub struct Tracer<'a> {
    scene: &'a Scene,
    facets: Facets,
    config: TracerConfig,
    eta: Vec<Complex64>,
    /// Per object: its material's thickness (a slab), `None` for the half-space.
    thickness_m: Vec<Option<f64>>,
    wavelength_m: f64,
}

fn check_position(what: &'static str, p: DVec3) -> Result<(), PathError> {
    if !p.is_finite() {
        Err(PathError::NonFinitePosition { what, value: p })
    } else if p.abs().max_element() > MAX_COORD_M {
        Err(PathError::FarPosition { what, value: p })
    } else {
        Ok(())
    }
}

/// Unit vectors `(θ̂, φ̂)` of direction `d` (unit) and its angles `(θ, φ)`.
fn spherical_basis(d: DVec3) -> (DVec3, DVec3, f64, f64) {
    let theta = d.z.clamp(-1.0, 1.0).acos();
    let phi = d.y.atan2(d.x);
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    (
        DVec3::new(ct * cp, ct * sp, -st),
        DVec3::new(-sp, cp, 0.0),
        theta,
        phi,
    )
}

/// Complex 3-vector (field).
#[derive(Clone, Copy, Debug)]
struct CVec3 {
    re: DVec3,
    im: DVec3,
}

impl CVec3 {
    fn real(v: DVec3) -> Self {
        CVec3 {
            re: v,
            im: DVec3::ZERO,
        }
    }
    fn dot(&self, v: DVec3) -> Complex64 {
        Complex64::new(self.re.dot(v), self.im.dot(v))
    }
    fn scaled(c: Complex64, v: DVec3) -> Self {
        CVec3 {
            re: v * c.re,
            im: v * c.im,
        }
    }
    fn add(self, o: Self) -> Self {
        CVec3 {
            re: self.re + o.re,
            im: self.im + o.im,
        }
    }
}

/// Unit vector perpendicular to unit `k`.
pub(super) fn any_perpendicular(k: DVec3) -> DVec3 {
    let a = if k.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    k.cross(a).normalize()
}

impl<'a> Tracer<'a> {
    /// Prepares a tracer: checks the configuration and builds the facets.
    ///
    /// # Errors
    /// [`PathError::OutOfRange`] for a frequency that is not finite and positive, `max_order >
    /// MAX_ORDER`, zero SBR rays or negative/non-finite facet tolerances.
    pub fn new(scene: &'a Scene, config: TracerConfig) -> Result<Tracer<'a>, PathError> {
        let f = config.frequency_hz;
        if !(f.is_finite() && f > 0.0) {
            return Err(PathError::OutOfRange {
                what: "frequency_hz",
                value: f,
                expected: "finite and > 0",
            });
        }
        if config.max_order > MAX_ORDER {
            return Err(PathError::OutOfRange {
                what: "max_order",
                value: config.max_order as f64,
                expected: "at most 8",
            });
        }
        if let CandidateMode::Sbr { rays } = config.candidates {
            if rays == 0 || rays > MAX_SBR_RAYS {
                return Err(PathError::OutOfRange {
                    what: "sbr_rays",
                    value: rays as f64,
                    expected: "1 ..= 2^30 (MAX_SBR_RAYS)",
                });
            }
        }
        if let Some((i, (lo, hi))) = scene.material_outside(f) {
            let o = &scene.objects[i];
            return Err(PathError::MaterialFrequency {
                freq_ghz: f / 1e9,
                material: o.material.name(),
                object: o.name.clone(),
                lo_ghz: lo,
                hi_ghz: hi,
            });
        }
        for (what, v) in [
            ("facet_angle_tol_rad", config.facet_angle_tol_rad),
            ("facet_dist_tol_m", config.facet_dist_tol_m),
            ("vertical_tol_m", config.vertical_tol_m),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(PathError::OutOfRange {
                    what,
                    value: v,
                    expected: "finite and >= 0",
                });
            }
        }
        let facets = Facets::build(
            scene,
            config.facet_angle_tol_rad,
            config.facet_dist_tol_m,
            config.vertical_tol_m,
        );
        if config.candidates == CandidateMode::Exhaustive {
            let count = exhaustive_sequences(facets.facets.len(), config.max_order);
            let need = count * EXHAUSTIVE_BYTES_PER_SEQUENCE as f64;
            if let Some((need_gib, have_gib)) = crate::memory::shortfall(need) {
                return Err(PathError::TooLarge {
                    what: "exhaustive candidates",
                    count,
                    need_gib,
                    have_gib,
                });
            }
        }
        let eta = scene
            .objects
            .iter()
            .map(|o| o.material.complex_permittivity(f))
            .collect();
        let thickness_m = scene.objects.iter().map(|o| o.thickness_m).collect();
        Ok(Tracer {
            scene,
            facets,
            wavelength_m: crate::wavelength_m(f),
            config,
            eta,
            thickness_m,
        })
    }

    /// The facets the tracer reflects on.
    pub fn facets(&self) -> &Facets {
        &self.facets
    }

    /// The configuration.
    pub fn config(&self) -> &TracerConfig {
        &self.config
    }

    /// Candidate facet sequences for transmitter `tx` (see module docs), to be reused for every
    /// receiver with [`Tracer::trace`]. Runs in parallel (rayon).
    ///
    /// # Errors
    /// [`PathError::NonFinitePosition`] for a NaN or infinite `tx`.
    pub fn prepare_tx(&self, tx: DVec3) -> Result<TxCandidates, PathError> {
        check_position("tx", tx)?;
        let search = Search {
            scene: self.scene,
            facets: &self.facets,
            config: &self.config,
        };
        Ok(search.candidates(tx))
    }

    /// Paths from `tx` to `rx` (prepares the candidates for `tx` first; use
    /// [`Tracer::prepare_tx`] + [`Tracer::trace`] for many receivers).
    ///
    /// # Errors
    /// [`PathError::NonFinitePosition`] for a NaN or infinite position.
    pub fn paths(&self, tx: DVec3, rx: DVec3) -> Result<Vec<Path>, PathError> {
        let c = self.prepare_tx(tx)?;
        self.trace(&c, rx)
    }

    /// Paths from the prepared transmitter to every receiver, in parallel over receivers.
    ///
    /// # Errors
    /// [`PathError::NonFinitePosition`] naming the first receiver that is NaN or infinite.
    pub fn trace_many(
        &self,
        cand: &TxCandidates,
        rxs: &[DVec3],
    ) -> Result<Vec<Vec<Path>>, PathError> {
        for &rx in rxs {
            check_position("rx", rx)?;
        }
        rxs.par_iter().map(|&rx| self.trace(cand, rx)).collect()
    }

    /// Paths from the prepared transmitter to `rx`, sorted by delay.
    ///
    /// # Errors
    /// [`PathError::NonFinitePosition`] for a NaN or infinite `rx`.
    pub fn trace(&self, cand: &TxCandidates, rx: DVec3) -> Result<Vec<Path>, PathError> {
        check_position("rx", rx)?;
        let tx = cand.tx;
        let mut paths = Vec::new();
        // The far-field path model needs at least a wavelength between the ends: a receiver
        // on the transmitter (a monostatic radar) has no line-of-sight path, only echoes.
        if self.config.los
            && (rx - tx).length() >= self.wavelength_m
            && self.leg_clear(tx, rx, u32::MAX)
        {
            paths.push(self.make_path(tx, rx, &[], &[], (rx - tx).length()));
        }
        let mut chain = [0u32; MAX_ORDER];
        let mut points = [DVec3::ZERO; MAX_ORDER];
        'cand: for node in &cand.nodes {
            // Collect the chain, deepest first.
            let depth = node.depth as usize;
            let mut id = node;
            for slot in chain[..depth].iter_mut() {
                *slot = id.facet;
                if id.parent != ROOT {
                    id = &cand.nodes[id.parent as usize];
                }
            }
            // chain[0] is the last facet (next to rx). Back-trace the images.
            let mut q = rx;
            let mut nd = node;
            for i in 0..depth {
                let fc = &self.facets.facets[chain[i] as usize];
                let img = nd.image;
                let dq = fc.normal.dot(q) - fc.offset;
                let di = fc.normal.dot(img) - fc.offset;
                if dq * di >= 0.0 || dq.abs() < 1e-9 {
                    continue 'cand;
                }
                let s = dq / (dq - di);
                let p = q + (img - q) * s;
                let pad = fc.thickness + 1e-6 * (1.0 + p.abs().max_element());
                if p.cmplt(fc.lo - pad).any() || p.cmpgt(fc.hi + pad).any() {
                    continue 'cand;
                }
                points[i] = p;
                q = p;
                if nd.parent != ROOT {
                    nd = &cand.nodes[nd.parent as usize];
                }
            }
            // The first facet must see the transmitter from the side the image was made on.
            // (Guaranteed by construction: the image of tx is mirrored through that plane.)
            // BVH validation, receiver side first.
            let mut from = rx;
            let mut from_facet = u32::MAX;
            for i in 0..depth {
                if !self.leg_hits_facet(from, from_facet, points[i], chain[i]) {
                    continue 'cand;
                }
                from = points[i];
                from_facet = chain[i];
            }
            if !self.leg_clear(from, tx, from_facet) {
                continue 'cand;
            }
            // Reverse to transmitter order.
            let mut fwd_f = [0u32; MAX_ORDER];
            let mut fwd_p = [DVec3::ZERO; MAX_ORDER];
            for i in 0..depth {
                fwd_f[i] = chain[depth - 1 - i];
                fwd_p[i] = points[depth - 1 - i];
            }
            // Unfolded length from the last image (exact in f64).
            let length_m = (rx - node.image).length();
            paths.push(self.make_path(tx, rx, &fwd_f[..depth], &fwd_p[..depth], length_m));
        }
        paths.sort_by(|a, b| a.delay_s.total_cmp(&b.delay_s));
        dedup(&mut paths);
        Ok(paths)
    }

    /// True if nothing blocks the segment `a → b` (ignoring facet `skip` at `a`).
    fn leg_clear(&self, a: DVec3, b: DVec3, skip: u32) -> bool {
        let d = b - a;
        let len = d.length();
        if len <= 2.0 * SURFACE_EPS_M as f64 {
            return true;
        }
        let dir = (d / len).as_vec3();
        let tf = &self.facets.tri_facet;
        let tmin = if skip == u32::MAX { SURFACE_EPS_M } else { 0.0 };
        self.scene
            .closest_hit_skipping(
                a.as_vec3(),
                dir,
                tmin,
                (len - SURFACE_EPS_M as f64) as f32,
                |t| tf[t as usize] == skip,
            )
            .is_none()
    }

    /// True if the ray from `a` toward `p` (on facet `f`) first hits facet `f`, near `p`.
    fn leg_hits_facet(&self, a: DVec3, skip: u32, p: DVec3, f: u32) -> bool {
        let d = p - a;
        let len = d.length();
        if len <= SURFACE_EPS_M as f64 {
            return false;
        }
        let dir = d / len;
        let fc = &self.facets.facets[f as usize];
        let cos = dir.dot(fc.normal).abs().max(0.05);
        let tol = (fc.thickness + SURFACE_EPS_M as f64) / cos;
        let tf = &self.facets.tri_facet;
        let tmin = if skip == u32::MAX { SURFACE_EPS_M } else { 0.0 };
        match self.scene.closest_hit_skipping(
            a.as_vec3(),
            dir.as_vec3(),
            tmin,
            (len + tol) as f32,
            |t| tf[t as usize] == skip,
        ) {
            Some(h) => {
                if tf[h.triangle as usize] == f {
                    true
                } else {
                    // Another surface only within the tolerance band around p (e.g. a wall
                    // meeting the facet at p) does not block.
                    (h.t as f64) > len - tol && self.inside_facet(p, f)
                }
            }
            // Crack between two triangles of the facet (non-watertight ray/triangle test).
            None => self.inside_facet(p, f),
        }
    }

    /// Exact test: the projection of `p` on facet `f`'s plane lies in one of its triangles.
    fn inside_facet(&self, p: DVec3, f: u32) -> bool {
        let fc = &self.facets.facets[f as usize];
        let n = fc.normal;
        let u = any_perpendicular(n);
        let v = n.cross(u);
        let to2 = |x: DVec3| (x.dot(u), x.dot(v));
        let (px, py) = to2(p);
        fc.triangles.iter().any(|&t| {
            let [a, b, c] = tri_vertices(self.scene, t);
            let (ax, ay) = to2(a);
            let (bx, by) = to2(b);
            let (cx, cy) = to2(c);
            let det = (bx - ax) * (cy - ay) - (cx - ax) * (by - ay);
            if det == 0.0 {
                return false;
            }
            let l1 = ((px - ax) * (cy - ay) - (cx - ax) * (py - ay)) / det;
            let l2 = ((bx - ax) * (py - ay) - (px - ax) * (by - ay)) / det;
            let eps = 1e-9;
            l1 >= -eps && l2 >= -eps && l1 + l2 <= 1.0 + eps
        })
    }

    /// Builds a path of unfolded length `length_m` through the reflection points: angles, the
    /// polarimetric Fresnel product, free-space spreading and carrier phase.
    fn make_path(
        &self,
        tx: DVec3,
        rx: DVec3,
        facets: &[u32],
        points: &[DVec3],
        length_m: f64,
    ) -> Path {
        let mut verts = Vec::with_capacity(facets.len() + 2);
        verts.push(tx);
        verts.extend_from_slice(points);
        verts.push(rx);
        let k0 = (verts[1] - verts[0]).normalize();
        let (th_t, ph_t, zod, aod) = spherical_basis(k0);
        let mut e = [CVec3::real(th_t), CVec3::real(ph_t)];
        let mut k_in = k0;
        let mut interactions = Vec::with_capacity(facets.len().max(1));
        for (i, &f) in facets.iter().enumerate() {
            let fc = &self.facets.facets[f as usize];
            let n = fc.normal;
            let k_out = (verts[i + 2] - verts[i + 1]).normalize();
            let cos_i = k_in.dot(n).abs();
            let o = fc.object as usize;
            let r = reflection(self.eta[o], cos_i, self.thickness_m[o], self.wavelength_m);
            let sx = k_in.cross(n);
            let s = if sx.length() > 1e-12 {
                sx.normalize()
            } else {
                any_perpendicular(k_in)
            };
            let p_in = s.cross(k_in);
            let p_out = s.cross(k_out);
            for field in e.iter_mut() {
                *field = CVec3::scaled(r.te * field.dot(s), s)
                    .add(CVec3::scaled(r.tm * field.dot(p_in), p_out));
            }
            interactions.push(Interaction::Reflection {
                object: fc.object,
                facet: f,
                point: points[i],
            });
            k_in = k_out;
        }
        if interactions.is_empty() {
            interactions.push(Interaction::Los);
        }
        let (th_r, ph_r, _, _) = spherical_basis(k_in);
        let (_, _, zoa, aoa) = spherical_basis(-k_in);
        let jones = [
            [e[0].dot(th_r), e[1].dot(th_r)],
            [e[0].dot(ph_r), e[1].dot(ph_r)],
        ];
        let mut path = Path {
            delay_s: length_m / C_M_PER_S,
            length_m,
            a: Complex64::new(0.0, 0.0),
            jones,
            aod,
            zod,
            aoa,
            zoa,
            interactions,
        };
        self.apply_spreading(&mut path);
        path
    }

    /// Multiplies the Jones matrix by `λ/(4πL)·e^{−j2π L/λ}` and sets `a`.
    fn apply_spreading(&self, path: &mut Path) {
        let amp = free_space_amplitude(path.length_m, self.wavelength_m);
        let phase = -2.0 * std::f64::consts::PI * (path.length_m / self.wavelength_m).fract();
        let g = Complex64::from_polar(amp, phase);
        for row in path.jones.iter_mut() {
            for x in row.iter_mut() {
                *x *= g;
            }
        }
        path.a = match self.config.polarization {
            Polarization::Vertical => path.jones[0][0],
            Polarization::Horizontal => path.jones[1][1],
        };
    }
}

/// Drops paths equal to an earlier one (same delay within 1e-12 relative, same interaction kinds
/// and points within 1 µm): e.g. one specular point found through two coplanar facets.
fn dedup(paths: &mut Vec<Path>) {
    let mut keep: Vec<Path> = Vec::with_capacity(paths.len());
    'outer: for p in paths.drain(..) {
        for q in keep.iter().rev() {
            if p.delay_s - q.delay_s > 1e-12 * p.delay_s + 1e-18 {
                break;
            }
            if p.interactions.len() == q.interactions.len()
                && p.interactions
                    .iter()
                    .zip(&q.interactions)
                    .all(|(x, y)| same_interaction(x, y))
            {
                continue 'outer;
            }
        }
        keep.push(p);
    }
    *paths = keep;
}

fn same_interaction(x: &Interaction, y: &Interaction) -> bool {
    match (x, y) {
        (Interaction::Los, Interaction::Los) => true,
        (Interaction::Reflection { point: a, .. }, Interaction::Reflection { point: b, .. })
        | (Interaction::Diffraction { point: a, .. }, Interaction::Diffraction { point: b, .. }) => {
            (*a - *b).length() < 1e-6
        }
        _ => false,
    }
}
