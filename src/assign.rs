//! Cost matrices with gating, and optimal assignment (thesis ch. 4.5) with `lsap`.
//!
//! A [`CostMatrix`] holds a finite cost for every allowed (row, column) pair and marks the rest
//! as gated. [`solve`] finds the optimal assignment under an [`Unmatched`] policy:
//!
//! - [`Unmatched::MaxMatches`]: as many allowed pairs as possible, then the least total cost
//!   (SORT's use of `linear_sum_assignment` followed by dropping gated pairs);
//! - [`Unmatched::Cost`]`(λ)`: minimise `Σ matched cost + λ·(unmatched rows + unmatched
//!   columns)`, so a pair is only worth matching when its cost is below `2λ` (ByteTrack's
//!   `lapjv(..., cost_limit = 2λ)`).
//!
//! The solver never sees NaN or infinity: gated pairs get a large finite cost, chosen so that
//! no optimal solution contains one (see [`solve`]), and any gated pair the solver still returns
//! (a row with no allowed column at all) is dropped afterwards. The matrix is first split into the
//! connected components of its allowed pairs, and each component is solved on its own: the
//! optimum decomposes exactly, and many small problems are much cheaper than one big one.

use thiserror::Error;

/// Errors raised building or solving an assignment problem.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum AssignError {
    /// A cost is NaN or infinite.
    #[error("cost at row {row}, column {col} is not finite: {value}")]
    NonFinite {
        /// Row index.
        row: usize,
        /// Column index.
        col: usize,
        /// The value given.
        value: f64,
    },
    /// A row or column index is outside the matrix.
    #[error("index ({row}, {col}) outside a {rows}x{cols} cost matrix")]
    OutOfRange {
        /// Row index given.
        row: usize,
        /// Column index given.
        col: usize,
        /// Matrix rows.
        rows: usize,
        /// Matrix columns.
        cols: usize,
    },
    /// The unmatched cost λ is not finite.
    #[error("unmatched cost must be finite, got {value}")]
    BadUnmatchedCost {
        /// The value given.
        value: f64,
    },
    /// The solver rejected a sub-problem (should not happen with finite costs).
    #[error("assignment solver failed on a {rows}x{cols} sub-problem")]
    Solver {
        /// Sub-problem rows.
        rows: usize,
        /// Sub-problem columns.
        cols: usize,
    },
}

/// A dense `rows × cols` cost matrix where each entry is a finite cost or gated (not allowed).
#[derive(Debug, Clone, PartialEq)]
pub struct CostMatrix {
    rows: usize,
    cols: usize,
    data: Vec<Option<f64>>,
}

impl CostMatrix {
    /// A matrix with every pair gated.
    pub fn new(rows: usize, cols: usize) -> Self {
        Self {
            rows,
            cols,
            data: vec![None; rows * cols],
        }
    }

    /// A matrix filled from `f(row, col)`: `Some(cost)` allows the pair, `None` gates it.
    pub fn from_fn(
        rows: usize,
        cols: usize,
        mut f: impl FnMut(usize, usize) -> Option<f64>,
    ) -> Result<Self, AssignError> {
        let mut m = Self::new(rows, cols);
        for r in 0..rows {
            for c in 0..cols {
                if let Some(v) = f(r, c) {
                    m.set(r, c, v)?;
                }
            }
        }
        Ok(m)
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of columns.
    pub fn cols(&self) -> usize {
        self.cols
    }

    fn index(&self, row: usize, col: usize) -> Result<usize, AssignError> {
        if row >= self.rows || col >= self.cols {
            return Err(AssignError::OutOfRange {
                row,
                col,
                rows: self.rows,
                cols: self.cols,
            });
        }
        Ok(row * self.cols + col)
    }

    /// Allows the pair `(row, col)` at `cost`; a non-finite cost is an error.
    pub fn set(&mut self, row: usize, col: usize, cost: f64) -> Result<(), AssignError> {
        let i = self.index(row, col)?;
        if !cost.is_finite() {
            return Err(AssignError::NonFinite {
                row,
                col,
                value: cost,
            });
        }
        self.data[i] = Some(cost);
        Ok(())
    }

    /// Gates the pair `(row, col)`: it will never be matched.
    pub fn gate(&mut self, row: usize, col: usize) -> Result<(), AssignError> {
        let i = self.index(row, col)?;
        self.data[i] = None;
        Ok(())
    }

    /// The cost of `(row, col)`, `None` when gated or out of range.
    pub fn get(&self, row: usize, col: usize) -> Option<f64> {
        if row >= self.rows || col >= self.cols {
            return None;
        }
        self.data[row * self.cols + col]
    }
}

/// What leaving a row or column unmatched costs (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Unmatched {
    /// Match as many allowed pairs as possible, then minimise the total cost.
    MaxMatches,
    /// Each unmatched row and each unmatched column costs this much.
    Cost(f64),
}

/// One matched pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Match {
    /// Row (track) index.
    pub row: usize,
    /// Column (detection) index.
    pub col: usize,
    /// The pair's cost.
    pub cost: f64,
}

/// The result of [`solve`]: matches sorted by row, and the rows and columns left over.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Assignment {
    /// Matched pairs, sorted by row.
    pub matches: Vec<Match>,
    /// Rows with no match, ascending.
    pub unmatched_rows: Vec<usize>,
    /// Columns with no match, ascending.
    pub unmatched_cols: Vec<usize>,
}

impl Assignment {
    /// Total cost of the matched pairs.
    pub fn total_cost(&self) -> f64 {
        self.matches.iter().map(|m| m.cost).sum()
    }
}

/// One connected component: its rows, its columns, and its edges in local indices.
type Component = (Vec<usize>, Vec<usize>, Vec<(usize, usize, f64)>);

/// Union–find (path halving) over `0..n`: here rows `0..r` and columns `r..r+c`, for the
/// connected components; the tracker's ambiguity groups use it too.
pub(crate) struct Dsu(Vec<usize>);

impl Dsu {
    /// `n` singletons.
    pub(crate) fn new(n: usize) -> Self {
        Self((0..n).collect())
    }
    /// The representative of `i`'s set.
    pub(crate) fn find(&mut self, mut i: usize) -> usize {
        while self.0[i] != i {
            self.0[i] = self.0[self.0[i]];
            i = self.0[i];
        }
        i
    }
    /// Merges the sets of `a` and `b`.
    pub(crate) fn join(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            self.0[ra] = rb;
        }
    }
}

/// Whether a component of one allowed pair (cost `v`) is matched under `policy`: always to
/// maximise matches, else when that beats leaving both out (`v < 2λ`).
fn lone_pair_matches(policy: Unmatched, v: f64) -> bool {
    match policy {
        Unmatched::MaxMatches => true,
        Unmatched::Cost(l) => v < 2.0 * l,
    }
}

/// Solves the assignment problem optimally under `policy` (see the module docs).
///
/// Gated pairs are never returned. Per connected component with `n` rows and `m` columns:
///
/// - `MaxMatches` solves the `n × m` matrix with gated entries at
///   `BIG = 2·(min(n, m) + 1)·(|c_max| + |c_min| + 1)`: one more allowed pair always saves more
///   than any difference in allowed costs can add, so the solver maximises the number of allowed
///   pairs first;
/// - `Cost(λ)` solves the `(n+m) × (m+n)` matrix `[[C, λ on the diagonal], [λ on the diagonal,
///   0]]` (lapjv's `extend_cost`), with gated and off-diagonal entries at
///   `BIG = 2·(n+m)·(|λ| + |c_max| + |c_min|) + 1`, more than the all-unmatched solution costs,
///   so no optimum uses one.
pub fn solve(matrix: &CostMatrix, policy: Unmatched) -> Result<Assignment, AssignError> {
    let mut edges = Vec::new();
    for r in 0..matrix.rows {
        for c in 0..matrix.cols {
            if let Some(v) = matrix.data[r * matrix.cols + c] {
                edges.push((r, c, v));
            }
        }
    }
    solve_sparse(matrix.rows, matrix.cols, &edges, policy)
}

/// [`solve`] on a sparse problem: `rows × cols` with only the pairs in `edges`
/// (`(row, col, cost)`) allowed; a pair listed twice keeps its last cost. Work is linear in the
/// edges plus the dense solves of the connected components, so a tracker with hundreds of
/// tracks but a handful of candidates each never touches an `n × m` matrix.
pub fn solve_sparse(
    rows: usize,
    cols: usize,
    edges: &[(usize, usize, f64)],
    policy: Unmatched,
) -> Result<Assignment, AssignError> {
    if let Unmatched::Cost(l) = policy {
        if !l.is_finite() {
            return Err(AssignError::BadUnmatchedCost { value: l });
        }
    }
    for &(row, col, value) in edges {
        if row >= rows || col >= cols {
            return Err(AssignError::OutOfRange {
                row,
                col,
                rows,
                cols,
            });
        }
        if !value.is_finite() {
            return Err(AssignError::NonFinite { row, col, value });
        }
    }
    let mut dsu = Dsu::new(rows + cols);
    for &(r, c, _) in edges {
        dsu.join(r, rows + c);
    }
    // Edges per component (by root): a component of one edge, a track with its only
    // detection, is decided here, without the matrix, index lists and solver allocations
    // each component costs (most components in a sparse scene; issue 10).
    let mut edges_of_root = vec![0usize; rows + cols];
    for &(r, _, _) in edges {
        let root = dsu.find(r);
        edges_of_root[root] += 1;
    }
    let mut out = Assignment::default();
    let mut row_used = vec![false; rows];
    let mut col_used = vec![false; cols];
    // Components in order of first appearance; local indices within each.
    let mut comp_of_root = vec![usize::MAX; rows + cols];
    let mut local = vec![usize::MAX; rows + cols];
    let mut comps: Vec<Component> = Vec::new();
    for &(r, c, v) in edges {
        let root = dsu.find(r);
        if edges_of_root[root] == 1 {
            if lone_pair_matches(policy, v) {
                row_used[r] = true;
                col_used[c] = true;
                out.matches.push(Match {
                    row: r,
                    col: c,
                    cost: v,
                });
            }
            continue;
        }
        if comp_of_root[root] == usize::MAX {
            comp_of_root[root] = comps.len();
            comps.push((Vec::new(), Vec::new(), Vec::new()));
        }
        let comp = &mut comps[comp_of_root[root]];
        if local[r] == usize::MAX {
            local[r] = comp.0.len();
            comp.0.push(r);
        }
        if local[rows + c] == usize::MAX {
            local[rows + c] = comp.1.len();
            comp.1.push(c);
        }
        comp.2.push((local[r], local[rows + c], v));
    }
    for (crows, ccols, cedges) in &comps {
        let mut m = CostMatrix::new(crows.len(), ccols.len());
        for &(i, j, v) in cedges {
            m.set(i, j, v)?;
        }
        let (li, lj): (Vec<usize>, Vec<usize>) = ((0..m.rows).collect(), (0..m.cols).collect());
        let pairs = match policy {
            Unmatched::MaxMatches => solve_max_matches(&m, &li, &lj)?,
            Unmatched::Cost(l) => solve_with_unmatched_cost(&m, &li, &lj, l)?,
        };
        for (i, j) in pairs {
            if let (Some(cost), Some(&r), Some(&c)) = (m.get(i, j), crows.get(i), ccols.get(j)) {
                row_used[r] = true;
                col_used[c] = true;
                out.matches.push(Match {
                    row: r,
                    col: c,
                    cost,
                });
            }
        }
    }
    out.matches.sort_by_key(|m| m.row);
    out.unmatched_rows = (0..rows).filter(|&r| !row_used[r]).collect();
    out.unmatched_cols = (0..cols).filter(|&c| !col_used[c]).collect();
    Ok(out)
}

fn cost_range(matrix: &CostMatrix, rows: &[usize], cols: &[usize]) -> (f64, f64) {
    let (mut lo, mut hi) = (0.0f64, 0.0f64);
    for &r in rows {
        for &c in cols {
            if let Some(v) = matrix.get(r, c) {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
    }
    (lo, hi)
}

fn run_lsap(n: usize, m: usize, cost: &Vec<f64>) -> Result<Vec<(usize, usize)>, AssignError> {
    let (a, b) =
        lsap::solve(n, m, cost, false).map_err(|_| AssignError::Solver { rows: n, cols: m })?;
    Ok(a.into_iter().zip(b).collect())
}

fn solve_max_matches(
    matrix: &CostMatrix,
    rows: &[usize],
    cols: &[usize],
) -> Result<Vec<(usize, usize)>, AssignError> {
    if let ([r], [c]) = (rows, cols) {
        return Ok(vec![(*r, *c)]);
    }
    let (lo, hi) = cost_range(matrix, rows, cols);
    let k = rows.len().min(cols.len()) as f64;
    let big = 2.0 * (k + 1.0) * (hi.abs() + lo.abs() + 1.0);
    let (n, m) = (rows.len(), cols.len());
    let mut cost = Vec::with_capacity(n * m);
    for &r in rows {
        for &c in cols {
            cost.push(matrix.get(r, c).unwrap_or(big));
        }
    }
    Ok(run_lsap(n, m, &cost)?
        .into_iter()
        .map(|(i, j)| (rows[i], cols[j]))
        .collect())
}

fn solve_with_unmatched_cost(
    matrix: &CostMatrix,
    rows: &[usize],
    cols: &[usize],
    lambda: f64,
) -> Result<Vec<(usize, usize)>, AssignError> {
    let (n, m) = (rows.len(), cols.len());
    if let ([r], [c]) = (rows, cols) {
        // One allowed pair: match it when that beats leaving both out.
        return Ok(match matrix.get(*r, *c) {
            Some(v) if lone_pair_matches(Unmatched::Cost(lambda), v) => vec![(*r, *c)],
            _ => vec![],
        });
    }
    let (lo, hi) = cost_range(matrix, rows, cols);
    let size = n + m;
    let big = 2.0 * size as f64 * (lambda.abs() + hi.abs() + lo.abs()) + 1.0;
    let mut cost = vec![big; size * size];
    for (i, &r) in rows.iter().enumerate() {
        for (j, &c) in cols.iter().enumerate() {
            if let Some(v) = matrix.get(r, c) {
                cost[i * size + j] = v;
            }
        }
        // Row i left unmatched: paired with its own dummy column m + i.
        cost[i * size + m + i] = lambda;
    }
    for j in 0..m {
        // Column j left unmatched: paired with its own dummy row n + j.
        cost[(n + j) * size + j] = lambda;
        // Dummy rows and dummy columns pair up freely.
        for i in 0..n {
            cost[(n + j) * size + m + i] = 0.0;
        }
    }
    Ok(run_lsap(size, size, &cost)?
        .into_iter()
        .filter(|&(i, j)| i < n && j < m)
        .map(|(i, j)| (rows[i], cols[j]))
        .collect())
}

// proptest does not build for wasm32 (`wasm-pack test` builds unit tests there too).
#[cfg(all(test, not(target_arch = "wasm32")))]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Every partial matching over allowed pairs, by recursion over rows.
    fn brute_force(m: &CostMatrix, policy: Unmatched) -> (usize, f64) {
        fn rec(
            m: &CostMatrix,
            r: usize,
            used: &mut Vec<bool>,
            count: usize,
            cost: f64,
            best: &mut Vec<(usize, f64)>,
        ) {
            if r == m.rows() {
                best.push((count, cost));
                return;
            }
            rec(m, r + 1, used, count, cost, best);
            for c in 0..m.cols() {
                if let (false, Some(v)) = (used[c], m.get(r, c)) {
                    used[c] = true;
                    rec(m, r + 1, used, count + 1, cost + v, best);
                    used[c] = false;
                }
            }
        }
        let mut all = Vec::new();
        rec(m, 0, &mut vec![false; m.cols()], 0, 0.0, &mut all);
        match policy {
            Unmatched::MaxMatches => all
                .into_iter()
                .min_by(|a, b| b.0.cmp(&a.0).then(a.1.total_cmp(&b.1)))
                .unwrap(),
            Unmatched::Cost(l) => {
                let obj = |(k, c): (usize, f64)| c + l * (m.rows() + m.cols() - 2 * k) as f64;
                let best = all
                    .into_iter()
                    .min_by(|a, b| obj(*a).total_cmp(&obj(*b)))
                    .unwrap();
                (best.0, obj(best))
            }
        }
    }

    fn check_valid(m: &CostMatrix, a: &Assignment) {
        let mut rows = vec![false; m.rows()];
        let mut cols = vec![false; m.cols()];
        for x in &a.matches {
            assert_eq!(m.get(x.row, x.col), Some(x.cost), "gated pair returned");
            assert!(!rows[x.row] && !cols[x.col], "row or column used twice");
            rows[x.row] = true;
            cols[x.col] = true;
        }
        assert_eq!(a.matches.len() + a.unmatched_rows.len(), m.rows());
        assert_eq!(a.matches.len() + a.unmatched_cols.len(), m.cols());
        assert!(a.unmatched_rows.iter().all(|&r| !rows[r]));
        assert!(a.unmatched_cols.iter().all(|&c| !cols[c]));
    }

    fn matrix_strategy() -> impl Strategy<Value = CostMatrix> {
        (0usize..=5, 0usize..=5).prop_flat_map(|(r, c)| {
            proptest::collection::vec(
                prop_oneof![
                    1 => Just(None),
                    3 => (-5.0f64..20.0).prop_map(Some),
                    1 => (0u8..4).prop_map(|v| Some(v as f64)), // ties
                ],
                r * c,
            )
            .prop_map(move |data| CostMatrix {
                rows: r,
                cols: c,
                data,
            })
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

        #[test]
        fn max_matches_is_optimal(m in matrix_strategy()) {
            let a = solve(&m, Unmatched::MaxMatches).unwrap();
            check_valid(&m, &a);
            let (k, c) = brute_force(&m, Unmatched::MaxMatches);
            prop_assert_eq!(a.matches.len(), k);
            prop_assert!((a.total_cost() - c).abs() < 1e-9, "{} vs {}", a.total_cost(), c);
        }

        #[test]
        fn sparse_equals_dense(m in matrix_strategy(), l in 0.0f64..12.0) {
            let mut edges = Vec::new();
            for r in 0..m.rows() {
                for c in 0..m.cols() {
                    if let Some(v) = m.get(r, c) {
                        // Listed twice: the last cost counts.
                        edges.push((r, c, v + 100.0));
                        edges.push((r, c, v));
                    }
                }
            }
            for policy in [Unmatched::MaxMatches, Unmatched::Cost(l)] {
                let sparse = solve_sparse(m.rows(), m.cols(), &edges, policy).unwrap();
                check_valid(&m, &sparse);
                let dense = solve(&m, policy).unwrap();
                prop_assert!((sparse.total_cost() - dense.total_cost()).abs() < 1e-9);
                prop_assert_eq!(sparse.matches.len(), dense.matches.len());
            }
        }

        #[test]
        fn unmatched_cost_is_optimal(m in matrix_strategy(), l in -1.0f64..12.0) {
            let a = solve(&m, Unmatched::Cost(l)).unwrap();
            check_valid(&m, &a);
            let (_, best) = brute_force(&m, Unmatched::Cost(l));
            let got = a.total_cost()
                + l * (m.rows() + m.cols() - 2 * a.matches.len()) as f64;
            prop_assert!((got - best).abs() < 1e-9, "{} vs {}", got, best);
        }
    }

    #[test]
    fn classic_three_by_three() {
        let c = [[4.0, 1.0, 3.0], [2.0, 0.0, 5.0], [3.0, 2.0, 2.0]];
        let m = CostMatrix::from_fn(3, 3, |r, k| Some(c[r][k])).unwrap();
        let a = solve(&m, Unmatched::MaxMatches).unwrap();
        assert_eq!(a.total_cost(), 5.0);
        let pairs: Vec<_> = a.matches.iter().map(|x| (x.row, x.col)).collect();
        assert_eq!(pairs, vec![(0, 1), (1, 0), (2, 2)]);
    }

    #[test]
    fn unmatched_cost_declines_expensive_pairs() {
        let m = CostMatrix::from_fn(2, 2, |r, c| Some(if r == c { 0.2 } else { 0.9 })).unwrap();
        let a = solve(&m, Unmatched::Cost(0.3)).unwrap();
        assert_eq!(a.matches.len(), 2);
        // Off-diagonal forced: both pairs cost 0.9 > 2λ = 0.6, so nothing is matched.
        let m = CostMatrix::from_fn(2, 2, |r, c| (r != c).then_some(0.9)).unwrap();
        let a = solve(&m, Unmatched::Cost(0.3)).unwrap();
        assert!(a.matches.is_empty());
        assert_eq!(a.unmatched_rows, vec![0, 1]);
        let a = solve(&m, Unmatched::MaxMatches).unwrap();
        assert_eq!(a.matches.len(), 2);
    }

    #[test]
    fn rejects_non_finite_costs() {
        let mut m = CostMatrix::new(2, 2);
        assert!(matches!(
            m.set(0, 1, f64::NAN),
            Err(AssignError::NonFinite { row: 0, col: 1, .. })
        ));
        assert!(m.set(0, 0, f64::INFINITY).is_err());
        assert!(matches!(
            m.set(2, 0, 1.0),
            Err(AssignError::OutOfRange { .. })
        ));
        assert!(solve(&m, Unmatched::Cost(f64::NAN)).is_err());
        assert!(matches!(
            solve_sparse(2, 2, &[(0, 0, f64::NAN)], Unmatched::MaxMatches),
            Err(AssignError::NonFinite { .. })
        ));
        assert!(matches!(
            solve_sparse(2, 2, &[(0, 2, 1.0)], Unmatched::MaxMatches),
            Err(AssignError::OutOfRange { .. })
        ));
        let a = solve(&m, Unmatched::MaxMatches).unwrap();
        assert!(a.matches.is_empty());
        assert_eq!(a.unmatched_cols, vec![0, 1]);
    }

    #[test]
    fn empty_and_rectangular() {
        let a = solve(&CostMatrix::new(0, 4), Unmatched::MaxMatches).unwrap();
        assert_eq!(a.unmatched_cols, vec![0, 1, 2, 3]);
        let m = CostMatrix::from_fn(1, 3, |_, c| Some([3.0, 1.0, 2.0][c])).unwrap();
        let a = solve(&m, Unmatched::MaxMatches).unwrap();
        assert_eq!(
            (a.matches[0].col, a.unmatched_cols.clone()),
            (1, vec![0, 2])
        );
        let m = CostMatrix::from_fn(3, 1, |r, _| Some([3.0, 1.0, 2.0][r])).unwrap();
        let a = solve(&m, Unmatched::MaxMatches).unwrap();
        assert_eq!(
            (a.matches[0].row, a.unmatched_rows.clone()),
            (1, vec![0, 2])
        );
    }
}
