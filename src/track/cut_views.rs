//! Whether a sequence's detector boxes the visible part of a partly hidden object (see
//! [`Config::complete_cut_boxes`](super::Config::complete_cut_boxes)), judged from each frame's
//! detections alone.
//!
//! A detector that boxes what it sees (most box detectors on a crowd, and every box taken
//! from a visible mask) cuts a person behind a nearer one from below: the box's height falls
//! and its width stays, so the boxes that nearer detections would cover come flatter than the
//! others. A detector of whole (amodal) boxes, or boxes with noise only, keeps their aspect
//! whatever covers them. Measured on the grid's detections (every sequence; see
//! `tests/data/quality/README.md`, "Completing cut boxes"): the lower-quartile aspect of covered
//! detections over that of uncovered ones is 0.44–0.56 on the dense crowd's visible-part
//! boxes and 0.64 or more on all 354 sequences of MOT15, SportsMOT and BDD100K under every
//! detector model; the crowd's own amodal boxes, with or without 10 % noise, give 0.99–1.02.

use super::scores::Window;
use crate::frame::BBox;

/// Samples each side keeps (the latest): a long video's detector may change.
const CUT_CAP: usize = 4096;
/// Covered views the judgement waits for (a sparse scene's few change nothing).
const CUT_MIN_HIDDEN: usize = 30;
/// Uncovered views the judgement waits for.
const CUT_MIN_CLEAR: usize = 10;
/// Lone detections (overlapping no other) the reference aspect waits for.
const CUT_MIN_FREE: usize = 20;
/// A detection's expected whole box counts as hidden when one nearer detection covers at
/// least this share of it, and clear when none covers more than `CUT_CLEAR`.
const CUT_HIDDEN_SHARE: f64 = 0.6;
/// See `CUT_HIDDEN_SHARE`.
const CUT_CLEAR: f64 = 0.05;
/// The detector boxes visible parts when the hidden views' lower-quartile aspect (h / w) is
/// below this share of the clear views'.
const CUT_ASPECT: f64 = 0.6;

/// Whether the detector boxes the visible part of a partly hidden person, judged from each
/// frame's detections alone (no tracks): a visible-part detector cuts a person behind from
/// below (the height falls, the width stays), so the boxes that nearer detections would cover
/// come flatter than the others; whole boxes with noise keep their aspect whatever covers
/// them. Each detection's expected whole box keeps its top and width and takes the height its
/// width gives at the median aspect of the detections that overlap no other; the nearer
/// detection (lower expected bottom) covering most of it gives its covered share.
#[derive(Debug, Clone)]
pub(crate) struct CutJudge {
    /// Aspects of the detections that overlap no other.
    free: Window,
    /// Aspects of the detections covered at least `CUT_HIDDEN_SHARE`.
    hidden: Window,
    /// Aspects of the detections covered less than `CUT_CLEAR`.
    clear: Window,
}

impl Default for CutJudge {
    fn default() -> Self {
        Self {
            free: Window::new(CUT_CAP),
            hidden: Window::new(CUT_CAP),
            clear: Window::new(CUT_CAP),
        }
    }
}

impl CutJudge {
    /// Takes one frame's detection boxes.
    pub(crate) fn observe(&mut self, boxes: &[BBox]) {
        let ok: Vec<&BBox> = boxes.iter().filter(|b| b.w > 0.0 && b.h > 0.0).collect();
        for (i, b) in ok.iter().enumerate() {
            let alone = ok
                .iter()
                .enumerate()
                .all(|(j, o)| j == i || o.intersection_area(b) <= 0.0);
            if alone {
                self.free.push(b.h / b.w);
            }
        }
        let a0 = match self.free.quantile(0.5) {
            Some(a) if self.free.len() >= CUT_MIN_FREE => a,
            _ => return,
        };
        let full: Vec<BBox> = ok
            .iter()
            .map(|b| BBox::new(b.x, b.y, b.w, b.h.max(b.w * a0)))
            .collect();
        for (i, b) in ok.iter().enumerate() {
            let e = &full[i];
            let bottom = e.y + e.h;
            let area = e.w * e.h;
            let f = ok
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != i && full[j].y + full[j].h > bottom)
                .map(|(_, o)| o.intersection_area(e) / area)
                .fold(0.0, f64::max);
            if f >= CUT_HIDDEN_SHARE {
                self.hidden.push(b.h / b.w);
            } else if f < CUT_CLEAR {
                self.clear.push(b.h / b.w);
            }
        }
    }

    /// Whether the hidden views come boxed flatter (see the type).
    pub(crate) fn cuts(&self) -> bool {
        if self.hidden.len() < CUT_MIN_HIDDEN || self.clear.len() < CUT_MIN_CLEAR {
            return false;
        }
        match (self.hidden.quantile(0.25), self.clear.quantile(0.25)) {
            (Some(h), Some(c)) => h < CUT_ASPECT * c,
            _ => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Eight people in a nearer row (feet at y = 400) and eight behind them (whole boxes
    /// 280–380), each covered from below by the nearer one (0.7 of its whole box), and eight
    /// standing alone; all 40 px wide and about 100 tall (`jitter` on each height). With
    /// `visible` the people behind are boxed by their visible part (280–300), else whole.
    fn crowd(visible: bool, jitter: f64, frames: usize) -> CutJudge {
        let mut j = CutJudge::default();
        let mut state = 7u64;
        let mut rnd = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 33) as f64 / (1u64 << 31) as f64) * 2.0 - 1.0
        };
        for _ in 0..frames {
            let mut boxes = Vec::new();
            for k in 0..8 {
                let x = 100.0 * k as f64;
                let h = 100.0 * (1.0 + jitter * rnd());
                boxes.push(BBox::new(x, 400.0 - h, 40.0, h));
                let h = if visible {
                    20.0
                } else {
                    100.0 * (1.0 + jitter * rnd())
                };
                boxes.push(BBox::new(x + 5.0, 280.0, 40.0, h));
                let h = 100.0 * (1.0 + jitter * rnd());
                boxes.push(BBox::new(x + 50.0, 600.0, 40.0, h));
            }
            j.observe(&boxes);
        }
        j
    }

    #[test]
    fn boxes_of_the_visible_part_are_told_from_whole_ones() {
        assert!(crowd(true, 0.05, 10).cuts());
        assert!(!crowd(false, 0.05, 10).cuts());
        assert!(!crowd(false, 0.15, 10).cuts());
        // Too few covered views yet: no judgement.
        assert!(!crowd(true, 0.05, 1).cuts());
    }

    #[test]
    fn degenerate_boxes_are_ignored() {
        let mut j = CutJudge::default();
        for _ in 0..50 {
            j.observe(&[
                BBox::new(0.0, 0.0, 0.0, 10.0),
                BBox::new(0.0, 0.0, 10.0, 0.0),
                BBox::new(5.0, 5.0, 10.0, 20.0),
            ]);
        }
        assert!(!j.cuts());
    }
}
