//! The offline pass (thesis ch. 5) as JS sees it: its settings, progress reports and result.

use super::*;
use crate::track::offline::{Join, JoinSolver, OfflineConfig, Phase, Progress, Trajectory};
use crate::track::Config as TrackConfig;
use serde::{Deserialize, Serialize};
use tsify::Tsify;
use wasm_bindgen::prelude::*;

/// Settings of the re-linker (the core's `track::offline::RelinkConfig`, every field
/// optional: absent fields keep the core's defaults).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct RelinkOptions {
    /// A slave must end at most this long (seconds) before its master starts.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub max_gap_seconds: Option<f64>,
    /// Slaves kept per master, the most recently ended first.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub max_slaves: Option<u32>,
    /// Of those, how many with the most SIFT connections are kept (with frames only).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub appearance_keep: Option<u32>,
    /// Length (seconds) of the centroid history velocity and acceleration are fitted on.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub history_seconds: Option<f64>,
    /// Shapes smaller than this fraction of the median size near an end are not used for
    /// its motion (they are entering or leaving an occlusion).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub reliable_size: Option<f64>,
    /// Scale of the estimated acceleration in the rollout (1: the thesis, 0: constant velocity).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub acceleration: Option<f64>,
    /// Also roll the master back to the slave's end and average both errors.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub bidirectional: Option<bool>,
    /// Gate radius at zero gap, in shape sizes.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub gate_base: Option<f64>,
    /// Growth of the gate radius per second of gap, in shape sizes.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub gate_per_second: Option<f64>,
    /// Largest ratio of the two ends' sizes a join accepts.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub max_size_ratio: Option<f64>,
    /// How joins are chosen: all together (min-cost matching) or the thesis' greedy order.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional, type = "\"global\" | \"greedy\"")]
    pub solver: Option<JoinSolver>,
    /// Refuse a join whose predicted path leaves the image.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub stay_in_view: Option<bool>,
}

/// Settings of gap filling (the core's `FillConfig`; absent fields keep their defaults).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct FillOptions {
    /// Longest gap filled, in missing frames (0: no filling).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub max_gap: Option<u32>,
    /// Also fill gaps inside one online track, not only between joined ones.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub within_tracks: Option<bool>,
    /// Path of the filled shapes.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional, type = "\"linear\" | \"kalman\"")]
    pub trajectory: Option<Trajectory>,
    /// Gaps between two partial mask views (below this fraction of the shape's usual area)
    /// are hides and are not filled (0: fill them too).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub hidden_ratio: Option<f64>,
    /// Keep the online pass's coasted shapes after an identity's last observation.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub coasted_tails: Option<bool>,
    /// Longest gap filled in seconds (instead of `max_gap` frames).
    #[serde(
        deserialize_with = "double_option",
        skip_serializing_if = "Option::is_none"
    )]
    #[tsify(optional, type = "number | null")]
    pub max_gap_seconds: Option<Option<f64>>,
}

/// SIFT detector settings for the appearance snapshots (the core's `SiftConfig`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct SiftOptions {
    /// Layers per octave (1..=8).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub n_octave_layers: Option<u32>,
    /// Contrast threshold.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub contrast_threshold: Option<f32>,
    /// Edge rejection threshold.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub edge_threshold: Option<f32>,
    /// Blur of the first layer.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub sigma: Option<f32>,
    /// Upsample the crop 2× first.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub upsample: Option<bool>,
    /// Keep only the strongest keypoints; `null`: all.
    #[serde(
        deserialize_with = "double_option",
        skip_serializing_if = "Option::is_none"
    )]
    #[tsify(optional, type = "number | null")]
    pub max_keypoints: Option<Option<u32>>,
    /// Downscale crops whose longer side exceeds this; `null`: never.
    #[serde(
        deserialize_with = "double_option",
        skip_serializing_if = "Option::is_none"
    )]
    #[tsify(optional, type = "number | null")]
    pub max_side: Option<Option<u32>>,
}

/// Descriptor matching settings (the core's `MatchConfig`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct MatchOptions {
    /// Lowe's ratio.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub ratio: Option<f32>,
    /// Require mutual nearest neighbours.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub cross_check: Option<bool>,
}

/// Appearance snapshots (the core's `AppearanceConfig`): a small grey crop of each track's
/// first and last appearance, taken from the frames during the online pass.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct AppearanceOptions {
    /// Take snapshots at all (only `update` with pixels can).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub enabled: Option<bool>,
    /// Longer side crops are downscaled to.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub max_side: Option<u32>,
    /// SIFT detector settings.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub sift: Option<SiftOptions>,
    /// Descriptor matching settings.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub matching: Option<MatchOptions>,
}

/// What a tracker needs to run the offline pass at the end: the video's frame rate, and the
/// offline stages' settings (every one optional; the online part is the tracker's config).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Tsify)]
#[serde(deny_unknown_fields)]
pub struct OfflineOptions {
    /// Frames per second of the video: the re-linker's filter steps `Δt = 1/fps`, and its
    /// gates are in seconds.
    pub fps: f64,
    /// Image width, for box-only tracking (`updateDetections`); frames tell it otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub width: Option<u32>,
    /// Image height, for box-only tracking.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub height: Option<u32>,
    /// The re-linker.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub relink: Option<RelinkOptions>,
    /// Gap filling.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub fill: Option<FillOptions>,
    /// Appearance snapshots.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub appearance: Option<AppearanceOptions>,
    /// Identities shorter than this many seconds of observed shapes are dropped.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub min_track_seconds: Option<f64>,
}

impl OfflineOptions {
    /// The core config: the given offline settings over the defaults, around `online`.
    pub fn to_core(&self, online: TrackConfig) -> Result<OfflineConfig, JsValue> {
        // Every part takes defaults for absent fields, so a JSON round trip does the overlay.
        let mut parts = serde_json::json!({
            "relink": self.relink.clone().unwrap_or_default(),
            "fill": self.fill.clone().unwrap_or_default(),
            "appearance": self.appearance.clone().unwrap_or_default(),
        });
        if let (Some(m), Some(s)) = (parts.as_object_mut(), self.min_track_seconds) {
            m.insert("min_track_seconds".into(), serde_json::json!(s));
        }
        let mut cfg: OfflineConfig = serde_json::from_value(parts).map_err(js_error)?;
        cfg.online = online;
        cfg.validate().map_err(js_error)?;
        Ok(cfg)
    }
}

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
