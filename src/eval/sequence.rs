//! The similarity-agnostic input of every MOT metric: per frame, the ground-truth ids, the
//! tracker ids and their similarity matrix (box IoU, mask IoU or anything in `[0, 1]`).
//!
//! Ids are relabelled to `0..n` in ascending order of the original ids, as TrackEval does after
//! preprocessing; the order matters because the assignment solver breaks ties by position.

use super::error::{EvalError, Side};

#[derive(Debug, Clone, Copy)]
struct Span {
    /// 0-based timestep.
    t: usize,
    gt: usize,
    num_gt: usize,
    tracker: usize,
    num_tracker: usize,
    sim: usize,
}

/// One sequence ready for the metrics: ids are dense (`0..num_gt_ids`, `0..num_tracker_ids`).
///
/// Only frames with at least one object are stored, so a huge `seqLength` costs nothing; no
/// metric does anything in a frame without objects.
#[derive(Debug, Clone)]
pub struct SequenceData {
    name: String,
    num_frames: usize,
    num_gt_ids: usize,
    num_tracker_ids: usize,
    gt_ids: Vec<u32>,
    tracker_ids: Vec<u32>,
    sim: Vec<f64>,
    frames: Vec<Span>,
}

/// A view of one frame of a [`SequenceData`].
#[derive(Debug, Clone, Copy)]
pub struct FrameView<'a> {
    /// Dense ground-truth ids of the frame's objects.
    pub gt_ids: &'a [u32],
    /// Dense tracker ids of the frame's objects.
    pub tracker_ids: &'a [u32],
    /// Similarities, row-major: `similarity[i * tracker_ids.len() + j]` for gt `i`, tracker `j`.
    pub similarity: &'a [f64],
}

impl FrameView<'_> {
    /// Similarity of gt object `i` and tracker object `j` of this frame.
    #[inline]
    pub fn sim(&self, i: usize, j: usize) -> f64 {
        self.similarity[i * self.tracker_ids.len() + j]
    }
}

impl SequenceData {
    /// Sequence name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Number of frames (timesteps), including empty ones.
    pub fn num_frames(&self) -> usize {
        self.num_frames
    }

    /// Number of distinct ground-truth ids.
    pub fn num_gt_ids(&self) -> usize {
        self.num_gt_ids
    }

    /// Number of distinct tracker ids.
    pub fn num_tracker_ids(&self) -> usize {
        self.num_tracker_ids
    }

    /// Number of ground-truth objects over all frames.
    pub fn num_gt_dets(&self) -> usize {
        self.gt_ids.len()
    }

    /// Number of tracker objects over all frames.
    pub fn num_tracker_dets(&self) -> usize {
        self.tracker_ids.len()
    }

    /// Frame `t` (0-based); `None` past the end, an empty view for a frame without objects.
    pub fn frame(&self, t: usize) -> Option<FrameView<'_>> {
        if t >= self.num_frames {
            return None;
        }
        Some(match self.frames.binary_search_by_key(&t, |s| s.t) {
            Ok(k) => self.view(&self.frames[k]),
            Err(_) => FrameView {
                gt_ids: &[],
                tracker_ids: &[],
                similarity: &[],
            },
        })
    }

    /// The frames that have objects, in time order (frames without objects are skipped).
    pub fn frames(&self) -> impl Iterator<Item = FrameView<'_>> + '_ {
        self.frames.iter().map(|s| self.view(s))
    }

    fn view(&self, s: &Span) -> FrameView<'_> {
        FrameView {
            gt_ids: &self.gt_ids[s.gt..s.gt + s.num_gt],
            tracker_ids: &self.tracker_ids[s.tracker..s.tracker + s.num_tracker],
            similarity: &self.sim[s.sim..s.sim + s.num_gt * s.num_tracker],
        }
    }
}

/// Builds a [`SequenceData`] frame by frame from arbitrary (sparse, signed) ids.
#[derive(Debug, Clone)]
pub struct SequenceBuilder {
    name: String,
    num_frames: usize,
    gt_ids: Vec<i64>,
    tracker_ids: Vec<i64>,
    sim: Vec<f64>,
    frames: Vec<Span>,
    scratch: Vec<i64>,
}

impl SequenceBuilder {
    /// An empty sequence called `name`.
    pub fn new(name: impl Into<String>) -> Self {
        SequenceBuilder {
            name: name.into(),
            num_frames: 0,
            gt_ids: Vec::new(),
            tracker_ids: Vec::new(),
            sim: Vec::new(),
            frames: Vec::new(),
            scratch: Vec::new(),
        }
    }

    /// Appends the next frame. `similarity` is row-major, `gt_ids.len() × tracker_ids.len()`,
    /// each value in `[0, 1]`; ids must be unique within the frame.
    pub fn push_frame(
        &mut self,
        gt_ids: &[i64],
        tracker_ids: &[i64],
        similarity: &[f64],
    ) -> Result<(), EvalError> {
        let frame = self.num_frames + 1;
        if similarity.len() != gt_ids.len() * tracker_ids.len() {
            return Err(EvalError::SimilarityShape {
                seq: self.name.clone(),
                frame,
                len: similarity.len(),
                gt: gt_ids.len(),
                tracker: tracker_ids.len(),
            });
        }
        let eps = f64::EPSILON;
        if let Some(&value) = similarity
            .iter()
            .find(|v| !(**v >= -eps && **v <= 1.0 + eps))
        {
            return Err(EvalError::SimilarityRange {
                seq: self.name.clone(),
                frame,
                value,
            });
        }
        for (side, ids) in [(Side::Tracker, tracker_ids), (Side::Gt, gt_ids)] {
            if let Some(id) = first_duplicate(ids, &mut self.scratch) {
                return Err(EvalError::FrameDuplicateId {
                    seq: self.name.clone(),
                    frame,
                    side,
                    id,
                });
            }
        }
        self.num_frames += 1;
        if gt_ids.is_empty() && tracker_ids.is_empty() {
            return Ok(());
        }
        self.frames.push(Span {
            t: frame - 1,
            gt: self.gt_ids.len(),
            num_gt: gt_ids.len(),
            tracker: self.tracker_ids.len(),
            num_tracker: tracker_ids.len(),
            sim: self.sim.len(),
        });
        self.gt_ids.extend_from_slice(gt_ids);
        self.tracker_ids.extend_from_slice(tracker_ids);
        self.sim.extend_from_slice(similarity);
        Ok(())
    }

    /// Appends `count` frames without objects.
    pub fn push_empty_frames(&mut self, count: usize) {
        self.num_frames += count;
    }

    /// Relabels ids densely (ascending original order) and returns the sequence.
    pub fn finish(self) -> SequenceData {
        let (gt_ids, num_gt_ids) = relabel(&self.gt_ids);
        let (tracker_ids, num_tracker_ids) = relabel(&self.tracker_ids);
        SequenceData {
            name: self.name,
            num_frames: self.num_frames,
            num_gt_ids,
            num_tracker_ids,
            gt_ids,
            tracker_ids,
            sim: self.sim,
            frames: self.frames,
        }
    }
}

/// The first id that occurs twice, if any (smallest such id, as TrackEval lists them sorted).
pub(crate) fn first_duplicate(ids: &[i64], scratch: &mut Vec<i64>) -> Option<i64> {
    if ids.len() < 2 {
        return None;
    }
    scratch.clear();
    scratch.extend_from_slice(ids);
    scratch.sort_unstable();
    scratch.windows(2).find(|w| w[0] == w[1]).map(|w| w[0])
}

fn relabel(ids: &[i64]) -> (Vec<u32>, usize) {
    let mut uniq = ids.to_vec();
    uniq.sort_unstable();
    uniq.dedup();
    let dense = ids
        .iter()
        .map(|id| uniq.binary_search(id).unwrap_or(0) as u32)
        .collect();
    (dense, uniq.len())
}

/// Optimal assignment with scipy's `linear_sum_assignment` semantics (via the `lsap` port),
/// reusing its buffers between calls.
#[derive(Debug, Default)]
pub(crate) struct Assigner {
    cost: Vec<f64>,
    pub(crate) rows: Vec<usize>,
    pub(crate) cols: Vec<usize>,
}

impl Assigner {
    /// Clears the cost matrix and sizes it `nr × nc` (filled with zeros).
    pub(crate) fn reset(&mut self, nr: usize, nc: usize) -> &mut [f64] {
        self.cost.clear();
        self.cost.resize(nr * nc, 0.0);
        &mut self.cost
    }

    /// The cost matrix of the last [`Assigner::reset`].
    pub(crate) fn cost(&self) -> &[f64] {
        &self.cost
    }

    /// Minimises the cost set with [`Assigner::reset`]; results in `rows`/`cols`, rows ascending.
    /// Returns false when the solver refuses the matrix (non-finite entries).
    pub(crate) fn solve(&mut self, nr: usize, nc: usize) -> bool {
        self.rows.clear();
        self.cols.clear();
        if nr == 0 || nc == 0 {
            return true;
        }
        match lsap::solve(nr, nc, &self.cost, false) {
            Ok((r, c)) => {
                self.rows = r;
                self.cols = c;
                true
            }
            Err(_) => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relabels_in_ascending_order_and_keeps_frames() {
        let mut b = SequenceBuilder::new("s");
        b.push_frame(&[7, 3], &[100], &[0.5, 0.25]).unwrap();
        b.push_frame(&[], &[], &[]).unwrap();
        b.push_frame(&[3], &[-4, 100], &[0.0, 1.0]).unwrap();
        let s = b.finish();
        assert_eq!(s.num_frames(), 3);
        assert_eq!((s.num_gt_ids(), s.num_tracker_ids()), (2, 2));
        let f0 = s.frame(0).unwrap();
        assert_eq!(f0.gt_ids, &[1, 0]);
        assert_eq!(f0.tracker_ids, &[1]);
        assert_eq!(f0.sim(1, 0), 0.25);
        let f2 = s.frame(2).unwrap();
        assert_eq!(f2.tracker_ids, &[0, 1]);
        assert_eq!(s.num_gt_dets(), 3);
        assert!(s.frame(1).unwrap().gt_ids.is_empty());
        assert!(s.frame(3).is_none());
        assert_eq!(s.frames().count(), 2);
    }

    #[test]
    fn rejects_bad_frames() {
        let mut b = SequenceBuilder::new("s");
        assert!(matches!(
            b.push_frame(&[1], &[1], &[]),
            Err(EvalError::SimilarityShape { .. })
        ));
        assert!(matches!(
            b.push_frame(&[1], &[1], &[f64::NAN]),
            Err(EvalError::SimilarityRange { .. })
        ));
        assert!(matches!(
            b.push_frame(&[1, 1], &[], &[]),
            Err(EvalError::FrameDuplicateId {
                side: Side::Gt,
                id: 1,
                ..
            })
        ));
    }

    #[test]
    fn assigner_breaks_ties_like_scipy() {
        // scipy.optimize.linear_sum_assignment(np.zeros((2, 3))) -> ([0, 1], [0, 1])
        let mut a = Assigner::default();
        a.reset(2, 3);
        assert!(a.solve(2, 3));
        assert_eq!((a.rows.clone(), a.cols.clone()), (vec![0, 1], vec![0, 1]));
        // Tall: scipy gives rows [0, 2], cols [1, 0] for [[0,-1],[0,0],[-1,0]].
        let c = a.reset(3, 2);
        c.copy_from_slice(&[0.0, -1.0, 0.0, 0.0, -1.0, 0.0]);
        assert!(a.solve(3, 2));
        assert_eq!((a.rows.clone(), a.cols.clone()), (vec![0, 2], vec![1, 0]));
    }
}
