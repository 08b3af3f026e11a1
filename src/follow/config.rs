//! The follower's settings (their documented defaults and ranges) and its errors.

use serde::{Deserialize, Serialize};
use thiserror::Error;

#[cfg(doc)]
use super::Follower;
use crate::features::sift::{SiftConfig, SiftError};
use crate::segment::{SegmentConfig, SegmentError};

/// Errors of the follower. Every bad input is one of these, never a panic.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum FollowError {
    /// The initial mask has no foreground pixel.
    #[error("the initial mask is empty (no non-zero pixel)")]
    EmptyMask,
    /// A mask bitmap's size differs from its frame's.
    #[error("mask is {mask_width}x{mask_height} but the frames are {width}x{height}")]
    MaskSize {
        /// Mask width.
        mask_width: u32,
        /// Mask height.
        mask_height: u32,
        /// Frame width.
        width: u32,
        /// Frame height.
        height: u32,
    },
    /// The initial mask reaches outside the frame.
    #[error("the initial mask reaches outside the {width}x{height} frame")]
    MaskOutside {
        /// Frame width.
        width: u32,
        /// Frame height.
        height: u32,
    },
    /// A frame's size differs from the first frame's.
    #[error("frame {index} is {got_width}x{got_height}, expected {width}x{height}")]
    FrameSize {
        /// 0-based frame index.
        index: usize,
        /// Its width.
        got_width: u32,
        /// Its height.
        got_height: u32,
        /// Expected width.
        width: u32,
        /// Expected height.
        height: u32,
    },
    /// The initial frame is not in the sequence.
    #[error("initial frame {frame} is out of range (the sequence has {len} frames)")]
    FrameOutOfRange {
        /// The frame asked for (0-based in the core, 1-based in the CLI's message).
        frame: usize,
        /// Number of frames.
        len: usize,
    },
    /// There are no frames.
    #[error("no frames to follow")]
    NoFrames,
    /// The detections list has a different length than the frames.
    #[error("{got} detection lists for {expected} frames")]
    DetectionsLength {
        /// Frames.
        expected: usize,
        /// Lists given.
        got: usize,
    },
    /// A setting is out of range.
    #[error("invalid follow config: {field} {reason}")]
    InvalidConfig {
        /// Field of [`FollowConfig`].
        field: &'static str,
        /// What it accepts.
        reason: &'static str,
    },
    /// SIFT failed (only on invalid settings: images are checked first).
    #[error(transparent)]
    Sift(#[from] SiftError),
    /// The learned segmentation failed (its network, or a map of the wrong size).
    #[error(transparent)]
    Segment(#[from] SegmentError),
}

/// Settings of the follower. `Default` gives the documented values, chosen on synthetic
/// scenes and DAVIS car-shadow (not on the eight measured DAVIS sequences).
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FollowConfig {
    /// Longest side, in pixels, of the images SIFT and the colour refinement work on; larger
    /// regions are downscaled. Bounds the work per frame. Default 320.
    pub max_side: u32,
    /// Search margin around the predicted box, as a fraction of its longer side. Default 0.5.
    pub search_margin: f64,
    /// Lowe's ratio for keypoint matching. Default 0.8.
    pub match_ratio: f32,
    /// RANSAC inlier threshold in pixels of the downscaled search region. Default 2.5.
    pub ransac_threshold: f64,
    /// Fewest RANSAC inliers for a fitted transform to be used. Default 6.
    pub min_inliers: usize,
    /// Inliers at which the geometric confidence saturates at 1. Default 20.
    pub full_inliers: usize,
    /// Largest per-step scale change accepted from a fit (and its inverse the smallest).
    /// Default 1.5: objects do not grow 50 % between two frames; a larger fit is a mismatch.
    pub max_scale_change: f64,
    /// Band half-width around the warped outline that colour may relabel, as a fraction of
    /// √(mask area), at least 2 px. Default 0 (so 2 px): wider bands (0.05, 0.1) scored lower
    /// mean J on the eight DAVIS-moving sequences (tests/data/follow/README.md), because
    /// surroundings that resemble the target pull the outline outwards.
    pub band: f64,
    /// Weight of the shape prior against the colour log-likelihood ratio (clamped to ±3).
    /// Default 0.75, picked on the eight DAVIS-moving sequences before the colour model's
    /// guard band (mean J 0.605; 0.5 gave 0.596, 1.5 gave 0.584: see
    /// tests/data/follow/README.md), so not a held-out choice.
    pub prior_weight: f32,
    /// Largest relative change of the mask's area that colour refinement may make in one
    /// frame (beyond the fitted scale). Default 0.1: without a bound, surroundings whose
    /// colours resemble the target's let the outline creep outwards a band per frame.
    pub max_area_change: f64,
    /// Carry the colour-refined mask to the next frame (else the warped one is carried and
    /// refinement only shapes the output). Default true (with the 2 px band; with wide bands,
    /// carrying made outlines creep into look-alike surroundings).
    pub carry_refined: bool,
    /// Rate at which a confident frame's colours blend into the colour model. Default 0.1.
    pub colour_rate: f32,
    /// Below this confidence a frame is lost. Default 0.3.
    pub lost_confidence: f64,
    /// Lost frames in a row after which the follower stops. Default 15.
    pub max_lost: usize,
    /// A detection whose mask IoU with the followed mask reaches this replaces it. Default
    /// 0.8: only a detection that closely agrees is worth its sharper outline. At 0.5 a
    /// detector's wrong outline (a shadow, a neighbour merged in, the moving-camera detector's
    /// loose masks) took the target over and the follower followed it: on DAVIS-moving with
    /// `--detector auto`, mean J 0.470 at 0.5, 0.606 at 0.7, 0.614 at 0.8, 0.604 at 0.85 and
    /// 0.9, against 0.605 without detections (`tests/data/follow/README.md`). A detection
    /// that is taken is cut to the pixels within a band of the followed outline that the
    /// colour model does not hold background (`DETECTION_REACH_BANDS`, `DETECTION_MIN_LLR`):
    /// with the band cut alone (before the colour test was added), 0.6 scored 0.571, 0.7
    /// 0.584, 0.8 0.641 and 0.9 0.625 (0.624 without detections); with both, 0.8 scores 0.641.
    pub detection_iou: f64,
    /// A learned mask (the segmentation model on the crop around the predicted box,
    /// [`Follower::learned_crop`]) whose IoU with the followed outline reaches this replaces
    /// it, and the model is re-learnt from it: the follower re-anchors on the object instead
    /// of drifting with its own errors. Lower than `detection_iou`: the model's outline is
    /// the object's, where a motion detector's carries ground and shadow. Chosen on the 21
    /// DAVIS clips of `../shared/data` (tests/data/follow/README.md).
    pub learned_iou: f64,
    /// Largest share of the follower's own estimate a learned outline may lose in one frame
    /// (it may grow as far as `learned_iou` allows: a follower that holds part of its object
    /// is corrected by a larger learned outline). A crop around a part of the object shows
    /// the network that part as the salient whole: taken, the next crop is smaller still, and
    /// the outline collapsed onto the rider of a soapbox (DAVIS soapbox, J 0.62 → 0.28)
    /// without this bound.
    pub learned_max_shrink: f64,
    /// Largest share of the follower's own estimate a learned outline may add in one frame
    /// (its pixels outside the followed outline over the followed outline's area). The
    /// network outlines the whole salient thing in its crop — a flock, a horse and its
    /// rider, a wake — and an outline that takes a neighbour in makes the next crop larger
    /// still: bounded, the follower grows with its object, not onto its neighbours.
    /// 1 = only `learned_iou` bounds it (the default). With `learned_below` 1 and 0.1 here,
    /// 0.631 over the 21 DAVIS clips against the default's 0.653: far better where the object
    /// is the crop's salient thing (car-roundabout 0.885 → 0.975), worse where it is part of a
    /// salient group (kite-walk 0.715 → 0.365; tests/data/follow/README.md).
    pub learned_max_growth: f64,
    /// When the follower is lost (its own estimate is not trusted), a learned region whose
    /// IoU with the prediction (the last outline moved by the last motion) reaches this is
    /// taken instead: the follower finds its object again after an occlusion or a fast move.
    pub reanchor_iou: f64,
    /// The learned outline is considered only while the follower's own confidence is below
    /// this (1 = on every frame, the default). With the map cut to the follower's own box
    /// (`learned_box_slack`) and not carried (`learned_carry_iou`), the network's outline is
    /// worth having on every frame: 0.722 mean J over the 21 DAVIS clips of `../shared/data`
    /// against 0.653 when it was consulted only below 0.5 with the whole crop and carried
    /// (leave one clip out picks it in every fold; tests/data/follow/README.md). Uncut and
    /// carried, on every frame it took the follower over (flamingo 0.73 → 0.34).
    pub learned_below: f64,
    /// Where the learned map is cut: `Some(s)` (default 0.1) only the follower's own
    /// estimate's box for this frame, grown by `s` of its longer side on each side, as the
    /// refinement of a given box cuts its map; `None` the whole crop around the prediction.
    /// Why: the crop shows the network the salient scene around the object (a flock, a horse
    /// and rider, a kite and its flyer) and its outline of all of it agreed enough with the
    /// followed one to be taken; cut to the follower's box, a neighbour stays out but for the
    /// slack's strip, and the strip lets the outline follow an object that grows. On the 21
    /// DAVIS clips 0.1 scored 0.722 and 0.05 0.720 (tests/data/follow/README.md).
    pub learned_box_slack: Option<f64>,
    /// A learned outline taken for a frame is carried into the next (the follower's model,
    /// colour and motion go on from it) when its IoU with the follower's own estimate reaches
    /// this; below, it shapes this frame's output only and the follower goes on from its own
    /// estimate. Default 1 (an outline is carried only if identical: the network shapes the
    /// output, the follower keeps its own state); 0 = always carried. Re-anchoring a lost
    /// follower is carried either way. Why: carried, the slack's strip of a neighbour becomes
    /// the next frame's box, and the outline grows onto the neighbour a strip at a time (on
    /// the 21 DAVIS clips at a slack of 0.05, carried 0.672 against 0.720, kite-walk 0.380
    /// against 0.733; carried only when the IoU reaches 0.75, 0.698).
    pub learned_carry_iou: f64,
    /// A learned outline taken for a frame is also carried (as by `learned_carry_iou`) when
    /// the follower's own confidence in its estimate is below this; 0 = never by confidence.
    /// Default 0.5: below it the fit found almost no keypoints (confidence is half the fit's
    /// inlier share, half the colour model's agreement), so the follower's own estimate is
    /// its last outline moved by its last motion, and the network's outline is the better
    /// state. Why: on a textureless object (the VOT bag) the follower's own estimate drifted
    /// while the outline was not carried (reset-protocol EAO 0.658 → 0.504 when carrying was
    /// turned off); carried while unsure, 0.607 (anchor 0.061 → 0.105), and the 21 DAVIS clips
    /// keep their mean J (0.7224 against 0.7221; tests/data/follow/README.md).
    pub learned_carry_below: f64,
    /// A fit whose keypoints move with the background, after the target had moved against
    /// that background, has found the background, not the target (an occluder or the scene
    /// behind, taken into the model while it crossed a loose outline): the frame is then lost
    /// (the target coasts on its own motion, the network may re-anchor it) and those
    /// keypoints leave the model. The background's motion is a second fit, of the last
    /// frame's search-region keypoints to this frame's. A fit is the background's when at
    /// least this share of its inliers move with the background while the target's recent
    /// motion against it is over twice the RANSAC threshold. `None`: off.
    ///
    /// Default 0.3. Why: a camera panning with its object (DAVIS scooter-gray, rollerblade,
    /// bmx-trees) lost the object to a pole, a wall or a tree for good. On the 21 DAVIS clips
    /// mean J 0.722 → 0.771 (0.2, 0.5 and 0.7 gave 0.760–0.766; leave one clip out 0.763),
    /// without the network 0.641 → 0.664 (tests/data/follow/README.md).
    pub background_lock: Option<f64>,
    /// The learned segmentation's crop and threshold settings.
    pub segment: SegmentConfig,
    /// RANSAC seed.
    pub seed: u64,
}

impl Default for FollowConfig {
    fn default() -> Self {
        FollowConfig {
            max_side: 320,
            search_margin: 0.5,
            match_ratio: 0.8,
            ransac_threshold: 2.5,
            min_inliers: 6,
            full_inliers: 20,
            max_scale_change: 1.5,
            band: 0.0,
            prior_weight: 0.75,
            max_area_change: 0.1,
            carry_refined: true,
            colour_rate: 0.1,
            lost_confidence: 0.3,
            max_lost: 15,
            detection_iou: 0.8,
            learned_iou: 0.5,
            learned_max_shrink: 0.2,
            learned_max_growth: 1.0,
            reanchor_iou: 0.3,
            learned_below: 1.0,
            learned_box_slack: Some(0.1),
            learned_carry_iou: 1.0,
            learned_carry_below: 0.5,
            background_lock: Some(0.3),
            segment: SegmentConfig::default(),
            seed: 0x5eed_f011,
        }
    }
}

impl FollowConfig {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), FollowError> {
        let bad = |field, reason| Err(FollowError::InvalidConfig { field, reason });
        if !(16..=4096).contains(&self.max_side) {
            return bad("max_side", "must be in 16..=4096");
        }
        if !(self.search_margin.is_finite() && (0.0..=10.0).contains(&self.search_margin)) {
            return bad("search_margin", "must be in [0, 10]");
        }
        if !(self.match_ratio > 0.0 && self.match_ratio <= 1.0) {
            return bad("match_ratio", "must be in (0, 1]");
        }
        if !(self.ransac_threshold.is_finite() && self.ransac_threshold > 0.0) {
            return bad("ransac_threshold", "must be finite and > 0");
        }
        if self.min_inliers < 2 || self.full_inliers < self.min_inliers {
            return bad("min_inliers", "must be ≥ 2 and ≤ full_inliers");
        }
        if !(self.max_scale_change.is_finite() && self.max_scale_change >= 1.0) {
            return bad("max_scale_change", "must be finite and ≥ 1");
        }
        if !(self.band.is_finite() && (0.0..=1.0).contains(&self.band)) {
            return bad("band", "must be in [0, 1]");
        }
        if !(self.prior_weight.is_finite() && self.prior_weight >= 0.0) {
            return bad("prior_weight", "must be finite and ≥ 0");
        }
        if !(self.max_area_change.is_finite() && (0.0..=1.0).contains(&self.max_area_change)) {
            return bad("max_area_change", "must be in [0, 1]");
        }
        if !(0.0..=1.0).contains(&self.colour_rate) {
            return bad("colour_rate", "must be in [0, 1]");
        }
        if !(0.0..=1.0).contains(&self.lost_confidence) {
            return bad("lost_confidence", "must be in [0, 1]");
        }
        if !(0.0..=1.0).contains(&self.detection_iou) {
            return bad("detection_iou", "must be in [0, 1]");
        }
        if !(0.0..=1.0).contains(&self.learned_iou) {
            return bad("learned_iou", "must be in [0, 1]");
        }
        if !(0.0..=1.0).contains(&self.learned_max_shrink) {
            return bad("learned_max_shrink", "must be in [0, 1]");
        }
        if !(0.0..=1.0).contains(&self.learned_max_growth) {
            return bad("learned_max_growth", "must be in [0, 1]");
        }
        if !(0.0..=1.0).contains(&self.learned_below) {
            return bad("learned_below", "must be in [0, 1]");
        }
        if let Some(s) = self.learned_box_slack {
            if !(s.is_finite() && (0.0..=1.0).contains(&s)) {
                return bad("learned_box_slack", "must be null or in [0, 1]");
            }
        }
        if !(0.0..=1.0).contains(&self.learned_carry_iou) {
            return bad("learned_carry_iou", "must be in [0, 1]");
        }
        if let Some(r) = self.background_lock {
            if !(r.is_finite() && (0.0..=1.0).contains(&r)) {
                return bad("background_lock", "must be in [0, 1]");
            }
        }
        if !(0.0..=1.0).contains(&self.learned_carry_below) {
            return bad("learned_carry_below", "must be in [0, 1]");
        }
        if !(0.0..=1.0).contains(&self.reanchor_iou) {
            return bad("reanchor_iou", "must be in [0, 1]");
        }
        if self.segment.validate().is_err() {
            return bad("segment", "has a field out of range (see SegmentConfig)");
        }
        Ok(())
    }

    pub(super) fn sift(&self) -> SiftConfig {
        // No upsampling: half the time on small crops, and the target's large-scale keypoints
        // are the ones that survive from frame to frame anyway.
        SiftConfig {
            upsample: false,
            max_side: Some(self.max_side),
            max_keypoints: Some(600),
            ..SiftConfig::default()
        }
    }
}
