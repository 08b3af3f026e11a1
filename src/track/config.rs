//! Tracker configuration: one set of documented defaults, used unchanged on every sequence.
//!
//! The defaults were chosen on six MOT15-train sequences and checked on the other five (see
//! the repository's tracking notes); they are not tuned per sequence. Every field has a default,
//! so a JSON config only needs the fields it changes: `{"max_lost": 60}` is a valid config.

use super::coasting::Coasting;
use super::features::{AppearanceConfig, Needs};
use super::hindsight::Hindsight;
use super::scores::ScoreAdaptation;
use super::TrackError;
use crate::features::sift::MatchConfig;
use crate::motion::BoxKalmanParams;
use serde::{Deserialize, Serialize};

pub use super::terms::{TermConfig, Terms};

/// How C1 fits the transform between two shapes.
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum ShapeVariant {
    /// Alg. 4: χ² matching of the contour vertices' log-polar histograms (default).
    #[default]
    Contour,
    /// Alg. 5: the transform is fitted to SIFT keypoint matches; C1 is still measured on the
    /// contour vertices. Falls back to the centroid alignment without enough matches.
    Sift,
}

/// The box a track reports for a matched detection (a mask detection's mask is reported
/// unchanged beside it).
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ReportBox {
    /// The detection's box, as the detector gave it.
    Detection,
    /// The association filter's corrected box (what SORT, ByteTrack and OC-SORT report).
    Filter,
    /// The detection smoothed per coordinate by the filter (or none) whose estimates best
    /// agreed with the following detections so far in the sequence (see
    /// `track::estimate`).
    #[default]
    Adaptive,
}

/// A starting point for [`Config`]: the fields a settings object does not name keep the
/// preset's values (see [`Config::from_settings`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify))]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum Preset {
    /// [`Config::default`]: tuned on MOTChallenge boxes.
    #[default]
    Default,
    /// [`Config::masks`]: instance masks with frames (appearance in ambiguous groups,
    /// re-identification by colour and SIFT, amodal completion, fragment merging, coasting).
    Masks,
}

impl Preset {
    /// The preset's complete config.
    pub fn config(self) -> Config {
        match self {
            Preset::Default => Config::default(),
            Preset::Masks => Config::masks(),
        }
    }
}

/// Everything the online tracker can be told. Defaults are documented on each field.
#[cfg_attr(
    target_arch = "wasm32",
    derive(tsify::Tsify),
    tsify(rename = "TrackConfig", missing_as_null)
)]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// Detections scoring below this are ignored. Default 0 (keep all).
    pub min_score: f64,
    /// Detections at or above this score are "high": they are matched first, to every active
    /// track, and may start tracks. Those between `min_score` and `high_score` only extend
    /// tracks that were matched in the previous frame (ByteTrack's second association), which
    /// keeps a partly occluded person tracked without letting clutter start tracks. Default 0.6.
    pub high_score: f64,
    /// Score an unmatched detection needs to start a new (tentative) track. Default 0.9.
    pub new_track_score: f64,
    /// Score thresholds from the sequence's own scores instead of `high_score` and
    /// `new_track_score` (see [`super::scores`]): quantiles of the scores of the detections
    /// matched to confirmed tracks. `None`: the fixed thresholds. Default: high from the
    /// lowest matched score (quantile 0), births from the 0.25 quantile, chosen on the
    /// robustness grid (`tests/data/quality/README.md`).
    pub score_adaptation: Option<ScoreAdaptation>,
    /// An unmatched detection overlapping a detection matched this frame by more than this IoU
    /// does not start a track: it is most likely a duplicate box on an already tracked object.
    /// Default 1 (disabled): on MOT15 the detector's own NMS leaves few duplicates.
    pub spawn_max_iou: f64,
    /// Matches a tentative track needs to be confirmed (and get an id). 1 confirms at birth.
    /// Default 5: with `report_tentative` a longer wait costs no recall, only latency, and it
    /// filters out short-lived false positives.
    pub min_hits: u32,
    /// Confirmation by accumulated evidence instead of a birth threshold: any unmatched high
    /// detection may start a tentative track, each match adds 1 to its evidence when the
    /// detection scores at least the birth threshold and this weight when it scores less, and
    /// the track is confirmed once its evidence reaches [`Config::confirm_hits`]. A persistent
    /// object whose detector scores it low is confirmed after `1/weight` times as many
    /// matches; clutter that does not persist never is. `None`: births need the birth
    /// threshold and every match counts 1. Default 0.5.
    pub birth_evidence: Option<f64>,
    /// Fewest matches confirmation needs however low the frame rate (see
    /// [`Config::confirm_hits`]). Default: `u32::MAX`, i.e. `min_hits` is not scaled.
    pub min_hits_floor: u32,
    /// Frames in a row a tentative track may go unmatched before it is dropped, at
    /// [`Config::frame_counts_at`] frames per second (scaled to the video's
    /// [`Config::frame_rate`] when known, at least 1 unless 0: the allowance is a time, like
    /// `max_lost`). Default 1: a detector that misses one frame in a few should not make
    /// every birth start over.
    pub max_tentative_misses: u32,
    /// Frames a confirmed track stays lost (searchable, re-identified under its id) before it
    /// is removed, at [`Config::frame_counts_at`] frames per second (scaled to the video's
    /// [`Config::frame_rate`] when known). Default 38 (1.3 s).
    pub max_lost: u32,
    /// `max_lost` for the frames tracked without their image (boxes, or masks given alone):
    /// there is then no appearance to re-identify a long-lost track by, so the horizon that
    /// suits appearance-free tracking applies, and [`Config::lost_reid_only`] does not (see
    /// [`Config::without_frames`]). `None`: `max_lost`. Default `None`; the mask preset, whose
    /// 60 frames are for shapes re-identified by their colours after an occluder, keeps the
    /// defaults' 38 here, which the grid's 33 box cells chose without appearance.
    pub max_lost_without_frames: Option<u32>,
    /// When a tentative track is confirmed, also report its earlier (tentative) frames, so the
    /// output does not miss the first `min_hits − 1` frames of every track. The shapes are
    /// returned by the `update` that confirms the track, with their own frame numbers.
    /// Default true.
    pub report_tentative: bool,
    /// Also report, under a newly confirmed track's id, the views of a removed tentative track
    /// whose motion leads to it (see [`super::hindsight`]; needs `report_tentative`). Default
    /// on, with [`Hindsight::default`]; the mask preset too.
    pub hindsight: Option<Hindsight>,
    /// The region estimator grows each track's predicted box by this fraction of its size on
    /// every side; only pairs whose grown box meets the detection are scored at all.
    /// Default 0.5.
    pub region_margin: f64,
    /// Extra growth of the region margin per frame a track has been unmatched, since its
    /// predicted position is less certain every frame. Default 0.1.
    pub region_margin_per_miss: f64,
    /// Highest combined cost accepted between an active or lost track and a high detection.
    /// Default 0.75 (with IoU alone: IoU ≥ 0.25).
    pub max_cost: f64,
    /// Tighten the main association's gate ([`Config::main_max_cost`]) to this multiple of
    /// what this sequence's unambiguous matches cost at most (their 0.99 quantile; see
    /// [`super::gate`]): a steady detector's true matches cost little, and a looser gate only
    /// lets a track whose object went unseen take a neighbour's detection. `None`: the fixed
    /// gate. Default 1.5 (`tests/data/quality/README.md`, "The gate from the sequence's own
    /// matches": MOT15's detector models +1.5 / +1.9 HOTA online / offline, no dataset of the
    /// grid worse; a tighter multiple loses deforming shapes).
    pub adaptive_gate: Option<f64>,
    /// The main stage's gate at [`Config::frame_counts_at`] fps, when the frame rate is known:
    /// it grows with the time between frames (a true match's shift, and so its cost, does),
    /// capped at `max_cost` ([`Config::main_max_cost`]). Ragged masks at 30 fps need a tighter
    /// gate than 0.75 (or a track takes a split piece or a neighbour when its own mask is
    /// missed), 5 fps footage a looser one. Default `None` (`max_cost` at any rate).
    pub reference_max_cost: Option<f64>,
    /// Highest combined cost accepted between a track and a low detection (second stage).
    /// Default 0.5: a low-confidence box must overlap the prediction well.
    pub max_cost_low: f64,
    /// Low detections (the second association) extend tentative tracks matched in the
    /// previous frame too, as evidence at the [`Config::birth_evidence`] weight: an object
    /// scored around the adaptive high threshold was cut by each view just below it and
    /// confirmed late or never (ByteTrack's second stage takes confirmed tracks only, as it
    /// confirms on hits alone). Default true (grid: `tests/data/quality/README.md`).
    pub low_extends_tentative: bool,
    /// Highest combined cost accepted between a tentative track and a high detection.
    /// Default 0.85: a new track's velocity is still unknown, so its prediction is loose.
    pub max_cost_tentative: f64,
    /// How much leaving a track or a detection unmatched costs in the assignment: a pair is
    /// matched only when its cost is below twice this (ByteTrack's lapjv `cost_limit`).
    /// `None` (default): maximise the number of matches first (SORT).
    pub unmatched_cost: Option<f64>,
    /// Velocity of a lost track is multiplied by this every frame it stays lost, so a long-lost
    /// track's prediction does not drift away from where a stopped person reappears.
    /// Default 1 (no decay): on MOT15 people keep walking while occluded.
    pub lost_velocity_decay: f64,
    /// When a lost track is matched again, re-run its filter along the straight line from its
    /// last box to the new one (OC-SORT's observation-centric re-update), so it leaves the gap
    /// with the velocity the gap implies instead of the one it drifted on. Default true: on
    /// the robustness grid it ties the best objective (−0.02) and keeps one more cell ahead of
    /// every peer (27 of 33; see `tests/data/quality/README.md`).
    pub reupdate_after_gap: bool,
    /// Match lost tracks only after the tracks seen in the previous frame have taken their
    /// detections (DeepSORT's matching cascade, in two levels). Without it, lost and active
    /// tracks compete for the high detections in one assignment. Default false.
    pub lost_second: bool,
    /// Tentative tracks take part in the first association together with the confirmed (and
    /// lost) ones, as in ByteTrack, instead of getting what is left afterwards. Default false.
    pub tentative_first: bool,
    /// Lost tracks are matched only by the re-identification stage (its terms, gates and
    /// `reid_max_cost`), which then runs before the tentative tracks' stage; the main
    /// association is for tracks seen in the previous frame. Geometric costs of a lost track
    /// against what its prediction has drifted to mean little, and a lost track should be
    /// recognised by its appearance, not by a detection happening to lie where it was
    /// predicted. Default false (MOT15 boxes have no appearance); the mask preset turns it on.
    pub lost_reid_only: bool,
    /// With [`Config::lost_reid_only`], lost tracks last seen whole and missed for at most
    /// this many frames (at [`Config::frame_counts_at`] fps) still take part in the main
    /// association: a shape seen whole cannot have slid behind something in one frame, so the
    /// gap is a missed detection (a ragged mask in a crowd) and the prediction is still where
    /// the shape is; shapes last seen partly (going behind an occluder) and longer gaps are
    /// for re-identification by appearance. Default 0; the mask preset uses its coasting span
    /// (8): a track reported at its prediction is also matched there.
    pub lost_main_frames: u32,
    /// In the main association, a confirmed or lost track gives up a detection that a
    /// tentative track matched in the previous frame and before matches at a cost lower by more than this
    /// margin (see [`super::associate`]): the tentative tracks' own stage comes later, and a
    /// track sliding behind a new shape would otherwise take the new shape's view and swap
    /// with it. `None`: tentative tracks wait. Default `None`; the mask preset 0.1.
    pub defer_to_tentative: Option<f64>,
    /// The pair-cost terms of the main association. Default: IoU with the predicted box, mask
    /// IoU (masks only), and shape context + colour at 0.5/0.5 (when registered, with data).
    pub terms: Terms,
    /// The pair-cost terms of the re-identification stage: lost tracks × detections nobody else
    /// took, before those start new tracks. Default [`Terms::reid_default`]: IoU with the last
    /// observed box, plus appearance when available. All weights 0 disables the stage.
    pub reid_terms: Terms,
    /// When a tentative track is confirmed, first look for a lost track it re-identifies
    /// (re-identification terms and `reid_max_cost`, against the confirming detection): if
    /// one is found, the lost track takes over the tentative one and its earlier frames,
    /// under its old id. A shape reappearing from behind an occluder shows slivers first,
    /// too little to recognise it; `min_hits` frames later there is more to go on. Default
    /// false; the mask preset turns it on.
    pub reid_at_confirmation: bool,
    /// Highest combined re-identification cost accepted. Default 0.6.
    pub reid_max_cost: f64,
    /// Noise of the constant-velocity box Kalman filter. Default σp = 0.02, σv = 0.0125,
    /// σm = 0.1 (see [`crate::motion`]), per frame at [`Config::frame_counts_at`] frames
    /// per second (see [`Config::motion_per_second`]).
    pub motion: BoxKalmanParams,
    /// Mask features (shell, SIFT, colour, shape context) and when the tracker computes the
    /// appearance parts. Only mask detections with a frame get appearance.
    pub appearance: AppearanceConfig,
    /// How the shape context cost C1 fits its transform: Alg. 4 (contour, default) or Alg. 5
    /// (SIFT matches).
    pub shape_variant: ShapeVariant,
    /// SIFT matching (Lowe's ratio test) for the SIFT term and Alg. 5. Default ratio 0.8.
    pub sift_matching: MatchConfig,
    /// Fewest keypoints on both sides for the SIFT term to have data. Default 3.
    pub sift_min_keypoints: usize,
    /// Amodal completion: a mask detection much smaller than its track's reference area
    /// (below `appearance.whole_ratio`) is taken as partly hidden, and the filter is updated
    /// with the box of the whole shape, anchored on the detection's sides that agree with the
    /// prediction, so the velocity is not dragged by the occluder's edge. Box detections are
    /// completed only under [`Config::complete_cut_boxes`]. Default true.
    pub amodal: bool,
    /// With `amodal`, box detections are completed like masks once the sequence's own
    /// detections show that the detector boxes the visible part of a partly hidden object
    /// (boxes that nearer detections would cover come flatter than the others: see
    /// `track::cut_views`); a detector of whole boxes, or boxes with noise, is left as it is
    /// (completing its boxes cost up to 9 HOTA on the grid's street and sports cells). On the
    /// dense crowd's visible-part boxes (the grid's clean cell): online HOTA +4.1, offline
    /// +3.5 (IDF1 +6.6 / +4.5), the ragged cell −0.4 / −0.9; every other grid cell but
    /// MOT15's real detections (+0.05) unchanged (`tests/data/quality/README.md`). Default
    /// true.
    pub complete_cut_boxes: bool,
    /// With `amodal`, a matched mask detection whose area is below this fraction of its
    /// confirmed track's reference area (a sliver at an occluder's edge) does not correct the
    /// motion filter: the track keeps its predicted motion through the occlusion. Default 0.4.
    pub sliver_ratio: f64,
    /// Merge a matched mask detection with an unmatched one it touches, when together they
    /// make up the track's whole shape and no other track can take the second (a shape split
    /// in two by the detector). Default false; the mask preset turns it on.
    pub merge_fragments: bool,
    /// Frames a confirmed track that was last seen whole may go undetected and still be
    /// reported, at its predicted place with its last mask moved by the predicted motion
    /// (`interpolated: true`, `state: Lost`, no detection index): a shape seen whole cannot
    /// vanish behind an occluder in one frame, so a gap right after a whole view is a missed
    /// detection. Default 8 at [`Config::frame_counts_at`] fps (with [`Config::coasting`]:
    /// only while this tracker's own gaps of that length usually close, so the count is an
    /// upper bound, not a guess of every video's gaps); the mask preset ([`Config::masks`])
    /// uses 8, always.
    pub coast_frames: u32,
    /// Coast only when this tracker's history says a gap of the current length usually
    /// closes within `coast_frames` (see [`super::coasting`]). `None`: always coast up to
    /// `coast_frames` after a whole view. Default: coasting with
    /// [`Coasting::default`].
    pub coasting: Option<Coasting>,
    /// Frames per second of the video, when known (the CLI reads it from `seqinfo.ini`, the
    /// offline tracker is given it): frame counts that measure time ([`Config::max_lost`],
    /// [`Config::coast_frames`]) are scaled from [`Config::frame_counts_at`] to it, so a lost
    /// track is kept as long in seconds at 5 fps as at 30. `None`: counts are used as given.
    pub frame_rate: Option<f64>,
    /// Scale the motion filter's process noise with the time between frames: its σ are given
    /// per frame at [`Config::frame_counts_at`] fps, and at `fps` the position and velocity
    /// noise are multiplied by `frame_counts_at / fps` (objects change speed and heading more
    /// between two frames of a 5 fps video than of a 30 fps one). Needs
    /// [`Config::frame_rate`]. Default true.
    pub motion_per_second: bool,
    /// The frame rate those frame counts are given at. Default 30 (ByteTrack's convention:
    /// `track_buffer` 30 frames at 30 fps).
    pub frame_counts_at: f64,
    /// The box a track matched to a detection reports. Default [`ReportBox::Adaptive`]: the
    /// detection's box smoothed only as far as smoothing agrees with the following detections
    /// on this sequence — for mask detections too (the mask stays the detection's; a ragged,
    /// split or merged mask's box is a noisy measurement like a detector's box). Under
    /// `Detection` and `Filter` a mask detection reports its mask's box.
    pub report_box: ReportBox,
    /// Tracks unmatched in the last frame follow the camera: when the tracks that were matched
    /// agree on a common offset between their predictions and this frame's detections (a
    /// pan, a shake), the others are moved by it before association, so a lost track is looked
    /// for where the camera took it (see `track::camera`). Default true.
    pub camera_motion: bool,
}

impl Default for Config {
    /// Chosen on the robustness grid (`shapetrack grid`, `tests/data/quality/README.md`):
    /// MOT15, SportsMOT, BDD100K and synthetic scenes under eight detector models, by random
    /// and local search against the best of five peer trackers per cell, with
    /// leave-one-dataset-out figures as the estimate for unseen data. The mechanisms that
    /// adapt (score thresholds from the sequence's scores, evidence-based confirmation,
    /// coasting from the tracker's own gap statistics, time-based counts and motion noise)
    /// replace constants that fitted one detector.
    fn default() -> Self {
        Self {
            min_score: 0.0,
            high_score: 0.6,
            new_track_score: 0.9,
            // Thresholds from the sequence's own scores: a detector's calibration is not ours
            // to assume (MOT15's Faster R-CNN scores 0.85–1, a YOLO 0.3–0.9, a thresholded
            // browser detector a constant 1).
            score_adaptation: Some(ScoreAdaptation {
                high_quantile: 0.0,
                birth_quantile: 0.25,
                ..ScoreAdaptation::default()
            }),
            spawn_max_iou: 1.0,
            min_hits: 5,
            min_hits_floor: u32::MAX,
            birth_evidence: Some(0.5),
            max_tentative_misses: 1,
            max_lost: 38,
            max_lost_without_frames: None,
            report_tentative: true,
            hindsight: Some(Hindsight::default()),
            region_margin: 0.5,
            region_margin_per_miss: 0.1,
            max_cost: 0.75,
            // Chosen on the robustness grid, leave one dataset out (see the field).
            adaptive_gate: Some(1.5),
            reference_max_cost: None,
            max_cost_low: 0.5,
            low_extends_tentative: true,
            max_cost_tentative: 0.85,
            unmatched_cost: None,
            lost_velocity_decay: 1.0,
            reupdate_after_gap: true,
            lost_second: false,
            tentative_first: false,
            lost_reid_only: false,
            lost_main_frames: 0,
            defer_to_tentative: None,
            terms: Terms::default(),
            reid_terms: Terms::reid_default(),
            reid_at_confirmation: false,
            reid_max_cost: 0.6,
            // Steadier positions and livelier velocities than ByteTrack's 1/20 and 1/160 (people
            // and players change pace), and measurements trusted less than MOT15's boxes
            // would allow: other detectors' boxes jitter more.
            motion: BoxKalmanParams {
                std_position: 0.02,
                std_velocity: 0.0125,
                std_measurement: 0.1,
            },
            appearance: AppearanceConfig::default(),
            shape_variant: ShapeVariant::Contour,
            sift_matching: MatchConfig::default(),
            sift_min_keypoints: 3,
            amodal: true,
            complete_cut_boxes: true,
            sliver_ratio: 0.4,
            merge_fragments: false,
            coast_frames: 8,
            coasting: Some(Coasting::default()),
            frame_rate: None,
            motion_per_second: true,
            frame_counts_at: 30.0,
            report_box: ReportBox::Adaptive,
            camera_motion: true,
        }
    }
}

/// Largest [`Config::region_margin`] and [`Config::region_margin_per_miss`]: box sizes on
/// each side.
const MAX_MARGIN: f64 = 1000.0;

fn check(field: &str, value: f64, ok: bool, reason: &'static str) -> Result<(), TrackError> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(TrackError::InvalidConfig {
            field: field.to_string(),
            value,
            reason,
        })
    }
}

impl Config {
    /// Checks every value is finite and in range.
    pub fn validate(&self) -> Result<(), TrackError> {
        check("min_score", self.min_score, true, "must be finite")?;
        check("high_score", self.high_score, true, "must be finite")?;
        check(
            "new_track_score",
            self.new_track_score,
            true,
            "must be finite",
        )?;
        check(
            "min_hits",
            self.min_hits as f64,
            self.min_hits >= 1,
            "must be ≥ 1",
        )?;
        // A region a thousand box sizes wide on each side already reaches every detection of
        // any frame; far larger margins (1e300) overflow the grown box to infinity.
        let m = self.region_margin;
        check(
            "region_margin",
            m,
            (0.0..=MAX_MARGIN).contains(&m),
            "must be in [0, 1000]",
        )?;
        let m = self.region_margin_per_miss;
        check(
            "region_margin_per_miss",
            m,
            (0.0..=MAX_MARGIN).contains(&m),
            "must be in [0, 1000]",
        )?;
        for (field, v) in [
            ("max_cost", self.max_cost),
            ("max_cost_low", self.max_cost_low),
            ("max_cost_tentative", self.max_cost_tentative),
        ] {
            check(field, v, v >= 0.0, "must be ≥ 0")?;
        }
        if let Some(u) = self.unmatched_cost {
            check("unmatched_cost", u, u >= 0.0, "must be ≥ 0")?;
        }
        let d = self.lost_velocity_decay;
        check(
            "lost_velocity_decay",
            d,
            (0.0..=1.0).contains(&d),
            "must be in [0, 1]",
        )?;
        let r = self.sliver_ratio;
        check(
            "sliver_ratio",
            r,
            (0.0..=1.0).contains(&r),
            "must be in [0, 1]",
        )?;
        let r = self.reid_max_cost;
        check("reid_max_cost", r, r >= 0.0, "must be ≥ 0")?;
        if let Some(f) = self.frame_rate {
            check("frame_rate", f, f > 0.0, "must be > 0")?;
        }
        let f = self.frame_counts_at;
        check("frame_counts_at", f, f > 0.0, "must be > 0")?;
        for (section, terms) in [("terms", &self.terms), ("reid_terms", &self.reid_terms)] {
            for (name, t) in terms.named() {
                let w = t.weight;
                check(
                    &format!("{section}.{name}.weight"),
                    w,
                    w >= 0.0,
                    "must be ≥ 0",
                )?;
                let s = t.scale;
                check(
                    &format!("{section}.{name}.scale"),
                    s,
                    s > 0.0,
                    "must be > 0",
                )?;
                // Every term's cost is ≥ 0, so a negative gate refuses every pair.
                if let Some(g) = t.gate {
                    let field = format!("{section}.{name}.gate");
                    check(
                        &field,
                        g,
                        g >= 0.0,
                        "must be ≥ 0 (costs are never negative)",
                    )?;
                }
            }
        }
        // With every weight 0 the main association scores no pair and no track is ever
        // matched (re-identification may be off: its terms may all be 0).
        if self.terms.named().iter().all(|(_, t)| t.weight == 0.0) {
            check(
                "terms",
                0.0,
                false,
                "every weight is 0: no track could ever be matched (give one term a weight > 0)",
            )?;
        }
        if let Some(m) = self.defer_to_tentative {
            check("defer_to_tentative", m, m >= 0.0, "must be ≥ 0")?;
        }
        if let Some(w) = self.birth_evidence {
            check(
                "birth_evidence",
                w,
                w > 0.0 && w <= 1.0,
                "must be in (0, 1]",
            )?;
        }
        let sub = |(field, value, reason): (&str, f64, &'static str)| TrackError::InvalidConfig {
            field: field.to_string(),
            value,
            reason,
        };
        if let Some(a) = &self.coasting {
            a.validate().map_err(sub)?;
        }
        if let Some(k) = self.adaptive_gate {
            check("adaptive_gate", k, k > 0.0, "must be > 0")?;
        }
        if let Some(a) = &self.hindsight {
            a.validate().map_err(sub)?;
        }
        if let Some(a) = &self.score_adaptation {
            a.validate().map_err(sub)?;
        }
        if let Some(g) = self.reference_max_cost {
            check("reference_max_cost", g, g >= 0.0, "must be ≥ 0")?;
        }
        self.motion.validate()?;
        self.appearance.validate().map_err(sub)?;
        Ok(())
    }

    /// The main association's gate at the video's frame rate: `max_cost`, or
    /// [`Config::reference_max_cost`] scaled by `frame_counts_at / frame_rate` when both are
    /// known, at most `max_cost`.
    pub fn main_max_cost(&self) -> f64 {
        match (self.reference_max_cost, self.frame_rate) {
            (Some(g), Some(fps)) if fps > 0.0 => {
                (g * self.frame_counts_at / fps).min(self.max_cost)
            }
            _ => self.max_cost,
        }
    }

    /// The rules for a frame tracked without its image: no appearance can re-identify a lost
    /// track, so lost tracks take part in the main association as in box mode
    /// (`lost_reid_only` off: the re-identification stage alone would match them by their
    /// predicted box only) and stay lost [`Config::max_lost_without_frames`] frames. BDD100K's
    /// real masks (5 fps, no frames) with the mask preset: HOTA online 61.05 → 61.91, offline
    /// 60.96 → 62.46, above box mode's 61.74 / 61.82 (`shapetrack grid eval --datasets
    /// bdd-masks --input both`); no other grid cell tracks masks without frames.
    pub fn without_frames(&self) -> Config {
        Config {
            lost_reid_only: false,
            max_lost: self.max_lost_without_frames.unwrap_or(self.max_lost),
            ..self.clone()
        }
    }

    /// Frames a confirmed track stays lost before it is removed, at the video's frame rate,
    /// on a frame given with its image (`has_frame`: [`Config::max_lost`]) or without
    /// ([`Config::without_frames`]).
    pub fn max_lost_frames(&self, has_frame: bool) -> u32 {
        let n = match (has_frame, self.max_lost_without_frames) {
            (false, Some(n)) => n,
            _ => self.max_lost,
        };
        self.frames(n)
    }

    /// `frames` (a count given at [`Config::frame_counts_at`] fps) at the video's frame rate:
    /// scaled and rounded when [`Config::frame_rate`] is known, at least 1 when `frames` is.
    pub fn frames(&self, frames: u32) -> u32 {
        match self.frame_rate {
            Some(fps) if frames > 0 => {
                let n = (frames as f64 * fps / self.frame_counts_at).round();
                (n.clamp(1.0, u32::MAX as f64)) as u32
            }
            _ => frames,
        }
    }

    /// The motion filter's noise at the video's frame rate (see
    /// [`Config::motion_per_second`]).
    pub fn motion_params(&self) -> BoxKalmanParams {
        match (self.motion_per_second, self.frame_rate) {
            (true, Some(fps)) => {
                let k = self.frame_counts_at / fps;
                BoxKalmanParams {
                    std_position: self.motion.std_position * k,
                    std_velocity: self.motion.std_velocity * k,
                    ..self.motion
                }
            }
            _ => self.motion,
        }
    }

    /// Matches a tentative track needs to be confirmed at the video's frame rate:
    /// [`Config::min_hits`] scaled like the other frame counts, at least
    /// [`Config::min_hits_floor`] (and never more than `min_hits`).
    pub fn confirm_hits(&self) -> u32 {
        self.frames(self.min_hits)
            .max(self.min_hits_floor)
            .min(self.min_hits.max(1))
    }

    /// The appearance parts the enabled terms read (the tracker computes only those).
    pub fn appearance_needs(&self) -> Needs {
        let on = |f: fn(&Terms) -> f64| f(&self.terms) > 0.0 || f(&self.reid_terms) > 0.0;
        let shape = on(|t| t.shape_context.weight);
        Needs {
            shape,
            sift: on(|t| t.sift.weight) || (shape && self.shape_variant == ShapeVariant::Sift),
            colour: on(|t| t.colour.weight),
        }
    }

    /// Reads a config from JSON; missing fields take their defaults, unknown fields are errors.
    pub fn from_json(text: &str) -> Result<Config, serde_json::Error> {
        Config::default().overlay_json(text)
    }

    /// This config with the fields a JSON object names replaced, nested objects merged field
    /// by field (`{"terms": {"iou": {"weight": 2}}}` changes one weight and keeps the rest of
    /// `self`, not of the defaults). Unknown fields are errors, and every error names its
    /// field (see [`crate::settings::overlay`]). This is how a partial config applies over a
    /// preset such as [`Config::masks`].
    pub fn overlay(&self, patch: &serde_json::Value) -> Result<Config, serde_json::Error> {
        crate::settings::overlay(self, patch)
    }

    /// [`Config::overlay`] from JSON text.
    pub fn overlay_json(&self, text: &str) -> Result<Config, serde_json::Error> {
        self.overlay(&serde_json::from_str(text)?)
    }

    /// A config from a settings object as people write it: an optional `"preset"`
    /// (`"default"` or `"masks"`; `preset` when absent) and any fields of [`Config`] over it.
    /// The CLI's `--config` files and the browser's settings objects both come through here.
    pub fn from_settings(
        preset: Preset,
        v: &serde_json::Value,
    ) -> Result<Config, serde_json::Error> {
        use serde::de::Error as _;
        let serde_json::Value::Object(map) = v else {
            return Err(serde_json::Error::custom("settings must be a JSON object"));
        };
        let mut patch = map.clone();
        let preset = match patch.remove("preset") {
            None => preset,
            Some(p) => serde_json::from_value(p)
                .map_err(|e| serde_json::Error::custom(format!("preset: {e}")))?,
        };
        preset.config().overlay(&serde_json::Value::Object(patch))
    }
}

pub use crate::settings::check_shape;

#[cfg(test)]
#[path = "config_tests.rs"]
mod tests;
