//! Broad phase: which pairs of boxes can possibly touch, so the exact (GJK) test only runs on
//! those. Sort-and-sweep along x: `O((n + m) log(n + m) + k)` for `k` x-overlapping pairs,
//! against the `n·m` GJK calls of the thesis' double loop.

use crate::frame::BBox;

/// The pairs `(i, j)` such that `a[i]` and `b[j]` overlap or lie within `slack` of each other
/// (closed test on both axes), sorted by `(i, j)`. Boxes with non-finite coordinates match
/// nothing.
pub fn overlapping_box_pairs(a: &[BBox], b: &[BBox], slack: f64) -> Vec<(usize, usize)> {
    let slack = if slack.is_finite() {
        slack.max(0.0)
    } else {
        0.0
    };
    // One entry per box, sorted by its left edge; `side` 0 = a, 1 = b.
    let mut order: Vec<(f64, u8, usize)> = a
        .iter()
        .enumerate()
        .map(|(i, r)| (r.x, 0u8, i))
        .chain(b.iter().enumerate().map(|(j, r)| (r.x, 1u8, j)))
        .filter(|&(x, _, _)| x.is_finite())
        .collect();
    order.sort_unstable_by(|p, q| p.0.total_cmp(&q.0).then(p.1.cmp(&q.1)).then(p.2.cmp(&q.2)));
    let boxes = [a, b];
    // Boxes whose x-interval may still reach the sweep line, per side.
    let mut active: [Vec<usize>; 2] = [Vec::new(), Vec::new()];
    let mut pairs = Vec::new();
    for &(x, side, idx) in &order {
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
    sorted_by_first(&pairs, a.len())
}

/// `pairs` (each `i < n`) sorted by `(i, j)`: counted into one bucket per `i`, then each
/// bucket's few `j` sorted. The sweep emits an `i`'s pairs scattered over the whole sweep; in a
/// crowd a general sort of its thousands of pairs was 3 % of the 200-shape bench (issue 10),
/// this is linear in the pairs and `n`, plus the buckets' small sorts.
fn sorted_by_first(pairs: &[(usize, usize)], n: usize) -> Vec<(usize, usize)> {
    let mut start = vec![0usize; n + 1];
    for &(i, _) in pairs {
        start[i + 1] += 1;
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut next = start.clone();
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
