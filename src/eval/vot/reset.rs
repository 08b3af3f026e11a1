//! The reset protocol of VOT2016–2019: running a tracker with re-initialisation after each
//! failure, and scoring the trajectories per sequence and over a dataset (the parent module's
//! doc has the definitions).

use super::{overlap, overlaps, OverlapMethod, VotError};
use crate::io::vot::{Region, SPECIAL_FAILURE, SPECIAL_INIT, SPECIAL_UNKNOWN};
use serde::{Deserialize, Serialize};

/// Parameters of the reset protocol.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ResetParams {
    /// Overlap at or below which a frame is a failure.
    pub failure_overlap: f64,
    /// Frames from a failure to the re-initialisation.
    pub skip_initialize: usize,
    /// Frames from an initialisation (itself included) left out of accuracy.
    pub burnin: usize,
    /// Reliability sensitivity S in exp(−S·F/L).
    pub sensitivity: f64,
    /// Image size for clipping regions, when known.
    pub bounds: Option<(u32, u32)>,
    /// Overlap computation.
    pub method: OverlapMethod,
    /// First EAO curve index averaged.
    pub eao_low: usize,
    /// Last EAO curve index averaged (inclusive).
    pub eao_high: usize,
}

impl Default for ResetParams {
    fn default() -> Self {
        Self {
            failure_overlap: 0.0,
            skip_initialize: 5,
            burnin: 10,
            sensitivity: 30.0,
            bounds: None,
            method: OverlapMethod::Exact,
            eao_low: 46,
            eao_high: 291,
        }
    }
}

/// Runs a tracker under the reset protocol. `tracker(start, init)` is given the 0-based start
/// frame and the ground truth there and returns its regions for frames `start + 1 ..` (it may
/// stop early: missing frames count as failures). Returns the trajectory: code 1 at
/// initialisations, code 2 at failures, code 0 for skipped frames, regions elsewhere.
///
/// A frame whose ground truth is empty (the object absent: VOT writes `NaN` coordinates,
/// read as code 0) is never a failure, whatever the tracker reports there: the anchor
/// protocol's rule ([`super::evaluate_anchor_sequence`] counts a failure only where the
/// object is present), so that both protocols judge the same frames alike. (The toolkit's
/// supervisor would fail a tracker that still reports the object while it is hidden; its
/// VOT2016–2019 sequences have no such frame, so their results are unchanged.)
pub fn run_reset_protocol<F>(gt: &[Region], params: &ResetParams, mut tracker: F) -> Vec<Region>
where
    F: FnMut(usize, &Region) -> Vec<Region>,
{
    let n = gt.len();
    let mut traj = vec![Region::Special(SPECIAL_UNKNOWN); n];
    let mut frame = 0;
    while frame < n {
        traj[frame] = Region::Special(SPECIAL_INIT);
        let start = frame;
        let out = tracker(start, &gt[start]);
        frame += 1;
        while frame < n {
            let r = out.get(frame - start - 1);
            let o = r.map_or(0.0, |r| {
                overlap(r, &gt[frame], params.bounds, params.method)
            });
            match r {
                Some(r) if o > params.failure_overlap || gt[frame].is_empty() => {
                    traj[frame] = r.clone();
                    frame += 1;
                }
                _ => {
                    traj[frame] = Region::Special(SPECIAL_FAILURE);
                    frame += params.skip_initialize.max(1);
                    break;
                }
            }
        }
    }
    traj
}

/// A sequence evaluated under the reset protocol.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResetSequence {
    /// Mean overlap over the frames counted for accuracy (0 when none).
    pub accuracy: f64,
    /// Frames counted for accuracy.
    pub accuracy_frames: usize,
    /// Number of failures.
    pub failures: usize,
    /// Sequence length.
    pub length: usize,
    /// Frames (0-based) where the tracker failed.
    pub failure_frames: Vec<usize>,
    /// EAO runs: overlaps from an initialisation to just before its failure (or the end), and
    /// whether it reached the end.
    pub runs: Vec<(Vec<f64>, bool)>,
}

/// Evaluates a reset-protocol trajectory against the ground truth.
pub fn evaluate_reset_sequence(
    gt: &[Region],
    trajectory: &[Region],
    params: &ResetParams,
) -> Result<ResetSequence, VotError> {
    let ov = overlaps(trajectory, gt, params.bounds, params.method)?;
    let n = ov.len();
    let mut counted = vec![true; n];
    let (mut fails, mut inits) = (Vec::new(), Vec::new());
    for (i, r) in trajectory.iter().enumerate() {
        match r.special() {
            Some(SPECIAL_UNKNOWN) => counted[i] = false,
            Some(SPECIAL_INIT) => {
                inits.push(i);
                for c in counted.iter_mut().skip(i).take(params.burnin) {
                    *c = false;
                }
            }
            Some(SPECIAL_FAILURE) => {
                fails.push(i);
                counted[i] = false;
            }
            _ => {}
        }
    }
    let kept: Vec<f64> = ov
        .iter()
        .zip(&counted)
        .filter(|(_, &c)| c)
        .map(|(&o, _)| o)
        .collect();
    let mut runs = Vec::new();
    if fails.is_empty() {
        runs.push((ov.clone(), true));
    } else {
        for (k, &f) in fails.iter().enumerate() {
            let start = inits.get(k).copied().unwrap_or(0).min(f);
            runs.push((ov[start..f].to_vec(), false));
        }
        if inits.len() > fails.len() {
            if let Some(&last) = inits.last() {
                runs.push((ov[last..].to_vec(), true));
            }
        }
    }
    Ok(ResetSequence {
        accuracy: if kept.is_empty() {
            0.0
        } else {
            kept.iter().sum::<f64>() / kept.len() as f64
        },
        accuracy_frames: kept.len(),
        failures: fails.len(),
        length: n,
        failure_frames: fails,
        runs,
    })
}

/// Dataset-level reset-protocol scores.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResetSummary {
    /// Accuracy (length-weighted mean of sequence accuracies).
    pub accuracy: f64,
    /// Failures per sequence (length-weighted mean).
    pub failures: f64,
    /// Total failures.
    pub total_failures: usize,
    /// Reliability exp(−S·F/L̄) with L̄ the mean sequence length (the toolkit's robustness).
    pub reliability: f64,
    /// EAO (`None` when the curve does not reach `eao_low`).
    pub eao: Option<f64>,
    /// EAO curve.
    pub eao_curve: Vec<f64>,
}

/// Pools sequences as the toolkit's `supervised_average_ar` and `supervised_eao_*` analyses.
pub fn summarize_reset(
    seqs: &[ResetSequence],
    params: &ResetParams,
) -> Result<ResetSummary, VotError> {
    if seqs.is_empty() {
        return Err(VotError::Empty);
    }
    let wsum: f64 = seqs.iter().map(|s| s.length as f64).sum();
    let acc = seqs
        .iter()
        .map(|s| s.accuracy * s.length as f64)
        .sum::<f64>()
        / wsum;
    let fail = seqs
        .iter()
        .map(|s| s.failures as f64 * s.length as f64)
        .sum::<f64>()
        / wsum;
    let mean_len = wsum / seqs.len() as f64;
    let runs: Vec<&(Vec<f64>, bool)> = seqs.iter().flat_map(|s| &s.runs).collect();
    let max_len = runs.iter().map(|r| r.0.len()).max().unwrap_or(0);
    let mut curve = vec![0.0; max_len];
    let mut weight = vec![0.0; max_len];
    for (o, success) in &runs {
        let mut prefix = 0.0;
        for j in 0..max_len {
            let v = if j == 0 {
                o.first().copied().unwrap_or(0.0)
            } else {
                prefix += o.get(j).copied().unwrap_or(0.0);
                prefix / j as f64
            };
            if !*success || j < o.len() {
                curve[j] += v;
                weight[j] += 1.0;
            }
        }
    }
    let curve: Vec<f64> = curve
        .iter()
        .zip(&weight)
        .map(|(c, w)| if *w > 0.0 { c / w } else { 0.0 })
        .collect();
    let hi = (params.eao_high + 1).min(curve.len());
    let eao = (params.eao_low < hi)
        .then(|| curve[params.eao_low..hi].iter().sum::<f64>() / (hi - params.eao_low) as f64);
    Ok(ResetSummary {
        accuracy: acc,
        failures: fail,
        total_failures: seqs.iter().map(|s| s.failures).sum(),
        reliability: (-params.sensitivity * fail / mean_len).exp(),
        eao,
        eao_curve: curve,
    })
}
