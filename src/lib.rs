//! # shapetrack
//!
//! A multi-object shape tracker after the thesis "Computational Geometric-Based Visual Shape
//! Tracker": track-by-detection over instance masks (boxes are the degenerate case), with a
//! computational-geometric region estimator, a shape context descriptor, a spatial colour
//! analyser and, offline, a Kalman trajectory re-linker. The same core builds natively (the
//! `shapetrack` CLI) and for `wasm32-unknown-unknown` (the browser app in `www/`).
//!
//! Module map, in pipeline order:
//!
//! - [`frame`]: frames (borrowed RGB/RGBA views), boxes, masks, detections, tracked shapes.
//! - [`detect`]: the adaptive background subtractor and the [`detect::Detector`] trait.
//! - [`segment`]: learned segmentation (U²-Net-p): boxes, blobs and whole frames into object
//!   masks, one state machine for the CLI (tract) and the browser (onnxruntime-web).
//! - [`geometry`]: Canny edges and contours, moments, Delaunay shells, GJK, broad phase.
//! - [`features`]: SIFT, shape context, spatial colour analyser.
//! - [`follow`]: following one user-given target without (or with) detections; shape-aware
//!   interpolation between keyframe masks.
//! - [`region`]: region clusters (thesis Alg. 2).
//! - [`assign`]: cost matrices and optimal assignment.
//! - [`motion`]: Kalman filters (constant velocity online, constant acceleration re-linker).
//! - [`track`]: the online tracker, the offline re-linker, track lifecycle.
//! - [`eval`]: MOT (CLEAR, Identity, HOTA) and VOT (accuracy, robustness, EAO) metrics.
//! - [`io`]: MOTChallenge, MOTS, COCO-video, CVAT XML, PNG masks, VOT files.
//! - [`synth`]: deterministic synthetic scenes with ground truth.
//! - [`settings`]: partial JSON settings over any config (CLI files, JS objects), errors
//!   naming the field.
//! - `grid` (native only): the robustness grid — datasets × detector models × trackers.
//!
//! The core never imports wasm-bindgen; the browser bindings live in `wasm` (wasm32 only).
//!
//! Online tracking in box mode (no image: the degenerate case of masks), one call per frame:
//!
//! ```
//! use shapetrack::{track::{Config, Tracker}, BBox, Detection};
//! let mut tracker = Tracker::new(Config::default())?;
//! for x in [10.0, 14.0, 18.0, 22.0] {
//!     let tracks = tracker.update(None, &[Detection::from_box(BBox::new(x, 20.0, 30.0, 60.0), 0.9)])?;
//!     assert!(tracks.iter().all(|t| t.id == 1), "one walker, one identity");
//! }
//! # Ok::<(), shapetrack::track::TrackError>(())
//! ```
#![deny(missing_docs)]

pub mod assign;
pub mod detect;
pub mod eval;
pub mod features;
pub mod follow;
pub mod frame;
pub mod geometry;
#[cfg(not(target_arch = "wasm32"))]
pub mod grid;
pub mod io;
pub mod motion;
pub mod region;
mod runs;
mod scratch;
pub mod segment;
pub mod settings;
pub mod synth;
pub mod track;

#[cfg(target_arch = "wasm32")]
pub mod wasm;

pub use frame::{
    BBox, Detection, Frame, FrameError, Mask, PixelFormat, Point, TrackState, TrackedShape,
};
