//! The join matching in blocks of bounded size: the re-linker's min-cost matching over the
//! candidate joins, with each dense solve capped at [`MAX_BLOCK`] tracks.
//!
//! The matching splits into the connected components of the candidate graph, and each is
//! solved densely (cubic in its size). Sparse real scenes give components of a few tracks;
//! crowded short tracklets (a dense crowd the detector keeps losing) chain every track to the
//! next and give one component of thousands, whose dense solve took 100 s for 300 frames
//! (issue 65). A component above [`MAX_BLOCK`] is therefore cut in time: its candidate joins
//! in order of the master's first frame, in windows of at most [`MAX_BLOCK`] tracks, each
//! window solved optimally with the tracks an earlier window joined left out. Only such
//! crowds are cut; every smaller component is solved exactly as before.

use crate::assign::{self, AssignError, Unmatched};

/// Most tracks (slaves plus masters) one dense solve of the join matching may hold. The dense
/// solve is cubic: 1,024 tracks is well under a second, while the components of real scenes
/// are a few tracks (the quality sequences' largest stay far below the cap, so their joins are
/// unchanged).
pub const MAX_BLOCK: usize = 1024;

/// What leaving an end unmatched costs: a pair (cost ≤ 1) is always worth taking unless it
/// displaces cheaper ones, so the optimum minimises Σ (cost − 1).
const UNMATCHED: f64 = 0.5;

#[cfg(test)]
thread_local! {
    /// The largest dense solve of the last matching on this thread (tracks), for the tests.
    pub(crate) static LARGEST: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// The min-cost matching of `edges` (slave, master, cost) over `n` tracks, each component of
/// the candidate graph above [`MAX_BLOCK`] tracks cut in windows by `time[k]` (edge `k`'s
/// master's first frame; module docs). Returns the chosen (slave, master) pairs.
pub(crate) fn solve_in_blocks(
    n: usize,
    edges: &[(usize, usize, f64)],
    time: &[u32],
) -> Result<Vec<(usize, usize)>, AssignError> {
    let mut parent: Vec<usize> = (0..2 * n).collect();
    fn find(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for &(r, c, _) in edges {
        let (a, b) = (find(&mut parent, r), find(&mut parent, n + c));
        if a != b {
            parent[a] = b;
        }
    }
    let mut size = vec![0usize; 2 * n];
    for i in 0..2 * n {
        let root = find(&mut parent, i);
        size[root] += 1;
    }
    let root_of: Vec<usize> = edges
        .iter()
        .map(|&(r, _, _)| find(&mut parent, r))
        .collect();
    let small: Vec<(usize, usize, f64)> = edges
        .iter()
        .zip(&root_of)
        .filter(|(_, &root)| size[root] <= MAX_BLOCK)
        .map(|(e, _)| *e)
        .collect();
    #[cfg(test)]
    LARGEST.with(|l| {
        let most = root_of.iter().map(|&r| size[r]).filter(|&s| s <= MAX_BLOCK);
        l.set(most.max().unwrap_or(0));
    });
    let mut out: Vec<(usize, usize)> =
        assign::solve_sparse(n, n, &small, Unmatched::Cost(UNMATCHED))?
            .matches
            .iter()
            .map(|m| (m.row, m.col))
            .collect();

    // The crowds: every large component's edges, by component, then time.
    let mut big: Vec<usize> = (0..edges.len())
        .filter(|&k| size[root_of[k]] > MAX_BLOCK)
        .collect();
    if big.is_empty() {
        return Ok(out);
    }
    big.sort_by_key(|&k| (root_of[k], time[k], edges[k].1, edges[k].0));
    let mut used = vec![false; 2 * n];
    // Window stamp per track: a track is in the current window when its stamp is `window`.
    let mut stamp = vec![usize::MAX; 2 * n];
    let (mut window, mut members, mut current) = (0usize, 0usize, Vec::new());
    let mut k = 0;
    while k <= big.len() {
        let next = big.get(k).map(|&e| (e, edges[e]));
        let fresh = |stamp: &[usize], (r, c): (usize, usize)| {
            usize::from(stamp[r] != window) + usize::from(stamp[n + c] != window)
        };
        let same_comp = match (next, current.last()) {
            (Some((e, _)), Some(&(prev, _))) => root_of[e] == root_of[prev],
            _ => true,
        };
        let full = next.is_some_and(|(_, (r, c, _))| members + fresh(&stamp, (r, c)) > MAX_BLOCK);
        if next.is_none() || full || !same_comp {
            if !current.is_empty() {
                let win: Vec<(usize, usize, f64)> = current.iter().map(|&(_, e)| e).collect();
                #[cfg(test)]
                LARGEST.with(|l| l.set(l.get().max(members)));
                let sol = assign::solve_sparse(n, n, &win, Unmatched::Cost(UNMATCHED))?;
                for m in &sol.matches {
                    used[m.row] = true;
                    used[n + m.col] = true;
                    out.push((m.row, m.col));
                }
            }
            current.clear();
            members = 0;
            window += 1;
            if next.is_none() {
                break;
            }
            continue;
        }
        let (e, (r, c, v)) = next.expect("checked above");
        k += 1;
        if used[r] || used[n + c] {
            continue;
        }
        members += fresh(&stamp, (r, c));
        stamp[r] = window;
        stamp[n + c] = window;
        current.push((e, (r, c, v)));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{BBox, Point, TrackState, TrackedShape};
    use crate::track::offline::{relink, OfflineConfig, SequenceInfo};

    /// A crowd the detector keeps losing: 64 objects in an 8 × 8 grid drifting right, each
    /// seen for 6 frames then missed for 2, a new track id after every miss, over 300 frames
    /// (2,400 tracklets). Every tracklet is a candidate slave of its neighbours' next ones,
    /// so the candidate graph is one component of thousands of tracks.
    fn crowded_tracklets() -> Vec<TrackedShape> {
        let mut shapes = Vec::new();
        let mut id = 0u64;
        for obj in 0..64u32 {
            let (gx, gy) = (f64::from(obj % 8), f64::from(obj / 8));
            let phase = (obj * 3 + obj / 8) % 8;
            let mut f = 1 + phase;
            while f <= 300 {
                id += 1;
                for g in f..(f + 6).min(301) {
                    let c = Point::new(40.0 + 10.0 * gx + 0.5 * f64::from(g), 40.0 + 16.0 * gy);
                    let bbox = BBox::from_center(c, 20.0, 40.0);
                    shapes.push(TrackedShape {
                        id,
                        frame: g,
                        bbox,
                        mask: None,
                        centroid: c,
                        state: TrackState::Confirmed,
                        score: 0.9,
                        class: -1,
                        cost: 0.0,
                        det_index: Some(0),
                        interpolated: false,
                    });
                }
                f += 8;
            }
        }
        shapes
    }

    #[test]
    fn crowded_short_tracklets_are_solved_in_bounded_blocks() {
        let shapes = crowded_tracklets();
        let seq = SequenceInfo::new(25.0);
        let r = relink(shapes, None, &OfflineConfig::default(), &seq, &mut |_| {}).unwrap();
        let largest = LARGEST.with(|l| l.get());
        assert!(
            largest <= MAX_BLOCK,
            "a dense solve of {largest} tracks, {} joins",
            r.joins.len()
        );
        // The crowd is still joined: most tracklets continue another.
        assert!(r.joins.len() > 1500, "{} joins", r.joins.len());
    }

    #[test]
    fn small_components_are_solved_as_one() {
        // Two slaves, two masters, crossing costs: the optimum, not the first come.
        let edges = [(0, 2, 0.1), (0, 3, 0.2), (1, 2, 0.15), (1, 3, 0.9)];
        let mut got = solve_in_blocks(4, &edges, &[5, 5, 5, 5]).unwrap();
        got.sort_unstable();
        assert_eq!(got, vec![(0, 3), (1, 2)]);
    }
}
