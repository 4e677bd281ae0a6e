//! Comparing two multipath sets of one link (paper §2, Fig. 8): the paths ray-traced on the true
//! scene and those predicted on the digital twin.
//!
//! # Method
//! 1. **Parameters** ([`PathParams`]): delay τ, gain, and the four angles of a
//!    [`crate::paths::Path`] (AoD φ_D, ZoD θ_D, AoA φ_A, ZoA θ_A, Sionna's conventions: zenith θ
//!    from +z, azimuth φ from +x toward +y, radians).
//! 2. **Window** ([`within_window`]): a set keeps the paths whose gain is within `window_db` of
//!    its own strongest path (the paper keeps 20 dB).
//! 3. **Chamfer-style matching** ([`chamfer_match`]): every path of one set is paired with its
//!    nearest path of the other set, in both directions (true → twin and twin → true), so a
//!    missing path and a spurious path both show up as errors.
//! 4. **Errors** ([`ParamErrors`]): absolute differences of the matched pair, parameter by
//!    parameter; azimuth differences are wrapped to [0, π] ([`wrap_angle`]), zenith differences
//!    need no wrap (θ ∈ [0, π]).
//!
//! # Distance normalisation
//! The five parameters have different units, so the nearest-neighbour distance is taken in a
//! normalised space ([`MatchScale`]):
//! `d² = (Δτ/s_τ)² + (Δφ_D/s_θ)² + (Δθ_D/s_θ)² + (Δφ_A/s_θ)² + (Δθ_A/s_θ)²`,
//! azimuths wrapped. The default `s_τ = 1 ns`, `s_θ = 1°` weighs one nanosecond of delay like one
//! degree of angle — the units in which the paper reports its errors (its 90th percentiles are
//! 3.5 ns and 1–3°, i.e. comparable numbers). At 10 GHz one nanosecond is 30 cm of path length;
//! distinct paths of one link (line of sight, ground bounce, wall bounces) differ by several ns or
//! degrees, so they are not confused at this scale.
//!
//! Percentiles ([`percentile`]) interpolate linearly between order statistics (numpy's default,
//! "type 7").

use crate::paths::{Interaction, Path, MAX_ORDER};

/// Why a comparison could not be made.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MultipathError {
    /// A parameter is out of range.
    #[error("{what}: {value} is out of range ({expected})")]
    OutOfRange {
        /// Parameter name.
        what: &'static str,
        /// The value.
        value: f64,
        /// What was expected.
        expected: &'static str,
    },
    /// An empty input where values are needed.
    #[error("{what}: empty")]
    Empty {
        /// Input name.
        what: &'static str,
    },
}

/// The parameters of one path used for matching: delay, gain and angles (radians).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathParams {
    /// Delay τ, seconds.
    pub delay_s: f64,
    /// Gain `20·log10|a|`, dB.
    pub gain_db: f64,
    /// Azimuth of departure, rad.
    pub aod: f64,
    /// Zenith of departure, rad.
    pub zod: f64,
    /// Azimuth of arrival, rad.
    pub aoa: f64,
    /// Zenith of arrival, rad.
    pub zoa: f64,
    /// Number of interactions (0: line of sight).
    pub order: usize,
    /// Object ([`crate::Scene::objects`] index) of each interaction, transmitter first; the
    /// first `order` entries are valid, the rest `u32::MAX`.
    pub objects: [u32; MAX_ORDER],
}

impl PathParams {
    /// The objects the path interacts with, transmitter first (empty for line of sight).
    pub fn objects(&self) -> &[u32] {
        &self.objects[..self.order.min(MAX_ORDER)]
    }
}

impl From<&Path> for PathParams {
    fn from(p: &Path) -> Self {
        let mut objects = [u32::MAX; MAX_ORDER];
        let mut order = 0;
        for i in &p.interactions {
            match i {
                Interaction::Reflection { object, .. }
                | Interaction::Diffraction { object, .. } => {
                    if order < MAX_ORDER {
                        objects[order] = *object;
                    }
                    order += 1;
                }
                Interaction::Los => {}
            }
        }
        PathParams {
            delay_s: p.delay_s,
            gain_db: p.gain_db(),
            aod: p.aod,
            zod: p.zod,
            aoa: p.aoa,
            zoa: p.zoa,
            order,
            objects,
        }
    }
}

/// Normalisation of the matching distance (see module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MatchScale {
    /// Delay difference counted as one unit, seconds.
    pub delay_s: f64,
    /// Angle difference counted as one unit, radians.
    pub angle_rad: f64,
}

impl Default for MatchScale {
    /// 1 ns and 1°.
    fn default() -> Self {
        MatchScale {
            delay_s: 1e-9,
            angle_rad: 1f64.to_radians(),
        }
    }
}

impl MatchScale {
    /// Checks both scales are finite and positive.
    ///
    /// # Errors
    /// [`MultipathError::OutOfRange`] naming `delay_s` or `angle_rad`.
    pub fn check(&self) -> Result<(), MultipathError> {
        for (what, value) in [("delay_s", self.delay_s), ("angle_rad", self.angle_rad)] {
            if !(value.is_finite() && value > 0.0) {
                return Err(MultipathError::OutOfRange {
                    what,
                    value,
                    expected: "finite and > 0",
                });
            }
        }
        Ok(())
    }
}

/// Absolute per-parameter differences of two paths (seconds, radians).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamErrors {
    /// |Δτ|, seconds.
    pub delay_s: f64,
    /// |Δφ_A| wrapped to [0, π], rad.
    pub aoa: f64,
    /// |Δφ_D| wrapped to [0, π], rad.
    pub aod: f64,
    /// |Δθ_A|, rad.
    pub zoa: f64,
    /// |Δθ_D|, rad.
    pub zod: f64,
}

impl ParamErrors {
    /// The errors between `a` and `b` (symmetric).
    pub fn between(a: &PathParams, b: &PathParams) -> ParamErrors {
        ParamErrors {
            delay_s: (a.delay_s - b.delay_s).abs(),
            aoa: wrap_angle(a.aoa - b.aoa).abs(),
            aod: wrap_angle(a.aod - b.aod).abs(),
            zoa: (a.zoa - b.zoa).abs(),
            zod: (a.zod - b.zod).abs(),
        }
    }

    /// The normalised distance `d` of the module docs.
    pub fn distance(&self, scale: &MatchScale) -> f64 {
        let t = self.delay_s / scale.delay_s;
        let s = scale.angle_rad;
        (t * t
            + (self.aoa / s).powi(2)
            + (self.aod / s).powi(2)
            + (self.zoa / s).powi(2)
            + (self.zod / s).powi(2))
        .sqrt()
    }
}

/// An angle difference wrapped to (−π, π].
pub fn wrap_angle(rad: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    let r = rad.rem_euclid(TAU);
    if r > PI {
        r - TAU
    } else {
        r
    }
}

/// The strongest gain of `paths`, dB (`None` for no path).
pub fn strongest_db(paths: &[PathParams]) -> Option<f64> {
    paths.iter().map(|p| p.gain_db).reduce(f64::max)
}

/// The paths within `window_db` of the strongest (gain ≥ strongest − window), in input order.
///
/// # Errors
/// [`MultipathError::OutOfRange`] for a window that is negative or not finite.
pub fn within_window(
    paths: &[PathParams],
    window_db: f64,
) -> Result<Vec<PathParams>, MultipathError> {
    if !(window_db.is_finite() && window_db >= 0.0) {
        return Err(MultipathError::OutOfRange {
            what: "window_db",
            value: window_db,
            expected: "finite and >= 0",
        });
    }
    let Some(best) = strongest_db(paths) else {
        return Ok(Vec::new());
    };
    Ok(paths
        .iter()
        .filter(|p| p.gain_db >= best - window_db)
        .copied()
        .collect())
}

/// One path of a set paired with its nearest path of the other set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Match {
    /// Index of the path in the set it comes from.
    pub from: usize,
    /// Index of its nearest path in the other set.
    pub to: usize,
    /// Normalised distance (see module docs).
    pub distance: f64,
    /// Per-parameter errors of the pair.
    pub errors: ParamErrors,
}

/// For every path of `from`, its nearest path of `to` (ties: the lower index). Empty if `to` is
/// empty. Brute force: a link has tens of paths.
pub fn nearest_matches(from: &[PathParams], to: &[PathParams], scale: &MatchScale) -> Vec<Match> {
    if to.is_empty() {
        return Vec::new();
    }
    from.iter()
        .enumerate()
        .map(|(i, a)| {
            let mut best: Option<Match> = None;
            for (j, b) in to.iter().enumerate() {
                let errors = ParamErrors::between(a, b);
                let distance = errors.distance(scale);
                if best.is_none_or(|m| distance < m.distance) {
                    best = Some(Match {
                        from: i,
                        to: j,
                        distance,
                        errors,
                    });
                }
            }
            best.expect("`to` is not empty")
        })
        .collect()
}

/// Both directions of the Chamfer-style matching of two sets.
#[derive(Clone, Debug, PartialEq)]
pub struct ChamferMatch {
    /// Every path of the reference (true) set with its nearest predicted path.
    pub forward: Vec<Match>,
    /// Every predicted (twin) path with its nearest reference path.
    pub backward: Vec<Match>,
}

impl ChamferMatch {
    /// All pairs, forward first.
    pub fn all(&self) -> impl Iterator<Item = &Match> {
        self.forward.iter().chain(&self.backward)
    }
}

/// Matches `reference` (true) and `predicted` (twin) both ways (see module docs).
///
/// # Errors
/// [`MultipathError::OutOfRange`] for a bad scale.
pub fn chamfer_match(
    reference: &[PathParams],
    predicted: &[PathParams],
    scale: &MatchScale,
) -> Result<ChamferMatch, MultipathError> {
    scale.check()?;
    Ok(ChamferMatch {
        forward: nearest_matches(reference, predicted, scale),
        backward: nearest_matches(predicted, reference, scale),
    })
}

/// The `q`-th percentile (0 … 100) of `values`, linearly interpolated between order statistics
/// (rank `q/100·(n−1)`).
///
/// # Errors
/// [`MultipathError::Empty`] for no value, [`MultipathError::OutOfRange`] for `q` outside
/// [0, 100] or a NaN value.
pub fn percentile(values: &[f64], q: f64) -> Result<f64, MultipathError> {
    if !(0.0..=100.0).contains(&q) {
        return Err(MultipathError::OutOfRange {
            what: "percentile",
            value: q,
            expected: "in [0, 100]",
        });
    }
    if values.is_empty() {
        return Err(MultipathError::Empty { what: "values" });
    }
    if let Some(&v) = values.iter().find(|v| v.is_nan()) {
        return Err(MultipathError::OutOfRange {
            what: "values",
            value: v,
            expected: "not NaN",
        });
    }
    let mut s = values.to_vec();
    s.sort_by(f64::total_cmp);
    let rank = q / 100.0 * (s.len() - 1) as f64;
    let lo = rank.floor() as usize;
    let hi = rank.ceil() as usize;
    Ok(s[lo] + (s[hi] - s[lo]) * (rank - lo as f64))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn p(delay_ns: f64, aod_deg: f64, zod_deg: f64, aoa_deg: f64, zoa_deg: f64) -> PathParams {
        PathParams {
            delay_s: delay_ns * 1e-9,
            gain_db: -80.0,
            aod: aod_deg.to_radians(),
            zod: zod_deg.to_radians(),
            aoa: aoa_deg.to_radians(),
            zoa: zoa_deg.to_radians(),
            order: 0,
            objects: [u32::MAX; MAX_ORDER],
        }
    }

    #[test]
    fn wrap_angle_maps_into_half_open_pi_interval() {
        // Exact in binary for these multiples of π up to one rounding of rem_euclid (≤ 1 ulp of
        // 2π ≈ 9e-16).
        for (x, want) in [
            (0.0, 0.0),
            (PI, PI),
            (-PI, PI),
            (3.0 * PI / 2.0, -PI / 2.0),
            (-3.0 * PI / 2.0, PI / 2.0),
            (2.0 * PI + 0.25, 0.25),
            (-0.25, -0.25),
        ] {
            assert!(
                (wrap_angle(x) - want).abs() < 1e-15,
                "{x} -> {}",
                wrap_angle(x)
            );
        }
    }

    #[test]
    fn azimuth_error_across_minus_pi_is_small() {
        // 179° and −179° are 2° apart, not 358°.
        let e = ParamErrors::between(
            &p(10.0, 179.0, 90.0, -179.0, 90.0),
            &p(10.0, -179.0, 90.0, 179.0, 90.0),
        );
        assert!((e.aod.to_degrees() - 2.0).abs() < 1e-9);
        assert!((e.aoa.to_degrees() - 2.0).abs() < 1e-9);
        assert_eq!(e.delay_s, 0.0);
    }

    #[test]
    fn distance_weighs_one_ns_like_one_degree() {
        let s = MatchScale::default();
        let a = p(100.0, 10.0, 80.0, -30.0, 95.0);
        let d1 = ParamErrors::between(&a, &p(101.0, 10.0, 80.0, -30.0, 95.0)).distance(&s);
        let d2 = ParamErrors::between(&a, &p(100.0, 11.0, 80.0, -30.0, 95.0)).distance(&s);
        assert!(
            (d1 - 1.0).abs() < 1e-9 && (d2 - 1.0).abs() < 1e-9,
            "{d1} {d2}"
        );
        // 3-4-5 across two parameters.
        let d = ParamErrors::between(&a, &p(103.0, 10.0, 80.0, -30.0, 99.0)).distance(&s);
        assert!((d - 5.0).abs() < 1e-9, "{d}");
    }

    #[test]
    fn chamfer_pairs_each_path_with_its_nearest_both_ways() {
        // Reference: LOS and a ground bounce; prediction: both slightly off plus a spurious path.
        let r = [
            p(300.0, 40.0, 80.0, -140.0, 100.0),
            p(302.0, 40.0, 83.0, -140.0, 83.0),
        ];
        let t = [
            p(300.5, 40.2, 80.0, -140.0, 100.0),
            p(302.0, 40.0, 83.3, -140.0, 83.0),
            p(350.0, 90.0, 85.0, 170.0, 90.0),
        ];
        let m = chamfer_match(&r, &t, &MatchScale::default()).unwrap();
        let fw: Vec<usize> = m.forward.iter().map(|x| x.to).collect();
        assert_eq!(fw, vec![0, 1]);
        let bw: Vec<usize> = m.backward.iter().map(|x| x.to).collect();
        assert_eq!(
            bw,
            vec![0, 1, 1],
            "the spurious path pairs with its nearest"
        );
        assert!((m.forward[0].errors.delay_s - 0.5e-9).abs() < 1e-15);
        assert!((m.forward[0].errors.aod.to_degrees() - 0.2).abs() < 1e-9);
        assert!((m.forward[1].errors.zod.to_degrees() - 0.3).abs() < 1e-9);
        // The spurious path's errors are large: 48 ns, 50° in AoD.
        assert!((m.backward[2].errors.delay_s - 48e-9).abs() < 1e-15);
        assert!((m.backward[2].errors.aod.to_degrees() - 50.0).abs() < 1e-9);
        assert_eq!(m.all().count(), 5);
    }

    #[test]
    fn matching_against_an_empty_set_gives_no_pairs() {
        let r = [p(1.0, 0.0, 90.0, 0.0, 90.0)];
        let m = chamfer_match(&r, &[], &MatchScale::default()).unwrap();
        assert!(m.forward.is_empty() && m.backward.is_empty());
    }

    #[test]
    fn bad_scale_is_named() {
        let bad = MatchScale {
            delay_s: 0.0,
            angle_rad: 1.0,
        };
        assert_eq!(
            chamfer_match(&[], &[], &bad).unwrap_err().to_string(),
            "delay_s: 0 is out of range (finite and > 0)"
        );
        let bad = MatchScale {
            delay_s: 1e-9,
            angle_rad: f64::NAN,
        };
        assert!(chamfer_match(&[], &[], &bad)
            .unwrap_err()
            .to_string()
            .starts_with("angle_rad: NaN"));
    }

    #[test]
    fn window_keeps_paths_within_db_of_the_strongest() {
        let mut a = p(1.0, 0.0, 90.0, 0.0, 90.0);
        let mut v = Vec::new();
        for g in [-70.0, -89.9, -90.0, -90.1, -120.0] {
            a.gain_db = g;
            v.push(a);
        }
        let k = within_window(&v, 20.0).unwrap();
        let gains: Vec<f64> = k.iter().map(|x| x.gain_db).collect();
        assert_eq!(gains, vec![-70.0, -89.9, -90.0]);
        assert_eq!(strongest_db(&v), Some(-70.0));
        assert!(within_window(&[], 20.0).unwrap().is_empty());
        assert_eq!(
            within_window(&v, -1.0).unwrap_err().to_string(),
            "window_db: -1 is out of range (finite and >= 0)"
        );
        assert!(within_window(&v, f64::INFINITY).is_err());
    }

    #[test]
    fn percentile_interpolates_order_statistics_like_numpy() {
        // numpy.percentile([4, 1, 3, 2], q) = 1, 1.3, 2.5, 3.7, 4 for q = 0, 10, 50, 90, 100.
        let v = [4.0, 1.0, 3.0, 2.0];
        for (q, want) in [
            (0.0, 1.0),
            (10.0, 1.3),
            (50.0, 2.5),
            (90.0, 3.7),
            (100.0, 4.0),
        ] {
            assert!((percentile(&v, q).unwrap() - want).abs() < 1e-12, "q {q}");
        }
        assert_eq!(percentile(&[7.0], 90.0).unwrap(), 7.0);
        assert_eq!(
            percentile(&[], 50.0).unwrap_err(),
            MultipathError::Empty { what: "values" }
        );
        assert!(percentile(&v, 101.0)
            .unwrap_err()
            .to_string()
            .starts_with("percentile: 101"));
        assert!(percentile(&[1.0, f64::NAN], 50.0).is_err());
    }
}
