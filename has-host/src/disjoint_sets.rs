//! Disjoint sets (union–find) over the indices `0..n`: which elements a set of pairwise links
//! joins into one component. Path halving on every find; a union makes the smaller root the
//! parent, so after any sequence of unions each component's root is its smallest index, whatever
//! the order of the links (deterministic labels for parallel callers that collect links first).

/// Disjoint sets over `0..len()` (module docs).
#[derive(Clone, Debug, Default)]
pub struct DisjointSets {
    parent: Vec<u32>,
}

impl DisjointSets {
    /// `n` singletons.
    pub fn new(n: usize) -> DisjointSets {
        let mut s = DisjointSets::default();
        s.reset(n);
        s
    }

    /// Makes the structure `n` singletons again, keeping its allocation.
    pub fn reset(&mut self, n: usize) {
        self.parent.clear();
        self.parent.extend(0..n as u32);
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        self.parent.len()
    }

    /// Whether there are no elements.
    pub fn is_empty(&self) -> bool {
        self.parent.is_empty()
    }

    /// The root of `a`'s component: its smallest index.
    pub fn find(&mut self, mut a: u32) -> u32 {
        while self.parent[a as usize] != a {
            let g = self.parent[self.parent[a as usize] as usize];
            self.parent[a as usize] = g;
            a = g;
        }
        a
    }

    /// Joins the components of `a` and `b`.
    pub fn union(&mut self, a: u32, b: u32) {
        let (a, b) = (self.find(a), self.find(b));
        if a != b {
            self.parent[a.max(b) as usize] = a.min(b);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_component_s_root_is_its_smallest_index_in_any_link_order() {
        let links = [(5u32, 3u32), (3, 7), (1, 2), (7, 0), (6, 6)];
        let mut forward = DisjointSets::new(8);
        let mut backward = DisjointSets::new(8);
        for &(a, b) in &links {
            forward.union(a, b);
        }
        for &(a, b) in links.iter().rev() {
            backward.union(b, a);
        }
        let roots = |s: &mut DisjointSets| (0..8).map(|i| s.find(i)).collect::<Vec<_>>();
        let want = vec![0, 1, 1, 0, 4, 0, 6, 0];
        assert_eq!(roots(&mut forward), want);
        assert_eq!(roots(&mut backward), want);
        forward.reset(3);
        assert_eq!(forward.len(), 3);
        assert_eq!(
            (0..3).map(|i| forward.find(i)).collect::<Vec<_>>(),
            [0, 1, 2]
        );
    }
}
