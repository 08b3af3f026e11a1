//! Broad phase: which pairs of boxes can possibly touch, so the exact (GJK) test only runs on
//! those. Sort-and-sweep along x: `O((n + m) log(n + m) + k)` for `k` x-overlapping pairs,
//! against the `n·m` GJK calls of the thesis' double loop.

use crate::frame::BBox;
use crate::scratch::{with_scratch, Scratch};
use std::cell::RefCell;

/// The sweep's working buffers, kept per thread between calls: the tracker sweeps three or
/// four sets of boxes a frame (regions, re-identification's regions, the camera's witnesses,
/// the tracks about to meet), and each call allocated its sort order, both sides' active
/// lists, the raw pairs and two bucket tables, and grew most of them step by step (issue 10:
/// no allocation per frame in the hot path). Only the returned pairs are allocated now.
struct Sweep {
    /// One entry per box, `(left edge, side, index)`; side 0 = a, 1 = b.
    order: Vec<(f64, u8, usize)>,
    /// Boxes whose x-interval may still reach the sweep line, per side.
    active: [Vec<usize>; 2],
    /// The pairs in sweep order.
    pairs: Vec<(usize, usize)>,
    /// Bucket starts of [`sorted_by_first`], and each bucket's next free slot.
    start: Vec<usize>,
    next: Vec<usize>,
}

impl Scratch for Sweep {
    const EMPTY: Sweep = Sweep {
        order: Vec::new(),
        active: [Vec::new(), Vec::new()],
        pairs: Vec::new(),
        start: Vec::new(),
        next: Vec::new(),
    };

    /// Whether any buffer grew past what a frame of an ordinary crowd needs: then it is
    /// released after the call, so one huge set of boxes does not keep its memory for good.
    fn oversized(&self) -> bool {
        self.pairs.capacity() > KEPT_PAIRS
            || self.order.capacity() > KEPT_BOXES
            || self.start.capacity() > KEPT_BOXES
    }
}

/// Most pairs (and boxes) whose buffers stay allocated between calls.
const KEPT_PAIRS: usize = 1 << 16;
const KEPT_BOXES: usize = 1 << 14;

thread_local! {
    static SWEEP: RefCell<Sweep> = const { RefCell::new(Sweep::EMPTY) };
}

/// The pairs `(i, j)` such that `a[i]` and `b[j]` overlap or lie within `slack` of each other
/// (closed test on both axes), sorted by `(i, j)`. Boxes with non-finite coordinates match
/// nothing.
pub fn overlapping_box_pairs(a: &[BBox], b: &[BBox], slack: f64) -> Vec<(usize, usize)> {
    with_scratch(&SWEEP, |sweep| sweep_into(sweep, a, b, slack))
}

/// [`overlapping_box_pairs`] with the working buffers `w` (their contents are overwritten).
fn sweep_into(w: &mut Sweep, a: &[BBox], b: &[BBox], slack: f64) -> Vec<(usize, usize)> {
    let slack = if slack.is_finite() {
        slack.max(0.0)
    } else {
        0.0
    };
    w.order.clear();
    w.order.extend(
        a.iter()
            .enumerate()
            .map(|(i, r)| (r.x, 0u8, i))
            .chain(b.iter().enumerate().map(|(j, r)| (r.x, 1u8, j)))
            .filter(|&(x, _, _)| x.is_finite()),
    );
    w.order
        .sort_unstable_by(|p, q| p.0.total_cmp(&q.0).then(p.1.cmp(&q.1)).then(p.2.cmp(&q.2)));
    let boxes = [a, b];
    let Sweep {
        order,
        active,
        pairs,
        start,
        next,
    } = w;
    active.iter_mut().for_each(Vec::clear);
    pairs.clear();
    for &(x, side, idx) in order.iter() {
        let s = side as usize;
        let o = 1 - s;
        let me = &boxes[s][idx];
        // Sorted by left edge, so a box that ends before this one starts (plus slack) can
        // never meet any later box either: drop it for good.
        let other = boxes[o];
        active[o].retain(|&k| other[k].x2() + slack >= x);
        for &k in &active[o] {
            let r = &other[k];
            if r.y <= me.y2() + slack && me.y <= r.y2() + slack {
                pairs.push(if s == 0 { (idx, k) } else { (k, idx) });
            }
        }
        active[s].push(idx);
    }
    sorted_by_first(pairs, a.len(), start, next)
}

/// `pairs` (each `i < n`) sorted by `(i, j)`: counted into one bucket per `i`, then each
/// bucket's few `j` sorted. The sweep emits an `i`'s pairs scattered over the whole sweep; in a
/// crowd a general sort of its thousands of pairs was 3 % of the 200-shape bench (issue 10),
/// this is linear in the pairs and `n`, plus the buckets' small sorts. `start` and `next` are
/// working buffers (overwritten).
fn sorted_by_first(
    pairs: &[(usize, usize)],
    n: usize,
    start: &mut Vec<usize>,
    next: &mut Vec<usize>,
) -> Vec<(usize, usize)> {
    start.clear();
    start.resize(n + 1, 0);
    for &(i, _) in pairs {
        start[i + 1] += 1;
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    next.clone_from(start);
    let mut out = vec![(0, 0); pairs.len()];
    for &(i, j) in pairs {
        out[next[i]] = (i, j);
        next[i] += 1;
    }
    for w in start.windows(2) {
        out[w[0]..w[1]].sort_unstable();
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute(a: &[BBox], b: &[BBox], slack: f64) -> Vec<(usize, usize)> {
        let mut v = Vec::new();
        for (i, p) in a.iter().enumerate() {
            for (j, q) in b.iter().enumerate() {
                if p.x <= q.x2() + slack
                    && q.x <= p.x2() + slack
                    && p.y <= q.y2() + slack
                    && q.y <= p.y2() + slack
                {
                    v.push((i, j));
                }
            }
        }
        v
    }

    #[test]
    fn sweep_matches_brute_force() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(7);
        for _ in 0..50 {
            let mut gen = |n: usize| -> Vec<BBox> {
                (0..n)
                    .map(|_| {
                        BBox::new(
                            rng.gen_range(0.0..100.0),
                            rng.gen_range(0.0..100.0),
                            rng.gen_range(0.0..15.0),
                            rng.gen_range(0.0..15.0),
                        )
                    })
                    .collect()
            };
            let (a, b) = (gen(30), gen(25));
            assert_eq!(overlapping_box_pairs(&a, &b, 0.5), brute(&a, &b, 0.5));
            assert_eq!(overlapping_box_pairs(&a, &b, 0.0), brute(&a, &b, 0.0));
        }
    }

    #[test]
    fn a_crowd_of_overlapping_boxes_matches_brute_force() {
        // Every box meets dozens of others: each `i` has many pairs, emitted out of order.
        use rand::{Rng, SeedableRng};
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(11);
        let mut gen = |n: usize| -> Vec<BBox> {
            (0..n)
                .map(|_| {
                    BBox::new(
                        rng.gen_range(0.0..60.0),
                        rng.gen_range(0.0..60.0),
                        rng.gen_range(5.0..30.0),
                        rng.gen_range(5.0..30.0),
                    )
                })
                .collect()
        };
        let (a, b) = (gen(200), gen(160));
        let pairs = overlapping_box_pairs(&a, &b, 1.0);
        assert!(pairs.len() > 20 * a.len(), "{} pairs", pairs.len());
        assert_eq!(pairs, brute(&a, &b, 1.0));
    }

    #[test]
    fn a_huge_sweep_releases_its_buffers_and_the_next_sweeps_alike() {
        // 300 × 300 boxes all over one another: 90,000 pairs, past what the buffers keep.
        let pile = vec![BBox::new(0.0, 0.0, 10.0, 10.0); 300];
        assert_eq!(overlapping_box_pairs(&pile, &pile, 0.0).len(), 90_000);
        SWEEP.with(|w| {
            let w = w.borrow();
            assert_eq!(w.pairs.capacity(), 0);
            assert!(!w.oversized());
        });
        let a = [BBox::new(0.0, 0.0, 2.0, 2.0), BBox::new(5.0, 5.0, 1.0, 1.0)];
        let b = [BBox::new(1.0, 1.0, 5.0, 5.0), BBox::new(9.0, 0.0, 1.0, 1.0)];
        assert_eq!(overlapping_box_pairs(&a, &b, 0.0), brute(&a, &b, 0.0));
        // An ordinary sweep keeps its buffers for the next.
        SWEEP.with(|w| assert!(w.borrow().pairs.capacity() > 0));
    }

    #[test]
    fn touching_boxes_pair_and_nan_does_not() {
        let a = [BBox::new(0.0, 0.0, 1.0, 1.0)];
        let b = [
            BBox::new(1.0, 1.0, 1.0, 1.0),
            BBox::new(f64::NAN, 0.0, 1.0, 1.0),
        ];
        assert_eq!(overlapping_box_pairs(&a, &b, 0.0), vec![(0, 0)]);
        assert!(overlapping_box_pairs(&[], &b, 0.0).is_empty());
    }
}
