//! A small s–t minimum cut for image grids (Boykov–Kolmogorov, iterative, integer capacities).
//!
//! Written by hand (see ARCHITECTURE.md): the graphs here are
//! small (a refinement crop has at most a few thousand pixels), the solver must run on
//! `wasm32-unknown-unknown` without threads, and it must not recurse (a search path can be as
//! long as the graph has nodes, which overflows wasm's small stack). The tests keep a Dinic
//! solver as the reference it is checked against.
//!
//! As in Kolmogorov's own implementation, the terminals are not nodes: each inner node keeps
//! one residual terminal capacity (from the source when positive, to the sink when negative),
//! and the nodes with one start in the search trees. A refinement crop ties almost every pixel
//! to a terminal; as arcs of two hub nodes those were a fifth of the arcs, and every
//! augmenting path ran through them. Measured: the same cuts (the pipeline digest did not
//! change), and a modest gain: one `perf` run of the moving-camera detector on DAVIS bus took
//! about a tenth fewer samples in all, the cut's share about the same.

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
    /// Residual terminal capacity per inner node: from the source when positive, to the
    /// sink when negative.
    terminal: Vec<i64>,
    /// Net terminal capacity per inner node as given (from the source minus to the sink),
    /// for [`FlowGraph::set_terminals`].
    given: Vec<i64>,
    /// Flow already routed source → node → sink when a node got capacity both ways.
    preflow: i64,
}

/// Search-tree membership of a node in Boykov–Kolmogorov.
const FREE: u8 = 0;
const S_TREE: u8 = 1;
const T_TREE: u8 = 2;
/// Parent marker of the nodes tied to their tree's terminal.
const ROOT: u32 = u32::MAX - 1;

const NONE: u32 = u32::MAX;

impl FlowGraph {
    /// A graph with `n` inner nodes (`0..n`); the source is `n` and the sink `n + 1`.
    pub fn new(n: usize) -> Self {
        Self {
            n,
            head: vec![NONE; n],
            next: Vec::new(),
            to: Vec::new(),
            cap: Vec::new(),
            terminal: vec![0; n],
            given: vec![0; n],
            preflow: 0,
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

    /// Capacity `c` from the source to `u` (`to_source`) or from `u` to the sink; what meets
    /// capacity the other way is routed source → `u` → sink at once.
    fn tie(&mut self, u: usize, c: i64, to_source: bool) {
        let c = c.max(0);
        self.given[u] += if to_source { c } else { -c };
        let t = &mut self.terminal[u];
        let opposite = if to_source { (-*t).max(0) } else { (*t).max(0) };
        self.preflow += c.min(opposite);
        *t += if to_source { c } else { -c };
    }

    /// An edge `u → v` of capacity `c_uv` and its reverse of capacity `c_vu` (0 for a directed
    /// edge; equal for the undirected smoothness edges of a grid). Either end may be the
    /// source or the sink; arcs into the source or out of the sink carry no flow and are
    /// dropped.
    pub fn add_edge(&mut self, u: usize, v: usize, c_uv: i32, c_vu: i32) {
        let (s, t) = (self.source(), self.sink());
        match (u, v) {
            (u, v) if u == s && v == t => self.preflow += i64::from(c_uv.max(0)),
            (u, v) if u == t && v == s => self.preflow += i64::from(c_vu.max(0)),
            (u, v) if u == s => self.tie(v, c_uv.into(), true),
            (u, v) if v == s => self.tie(u, c_vu.into(), true),
            (u, v) if v == t => self.tie(u, c_uv.into(), false),
            (u, v) if u == t => self.tie(v, c_vu.into(), false),
            (u, v) => {
                self.arc(u, v, c_uv);
                self.arc(v, u, c_vu);
            }
        }
    }

    /// Terminal edges of node `u`: `to_source` is paid when `u` ends on the sink side,
    /// `to_sink` when it ends on the source side. The common part is cut for sure and dropped
    /// (it is not counted in the flow).
    pub fn add_terminals(&mut self, u: usize, to_source: i32, to_sink: i32) {
        let m = to_source.min(to_sink);
        self.tie(u, i64::from(to_source - m), true);
        self.tie(u, i64::from(to_sink - m), false);
    }

    /// Sets node `u`'s terminal capacities, replacing those given before. After a cut (the
    /// arcs between nodes stay) [`FlowGraph::recut`] then starts from the flow already found
    /// instead of from zero (Kohli and Torr's dynamic graph cuts). The flow through `u`'s terminals is kept;
    /// where the new capacity is below it, the same amount is added to both of `u`'s terminal
    /// capacities, which every cut pays once and so moves no cut.
    pub fn set_terminals(&mut self, u: usize, to_source: i32, to_sink: i32) {
        let net = i64::from(to_source) - i64::from(to_sink);
        self.terminal[u] += net - self.given[u];
        self.given[u] = net;
    }

    /// The minimum cut, also after [`FlowGraph::set_terminals`] changed a cut graph: for each
    /// inner node whether it is on the source side (the smallest source side, as
    /// [`FlowGraph::min_cut`]'s, whose flow value counts only from the graph as first built).
    pub fn recut(&mut self) -> Vec<bool> {
        self.min_cut().0
    }

    /// Runs the max-flow and returns, for each inner node, whether it is on the source side of
    /// the minimum cut, with the cut's value.
    ///
    /// The source side is the set of nodes reachable from the source in the final residual
    /// graph: the smallest source side of any minimum cut, the same whichever maximum flow
    /// the solver found.
    ///
    /// Boykov–Kolmogorov (two search trees grown from the terminals, augmenting where they
    /// meet, orphans re-adopted; with their timestamp and distance heuristic): on the
    /// refinement's grids, where most paths are short, it is several times faster than
    /// Dinic's phases of breadth-first searches over the whole graph.
    pub fn min_cut(&mut self) -> (Vec<bool>, i64) {
        let mut bk = Search::new(self);
        let mut flow = bk.g.preflow;
        while let Some(meet) = bk.grow() {
            flow += bk.augment(meet);
            bk.adopt();
        }
        let side = bk.tree.iter().map(|&v| v == S_TREE).collect();
        (side, flow)
    }
}

/// The state of one Boykov–Kolmogorov run over a graph's residual capacities.
struct Search<'g> {
    g: &'g mut FlowGraph,
    /// [`FREE`], [`S_TREE`] or [`T_TREE`] per node.
    tree: Vec<u8>,
    /// The arc to the node's parent: in S the arc parent → node, in T the arc node → parent;
    /// [`ROOT`] for the nodes tied to the terminal, [`NONE`] for free nodes and orphans.
    parent: Vec<u32>,
    /// When the node's distance to its terminal was last known right (the heuristic's clock).
    stamp: Vec<u32>,
    /// The node's distance to its terminal, valid at `stamp`.
    dist: Vec<u32>,
    /// Nodes that may still grow their tree, in FIFO order.
    active: std::collections::VecDeque<u32>,
    queued: Vec<bool>,
    orphans: Vec<u32>,
    time: u32,
}

impl<'g> Search<'g> {
    /// Every node with terminal capacity starts in its terminal's tree, active.
    fn new(g: &'g mut FlowGraph) -> Self {
        let n = g.n;
        let mut bk = Search {
            g,
            tree: vec![FREE; n],
            parent: vec![NONE; n],
            stamp: vec![0; n],
            dist: vec![0; n],
            active: std::collections::VecDeque::with_capacity(n),
            queued: vec![false; n],
            orphans: Vec::new(),
            time: 1,
        };
        for v in 0..n {
            let t = bk.g.terminal[v];
            if t != 0 {
                bk.tree[v] = if t > 0 { S_TREE } else { T_TREE };
                bk.parent[v] = ROOT;
                bk.stamp[v] = bk.time;
                bk.dist[v] = 1;
                bk.activate(v);
            }
        }
        bk
    }

    fn activate(&mut self, v: usize) {
        if !self.queued[v] {
            self.queued[v] = true;
            self.active.push_back(v as u32);
        }
    }

    /// The tail of arc `e` (arcs come in pairs `e`, `e ^ 1`).
    fn tail(&self, e: u32) -> usize {
        self.g.to[(e ^ 1) as usize] as usize
    }

    /// The parent of `v` through its parent arc `e`, in tree `side`.
    fn up(&self, side: u8, e: u32) -> usize {
        if side == S_TREE {
            self.tail(e)
        } else {
            self.g.to[e as usize] as usize
        }
    }

    /// The arc between `v` and its neighbour across arc `e` (leaving `v`) that carries flow
    /// in tree `side`'s direction: away from the source in S (`v → q`), towards the sink in
    /// T (`q → v`) when `v` grows; reversed when `v` looks for a parent.
    fn tree_arc(side: u8, e: u32, growing: bool) -> u32 {
        if (side == S_TREE) == growing {
            e
        } else {
            e ^ 1
        }
    }

    /// Growth: active nodes extend their trees until the trees meet. Returns the arc from the
    /// S side to the T side where they met, `None` when no augmenting path is left.
    fn grow(&mut self) -> Option<u32> {
        while let Some(&p) = self.active.front() {
            let p = p as usize;
            let side = self.tree[p];
            if side != FREE {
                let mut e = self.g.head[p];
                while e != NONE {
                    let q = self.g.to[e as usize] as usize;
                    let arc = Self::tree_arc(side, e, true);
                    if self.g.cap[arc as usize] > 0 {
                        if self.tree[q] == FREE {
                            self.tree[q] = side;
                            self.parent[q] = arc;
                            self.stamp[q] = self.stamp[p];
                            self.dist[q] = self.dist[p] + 1;
                            self.activate(q);
                        } else if self.tree[q] != side {
                            // `p` stays active: it may meet the other tree again.
                            return Some(arc);
                        }
                    }
                    e = self.g.next[e as usize];
                }
            }
            self.active.pop_front();
            self.queued[p] = false;
        }
        None
    }

    /// Pushes the path's bottleneck along source → … tail(meet) → head(meet) … → sink; nodes
    /// whose parent arc or terminal capacity it exhausts become orphans. Returns the flow
    /// pushed.
    fn augment(&mut self, meet: u32) -> i64 {
        self.time += 1;
        let ends = [
            (S_TREE, self.tail(meet)),
            (T_TREE, self.g.to[meet as usize] as usize),
        ];
        let mut f = i64::from(self.g.cap[meet as usize]);
        for (side, start) in ends {
            let mut v = start;
            while self.parent[v] != ROOT {
                f = f.min(i64::from(self.g.cap[self.parent[v] as usize]));
                v = self.up(side, self.parent[v]);
            }
            f = f.min(self.g.terminal[v].abs());
        }
        // `f` is at most the meeting arc's capacity, an `i32`.
        let fa = f as i32;
        self.g.cap[meet as usize] -= fa;
        self.g.cap[(meet ^ 1) as usize] += fa;
        for (side, start) in ends {
            let mut v = start;
            while self.parent[v] != ROOT {
                let e = self.parent[v];
                self.g.cap[e as usize] -= fa;
                self.g.cap[(e ^ 1) as usize] += fa;
                let next = self.up(side, e);
                if self.g.cap[e as usize] == 0 {
                    self.parent[v] = NONE;
                    self.orphans.push(v as u32);
                }
                v = next;
            }
            let t = &mut self.g.terminal[v];
            *t += if side == S_TREE { -f } else { f };
            if *t == 0 {
                self.parent[v] = NONE;
                self.orphans.push(v as u32);
            }
        }
        f
    }

    /// Whether `q`'s path to its terminal (in tree `side`) is intact, and its length; the
    /// path is stamped with its distances so later checks stop early.
    fn root_distance(&mut self, side: u8, q: usize) -> Option<u32> {
        let mut d = 0u32;
        let mut u = q;
        loop {
            if self.stamp[u] == self.time {
                d += self.dist[u];
                break;
            }
            match self.parent[u] {
                NONE => return None,
                ROOT => {
                    self.stamp[u] = self.time;
                    self.dist[u] = 1;
                    d += 1;
                    break;
                }
                pa => {
                    d += 1;
                    u = self.up(side, pa);
                }
            }
        }
        let (mut u, mut du) = (q, d);
        while self.stamp[u] != self.time {
            self.stamp[u] = self.time;
            self.dist[u] = du;
            du = du.saturating_sub(1);
            u = self.up(side, self.parent[u]);
        }
        Some(d)
    }

    /// Adoption: each orphan takes the neighbour in its own tree with an open arc to it and
    /// the shortest intact path to the terminal as its parent, or leaves the tree: its
    /// neighbours that could grow into it again become active, its children orphans. (An
    /// orphan has no terminal capacity left: a node with some keeps its terminal as parent.)
    fn adopt(&mut self) {
        while let Some(o) = self.orphans.pop() {
            let o = o as usize;
            let side = self.tree[o];
            let mut best: Option<(u32, u32)> = None;
            let mut e = self.g.head[o];
            while e != NONE {
                let q = self.g.to[e as usize] as usize;
                let arc = Self::tree_arc(side, e, false);
                if self.tree[q] == side && self.g.cap[arc as usize] > 0 {
                    if let Some(d) = self.root_distance(side, q) {
                        if best.is_none_or(|(_, bd)| d < bd) {
                            best = Some((arc, d));
                        }
                    }
                }
                e = self.g.next[e as usize];
            }
            if let Some((arc, d)) = best {
                self.parent[o] = arc;
                self.stamp[o] = self.time;
                self.dist[o] = d + 1;
                continue;
            }
            let mut e = self.g.head[o];
            while e != NONE {
                let q = self.g.to[e as usize] as usize;
                if self.tree[q] == side {
                    if self.g.cap[Self::tree_arc(side, e, false) as usize] > 0 {
                        self.activate(q);
                    }
                    let pq = self.parent[q];
                    if pq != NONE && pq != ROOT && self.up(side, pq) == o {
                        self.parent[q] = NONE;
                        self.orphans.push(q as u32);
                    }
                }
                e = self.g.next[e as usize];
            }
            self.tree[o] = FREE;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The graph with its terminals as arcs of two extra nodes (`n` the source, `n + 1` the
    /// sink), for the reference solver.
    fn with_terminal_arcs(g: &FlowGraph) -> FlowGraph {
        let mut a = g.clone();
        a.head.extend([NONE, NONE]);
        let (s, t) = (g.n, g.n + 1);
        for (v, &c) in g.terminal.iter().enumerate() {
            let c = i32::try_from(c.abs()).expect("terminal capacity fits an i32 here");
            if g.terminal[v] > 0 {
                a.arc(s, v, c);
                a.arc(v, s, 0);
            } else if g.terminal[v] < 0 {
                a.arc(v, t, c);
                a.arc(t, v, 0);
            }
        }
        a
    }

    /// Dinic's algorithm over the terminal arcs: the reference the Boykov–Kolmogorov solver
    /// is checked against.
    fn dinic(g: &FlowGraph) -> (Vec<bool>, i64) {
        let mut g = with_terminal_arcs(g);
        let g = &mut g;
        let mut level = vec![-1; g.n + 2];
        let mut iter = vec![NONE; g.n + 2];
        let mut flow = 0i64;
        while bfs(g, &mut level) {
            flow += blocking_flow(g, &mut level, &mut iter);
        }
        flow += g.preflow;
        // After the last BFS, the nodes it reached are the source side.
        let side = level[..g.n].iter().map(|&l| l >= 0).collect();
        (side, flow)
    }

    fn bfs(g: &FlowGraph, level: &mut [i32]) -> bool {
        let (s, t) = (g.source(), g.sink());
        level.iter_mut().for_each(|l| *l = -1);
        let mut queue = std::collections::VecDeque::with_capacity(g.n + 2);
        level[s] = 0;
        queue.push_back(s);
        while let Some(u) = queue.pop_front() {
            let mut e = g.head[u];
            while e != NONE {
                let v = g.to[e as usize] as usize;
                if g.cap[e as usize] > 0 && level[v] < 0 {
                    level[v] = level[u] + 1;
                    queue.push_back(v);
                }
                e = g.next[e as usize];
            }
        }
        level[t] >= 0
    }

    /// One blocking flow along the level graph, with an explicit path stack.
    fn blocking_flow(g: &mut FlowGraph, level: &mut [i32], iter: &mut [u32]) -> i64 {
        let (s, t) = (g.source(), g.sink());
        iter.copy_from_slice(&g.head);
        let mut total = 0i64;
        let mut path: Vec<u32> = Vec::new();
        let mut u = s;
        loop {
            if u == t {
                let f = path.iter().map(|&e| g.cap[e as usize]).min().unwrap_or(0);
                let mut cut_at = path.len();
                for (i, &e) in path.iter().enumerate() {
                    g.cap[e as usize] -= f;
                    g.cap[(e ^ 1) as usize] += f;
                    if g.cap[e as usize] == 0 && cut_at == path.len() {
                        cut_at = i;
                    }
                }
                total += f as i64;
                path.truncate(cut_at);
                u = match path.last() {
                    Some(&e) => g.to[e as usize] as usize,
                    None => s,
                };
                continue;
            }
            let mut advanced = false;
            while iter[u] != NONE {
                let e = iter[u] as usize;
                let v = g.to[e] as usize;
                if g.cap[e] > 0 && level[v] == level[u] + 1 {
                    path.push(e as u32);
                    u = v;
                    advanced = true;
                    break;
                }
                iter[u] = g.next[e];
            }
            if advanced {
                continue;
            }
            // Dead end: no augmenting path leaves `u` in this phase.
            level[u] = -1;
            match path.pop() {
                None => return total,
                Some(e) => {
                    let tail = g.to[(e ^ 1) as usize] as usize;
                    iter[tail] = g.next[e as usize];
                    u = tail;
                }
            }
        }
    }

    /// Random grids like the refinement's (terminal costs on most pixels, a few hard seeds,
    /// symmetric smoothness edges to the 8-neighbours, capacities from 1 to ~10⁴): the
    /// Boykov–Kolmogorov cut equals Dinic's, flow and source side (the smallest source side
    /// is unique, whichever maximum flow was found).
    #[test]
    fn boykov_kolmogorov_equals_dinic_on_random_grids() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = |m: u64| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state % m
        };
        for case in 0..60 {
            let (w, h) = (2 + rnd(40) as usize, 2 + rnd(40) as usize);
            let n = w * h;
            let mut a = FlowGraph::new(n);
            let scale = [4, 100, 10_000][case % 3];
            for p in 0..n {
                match rnd(20) {
                    0 => a.add_terminals(p, INFINITE, 0),
                    1 => a.add_terminals(p, 0, INFINITE),
                    _ => {
                        let (x, y) = (rnd(scale) as i32, rnd(scale) as i32);
                        a.add_terminals(p, x, y);
                    }
                }
            }
            for y in 0..h {
                for x in 0..w {
                    for (dx, dy) in [(1i32, 0i32), (0, 1), (1, 1), (-1, 1)] {
                        let (nx, ny) = (x as i32 + dx, y as i32 + dy);
                        if nx < 0 || ny < 0 || nx >= w as i32 || ny >= h as i32 {
                            continue;
                        }
                        let c = rnd(scale / 2 + 1) as i32;
                        a.add_edge(y * w + x, ny as usize * w + nx as usize, c, c);
                    }
                }
            }
            let b = a.clone();
            let (side_bk, flow_bk) = a.min_cut();
            let (side_d, flow_d) = dinic(&b);
            assert_eq!(flow_bk, flow_d, "case {case}: {w}×{h}");
            assert_eq!(side_bk, side_d, "case {case}: {w}×{h}");

            // New terminal capacities on the cut graph (as refinement's next round sets
            // them): the recut from the kept flow equals a fresh graph's cut.
            let mut fresh = FlowGraph::new(n);
            for p in 0..n {
                let (x, y) = match rnd(20) {
                    0 => (INFINITE, 0),
                    1 => (0, INFINITE),
                    _ => (rnd(scale) as i32, rnd(scale) as i32),
                };
                a.set_terminals(p, x, y);
                fresh.add_terminals(p, x, y);
            }
            fresh.to.clone_from(&b.to);
            fresh.next.clone_from(&b.next);
            fresh.head.clone_from(&b.head);
            fresh.cap.clone_from(&b.cap);
            let (side_fresh, _) = dinic(&fresh);
            assert_eq!(a.recut(), side_fresh, "case {case}: {w}×{h}, recut");
        }
    }

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
