//! The tracker's settings as JS gives them: every field optional, laid over a preset.

use super::*;
use crate::track::Config as TrackConfig;
use serde::{Deserialize, Serialize};
use tsify::Tsify;

/// Reads a field that may be absent (keep the default), `null` (no value) or a value.
pub(super) fn double_option<'de, D, T>(d: D) -> Result<Option<Option<T>>, D::Error>
where
    D: serde::Deserializer<'de>,
    T: Deserialize<'de>,
{
    Option::<T>::deserialize(d).map(Some)
}

/// Weight, gate and scale of one pair-cost term; absent fields keep their defaults.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct TermOptions {
    /// Weight in the combined cost; 0 disables the term.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub weight: Option<f64>,
    /// Highest cost of this term a match may have; `null`: no gate.
    #[serde(
        deserialize_with = "double_option",
        skip_serializing_if = "Option::is_none"
    )]
    #[tsify(optional, type = "number | null")]
    pub gate: Option<Option<f64>>,
    /// Term-specific scale.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub scale: Option<f64>,
}

/// The pair-cost terms (see the core's `track::Terms` for what each measures).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct TermsOptions {
    /// Box IoU with the predicted box.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub iou: Option<TermOptions>,
    /// Box IoU with the track's last observed box (finds a lost track where it was last seen).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub last_iou: Option<TermOptions>,
    /// Generalised IoU.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub giou: Option<TermOptions>,
    /// How much of the detection's box lies outside the (grown) predicted box: a partly
    /// hidden shape lies inside its whole predicted box.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub ioa: Option<TermOptions>,
    /// Centre distance.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub centre: Option<TermOptions>,
    /// Size ratio.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub size: Option<TermOptions>,
    /// Mahalanobis distance under the Kalman filter.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub mahalanobis: Option<TermOptions>,
    /// Mask IoU.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub mask_iou: Option<TermOptions>,
    /// Shape context (thesis ch. 4.3).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub shape_context: Option<TermOptions>,
    /// Spatial colour (thesis ch. 4.4).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub colour: Option<TermOptions>,
    /// SIFT matches.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub sift: Option<TermOptions>,
}

/// Noise of the constant-velocity box Kalman filter, as fractions of the box size.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct MotionOptions {
    /// Position process noise per frame.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub std_position: Option<f64>,
    /// Velocity process noise per frame.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub std_velocity: Option<f64>,
    /// Measurement noise.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub std_measurement: Option<f64>,
}

/// The starting point of a tracker's settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, Tsify)]
#[serde(rename_all = "kebab-case")]
pub enum Preset {
    /// The core's defaults (`Config::default()`), tuned on MOTChallenge boxes.
    #[default]
    Default,
    /// The mask preset (`Config::masks()`): instance masks with frames, appearance in
    /// ambiguous clusters, re-identification by colour and SIFT, amodal completion, fragment
    /// merging.
    Masks,
}

/// The tracker's settings (the core's `track::Config`, every field optional: absent fields keep
/// the preset's values, by default the core's documented defaults). A test checks this mirrors
/// the core's fields exactly.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct TrackerConfig {
    /// What the other fields apply over: `"default"` (the core's defaults) or `"masks"`.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub preset: Option<Preset>,
    /// Detections scoring below this are ignored.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub min_score: Option<f64>,
    /// Detections at or above this score are matched first and may start tracks.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub high_score: Option<f64>,
    /// Score an unmatched detection needs to start a track.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub new_track_score: Option<f64>,
    /// Score thresholds from the sequence's own scores (`{ high_quantile, birth_quantile,
    /// window, warmup }`, absent fields at their defaults); `null`: the fixed thresholds.
    #[serde(
        deserialize_with = "double_option",
        skip_serializing_if = "Option::is_none"
    )]
    #[tsify(
        optional,
        type = "{ high_quantile?: number, birth_quantile?: number, window?: number, warmup?: number } | null"
    )]
    pub score_adaptation: Option<Option<serde_json::Value>>,
    /// An unmatched detection overlapping a matched one by more than this IoU starts no track.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub spawn_max_iou: Option<f64>,
    /// Matches a tentative track needs to be confirmed.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub min_hits: Option<u32>,
    /// Fewest matches confirmation needs however low the frame rate.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub min_hits_floor: Option<u32>,
    /// Weight of a match below the birth threshold towards confirmation (`null`: births
    /// need the threshold and every match counts 1).
    #[serde(
        deserialize_with = "double_option",
        skip_serializing_if = "Option::is_none"
    )]
    #[tsify(optional, type = "number | null")]
    pub birth_evidence: Option<Option<f64>>,
    /// Frames a tentative track may go unmatched.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub max_tentative_misses: Option<u32>,
    /// Frames a confirmed track stays lost (and re-identifiable) before removal.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub max_lost: Option<u32>,
    /// Report a confirmed track's tentative frames too.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub report_tentative: Option<bool>,
    /// Growth of a track's predicted box before region estimation, as a fraction of its size.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub region_margin: Option<f64>,
    /// Extra growth per frame unmatched.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub region_margin_per_miss: Option<f64>,
    /// Highest cost accepted for a high detection.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub max_cost: Option<f64>,
    /// The main gate at 30 fps (scaled by the frame interval, at most `max_cost`); `null`:
    /// `max_cost` at any frame rate.
    #[serde(
        deserialize_with = "double_option",
        skip_serializing_if = "Option::is_none"
    )]
    #[tsify(optional, type = "number | null")]
    pub reference_max_cost: Option<Option<f64>>,
    /// Highest cost accepted for a low detection.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub max_cost_low: Option<f64>,
    /// Highest cost accepted for a tentative track.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub max_cost_tentative: Option<f64>,
    /// Cost of leaving a track or detection unmatched; `null`: maximise matches first.
    #[serde(
        deserialize_with = "double_option",
        skip_serializing_if = "Option::is_none"
    )]
    #[tsify(optional, type = "number | null")]
    pub unmatched_cost: Option<Option<f64>>,
    /// Per-frame decay of a lost track's velocity.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub lost_velocity_decay: Option<f64>,
    /// Re-run a re-found lost track's filter along the gap (OC-SORT's re-update).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub reupdate_after_gap: Option<bool>,
    /// Tentative tracks compete with confirmed ones in the first association (ByteTrack).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub tentative_first: Option<bool>,
    /// Match lost tracks after the tracks seen in the previous frame.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub lost_second: Option<bool>,
    /// Terms of the main association.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub terms: Option<TermsOptions>,
    /// Terms of the re-identification stage.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub reid_terms: Option<TermsOptions>,
    /// Highest re-identification cost accepted.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub reid_max_cost: Option<f64>,
    /// Kalman filter noise.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub motion: Option<MotionOptions>,
    /// Lost tracks are matched only by re-identification (appearance), not by the main
    /// association.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub lost_reid_only: Option<bool>,
    /// With `lost_reid_only`, lost tracks missed for at most this many frames (at 30 fps)
    /// still take part in the main association.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub lost_main_frames: Option<u32>,
    /// A track being confirmed first looks for a lost track it re-identifies and takes its id.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub reid_at_confirmation: Option<bool>,
    /// Mask features and when appearance is computed (the core's `track::AppearanceConfig`:
    /// `shell`, `sift`, `colour`, `shape_context`, `lazy`, `ambiguity`, `refresh`,
    /// `whole_ratio`); checked by the core, unknown fields are errors.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional, type = "Record<string, unknown>")]
    pub appearance: Option<serde_json::Value>,
    /// How the shape context cost fits its transform: thesis Alg. 4 or Alg. 5.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional, type = "\"Contour\" | \"Sift\"")]
    pub shape_variant: Option<String>,
    /// SIFT matching (`ratio`, `cross_check`).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional, type = "{ ratio?: number, cross_check?: boolean }")]
    pub sift_matching: Option<serde_json::Value>,
    /// Fewest keypoints on both sides for the SIFT term to have data.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub sift_min_keypoints: Option<u32>,
    /// Update a partly hidden mask's track with the box of its whole shape.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub amodal: Option<bool>,
    /// Below this fraction of its reference area a matched mask does not correct the motion.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub sliver_ratio: Option<f64>,
    /// Merge a shape the detector split in two before its track is updated.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub merge_fragments: Option<bool>,
    /// Frames a confirmed track last seen whole may go undetected and still be reported at
    /// its predicted place.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub coast_frames: Option<u32>,
    /// Coast only when this tracker's own gaps of that length usually close
    /// (`{ min_probability }`); `null`: always coast up to `coast_frames`.
    #[serde(
        deserialize_with = "double_option",
        skip_serializing_if = "Option::is_none"
    )]
    #[tsify(optional, type = "{ min_probability?: number } | null")]
    pub coasting: Option<Option<serde_json::Value>>,
    /// Frames per second of the video (time-measuring frame counts scale to it); `null`:
    /// unknown, counts used as given.
    #[serde(
        deserialize_with = "double_option",
        skip_serializing_if = "Option::is_none"
    )]
    #[tsify(optional, type = "number | null")]
    pub frame_rate: Option<Option<f64>>,
    /// Scale the motion filter's process noise with the time between frames.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub motion_per_second: Option<bool>,
    /// The frame rate `max_lost` and `coast_frames` are given at.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub frame_counts_at: Option<f64>,
    /// The box reported for a matched detection: the detection's, the association filter's
    /// (box detections only), or (default) the detection smoothed only as far as smoothing
    /// agrees with the following detections of this sequence, mask detections included (the
    /// app's mask detectors ask for `detection`: a label's box is its mask's extent).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional, type = "\"detection\" | \"filter\" | \"adaptive\"")]
    pub report_box: Option<String>,
    /// Lost tracks follow a camera motion the seen tracks agree on (a pan, a shake).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub camera_motion: Option<bool>,
}

impl TrackerConfig {
    /// The core config: the given fields over the preset, nested objects merged field by
    /// field ([`TrackConfig::overlay`]).
    pub fn to_core(&self) -> Result<TrackConfig, JsValue> {
        let base = match self.preset.unwrap_or_default() {
            Preset::Default => TrackConfig::default(),
            Preset::Masks => TrackConfig::masks(),
        };
        let patch = TrackerConfig {
            preset: None,
            ..self.clone()
        };
        let v = serde_json::to_value(&patch).map_err(js_error)?;
        base.overlay(&v).map_err(js_error)
    }
}
