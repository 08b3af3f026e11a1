//! Detection: the [`Detector`] interface and the default detector, the thesis' adaptive
//! background subtractor ([`BackgroundSubtractor`], §3.2.1 eq. 1–2), with the binary
//! morphology and connected-component labelling it is built from; its camera-motion-compensated
//! variant for moving cameras ([`MovingCameraDetector`], with [`CameraJudge`] to tell the two
//! kinds of footage apart); and box → mask refinement ([`refine_box`], GrabCut-like, on a
//! hand-written min-cut in [`maxflow`]).
//!
//! Any other detector (an in-browser model, detections read from files) plugs into the tracker
//! by implementing [`Detector`] or by handing over its `Vec<Detection>` directly.

pub mod background;
pub mod components;
pub mod flow;
mod gray;
pub mod maxflow;
pub mod morphology;
pub mod moving;
pub mod refine;

pub use background::{BackgroundConfig, BackgroundSubtractor, ShadowConfig, UpdatePolicy};
pub use components::{Blob, Components, Connectivity, Run};
pub use flow::{DenseFlow, FlowConfig, FlowField};
pub use morphology::Morphology;
pub use moving::{CameraJudge, CameraMotion, MotionCue, MovingCameraDetector, MovingConfig};
pub use refine::{refine_box, refine_box_hinted, BoxRefiner, Hint, RefineConfig};

use crate::frame::{Detection, Frame};
use thiserror::Error;

/// Errors of the detection layer.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum DetectError {
    /// A frame's size differs from the size the detector was started with (call `reset` to
    /// start over on a new size).
    #[error(
        "frame is {width}x{height} but the detector was started on {expected_width}x{expected_height} frames"
    )]
    SizeChanged {
        /// Width of the first frame.
        expected_width: u32,
        /// Height of the first frame.
        expected_height: u32,
        /// Width of this frame.
        width: u32,
        /// Height of this frame.
        height: u32,
    },
    /// A configuration value is out of range.
    #[error(
        "invalid detector setting {field} = {}: {reason}",
        crate::settings::Short::of(.value)
    )]
    InvalidConfig {
        /// The setting.
        field: &'static str,
        /// The value given.
        value: f64,
        /// What is allowed.
        reason: &'static str,
    },
    /// The colour models of a box refinement could not be built.
    #[error("box refinement failed: {reason}")]
    Refine {
        /// What failed.
        reason: String,
    },
    /// A bitmap does not have `width·height` entries.
    #[error("bitmap has {len} entries, expected {width}x{height}")]
    BitmapSize {
        /// Entries given.
        len: usize,
        /// Width.
        width: u32,
        /// Height.
        height: u32,
    },
}

/// Finds the objects in one frame. Stateful detectors (a background model) learn from every
/// frame they see, so frames must come in order.
pub trait Detector {
    /// The detections of `frame`: each with a box, usually a mask, and a score.
    fn detect(&mut self, frame: &Frame) -> Result<Vec<Detection>, DetectError>;
}
