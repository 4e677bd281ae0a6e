//! Sensors of hybrid aperture sensing: the base station's real aperture (a vertical uniform planar
//! array) and a terminal's virtual aperture (a straight track sampled at transmit positions).
//!
//! Frame: metres, z up. A base-station panel stands vertically; its boresight (normal) points
//! horizontally at azimuth `φ` (radians from +x toward +y). Elements sit at the centres of a
//! `rows × cols` partition of the `width × height` panel: element `(r, c)` is at
//! `centre + u·(c − (cols−1)/2)·width/cols + z·(r − (rows−1)/2)·height/rows` with the horizontal
//! tangent `u = (−sin φ, cos φ, 0)`. Element `(r, c)` has index `r·cols + c` (row-major, row 0 at
//! the bottom).

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A vertical uniform planar array (the base station's real aperture).
#[derive(Clone, Debug, PartialEq)]
pub struct PlanarArray {
    /// Panel centre, metres.
    pub centre: Vec3,
    /// Boresight azimuth φ, radians from +x toward +y (the panel's normal is horizontal).
    pub boresight_az_rad: f32,
    /// Element rows (vertical).
    pub rows: usize,
    /// Element columns (horizontal).
    pub cols: usize,
    /// Panel width (horizontal extent), metres.
    pub width_m: f32,
    /// Panel height (vertical extent), metres.
    pub height_m: f32,
}

impl PlanarArray {
    /// Unit boresight (outward normal).
    pub fn boresight(&self) -> Vec3 {
        Vec3::new(
            self.boresight_az_rad.cos(),
            self.boresight_az_rad.sin(),
            0.0,
        )
    }

    /// Unit horizontal tangent (direction of increasing column).
    pub fn tangent(&self) -> Vec3 {
        Vec3::new(
            -self.boresight_az_rad.sin(),
            self.boresight_az_rad.cos(),
            0.0,
        )
    }

    /// Horizontal and vertical element spacing, metres.
    pub fn spacing_m(&self) -> (f32, f32) {
        (
            self.width_m / self.cols as f32,
            self.height_m / self.rows as f32,
        )
    }

    /// Position of element `(row, col)`.
    pub fn element(&self, row: usize, col: usize) -> Vec3 {
        let (dx, dz) = self.spacing_m();
        let cu = (col as f32 - (self.cols as f32 - 1.0) * 0.5) * dx;
        let cz = (row as f32 - (self.rows as f32 - 1.0) * 0.5) * dz;
        self.centre + self.tangent() * cu + Vec3::Z * cz
    }

    /// Every `step`-th element in both directions (step 1: all `rows·cols`), row-major. The
    /// subsampled array keeps the panel's extent (and so its resolution) but thins the elements.
    pub fn elements(&self, step: usize) -> Vec<Vec3> {
        let step = step.max(1);
        let mut out = Vec::with_capacity((self.rows / step + 1) * (self.cols / step + 1));
        for r in (0..self.rows).step_by(step) {
            for c in (0..self.cols).step_by(step) {
                out.push(self.element(r, c));
            }
        }
        out
    }

    /// The grating-lobe aliases of scene point `p` for this panel and a transmitter at `tx`: the
    /// points the panel cannot tell from `p`. Elements sit on a lattice of pitch `d` along each
    /// panel axis (`spacing_m`; a thinned subset too), so the receive phases of a far-field
    /// direction repeat when its direction sine along that axis moves by a whole `m·λ/d`: for
    /// `d > λ/2` such a shifted direction can be visible (sines in [−1, 1], the same side of the
    /// panel). Along it, the alias is the point at `p`'s bistatic range `|p − tx| + |p − centre|`
    /// (`ρ = (r² − |c − tx|²) / (2(r + d̂·(c − tx)))` from the centre `c` along `d̂`): the same range
    /// bin and the same array phases, so an echo from either focuses at both. Empty for a panel at
    /// `λ/2` or finer, or for `p` at the centre.
    pub fn grating_aliases(&self, wavelength_m: f32, p: Vec3, tx: Vec3) -> Vec<Vec3> {
        let (dx, dz) = self.spacing_m();
        let (t, n) = (self.tangent(), self.boresight());
        let rel = p - self.centre;
        let dist = rel.length();
        if dist.is_nan() || dist <= 0.0 || wavelength_m.is_nan() || wavelength_m <= 0.0 {
            return Vec::new();
        }
        let dir = rel / dist;
        let (u, w, front) = (dir.dot(t), dir.z, dir.dot(n));
        let r = dist + (p - tx).length();
        let ct = self.centre - tx;
        let orders = |pitch: f32| -> Vec<f32> {
            let step = wavelength_m / pitch;
            // |m·step| < 2: beyond that no shifted sine can stay in [−1, 1].
            let m_max = if pitch > 0.5 * wavelength_m {
                (2.0 / step).floor() as i32
            } else {
                0
            };
            (-m_max..=m_max).map(|m| m as f32 * step).collect()
        };
        let mut out = Vec::new();
        for su in orders(dx) {
            for sw in orders(dz) {
                if su == 0.0 && sw == 0.0 {
                    continue;
                }
                let (u2, w2) = (u + su, w + sw);
                let q = 1.0 - u2 * u2 - w2 * w2;
                if q <= 0.0 {
                    continue;
                }
                let d = t * u2 + Vec3::Z * w2 + n * (q.sqrt() * front.signum());
                let den = 2.0 * (r + d.dot(ct));
                if den <= 0.0 {
                    continue;
                }
                let rho = (r * r - ct.length_squared()) / den;
                if rho > 0.0 {
                    out.push(self.centre + d * rho);
                }
            }
        }
        out
    }

    /// One element per `step × step` block of the panel, at a seeded random row and column
    /// within the block (jittered thinning): the same count as [`PlanarArray::elements`], but no
    /// periodic gaps, so no grating lobes — the replicas of a periodic `step`-thinned panel
    /// (spacing `step·d`, lobes every `λ/(step·d)` in direction sine) decohere into a diffuse
    /// sidelobe floor of about `1/N` in power. `step = 1` gives every element, as
    /// [`PlanarArray::elements`].
    pub fn elements_jittered(&self, step: usize, seed: u64) -> Vec<Vec3> {
        self.jittered_indices(step, seed)
            .into_iter()
            .map(|i| self.element(i / self.cols, i % self.cols))
            .collect()
    }

    /// The element indices (`row·cols + col`) of [`PlanarArray::elements_jittered`], in its
    /// order: the thinned panel as a subset of the whole one.
    pub fn jittered_indices(&self, step: usize, seed: u64) -> Vec<usize> {
        let step = step.max(1);
        if step == 1 {
            return (0..self.rows * self.cols).collect();
        }
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut out = Vec::with_capacity((self.rows / step + 1) * (self.cols / step + 1));
        for r0 in (0..self.rows).step_by(step) {
            for c0 in (0..self.cols).step_by(step) {
                let r = r0 + rng.random_range(0..step.min(self.rows - r0));
                let c = c0 + rng.random_range(0..step.min(self.cols - c0));
                out.push(r * self.cols + c);
            }
        }
        out
    }

    /// The panel as a has-dsp lattice ([`has_dsp::bp::factorised::Lattice`]), world frame:
    /// element `(row, col)` at `first + col·col_step + row·row_step`, as [`PlanarArray::element`].
    pub fn lattice(&self) -> has_dsp::bp::factorised::Lattice {
        let (dx, dz) = self.spacing_m();
        has_dsp::bp::factorised::Lattice {
            first: self.element(0, 0),
            col_step: self.tangent() * dx,
            row_step: Vec3::Z * dz,
            rows: self.rows,
            cols: self.cols,
        }
    }
}

/// A straight virtual aperture: the terminal transmits at `positions` evenly spaced points from
/// `start` to `end` (both included).
#[derive(Clone, Debug, PartialEq)]
pub struct VirtualAperture {
    /// First transmit position, metres.
    pub start: Vec3,
    /// Last transmit position, metres.
    pub end: Vec3,
    /// Number of transmit positions (≥ 2 for an aperture, 1 for a single snapshot).
    pub positions: usize,
}

impl VirtualAperture {
    /// Aperture length, metres.
    pub fn length_m(&self) -> f32 {
        self.start.distance(self.end)
    }

    /// Centre of the track.
    pub fn centre(&self) -> Vec3 {
        (self.start + self.end) * 0.5
    }

    /// Every `step`-th transmit position (step 1: all).
    pub fn positions(&self, step: usize) -> Vec<Vec3> {
        let n = self.positions.max(1);
        (0..n)
            .step_by(step.max(1))
            .map(|i| {
                if n == 1 {
                    self.centre()
                } else {
                    self.start.lerp(self.end, i as f32 / (n - 1) as f32)
                }
            })
            .collect()
    }

    /// One transmit position per run of `step`, at a seeded random index within the run
    /// (jittered thinning, as [`PlanarArray::elements_jittered`]): no periodic gaps, so no
    /// grating lobes along the track. `step = 1` gives every position.
    pub fn positions_jittered(&self, step: usize, seed: u64) -> Vec<Vec3> {
        let step = step.max(1);
        let n = self.positions.max(1);
        if step == 1 || n == 1 {
            return self.positions(1);
        }
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .step_by(step)
            .map(|i0| {
                let i = i0 + rng.random_range(0..step.min(n - i0));
                self.start.lerp(self.end, i as f32 / (n - 1) as f32)
            })
            .collect()
    }
}

/// Transmit-position spacing (metres) that samples the phase history of a scene seen within
/// `half_angle_rad` of broadside without aliasing: the one-way phase `2π r_V/λ` changes by at most
/// `2π·d·sin(half_angle)/λ` per step, which must stay below π, so `d ≤ λ / (2 sin half_angle)`.
pub fn nyquist_spacing_m(wavelength_m: f32, half_angle_rad: f32) -> f32 {
    wavelength_m / (2.0 * half_angle_rad.sin().abs().max(1e-6))
}

/// Theoretical resolutions of one hybrid-aperture pair at a scene point, metres:
/// `(range, cross_range_virtual, cross_range_real_h, cross_range_real_v)`, the extents of
/// [`pair_resolution_axes`].
pub fn pair_resolution_m(
    point: Vec3,
    array: &PlanarArray,
    aperture: &VirtualAperture,
    wavelength_m: f32,
    bandwidth_hz: f32,
) -> (f32, f32, f32, f32) {
    let [r, v, h, z] = pair_resolution_axes(point, array, aperture, wavelength_m, bandwidth_hz);
    (r.1, v.1, h.1, z.1)
}

/// The four directions one hybrid-aperture pair resolves at a scene point, each with its
/// resolution along it (metres): range, the virtual aperture's cross-range, the receive panel's
/// horizontal and vertical cross-ranges. Directions are unit vectors (zero where undefined, e.g.
/// a track pointing at the point).
///
/// Range resolution is `c/B` in bistatic path length, i.e. `c / (B·|∇(r_V + r_R)|)` along the
/// bisector `∇(r_V + r_R)`, where `|∇(r_V + r_R)| = 2 cos(β/2)` for bistatic angle β.
/// Cross-range from an aperture of length `L` at distance `R` is `λR/L` for the receive array,
/// along the panel's horizontal tangent and the vertical projected across the line of sight. The
/// track's is [`track_cross_range_m`], `λR/(L·sin θ)` at angle `θ` off its axis, along the
/// track's direction projected across the line of sight: the one-way phase varies across the
/// track as `cos θ`, whose gradient has that direction and magnitude `sin θ/R`. Near the axis
/// the projected direction turns with any small offset (up and down for a point a metre below a
/// vehicle's track), and the broadside `λR/L` there would claim a fine resolution in whatever
/// direction that is.
pub fn pair_resolution_axes(
    point: Vec3,
    array: &PlanarArray,
    aperture: &VirtualAperture,
    wavelength_m: f32,
    bandwidth_hz: f32,
) -> [(Vec3, f32); 4] {
    let c = has_dsp::geometry::C_M_PER_S as f32;
    let uv = (aperture.centre() - point).normalize_or_zero();
    let ur = (array.centre - point).normalize_or_zero();
    let grad = uv + ur;
    let range = c / (bandwidth_hz * grad.length().max(1e-3));
    let rr = array.centre.distance(point);
    let across = |d: Vec3, u: Vec3| (d - u * d.dot(u)).normalize_or_zero();
    let track = (aperture.end - aperture.start).normalize_or_zero();
    [
        (grad.normalize_or_zero(), range),
        (
            across(track, uv),
            track_cross_range_m(point, aperture, wavelength_m),
        ),
        (
            across(array.tangent(), ur),
            wavelength_m * rr / array.width_m,
        ),
        (across(Vec3::Z, ur), wavelength_m * rr / array.height_m),
    ]
}

/// The vertical extent (metres) of a pair's resolution cell at a scene point: `√((J⁻¹)_zz)` for
/// the information matrix `J = Σ a aᵀ/δ²` over the four directions and resolutions of
/// [`pair_resolution_axes`] — how finely the pair places an echo in height, whatever direction
/// resolves it.
pub fn vertical_extent_m(
    point: Vec3,
    array: &PlanarArray,
    aperture: &VirtualAperture,
    wavelength_m: f32,
    bandwidth_hz: f32,
) -> f32 {
    let mut j = glam::DMat3::ZERO;
    for (a, d) in pair_resolution_axes(point, array, aperture, wavelength_m, bandwidth_hz) {
        let a = a.as_dvec3();
        j += glam::DMat3::from_cols(a * a.x, a * a.y, a * a.z) / (d as f64).powi(2).max(1e-12);
    }
    if j.determinant().abs() < 1e-18 {
        return f32::INFINITY;
    }
    (j.inverse().z_axis.z.max(0.0)).sqrt() as f32
}

/// Cross-range resolution (metres) of a linear track of length `L` at a point seen at angle `θ`
/// from the track's axis, distance `R` from its centre: the one-way phase `2π r/λ` changes across
/// the track by `L·cos θ/λ` cycles, so the track resolves `Δ(cos θ) = λ/L`, an angle of
/// `λ/(L·sin θ)` off the axis and `√(2λ/L)` on it (where `cos θ` is stationary):
/// `R·λ/(L·max(sin θ, √(λ/(2L))))`. At broadside this is [`pair_resolution_axes`]'s `λR/L`; at
/// the track's endfire a 3 m track at 10 GHz resolves 0.14 rad, 14 × its broadside angle.
pub fn track_cross_range_m(point: Vec3, aperture: &VirtualAperture, wavelength_m: f32) -> f32 {
    let l = aperture.length_m().max(1e-3);
    let to = point - aperture.centre();
    let r = to.length();
    let axis = (aperture.end - aperture.start).normalize_or_zero();
    let sin = to.normalize_or_zero().cross(axis).length();
    r * wavelength_m / (l * sin.max((wavelength_m / (2.0 * l)).sqrt()))
}

/// The resolution cell of a pair at a scene point: its volume (m³) and vertical extent (m) —
/// range × horizontal cross-range × the panel's vertical cross-range, the horizontal one the finer
/// of the track's ([`track_cross_range_m`], endfire included) and the panel's.
pub fn pair_cell_m3(
    point: Vec3,
    array: &PlanarArray,
    aperture: &VirtualAperture,
    wavelength_m: f32,
    bandwidth_hz: f32,
) -> (f32, f32) {
    let [r, _, h, z] = pair_resolution_axes(point, array, aperture, wavelength_m, bandwidth_hz);
    let track = track_cross_range_m(point, aperture, wavelength_m);
    (r.1 * track.min(h.1) * z.1, z.1)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn panel() -> PlanarArray {
        PlanarArray {
            centre: Vec3::new(10.0, 0.0, 5.0),
            boresight_az_rad: std::f32::consts::PI,
            rows: 32,
            cols: 32,
            width_m: 1.0,
            height_m: 0.5,
        }
    }

    #[test]
    fn panel_spans_its_width_and_height_around_the_centre() {
        let a = panel();
        let els = a.elements(1);
        assert_eq!(els.len(), 1024);
        let mean = els.iter().copied().sum::<Vec3>() / els.len() as f32;
        assert!(mean.distance(a.centre) < 1e-5);
        let (dx, dz) = a.spacing_m();
        assert!((dx - 1.0 / 32.0).abs() < 1e-7 && (dz - 0.5 / 32.0).abs() < 1e-7);
        // Element 0 is bottom-left seen from behind: column runs along the tangent.
        let first = a.element(0, 0);
        let last = a.element(31, 31);
        assert!((last.z - first.z - 31.0 * dz).abs() < 1e-5);
        assert!(((last - first).dot(a.tangent()) - 31.0 * dx).abs() < 1e-5);
        // The panel is vertical and perpendicular to the boresight.
        assert!((last - first).dot(a.boresight()).abs() < 1e-5);
        assert_eq!(a.elements(4).len(), 64);
    }

    /// `|Σ_k e^{j2π(|q − e_k| − |p − e_k|)/λ}| / N` over the panel's elements: 1 when the panel
    /// receives an echo from `q` with the phases it expects from `p`.
    fn array_match(a: &PlanarArray, lambda: f32, p: Vec3, q: Vec3) -> f64 {
        let els = a.elements(1);
        let (mut re, mut im) = (0.0f64, 0.0f64);
        for e in &els {
            let d = (q.as_dvec3().distance(e.as_dvec3()) - p.as_dvec3().distance(e.as_dvec3()))
                / lambda as f64;
            re += (std::f64::consts::TAU * d).cos();
            im += (std::f64::consts::TAU * d).sin();
        }
        re.hypot(im) / els.len() as f64
    }

    #[test]
    fn a_grating_alias_has_the_points_range_and_array_phases() {
        // The paper's panel: 1 m wide over 32 columns, 3.125 cm ≈ 1.04 λ at 10 GHz.
        let (a, lambda) = (panel(), 0.03f32);
        let (p, tx) = (Vec3::new(-20.0, 8.0, 3.0), Vec3::new(-5.0, -10.0, 1.5));
        let range = |q: Vec3| crate::bistatic_range(q, tx, a.centre);
        let aliases = a.grating_aliases(lambda, p, tx);
        assert!(!aliases.is_empty());
        for q in &aliases {
            assert!((range(*q) - range(p)).abs() < 1e-3, "{q}");
            assert!(q.distance(p) > 5.0, "{q}");
            // The whole panel sees q's echo with p's phases (near-field residue aside).
            let m = array_match(&a, lambda, p, *q);
            assert!(m > 0.9, "{q}: {m}");
        }
        // Half an alias step away (same range) the panel does not match: the aliases are what
        // the lattice makes, not any nearby direction.
        let q = aliases[0];
        let mid = a.centre
            + ((p - a.centre).normalize() + (q - a.centre).normalize()).normalize()
                * (p - a.centre).length();
        assert!(array_match(&a, lambda, p, mid) < 0.2);
        // A λ/2 panel has none.
        let fine = PlanarArray {
            width_m: 32.0 * 0.015,
            ..panel()
        };
        assert!(fine.grating_aliases(lambda, p, tx).is_empty());
    }

    #[test]
    fn a_track_resolves_least_along_its_own_line() {
        let ap = VirtualAperture {
            start: Vec3::new(-1.5, 0.0, 1.5),
            end: Vec3::new(1.5, 0.0, 1.5),
            positions: 200,
        };
        let lambda = 0.03;
        // Broadside at 20 m: λR/L = 0.2 m, the figure of pair_resolution_axes.
        let broadside = track_cross_range_m(Vec3::new(0.0, 20.0, 1.5), &ap, lambda);
        assert!((broadside - 0.2).abs() < 1e-4, "{broadside}");
        // On the track's line at 20 m: R·√(2λ/L) = 2.83 m.
        let endfire = track_cross_range_m(Vec3::new(-20.0, 0.0, 1.5), &ap, lambda);
        assert!(
            (endfire - 20.0 * (2.0f32 * lambda / 3.0).sqrt()).abs() < 1e-3,
            "{endfire}"
        );
        // 30° off the line: λR/(L sin 30°), twice the broadside figure.
        let p = Vec3::new(
            -20.0 * 30f32.to_radians().cos(),
            20.0 * 30f32.to_radians().sin(),
            1.5,
        );
        assert!((track_cross_range_m(p, &ap, lambda) - 0.4).abs() < 1e-3);
    }

    #[test]
    fn a_track_does_not_place_in_height_a_point_on_its_own_line() {
        // A vehicle's 3 m track at 1.5 m, the panel 60 m off at 20 m; a ground point 30 m along
        // the track's line, 1 m below it. The track's cross-range direction there is nearly
        // vertical (the small offset is all that is across the line of sight), but the track
        // resolves it only by R·√(2λ/L), metres: the height must come from the panel.
        let ap = VirtualAperture {
            start: Vec3::new(-1.5, 0.0, 1.5),
            end: Vec3::new(1.5, 0.0, 1.5),
            positions: 200,
        };
        let a = PlanarArray {
            centre: Vec3::new(0.0, 60.0, 20.0),
            boresight_az_rad: -std::f32::consts::FRAC_PI_2,
            ..panel()
        };
        let (lambda, b) = (0.03, 400e6);
        let p = Vec3::new(-30.0, 0.0, 0.5);
        let [_, (dir, res), ..] = pair_resolution_axes(p, &a, &ap, lambda, b);
        assert!(
            dir.z.abs() > 0.9,
            "the track's direction there is about vertical: {dir}"
        );
        assert!(
            (res - track_cross_range_m(p, &ap, lambda)).abs() < 1e-6 && res > 3.0,
            "{res}"
        );
        // The height is the panel's: its vertical cross-range, not the track's broadside λR/L.
        let h = vertical_extent_m(p, &a, &ap, lambda, b);
        let panel_v = lambda * a.centre.distance(p) / a.height_m;
        assert!(h > 0.5 * panel_v, "{h} vs the panel's {panel_v}");
        // With the broadside λR/L = 0.3 m along that direction, it was about that.
        assert!(h > 5.0 * lambda * 30.0 / 3.0, "{h}");
    }

    #[test]
    fn aperture_positions_are_even_and_include_both_ends() {
        let ap = VirtualAperture {
            start: Vec3::ZERO,
            end: Vec3::new(3.0, 0.0, 0.0),
            positions: 4,
        };
        let p = ap.positions(1);
        assert_eq!(p, vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0, Vec3::X * 3.0]);
        assert_eq!(ap.positions(2).len(), 2);
        assert_eq!(ap.length_m(), 3.0);
    }

    #[test]
    fn nyquist_spacing_is_half_a_wavelength_for_a_full_half_space() {
        let d = nyquist_spacing_m(0.03, std::f32::consts::FRAC_PI_2);
        assert!((d - 0.015).abs() < 1e-7);
        assert!(nyquist_spacing_m(0.03, 0.5) > d);
    }

    #[test]
    fn monostatic_range_resolution_is_half_the_path_resolution() {
        let a = panel();
        let ap = VirtualAperture {
            start: a.centre,
            end: a.centre,
            positions: 1,
        };
        let (r, ..) = pair_resolution_m(Vec3::new(-20.0, 0.0, 5.0), &a, &ap, 0.03, 400e6);
        assert!((r - 0.374_740_6).abs() < 1e-4, "{r}");
    }
}
