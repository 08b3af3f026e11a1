//! A small s–t minimum cut for image grids (Dinic's algorithm, iterative, integer capacities).
//!
//! Written by hand (see ARCHITECTURE.md): the graphs here are
//! small (a refinement crop has at most a few thousand pixels), the solver must run on
//! `wasm32-unknown-unknown` without threads, and it must not recurse (a blocking-flow DFS can be
//! as deep as the graph has nodes, which overflows wasm's small stack).

/// Capacity that no cut will pay: hard constraints.
pub const INFINITE: i32 = 1 << 28;

/// A directed graph with a source and a sink, built once and cut once.
#[derive(Debug, Clone)]
pub struct FlowGraph {
    n: usize,
    head: Vec<u32>,
    next: Vec<u32>,
    to: Vec<u32>,
    cap: Vec<i32>,
    level: Vec<i32>,
    iter: Vec<u32>,
}

const NONE: u32 = u32::MAX;

impl FlowGraph {
    /// A graph with `n` inner nodes (`0..n`); the source is `n` and the sink `n + 1`.
    pub fn new(n: usize) -> Self {
        Self {
            n,
            head: vec![NONE; n + 2],
            next: Vec::new(),
            to: Vec::new(),
            cap: Vec::new(),
            level: vec![-1; n + 2],
            iter: vec![NONE; n + 2],
        }
    }

    /// The source node.
    pub fn source(&self) -> usize {
        self.n
    }

    /// The sink node.
    pub fn sink(&self) -> usize {
        self.n + 1
    }

    fn arc(&mut self, u: usize, v: usize, c: i32) {
        self.to.push(v as u32);
        self.cap.push(c.max(0));
        self.next.push(self.head[u]);
        self.head[u] = (self.to.len() - 1) as u32;
    }

    /// An edge `u → v` of capacity `c_uv` and its reverse of capacity `c_vu` (0 for a directed
    /// edge; equal for the undirected smoothness edges of a grid).
    pub fn add_edge(&mut self, u: usize, v: usize, c_uv: i32, c_vu: i32) {
        self.arc(u, v, c_uv);
        self.arc(v, u, c_vu);
    }

    /// Terminal edges of node `u`: `to_source` is paid when `u` ends on the sink side,
    /// `to_sink` when it ends on the source side. The common part is cut for sure and dropped,
    /// which leaves at most one terminal edge per node (less work for the flow).
    pub fn add_terminals(&mut self, u: usize, to_source: i32, to_sink: i32) {
        let m = to_source.min(to_sink);
        let (a, b) = (to_source - m, to_sink - m);
        if a > 0 {
            let s = self.source();
            self.add_edge(s, u, a, 0);
        }
        if b > 0 {
            let t = self.sink();
            self.add_edge(u, t, b, 0);
        }
    }

    fn bfs(&mut self) -> bool {
        let (s, t) = (self.source(), self.sink());
        self.level.iter_mut().for_each(|l| *l = -1);
        let mut queue = std::collections::VecDeque::with_capacity(self.n + 2);
        self.level[s] = 0;
        queue.push_back(s);
        while let Some(u) = queue.pop_front() {
            let mut e = self.head[u];
            while e != NONE {
                let v = self.to[e as usize] as usize;
                if self.cap[e as usize] > 0 && self.level[v] < 0 {
                    self.level[v] = self.level[u] + 1;
                    queue.push_back(v);
                }
                e = self.next[e as usize];
            }
        }
        self.level[t] >= 0
    }

    /// One blocking flow along the level graph, with an explicit path stack.
    fn blocking_flow(&mut self) -> i64 {
        let (s, t) = (self.source(), self.sink());
        self.iter.copy_from_slice(&self.head);
        let mut total = 0i64;
        let mut path: Vec<u32> = Vec::new();
        let mut u = s;
        loop {
            if u == t {
                let f = path
                    .iter()
                    .map(|&e| self.cap[e as usize])
                    .min()
                    .unwrap_or(0);
                let mut cut_at = path.len();
                for (i, &e) in path.iter().enumerate() {
                    self.cap[e as usize] -= f;
                    self.cap[(e ^ 1) as usize] += f;
                    if self.cap[e as usize] == 0 && cut_at == path.len() {
                        cut_at = i;
                    }
                }
                total += f as i64;
                path.truncate(cut_at);
                u = match path.last() {
                    Some(&e) => self.to[e as usize] as usize,
                    None => s,
                };
                continue;
            }
            let mut advanced = false;
            while self.iter[u] != NONE {
                let e = self.iter[u] as usize;
                let v = self.to[e] as usize;
                if self.cap[e] > 0 && self.level[v] == self.level[u] + 1 {
                    path.push(e as u32);
                    u = v;
                    advanced = true;
                    break;
                }
                self.iter[u] = self.next[e];
            }
            if advanced {
                continue;
            }
            // Dead end: no augmenting path leaves `u` in this phase.
            self.level[u] = -1;
            match path.pop() {
                None => return total,
                Some(e) => {
                    let tail = self.to[(e ^ 1) as usize] as usize;
                    self.iter[tail] = self.next[e as usize];
                    u = tail;
                }
            }
        }
    }

    /// Runs the max-flow and returns, for each inner node, whether it is on the source side of
    /// the minimum cut, with the cut's value.
    pub fn min_cut(&mut self) -> (Vec<bool>, i64) {
        let mut flow = 0i64;
        while self.bfs() {
            flow += self.blocking_flow();
        }
        // After the last BFS, the nodes it reached are the source side.
        let side = self.level[..self.n].iter().map(|&l| l >= 0).collect();
        (side, flow)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn textbook_cut() {
        // s→0 (3), s→1 (2), 0→1 (1), 0→t (2), 1→t (3): max flow 5.
        let mut g = FlowGraph::new(2);
        let (s, t) = (g.source(), g.sink());
        g.add_edge(s, 0, 3, 0);
        g.add_edge(s, 1, 2, 0);
        g.add_edge(0, 1, 1, 0);
        g.add_edge(0, t, 2, 0);
        g.add_edge(1, t, 3, 0);
        let (_, f) = g.min_cut();
        assert_eq!(f, 5);
    }

    #[test]
    fn chain_cut_at_weakest_link() {
        let n = 5000;
        let mut g = FlowGraph::new(n);
        g.add_terminals(0, INFINITE, 0);
        g.add_terminals(n - 1, 0, INFINITE);
        for i in 0..n - 1 {
            let c = if i == 3000 { 1 } else { 10 };
            g.add_edge(i, i + 1, c, c);
        }
        let (side, f) = g.min_cut();
        assert_eq!(f, 1);
        assert!(side[3000] && !side[3001]);
    }
}
