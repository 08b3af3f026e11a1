//! Identity metrics (IDF1, IDP, IDR), ported from TrackEval's `identity.py`.
//!
//! TrackEval solves a `(G+T)²` assignment in which every gt id and every tracker id may instead
//! take a private dummy partner. Its optimum always has `IDTP = max Σ potential_matches` over
//! one-to-one gt/tracker pairings (a pair with no potential match costs exactly what its two
//! dummies cost), so we solve that bipartite problem directly on the ids that have at least one
//! potential match. IDTP, IDFN and IDFP are integers fixed by the optimum's value, so they equal
//! TrackEval's exactly, whichever optimum a tie picks.

use super::error::EvalError;
use super::sequence::{Assigner, SequenceData};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// Identity results of one sequence or of a combination; ratios are fractions (0–1).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Identity {
    /// Identity true positives.
    pub idtp: u64,
    /// Identity false negatives.
    pub idfn: u64,
    /// Identity false positives.
    pub idfp: u64,
    /// IDF1 score.
    pub idf1: f64,
    /// Identity recall.
    pub idr: f64,
    /// Identity precision.
    pub idp: f64,
}

impl Identity {
    /// Recomputes IDF1, IDR, IDP from the counts.
    pub fn finalize(&mut self) {
        let (tp, fn_, fp) = (self.idtp as f64, self.idfn as f64, self.idfp as f64);
        self.idr = tp / (tp + fn_).max(1.0);
        self.idp = tp / (tp + fp).max(1.0);
        self.idf1 = tp / (tp + 0.5 * fp + 0.5 * fn_).max(1.0);
    }

    /// Combines sequences: sums of counts, then derived fields.
    pub fn combine<'a>(all: impl IntoIterator<Item = &'a Identity>) -> Identity {
        let mut c = Identity::default();
        for r in all {
            c.idtp += r.idtp;
            c.idfn += r.idfn;
            c.idfp += r.idfp;
        }
        c.finalize();
        c
    }
}

/// Reusable state for [`identity`].
#[derive(Debug, Default)]
pub(crate) struct IdentityScratch {
    assign: Assigner,
    pairs: HashMap<(u32, u32), u32>,
    gt_index: Vec<u32>,
    tracker_index: Vec<u32>,
}

/// Identity metrics of one sequence, with `threshold` the similarity needed for a match (0.5).
pub fn identity(seq: &SequenceData, threshold: f64) -> Result<Identity, EvalError> {
    identity_with(seq, threshold, &mut IdentityScratch::default())
}

pub(crate) fn identity_with(
    seq: &SequenceData,
    threshold: f64,
    s: &mut IdentityScratch,
) -> Result<Identity, EvalError> {
    let mut res = Identity::default();
    if seq.num_tracker_dets() == 0 {
        res.idfn = seq.num_gt_dets() as u64;
        return Ok(res);
    }
    if seq.num_gt_dets() == 0 {
        res.idfp = seq.num_tracker_dets() as u64;
        return Ok(res);
    }
    // Potential matches: frames in which a gt id and a tracker id overlap enough.
    s.pairs.clear();
    for f in seq.frames() {
        let nt = f.tracker_ids.len();
        for (i, &g) in f.gt_ids.iter().enumerate() {
            let row = &f.similarity[i * nt..(i + 1) * nt];
            for (j, &v) in row.iter().enumerate() {
                if v >= threshold {
                    *s.pairs.entry((g, f.tracker_ids[j])).or_insert(0) += 1;
                }
            }
        }
    }
    // Dense indices of the ids that take part in some potential match, in ascending id order.
    const NONE: u32 = u32::MAX;
    s.gt_index.clear();
    s.gt_index.resize(seq.num_gt_ids(), NONE);
    s.tracker_index.clear();
    s.tracker_index.resize(seq.num_tracker_ids(), NONE);
    for &(g, t) in s.pairs.keys() {
        s.gt_index[g as usize] = 0;
        s.tracker_index[t as usize] = 0;
    }
    let ng = number_marked(&mut s.gt_index);
    let nt = number_marked(&mut s.tracker_index);
    let cost = s.assign.reset(ng, nt);
    for (&(g, t), &count) in &s.pairs {
        let (r, c) = (s.gt_index[g as usize], s.tracker_index[t as usize]);
        cost[r as usize * nt + c as usize] = -(count as f64);
    }
    if !s.assign.solve(ng, nt) {
        return Err(EvalError::Assignment {
            seq: seq.name().to_string(),
            rows: ng,
            cols: nt,
        });
    }
    let idtp: f64 = s
        .assign
        .rows
        .iter()
        .zip(&s.assign.cols)
        .map(|(&r, &c)| -s.assign.cost()[r * nt + c])
        .sum();
    let idtp = idtp.round() as u64;
    res.idtp = idtp;
    res.idfn = seq.num_gt_dets() as u64 - idtp;
    res.idfp = seq.num_tracker_dets() as u64 - idtp;
    res.finalize();
    Ok(res)
}

/// Replaces each marked (non-`u32::MAX`) entry by its rank among marked entries; returns count.
fn number_marked(index: &mut [u32]) -> usize {
    let mut k = 0u32;
    for v in index.iter_mut() {
        if *v != u32::MAX {
            *v = k;
            k += 1;
        }
    }
    k as usize
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::SequenceBuilder;
    use rand::{Rng, SeedableRng};
    use rand_xoshiro::Xoshiro256PlusPlus;

    /// TrackEval's own `(G+T)²` construction, to check the reduced problem against.
    fn trackeval_identity(seq: &SequenceData, thr: f64) -> (u64, u64, u64) {
        let (g, t) = (seq.num_gt_ids(), seq.num_tracker_ids());
        let mut pm = vec![0.0; g * t];
        let (mut gc, mut tc) = (vec![0.0; g], vec![0.0; t]);
        for f in seq.frames() {
            for (i, &gi) in f.gt_ids.iter().enumerate() {
                for (j, &tj) in f.tracker_ids.iter().enumerate() {
                    if f.sim(i, j) >= thr {
                        pm[gi as usize * t + tj as usize] += 1.0;
                    }
                }
            }
            for &gi in f.gt_ids {
                gc[gi as usize] += 1.0;
            }
            for &tj in f.tracker_ids {
                tc[tj as usize] += 1.0;
            }
        }
        let n = g + t;
        let (mut fp, mut fnm) = (vec![0.0; n * n], vec![0.0; n * n]);
        for r in g..n {
            for c in 0..t {
                fp[r * n + c] = 1e10;
            }
        }
        for r in 0..g {
            for c in t..n {
                fnm[r * n + c] = 1e10;
            }
        }
        for gi in 0..g {
            for c in 0..t {
                fnm[gi * n + c] = gc[gi];
            }
            fnm[gi * n + t + gi] = gc[gi];
        }
        for tj in 0..t {
            for r in 0..g {
                fp[r * n + tj] = tc[tj];
            }
            fp[(tj + g) * n + tj] = tc[tj];
        }
        for r in 0..g {
            for c in 0..t {
                fnm[r * n + c] -= pm[r * t + c];
                fp[r * n + c] -= pm[r * t + c];
            }
        }
        let cost: Vec<f64> = fp.iter().zip(&fnm).map(|(a, b)| a + b).collect();
        let (rows, cols) = lsap::solve(n, n, &cost, false).unwrap();
        let idfn: f64 = rows.iter().zip(&cols).map(|(&r, &c)| fnm[r * n + c]).sum();
        let idfp: f64 = rows.iter().zip(&cols).map(|(&r, &c)| fp[r * n + c]).sum();
        let total: f64 = gc.iter().sum();
        ((total - idfn) as u64, idfn as u64, idfp as u64)
    }

    #[test]
    fn reduced_assignment_equals_trackeval_construction() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
        for _ in 0..60 {
            let mut b = SequenceBuilder::new("r");
            let frames = rng.gen_range(1..12);
            for _ in 0..frames {
                let ng = rng.gen_range(0..5);
                let nt = rng.gen_range(0..6);
                let mut gids: Vec<i64> = (0..8).collect();
                let mut tids: Vec<i64> = (0..10).collect();
                for k in 0..8 {
                    gids.swap(k, rng.gen_range(k..8));
                }
                for k in 0..10 {
                    tids.swap(k, rng.gen_range(k..10));
                }
                let sim: Vec<f64> = (0..ng * nt)
                    .map(|_| {
                        if rng.gen_bool(0.5) {
                            rng.gen::<f64>()
                        } else {
                            0.0
                        }
                    })
                    .collect();
                b.push_frame(&gids[..ng], &tids[..nt], &sim).unwrap();
            }
            let seq = b.finish();
            if seq.num_gt_dets() == 0 || seq.num_tracker_dets() == 0 {
                continue;
            }
            let ours = identity(&seq, 0.5).unwrap();
            assert_eq!(
                (ours.idtp, ours.idfn, ours.idfp),
                trackeval_identity(&seq, 0.5)
            );
        }
    }
}
