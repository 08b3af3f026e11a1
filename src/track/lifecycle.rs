//! One track: its identity, lifecycle counters, motion filter and last appearance.

use super::online::Features;
use crate::frame::{BBox, Detection, Point, TrackState, TrackedShape};
use crate::motion::{BoxMotionModel, MotionModel};

/// The boxed motion filter a track owns (any [`MotionModel`] on boxes).
pub(crate) type BoxMotion = Box<dyn BoxMotionModel>;

/// One track. Pair-cost terms read it through the accessors; the tracker alone mutates it.
pub struct Track {
    pub(crate) id: Option<u64>,
    pub(crate) state: TrackState,
    pub(crate) motion: BoxMotion,
    /// The filter right after the last match, kept for the re-update after a gap.
    pub(crate) snapshot: Option<BoxMotion>,
    /// Kalman prediction for the current frame (set by the predict phase).
    pub(crate) predicted: BBox,
    /// Frames matched, in total.
    pub(crate) hits: u32,
    /// Consecutive frames without a match (0 when matched this or the previous frame).
    pub(crate) misses: u32,
    /// Frame of the last match (tracker frame numbers, 1-based).
    pub(crate) last_frame: u32,
    pub(crate) last: Detection,
    pub(crate) features: Option<Features>,
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

    /// The displacement from the last matched box's centre to the predicted centre.
    pub fn predicted_shift(&self) -> Point {
        self.predicted.center() - self.last.bbox.center()
    }
}
