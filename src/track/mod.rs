//! The online tracker (thesis ch. 2.1, 3.3, 4.5): a phased update over a per-track Kalman
//! filter, region estimation, pair-cost terms and optimal assignment; and the track lifecycle.
//!
//! Modules, in the order they depend on one another (no module imports a later one; a test,
//! `tests/track_modules.rs`, keeps it so):
//!
//! - [`features`]: [`Features`] and the [`FeatureExtractor`]s: per detection, the cheap part
//!   (centroid, area, convex shell) once per frame, the appearance (shape context, SIFT,
//!   colour) on demand.
//! - [`config`]: [`Config`], one documented set of parameters for every sequence
//!   ([`Config::masks`] for instance masks with frames).
//! - `amodal`: the whole shape's box behind a partial view.
//! - `lifecycle`: [`Track`], which owns its lifecycle as methods (born, hit, confirm, miss,
//!   absorb, coast).
//! - [`regions`]: [`estimate_regions`], which pairs are worth scoring at all (thesis Alg. 2).
//! - [`cost`]: the [`PairCost`] trait, the built-in geometric/motion terms and their weighted,
//!   renormalised combination (thesis eq. 39 generalised).
//! - [`appearance`]: the appearance terms, C1 (shape context), C2 (colour) and SIFT.
//! - `prepare`: a frame's detections checked, clipped, split into high and low confidence.
//! - [`associate`]: association as a list of [`Stage`]s built from the config.
//! - `describe`: when appearance is worth computing; `fragments`: detector-split masks
//!   merged; `timing`: [`PhaseTimes`].
//! - [`online`]: [`Tracker`], whose `update` runs the phases in turn.
//! - [`sequence`]: whole-sequence helpers (records in, records out).
//! - [`from_files`]: a whole sequence from its files to a results file, what
//!   `shapetrack track` and the Python package's batch runs both call.
//! - [`offline`]: the offline mode: Kalman trajectory re-linker and gap filling (thesis ch. 5).
//!
//! A track's lifecycle: **tentative** (born from an unmatched confident detection) →
//! **confirmed** after [`Config::min_hits`] matches → **lost** when a frame passes without a
//! match (kept and searchable for [`Config::max_lost`] frames; a match re-identifies it under
//! the same id) → **removed**. Ids are handed out by each [`Tracker`] when a track is
//! confirmed, so they are dense, start at 1, and two trackers never share a counter.

mod amodal;
pub mod appearance;
pub mod associate;
mod camera;
pub mod coasting;
pub mod config;
pub mod cost;
mod cut_views;
mod describe;
mod estimate;
pub mod features;
mod fragments;
pub mod gate;
// Files on disk: the CLI and the Python package. It compiles for wasm32 too (the CLI does, for
// `wasm-pack test`); the browser module never calls it, so none of it is linked there.
pub mod from_files;
pub mod hindsight;
mod lifecycle;
pub mod offline;
pub mod online;
mod prepare;
mod presets;
pub mod regions;
pub mod scores;
mod search;
pub mod sequence;
mod terms;
mod timing;
pub mod usable;

pub use appearance::{ColourCost, ColourMode, ShapeContextCost, SiftCost, TrackSide};
pub use associate::{Stage, StageCosts, StageDetections, StageTracks};
pub use coasting::Coasting;
pub use config::{Config, Preset, ReportBox, ShapeVariant, TermConfig, Terms};
pub use cost::{
    Candidate, CentreDistanceCost, CheapTerms, CostModel, GiouCost, IoaCost, IouCost, LastIouCost,
    MahalanobisCost, MaskIouCost, PairCost, SizeCost, WeightedTerm,
};
pub use features::{
    Appearance, AppearanceConfig, BoxFeatures, FeatureExtractor, Features, MaskFeatures, Needs,
    ShellMode,
};
pub use hindsight::Hindsight;
pub use lifecycle::Track;
pub use online::Tracker;
pub use regions::{estimate_regions, Cluster, Regions};
pub use scores::{ScoreAdaptation, Thresholds};
pub use sequence::{detections_by_frame, to_records, track_sequence};
pub use timing::PhaseTimes;

use crate::assign::AssignError;
use crate::motion::MotionError;
use thiserror::Error;

/// Most detections one frame may hold. Candidate pairs grow with tracks × detections when
/// everything overlaps (10,000 stacked boxes took 11 GB before pairs were capped per track,
/// see [`regions::MAX_CANDIDATES`]); no detector emits that many objects per frame (YOLO's
/// `max_det` is 300, a MOT20 frame holds ~250 people), and a frame beyond this cap is an
/// error, not a stall. The same cap as the readers' ([`crate::io::limits::MAX_BOXES_PER_FRAME`],
/// defined there because the readers sit below the tracker).
pub const MAX_DETECTIONS: usize = crate::io::limits::MAX_BOXES_PER_FRAME;

/// Errors raised by the tracker.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum TrackError {
    /// A detection has a NaN or infinite value, or a negative size.
    #[error(
        "detection {index}: {field} is {}, expected {expected}",
        crate::settings::Short::of(.value)
    )]
    InvalidDetection {
        /// Index of the detection in the frame's input.
        index: usize,
        /// Which field.
        field: &'static str,
        /// The value given.
        value: f64,
        /// What was expected.
        expected: &'static str,
    },
    /// More detections in one frame than the tracker takes ([`MAX_DETECTIONS`]).
    #[error(
        "{count} detections in one frame; at most {max} are tracked (filter them by score first)"
    )]
    TooManyDetections {
        /// Detections given.
        count: usize,
        /// The cap.
        max: usize,
    },
    /// A configuration value is out of range.
    #[error("config: {field} = {}: {reason}", crate::settings::Short::of(.value))]
    InvalidConfig {
        /// Which field (dotted path, e.g. `terms.iou.weight`).
        field: String,
        /// The value given.
        value: f64,
        /// What is wrong.
        reason: &'static str,
    },
    /// A feature extractor failed on a detection.
    #[error("detection {index}: feature extraction failed: {message}")]
    Features {
        /// Index of the detection in the frame's input.
        index: usize,
        /// What went wrong.
        message: String,
    },
    /// The frame's size differs from the previous frames'.
    #[error(
        "frame is {width}x{height}, but earlier frames were {expected_width}x{expected_height}"
    )]
    FrameSize {
        /// Width of this frame.
        width: u32,
        /// Height of this frame.
        height: u32,
        /// Width of the earlier frames.
        expected_width: u32,
        /// Height of the earlier frames.
        expected_height: u32,
    },
    /// A motion filter rejected its input.
    #[error("motion filter: {0}")]
    Motion(#[from] MotionError),
    /// The assignment failed.
    #[error("assignment: {0}")]
    Assign(#[from] AssignError),
}
