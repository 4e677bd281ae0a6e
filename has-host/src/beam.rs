//! Beam selection with a DFT codebook of a base station's uniform planar array (UPA), from
//! propagation paths.
//!
//! # Array
//! A vertical `rows × cols` panel with element spacing `spacing_wl` wavelengths in both
//! directions, its normal horizontal at azimuth `boresight_az_rad` (from +x toward +y):
//! `n = (cos ψ, sin ψ, 0)`, horizontal panel axis `h = (−sin ψ, cos ψ, 0)` (n turned +90° about
//! z), vertical axis `z`. Element `(r, c)` sits at `spacing·λ·(c·h + r·z)` from the first one.
//! Elements are isotropic (like the tracer's antennas), so a direction behind the panel has the
//! same response as its mirror image in front.
//!
//! # Codebook
//! For a departure direction `d` (unit, from the angles ZoD θ, AoD φ of the paths) the direction
//! cosines are `u = h·d`, `v = z·d`; the steering vector is `e^{j2π s (c·u + r·v)}` with `s` the
//! spacing in wavelengths. Beam `(k, l)` (`k < cols`, `l < rows`) is the DFT column pair with
//! spatial frequencies `ψ_k = (k − (cols−1)/2)/cols`, `ψ_l = (l − (rows−1)/2)/rows` (cycles per
//! element, symmetric about broadside; at λ/2 spacing beam k points at `u = 2ψ_k`), normalised
//! to unit norm: the beams are orthonormal and the array gain of a path on a beam centre is
//! `rows·cols`. Beam index `b = l·cols + k`.
//!
//! # Gain of a beam
//! Narrowband, at the carrier: `G_b = |Σ_p a_p · w_bᴴ a(d_p)|²` — the coherent sum of the path
//! amplitudes `a_p` (which carry the carrier phase) through the array response, i.e. the power
//! a single-antenna UE receives when the BS transmits on beam `b`. It factorises per axis:
//! `w_bᴴ a(d) = F_cols(s·u − ψ_k) · F_rows(s·v − ψ_l)` with
//! `F_N(x) = N^{−1/2} Σ_{m<N} e^{j2π m x}`.

use num_complex::Complex64;

use crate::multipath::MultipathError;
use crate::paths::Path;

/// A DFT codebook of a vertical UPA (see module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct DftCodebook {
    rows: usize,
    cols: usize,
    spacing_wl: f64,
    boresight_az_rad: f64,
}

/// A path as the codebook sees it: complex amplitude and departure angles (rad).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Complex amplitude (carrier phase included).
    pub a: Complex64,
    /// Azimuth of departure, rad.
    pub aod: f64,
    /// Zenith of departure, rad.
    pub zod: f64,
}

impl From<&Path> for Ray {
    fn from(p: &Path) -> Self {
        Ray {
            a: p.a,
            aod: p.aod,
            zod: p.zod,
        }
    }
}

/// `F_N(x) = N^{−1/2} Σ_{m<N} e^{j2π m x}` for each `x` of `xs`.
fn array_factor(n: usize, x: f64) -> Complex64 {
    let step = Complex64::from_polar(1.0, 2.0 * std::f64::consts::PI * x);
    let mut acc = Complex64::new(0.0, 0.0);
    let mut ph = Complex64::new(1.0, 0.0);
    for _ in 0..n {
        acc += ph;
        ph *= step;
    }
    acc / (n as f64).sqrt()
}

impl DftCodebook {
    /// A `rows × cols` codebook, spacing in wavelengths, boresight azimuth in radians.
    ///
    /// # Errors
    /// [`MultipathError::OutOfRange`] naming `rows`, `cols`, `spacing_wl` or `boresight_az_rad`.
    pub fn new(
        rows: usize,
        cols: usize,
        spacing_wl: f64,
        boresight_az_rad: f64,
    ) -> Result<DftCodebook, MultipathError> {
        for (what, v) in [("rows", rows), ("cols", cols)] {
            if v == 0 {
                return Err(MultipathError::OutOfRange {
                    what,
                    value: 0.0,
                    expected: ">= 1",
                });
            }
        }
        if !(spacing_wl.is_finite() && spacing_wl > 0.0) {
            return Err(MultipathError::OutOfRange {
                what: "spacing_wl",
                value: spacing_wl,
                expected: "finite and > 0",
            });
        }
        if !boresight_az_rad.is_finite() {
            return Err(MultipathError::OutOfRange {
                what: "boresight_az_rad",
                value: boresight_az_rad,
                expected: "finite",
            });
        }
        Ok(DftCodebook {
            rows,
            cols,
            spacing_wl,
            boresight_az_rad,
        })
    }

    /// Number of beams (`rows·cols`).
    pub fn len(&self) -> usize {
        self.rows * self.cols
    }

    /// Always false (a codebook has at least one beam).
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Direction cosines `(u, v)` of the departure direction with angles `(aod, zod)`.
    pub fn direction_cosines(&self, aod: f64, zod: f64) -> (f64, f64) {
        let (st, ct) = zod.sin_cos();
        let d = (st * aod.cos(), st * aod.sin(), ct);
        let (sp, cp) = self.boresight_az_rad.sin_cos();
        (-sp * d.0 + cp * d.1, d.2)
    }

    /// The `(k, l)` of beam `b` (column, row).
    pub fn beam_kl(&self, b: usize) -> (usize, usize) {
        (b % self.cols, b / self.cols)
    }

    /// Spatial frequencies `(ψ_k, ψ_l)` of beam `b`, cycles per element.
    pub fn beam_frequencies(&self, b: usize) -> (f64, f64) {
        let (k, l) = self.beam_kl(b);
        (
            (k as f64 - (self.cols as f64 - 1.0) / 2.0) / self.cols as f64,
            (l as f64 - (self.rows as f64 - 1.0) / 2.0) / self.rows as f64,
        )
    }

    /// `G_b` of every beam (index `l·cols + k`), linear power (see module docs).
    pub fn beam_gains(&self, rays: &[Ray]) -> Vec<f64> {
        let mut field = vec![Complex64::new(0.0, 0.0); self.len()];
        let mut fc = vec![Complex64::new(0.0, 0.0); self.cols];
        let mut fr = vec![Complex64::new(0.0, 0.0); self.rows];
        for r in rays {
            let (u, v) = self.direction_cosines(r.aod, r.zod);
            for (k, f) in fc.iter_mut().enumerate() {
                let (psi, _) = self.beam_frequencies(k);
                *f = array_factor(self.cols, self.spacing_wl * u - psi);
            }
            for (l, f) in fr.iter_mut().enumerate() {
                let (_, psi) = self.beam_frequencies(l * self.cols);
                *f = r.a * array_factor(self.rows, self.spacing_wl * v - psi);
            }
            for (l, frl) in fr.iter().enumerate() {
                let row = &mut field[l * self.cols..(l + 1) * self.cols];
                for (x, fck) in row.iter_mut().zip(&fc) {
                    *x += frl * fck;
                }
            }
        }
        field.iter().map(|x| x.norm_sqr()).collect()
    }

    /// The beam with the highest gain and that gain (`None` without rays; ties: lowest index).
    pub fn best_beam(&self, rays: &[Ray]) -> Option<(usize, f64)> {
        if rays.is_empty() {
            return None;
        }
        best_of(&self.beam_gains(rays))
    }
}

/// Index and value of the largest gain (ties: lowest index; `None` if empty).
pub fn best_of(gains: &[f64]) -> Option<(usize, f64)> {
    let mut best: Option<(usize, f64)> = None;
    for (i, &g) in gains.iter().enumerate() {
        if best.is_none_or(|(_, b)| g > b) {
            best = Some((i, g));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Angles (aod, zod) of the direction with cosines (u, v) in front of a panel with boresight
    /// azimuth `psi`.
    fn angles_for(psi: f64, u: f64, v: f64) -> (f64, f64) {
        let w = (1.0 - u * u - v * v).sqrt();
        let (sp, cp) = psi.sin_cos();
        // d = w·n + u·h + v·z
        let d = (w * cp - u * sp, w * sp + u * cp, v);
        (d.1.atan2(d.0), d.2.acos())
    }

    fn ray(cb: &DftCodebook, u: f64, v: f64, a: Complex64) -> Ray {
        let (aod, zod) = angles_for(cb.boresight_az_rad, u, v);
        Ray { a, aod, zod }
    }

    #[test]
    fn path_on_a_beam_centre_gets_full_array_gain_on_that_beam_only() {
        let cb = DftCodebook::new(32, 32, 0.5, 0.7).unwrap();
        // Beam (k, l) = (20, 9): u = 2ψ_k, v = 2ψ_l at λ/2.
        let b = 9 * 32 + 20;
        let (pk, pl) = cb.beam_frequencies(b);
        let a = Complex64::from_polar(1e-4, 0.3);
        let g = cb.beam_gains(&[ray(&cb, 2.0 * pk, 2.0 * pl, a)]);
        // Array gain rows·cols = 1024 on the beam; the DFT beams are orthogonal, so every other
        // beam's response is a zero of the Dirichlet kernel (round-off only: ~1e-15 relative).
        let peak = 1024.0 * a.norm_sqr();
        assert!((g[b] - peak).abs() < 1e-9 * peak, "{} vs {peak}", g[b]);
        for (i, &x) in g.iter().enumerate() {
            if i != b {
                assert!(x < 1e-20 * peak, "beam {i}: {x}");
            }
        }
        assert_eq!(
            cb.best_beam(&[ray(&cb, 2.0 * pk, 2.0 * pl, a)]).unwrap().0,
            b
        );
    }

    #[test]
    fn direction_between_two_beams_picks_the_nearer_one() {
        let cb = DftCodebook::new(32, 32, 0.5, -1.2).unwrap();
        let b0 = 16 * 32 + 10;
        let (pk, pl) = cb.beam_frequencies(b0);
        // A quarter of the beam spacing (2/32 in u) toward beam k+1: beam k still wins.
        let r = ray(
            &cb,
            2.0 * pk + 0.25 * 2.0 / 32.0,
            2.0 * pl,
            Complex64::new(1.0, 0.0),
        );
        assert_eq!(cb.best_beam(&[r]).unwrap().0, b0);
        let r = ray(
            &cb,
            2.0 * pk + 0.75 * 2.0 / 32.0,
            2.0 * pl,
            Complex64::new(1.0, 0.0),
        );
        assert_eq!(cb.best_beam(&[r]).unwrap().0, b0 + 1);
    }

    #[test]
    fn two_paths_on_one_beam_add_coherently() {
        let cb = DftCodebook::new(8, 8, 0.5, 0.0).unwrap();
        let b = 3 * 8 + 5;
        let (pk, pl) = cb.beam_frequencies(b);
        let a = Complex64::new(1.0, 0.0);
        let r1 = ray(&cb, 2.0 * pk, 2.0 * pl, a);
        // Same direction in front and behind the panel (mirror through its plane): isotropic
        // elements see the same u, v.
        let mut r2 = r1;
        r2.aod = std::f64::consts::PI - r1.aod; // boresight 0: mirror y-z plane flips x
        let in_phase = cb.beam_gains(&[r1, r2])[b];
        assert!((in_phase - 4.0 * 64.0).abs() < 1e-9, "{in_phase}");
        r2.a = -a;
        let opposite = cb.beam_gains(&[r1, r2])[b];
        assert!(opposite < 1e-18, "{opposite}");
    }

    #[test]
    fn bad_codebook_parameters_are_named() {
        assert_eq!(
            DftCodebook::new(0, 32, 0.5, 0.0).unwrap_err().to_string(),
            "rows: 0 is out of range (>= 1)"
        );
        assert!(DftCodebook::new(32, 0, 0.5, 0.0)
            .unwrap_err()
            .to_string()
            .starts_with("cols: 0"));
        assert!(DftCodebook::new(32, 32, f64::NAN, 0.0)
            .unwrap_err()
            .to_string()
            .starts_with("spacing_wl: NaN"));
        assert!(DftCodebook::new(32, 32, 0.5, f64::INFINITY)
            .unwrap_err()
            .to_string()
            .starts_with("boresight_az_rad: inf"));
        let cb = DftCodebook::new(4, 4, 0.5, 0.0).unwrap();
        assert_eq!(cb.best_beam(&[]), None);
        assert_eq!(best_of(&[1.0, 3.0, 3.0, 2.0]), Some((1, 3.0)));
    }
}
