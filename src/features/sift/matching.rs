//! Brute-force L2 descriptor matching with Lowe's ratio test and an optional mutual-nearest
//! (cross) check.

use super::descriptor::DESCR_LEN;
use super::{MatchConfig, SiftMatch};

/// Bytes summed between two early-exit tests: long enough that the horizontal reduction of the
/// vector accumulator is amortised, short enough to stop early on clear non-neighbours.
const BLOCK: usize = 64;

/// Squared L2 distance between two byte descriptors, abandoning the sum (and returning a value
/// ≥ `bound`) as soon as a block pushes it to `bound` or beyond. The blocks are fixed-size so
/// the inner sum compiles to packed multiply-adds.
#[inline]
fn dist_sq_bounded(a: &[u8; DESCR_LEN], b: &[u8; DESCR_LEN], bound: u32) -> u32 {
    let mut acc = 0u32;
    for (ca, cb) in a.chunks_exact(BLOCK).zip(b.chunks_exact(BLOCK)) {
        let mut s = 0i32;
        for (&x, &y) in ca.iter().zip(cb) {
            // |x - y| fits a byte; widened to i16 its squares pair up into i32 (pmaddwd).
            let d = i16::from(x.abs_diff(y));
            s += i32::from(d) * i32::from(d);
        }
        acc += s as u32;
        if acc >= bound {
            return acc;
        }
    }
    acc
}

/// Matches every query descriptor to its nearest train descriptor, keeping it when the nearest
/// is closer than `ratio` × the second nearest (and, with `cross_check`, when the query is also
/// the train descriptor's nearest).
pub(crate) fn match_sets(
    query: &[[u8; DESCR_LEN]],
    train: &[[u8; DESCR_LEN]],
    cfg: &MatchConfig,
) -> Vec<SiftMatch> {
    let mut out = Vec::new();
    if query.is_empty() || train.is_empty() {
        return out;
    }
    let ratio2 = f64::from(cfg.ratio) * f64::from(cfg.ratio);
    for (qi, q) in query.iter().enumerate() {
        let (mut best, mut second, mut best_j) = (u32::MAX, u32::MAX, 0usize);
        for (tj, t) in train.iter().enumerate() {
            let d = dist_sq_bounded(q, t, second);
            if d < best {
                second = best;
                best = d;
                best_j = tj;
            } else if d < second {
                second = d;
            }
        }
        // With a single train descriptor there is no second neighbour: the match cannot be
        // ambiguous, so it is kept (second = +inf).
        let passes = second == u32::MAX || (f64::from(best) < ratio2 * f64::from(second));
        if passes {
            out.push(SiftMatch {
                query: qi,
                train: best_j,
                distance: (best as f32).sqrt(),
            });
        }
    }
    if cfg.cross_check && !out.is_empty() {
        // Nearest query for each train descriptor that was matched at all.
        let mut back: Vec<Option<usize>> = vec![None; train.len()];
        for m in &out {
            if back[m.train].is_some() {
                continue;
            }
            let t = &train[m.train];
            let (mut best, mut best_i) = (u32::MAX, 0usize);
            for (qi, q) in query.iter().enumerate() {
                let d = dist_sq_bounded(t, q, best);
                if d < best {
                    best = d;
                    best_i = qi;
                }
            }
            back[m.train] = Some(best_i);
        }
        out.retain(|m| back[m.train] == Some(m.query));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn full_dist(a: &[u8; DESCR_LEN], b: &[u8; DESCR_LEN]) -> u32 {
        a.iter()
            .zip(b)
            .map(|(&x, &y)| (i32::from(x) - i32::from(y)).pow(2) as u32)
            .sum()
    }

    #[test]
    fn bounded_distance_is_exact_below_the_bound() {
        let a: [u8; DESCR_LEN] = std::array::from_fn(|i| (i * 7 % 256) as u8);
        let b: [u8; DESCR_LEN] = std::array::from_fn(|i| (i * 13 % 256) as u8);
        let d = full_dist(&a, &b);
        assert_eq!(dist_sq_bounded(&a, &b, u32::MAX), d);
        assert!(dist_sq_bounded(&a, &b, d / 2) >= d / 2);
        assert_eq!(dist_sq_bounded(&a, &a, 1), 0);
    }
}
