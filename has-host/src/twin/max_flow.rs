//! A small maximum-flow graph for the twin's minimum cuts (footprint inside / outside, roof
//! label expansions): Dinic's algorithm (breadth-first levels, blocking flows by depth-first
//! search), f64 capacities. The cut is read as the set reachable from the source in the
//! residual graph: the minimal source set, the same for every maximum flow.

/// Directed graph with paired residual edges.
pub(crate) struct FlowGraph {
    head: Vec<Vec<usize>>,
    to: Vec<usize>,
    cap: Vec<f64>,
}

/// Residual capacities at or below this are saturated.
const EPS: f64 = 1e-12;

impl FlowGraph {
    /// A graph of `n` nodes and no edge.
    pub(crate) fn new(n: usize) -> Self {
        Self {
            head: vec![Vec::new(); n],
            to: Vec::new(),
            cap: Vec::new(),
        }
    }

    /// Edge a→b of capacity `ab` and its reverse of capacity `ba`.
    pub(crate) fn add(&mut self, a: usize, b: usize, ab: f64, ba: f64) {
        self.head[a].push(self.to.len());
        self.to.push(b);
        self.cap.push(ab);
        self.head[b].push(self.to.len());
        self.to.push(a);
        self.cap.push(ba);
    }

    /// Pushes a maximum flow from `s` to `t`.
    pub(crate) fn max_flow(&mut self, s: usize, t: usize) {
        let n = self.head.len();
        let mut level = vec![u32::MAX; n];
        let mut next = vec![0usize; n];
        loop {
            level.fill(u32::MAX);
            level[s] = 0;
            let mut queue = std::collections::VecDeque::from([s]);
            while let Some(u) = queue.pop_front() {
                for &e in &self.head[u] {
                    let v = self.to[e];
                    if level[v] == u32::MAX && self.cap[e] > EPS {
                        level[v] = level[u] + 1;
                        queue.push_back(v);
                    }
                }
            }
            if level[t] == u32::MAX {
                return;
            }
            next.fill(0);
            while self.augment(s, t, &level, &mut next) {}
        }
    }

    /// One augmenting path along increasing levels (iterative depth-first search); whether one
    /// was found.
    fn augment(&mut self, s: usize, t: usize, level: &[u32], next: &mut [usize]) -> bool {
        let mut path: Vec<usize> = Vec::new(); // edges
        let mut u = s;
        loop {
            if u == t {
                let push = path.iter().map(|&e| self.cap[e]).fold(f64::MAX, f64::min);
                for &e in &path {
                    self.cap[e] -= push;
                    self.cap[e ^ 1] += push;
                }
                return true;
            }
            let mut advanced = false;
            while next[u] < self.head[u].len() {
                let e = self.head[u][next[u]];
                let v = self.to[e];
                if self.cap[e] > EPS && level[v] == level[u] + 1 {
                    path.push(e);
                    u = v;
                    advanced = true;
                    break;
                }
                next[u] += 1;
            }
            if !advanced {
                // Dead end: retreat and skip the edge that led here.
                let Some(e) = path.pop() else {
                    return false;
                };
                u = self.to[e ^ 1];
                next[u] += 1;
            }
        }
    }

    /// Nodes reachable from `s` in the residual graph.
    pub(crate) fn reachable(&self, s: usize) -> Vec<bool> {
        let mut seen = vec![false; self.head.len()];
        seen[s] = true;
        let mut stack = vec![s];
        while let Some(u) = stack.pop() {
            for &e in &self.head[u] {
                if self.cap[e] > EPS && !seen[self.to[e]] {
                    seen[self.to[e]] = true;
                    stack.push(self.to[e]);
                }
            }
        }
        seen
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cut_of_a_small_graph_is_its_minimum() {
        // s=0, t=3; 0→1 (3), 0→2 (2), 1→2 (1), 1→3 (2), 2→3 (3): max flow 5, and the minimal
        // source set is {s} (both source edges saturate).
        let mut g = FlowGraph::new(4);
        g.add(0, 1, 3.0, 0.0);
        g.add(0, 2, 2.0, 0.0);
        g.add(1, 2, 1.0, 0.0);
        g.add(1, 3, 2.0, 0.0);
        g.add(2, 3, 3.0, 0.0);
        g.max_flow(0, 3);
        assert_eq!(g.reachable(0), vec![true, false, false, false]);
        // 0→1 (1) only: the cut is that edge, and 1 stays on the sink side.
        let mut g = FlowGraph::new(4);
        g.add(0, 1, 1.0, 0.0);
        g.add(1, 3, 5.0, 0.0);
        g.add(0, 2, 5.0, 0.0);
        g.add(2, 3, 1.0, 0.0);
        g.max_flow(0, 3);
        assert_eq!(g.reachable(0), vec![true, false, true, false]);
    }
}
