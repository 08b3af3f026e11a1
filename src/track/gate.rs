//! The main association's gate from this sequence's own unambiguous matches
//! ([`Config::adaptive_gate`](super::Config::adaptive_gate)).
//!
//! How much a true match costs depends on the detector: a steady detector's box lands where the
//! track's prediction does, a jittery one's anywhere in a wide neighbourhood. One fixed gate
//! must serve both, so it is loose, and a loose gate lets a track whose own object went unseen
//! take a neighbour's detection. Pairs that nobody else could take — the track has one
//! candidate detection under the fixed gate and the detection one candidate track — are
//! matches whatever the gate: their costs measure what a true match costs under this
//! detector, and the gate is tightened to a multiple of their upper tail ([`GATE_QUANTILE`];
//! never above the fixed gate). The tail, not the median: a deforming shape's true matches
//! cost little most of the time and much at its changes, and a gate under those loses it.

use super::associate::{Edge, Pair};
use super::scores::Window;

/// The quantile of the unambiguous matches' costs that the gate is a multiple of.
pub const GATE_QUANTILE: f64 = 0.99;
/// Unambiguous matches seen before the gate adapts.
pub const GATE_WARMUP: usize = 50;
/// Unambiguous matches' costs kept (the latest): a long video's detector may change.
const GATE_WINDOW: usize = 2048;

/// The costs of this sequence's unambiguous matches.
#[derive(Debug, Clone)]
pub(crate) struct GateStats {
    costs: Window,
}

impl Default for GateStats {
    fn default() -> Self {
        Self {
            costs: Window::new(GATE_WINDOW),
        }
    }
}

impl GateStats {
    /// The gate for this frame: `fixed`, or `factor` times the unambiguous matches'
    /// [`GATE_QUANTILE`] once [`GATE_WARMUP`] of them have been seen, at most `fixed`.
    pub(crate) fn gate(&self, fixed: f64, factor: f64) -> f64 {
        if self.costs.len() < GATE_WARMUP {
            return fixed;
        }
        match self.costs.quantile(GATE_QUANTILE) {
            Some(c) => (factor * c).min(fixed),
            None => fixed,
        }
    }

    /// Records the frame's unambiguous main-stage matches: of `matches`, those whose track
    /// and detection have no other edge in `edges` passing `fixed` (threshold-compared cost).
    pub(crate) fn observe(&mut self, edges: &[Edge], matches: &[Pair], fixed: f64) {
        let (mut nt, mut nd) = (0usize, 0usize);
        for &(t, d, _, _) in edges {
            nt = nt.max(t + 1);
            nd = nd.max(d + 1);
        }
        let mut per_track = vec![0u32; nt];
        let mut per_det = vec![0u32; nd];
        let mut gate_of = vec![(usize::MAX, 0.0); nt];
        for &(t, d, _, g) in edges.iter().filter(|e| e.3 <= fixed) {
            per_track[t] += 1;
            per_det[d] += 1;
            gate_of[t] = (d, g);
        }
        for m in matches {
            let alone = per_track.get(m.track) == Some(&1) && per_det.get(m.det) == Some(&1);
            match gate_of.get(m.track) {
                Some(&(d, g)) if alone && d == m.det => self.costs.push(g),
                _ => {}
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pair(track: usize, det: usize) -> Pair {
        Pair {
            track,
            det,
            cost: 0.0,
        }
    }

    #[test]
    fn only_pairs_nobody_else_could_take_are_counted() {
        let mut s = GateStats::default();
        // Track 0 – det 0 alone (0.2); tracks 1 and 2 both reach det 1; track 3 reaches det 2
        // and det 3 (0.9 is above the fixed gate, so det 3 does not count against it).
        let edges: Vec<Edge> = vec![
            (0, 0, 0.2, 0.2),
            (1, 1, 0.3, 0.3),
            (2, 1, 0.4, 0.4),
            (3, 2, 0.1, 0.1),
            (3, 3, 0.9, 0.9),
        ];
        let matches = [pair(0, 0), pair(1, 1), pair(3, 2)];
        for k in 0..GATE_WARMUP / 2 {
            // Before the warm-up: the fixed gate.
            assert_eq!(s.gate(0.75, 2.0), 0.75, "after {k} frames");
            s.observe(&edges, &matches, 0.75);
        }
        // 0.2 and 0.1 once a frame: the upper tail is 0.2, so the gate is 0.4 at ×2 ...
        assert!((s.gate(0.75, 2.0) - 0.4).abs() < 1e-12);
        // ... and never above the fixed gate.
        assert_eq!(s.gate(0.3, 2.0), 0.3);
        // Frames where det 1's pair is the only one: they count, and raise the tail.
        for _ in 0..5 {
            s.observe(&[(1, 1, 0.5, 0.5)], &[pair(1, 1)], 0.75);
        }
        assert!((s.gate(0.75, 1.0) - 0.5).abs() < 1e-12);
    }
}
