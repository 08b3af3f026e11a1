//! The offline pass (thesis ch. 5) as JS sees it: its progress reports and result (its
//! settings are `settings::OfflineSettings`).

use super::*;
use crate::track::offline::{Join, Phase, Progress};
use serde::Serialize;
use tsify::Tsify;
use wasm_bindgen::prelude::*;

/// Where the offline pass is: its phase and how far into it, in `[0, 1]`. `finish` reports
/// the phases after the online pass, in order: candidates, appearance (only with frames),
/// matching, filling, done.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Tsify)]
pub struct OfflineProgress {
    /// Current phase.
    #[tsify(
        type = "\"online\" | \"candidates\" | \"appearance\" | \"matching\" | \"filling\" | \"done\""
    )]
    pub phase: Phase,
    /// Fraction of the phase done.
    pub fraction: f64,
}

impl From<Progress> for OfflineProgress {
    fn from(p: Progress) -> Self {
        OfflineProgress {
            phase: p.phase,
            fraction: p.fraction,
        }
    }
}

/// One join the re-linker made: track `master` (an online id) continues track `slave`, and
/// now carries the slave's identity.
#[derive(Debug, Clone, PartialEq, Serialize, Tsify)]
pub struct JoinJs {
    /// Online id of the track that ended.
    pub slave: i64,
    /// Online id of the track that continues it.
    pub master: i64,
    /// The slave's last frame.
    pub slave_last: u32,
    /// The master's first frame.
    pub master_first: u32,
    /// Gate-normalised cost of the join, in `[0, 1]`.
    pub cost: f64,
    /// SIFT connections between the two ends, when both had appearance snapshots.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub connections: Option<u32>,
}

impl From<&Join> for JoinJs {
    fn from(j: &Join) -> Self {
        JoinJs {
            slave: j.slave as i64,
            master: j.master as i64,
            slave_last: j.slave_last,
            master_first: j.master_first,
            cost: j.cost,
            connections: j.connections.map(|c| c as u32),
        }
    }
}

/// What `finish` returns.
#[derive(Debug, Clone, PartialEq, Serialize, Tsify)]
pub struct OfflineOutput {
    /// Every record after the offline pass, by frame then id: the online records under their
    /// joined ids, and the filled-in ones (`interpolated: true`).
    pub records: Records,
    /// The joins made, by the master's first frame.
    pub joins: Vec<JoinJs>,
    /// Number of records filled in.
    pub filled: u32,
    /// The records filled in by this pass (not those the online pass had already coasted
    /// over, which are in `records` flagged interpolated too).
    pub added: Records,
}

#[wasm_bindgen]
extern "C" {
    /// A progress callback: called with each progress report of the offline pass.
    // Parenthesised: the generated signature appends `| null` to optional parameters.
    #[wasm_bindgen(typescript_type = "((progress: OfflineProgress) => void)")]
    pub type ProgressCallback;
}
