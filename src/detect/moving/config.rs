//! [`MovingConfig`], the settings of the moving-camera detector, and [`MotionCue`], the cue
//! that finds what moves against the camera.

use crate::detect::flow::FlowConfig;
use crate::detect::refine::RefineConfig;
use crate::detect::DetectError;
#[cfg(doc)]
use crate::detect::{DenseFlow, Hint, MovingCameraDetector};
use serde::{Deserialize, Serialize};

/// Settings of the [`MovingCameraDetector`].
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MovingConfig {
    /// Longer side of the working copy in pixels (854×480 works at 214×120). Default `240`.
    pub work_side: u32,
    /// Background cue: grey-level difference (working copy) above which a pixel is
    /// foreground. Default `18`.
    pub threshold: f32,
    /// Background cue: learning rate `α` of eq. 2 once a pixel has history. Default `0.1`.
    pub alpha: f32,
    /// Background cue: learning rate of foreground pixels (lets ghosts of the first frames
    /// fade). Default `0.02`.
    pub foreground_alpha: f32,
    /// Background cue: frames of history a pixel needs before it can be foreground. Default
    /// `3`.
    pub min_age: u32,
    /// Fewest RANSAC inliers for a camera motion to be trusted. Default `12`.
    pub min_inliers: usize,
    /// Smallest inlier share of the matches for a camera motion to be trusted. Default `0.2`:
    /// an object that fills half the frame holds half the matches (at 0.35 soapbox lost a
    /// third of its frames to re-initialisations); a cut or a blurred frame gives a few
    /// chance inliers in a hundred.
    pub min_inlier_ratio: f64,
    /// Largest share of the pixels (with history, for the background cue) that may be
    /// foreground. Default `0.5`.
    pub max_foreground: f64,
    /// Blobs smaller than this share of the working frame are dropped. Default `0.002`.
    pub min_blob: f64,
    /// Most blobs refined per frame, largest first (the per-frame cost bound). Default `4`.
    pub max_blobs: usize,
    /// A blob's box grows by this fraction of its size on each side before refinement.
    /// Default `0.1`.
    pub box_margin: f64,
    /// Radius of the closing that joins the pieces of one object (working pixels). Default `2`.
    pub close_radius: u32,
    /// Refinement settings; `None` reports the coarse blobs themselves (upscaled). Default:
    /// [`RefineConfig`]'s defaults. Each blob's own pixels are the refinement's [`Hint`], so
    /// its colour models start from the object rather than from the whole, loose box. (Before
    /// the hint, the texture feature was off here: from the blobs' boxes alone it cost mean J
    /// 0.478 → 0.471 on the 8 DAVIS moving-camera sequences; with the flow cue's blobs as
    /// hints it gains, see `tests/data/detect/README.md`.)
    pub refine: Option<RefineConfig>,
    /// Background cue: registration error allowed, in working pixels: a pixel is foreground only
    /// when no model pixel within this radius is within the threshold of it, or no frame
    /// pixel within it is within the threshold of the model's pixel (see step 4). Default `1`.
    pub tolerance: u32,
    /// Background cue, ghost removal: frames a foreground pixel must keep one steady colour (within the
    /// threshold) before that colour replaces its model (0 = never). A model that still holds
    /// an object that has moved on (the first frames' object, above all) otherwise shows the
    /// object's "ghost" for as long as foreground pixels take to learn (`1/foreground_alpha`
    /// frames) and joins it to the object's blob. Default `8` (a third of a second at 24 fps):
    /// mean J on the 8 DAVIS moving-camera sequences 0.407 → 0.461, car-shadow 0.289 → 0.568;
    /// 4 frames swallow slow objects' flat interiors (0.339), 16 leave ghosts longer (0.425).
    pub ghost_frames: u32,
    /// What tells a moving pixel from the camera's motion. Default [`MotionCue::Flow`].
    pub cue: MotionCue,
    /// The dense flow's settings ([`MotionCue::Flow`]).
    pub flow: FlowConfig,
    /// [`MotionCue::Flow`]: a pixel moves when its flow differs from the camera's by more
    /// than `max(min_residual, residual_factor × the frame's median difference)` working
    /// pixels. Default `0.5` (2 frame pixels at 854×480).
    pub min_residual: f32,
    /// See [`min_residual`](Self::min_residual): the median difference is the flow's noise
    /// and the parallax the affine camera motion leaves, which differ from video to video.
    /// Default `4`.
    pub residual_factor: f32,
}

/// The cue that finds what moves against the camera ([`MovingConfig::cue`]).
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MotionCue {
    /// Dense optical flow ([`DenseFlow`]) between consecutive frames against the camera's
    /// affine motion fitted to it: a pixel moves when its flow is not the camera's. Needs no
    /// history (it reports from the second frame), and the interior of a flat-coloured
    /// object moves with its edges (the flow's smoothness carries it). On the 8 DAVIS
    /// moving-camera sequences mean J 0.673 (the background cue: 0.494), with fewer masks off
    /// the object (`tests/data/detect/README.md`).
    #[default]
    Flow,
    /// The background model warped with the camera motion, and the thesis' eq. 1–2 against
    /// it (steps 3–5 of the module docs): a pixel moves when its grey level is not the
    /// model's.
    Background,
}

impl Default for MovingConfig {
    fn default() -> Self {
        Self {
            work_side: 240,
            threshold: 18.0,
            alpha: 0.1,
            foreground_alpha: 0.02,
            min_age: 3,
            min_inliers: 12,
            min_inlier_ratio: 0.2,
            max_foreground: 0.5,
            min_blob: 0.002,
            max_blobs: 4,
            box_margin: 0.1,
            close_radius: 2,
            refine: Some(RefineConfig::default()),
            tolerance: 1,
            ghost_frames: 8,
            cue: MotionCue::Flow,
            flow: FlowConfig::default(),
            min_residual: 0.5,
            residual_factor: 4.0,
        }
    }
}

impl MovingConfig {
    /// Checks every setting.
    pub fn validate(&self) -> Result<(), DetectError> {
        let bad = |field: &'static str, value: f64, reason: &'static str| {
            Err(DetectError::InvalidConfig {
                field,
                value,
                reason,
            })
        };
        if !(32..=2048).contains(&self.work_side) {
            return bad("work_side", self.work_side as f64, "must be in 32..=2048");
        }
        if !(self.threshold.is_finite() && (0.0..255.0).contains(&self.threshold)) {
            return bad("threshold", self.threshold as f64, "must be in [0, 255)");
        }
        if self.ghost_frames > 255 {
            return bad(
                "ghost_frames",
                self.ghost_frames as f64,
                "must be at most 255",
            );
        }
        if self.tolerance > 8 {
            return bad("tolerance", self.tolerance as f64, "must be at most 8");
        }
        let unit = |v: f32| v.is_finite() && (0.0..=1.0).contains(&v);
        if !unit(self.alpha) || self.alpha == 0.0 {
            return bad("alpha", self.alpha as f64, "must be in (0, 1]");
        }
        if !unit(self.foreground_alpha) {
            return bad(
                "foreground_alpha",
                self.foreground_alpha as f64,
                "must be in [0, 1]",
            );
        }
        if self.min_age > 255 {
            return bad("min_age", self.min_age as f64, "must be at most 255");
        }
        if self.min_inliers < 3 {
            return bad("min_inliers", self.min_inliers as f64, "must be at least 3");
        }
        for (f, v) in [
            ("min_inlier_ratio", self.min_inlier_ratio),
            ("max_foreground", self.max_foreground),
            ("min_blob", self.min_blob),
            ("box_margin", self.box_margin),
        ] {
            if !(v.is_finite() && (0.0..=1.0).contains(&v)) {
                return bad(f, v, "must be in [0, 1]");
            }
        }
        if self.close_radius > 16 {
            return bad(
                "close_radius",
                self.close_radius as f64,
                "must be at most 16",
            );
        }
        if let Some(r) = &self.refine {
            r.validate()?;
        }
        if let Err((field, value, reason)) = self.flow.check() {
            return bad(field, value, reason);
        }
        for (f, v) in [
            ("min_residual", self.min_residual),
            ("residual_factor", self.residual_factor),
        ] {
            if !(v.is_finite() && (0.0..=100.0).contains(&v)) {
                return bad(f, v as f64, "must be in [0, 100]");
            }
        }
        Ok(())
    }
}
