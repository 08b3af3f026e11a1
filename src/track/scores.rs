//! Score thresholds that follow the detector, not a constant: a detection is *high* (matched
//! first, may start a track) or *low* (only extends tracks), and an unmatched high detection
//! may start a track, by comparison with the sequence's own scores.
//!
//! Detectors calibrate scores very differently: MOT15's Faster R-CNN gives true positives
//! 0.85–1.0 (median 0.98), a YOLO-style product of objectness and class probability may give
//! them 0.1–0.6, a detector thresholded in the browser gives everything 1.0. A fixed birth
//! threshold of 0.9 fits only the first: on the second nothing is ever born. So the thresholds
//! are quantiles of the scores of the detections the tracker itself matched to confirmed tracks
//! (its running estimate of the true positives' scores) over the last
//! [`ScoreAdaptation::window`] of them; until [`ScoreAdaptation::warmup`] such detections exist,
//! quantiles of every detection's score so far. Quantiles are invariant to any monotone
//! recalibration of the scores, so the tracker behaves the same whatever the detector's scale.

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

/// How score thresholds adapt to the sequence (see the module docs). Every field has a
/// default, so `{}` is the default adaptation.
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ScoreAdaptation {
    /// A detection is high when its score reaches this quantile of the matched detections'
    /// scores.
    pub high_quantile: f64,
    /// An unmatched high detection starts a track when its score reaches this quantile.
    pub birth_quantile: f64,
    /// Matched detections whose scores are kept (the most recent ones).
    pub window: usize,
    /// Matched detections needed before their scores are used; before, every detection's.
    pub warmup: usize,
}

impl Default for ScoreAdaptation {
    fn default() -> Self {
        Self {
            high_quantile: 0.05,
            birth_quantile: 0.2,
            window: 1000,
            warmup: 50,
        }
    }
}

impl ScoreAdaptation {
    /// Checks the quantiles lie in `[0, 1]` and the window holds at least the warm-up.
    pub fn validate(&self) -> Result<(), (&'static str, f64, &'static str)> {
        for (field, q) in [
            ("score_adaptation.high_quantile", self.high_quantile),
            ("score_adaptation.birth_quantile", self.birth_quantile),
        ] {
            if !(q.is_finite() && (0.0..=1.0).contains(&q)) {
                return Err((field, q, "must be in [0, 1]"));
            }
        }
        if self.window == 0 || self.window < self.warmup {
            return Err((
                "score_adaptation.window",
                self.window as f64,
                "must be ≥ 1 and ≥ warmup",
            ));
        }
        Ok(())
    }
}

/// The thresholds in force for one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Thresholds {
    /// Detections scoring at least this are high.
    pub high: f64,
    /// Unmatched high detections scoring at least this start tracks.
    pub birth: f64,
}

/// The last `cap` values, kept sorted too, for quantiles.
#[derive(Debug, Clone, Default)]
pub(crate) struct Window {
    order: VecDeque<f64>,
    sorted: Vec<f64>,
    cap: usize,
}

impl Window {
    pub(crate) fn new(cap: usize) -> Self {
        Self {
            cap: cap.max(1),
            ..Self::default()
        }
    }

    pub(crate) fn push(&mut self, v: f64) {
        if !v.is_finite() {
            return;
        }
        if self.order.len() == self.cap {
            if let Some(old) = self.order.pop_front() {
                let i = self.sorted.partition_point(|&x| x < old);
                if i < self.sorted.len() {
                    self.sorted.remove(i);
                }
            }
        }
        self.order.push_back(v);
        let i = self.sorted.partition_point(|&x| x < v);
        self.sorted.insert(i, v);
    }

    pub(crate) fn len(&self) -> usize {
        self.sorted.len()
    }

    /// The lower `q`-quantile (`None` when empty).
    pub(crate) fn quantile(&self, q: f64) -> Option<f64> {
        let n = self.sorted.len();
        if n == 0 {
            return None;
        }
        let k = ((q.clamp(0.0, 1.0) * (n - 1) as f64).floor() as usize).min(n - 1);
        self.sorted.get(k).copied()
    }
}

/// The running score statistics of one tracker.
#[derive(Debug, Clone)]
pub(crate) struct ScoreStats {
    adaptation: ScoreAdaptation,
    matched: Window,
    all: Window,
}

impl ScoreStats {
    pub(crate) fn new(adaptation: ScoreAdaptation) -> Self {
        Self {
            adaptation,
            matched: Window::new(adaptation.window),
            all: Window::new(adaptation.window),
        }
    }

    /// A detection's score, seen this frame.
    pub(crate) fn observe(&mut self, score: f64) {
        self.all.push(score);
    }

    /// The score of a detection matched to a confirmed track.
    pub(crate) fn observe_matched(&mut self, score: f64) {
        self.matched.push(score);
    }

    /// The thresholds for the next split, `fixed` while no score has been seen.
    pub(crate) fn thresholds(&self, fixed: Thresholds) -> Thresholds {
        let a = &self.adaptation;
        let w = if self.matched.len() >= a.warmup.max(1) {
            &self.matched
        } else {
            &self.all
        };
        match (w.quantile(a.high_quantile), w.quantile(a.birth_quantile)) {
            (Some(high), Some(birth)) => Thresholds {
                high,
                birth: birth.max(high),
            },
            _ => fixed,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FIXED: Thresholds = Thresholds {
        high: 0.6,
        birth: 0.9,
    };

    #[test]
    fn window_keeps_the_last_values_sorted() {
        let mut w = Window::new(3);
        for v in [5.0, 1.0, 3.0, 2.0, f64::NAN] {
            w.push(v);
        }
        // 5 left the window; NaN was never taken.
        assert_eq!(w.sorted, vec![1.0, 2.0, 3.0]);
        assert_eq!(w.quantile(0.0), Some(1.0));
        assert_eq!(w.quantile(0.5), Some(2.0));
        assert_eq!(w.quantile(1.0), Some(3.0));
        assert_eq!(Window::new(4).quantile(0.5), None);
    }

    #[test]
    fn thresholds_follow_the_matched_scores_after_warmup() {
        let a = ScoreAdaptation {
            high_quantile: 0.1,
            birth_quantile: 0.5,
            window: 100,
            warmup: 10,
        };
        let mut s = ScoreStats::new(a);
        assert_eq!(s.thresholds(FIXED), FIXED);
        // All detections: 0.0, 0.01, … 0.99.
        for i in 0..100 {
            s.observe(i as f64 / 100.0);
        }
        let t = s.thresholds(FIXED);
        assert!(
            (t.high - 0.09).abs() < 1e-12 && (t.birth - 0.49).abs() < 1e-12,
            "{t:?}"
        );
        // Matched ones score 0.5 … 0.59: used once there are 10.
        for i in 0..10 {
            s.observe_matched(0.5 + i as f64 / 100.0);
        }
        let t = s.thresholds(FIXED);
        assert!(
            (t.high - 0.50).abs() < 1e-12 && (t.birth - 0.54).abs() < 1e-12,
            "{t:?}"
        );
    }

    #[test]
    fn thresholds_are_invariant_to_the_score_scale() {
        // The same detections scored on two scales (x and 0.1 + 0.4·x²) split identically.
        let xs: Vec<f64> = (0..200).map(|i| ((i * 37) % 200) as f64 / 200.0).collect();
        let recal = |x: f64| 0.1 + 0.4 * x * x;
        let mut a = ScoreStats::new(ScoreAdaptation::default());
        let mut b = ScoreStats::new(ScoreAdaptation::default());
        for &x in &xs {
            a.observe(x);
            b.observe(recal(x));
        }
        for &x in xs.iter().skip(120) {
            a.observe_matched(x);
            b.observe_matched(recal(x));
        }
        let (ta, tb) = (a.thresholds(FIXED), b.thresholds(FIXED));
        for &x in &xs {
            assert_eq!(x >= ta.high, recal(x) >= tb.high);
            assert_eq!(x >= ta.birth, recal(x) >= tb.birth);
        }
        // A constant-score detector: everything is high and may start tracks.
        let mut c = ScoreStats::new(ScoreAdaptation::default());
        for _ in 0..10 {
            c.observe(1.0);
        }
        assert_eq!(
            c.thresholds(FIXED),
            Thresholds {
                high: 1.0,
                birth: 1.0
            }
        );
    }

    #[test]
    fn validation_rejects_bad_settings() {
        let bad = |a: ScoreAdaptation| a.validate().is_err();
        assert!(!bad(ScoreAdaptation::default()));
        assert!(bad(ScoreAdaptation {
            high_quantile: 1.5,
            ..Default::default()
        }));
        assert!(bad(ScoreAdaptation {
            birth_quantile: f64::NAN,
            ..Default::default()
        }));
        assert!(bad(ScoreAdaptation {
            window: 10,
            warmup: 20,
            ..Default::default()
        }));
    }
}
