//! VOT short-term metrics: region overlap, the VOT2020 anchor protocol (accuracy, robustness,
//! EAO; thesis §6.1, eq. 53–56) and the reset protocol of VOT2016–2019.
//!
//! # Overlap
//!
//! [`overlap`] is the intersection over union of two [`Region`]s of any kind, with two methods:
//!
//! - [`OverlapMethod::Exact`] (default): continuous geometry. Rectangles and polygons are
//!   areas bounded by their edges, filled by the even-odd rule (so non-convex and
//!   self-intersecting polygons work); a mask is the union of its pixels' unit squares. Areas
//!   are integrated exactly by a vertical sweep: between consecutive event abscissae (all
//!   vertices and all edge–edge crossings) no edge crosses another, so the covered length of
//!   each vertical line is linear in x and the midpoint rule is exact. The result is exact up
//!   to floating-point rounding for convex and non-convex polygons alike.
//! - [`OverlapMethod::Toolkit`]: a port of the VOT toolkit's `calculate_overlap` (vot-toolkit
//!   0.9, `vot/region/raster.py`): coordinates rounded half-to-even, rectangles and polygons
//!   rasterised with its scan-line rules, pixel counts compared. It reproduces the toolkit's
//!   numbers bit for bit (including its quirks); it falls back to `Exact` if the raster would
//!   exceed 2²⁶ pixels (the toolkit would allocate it).
//!
//! Both follow VOT's conventions: two empty regions (special codes, degenerate shapes) overlap
//! 1; `bounds = Some((w, h))` clips both regions to the image `[0, w] × [0, h]` first.
//!
//! # Anchor protocol (VOT2020, thesis eq. 53–56)
//!
//! The tracker is initialised at every anchor and run to the end of the sequence (forward
//! anchors) or to its first frame (backward anchors); the toolkit's trajectory of an anchor
//! has, in run order, the special code 1 at the anchor then one region per frame. Ported from
//! the toolkit's `multistart_ar`, `multistart_eao_curves`, `multistart_eao_curve` and
//! `multistart_eao_score` analyses:
//!
//! - per anchor run of N frames: overlaps o₀…o_{N−1} against the ground truth (bounded by the
//!   image when `bounds` is given). Failure: the first frame of `grace` (θ_N = 10) consecutive
//!   frames whose overlap is ≤ `threshold` (θ_φ = 0.1) and whose ground truth is not empty;
//!   N^F = the index of that frame (N when there is none);
//! - sequence: A = Σ_a Σ_{i<N^F_a} o_i / Σ_a N^F_a, R = Σ_a N^F_a / Σ_a N_a (eq. 53, 54
//!   pooled over the sequence's anchors); dataset: A weighted by Σ_a N^F_a, R by the
//!   sequence's length;
//! - EAO curve (eq. 55): for length j ≥ 1, each run with N > j contributes mean(o₁…o_j); a run
//!   that failed and has N ≤ j contributes Σ_{1≤i<N} o_i / (j − 1) with overlaps after N^F set
//!   to 0 (the toolkit divides by j − 1 here, not j; we keep it); a successful run shorter
//!   than j does not contribute. Sequences are pooled by contributing runs. Curve length
//!   `eao_high` (755); EAO = the mean of curve[`eao_low`..`eao_high`) — 640 values — where a
//!   length no run reaches counts as 0 (toolkit), and [`AnchorSummary::eao_defined`] is the
//!   mean over the lengths some run reaches (eq. 55 read literally: Φ̂_i is undefined when
//!   S(i) is empty).
//! - The anchor frame: the toolkit stores the special code 1 there, whose overlap with the
//!   ground truth is 0, so it counts as a 0 in A (and towards the grace counter). With
//!   [`InitFrame::GroundTruth`] (our default) it counts as overlap 1 instead — the tracker was
//!   given the ground truth — so a perfect tracker scores A = 1. [`AnchorParams::toolkit`]
//!   reproduces the toolkit exactly.
//!
//! The toolkit reads anchors from a sequence's `anchor.value` file; [`anchors_every`] places
//! them as VOT2020 describes: every Δ = 50 frames from the first, each run in the direction
//! that gives the longer sub-sequence (forward in the first half, backward in the second).
//!
//! # Reset protocol (VOT2016–2019)
//!
//! Ported from the toolkit's `SupervisedExperiment` and `supervised_*` analyses: the tracker
//! is initialised in frame 0 (special code 1); a frame whose overlap is ≤ `failure_overlap`
//! (0) is a failure (code 2) and the tracker is re-initialised `skip_initialize` (5) frames
//! later, the frames between being code 0. Accuracy = mean overlap over frames that are not
//! special and not within `burnin` (10) frames of an initialisation (the initialisation frame
//! included); failures = number of code-2 frames; reliability = exp(−S·F/L) with S = 30. Over
//! sequences A and F are length-weighted means. EAO: each initialisation starts a run that
//! ends before its failure (failed) or at the sequence end (successful); `curve[j]` = mean over
//! runs of mean(o₁…o_j) with failed runs padded with zeros and successful runs counted only
//! while j < their length (`curve[0]` = mean o₀); EAO = mean of `curve[eao_low..=eao_high]`
//! (VOT2019: 46–291).

mod anchor;
mod exact;
mod reset;
mod toolkit;

pub use anchor::{
    anchor_frames, anchors_every, evaluate_anchor_sequence, run_anchor_protocol, summarize_anchor,
    AnchorParams, AnchorRun, AnchorScorer, AnchorSequence, AnchorSummary, InitFrame,
};
pub use reset::{
    evaluate_reset_sequence, run_reset_protocol, summarize_reset, ResetParams, ResetSequence,
    ResetSummary,
};

use crate::io::vot::Region;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Errors of the VOT protocols.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum VotError {
    /// Two lists that must have the same length do not.
    #[error("{what}: expected {expected} entries, got {got}")]
    LengthMismatch {
        /// Which list.
        what: String,
        /// Entries expected.
        expected: usize,
        /// Entries given.
        got: usize,
    },
    /// An anchor lies outside the sequence.
    #[error("anchor at frame {frame} is outside the sequence of {len} frames")]
    AnchorOutOfRange {
        /// 0-based anchor frame.
        frame: usize,
        /// Sequence length.
        len: usize,
    },
    /// There is nothing to evaluate.
    #[error("no anchors / sequences to evaluate")]
    Empty,
}

/// How region overlap is computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum OverlapMethod {
    /// Exact continuous geometry (even-odd polygons, pixel-square masks).
    #[default]
    Exact,
    /// The VOT toolkit's rasterisation, bit for bit.
    Toolkit,
}

/// Rasters larger than this fall back to exact geometry in [`OverlapMethod::Toolkit`].
const MAX_RASTER: i64 = 1 << 26;

/// Intersection over union of two regions (see the module doc for conventions).
pub fn overlap(a: &Region, b: &Region, bounds: Option<(u32, u32)>, method: OverlapMethod) -> f64 {
    match method {
        OverlapMethod::Exact => exact::overlap(a, b, bounds),
        OverlapMethod::Toolkit => {
            toolkit::overlap(a, b, bounds).unwrap_or_else(|| exact::overlap(a, b, bounds))
        }
    }
}

/// Per-frame overlaps of two region lists of equal length.
pub fn overlaps(
    a: &[Region],
    b: &[Region],
    bounds: Option<(u32, u32)>,
    method: OverlapMethod,
) -> Result<Vec<f64>, VotError> {
    if a.len() != b.len() {
        return Err(VotError::LengthMismatch {
            what: "regions to compare".into(),
            expected: b.len(),
            got: a.len(),
        });
    }
    Ok(a.iter()
        .zip(b)
        .map(|(x, y)| overlap(x, y, bounds, method))
        .collect())
}

/// The area of a region, by exact geometry (clipped to `bounds` when given).
pub fn region_area(r: &Region, bounds: Option<(u32, u32)>) -> f64 {
    exact::area(r, bounds)
}

#[cfg(test)]
mod tests;
