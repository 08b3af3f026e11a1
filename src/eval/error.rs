//! Errors of the MOT evaluation layer.
//!
//! TrackEval refuses some inputs outright (a duplicate id in a frame, a frame beyond
//! `seqLength`, unknown ground-truth classes when preprocessing, overlapping MOTS masks). We
//! refuse the same inputs, and say where: the file and line when the records came from a file
//! (see [`Origin`](super::Origin)), otherwise the sequence, side and record number.

use serde::Serialize;
use std::fmt;
use thiserror::Error;

/// Which of the two inputs a record belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub enum Side {
    /// Ground truth.
    Gt,
    /// Tracker output (results).
    Tracker,
}

impl fmt::Display for Side {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Side::Gt => "ground truth",
            Side::Tracker => "tracker",
        })
    }
}

/// Where a bad record is.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Location {
    /// Sequence name.
    pub seq: String,
    /// Ground truth or tracker.
    pub side: Side,
    /// 0-based index of the record in the input vector.
    pub record: usize,
    /// File the record was read from, when known.
    pub file: Option<String>,
    /// 1-based line in `file` (0 when unknown).
    pub line: usize,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.file {
            Some(file) if self.line > 0 => write!(f, "{file}:{}", self.line),
            Some(file) => write!(f, "{file}"),
            None => write!(
                f,
                "sequence {}, {} record {}",
                self.seq,
                self.side,
                self.record + 1
            ),
        }
    }
}

/// What is wrong with a record (TrackEval raises an exception for each of these).
#[derive(Debug, Clone, PartialEq, Error, Serialize)]
pub enum Problem {
    /// The same id twice in one frame.
    #[error("id {id} appears more than once in frame {frame}")]
    DuplicateId {
        /// 1-based frame.
        frame: u32,
        /// The repeated id.
        id: i64,
    },
    /// More boxes of one side in one frame than the cap
    /// ([`MAX_BOXES_PER_FRAME`](crate::io::limits::MAX_BOXES_PER_FRAME)): the frame's
    /// similarity matrix and matching would grow with the file's claim, not with a scene.
    #[error("frame {frame} holds {count} boxes on this side, beyond the cap of {max} per frame")]
    TooManyBoxes {
        /// 1-based frame.
        frame: u32,
        /// Boxes of this side in the frame.
        count: usize,
        /// The cap.
        max: usize,
    },
    /// A frame outside `1..=num_frames` (`seqLength`).
    #[error("frame {frame} is outside the sequence's frames 1..={num_frames} (seqLength)")]
    InvalidTimestep {
        /// The frame found.
        frame: u32,
        /// Number of frames of the sequence.
        num_frames: u32,
    },
    /// A ground-truth class outside MOTChallenge's 1..=13 while preprocessing is on.
    #[error(
        "ground-truth class {class} in frame {frame} is not a MOTChallenge class (1..=13); \
         check the gt or evaluate without preprocessing"
    )]
    InvalidGtClass {
        /// 1-based frame.
        frame: u32,
        /// The class found.
        class: i32,
    },
    /// A tracker row with a class other than pedestrian (column 8 > 1).
    #[error(
        "tracker class {class} in frame {frame}: MOTChallenge evaluation is only valid for the \
         pedestrian class (column 8 must be ≤ 1)"
    )]
    NonPedestrianClass {
        /// 1-based frame.
        frame: u32,
        /// The class found.
        class: i32,
    },
    /// MOTS masks of one frame overlap (each pixel may belong to one object only).
    #[error("mask overlaps another mask of frame {frame}")]
    OverlappingMasks {
        /// 1-based frame.
        frame: u32,
    },
    /// Mask IoU was asked for but the record has no mask.
    #[error("record in frame {frame} has no mask, but mask IoU was requested")]
    MissingMask {
        /// 1-based frame.
        frame: u32,
    },
    /// A mask whose image size differs from the sequence's first mask.
    #[error(
        "mask in frame {frame} is {height}x{width} but the sequence's masks are \
         {expected_height}x{expected_width}"
    )]
    MaskSize {
        /// 1-based frame.
        frame: u32,
        /// This mask's image height.
        height: u32,
        /// This mask's image width.
        width: u32,
        /// The sequence's image height.
        expected_height: u32,
        /// The sequence's image width.
        expected_width: u32,
    },
    /// A box with a non-finite coordinate or a negative size.
    #[error("invalid box in frame {frame}")]
    InvalidBox {
        /// 1-based frame.
        frame: u32,
    },
}

/// Errors of MOT evaluation.
#[derive(Debug, Error)]
pub enum EvalError {
    /// A record TrackEval would refuse.
    #[error("{location}: {problem}")]
    Data {
        /// Where it is.
        location: Location,
        /// What is wrong.
        problem: Problem,
    },
    /// A frame pushed to a [`SequenceBuilder`](super::SequenceBuilder) repeats an id.
    #[error("sequence {seq}, frame {frame}: {side} id {id} appears more than once")]
    FrameDuplicateId {
        /// Sequence name.
        seq: String,
        /// 1-based frame.
        frame: usize,
        /// Ground truth or tracker.
        side: Side,
        /// The repeated id.
        id: i64,
    },
    /// A similarity matrix of the wrong size.
    #[error(
        "sequence {seq}, frame {frame}: similarity matrix has {len} values, expected {gt}x{tracker}"
    )]
    SimilarityShape {
        /// Sequence name.
        seq: String,
        /// 1-based frame.
        frame: usize,
        /// Values given.
        len: usize,
        /// Ground-truth objects in the frame.
        gt: usize,
        /// Tracker objects in the frame.
        tracker: usize,
    },
    /// A similarity outside `[0, 1]` (or NaN).
    #[error("sequence {seq}, frame {frame}: similarity {value} is outside [0, 1]")]
    SimilarityRange {
        /// Sequence name.
        seq: String,
        /// 1-based frame.
        frame: usize,
        /// The value.
        value: f64,
    },
    /// Two sequences with the same name.
    #[error("sequence {name} is given twice")]
    DuplicateSequence {
        /// The name.
        name: String,
    },
    /// Nothing to evaluate.
    #[error("no sequences to evaluate")]
    NoSequences,
    /// The assignment solver refused a matrix (cannot happen for finite similarities).
    #[error("sequence {seq}: assignment solver failed on a {rows}x{cols} matrix")]
    Assignment {
        /// Sequence name.
        seq: String,
        /// Rows.
        rows: usize,
        /// Columns.
        cols: usize,
    },
}
