//! The offline mode (thesis ch. 5, DESIGN §3): the whole sequence is known, so after the online
//! pass a Kalman trajectory re-linker joins tracks broken by occlusions or missed detections,
//! and the gaps are filled with shapes marked interpolated.
//!
//! ```text
//! online pass (+ appearance snapshots) → candidates → appearance (SIFT) → matching → filling
//! ```
//!
//! - [`OfflineTracker`]: feed frames one at a time ([`OfflineTracker::push_frame`], the online
//!   pass; with frames it also keeps each track's first and last appearance, see
//!   [`appearance`]), then [`OfflineTracker::finish`] runs the offline stages. This is the API a
//!   front end binds: it owns no frames, reports [`Progress`] (phase + fraction) through a
//!   callback, and returns plain data. It keeps the online output in a [`History`]: the shapes
//!   as they are, or with masks as RLE ([`RleHistory`]: the browser bindings run the pass through
//!   it, [`OfflineTracker::relink`] then [`OfflineTracker::apply`]).
//! - [`track_offline`]: the same over a whole sequence of detections without images (box mode).
//! - [`relink()`]: the offline stages alone, over any finished online output.
//!
//! **Joining** ([`mod@relink`] module): for each master (a track starting after the
//! first frame), up to [`RelinkConfig::max_slaves`] slaves that ended shortly before and never
//! overlap it, the [`RelinkConfig::appearance_keep`] with the most SIFT connections, a
//! constant-acceleration Kalman rollout (eq. 44–52, `Δt = 1/fps`) from each slave's end to the
//! master's start, a gate that grows with the gap; then all joins are chosen together by
//! min-cost matching ([`JoinSolver::Global`]) rather than greedily. A track is slave of at most
//! one master and master of at most one slave, and a slave always ends before its master
//! starts, so chains `A → B → C` form naturally and a joined identity never has two shapes in
//! one frame. The joined identity keeps the id of its first track.
//!
//! **Filling** ([`fill`] module): gaps of at most [`FillConfig::max_gap`] frames
//! between two shapes of one identity get boxes (and translated masks) along the trajectory,
//! with `interpolated = true` (COCO-video and CVAT exports carry the flag; MOT/MOTS text
//! cannot).
//!
//! **Coasting**: the online pass's coasted shapes (its predictions while a track was missed,
//! marked interpolated) are not observations. Joins and fills see observed shapes only; a
//! coasted shape stays where no observed or filled shape of its final identity covers its
//! frame, and is dropped past the identity's last observation unless
//! [`FillConfig::coasted_tails`] ([`OfflineResult::coasted_dropped`] counts what went).
//!
//! **Where this departs from the thesis, and why** (measured on MOT15-train, box mode, with
//! parameters chosen on six sequences and checked on the other five, and on synthetic
//! occlusion scenes; `tests/data/quality/README.md` has the numbers):
//!
//! - Joins are chosen together by min-cost matching, not master by master from the end.
//! - The "up to 5" slaves are the most recent among those passing the gates, so a crowd of
//!   tracks ending far away cannot push the right one out.
//! - A shape entering or leaving an occlusion is a shrinking sliver whose centroid lags the
//!   object: the ends are anchored at the outermost full-size shape
//!   ([`RelinkConfig::reliable_size`]) and sizes are medians, which is what made joins across
//!   bars work at all.
//! - Velocity and mean acceleration are least-squares fits over [`RelinkConfig::history_seconds`]
//!   (equal to the thesis' mean second difference on exact data; robust to lost frames). The
//!   acceleration from a 1.5-second history of detector boxes is mostly noise that `½·a·t²`
//!   blows up over a multi-second gap, so the rollout's control input is scaled by
//!   [`RelinkConfig::acceleration`], default 0 (the filter then carries constant velocity;
//!   1 is the thesis, and scored lower on both data sets).
//! - The error is averaged with the master's backward rollout ([`RelinkConfig::bidirectional`]),
//!   and paths leaving the image are refused ([`RelinkConfig::stay_in_view`]).
//! - The fill follows the straight line between the two observed ends ([`Trajectory::Linear`]),
//!   which scored at least as well as the Kalman bridge and never leaves the segment between
//!   two real observations.

pub mod appearance;
pub mod blocks;
pub mod config;
pub mod fill;
pub mod history;
pub mod relink;
pub mod smooth;

pub use appearance::{Snapshot, Snapshots};
pub use config::{
    AppearanceConfig, FillConfig, JoinSolver, OfflineConfig, RelinkConfig, SmoothConfig, Trajectory,
};
pub use history::{History, KeptMasks, OfflineInput, RleHistory, RleShape};
pub use relink::{fit_motion, rollout_backward, rollout_forward, EndState, Join};

use super::{TrackError, Tracker};
use crate::assign::AssignError;
use crate::features::sift::SiftError;
use crate::frame::{BBox, Detection, Frame, TrackedShape};
use crate::motion::MotionError;
use appearance::FeatureCache;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Errors of the offline pass.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum OfflineError {
    /// The online pass failed (bad detections, bad online config).
    #[error("online pass: {0}")]
    Track(#[from] TrackError),
    /// The Kalman rollout rejected its input.
    #[error("trajectory filter: {0}")]
    Motion(#[from] MotionError),
    /// The join matching failed.
    #[error("join assignment: {0}")]
    Assign(#[from] AssignError),
    /// SIFT on a snapshot failed.
    #[error("appearance: {0}")]
    Sift(#[from] SiftError),
    /// A configuration value is out of range.
    #[error("config: {field} = {}: {reason}", crate::settings::Short::of(.value))]
    InvalidConfig {
        /// Which field (dotted path).
        field: &'static str,
        /// The value given.
        value: f64,
        /// What is wrong.
        reason: &'static str,
    },
    /// The frame rate is not a positive finite number.
    #[error("fps = {fps}: must be finite and > 0")]
    InvalidFps {
        /// The value given.
        fps: f64,
    },
    /// The fill would make more than its budget: more shapes, or more mask pixels, than the
    /// input justifies (see [`fill::fill_budget`]). A setting such as `fill.max_gap` of 10⁹
    /// over a sparse input would otherwise allocate what the setting claims, not what the
    /// input holds.
    #[error(
        "fill: the gaps to fill need more than {cap} {what} (the budget for this input); \
         lower fill.max_gap or fill.max_gap_seconds"
    )]
    FillBudget {
        /// What ran out: "shapes" or "mask pixels".
        what: &'static str,
        /// The budget.
        cap: u64,
    },
    /// A shape handed to [`relink()`] is unusable.
    #[error("shape of id {id} in frame {frame}: {reason}")]
    InvalidShape {
        /// Its id.
        id: u64,
        /// Its frame.
        frame: u32,
        /// What is wrong.
        reason: &'static str,
    },
}

/// The stages of the offline pass, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Phase {
    /// The online tracker over every frame.
    Online,
    /// Candidate (slave, master) pairs: gates and Kalman rollouts.
    Candidates,
    /// SIFT connections between the candidates' snapshots (only with frames).
    Appearance,
    /// The join matching.
    Matching,
    /// Gap filling.
    Filling,
    /// Finished.
    Done,
}

/// A progress report: the current phase and how far it is, in `[0, 1]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Progress {
    /// Current phase.
    pub phase: Phase,
    /// Fraction of the phase done.
    pub fraction: f64,
}

/// What the offline pass returns.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OfflineResult {
    /// Every shape, observed and filled in, sorted by (frame, id). Observed shapes are the
    /// online pass's, unchanged but for their id.
    pub shapes: Vec<TrackedShape>,
    /// The joins made, by the master's first frame.
    pub joins: Vec<Join>,
    /// Number of shapes the fill made (`interpolated = true`). The online pass's coasted
    /// shapes that stay are interpolated too, and not counted here.
    pub filled: usize,
    /// How many of the online pass's coasted shapes (its predictions during misses) were
    /// left out: replaced by a fill or by an observation of the joined identity, past the
    /// identity's last observation (see [`FillConfig::coasted_tails`]), or in an identity
    /// too short to keep. With `min_track_seconds` 0 (the default), output shapes = input
    /// shapes + `filled` − `coasted_dropped`.
    #[serde(default)]
    pub coasted_dropped: usize,
}

impl OfflineResult {
    /// The id each online id ended up with (online ids not listed kept theirs).
    pub fn id_map(&self) -> std::collections::BTreeMap<u64, u64> {
        let mut parent: std::collections::BTreeMap<u64, u64> =
            self.joins.iter().map(|j| (j.master, j.slave)).collect();
        let keys: Vec<u64> = parent.keys().copied().collect();
        for k in keys {
            let mut root = k;
            // Chains only go back in time, so this terminates; the bound guards bad input.
            for _ in 0..=self.joins.len() {
                match parent.get(&root) {
                    Some(&p) if p != root => root = p,
                    _ => break,
                }
            }
            parent.insert(k, root);
        }
        parent
    }
}

fn check_fps(fps: f64) -> Result<(), OfflineError> {
    if fps.is_finite() && fps > 0.0 {
        Ok(())
    } else {
        Err(OfflineError::InvalidFps { fps })
    }
}

/// What the offline pass needs to know about the video besides its shapes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SequenceInfo {
    /// Frames per second: the re-linker's filter steps `Δt = 1/fps`.
    pub fps: f64,
    /// Image width and height in pixels, when known: a join whose predicted path leaves the
    /// image is refused (see [`RelinkConfig::stay_in_view`]).
    pub image_size: Option<(u32, u32)>,
}

impl SequenceInfo {
    /// A sequence at `fps` frames per second, image size unknown.
    pub fn new(fps: f64) -> Self {
        Self {
            fps,
            image_size: None,
        }
    }

    /// The same with an image size.
    pub fn with_image_size(self, width: u32, height: u32) -> Self {
        Self {
            image_size: Some((width, height)),
            ..self
        }
    }
}

/// The offline stages over a finished online output: appearance (when `snapshots` are given),
/// linking, filling. `shapes` are the online tracker's shapes (any order); `seq.fps` gives
/// `Δt = 1/fps`. Shapes with a non-finite or negative box, or two shapes with the same
/// (frame, id), are errors.
pub fn relink(
    shapes: Vec<TrackedShape>,
    snapshots: Option<&Snapshots>,
    config: &OfflineConfig,
    seq: &SequenceInfo,
    progress: &mut dyn FnMut(Progress),
) -> Result<OfflineResult, OfflineError> {
    relink_input(
        OfflineInput::from_shapes(shapes),
        snapshots,
        config,
        seq,
        progress,
    )
}

/// [`relink()`] over an [`OfflineInput`]: shapes whose masks may be carried as areas only
/// (what a compact [`History`] gives). The result is the same as over the full bitmaps as
/// long as the shapes at the ends of each track's runs of frames carry theirs.
pub fn relink_input(
    input: OfflineInput,
    snapshots: Option<&Snapshots>,
    config: &OfflineConfig,
    seq: &SequenceInfo,
    progress: &mut dyn FnMut(Progress),
) -> Result<OfflineResult, OfflineError> {
    relink_measured(
        input,
        DetectionBoxes::new(),
        snapshots,
        config,
        seq,
        progress,
    )
}

/// The detection boxes of the online pass's shapes, as ((id, frame), box): what the offline
/// smoother measures ([`smooth`]), where a shape reports a box the online tracker
/// smoothed. (A sorted list rather than a map: it is looked up once per shape, and a new map
/// type costs the browser build more code than the smoother itself.)
type DetectionBoxes = Vec<((u64, u32), BBox)>;

/// [`relink_input`] with each shape's detection box where known (`measured`, in any order; a
/// shape without one is measured by its own box).
fn relink_measured(
    input: OfflineInput,
    mut measured: DetectionBoxes,
    snapshots: Option<&Snapshots>,
    config: &OfflineConfig,
    seq: &SequenceInfo,
    progress: &mut dyn FnMut(Progress),
) -> Result<OfflineResult, OfflineError> {
    let OfflineInput { shapes, mask_areas } = input;
    config.validate()?;
    check_fps(seq.fps)?;
    let fps = seq.fps;
    let mut seen = std::collections::HashSet::with_capacity(shapes.len());
    for s in &shapes {
        let ok = s.bbox.is_valid()
            && s.centroid.x.is_finite()
            && s.centroid.y.is_finite()
            && s.bbox
                .x
                .abs()
                .max(s.bbox.y.abs())
                .max(s.bbox.w)
                .max(s.bbox.h)
                <= 1e9;
        if !ok {
            return Err(OfflineError::InvalidShape {
                id: s.id,
                frame: s.frame,
                reason: "box or centroid is not finite, is negative in size, or beyond ±1e9",
            });
        }
        if !seen.insert((s.frame, s.id)) {
            return Err(OfflineError::InvalidShape {
                id: s.id,
                frame: s.frame,
                reason: "two shapes share this (frame, id)",
            });
        }
    }
    drop(seen);

    // The online pass's coasted shapes (its predictions during misses, marked interpolated)
    // carry no evidence: joins and fills work on observed shapes only, and a coasted shape
    // stays only where no observed or filled shape of its final identity covers the frame
    // (and, unless `fill.coasted_tails`, only before that identity's last observation).
    // Otherwise a slave's coasted tail overlaps its master's first frames (no join possible)
    // and a gap's predictions stand where the two observed ends give a better estimate.
    let mut areas = Vec::with_capacity(shapes.len());
    let mut observed = Vec::with_capacity(shapes.len());
    let mut coasted = Vec::new();
    for (s, a) in shapes.into_iter().zip(mask_areas) {
        if s.interpolated {
            coasted.push(s);
        } else {
            observed.push(s);
            areas.push(a);
        }
    }
    let mut shapes = observed;
    // Boxes smoothed over each whole track before anything reads them (joins fit motion to
    // them, fills interpolate between them).
    measured.sort_unstable_by_key(|e| e.0);
    let boxes: Vec<Option<BBox>> = shapes
        .iter()
        .map(|s| {
            let k = measured
                .binary_search_by_key(&(s.id, s.frame), |e| e.0)
                .ok()?;
            Some(measured[k].1)
        })
        .collect();
    let is_mask: Vec<bool> = areas.iter().map(Option::is_some).collect();
    smooth::smooth_boxes(&mut shapes, &boxes, &is_mask, &config.smooth);
    let pieces = relink::pieces(&shapes);
    let use_appearance = config.appearance.enabled && snapshots.is_some_and(|s| !s.is_empty());
    let mut cache = match snapshots {
        Some(s) if use_appearance => Some(FeatureCache::new(s, &config.appearance)),
        _ => None,
    };
    let joins = relink::find_joins(
        &shapes,
        &pieces,
        cache.as_mut(),
        &config.relink,
        seq,
        progress,
    )?;

    let mut result = OfflineResult {
        shapes: Vec::new(),
        joins,
        filled: 0,
        coasted_dropped: 0,
    };
    let map = result.id_map();
    let origin: Vec<u64> = shapes.iter().map(|s| s.id).collect();
    for s in &mut shapes {
        if let Some(&root) = map.get(&s.id) {
            s.id = root;
        }
    }
    let filled = fill::fill_gaps(
        &shapes,
        &areas,
        &origin,
        seq.image_size,
        &config.fill,
        &config.relink,
        fps,
        progress,
    )?;
    let n_coasted = coasted.len();
    shapes.extend(filled);
    let mut last_seen: std::collections::HashMap<u64, u32> = Default::default();
    for s in &shapes {
        let e = last_seen.entry(s.id).or_insert(s.frame);
        *e = (*e).max(s.frame);
    }
    let mut covered: std::collections::HashSet<(u64, u32)> =
        shapes.iter().map(|s| (s.id, s.frame)).collect();
    // Where two joined tracks both coasted through one frame (a slave's predictions past its
    // last observation and its master's after a miss), the later-started one's prediction is
    // kept, as it rests on the later view: the coasted shapes are taken in that order, each
    // only where its identity has no shape yet. (`pieces` come sorted by id.)
    let started = |id: u64| match pieces.binary_search_by_key(&id, |p| p.id) {
        Ok(k) => pieces[k].first,
        Err(_) => 0,
    };
    let mut order: Vec<usize> = (0..coasted.len()).collect();
    order.sort_unstable_by_key(|&i| (std::cmp::Reverse(started(coasted[i].id)), i));
    let mut keep = vec![false; coasted.len()];
    for i in order {
        let s = &coasted[i];
        let id = map.get(&s.id).copied().unwrap_or(s.id);
        let tail = last_seen.get(&id).is_none_or(|&f| s.frame > f);
        keep[i] = (config.fill.coasted_tails || !tail) && covered.insert((id, s.frame));
    }
    let mut kept: Vec<TrackedShape> = coasted
        .into_iter()
        .zip(keep)
        .filter_map(|(mut s, k)| {
            s.id = map.get(&s.id).copied().unwrap_or(s.id);
            k.then_some(s)
        })
        .collect();
    if config.min_track_seconds > 0.0 {
        // Identities too short to be real: count their observed shapes.
        let need = (config.min_track_seconds * fps).ceil();
        let mut observed: std::collections::BTreeMap<u64, f64> = Default::default();
        for s in shapes.iter().filter(|s| !s.interpolated) {
            *observed.entry(s.id).or_default() += 1.0;
        }
        let long = |s: &TrackedShape| observed.get(&s.id).copied().unwrap_or(0.0) >= need;
        shapes.retain(long);
        kept.retain(long);
    }
    // `shapes` holds observed and filled shapes only until the kept coasting joins them.
    result.filled = shapes.iter().filter(|s| s.interpolated).count();
    result.coasted_dropped = n_coasted - kept.len();
    shapes.extend(kept);
    shapes.sort_by_key(|s| (s.frame, s.id));
    result.shapes = shapes;
    progress(Progress {
        phase: Phase::Done,
        fraction: 1.0,
    });
    Ok(result)
}

/// The whole-sequence offline tracker: the online pass frame by frame, then the offline stages.
///
/// `H` is where the online output is kept until then ([`History`]): the shapes as they are by
/// default, or with masks as RLE ([`RleHistory`], what the browser bindings use).
///
/// ```
/// use shapetrack::track::offline::{OfflineConfig, OfflineTracker};
/// use shapetrack::{BBox, Detection};
///
/// let mut t = OfflineTracker::new(OfflineConfig::default(), 25.0)?;
/// for k in 0..10 {
///     let det = Detection::from_box(BBox::new(10.0 + 3.0 * k as f64, 20.0, 30.0, 60.0), 0.99);
///     t.push_frame(None, &[det])?;
/// }
/// let mut phases = Vec::new();
/// let out = t.finish(|p| phases.push(p.phase))?;
/// assert_eq!(out.shapes.len(), 10);
/// assert!(out.shapes.iter().all(|s| s.id == 1));
/// # Ok::<(), shapetrack::track::offline::OfflineError>(())
/// ```
pub struct OfflineTracker<H: History = Vec<TrackedShape>> {
    config: OfflineConfig,
    seq: SequenceInfo,
    tracker: Tracker,
    shapes: H,
    snapshots: Snapshots,
    /// The detection each observed online shape was matched to (its box), kept for the
    /// offline smoother when [`SmoothConfig::enabled`].
    detections: DetectionBoxes,
}

impl<H: History> std::fmt::Debug for OfflineTracker<H> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OfflineTracker")
            .field("seq", &self.seq)
            .field("frames", &self.tracker.frame())
            .field("shapes", &self.shapes.items().len())
            .field("snapshots", &self.snapshots.len())
            .finish_non_exhaustive()
    }
}

impl OfflineTracker {
    /// An offline tracker with the online tracker built from `config.online`; `fps` is the
    /// video's frame rate (`Δt = 1/fps` of the re-linker's filter).
    pub fn new(config: OfflineConfig, fps: f64) -> Result<Self, OfflineError> {
        let tracker = Tracker::new(config.online.clone())?;
        Self::with_tracker(tracker, config, fps)
    }

    /// An offline tracker around an online tracker built by the caller (extra pair-cost terms,
    /// another feature extractor or motion filter). `config.online` is then not used.
    pub fn with_tracker(
        tracker: Tracker,
        config: OfflineConfig,
        fps: f64,
    ) -> Result<Self, OfflineError> {
        Self::with_history(tracker, config, fps)
    }
}

impl<H: History> OfflineTracker<H> {
    /// An offline tracker around `tracker` that keeps its online output in an `H` (see
    /// [`History`]); otherwise as [`OfflineTracker::with_tracker`].
    pub fn with_history(
        tracker: Tracker,
        config: OfflineConfig,
        fps: f64,
    ) -> Result<Self, OfflineError> {
        config.validate()?;
        check_fps(fps)?;
        Ok(Self {
            config,
            seq: SequenceInfo::new(fps),
            tracker,
            shapes: H::default(),
            snapshots: Snapshots::new(),
            detections: DetectionBoxes::new(),
        })
    }

    /// Tells the re-linker and the online tracker the image size (frames given to
    /// [`OfflineTracker::push_frame`] tell them too).
    pub fn with_image_size(mut self, width: u32, height: u32) -> Self {
        self.seq.image_size = Some((width, height));
        self.tracker = self.tracker.with_image_size(width, height);
        self
    }

    /// Tells only the re-linker (and an [`RleHistory`], which encodes masks for it) the image
    /// size, when there is one; the online tracker learns it from frames, if any. Frames given
    /// to [`OfflineTracker::push_frame`] override it.
    pub fn with_sequence_image_size(mut self, size: Option<(u32, u32)>) -> Self {
        self.seq.image_size = size;
        self
    }

    /// The online pass over one frame. Returns the online shapes this frame produced (those of
    /// tracks confirmed now may carry earlier frame numbers). With a `frame`, the shapes seen
    /// in it become their tracks' appearance snapshots; the frame is not kept.
    pub fn push_frame(
        &mut self,
        frame: Option<&Frame<'_>>,
        detections: &[Detection],
    ) -> Result<&[H::Item], OfflineError> {
        let out = self.tracker.update(frame, detections)?;
        // The online tracker has checked this frame against the earlier ones (and against a
        // size given with `with_image_size`): a frame's size is the sequence's.
        if let Some(f) = frame {
            self.seq.image_size = Some((f.width(), f.height()));
        }
        let now = self.tracker.frame();
        if let (Some(f), true) = (frame, self.config.appearance.enabled) {
            for s in out.iter().filter(|s| s.frame == now) {
                self.snapshots.record(f, s, self.config.appearance.max_side);
            }
            self.snapshots.end_frame();
        }
        if self.config.smooth.enabled {
            // A shape of this frame knows its detection; shapes a confirmation brings from
            // earlier frames report their detection's box anyway (a track's first matches are
            // never smoothed online).
            for s in out.iter().filter(|s| s.frame == now && !s.interpolated) {
                if let Some(d) = s.det_index.and_then(|i| detections.get(i)) {
                    self.detections.push(((s.id, s.frame), d.bbox));
                }
            }
        }
        let start = self.shapes.items().len();
        for s in out {
            self.shapes.push(s, self.seq.image_size);
        }
        Ok(&self.shapes.items()[start..])
    }

    /// Skips `n` frames without detections while no track is live (see
    /// [`Tracker::skip_idle`]); returns how many were skipped (`n` or 0).
    pub fn skip_idle(&mut self, n: u32) -> u32 {
        self.tracker.skip_idle(n)
    }

    /// Frames pushed so far.
    pub fn frames(&self) -> u32 {
        self.tracker.frame()
    }

    /// The online tracker's time per phase ([`Tracker::phase_times`]; zero unless it was
    /// built [`Tracker::with_clock`]).
    pub fn phase_times(&self) -> crate::track::PhaseTimes {
        self.tracker.phase_times()
    }

    /// The online output so far.
    pub fn online_shapes(&self) -> &[H::Item] {
        self.shapes.items()
    }

    /// The image size, when known (from frames, or as given).
    pub fn image_size(&self) -> Option<(u32, u32)> {
        self.seq.image_size
    }

    /// The appearance snapshots taken so far.
    pub fn snapshots(&self) -> &Snapshots {
        &self.snapshots
    }

    /// The configuration.
    pub fn config(&self) -> &OfflineConfig {
        &self.config
    }

    /// Runs the offline stages on everything pushed (see [`relink()`]).
    pub fn finish(self, mut progress: impl FnMut(Progress)) -> Result<OfflineResult, OfflineError> {
        let snaps = (!self.snapshots.is_empty()).then_some(&self.snapshots);
        let input = self.shapes.into_offline_input();
        let boxes = self.detections;
        relink_measured(input, boxes, snaps, &self.config, &self.seq, &mut progress)
    }

    /// The offline stages on everything pushed so far, leaving the tracker as it is: a front
    /// end whose progress callback failed can run them again.
    pub fn relink(
        &self,
        mut progress: impl FnMut(Progress),
    ) -> Result<OfflineResult, OfflineError> {
        let snaps = (!self.snapshots.is_empty()).then_some(&self.snapshots);
        let input = self.shapes.offline_input();
        let boxes = self.detections.clone();
        relink_measured(input, boxes, snaps, &self.config, &self.seq, &mut progress)
    }
}

impl OfflineTracker<RleHistory> {
    /// Runs the offline stages on everything pushed, as [`OfflineTracker::finish`], and
    /// returns with the result each of its shapes' masks, packed (see [`KeptMasks::resolve`]):
    /// a long video's masks are never all decoded at once, and the shapes are not copied.
    pub fn finish_packed(
        self,
        mut progress: impl FnMut(Progress),
    ) -> Result<(OfflineResult, Vec<Option<crate::io::PackedRle>>), OfflineError> {
        let snaps = (!self.snapshots.is_empty()).then_some(&self.snapshots);
        let (input, kept) = self.shapes.into_parts();
        let boxes = self.detections;
        let result = relink_measured(input, boxes, snaps, &self.config, &self.seq, &mut progress)?;
        let masks = kept.resolve(&result, self.seq.image_size);
        Ok((result, masks))
    }

    /// Applies `result` (from [`OfflineTracker::relink`]) to the kept output in place, for a
    /// front end that has shown the online output as it came (see [`RleHistory::apply`]), and
    /// frees the appearance snapshots. Returns the shapes added. No frame may follow.
    pub fn apply(&mut self, result: &OfflineResult) -> Vec<RleShape> {
        self.snapshots = Snapshots::new();
        self.shapes.apply(result, self.seq.image_size)
    }
}

/// Offline tracking of a whole sequence without images: `frames[k]` holds the detections of
/// frame `k + 1`. Reports the online phase per frame, then the offline stages.
pub fn track_offline(
    config: &OfflineConfig,
    seq: &SequenceInfo,
    frames: &[Vec<Detection>],
    mut progress: impl FnMut(Progress),
) -> Result<OfflineResult, OfflineError> {
    let mut t =
        OfflineTracker::new(config.clone(), seq.fps)?.with_sequence_image_size(seq.image_size);
    let n = frames.len().max(1) as f64;
    for (k, dets) in frames.iter().enumerate() {
        if k % 16 == 0 {
            progress(Progress {
                phase: Phase::Online,
                fraction: k as f64 / n,
            });
        }
        t.push_frame(None, dets)?;
    }
    progress(Progress {
        phase: Phase::Online,
        fraction: 1.0,
    });
    t.finish(progress)
}
