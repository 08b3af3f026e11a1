//! Configuration of the offline pass: the re-linker, gap filling and appearance snapshots.
//!
//! Every field has a default (one global configuration, chosen on six MOT15-train sequences and
//! checked on the other five, see `tests/data/quality/README.md`), so a JSON config only needs
//! the fields it changes. Times are in seconds where the quantity is physical (how long an
//! object may stay hidden, how fast the gate grows), so one config fits 7 fps and 30 fps
//! videos alike; they become frames through the sequence's `fps`.

use super::OfflineError;
use crate::features::sift::{MatchConfig, SiftConfig};
use crate::track::Config;
use serde::{Deserialize, Serialize};

/// How the joins are chosen among all (slave, master) candidate pairs.
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JoinSolver {
    /// Min-cost matching over all candidate pairs at once (`lsap`): the joins minimise
    /// `Σ (cost − 1)`, so every allowed pair is worth taking, but never at the price of two
    /// others. Default.
    Global,
    /// The thesis' order: masters from the end of the sequence backwards, each taking its
    /// cheapest slave not taken yet. Kept to show (and test) where it fails.
    Greedy,
}

/// Which trajectory filled-in shapes follow between the two ends of a gap.
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Trajectory {
    /// The centroid moves on the straight line between the last shape before the gap and the
    /// first one after it, at constant speed. Default (see [`FillConfig::trajectory`]).
    Linear,
    /// A two-sided constant-acceleration Kalman bridge: the rollout from before the gap (eq.
    /// 44–52) and the backward rollout from after it, blended linearly in time so that the path
    /// leaves and reaches both ends exactly.
    Kalman,
}

/// The Kalman trajectory re-linker (thesis ch. 5, DESIGN §3).
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RelinkConfig {
    /// A slave must end at most this long (seconds) before its master starts. Default 5.
    pub max_gap_seconds: f64,
    /// Slaves kept per master, the most recently ended first (the thesis' "up to 5").
    /// Default 5.
    pub max_slaves: usize,
    /// Of those, the ones with the most SIFT connections to the master that are kept, when
    /// both have appearance snapshots (the thesis' "up to two"). Default 2. Without
    /// snapshots (box mode, no frames) the appearance step drops out.
    pub appearance_keep: usize,
    /// Length of the centroid history (seconds, at least three points when the track has them)
    /// from which velocity and mean acceleration are estimated. Default 1.5.
    pub history_seconds: f64,
    /// Shapes smaller than this fraction of the median size near a track's end are not used to
    /// estimate its motion (they are entering or leaving an occlusion); the end is anchored at
    /// the outermost shape that is used. 0 uses every shape. Default 0.8.
    pub reliable_size: f64,
    /// Multiplies the estimated mean acceleration before the rollout: 1 is the thesis, 0 turns
    /// the filter into a constant-velocity one. Default 0 (see the module docs of
    /// [`crate::track::offline`] for why).
    pub acceleration: f64,
    /// Also roll the master back from its start to the slave's end and average both errors.
    /// Default true.
    pub bidirectional: bool,
    /// Gate radius at zero gap, in units of the shape's size `sqrt(w·h)`. Default 0.75.
    pub gate_base: f64,
    /// Growth of the gate radius per second of gap, in units of the shape's size. Default
    /// 0.25.
    pub gate_per_second: f64,
    /// Widen the gate to this sequence's own motion: the sequence's tracks are cut with
    /// artificial gaps (0.2–2 s), both sides' ends estimated as for a real pair, and the gate
    /// is multiplied by the quantile `calibrate` of their errors over its radius (never
    /// narrowed, widened at most 4×; unchanged with fewer than 20 cuts). `None`: the gate as
    /// configured. Default `Some(0.7)`.
    ///
    /// The fixed gate (0.5 + 0.5/s) was chosen on MOT15's pedestrians; players on SportsMOT
    /// turn and sprint, and their true continuations fell outside it. On the box grid
    /// (offline, 33 cells) mean HOTA 59.94 → 60.42 with this gate and the defaults above
    /// (SportsMOT +1.24, synthetic +0.39, MOT15 +0.25, BDD100K +0.19, worst cell −0.15); a
    /// fixed wider gate gained more on SportsMOT and synthetic scenes but lost on MOT15 and
    /// BDD100K (`tests/data/quality/README.md`).
    pub calibrate: Option<f64>,
    /// Largest ratio of the two ends' sizes `sqrt(w·h)` (medians near each end) a join
    /// accepts. Default 1.2.
    pub max_size_ratio: f64,
    /// How joins are chosen. Default [`JoinSolver::Global`].
    pub solver: JoinSolver,
    /// When the image size is known, refuse a pair whose predicted path (forward from the
    /// slave, and backward from the master when `bidirectional`) leaves the image: the object
    /// went out of view, and whoever appears later is someone else. Default true.
    pub stay_in_view: bool,
}

impl Default for RelinkConfig {
    fn default() -> Self {
        Self {
            max_gap_seconds: 5.0,
            max_slaves: 5,
            appearance_keep: 2,
            history_seconds: 1.5,
            reliable_size: 0.8,
            acceleration: 0.0,
            bidirectional: true,
            gate_base: 0.75,
            gate_per_second: 0.25,
            calibrate: Some(0.7),
            max_size_ratio: 1.2,
            solver: JoinSolver::Global,
            stay_in_view: true,
        }
    }
}

/// The offline boxes: each track's detections smoothed with the whole track known, as far as
/// the sequence shows smoothing helps (see [`super::smooth`]).
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SmoothConfig {
    /// Smooth the boxes. Default true.
    pub enabled: bool,
    /// A detection whose left-out residual is beyond this many robust standard deviations is
    /// down-weighted (Huber). Default 2.5.
    pub huber: f64,
    /// Times the Huber weights are re-fitted (0: plain least squares). Default 2.
    pub reweight: u32,
    /// A coordinate is smoothed only when its best smoother's left-out error is at most this
    /// share of the lightest smoother's (the detections are kept otherwise). Default 0.8.
    pub min_gain: f64,
    /// Shortest run of consecutive observed frames smoothed (at least 3). Default 3.
    pub min_run: u32,
}

impl Default for SmoothConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            huber: 2.5,
            reweight: 2,
            min_gain: 0.8,
            min_run: 3,
        }
    }
}

/// Gap filling: shapes invented between two observed shapes of one identity.
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FillConfig {
    /// Longest gap filled, in missing frames; longer gaps stay empty. 0 disables filling.
    /// Default 10: on MOT15 longer fills added more false boxes than they recovered (people
    /// hidden that long are mostly not annotated), lowering MOTA.
    pub max_gap: u32,
    /// Also fill the gaps the online tracker left inside one track (lost, then re-identified),
    /// not only those between joined tracks. Default true.
    pub within_tracks: bool,
    /// Path of the filled shapes. Default [`Trajectory::Linear`].
    pub trajectory: Trajectory,
    /// Longest gap filled in seconds instead of frames (`max_gap` then does not apply): a
    /// gap of 10 frames is a blink at 30 fps and two seconds at 5 fps. `None`: `max_gap`.
    pub max_gap_seconds: Option<f64>,
    /// Gaps between two *partial* mask views are hides, not missed detections, and are not
    /// filled: both the shape before the gap and the one after it have a mask smaller than
    /// this fraction of the median mask area of the identity's shapes near that end (it was
    /// going behind something and coming out again), on the reasoning that masks are visible
    /// parts (MOTS, DAVIS, COCO-video) and a mask for a shape nobody can see would be wrong.
    /// Box-only shapes are always filled. 0 fills hides too. Default 0: measured, such gaps
    /// were mostly a partly visible shape the detector missed, not a hidden one (mask cells
    /// offline, mean HOTA +0.17 with 0 instead of 0.5, occluders +0.8, no cell below −0.03,
    /// BDD100K's real masks unchanged).
    pub hidden_ratio: f64,
    /// Keep the online pass's coasted shapes (its predictions while a track was missed) after
    /// an identity's last observation. Default false: offline, that identity is known never
    /// to have been seen again, and its predictions past the last observation were more often
    /// false boxes than a missed object (box grid, offline mean HOTA 59.03 → 59.14; mask cells
    /// 72.25 → 72.33; `tests/data/quality/README.md`). Coasted shapes inside a track are
    /// replaced by the fill where one is made, whatever this says.
    pub coasted_tails: bool,
    /// A mask filled into a gap is the nearer end's mask scaled (about its centroid, each axis
    /// apart) to the box size interpolated between the two ends, then moved along the path, so
    /// a shape that grows as it enters the frame or comes closer is filled at the size between.
    /// `false`: translated only. Needs the image size (known with frames or a sequence size).
    /// Default true: on the grid's 13 mask cells offline mean HOTA 74.99 → 75.52, 11 cells up,
    /// one down by 0.12 (`tests/data/quality/README.md`).
    pub scale_masks: bool,
}

impl Default for FillConfig {
    fn default() -> Self {
        Self {
            max_gap: 10,
            within_tracks: true,
            trajectory: Trajectory::Linear,
            max_gap_seconds: None,
            hidden_ratio: 0.0,
            coasted_tails: false,
            scale_masks: true,
        }
    }
}

/// Appearance snapshots: a grey crop of each track's first and last appearance, kept during
/// the online pass so the video need not stay in memory, and matched with SIFT at the end.
#[cfg_attr(
    target_arch = "wasm32",
    derive(tsify::Tsify),
    tsify(rename = "SnapshotConfig", missing_as_null)
)]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AppearanceConfig {
    /// Take snapshots at all (only when frames are given). Default true.
    pub enabled: bool,
    /// Crops whose longer side exceeds this are downscaled to it before they are stored, which
    /// bounds the memory per track (2 crops of at most `max_side²` bytes, plus their masks).
    /// Default 128.
    pub max_side: u32,
    /// SIFT detector settings for the snapshots. Default: OpenCV's defaults.
    pub sift: SiftConfig,
    /// Descriptor matching: a "connection" is a match passing Lowe's ratio test. Default ratio
    /// 0.8.
    pub matching: MatchConfig,
}

impl Default for AppearanceConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            max_side: 128,
            sift: SiftConfig::default(),
            matching: MatchConfig::default(),
        }
    }
}

/// Everything the offline pass can be told: the online tracker's config plus the offline
/// stages'. `{}` is a valid JSON config (all defaults).
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OfflineConfig {
    /// The online pass.
    // tsify names a field's type by its Rust name; these two are renamed in TypeScript.
    #[cfg_attr(target_arch = "wasm32", tsify(type = "TrackConfig"))]
    pub online: Config,
    /// The re-linker.
    pub relink: RelinkConfig,
    /// Gap filling.
    pub fill: FillConfig,
    /// The boxes of observed shapes, smoothed over each track.
    pub smooth: SmoothConfig,
    /// Appearance snapshots.
    #[cfg_attr(target_arch = "wasm32", tsify(type = "SnapshotConfig"))]
    pub appearance: AppearanceConfig,
    /// Identities with fewer observed (not filled-in) shapes than this many seconds' worth of
    /// frames after joining are dropped: a short track nothing re-joined is most likely a
    /// false one. Default 0 (keep every identity).
    pub min_track_seconds: f64,
}

impl FillConfig {
    /// The longest gap filled, in frames, at `fps`.
    pub fn max_gap_frames(&self, fps: f64) -> u32 {
        match self.max_gap_seconds {
            Some(s) if s.is_finite() && fps.is_finite() => (s * fps).round().clamp(0.0, 1e6) as u32,
            Some(_) => 0,
            None => self.max_gap,
        }
    }
}

impl Default for OfflineConfig {
    fn default() -> Self {
        Self {
            online: Config::default(),
            relink: RelinkConfig::default(),
            fill: FillConfig::default(),
            smooth: SmoothConfig::default(),
            appearance: AppearanceConfig::default(),
            min_track_seconds: 0.0,
        }
    }
}

fn check(
    field: &'static str,
    value: f64,
    ok: bool,
    reason: &'static str,
) -> Result<(), OfflineError> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(OfflineError::InvalidConfig {
            field,
            value,
            reason,
        })
    }
}

impl OfflineConfig {
    /// Checks every value is finite and in range (the online part included).
    pub fn validate(&self) -> Result<(), OfflineError> {
        self.online.validate()?;
        let m = &self.smooth;
        let v = m.huber;
        check("smooth.huber", v, v > 0.0, "must be > 0")?;
        let v = m.min_gain;
        check(
            "smooth.min_gain",
            v,
            v > 0.0 && v <= 1.0,
            "must be in (0, 1]",
        )?;
        let v = m.reweight as f64;
        check("smooth.reweight", v, v <= 10.0, "must be ≤ 10")?;
        let r = &self.relink;
        let v = r.max_gap_seconds;
        check("relink.max_gap_seconds", v, v >= 0.0, "must be ≥ 0")?;
        let v = r.history_seconds;
        check("relink.history_seconds", v, v >= 0.0, "must be ≥ 0")?;
        let v = r.reliable_size;
        check(
            "relink.reliable_size",
            v,
            (0.0..=1.0).contains(&v),
            "must be in [0, 1]",
        )?;
        let v = r.acceleration;
        check("relink.acceleration", v, v >= 0.0, "must be ≥ 0")?;
        let v = r.gate_base;
        check("relink.gate_base", v, v >= 0.0, "must be ≥ 0")?;
        let v = r.gate_per_second;
        check("relink.gate_per_second", v, v >= 0.0, "must be ≥ 0")?;
        if let Some(q) = r.calibrate {
            check(
                "relink.calibrate",
                q,
                (0.0..=1.0).contains(&q),
                "must be in [0, 1]",
            )?;
        }
        let v = r.max_size_ratio;
        check("relink.max_size_ratio", v, v >= 1.0, "must be ≥ 1")?;
        let v = self.fill.hidden_ratio;
        check(
            "fill.hidden_ratio",
            v,
            (0.0..=1.0).contains(&v),
            "must be in [0, 1]",
        )?;
        if let Some(v) = self.fill.max_gap_seconds {
            check("fill.max_gap_seconds", v, v >= 0.0, "must be ≥ 0")?;
        }
        let v = self.min_track_seconds;
        check("min_track_seconds", v, v >= 0.0, "must be ≥ 0")?;
        let v = self.appearance.max_side as f64;
        check("appearance.max_side", v, v >= 8.0, "must be ≥ 8")?;
        self.appearance.sift.validate()?;
        Ok(())
    }

    /// Reads a config from JSON; missing fields take their defaults, unknown fields are errors.
    pub fn from_json(text: &str) -> Result<OfflineConfig, serde_json::Error> {
        Self::from_value(serde_json::from_str(text)?)
    }

    /// [`OfflineConfig::from_json`] from a parsed value: a partial config over the defaults
    /// (see [`crate::settings::overlay`]; errors name the field).
    pub fn from_value(v: serde_json::Value) -> Result<OfflineConfig, serde_json::Error> {
        crate::settings::overlay(&OfflineConfig::default(), &v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_is_valid_and_partial_json_keeps_defaults() {
        let c = OfflineConfig::default();
        c.validate().unwrap();
        let s = serde_json::to_string(&c).unwrap();
        assert_eq!(OfflineConfig::from_json(&s).unwrap(), c);
        let p = OfflineConfig::from_json(
            r#"{"relink": {"max_slaves": 3, "solver": "greedy"}, "fill": {"max_gap": 0}}"#,
        )
        .unwrap();
        assert_eq!(p.relink.max_slaves, 3);
        assert_eq!(p.relink.solver, JoinSolver::Greedy);
        assert_eq!(p.relink.gate_base, c.relink.gate_base);
        assert_eq!(p.fill.max_gap, 0);
        assert!(OfflineConfig::from_json(r#"{"relink": {"max_slave": 3}}"#).is_err());
    }

    #[test]
    fn rejects_out_of_range_values() {
        let mut c = OfflineConfig::default();
        c.relink.max_size_ratio = 0.5;
        assert!(matches!(
            c.validate(),
            Err(OfflineError::InvalidConfig {
                field: "relink.max_size_ratio",
                ..
            })
        ));
        let mut c = OfflineConfig::default();
        c.relink.gate_base = f64::NAN;
        assert!(c.validate().is_err());
        for q in [1.5, -0.1, f64::NAN] {
            let mut c = OfflineConfig::default();
            c.relink.calibrate = Some(q);
            assert!(matches!(
                c.validate(),
                Err(OfflineError::InvalidConfig {
                    field: "relink.calibrate",
                    ..
                })
            ));
        }
        let mut c = OfflineConfig::default();
        c.online.min_hits = 0;
        assert!(matches!(c.validate(), Err(OfflineError::Track(_))));
    }
}
