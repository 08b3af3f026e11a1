//! When to report a confirmed track through a miss (coasting): only when the track is likely
//! to be found again soon, judged from this tracker's own history.
//!
//! A coasted shape (the track's predicted box, or its last mask moved by the predicted
//! motion) is a true positive if the object is still there and a false positive if it has left
//! or was a false track. Which is likelier depends on the detector and the scene: with a
//! detector that misses at random, almost every one-frame gap closes; in a scene where people
//! walk out of view or behind long occluders, most gaps never do. So the tracker counts how its
//! confirmed tracks' gaps ended — found again after `n` misses, or removed — and coasts a track
//! missed for `j` frames when the share of gaps that reached `j` misses and closed within the
//! coasting horizon is at least [`Coasting::min_probability`]. A Beta(1, 1) prior keeps the
//! estimate at ½ before anything has been seen.

use serde::{Deserialize, Serialize};

/// Adaptive coasting settings. Every field has a default, so `{}` is the default.
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Coasting {
    /// Coast a track missed for `j` frames when at least this share of this tracker's gaps
    /// that reached `j` misses closed within the horizon ([`Config::coast_frames`]).
    ///
    /// [`Config::coast_frames`]: super::Config::coast_frames
    pub min_probability: f64,
}

impl Default for Coasting {
    fn default() -> Self {
        Self {
            min_probability: 0.5,
        }
    }
}

impl Coasting {
    /// Checks the probability lies in `[0, 1]`.
    pub fn validate(&self) -> Result<(), (&'static str, f64, &'static str)> {
        let p = self.min_probability;
        if p.is_finite() && (0.0..=1.0).contains(&p) {
            Ok(())
        } else {
            Err(("coasting.min_probability", p, "must be in [0, 1]"))
        }
    }
}

/// How this tracker's gaps ended, by length.
#[derive(Debug, Clone, Default)]
pub(crate) struct GapStats {
    /// `closed[n]`: gaps closed after exactly `n` misses (index 0 unused).
    closed: Vec<u64>,
    /// `ended[n]`: gaps still open after `n` misses when their track was removed.
    ended: Vec<u64>,
}

fn bump(v: &mut Vec<u64>, n: u32) {
    let n = n as usize;
    if v.len() <= n {
        v.resize(n + 1, 0);
    }
    v[n] += 1;
}

impl GapStats {
    /// A confirmed track was found again after `misses` misses.
    pub(crate) fn closed(&mut self, misses: u32) {
        if misses > 0 {
            bump(&mut self.closed, misses);
        }
    }

    /// A confirmed track was removed while missed for `misses` frames.
    pub(crate) fn ended(&mut self, misses: u32) {
        if misses > 0 {
            bump(&mut self.ended, misses);
        }
    }

    /// The estimated probability that a gap that reached `j` misses closes after at most
    /// `horizon` misses, with a Beta(1, 1) prior.
    pub(crate) fn closes_within(&self, j: u32, horizon: u32) -> f64 {
        let (j, h) = (j as usize, horizon as usize);
        let count = |v: &[u64], lo: usize, hi: usize| -> u64 {
            v.iter()
                .enumerate()
                .filter(|(n, _)| (lo..=hi).contains(n))
                .map(|(_, c)| c)
                .sum()
        };
        let closed_soon = count(&self.closed, j, h);
        let reached = count(&self.closed, j, usize::MAX) + count(&self.ended, j, usize::MAX);
        (closed_soon as f64 + 1.0) / (reached as f64 + 2.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closing_probability_follows_the_history() {
        let mut g = GapStats::default();
        // Prior: ½.
        assert_eq!(g.closes_within(1, 3), 0.5);
        // Random misses: 18 one-frame gaps and 2 two-frame gaps closed, none ended.
        for _ in 0..18 {
            g.closed(1);
        }
        g.closed(2);
        g.closed(2);
        assert!((g.closes_within(1, 3) - 21.0 / 22.0).abs() < 1e-12);
        assert!((g.closes_within(2, 3) - 3.0 / 4.0).abs() < 1e-12);
        // Exits: 40 gaps ended after 30 misses dominate once they are seen.
        for _ in 0..40 {
            g.ended(30);
        }
        assert!(g.closes_within(1, 3) < 0.5);
        // A gap that already lasted 3 frames only counts gaps that reached 3.
        assert!((g.closes_within(3, 3) - 1.0 / 42.0).abs() < 1e-12);
        // Zero-length gaps are not gaps.
        g.closed(0);
        g.ended(0);
        assert!((g.closes_within(3, 3) - 1.0 / 42.0).abs() < 1e-12);
    }

    #[test]
    fn validation() {
        assert!(Coasting::default().validate().is_ok());
        assert!(Coasting {
            min_probability: 1.2
        }
        .validate()
        .is_err());
    }
}
