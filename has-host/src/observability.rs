//! How much of the true surface each base station–aperture pairing of a scenario could observe,
//! before imaging anything: the planning question behind "which BS pairs with which aperture
//! follows from visibility", and the ceiling of a reconstruction. `has-sim observability` prints
//! this call's [`ObservabilityReport`].
//!
//! A truth point counts as observed by a pairing when it sees the pairing's panel centre and at
//! least one of its aperture's start, centre and end ([`imaging::observable_truth`], the same test
//! as the observable / hidden split of the reconstruction's report). A set of pairings observes
//! the points that any of its members observes. Percentages are of the ground-truth samples
//! (`imaging.truth_density_per_m2` on the `imaging.truth_objects`), i.e. of the area.

use serde::Serialize;

use crate::imaging::{self, PairPlan, RunError};
use crate::scenario::Scenario;

/// One base station–aperture pairing in an [`ObservabilityReport`].
#[derive(Clone, Debug, Serialize)]
pub struct PairingObservability {
    /// `BS-aperture`.
    pub pair: String,
    /// Percentage of the truth points it observes.
    pub observed_pct: f64,
    /// Whether the reconstruction images it ([`imaging::plan_pairs`]).
    pub imaged: bool,
    /// Index of its base station in the scenario (not serialized: `pair` names it).
    #[serde(skip)]
    pub bs: usize,
    /// Index of its aperture in the scenario (not serialized: `pair` names it).
    #[serde(skip)]
    pub aperture: usize,
}

/// What every pairing of a scenario observes, alone and together.
#[derive(Clone, Debug, Serialize)]
pub struct ObservabilityReport {
    /// Ground-truth samples.
    pub truth_points: usize,
    /// Every pairing ([`imaging::every_pairing`], base station by base station).
    pub pairs: Vec<PairingObservability>,
    /// Percentage observed by the imaged pairs together.
    pub imaged_pairs_pct: f64,
    /// Percentage observed by every pairing together.
    pub every_pairing_pct: f64,
}

/// Flags of the points that any of `sets` flags (each set one flag per point, `n` points).
pub fn observed_by_any<'a>(sets: impl IntoIterator<Item = &'a [bool]>, n: usize) -> Vec<bool> {
    let mut any = vec![false; n];
    for s in sets {
        any.iter_mut().zip(s).for_each(|(a, &b)| *a |= b);
    }
    any
}

/// The observability of every pairing of `sc` (validated; apply a preset before), alone and
/// together (module docs).
///
/// # Errors
/// As [`imaging::build_world`] and [`imaging::plan_pairs`].
pub fn observability(sc: &Scenario) -> Result<ObservabilityReport, RunError> {
    let world = imaging::build_world(sc)?;
    let planned = imaging::choose_pairs(sc, &world)?;
    let every = imaging::every_pairing(sc);
    let is_planned = |p: &PairPlan| {
        planned
            .iter()
            .any(|q| q.bs == p.bs && q.aperture == p.aperture)
    };
    // One line-of-sight pass per pairing; the unions are ORs of those.
    let seen: Vec<Vec<bool>> = every
        .iter()
        .map(|p| imaging::observable_truth(sc, &world, std::slice::from_ref(p)))
        .collect();
    let n = world.truth.len();
    let union = |keep: &dyn Fn(&PairPlan) -> bool| {
        let sets = every
            .iter()
            .zip(&seen)
            .filter(|(p, _)| keep(p))
            .map(|(_, s)| s.as_slice());
        imaging::share_pct(&observed_by_any(sets, n))
    };
    Ok(ObservabilityReport {
        truth_points: n,
        pairs: every
            .iter()
            .zip(&seen)
            .map(|(p, s)| PairingObservability {
                pair: p.name.clone(),
                observed_pct: imaging::share_pct(s),
                imaged: is_planned(p),
                bs: p.bs,
                aperture: p.aperture,
            })
            .collect(),
        imaged_pairs_pct: union(&is_planned),
        every_pairing_pct: union(&|_| true),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_point_observed_by_several_pairings_counts_once_in_their_union() {
        // Point 0 seen by both pairings, point 1 by one, point 2 by none: the union observes
        // two of three points, 66.7 %, not the 100 % a sum of the shares (2/3 + 1/3) would give.
        let a = [true, true, false];
        let b = [true, false, false];
        let any = observed_by_any([&a[..], &b[..]], 3);
        assert_eq!(any, [true, true, false]);
        assert!((imaging::share_pct(&any) - 200.0 / 3.0).abs() < 1e-12);
        // A union observes at least each of its members, and no set observes nothing.
        assert!(imaging::share_pct(&any) >= imaging::share_pct(&a));
        assert_eq!(observed_by_any(std::iter::empty(), 3), [false; 3]);
    }
}
