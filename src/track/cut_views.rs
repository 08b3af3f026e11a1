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

use std::collections::VecDeque;

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
/// Histogram bins per unit of ln(aspect): a quantile is off by at most half a bin, 0.2 %,
/// far inside the judgement's margins (0.44–0.56 against ≥ 0.64 of `CUT_ASPECT`'s 0.6).
const BINS_PER_NAT: f64 = 256.0;
/// Aspects are clamped to `[1 / CUT_SPAN, CUT_SPAN]` (a 64 : 1 box is a sliver either way).
const CUT_SPAN: f64 = 64.0;

/// The latest `CUT_CAP` aspects as a histogram of ln(aspect): pushing is O(1) and a quantile
/// one pass over the fixed bins, where a sorted window paid a shift of up to its whole length
/// per sample — the judge's samples grow with the detections, so its cost stays linear in them.
#[derive(Debug, Clone)]
struct AspectWindow {
    order: VecDeque<u16>,
    counts: Vec<u32>,
}

impl AspectWindow {
    fn new() -> Self {
        let bins = (2.0 * CUT_SPAN.ln() * BINS_PER_NAT).ceil() as usize + 1;
        Self {
            order: VecDeque::with_capacity(CUT_CAP),
            counts: vec![0; bins],
        }
    }

    fn push(&mut self, aspect: f64) {
        if !aspect.is_finite() || aspect <= 0.0 {
            return;
        }
        let top = self.counts.len() - 1;
        let b = ((aspect.ln() + CUT_SPAN.ln()) * BINS_PER_NAT).round();
        let b = (b.max(0.0) as usize).min(top);
        if self.order.len() == CUT_CAP {
            if let Some(old) = self.order.pop_front() {
                self.counts[old as usize] -= 1;
            }
        }
        self.order.push_back(b as u16);
        self.counts[b] += 1;
    }

    fn len(&self) -> usize {
        self.order.len()
    }

    /// The lower `q`-quantile, as its bin's centre (`None` when empty).
    fn quantile(&self, q: f64) -> Option<f64> {
        let n = self.order.len();
        if n == 0 {
            return None;
        }
        let k = ((q.clamp(0.0, 1.0) * (n - 1) as f64).floor() as usize).min(n - 1);
        let mut seen = 0usize;
        for (b, &c) in self.counts.iter().enumerate() {
            seen += c as usize;
            if seen > k {
                return Some((b as f64 / BINS_PER_NAT - CUT_SPAN.ln()).exp());
            }
        }
        None
    }
}

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
    free: AspectWindow,
    /// Aspects of the detections covered at least `CUT_HIDDEN_SHARE`.
    hidden: AspectWindow,
    /// Aspects of the detections covered less than `CUT_CLEAR`.
    clear: AspectWindow,
}

impl Default for CutJudge {
    fn default() -> Self {
        Self {
            free: AspectWindow::new(),
            hidden: AspectWindow::new(),
            clear: AspectWindow::new(),
        }
    }
}

/// The pairs `(i, j)`, `i < j`, of `boxes` whose horizontal extents overlap (a positive
/// length), by a sweep over the boxes sorted by left edge: a crowd's people overlap only a
/// few neighbours, so this is near linear where all pairs were quadratic. Every pair the
/// judge needs overlaps horizontally (an expected whole box keeps its detection's width).
fn x_overlapping_pairs(boxes: &[&BBox]) -> Vec<(usize, usize)> {
    let mut by_x: Vec<usize> = (0..boxes.len()).collect();
    by_x.sort_by(|&a, &b| boxes[a].x.total_cmp(&boxes[b].x));
    let mut pairs = Vec::new();
    for (n, &i) in by_x.iter().enumerate() {
        let right = boxes[i].x2();
        for &j in &by_x[n + 1..] {
            if boxes[j].x >= right {
                break;
            }
            pairs.push((i.min(j), i.max(j)));
        }
    }
    pairs
}

impl CutJudge {
    /// Takes one frame's detection boxes.
    pub(crate) fn observe(&mut self, boxes: &[BBox]) {
        let ok: Vec<&BBox> = boxes
            .iter()
            .filter(|b| {
                b.w > 0.0 && b.h > 0.0 && [b.x, b.y, b.w, b.h].iter().all(|v| v.is_finite())
            })
            .collect();
        let pairs = x_overlapping_pairs(&ok);
        let mut alone = vec![true; ok.len()];
        for &(i, j) in &pairs {
            if ok[i].intersection_area(ok[j]) > 0.0 {
                alone[i] = false;
                alone[j] = false;
            }
        }
        for (b, _) in ok.iter().zip(&alone).filter(|(_, &a)| a) {
            self.free.push(b.h / b.w);
        }
        let a0 = match self.free.quantile(0.5) {
            Some(a) if self.free.len() >= CUT_MIN_FREE => a,
            _ => return,
        };
        let full: Vec<BBox> = ok
            .iter()
            .map(|b| BBox::new(b.x, b.y, b.w, b.h.max(b.w * a0)))
            .collect();
        // Each detection's largest share covered by one nearer detection.
        let mut covered = vec![0.0f64; ok.len()];
        for &(i, j) in &pairs {
            for (me, other) in [(i, j), (j, i)] {
                let e = &full[me];
                if full[other].y + full[other].h > e.y + e.h {
                    let f = ok[other].intersection_area(e) / (e.w * e.h);
                    covered[me] = covered[me].max(f);
                }
            }
        }
        for (b, &f) in ok.iter().zip(&covered) {
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

    /// A small deterministic generator in [0, 1).
    fn uniform(state: &mut u64) -> f64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    #[test]
    fn the_sweep_finds_every_horizontally_overlapping_pair() {
        let mut st = 3u64;
        for n in [0usize, 1, 2, 7, 60] {
            let boxes: Vec<BBox> = (0..n)
                .map(|k| {
                    // Some boxes share a left edge or touch another's right edge exactly.
                    let x = if k % 5 == 0 {
                        100.0
                    } else {
                        (uniform(&mut st) * 800.0).round()
                    };
                    BBox::new(
                        x,
                        uniform(&mut st) * 500.0,
                        1.0 + (uniform(&mut st) * 90.0).round(),
                        50.0,
                    )
                })
                .collect();
            let refs: Vec<&BBox> = boxes.iter().collect();
            let mut got = x_overlapping_pairs(&refs);
            got.sort_unstable();
            let mut want = Vec::new();
            for i in 0..n {
                for j in i + 1..n {
                    let (a, b) = (&boxes[i], &boxes[j]);
                    if a.x2().min(b.x2()) - a.x.max(b.x) > 0.0 {
                        want.push((i, j));
                    }
                }
            }
            assert_eq!(got, want, "{n} boxes");
        }
    }

    #[test]
    fn the_aspect_window_keeps_the_latest_samples_and_their_quantiles() {
        let mut w = AspectWindow::new();
        assert_eq!(w.quantile(0.5), None);
        let mut st = 11u64;
        let mut all = Vec::new();
        for _ in 0..(CUT_CAP + 1000) {
            let a = (uniform(&mut st) * 6.0 - 3.0).exp();
            w.push(a);
            all.push(a);
        }
        // Not finite or not positive: ignored.
        w.push(f64::NAN);
        w.push(-1.0);
        assert_eq!(w.len(), CUT_CAP);
        let mut latest = all[all.len() - CUT_CAP..].to_vec();
        latest.sort_by(f64::total_cmp);
        for q in [0.0, 0.25, 0.5, 0.9, 1.0] {
            let k = (q * (CUT_CAP - 1) as f64).floor() as usize;
            let got = w.quantile(q).unwrap();
            assert!(
                (got / latest[k]).ln().abs() <= 0.5 / BINS_PER_NAT + 1e-12,
                "q {q}: {got} vs {}",
                latest[k]
            );
        }
        // Beyond the span: clamped to the end bins.
        let mut e = AspectWindow::new();
        e.push(1e9);
        assert!((e.quantile(0.5).unwrap() / CUT_SPAN).ln().abs() <= 1.0 / BINS_PER_NAT);
    }
}
