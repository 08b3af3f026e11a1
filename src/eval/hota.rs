//! HOTA (Luiten et al., IJCV 2021) over α = 0.05, 0.10, …, 0.95, ported from TrackEval's
//! `hota.py`.
//!
//! TrackEval keeps dense `gt ids × tracker ids` matrices, 19 of them for the match counts. Only
//! pairs that ever overlap can be matched, so we index those pairs once and keep per-pair
//! counters instead; the arithmetic per pair is TrackEval's.

use super::error::EvalError;
use super::sequence::{Assigner, SequenceData};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

const EPS: f64 = f64::EPSILON;

/// Number of localisation thresholds α.
pub const NUM_ALPHAS: usize = 19;

/// The α thresholds, computed as `numpy.arange(0.05, 0.99, 0.05)` does (`0.05 + i·0.05`).
pub fn alphas() -> [f64; NUM_ALPHAS] {
    let mut a = [0.0; NUM_ALPHAS];
    for (i, v) in a.iter_mut().enumerate() {
        *v = 0.05 + i as f64 * 0.05;
    }
    a
}

/// HOTA results of one sequence or a combination: one value per α, fractions (0–1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Hota {
    /// Higher-order tracking accuracy `sqrt(DetA·AssA)`.
    pub hota: [f64; NUM_ALPHAS],
    /// Detection accuracy.
    pub det_a: [f64; NUM_ALPHAS],
    /// Association accuracy.
    pub ass_a: [f64; NUM_ALPHAS],
    /// Detection recall.
    pub det_re: [f64; NUM_ALPHAS],
    /// Detection precision.
    pub det_pr: [f64; NUM_ALPHAS],
    /// Association recall.
    pub ass_re: [f64; NUM_ALPHAS],
    /// Association precision.
    pub ass_pr: [f64; NUM_ALPHAS],
    /// Localisation accuracy (mean similarity of matches).
    pub loc_a: [f64; NUM_ALPHAS],
    /// Open-world tracking accuracy `sqrt(DetRe·AssA)`.
    pub owta: [f64; NUM_ALPHAS],
    /// Matches per α.
    pub hota_tp: [u64; NUM_ALPHAS],
    /// Missed gt objects per α.
    pub hota_fn: [u64; NUM_ALPHAS],
    /// Unmatched tracker objects per α.
    pub hota_fp: [u64; NUM_ALPHAS],
    /// HOTA at the lowest α.
    pub hota0: f64,
    /// LocA at the lowest α.
    pub loca0: f64,
    /// `HOTA(0)·LocA(0)`.
    pub hotaloca0: f64,
}

impl Default for Hota {
    fn default() -> Self {
        let z = [0.0; NUM_ALPHAS];
        Hota {
            hota: z,
            det_a: z,
            ass_a: z,
            det_re: z,
            det_pr: z,
            ass_re: z,
            ass_pr: z,
            loc_a: z,
            owta: z,
            hota_tp: [0; NUM_ALPHAS],
            hota_fn: [0; NUM_ALPHAS],
            hota_fp: [0; NUM_ALPHAS],
            hota0: 0.0,
            loca0: 0.0,
            hotaloca0: 0.0,
        }
    }
}

/// Mean over α, as TrackEval reports array fields.
pub fn mean(a: &[f64; NUM_ALPHAS]) -> f64 {
    a.iter().sum::<f64>() / NUM_ALPHAS as f64
}

impl Hota {
    /// Derived fields from TP/FN/FP, AssA and LocA (TrackEval's `_compute_final_fields`).
    pub fn finalize(&mut self) {
        for a in 0..NUM_ALPHAS {
            let (tp, fn_, fp) = (
                self.hota_tp[a] as f64,
                self.hota_fn[a] as f64,
                self.hota_fp[a] as f64,
            );
            self.det_re[a] = tp / (tp + fn_).max(1.0);
            self.det_pr[a] = tp / (tp + fp).max(1.0);
            self.det_a[a] = tp / (tp + fn_ + fp).max(1.0);
            self.hota[a] = (self.det_a[a] * self.ass_a[a]).sqrt();
            self.owta[a] = (self.det_re[a] * self.ass_a[a]).sqrt();
        }
        self.hota0 = self.hota[0];
        self.loca0 = self.loc_a[0];
        self.hotaloca0 = self.hota0 * self.loca0;
    }

    /// Combines sequences: summed counts, AssA/AssRe/AssPr and LocA weighted by HOTA_TP.
    pub fn combine<'a>(all: impl IntoIterator<Item = &'a Hota> + Clone) -> Hota {
        let mut c = Hota::default();
        for r in all.clone() {
            for a in 0..NUM_ALPHAS {
                c.hota_tp[a] += r.hota_tp[a];
                c.hota_fn[a] += r.hota_fn[a];
                c.hota_fp[a] += r.hota_fp[a];
            }
        }
        for r in all {
            for a in 0..NUM_ALPHAS {
                let w = r.hota_tp[a] as f64;
                c.ass_re[a] += r.ass_re[a] * w;
                c.ass_pr[a] += r.ass_pr[a] * w;
                c.ass_a[a] += r.ass_a[a] * w;
                // Weighted LocA sum, divided below.
                c.loc_a[a] += r.loc_a[a] * w;
            }
        }
        for a in 0..NUM_ALPHAS {
            let tp = c.hota_tp[a] as f64;
            c.ass_re[a] /= tp.max(1.0);
            c.ass_pr[a] /= tp.max(1.0);
            c.ass_a[a] /= tp.max(1.0);
            c.loc_a[a] = c.loc_a[a].max(1e-10) / tp.max(1e-10);
        }
        c.finalize();
        c
    }
}

/// Reusable state for [`hota`].
#[derive(Debug, Default)]
pub(crate) struct HotaScratch {
    assign: Assigner,
    pair_of: HashMap<(u32, u32), u32>,
    cell_pair: Vec<u32>,
    potential: Vec<f64>,
    pair_ids: Vec<(u32, u32)>,
    alignment: Vec<f64>,
    matches: Vec<[u32; NUM_ALPHAS]>,
    gt_id_count: Vec<f64>,
    tracker_id_count: Vec<f64>,
    row_sum: Vec<f64>,
    col_sum: Vec<f64>,
}

const NONE: u32 = u32::MAX;

/// HOTA of one sequence.
pub fn hota(seq: &SequenceData) -> Result<Hota, EvalError> {
    hota_with(seq, &mut HotaScratch::default())
}

pub(crate) fn hota_with(seq: &SequenceData, s: &mut HotaScratch) -> Result<Hota, EvalError> {
    let mut res = Hota::default();
    // TrackEval's early returns: nothing derived except LocA = 1.
    if seq.num_tracker_dets() == 0 || seq.num_gt_dets() == 0 {
        let (fn_, fp) = if seq.num_tracker_dets() == 0 {
            (seq.num_gt_dets() as u64, 0)
        } else {
            (0, seq.num_tracker_dets() as u64)
        };
        res.hota_fn = [fn_; NUM_ALPHAS];
        res.hota_fp = [fp; NUM_ALPHAS];
        res.loc_a = [1.0; NUM_ALPHAS];
        res.loca0 = 1.0;
        return Ok(res);
    }
    let alphas = alphas();

    s.pair_of.clear();
    s.cell_pair.clear();
    s.potential.clear();
    s.pair_ids.clear();
    s.gt_id_count.clear();
    s.gt_id_count.resize(seq.num_gt_ids(), 0.0);
    s.tracker_id_count.clear();
    s.tracker_id_count.resize(seq.num_tracker_ids(), 0.0);

    // Pass 1: similarity-weighted potential matches per id pair (soft IoU of each cell within
    // its row and column), and detections per id.
    for f in seq.frames() {
        let (ng, nt) = (f.gt_ids.len(), f.tracker_ids.len());
        s.row_sum.clear();
        s.row_sum.resize(ng, 0.0);
        s.col_sum.clear();
        s.col_sum.resize(nt, 0.0);
        for i in 0..ng {
            for j in 0..nt {
                let v = f.sim(i, j);
                s.row_sum[i] += v;
                s.col_sum[j] += v;
            }
        }
        for (i, &g) in f.gt_ids.iter().enumerate() {
            for (j, &t) in f.tracker_ids.iter().enumerate() {
                let v = f.sim(i, j);
                if v == 0.0 {
                    s.cell_pair.push(NONE);
                    continue;
                }
                let denom = s.col_sum[j] + s.row_sum[i] - v;
                let soft = if denom > EPS { v / denom } else { 0.0 };
                let next = s.pair_ids.len() as u32;
                let p = *s.pair_of.entry((g, t)).or_insert(next);
                if p == next {
                    s.pair_ids.push((g, t));
                    s.potential.push(0.0);
                }
                s.potential[p as usize] += soft;
                s.cell_pair.push(p);
            }
        }
        for &g in f.gt_ids {
            s.gt_id_count[g as usize] += 1.0;
        }
        for &t in f.tracker_ids {
            s.tracker_id_count[t as usize] += 1.0;
        }
    }
    // Global alignment (Jaccard of the two tracks before unique matching).
    s.alignment.clear();
    for (p, &(g, t)) in s.pair_ids.iter().enumerate() {
        let pm = s.potential[p];
        s.alignment
            .push(pm / (s.gt_id_count[g as usize] + s.tracker_id_count[t as usize] - pm));
    }
    s.matches.clear();
    s.matches.resize(s.pair_ids.len(), [0; NUM_ALPHAS]);

    // Pass 2: per frame, match to maximise alignment-weighted similarity, then count per α.
    let mut cell = 0usize;
    for f in seq.frames() {
        let (ng, nt) = (f.gt_ids.len(), f.tracker_ids.len());
        let cells = &s.cell_pair[cell..cell + ng * nt];
        cell += ng * nt;
        if ng == 0 {
            for v in res.hota_fp.iter_mut() {
                *v += nt as u64;
            }
            continue;
        }
        if nt == 0 {
            for v in res.hota_fn.iter_mut() {
                *v += ng as u64;
            }
            continue;
        }
        let cost = s.assign.reset(ng, nt);
        for (k, &p) in cells.iter().enumerate() {
            if p != NONE {
                cost[k] = -(s.alignment[p as usize] * f.similarity[k]);
            }
        }
        if !s.assign.solve(ng, nt) {
            return Err(EvalError::Assignment {
                seq: seq.name().to_string(),
                rows: ng,
                cols: nt,
            });
        }
        let mut tp = [0u64; NUM_ALPHAS];
        let mut loc = [0.0f64; NUM_ALPHAS];
        for (&i, &j) in s.assign.rows.iter().zip(&s.assign.cols) {
            let v = f.sim(i, j);
            // α ascends, so the α a match passes form a prefix.
            let passed = alphas.iter().take_while(|&&a| v >= a - EPS).count();
            if passed == 0 {
                continue;
            }
            let p = cells[i * nt + j];
            for a in 0..passed {
                tp[a] += 1;
                loc[a] += v;
                if p != NONE {
                    s.matches[p as usize][a] += 1;
                }
            }
        }
        for a in 0..NUM_ALPHAS {
            res.hota_tp[a] += tp[a];
            res.hota_fn[a] += ng as u64 - tp[a];
            res.hota_fp[a] += nt as u64 - tp[a];
            if tp[a] > 0 {
                res.loc_a[a] += loc[a];
            }
        }
    }

    // Association scores per α, averaged over matches.
    let mut ass_a = [0.0; NUM_ALPHAS];
    let mut ass_re = [0.0; NUM_ALPHAS];
    let mut ass_pr = [0.0; NUM_ALPHAS];
    for (p, &(g, t)) in s.pair_ids.iter().enumerate() {
        let (gc, tc) = (s.gt_id_count[g as usize], s.tracker_id_count[t as usize]);
        for a in 0..NUM_ALPHAS {
            let mc = s.matches[p][a] as f64;
            if mc == 0.0 {
                continue;
            }
            ass_a[a] += mc * (mc / (gc + tc - mc).max(1.0));
            ass_re[a] += mc * (mc / gc.max(1.0));
            ass_pr[a] += mc * (mc / tc.max(1.0));
        }
    }
    for a in 0..NUM_ALPHAS {
        let tp = (res.hota_tp[a] as f64).max(1.0);
        res.ass_a[a] = ass_a[a] / tp;
        res.ass_re[a] = ass_re[a] / tp;
        res.ass_pr[a] = ass_pr[a] / tp;
        res.loc_a[a] = res.loc_a[a].max(1e-10) / (res.hota_tp[a] as f64).max(1e-10);
    }
    res.finalize();
    Ok(res)
}
