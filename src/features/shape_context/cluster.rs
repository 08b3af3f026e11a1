//! Normalising one cost over the pairs of a region cluster into `[0, 1]`
//! ([`normalize_in_cluster`]).

use serde::{Deserialize, Serialize};

/// How [`normalize_in_cluster`] maps a region cluster's raw costs into `[0, 1]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum ClusterNorm {
    /// `v / max` (default). Keeps 0 at 0 and keeps ratios, so a perfect pair stays perfect and
    /// two equally good pairs stay equal; only the worst pair is pinned to 1.
    #[default]
    DivideByMax,
    /// `(v − min) / (max − min)`. Stretches the spread, but makes the best pair 0 even when
    /// it is poor, and cannot tell "all equally bad" from "all perfect".
    MinMax,
}

/// Normalises one cost (C1 or C2) over the pairs of one region cluster into `[0, 1]`, so that
/// eq. 39 weighs shape and colour on the same footing (thesis: "normalised within the
/// cluster").
///
/// Rules: negative values count as 0; NaN and infinite values (pairs that could not be
/// compared) become 1, the worst; the extrema are taken over the finite values only; if those
/// are all equal (including a single pair) every finite value maps to 0 under
/// [`ClusterNorm::MinMax`], and under [`ClusterNorm::DivideByMax`] to 0 when the maximum is 0
/// and to 1 otherwise. Because normalised values are only comparable within one cluster,
/// gating (rejecting a pair outright) must use the raw costs.
pub fn normalize_in_cluster(costs: &[f64], rule: ClusterNorm) -> Vec<f64> {
    let finite = || costs.iter().filter(|v| v.is_finite()).map(|v| v.max(0.0));
    let max = finite().fold(f64::NEG_INFINITY, f64::max);
    let min = finite().fold(f64::INFINITY, f64::min);
    costs
        .iter()
        .map(|&v| {
            if !v.is_finite() {
                return 1.0;
            }
            let v = v.max(0.0);
            let out = match rule {
                ClusterNorm::DivideByMax => {
                    if max > 0.0 {
                        v / max
                    } else {
                        0.0
                    }
                }
                ClusterNorm::MinMax => {
                    if max > min {
                        (v - min) / (max - min)
                    } else {
                        0.0
                    }
                }
            };
            out.clamp(0.0, 1.0)
        })
        .collect()
}
