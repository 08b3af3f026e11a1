//! Nearest-point look-ups over a point set: a k-d tree ([`PointIndex`]) and a uniform grid
//! of buckets for "nearest within `r`" ([`CellIndex`]).

use crate::frame::Point;

/// A static 2-D k-d tree over a point set, for nearest-point queries in `O(log n)` on average
/// (built in `O(n log n)`).
///
/// Non-finite points are left out; the indices it reports refer to the input slice.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PointIndex {
    /// Points with their input index, arranged as an implicit balanced tree: the median of
    /// each range is its node, split on x at even depths and y at odd ones.
    nodes: Vec<(Point, usize)>,
}

impl PointIndex {
    /// Builds the index.
    pub fn new(points: &[Point]) -> Self {
        let mut nodes: Vec<(Point, usize)> = points
            .iter()
            .copied()
            .enumerate()
            .filter(|(_, p)| p.x.is_finite() && p.y.is_finite())
            .map(|(i, p)| (p, i))
            .collect();
        build(&mut nodes, 0);
        Self { nodes }
    }

    /// Number of indexed points.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether no point is indexed.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The indexed point nearest to `q`: `(input index, distance)`; `None` when empty or `q`
    /// is not finite.
    pub fn nearest(&self, q: Point) -> Option<(usize, f64)> {
        if self.nodes.is_empty() || !(q.x.is_finite() && q.y.is_finite()) {
            return None;
        }
        let mut best = (usize::MAX, f64::INFINITY);
        nearest_in(&self.nodes, 0, q, &mut best);
        (best.0 != usize::MAX).then(|| (best.0, best.1.sqrt()))
    }
}

/// A uniform grid of buckets over a point set, for "the nearest point within `r`" queries
/// in `O(1)` when `r` is about the cell size: the colour analyser's look-ups of one shape's
/// samples (laid on a grid `spacing` apart) under another's, where only neighbours within a
/// fraction of the spacing count. [`PointIndex`] answers the same question in `O(log n)` with
/// backtracking; on a crowd's colour comparisons that was 15 % of the frame (issue 10).
///
/// Non-finite points are left out; the indices it reports refer to the input slice.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CellIndex {
    /// Lower corner of cell (0, 0).
    origin: Point,
    /// Cell side.
    cell: f64,
    /// Cells per row and per column.
    cols: usize,
    rows: usize,
    /// Cell `c`'s points are `items[starts[c]..starts[c + 1]]`, in input order.
    starts: Vec<usize>,
    items: Vec<(Point, usize)>,
}

impl CellIndex {
    /// Builds the index with cells of side `cell` (grown when the points' extent would need
    /// more than a few cells per point; a non-positive side gives one cell).
    pub fn new(points: &[Point], cell: f64) -> Self {
        let finite: Vec<(Point, usize)> = points
            .iter()
            .copied()
            .enumerate()
            .filter(|(_, p)| p.x.is_finite() && p.y.is_finite())
            .map(|(i, p)| (p, i))
            .collect();
        let Some(&(first, _)) = finite.first() else {
            return Self::default();
        };
        let (mut lo, mut hi) = (first, first);
        for &(p, _) in &finite {
            lo = Point::new(lo.x.min(p.x), lo.y.min(p.y));
            hi = Point::new(hi.x.max(p.x), hi.y.max(p.y));
        }
        let (w, h) = (hi.x - lo.x, hi.y - lo.y);
        // At most ~4 cells per point: sparse points with a small cell would otherwise ask
        // for an unbounded table.
        let budget = 4.0 * finite.len() as f64 + 16.0;
        let mut cell = if cell.is_finite() && cell > 0.0 {
            cell
        } else {
            w.max(h).max(1.0)
        };
        if (w / cell + 1.0) * (h / cell + 1.0) > budget {
            cell = ((w + cell) * (h + cell) / budget).sqrt().max(cell);
            while (w / cell + 1.0) * (h / cell + 1.0) > budget {
                cell *= 1.5;
            }
        }
        let cols = (w / cell) as usize + 1;
        let rows = (h / cell) as usize + 1;
        let cell_of = |p: Point| {
            let cx = (((p.x - lo.x) / cell) as usize).min(cols - 1);
            let cy = (((p.y - lo.y) / cell) as usize).min(rows - 1);
            cy * cols + cx
        };
        let mut starts = vec![0usize; cols * rows + 1];
        for &(p, _) in &finite {
            starts[cell_of(p) + 1] += 1;
        }
        for c in 0..cols * rows {
            starts[c + 1] += starts[c];
        }
        let mut fill = starts.clone();
        let mut items = vec![(Point::default(), 0); finite.len()];
        for &(p, i) in &finite {
            let c = cell_of(p);
            items[fill[c]] = (p, i);
            fill[c] += 1;
        }
        Self {
            origin: lo,
            cell,
            cols,
            rows,
            starts,
            items,
        }
    }

    /// Number of indexed points.
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// Whether no point is indexed.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// The indexed point nearest to `q` when one lies within `r` of it: `(input index,
    /// distance)`, the lowest index among equally near ones (as [`PointIndex::nearest`]).
    /// May also answer with a point slightly beyond `r` (within rounding); `None` when none
    /// is that near, or `q` or `r` is not finite.
    pub fn nearest_within(&self, q: Point, r: f64) -> Option<(usize, f64)> {
        if self.items.is_empty() || !(q.x.is_finite() && q.y.is_finite() && r.is_finite()) {
            return None;
        }
        // A margin above any rounding, so every point a `d ≤ r` test would keep is scanned.
        let r = r.max(0.0) * (1.0 + 1e-9) + 1e-9;
        let span = |v: f64, o: f64, n: usize| -> Option<(usize, usize)> {
            let (a, b) = ((v - r - o) / self.cell, (v + r - o) / self.cell);
            if b < 0.0 || a >= n as f64 {
                return None;
            }
            Some((a.max(0.0) as usize, (b as usize).min(n - 1)))
        };
        let (x0, x1) = span(q.x, self.origin.x, self.cols)?;
        let (y0, y1) = span(q.y, self.origin.y, self.rows)?;
        let mut best = (usize::MAX, f64::INFINITY);
        for cy in y0..=y1 {
            let row = cy * self.cols;
            for &(p, i) in &self.items[self.starts[row + x0]..self.starts[row + x1 + 1]] {
                let d2 = p.dist2(q);
                if d2 < best.1 || (d2 == best.1 && i < best.0) {
                    best = (i, d2);
                }
            }
        }
        (best.0 != usize::MAX && best.1 <= r * r).then(|| (best.0, best.1.sqrt()))
    }
}

fn axis_of(p: &Point, depth: usize) -> f64 {
    if depth % 2 == 0 {
        p.x
    } else {
        p.y
    }
}

fn build(nodes: &mut [(Point, usize)], depth: usize) {
    if nodes.len() <= 1 {
        return;
    }
    let mid = nodes.len() / 2;
    nodes.select_nth_unstable_by(mid, |a, b| {
        axis_of(&a.0, depth).total_cmp(&axis_of(&b.0, depth))
    });
    let (left, right) = nodes.split_at_mut(mid);
    build(left, depth + 1);
    if let Some((_, rest)) = right.split_first_mut() {
        build(rest, depth + 1);
    }
}

fn nearest_in(nodes: &[(Point, usize)], depth: usize, q: Point, best: &mut (usize, f64)) {
    let mid = nodes.len() / 2;
    let Some(&(p, idx)) = nodes.get(mid) else {
        return;
    };
    let d2 = p.dist2(q);
    if d2 < best.1 || (d2 == best.1 && idx < best.0) {
        *best = (idx, d2);
    }
    let diff = axis_of(&q, depth) - axis_of(&p, depth);
    let (left, right) = (&nodes[..mid], &nodes[mid + 1..]);
    let (near, far) = if diff < 0.0 {
        (left, right)
    } else {
        (right, left)
    };
    nearest_in(near, depth + 1, q, best);
    if diff * diff <= best.1 {
        nearest_in(far, depth + 1, q, best);
    }
}
