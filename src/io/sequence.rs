//! One sequence's ground truth and tracker records as read, with where each came from: the
//! data that `layout` reads and `eval` scores. It lives here, below both, so the readers do
//! not depend on the evaluation (its checks and scoring are `impl SequenceInput` in
//! `eval::preproc`); `shapetrack::eval` re-exports both types.

use super::Record;
use serde::{Deserialize, Serialize};

/// Where a vector of records was read from, so errors can name the file and line.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Origin {
    /// File name.
    pub file: String,
    /// `lines[i]`: 1-based line of record `i`.
    pub lines: Vec<usize>,
}

/// One sequence to evaluate: ground truth and tracker records, frames `1..=num_frames`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct SequenceInput {
    /// Sequence name.
    pub name: String,
    /// Number of frames (`seqLength`); records beyond are an error.
    pub num_frames: u32,
    /// Ground-truth records.
    pub gt: Vec<Record>,
    /// Tracker records.
    pub results: Vec<Record>,
    /// Where `gt` came from, if from a file.
    pub gt_origin: Option<Origin>,
    /// Where `results` came from, if from a file.
    pub results_origin: Option<Origin>,
}
