//! Candidate facet sequences, once per transmitter (step 2 of the tracer, see [`crate::paths`]):
//! shoot-and-bounce rays on a Fibonacci sphere, or every sequence ([`CandidateMode::Exhaustive`]),
//! stored as a trie of transmitter images reused for every receiver.

use std::collections::{HashMap, HashSet};

use glam::DVec3;
use rayon::prelude::*;

use super::facets::Facets;
use super::{CandidateMode, TracerConfig, MAX_ORDER};
use crate::scene::Scene;

/// One node of the candidate trie: a facet sequence (this node and its ancestors) with the
/// transmitter's image behind its last facet.
#[derive(Clone, Copy, Debug)]
pub(super) struct Node {
    pub(super) facet: u32,
    pub(super) parent: u32,
    pub(super) depth: u8,
    pub(super) image: DVec3,
}

pub(super) const ROOT: u32 = u32::MAX;

/// Candidate facet sequences for one transmitter, reusable for every receiver.
#[derive(Clone, Debug)]
pub struct TxCandidates {
    /// Transmitter position.
    pub tx: DVec3,
    pub(super) nodes: Vec<Node>,
}

impl TxCandidates {
    /// Number of candidate facet sequences (all orders).
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// True if there is no candidate reflection path.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }
}

/// Facet sequences of orders `1..=k` without immediate repeats over `f` facets,
/// `Σ_j f·(f−1)^(j−1)` (what [`CandidateMode::Exhaustive`] enumerates), in `f64`: no overflow.
pub(super) fn exhaustive_sequences(f: usize, k: usize) -> f64 {
    let f = f as f64;
    (0..k).map(|j| f * (f - 1.0).max(0.0).powi(j as i32)).sum()
}

/// Bytes the exhaustive search holds per facet sequence at its peak: the sequence in the list of
/// all and in the last order's frontier, its trie node and the trie's index entry.
pub(super) const EXHAUSTIVE_BYTES_PER_SEQUENCE: usize =
    2 * std::mem::size_of::<([u32; MAX_ORDER], u8)>() + std::mem::size_of::<Node>() + 24;

/// What the search reads: the scene (for the rays' BVH casts), its facets and the tracer's
/// configuration (order, mode, ray count).
pub(super) struct Search<'s> {
    pub(super) scene: &'s Scene,
    pub(super) facets: &'s Facets,
    pub(super) config: &'s TracerConfig,
}

impl Search<'_> {
    /// Candidate facet sequences for transmitter `tx` (see module docs), as a trie of images.
    /// Runs in parallel (rayon).
    pub(super) fn candidates(&self, tx: DVec3) -> TxCandidates {
        let k = self.config.max_order;
        let mut nodes = Vec::new();
        if k == 0 {
            return TxCandidates { tx, nodes };
        }
        let seqs: Vec<([u32; MAX_ORDER], u8)> = match self.config.candidates {
            CandidateMode::Sbr { rays } => self.sbr_sequences(tx, rays),
            CandidateMode::Exhaustive => self.all_sequences(),
        };
        // Insert into a trie (prefixes first: sequences sorted by length then content).
        let mut seqs = seqs;
        seqs.sort_unstable_by(|a, b| a.1.cmp(&b.1).then(a.0.cmp(&b.0)));
        let mut index: HashMap<(u32, u32), u32> = HashMap::new();
        for (seq, len) in seqs {
            let mut parent = ROOT;
            for (d, &f) in seq[..len as usize].iter().enumerate() {
                let id = match index.get(&(parent, f)) {
                    Some(&id) => id,
                    None => {
                        let src = if parent == ROOT {
                            tx
                        } else {
                            nodes[parent as usize].image
                        };
                        let fc = &self.facets.facets[f as usize];
                        let image = src - 2.0 * (fc.normal.dot(src) - fc.offset) * fc.normal;
                        let id = nodes.len() as u32;
                        nodes.push(Node {
                            facet: f,
                            parent,
                            depth: d as u8 + 1,
                            image,
                        });
                        index.insert((parent, f), id);
                        id
                    }
                };
                parent = id;
            }
        }
        TxCandidates { tx, nodes }
    }

    fn all_sequences(&self) -> Vec<([u32; MAX_ORDER], u8)> {
        let nf = self.facets.facets.len() as u32;
        let mut out = Vec::new();
        let mut frontier: Vec<([u32; MAX_ORDER], u8)> = vec![([0; MAX_ORDER], 0)];
        for _ in 0..self.config.max_order {
            let mut next = Vec::new();
            for (seq, len) in &frontier {
                for f in 0..nf {
                    if *len > 0 && seq[*len as usize - 1] == f {
                        continue;
                    }
                    let mut s = *seq;
                    s[*len as usize] = f;
                    next.push((s, len + 1));
                }
            }
            out.extend_from_slice(&next);
            frontier = next;
        }
        out
    }

    fn sbr_sequences(&self, tx: DVec3, rays: usize) -> Vec<([u32; MAX_ORDER], u8)> {
        let k = self.config.max_order;
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let tx32 = tx.as_vec3();
        let set = (0..rays)
            .into_par_iter()
            .fold(
                HashSet::new,
                |mut set: HashSet<([u32; MAX_ORDER], u8)>, i| {
                    let z = 1.0 - 2.0 * (i as f64 + 0.5) / rays as f64;
                    let r = (1.0 - z * z).max(0.0).sqrt();
                    let phi = golden * i as f64;
                    let mut dir = DVec3::new(r * phi.cos(), r * phi.sin(), z);
                    let mut origin = tx32;
                    let mut seq = [0u32; MAX_ORDER];
                    let mut prev = u32::MAX;
                    for depth in 0..k {
                        let tf = &self.facets.tri_facet;
                        let Some(hit) = self.scene.closest_hit_skipping(
                            origin,
                            dir.as_vec3(),
                            0.0,
                            f32::INFINITY,
                            |t| tf[t as usize] == prev,
                        ) else {
                            break;
                        };
                        let f = tf[hit.triangle as usize];
                        seq[depth] = f;
                        set.insert((seq, depth as u8 + 1));
                        let n = self.facets.facets[f as usize].normal;
                        dir = (dir - 2.0 * dir.dot(n) * n).normalize();
                        origin = hit.point;
                        prev = f;
                    }
                    set
                },
            )
            .reduce(HashSet::new, |mut a, mut b| {
                if a.len() < b.len() {
                    std::mem::swap(&mut a, &mut b);
                }
                a.extend(b);
                a
            });
        set.into_iter().collect()
    }
}
