//! The anchor protocol of VOT2020 (thesis eq. 53–56): placing anchors, running a tracker from
//! each, and scoring the runs per sequence and over a dataset (the parent module's doc has the
//! definitions).

use super::{overlap, OverlapMethod, VotError};
use crate::io::vot::{Anchor, Direction, Region, SPECIAL_INIT};
use serde::{Deserialize, Serialize};

/// Anchors every `spacing` frames from frame 0, each run in the direction of the longer
/// sub-sequence (forward when `n − f ≥ f + 1`), as VOT2020 places them.
pub fn anchors_every(num_frames: usize, spacing: usize) -> Vec<Anchor> {
    let spacing = spacing.max(1);
    (0..num_frames)
        .step_by(spacing)
        .map(|f| Anchor {
            frame: f,
            direction: if num_frames - f > f {
                Direction::Forward
            } else {
                Direction::Backward
            },
        })
        .collect()
}

/// The 0-based sequence frames an anchor's run visits, in run order.
pub fn anchor_frames(anchor: &Anchor, num_frames: usize) -> Vec<usize> {
    match anchor.direction {
        Direction::Forward => (anchor.frame..num_frames).collect(),
        Direction::Backward => (0..=anchor.frame.min(num_frames.saturating_sub(1)))
            .rev()
            .collect(),
    }
}

/// What the anchor frame (where the tracker is given the ground truth) counts as in accuracy
/// and in the failure test.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InitFrame {
    /// Overlap 1: the tracker was given the ground truth there.
    GroundTruth,
    /// Overlap of the special code 1 with the ground truth (0), as the toolkit computes it.
    Special,
}

/// Parameters of the anchor protocol.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AnchorParams {
    /// Overlap at or below which a frame counts towards a failure (θ_φ).
    pub threshold: f64,
    /// Consecutive such frames that make a failure (θ_N).
    pub grace: usize,
    /// Image size for clipping regions, when known.
    pub bounds: Option<(u32, u32)>,
    /// Overlap computation.
    pub method: OverlapMethod,
    /// What the anchor frame counts as.
    pub init_frame: InitFrame,
    /// First EAO curve index averaged (N_lo).
    pub eao_low: usize,
    /// EAO curve length; indices `eao_low..eao_high` are averaged (N_hi).
    pub eao_high: usize,
}

impl Default for AnchorParams {
    fn default() -> Self {
        Self {
            threshold: 0.1,
            grace: 10,
            bounds: None,
            method: OverlapMethod::Exact,
            init_frame: InitFrame::GroundTruth,
            eao_low: 115,
            eao_high: 755,
        }
    }
}

impl AnchorParams {
    /// The VOT toolkit's `vot2020/shortterm` baseline settings, reproduced exactly (raster
    /// overlap, special anchor frame); the toolkit clips to the image, so give its size.
    pub fn toolkit(bounds: Option<(u32, u32)>) -> Self {
        Self {
            bounds,
            method: OverlapMethod::Toolkit,
            init_frame: InitFrame::Special,
            ..Self::default()
        }
    }
}

/// One anchor's run evaluated.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AnchorRun {
    /// The anchor.
    pub anchor: Anchor,
    /// Frames in the run (N).
    pub length: usize,
    /// Frames before the failure (N^F; `length` when it did not fail).
    pub progress: usize,
    /// Whether the run failed.
    pub failed: bool,
    /// Accuracy of the run alone: mean overlap of its first `progress` frames.
    pub accuracy: f64,
    /// Overlap per frame in run order (after a failure as measured, not zeroed).
    pub overlaps: Vec<f64>,
}

/// A sequence evaluated under the anchor protocol.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AnchorSequence {
    /// Runs, in the order given.
    pub runs: Vec<AnchorRun>,
    /// Sequence accuracy (pooled over anchors).
    pub accuracy: f64,
    /// Sequence robustness (pooled over anchors).
    pub robustness: f64,
    /// Σ N^F (the accuracy's weight across sequences).
    pub accuracy_weight: f64,
    /// Sequence length (the robustness's weight).
    pub robustness_weight: f64,
    /// Per-length sum of run contributions to the EAO curve (index = length j).
    pub eao_sum: Vec<f64>,
    /// Per-length number of contributing runs.
    pub eao_active: Vec<f64>,
}

/// Evaluates the stored runs of one sequence. `runs[k]` is the trajectory of `anchors[k]` in
/// run order (its first entry, at the anchor, is ignored: it is the initialisation).
pub fn evaluate_anchor_sequence(
    gt: &[Region],
    anchors: &[Anchor],
    runs: &[Vec<Region>],
    params: &AnchorParams,
) -> Result<AnchorSequence, VotError> {
    if anchors.len() != runs.len() {
        if anchors.is_empty() {
            return Err(VotError::Empty);
        }
        return Err(VotError::LengthMismatch {
            what: "anchor trajectories".into(),
            expected: anchors.len(),
            got: runs.len(),
        });
    }
    let mut scorer = AnchorScorer::new(gt, params);
    for (anchor, traj) in anchors.iter().zip(runs) {
        scorer.add(anchor, traj.iter())?;
    }
    scorer.finish()
}

/// [`evaluate_anchor_sequence`] a run at a time, each run's regions taken one by one and
/// dropped once scored: memory follows one region and the per-frame overlaps, not every
/// anchor's masks (a long sequence's anchor runs hold its length squared over 100 regions).
#[derive(Debug, Clone)]
pub struct AnchorScorer<'a> {
    gt: &'a [Region],
    params: AnchorParams,
    runs: Vec<AnchorRun>,
    progress_sum: usize,
    acc_sum: f64,
    total: usize,
    eao_sum: Vec<f64>,
    eao_active: Vec<f64>,
}

impl<'a> AnchorScorer<'a> {
    /// A scorer for the runs of the sequence whose ground truth is `gt`.
    pub fn new(gt: &'a [Region], params: &AnchorParams) -> Self {
        Self {
            gt,
            params: *params,
            runs: Vec::new(),
            progress_sum: 0,
            acc_sum: 0.0,
            total: 0,
            eao_sum: vec![0.0; params.eao_high],
            eao_active: vec![0.0; params.eao_high],
        }
    }

    /// The number of regions the run of `anchor` must hold (its frames, the anchor's
    /// included), or an error when the anchor lies outside the sequence.
    pub fn run_length(&self, anchor: &Anchor) -> Result<usize, VotError> {
        self.run_frames(anchor).map(|f| f.len())
    }

    /// The frames of the run of `anchor`, in run order, or an error when the anchor lies
    /// outside the sequence.
    fn run_frames(&self, anchor: &Anchor) -> Result<Vec<usize>, VotError> {
        let n = self.gt.len();
        if anchor.frame >= n {
            return Err(VotError::AnchorOutOfRange {
                frame: anchor.frame,
                len: n,
            });
        }
        Ok(anchor_frames(anchor, n))
    }

    /// Scores the run of `anchor`, its regions in run order (the first, at the anchor, is the
    /// initialisation and ignored). It must hold exactly [`AnchorScorer::run_length`] regions.
    pub fn add<R: std::borrow::Borrow<Region>>(
        &mut self,
        anchor: &Anchor,
        traj: impl IntoIterator<Item = R>,
    ) -> Result<(), VotError> {
        let (gt, params) = (self.gt, &self.params);
        let frames = self.run_frames(anchor)?;
        let len = frames.len();
        let mut ov = Vec::with_capacity(len);
        let mut got = 0usize;
        for r in traj {
            if let Some(&f) = frames.get(got) {
                ov.push(overlap(r.borrow(), &gt[f], params.bounds, params.method));
            }
            got += 1;
        }
        if got != len {
            return Err(VotError::LengthMismatch {
                what: format!("trajectory of the anchor at frame {}", anchor.frame),
                expected: len,
                got,
            });
        }
        ov[0] = match params.init_frame {
            InitFrame::GroundTruth => 1.0,
            InitFrame::Special => overlap(
                &Region::Special(SPECIAL_INIT),
                &gt[frames[0]],
                params.bounds,
                params.method,
            ),
        };
        let mut grace = params.grace;
        let mut progress = ov.len();
        for (j, &o) in ov.iter().enumerate() {
            if o <= params.threshold && !gt[frames[j]].is_empty() {
                grace = grace.saturating_sub(1);
                if grace == 0 {
                    progress = (j + 1).saturating_sub(params.grace);
                    break;
                }
            } else {
                grace = params.grace;
            }
        }
        let failed = progress < ov.len();
        let run_acc: f64 = ov[..progress].iter().sum();
        self.progress_sum += progress;
        self.acc_sum += run_acc;
        self.total += ov.len();
        // EAO contribution (toolkit's compute_eao_partial) with post-failure overlaps zeroed.
        let mut zeroed = ov.clone();
        zeroed[progress..].fill(0.0);
        let mut prefix = 0.0;
        let tail: f64 = zeroed.iter().skip(1).sum();
        for j in 1..params.eao_high {
            if j < zeroed.len() {
                prefix += zeroed[j];
                self.eao_sum[j] += prefix / j as f64;
                self.eao_active[j] += 1.0;
            } else if failed {
                self.eao_sum[j] += tail / (j - 1).max(1) as f64;
                self.eao_active[j] += 1.0;
            }
        }
        self.runs.push(AnchorRun {
            anchor: *anchor,
            length: ov.len(),
            progress,
            failed,
            accuracy: if progress > 0 {
                run_acc / progress as f64
            } else {
                0.0
            },
            overlaps: ov,
        });
        Ok(())
    }

    /// The sequence's scores over the runs added (an error when none was).
    pub fn finish(self) -> Result<AnchorSequence, VotError> {
        if self.runs.is_empty() {
            return Err(VotError::Empty);
        }
        Ok(AnchorSequence {
            runs: self.runs,
            accuracy: if self.progress_sum > 0 {
                self.acc_sum / self.progress_sum as f64
            } else {
                0.0
            },
            robustness: self.progress_sum as f64 / self.total as f64,
            accuracy_weight: self.progress_sum as f64,
            robustness_weight: self.gt.len() as f64,
            eao_sum: self.eao_sum,
            eao_active: self.eao_active,
        })
    }
}

/// Dataset-level anchor-protocol scores.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AnchorSummary {
    /// Accuracy A.
    pub accuracy: f64,
    /// Robustness R.
    pub robustness: f64,
    /// EAO as the toolkit computes it (undefined curve points count as 0).
    pub eao: f64,
    /// Mean of the EAO curve over the defined points of `[eao_low, eao_high)` (`None` when no
    /// run reaches `eao_low` frames).
    pub eao_defined: Option<f64>,
    /// EAO curve Φ̂_j for j = 0..eao_high (`None` where no run contributes).
    pub eao_curve: Vec<Option<f64>>,
    /// Number of sequences.
    pub sequences: usize,
}

/// Pools sequences as the toolkit's `multistart_average_ar` and `multistart_eao_*` analyses.
pub fn summarize_anchor(
    seqs: &[AnchorSequence],
    params: &AnchorParams,
) -> Result<AnchorSummary, VotError> {
    if seqs.is_empty() {
        return Err(VotError::Empty);
    }
    let (mut a, mut wa, mut r, mut wr) = (0.0, 0.0, 0.0, 0.0);
    let mut sum = vec![0.0; params.eao_high];
    let mut active = vec![0.0; params.eao_high];
    for s in seqs {
        a += s.accuracy * s.accuracy_weight;
        wa += s.accuracy_weight;
        r += s.robustness * s.robustness_weight;
        wr += s.robustness_weight;
        for j in 0..params.eao_high {
            // A sequence's curve point is its runs' mean; pooled by its active count.
            sum[j] += s.eao_sum.get(j).copied().unwrap_or(0.0);
            active[j] += s.eao_active.get(j).copied().unwrap_or(0.0);
        }
    }
    let curve: Vec<Option<f64>> = sum
        .iter()
        .zip(&active)
        .map(|(&s, &n)| (n > 0.0).then(|| s / n))
        .collect();
    let lo = params.eao_low.min(params.eao_high);
    let window = &curve[lo..];
    let eao = if window.is_empty() {
        0.0
    } else {
        window.iter().map(|v| v.unwrap_or(0.0)).sum::<f64>() / window.len() as f64
    };
    let defined: Vec<f64> = window.iter().flatten().copied().collect();
    Ok(AnchorSummary {
        accuracy: if wa > 0.0 { a / wa } else { 0.0 },
        robustness: if wr > 0.0 { r / wr } else { 0.0 },
        eao,
        eao_defined: (!defined.is_empty())
            .then(|| defined.iter().sum::<f64>() / defined.len() as f64),
        eao_curve: curve,
        sequences: seqs.len(),
    })
}

/// Runs a tracker under the anchor protocol. For each anchor, `tracker(start, init, direction)`
/// is given the 0-based start frame, the ground truth there and the direction, and must return
/// one region for each following frame of the run (`anchor_frames(..).len() − 1` regions, in
/// run order). Returns each anchor's trajectory in run order, starting with the special code 1.
pub fn run_anchor_protocol<F>(
    frames_count: usize,
    gt: &[Region],
    anchors: &[Anchor],
    mut tracker: F,
) -> Result<Vec<Vec<Region>>, VotError>
where
    F: FnMut(usize, &Region, Direction) -> Vec<Region>,
{
    if gt.len() != frames_count {
        return Err(VotError::LengthMismatch {
            what: "ground truth".into(),
            expected: frames_count,
            got: gt.len(),
        });
    }
    let mut out = Vec::with_capacity(anchors.len());
    for a in anchors {
        if a.frame >= frames_count {
            return Err(VotError::AnchorOutOfRange {
                frame: a.frame,
                len: frames_count,
            });
        }
        let frames = anchor_frames(a, frames_count);
        let regions = tracker(a.frame, &gt[a.frame], a.direction);
        if regions.len() + 1 != frames.len() {
            return Err(VotError::LengthMismatch {
                what: format!("tracker output for the anchor at frame {}", a.frame),
                expected: frames.len() - 1,
                got: regions.len(),
            });
        }
        let mut traj = Vec::with_capacity(frames.len());
        traj.push(Region::Special(SPECIAL_INIT));
        traj.extend(regions);
        out.push(traj);
    }
    Ok(out)
}
