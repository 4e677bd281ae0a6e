//! A reconstruction split across processes or machines: shard `I/N` ([`Shard`]) images only its
//! share of the planned pairs ([`super::Prepared::image_shard`]) and records which ones
//! ([`ShardRecord`], `shard.json` of `has-sim reconstruct --shard`); the fusion reads the pair
//! clouds of every shard back ([`assign_pairs`], [`super::read_pair_images_from`]) and fuses them
//! in the scenario's pair order, so that the result does not depend on how the pairs were split
//! or in which order the shards are named.
//!
//! The split is round robin over the planned pairs: pair `k` (0-based, in the order of
//! [`super::Prepared::plans`], aperture then base station) belongs to shard `k mod N + 1`. It
//! needs nothing but the plan, so every shard computes it alone; and since neighbouring pairs
//! share an aperture (the same number of positions, about the same cost), each shard gets every
//! aperture's pairs in turn and the shards' costs differ by about one pair.

use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::imaging::{PairImage, PairPlan, World};

/// Shard `index` of `count` (1 ≤ `index` ≤ `count`), written `I/N`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// 1-based.
    pub index: usize,
    /// How many shards the pairs are split into.
    pub count: usize,
}

/// How the pairs are split among shards (module docs), as `shard.json` states it.
pub const SPLIT: &str =
    "round robin: pair k (0-based, in the scenario's pair order) belongs to shard k mod N + 1";

/// Why a shard or a set of shard directories is refused.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum ShardError {
    /// Not two whole numbers `I/N`.
    #[error("`{0}` is not I/N (shard I of N, whole numbers, 1 ≤ I ≤ N)")]
    Syntax(String),
    /// `N` is zero.
    #[error("`{0}`: N must be at least 1")]
    NoShards(String),
    /// `I` outside `1..=N`.
    #[error("`{0}`: I must be in 1..=N")]
    OutOfRange(String),
    /// A pair held by two directories.
    #[error("pair {pair} is in both {first} and {second}")]
    Duplicate {
        /// The pair's name.
        pair: String,
        /// The directory named first.
        first: String,
        /// The other.
        second: String,
    },
    /// A directory holds a pair the scenario does not plan.
    #[error("{dir} holds pair {pair}, which this scenario does not image")]
    Unknown {
        /// The pair's name.
        pair: String,
        /// The directory.
        dir: String,
    },
    /// Planned pairs no directory holds.
    #[error("{} of {planned} pairs are in none of the directories: {}", .missing.len(), .missing.join(", "))]
    Missing {
        /// Their names, in the scenario's pair order.
        missing: Vec<String>,
        /// Pairs planned.
        planned: usize,
    },
}

impl Shard {
    /// Shard `index` of `count`.
    ///
    /// # Errors
    /// [`ShardError::NoShards`] for `count` 0, [`ShardError::OutOfRange`] for `index` outside
    /// `1..=count`.
    pub fn new(index: usize, count: usize) -> Result<Shard, ShardError> {
        let text = format!("{index}/{count}");
        if count == 0 {
            return Err(ShardError::NoShards(text));
        }
        if !(1..=count).contains(&index) {
            return Err(ShardError::OutOfRange(text));
        }
        Ok(Shard { index, count })
    }

    /// Whether pair `k` (0-based index into the planned pairs) belongs to this shard.
    pub fn holds(&self, k: usize) -> bool {
        k % self.count == self.index - 1
    }

    /// The indices of this shard's pairs among `planned` pairs, in order.
    pub fn pairs(&self, planned: usize) -> Vec<usize> {
        (0..planned).filter(|&k| self.holds(k)).collect()
    }
}

impl FromStr for Shard {
    type Err = ShardError;

    /// `I/N`, e.g. `2/8` (spaces around the numbers are not accepted).
    fn from_str(s: &str) -> Result<Shard, ShardError> {
        let number = |t: &str| {
            (!t.is_empty() && t.bytes().all(|b| b.is_ascii_digit()))
                .then(|| t.parse::<usize>().ok())
                .flatten()
        };
        let (i, n) = s
            .split_once('/')
            .and_then(|(i, n)| Some((number(i)?, number(n)?)))
            .ok_or_else(|| ShardError::Syntax(s.to_string()))?;
        Shard::new(i, n)
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// Where a shard's time went, seconds.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct ShardTimings {
    /// Building the world and planning the pairs.
    pub setup: f64,
    /// Imaging this shard's pairs.
    pub imaging: f64,
    /// Echo synthesis, summed over its pairs.
    pub synthesis: f64,
    /// Back-projection, summed over its pairs.
    pub backprojection: f64,
}

/// What [`super::Prepared::image_shard`] produced.
pub struct ShardImages {
    /// Scene, scatterers, truth and terrain.
    pub world: World,
    /// The shard.
    pub shard: Shard,
    /// Every planned pair of the scenario.
    pub planned: Vec<PairPlan>,
    /// The indices into `planned` of the pairs this shard imaged, in order.
    pub pairs: Vec<usize>,
    /// Their images, one per entry of `pairs`.
    pub images: Vec<PairImage>,
    /// Timings.
    pub timings_s: ShardTimings,
}

/// `shard.json`: which scenario, preset and draw a shard imaged, and which of its pairs it
/// holds. `reconstruct --from-pairs` compares the digest, preset and seed with the scenario it
/// fuses, and the imaging path across shards.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ShardRecord {
    /// The scenario file (or the bundled one).
    pub scenario: String,
    /// `quick` or `default`.
    pub preset: String,
    /// [`crate::scenario::Scenario::digest`] of the scenario as run (preset and seed applied).
    pub scenario_digest: String,
    /// `imaging.seed`, or `--seed`.
    pub seed: u64,
    /// This shard.
    pub shard: Shard,
    /// How the pairs are split ([`SPLIT`]).
    pub split: String,
    /// Pairs the scenario plans (all shards together).
    pub planned_pairs: usize,
    /// The names of the pairs this shard holds (`pair_<name>.ply`), in the scenario's order.
    pub pairs: Vec<String>,
    /// Back-projection path (`f32`, `fixed_point_q15`), the fine pass's back-projection
    /// (`exact`, `factorised`) and the echo kind: what the digest leaves out of how the pairs
    /// were imaged, so that shards imaged differently are not fused together.
    pub imaging: String,
    /// Voxel × profile updates of this shard's pairs.
    pub backprojections: f64,
    /// Timings.
    pub timings_s: ShardTimings,
    /// Peak resident memory of the process, MiB.
    pub peak_rss_mib: Option<f64>,
    /// The work of each of this shard's pairs, in the order of `pairs` (empty in a record
    /// written before it was kept).
    #[serde(default)]
    pub pair_stats: Vec<crate::imaging::PairStats>,
}

/// For each planned pair, the index of the directory that holds it: `held[d]` are the pair
/// names directory `dirs[d]` holds. The result does not depend on the order of the directories
/// except for which one an error names first.
///
/// # Errors
/// [`ShardError::Unknown`] for a name not among `plans`, [`ShardError::Duplicate`] for a pair
/// two directories hold, [`ShardError::Missing`] naming every pair none holds.
pub fn assign_pairs(
    plans: &[PairPlan],
    dirs: &[PathBuf],
    held: &[Vec<String>],
) -> Result<Vec<usize>, ShardError> {
    let mut owner: Vec<Option<usize>> = vec![None; plans.len()];
    for (d, names) in held.iter().enumerate() {
        for name in names {
            let Some(k) = plans.iter().position(|p| &p.name == name) else {
                return Err(ShardError::Unknown {
                    pair: name.clone(),
                    dir: dirs[d].display().to_string(),
                });
            };
            if let Some(first) = owner[k] {
                return Err(ShardError::Duplicate {
                    pair: name.clone(),
                    first: dirs[first].display().to_string(),
                    second: dirs[d].display().to_string(),
                });
            }
            owner[k] = Some(d);
        }
    }
    let missing: Vec<String> = plans
        .iter()
        .zip(&owner)
        .filter(|(_, o)| o.is_none())
        .map(|(p, _)| p.name.clone())
        .collect();
    if !missing.is_empty() {
        return Err(ShardError::Missing {
            missing,
            planned: plans.len(),
        });
    }
    Ok(owner.into_iter().flatten().collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plans(names: &[&str]) -> Vec<PairPlan> {
        names
            .iter()
            .map(|n| PairPlan {
                name: n.to_string(),
                bs: 0,
                aperture: 0,
                positions: 1,
            })
            .collect()
    }

    #[test]
    fn shards_parse_only_as_i_of_n_with_i_in_range() {
        assert_eq!("2/3".parse(), Ok(Shard { index: 2, count: 3 }));
        assert_eq!(
            "1/1".parse::<Shard>().map(|s| s.to_string()),
            Ok("1/1".into())
        );
        for bad in ["a/b", "1", "1/", "/2", "-1/2", "1/2/3", " 1/2", "1.0/2", ""] {
            assert_eq!(
                bad.parse::<Shard>(),
                Err(ShardError::Syntax(bad.into())),
                "{bad}"
            );
        }
        assert_eq!(
            "1/0".parse::<Shard>(),
            Err(ShardError::NoShards("1/0".into()))
        );
        assert_eq!(
            "0/2".parse::<Shard>(),
            Err(ShardError::OutOfRange("0/2".into()))
        );
        assert_eq!(
            "3/2".parse::<Shard>(),
            Err(ShardError::OutOfRange("3/2".into()))
        );
        assert!("99999999999999999999999/2".parse::<Shard>().is_err());
    }

    #[test]
    fn the_shards_of_a_split_hold_every_pair_exactly_once_and_balance() {
        for n in 1..=7 {
            for planned in [0, 1, 5, 24, 25] {
                let mut seen = vec![0; planned];
                let mut sizes = Vec::new();
                for i in 1..=n {
                    let pairs = Shard::new(i, n).unwrap().pairs(planned);
                    assert!(pairs.windows(2).all(|w| w[0] < w[1]));
                    sizes.push(pairs.len());
                    for k in pairs {
                        seen[k] += 1;
                    }
                }
                assert!(seen.iter().all(|&c| c == 1), "{n} shards of {planned}");
                let (lo, hi) = (sizes.iter().min().unwrap(), sizes.iter().max().unwrap());
                assert!(hi - lo <= 1, "{sizes:?}");
            }
        }
        assert_eq!(Shard::new(2, 3).unwrap().pairs(7), vec![1, 4]);
    }

    #[test]
    fn pairs_are_assigned_whatever_the_order_of_the_directories_and_gaps_are_named() {
        let p = plans(&["a", "b", "c", "d"]);
        let dirs = [PathBuf::from("x"), PathBuf::from("y")];
        let held = |v: &[&[&str]]| -> Vec<Vec<String>> {
            v.iter()
                .map(|d| d.iter().map(|s| s.to_string()).collect())
                .collect()
        };
        assert_eq!(
            assign_pairs(&p, &dirs, &held(&[&["a", "c"], &["b", "d"]])),
            Ok(vec![0, 1, 0, 1])
        );
        assert_eq!(
            assign_pairs(&p, &dirs, &held(&[&["d", "b"], &["c", "a"]])),
            Ok(vec![1, 0, 1, 0])
        );
        assert_eq!(
            assign_pairs(&p, &dirs, &held(&[&["a"], &["d"]])),
            Err(ShardError::Missing {
                missing: vec!["b".into(), "c".into()],
                planned: 4
            })
        );
        let dup = assign_pairs(&p, &dirs, &held(&[&["a", "b", "c"], &["c", "d"]]));
        assert_eq!(
            dup.map_err(|e| e.to_string()),
            Err("pair c is in both x and y".into())
        );
        let unknown = assign_pairs(&p, &dirs, &held(&[&["a", "b", "z"], &["c", "d"]]));
        assert!(matches!(unknown, Err(ShardError::Unknown { .. })));
    }
    #[test]
    fn a_record_written_before_the_pairs_stats_were_kept_still_reads() {
        let old = r#"{"scenario": "s.toml", "preset": "default", "scenario_digest": "0e80",
            "seed": 1, "shard": {"index": 1, "count": 24}, "split": "round robin",
            "planned_pairs": 24, "pairs": ["BS1-V1"], "imaging": "f32",
            "backprojections": 1.0, "timings_s": {"setup": 0.1, "imaging": 2.0,
            "synthesis": 0.5, "backprojection": 1.0}, "peak_rss_mib": 700.0}"#;
        let r: ShardRecord = serde_json::from_str(old).expect("old record");
        assert!(r.pair_stats.is_empty());
        assert_eq!(r.pairs, ["BS1-V1"]);
    }
}
