//! One track: its identity, lifecycle counters, motion filter and last appearance.

use std::sync::Arc;

use super::features::Appearance;
use super::online::Features;
use crate::frame::{BBox, Detection, Point, TrackState, TrackedShape};
use crate::motion::{BoxMotionModel, MotionModel};

/// The boxed motion filter a track owns (any [`MotionModel`] on boxes).
pub(crate) type BoxMotion = Box<dyn BoxMotionModel>;

/// The areas and box sizes of a track's last [`Sizes::LEN`] matched detections, whose upper
/// quartiles are the reference size of the whole shape.
///
/// An upper quantile over a window rather than a running mean over "whole" views: partial views
/// (an occlusion starting or ending) are smaller and stay below it unless they fill three
/// quarters of the window, mask noise (erosion, dilation by a pixel or two) mostly cancels out,
/// and a transient
/// outlier (two touching shapes detected as one) leaves the window after a while. A running
/// mean fed only by views judged whole can lock up: one inflated value makes every later view
/// look partial, and the reference never updates again.
#[derive(Debug, Clone, Default)]
pub(crate) struct Sizes {
    ring: std::collections::VecDeque<[f64; 3]>,
}

impl Sizes {
    /// Views kept.
    pub(crate) const LEN: usize = 20;

    /// Adds a view's area and box size.
    pub(crate) fn push(&mut self, area: f64, w: f64, h: f64) {
        if self.ring.len() == Self::LEN {
            self.ring.pop_front();
        }
        self.ring.push_back([area, w, h]);
    }

    /// The upper quartile of each of area, width and height over the window.
    pub(crate) fn reference(&self) -> (f64, (f64, f64)) {
        let q = |k: usize| -> f64 {
            let mut v: Vec<f64> = self.ring.iter().map(|r| r[k]).collect();
            if v.is_empty() {
                return 0.0;
            }
            v.sort_by(f64::total_cmp);
            v[(3 * (v.len() - 1)) / 4]
        };
        (q(0), (q(1), q(2)))
    }
}

/// One track. Pair-cost terms read it through the accessors; the tracker alone mutates it.
pub struct Track {
    pub(crate) id: Option<u64>,
    pub(crate) state: TrackState,
    pub(crate) motion: BoxMotion,
    /// The filter right after the last match, kept for the re-update after a gap.
    pub(crate) snapshot: Option<BoxMotion>,
    /// Kalman prediction for the current frame (set by the predict phase).
    pub(crate) predicted: BBox,
    /// The filter's box right after the last match: where the predicted shift starts from.
    /// With amodal completion it is the whole shape's box even when only part was seen.
    pub(crate) anchor: BBox,
    /// Reference area of the whole shape (pixels; box area in box mode): see [`Sizes`].
    pub(crate) ref_area: f64,
    /// Reference box size `(w, h)` of the whole shape: see [`Sizes`].
    pub(crate) ref_size: (f64, f64),
    /// Areas and box sizes of the last matched detections.
    pub(crate) sizes: Sizes,
    /// The occluded side on each axis during the current partial view (amodal completion).
    pub(crate) cuts: [Option<super::online::Cut>; 2],
    /// Area of the last matched detection over `ref_area` (before updating it): below the
    /// whole ratio the last view was partial (occluded or leaving the frame).
    pub(crate) last_ratio: f64,
    /// Whether the last matched detection showed the whole shape: its area near the reference
    /// and no side needing amodal completion.
    pub(crate) last_whole: bool,
    /// The latest appearance computed for the track.
    pub(crate) appearance: Option<Arc<Appearance>>,
    /// The latest appearance computed while the shape was seen whole.
    pub(crate) reference: Option<Arc<Appearance>>,
    /// Frames matched, in total.
    pub(crate) hits: u32,
    /// Consecutive frames without a match (0 when matched this or the previous frame).
    pub(crate) misses: u32,
    /// Frame of the last match (tracker frame numbers, 1-based).
    pub(crate) last_frame: u32,
    pub(crate) last: Detection,
    pub(crate) features: Option<Features>,
    /// Last frame a shape was reported under the track's id (matched or coasted).
    pub(crate) reported_until: u32,
    /// Shapes matched while tentative, reported if the track is confirmed.
    pub(crate) pending: Vec<TrackedShape>,
}

impl std::fmt::Debug for Track {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Track")
            .field("id", &self.id)
            .field("state", &self.state)
            .field("predicted", &self.predicted)
            .field("hits", &self.hits)
            .field("misses", &self.misses)
            .field("last_frame", &self.last_frame)
            .finish_non_exhaustive()
    }
}

impl Track {
    /// The track's id; `None` while tentative (ids are given at confirmation).
    pub fn id(&self) -> Option<u64> {
        self.id
    }

    /// Lifecycle state.
    pub fn state(&self) -> TrackState {
        self.state
    }

    /// Where the motion filter expects the track in the current frame.
    pub fn predicted_box(&self) -> BBox {
        self.predicted
    }

    /// The track's motion filter.
    pub fn motion(&self) -> &dyn MotionModel<Measurement = BBox> {
        self.motion.as_ref()
    }

    /// The detection last matched to the track (its last appearance).
    pub fn last_detection(&self) -> &Detection {
        &self.last
    }

    /// The features of the last matched detection, when an extractor computed them.
    pub fn features(&self) -> Option<&Features> {
        self.features.as_ref()
    }

    /// Number of frames the track was matched in.
    pub fn hits(&self) -> u32 {
        self.hits
    }

    /// Consecutive frames without a match, up to the previous frame.
    pub fn misses(&self) -> u32 {
        self.misses
    }

    /// Frame number (1-based, the tracker's count) of the last match.
    pub fn last_frame(&self) -> u32 {
        self.last_frame
    }

    /// The displacement from the filter's box at the last match to the predicted box: how far
    /// the last appearance (mask, shell) is expected to have moved by the current frame.
    pub fn predicted_shift(&self) -> Point {
        self.predicted.center() - self.anchor.center()
    }

    /// The filter's box right after the last match.
    pub fn anchor_box(&self) -> BBox {
        self.anchor
    }

    /// Reference area of the whole shape (running mean over detections seen whole).
    pub fn reference_area(&self) -> f64 {
        self.ref_area
    }

    /// Area of the last matched detection over the reference area at that time (1 = seen
    /// whole; small = partly hidden).
    pub fn last_visible_ratio(&self) -> f64 {
        self.last_ratio
    }

    /// Whether the last matched detection showed the whole shape (see
    /// [`Config::amodal`](super::Config::amodal)).
    pub fn last_seen_whole(&self) -> bool {
        self.last_whole
    }

    /// The latest appearance computed for the track (`None` until one was needed).
    pub fn appearance(&self) -> Option<&Appearance> {
        self.appearance.as_deref()
    }

    /// The latest appearance computed while the shape was seen whole: what a lost track is
    /// re-identified by.
    pub fn reference_appearance(&self) -> Option<&Appearance> {
        self.reference.as_deref()
    }
}
