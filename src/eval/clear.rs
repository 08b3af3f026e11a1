//! CLEAR MOT metrics (MOTA, MOTP, IDSW, Frag, MT/PT/ML), ported from TrackEval's `clear.py`.

use super::error::EvalError;
use super::sequence::{Assigner, SequenceData};
use serde::{Deserialize, Serialize};

const EPS: f64 = f64::EPSILON;

/// CLEAR results of one sequence or of a combination; ratios are fractions (0–1).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Clear {
    /// True positives (matched gt objects).
    pub clr_tp: u64,
    /// False negatives (missed gt objects).
    pub clr_fn: u64,
    /// False positives (unmatched tracker objects).
    pub clr_fp: u64,
    /// Identity switches.
    pub idsw: u64,
    /// Mostly tracked gt ids (tracked in more than 80 % of their frames).
    pub mt: u64,
    /// Partially tracked gt ids.
    pub pt: u64,
    /// Mostly lost gt ids (tracked in less than 20 % of their frames).
    pub ml: u64,
    /// Fragmentations.
    pub frag: u64,
    /// Frames counted (0 for a sequence with no tracker or no gt objects, as TrackEval).
    pub clr_frames: u64,
    /// Sum of the similarities of matches.
    pub motp_sum: f64,
    /// Multi-object tracking accuracy.
    pub mota: f64,
    /// Multi-object tracking precision (mean similarity of matches).
    pub motp: f64,
    /// Multi-object detection accuracy.
    pub moda: f64,
    /// Recall `TP / (TP + FN)`.
    pub clr_re: f64,
    /// Precision `TP / (TP + FP)`.
    pub clr_pr: f64,
    /// MT ratio.
    pub mtr: f64,
    /// PT ratio.
    pub ptr: f64,
    /// ML ratio.
    pub mlr: f64,
    /// Soft MOTA: `(MOTP_sum − FP − IDSW) / (TP + FN)`.
    pub smota: f64,
    /// Detection F1.
    pub clr_f1: f64,
    /// False positives per frame.
    pub fp_per_frame: f64,
    /// MOTA with `log10(IDSW)`.
    pub motal: f64,
}

impl Clear {
    /// Recomputes the derived fields from the counts (TrackEval's `_compute_final_fields`).
    pub fn finalize(&mut self) {
        let (tp, fn_, fp, idsw) = (
            self.clr_tp as f64,
            self.clr_fn as f64,
            self.clr_fp as f64,
            self.idsw as f64,
        );
        let num_gt_ids = (self.mt + self.ml + self.pt) as f64;
        self.mtr = self.mt as f64 / num_gt_ids.max(1.0);
        self.mlr = self.ml as f64 / num_gt_ids.max(1.0);
        self.ptr = self.pt as f64 / num_gt_ids.max(1.0);
        self.clr_re = tp / (tp + fn_).max(1.0);
        self.clr_pr = tp / (tp + fp).max(1.0);
        self.moda = (tp - fp) / (tp + fn_).max(1.0);
        self.mota = (tp - fp - idsw) / (tp + fn_).max(1.0);
        self.motp = self.motp_sum / tp.max(1.0);
        self.smota = (self.motp_sum - fp - idsw) / (tp + fn_).max(1.0);
        self.clr_f1 = tp / (tp + 0.5 * fn_ + 0.5 * fp).max(1.0);
        self.fp_per_frame = fp / (self.clr_frames as f64).max(1.0);
        let safe_log_idsw = if self.idsw > 0 { idsw.log10() } else { idsw };
        self.motal = (tp - fp - safe_log_idsw) / (tp + fn_).max(1.0);
    }

    /// Combines sequences: sums of counts, then derived fields.
    pub fn combine<'a>(all: impl IntoIterator<Item = &'a Clear>) -> Clear {
        let mut c = Clear::default();
        for r in all {
            c.clr_tp += r.clr_tp;
            c.clr_fn += r.clr_fn;
            c.clr_fp += r.clr_fp;
            c.idsw += r.idsw;
            c.mt += r.mt;
            c.pt += r.pt;
            c.ml += r.ml;
            c.frag += r.frag;
            c.clr_frames += r.clr_frames;
            c.motp_sum += r.motp_sum;
        }
        c.finalize();
        c
    }
}

/// Reusable state for [`clear`], so evaluating many sequences allocates little.
#[derive(Debug, Default)]
pub(crate) struct ClearScratch {
    assign: Assigner,
    gt_id_count: Vec<u32>,
    gt_matched_count: Vec<u32>,
    gt_frag_count: Vec<u32>,
    prev_tracker_id: Vec<u32>,
    prev_timestep_tracker_id: Vec<u32>,
    prev_set: Vec<u32>,
    matched: Vec<(usize, usize)>,
}

const NONE: u32 = u32::MAX;

/// CLEAR metrics of one sequence, with `threshold` the similarity needed for a match (0.5).
pub fn clear(seq: &SequenceData, threshold: f64) -> Result<Clear, EvalError> {
    clear_with(seq, threshold, &mut ClearScratch::default())
}

pub(crate) fn clear_with(
    seq: &SequenceData,
    threshold: f64,
    s: &mut ClearScratch,
) -> Result<Clear, EvalError> {
    let mut res = Clear::default();
    // TrackEval returns early, leaving every derived field at 0 except MLR.
    if seq.num_tracker_dets() == 0 {
        res.clr_fn = seq.num_gt_dets() as u64;
        res.ml = seq.num_gt_ids() as u64;
        res.mlr = 1.0;
        return Ok(res);
    }
    if seq.num_gt_dets() == 0 {
        res.clr_fp = seq.num_tracker_dets() as u64;
        res.mlr = 1.0;
        return Ok(res);
    }
    let n = seq.num_gt_ids();
    for v in [
        &mut s.gt_id_count,
        &mut s.gt_matched_count,
        &mut s.gt_frag_count,
    ] {
        v.clear();
        v.resize(n, 0);
    }
    for v in [&mut s.prev_tracker_id, &mut s.prev_timestep_tracker_id] {
        v.clear();
        v.resize(n, NONE);
    }
    s.prev_set.clear();

    for f in seq.frames() {
        let (ng, nt) = (f.gt_ids.len(), f.tracker_ids.len());
        if ng == 0 {
            res.clr_fp += nt as u64;
            continue;
        }
        if nt == 0 {
            res.clr_fn += ng as u64;
            for &g in f.gt_ids {
                s.gt_id_count[g as usize] += 1;
            }
            continue;
        }
        // Prefer continuing last frame's pairs (1000 beats any similarity), then similarity.
        let cost = s.assign.reset(ng, nt);
        for (i, &g) in f.gt_ids.iter().enumerate() {
            let prev = s.prev_timestep_tracker_id[g as usize];
            for (j, &t) in f.tracker_ids.iter().enumerate() {
                let sim = f.sim(i, j);
                let score = if sim < threshold - EPS {
                    0.0
                } else {
                    1000.0 * ((prev == t) as u8 as f64) + sim
                };
                cost[i * nt + j] = -score;
            }
        }
        if !s.assign.solve(ng, nt) {
            return Err(EvalError::Assignment {
                seq: seq.name().to_string(),
                rows: ng,
                cols: nt,
            });
        }
        s.matched.clear();
        let mut motp_frame = 0.0;
        for (&i, &j) in s.assign.rows.iter().zip(&s.assign.cols) {
            let sim = f.sim(i, j);
            let prev = s.prev_timestep_tracker_id[f.gt_ids[i] as usize];
            let score = if sim < threshold - EPS {
                0.0
            } else {
                1000.0 * ((prev == f.tracker_ids[j]) as u8 as f64) + sim
            };
            if score > EPS {
                s.matched.push((i, j));
                motp_frame += sim;
            }
        }
        for &(i, j) in &s.matched {
            let (g, t) = (f.gt_ids[i] as usize, f.tracker_ids[j]);
            let prev = s.prev_tracker_id[g];
            if prev != NONE && prev != t {
                res.idsw += 1;
            }
        }
        for &g in f.gt_ids {
            s.gt_id_count[g as usize] += 1;
        }
        // A gt id starts a new tracked fragment when it was not matched in the last frame that
        // had both gt and tracker objects.
        for &(i, _) in &s.matched {
            let g = f.gt_ids[i] as usize;
            s.gt_matched_count[g] += 1;
            if s.prev_timestep_tracker_id[g] == NONE {
                s.gt_frag_count[g] += 1;
            }
        }
        for &g in &s.prev_set {
            s.prev_timestep_tracker_id[g as usize] = NONE;
        }
        s.prev_set.clear();
        for &(i, j) in &s.matched {
            let (g, t) = (f.gt_ids[i], f.tracker_ids[j]);
            s.prev_tracker_id[g as usize] = t;
            s.prev_timestep_tracker_id[g as usize] = t;
            s.prev_set.push(g);
        }
        let m = s.matched.len() as u64;
        res.clr_tp += m;
        res.clr_fn += ng as u64 - m;
        res.clr_fp += nt as u64 - m;
        if m > 0 {
            res.motp_sum += motp_frame;
        }
    }

    for g in 0..n {
        let count = s.gt_id_count[g];
        if count == 0 {
            continue;
        }
        let ratio = s.gt_matched_count[g] as f64 / count as f64;
        if ratio > 0.8 {
            res.mt += 1;
        } else if ratio >= 0.2 {
            res.pt += 1;
        }
        res.frag += s.gt_frag_count[g].saturating_sub(1) as u64;
    }
    res.ml = n as u64 - res.mt - res.pt;
    res.clr_frames = seq.num_frames() as u64;
    res.finalize();
    Ok(res)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::SequenceBuilder;

    #[test]
    fn counts_switches_and_fragments_as_trackeval() {
        // One gt id; tracker: id 10, gap (no tracker object), id 10, then id 11.
        let mut b = SequenceBuilder::new("s");
        b.push_frame(&[1], &[10], &[0.9]).unwrap();
        b.push_frame(&[1], &[], &[]).unwrap();
        b.push_frame(&[1], &[10], &[0.8]).unwrap();
        b.push_frame(&[1], &[11], &[0.7]).unwrap();
        b.push_frame(&[1], &[11], &[0.2]).unwrap();
        b.push_frame(&[1], &[11], &[0.6]).unwrap();
        let c = clear(&b.finish(), 0.5).unwrap();
        assert_eq!((c.clr_tp, c.clr_fn, c.clr_fp), (4, 2, 1));
        assert_eq!(c.idsw, 1);
        // A frame without tracker objects does not break the track (TrackEval keeps the
        // previous-timestep state); the unmatched frame 5 does: one fragmentation.
        assert_eq!(c.frag, 1);
        assert_eq!((c.mt, c.pt, c.ml), (0, 1, 0));
        assert!((c.motp - (0.9 + 0.8 + 0.7 + 0.6) / 4.0).abs() < 1e-15);
    }

    #[test]
    fn empty_gt_leaves_mota_zero() {
        let mut b = SequenceBuilder::new("s");
        b.push_frame(&[], &[1, 2], &[]).unwrap();
        let c = clear(&b.finish(), 0.5).unwrap();
        // TrackEval returns before computing MOTA (which would be -FP).
        assert_eq!((c.clr_fp, c.mota, c.mlr, c.clr_frames), (2, 0.0, 1.0, 0));
    }
}
