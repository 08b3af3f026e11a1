//! The online tracker: one [`Tracker::update`] per frame, in named phases.
//!
//! ```text
//! prepare → predict → estimate regions → describe → score pairs → assign → merge fragments
//!   → update matched → refresh appearance → age lost → coast → spawn
//! ```
//!
//! - **prepare**: validate the detections and the frame (typed errors, before any state
//!   changes), clip masks to the frame, drop detections below `min_score`, with zero area or an
//!   empty mask, split the rest into high and low confidence, and compute each one's cheap
//!   [`Features`] once (centroid, area, and for masks the convex shell).
//! - **predict**: every track's motion filter steps one frame.
//! - **estimate regions** (thesis Alg. 2): box mode: the predicted boxes, grown by a margin
//!   that widens while a track is unmatched, meet the detections' boxes
//!   ([`estimate_regions`]). With masks: each track's last shell, moved by its predicted
//!   displacement (swept along it for fast or lost tracks) and merged with its predicted box,
//!   grown by the same margin, meets the detections' shells by GJK
//!   ([`crate::region::region_clusters`]). Only pairs inside a cluster are ever scored.
//! - **describe**: appearance (shape context, SIFT, colour: only the parts the enabled terms
//!   read) for the detections of clusters that geometry cannot decide: a track with two
//!   candidates (or a detection with two tracks) whose geometric costs are close. A 1×1
//!   cluster, or a crossing that motion already resolves, costs no appearance.
//! - **score pairs**: the [`CostModel`] combines the enabled [`PairCost`] terms per pair;
//!   cluster-normalised terms (C1, C2) rank pairs, thresholds compare the others.
//! - **assign**: optimal assignment in stages (ByteTrack-style): (1) confirmed (and, unless
//!   [`Config::lost_reid_only`], lost) tracks × high detections, (2) tracks matched last frame
//!   × low detections, (3) tentative tracks × the remaining high detections, and the
//!   re-identification stage, lost tracks × high detections nobody took, scored then (its
//!   detections described then), before (3) with `lost_reid_only` and after it otherwise.
//! - **merge fragments** ([`Config::merge_fragments`]): a detector-split shape is put back
//!   together before its track is updated.
//! - **update matched**: filters correct (with the amodal box of a partly hidden mask, see
//!   [`Config::amodal`]), tentative tracks with enough hits are confirmed and get an id (or,
//!   with [`Config::reid_at_confirmation`], the id of a lost track they re-identify), lost
//!   tracks are re-identified under their old id; appearance computed this frame becomes the
//!   track's last (and, if the shape was seen whole, reference) appearance.
//! - **refresh appearance**: a matched track's appearance is computed now when it will be
//!   needed and this frame is the last chance to see it: when its box will touch another
//!   track's by the next frame (a crossing is coming), or when its reference appearance is
//!   missing or older than `appearance.refresh` frames while the shape is seen whole (so a
//!   track lost behind an occluder is re-identified by a whole view).
//! - **age lost**: unmatched tracks become lost, and are removed after `max_lost` frames
//!   (tentative ones after `max_tentative_misses`).
//! - **coast**: with [`Config::coast_frames`], confirmed tracks that were seen whole and missed
//!   for at most that many frames are reported at their predicted place.
//! - **spawn**: confident unmatched detections start tentative tracks, each with an
//!   appearance (so that no track lacks the appearance terms its rivals have).
//!
//! **What is reported.** Each call returns the confirmed tracks matched in this frame, with the
//! matched detection's box, mask and score (boxes are never invented online). With
//! `report_tentative`, the call that confirms a track also returns its earlier tentative frames
//! (with their own frame numbers), so a track's first `min_hits − 1` frames are not lost. Lost
//! tracks are not reported (except short coasts, above): filling their gaps is the offline
//! pass's job.
//!
//! **Bad input.** Non-finite or negative boxes and scores are typed errors
//! ([`TrackError::InvalidDetection`]); a frame whose size differs from the previous frames' is
//! [`TrackError::FrameSize`] (start a new tracker for a new video size); a mask reaching
//! outside the frame is clipped to it, and a mask that is empty (or empty once clipped) is
//! dropped like a zero-area box. None of these change the tracker's state.

use std::borrow::Cow;
use std::sync::Arc;

use super::appearance::{ColourCost, ColourMode, ShapeContextCost, SiftCost, TrackSide};
use super::config::{Config, Terms};
use super::cost::{Candidate, CostModel, PairCost, PairScore};
use super::features::{Appearance, MaskFeatures, Needs};
use super::lifecycle::{BoxMotion, Sizes, Track};
use super::regions::{estimate_regions, Regions};
use super::TrackError;
use crate::assign::{self, Unmatched};
use crate::frame::{BBox, Detection, Frame, Mask, Point, TrackState, TrackedShape};
use crate::geometry::{overlapping_box_pairs, ConvexShell};
use crate::motion::{BoxKalman, BoxMotionModel, MotionError, MotionFactory};
use crate::region::region_clusters;

/// Per-detection features, computed once per frame by a [`FeatureExtractor`] and kept on the
/// track as its last appearance when the detection is matched.
///
/// The cheap part (centroid, area, shell) is computed for every detection in the prepare
/// phase; the appearance only when the tracker needs it (module docs), and then shared with
/// the track. The pair-cost terms that read a part return "no data" while it is absent.
#[derive(Debug, Clone, Default, PartialEq)]
#[non_exhaustive]
pub struct Features {
    /// Centroid: mask moments (thesis eq. 10) when there is a mask, else the box centre.
    pub centroid: Point,
    /// Area: foreground pixels of the mask, else the box area (0 when the extractor did not
    /// say).
    pub area: f64,
    /// The mask's convex shell, for the region estimator (`None` for box detections).
    pub shell: Option<Arc<ConvexShell>>,
    /// Appearance, when it was computed this frame.
    pub appearance: Option<Arc<Appearance>>,
}

impl Features {
    /// Features holding a centroid only.
    pub fn with_centroid(centroid: Point) -> Self {
        Self {
            centroid,
            ..Self::default()
        }
    }
}

/// Computes a detection's [`Features`]: the cheap part once per detection per frame, the
/// appearance on demand.
pub trait FeatureExtractor: Send {
    /// The cheap features of `det` in `frame` (`None` in box mode, where there are no pixels).
    fn extract(&self, frame: Option<&Frame<'_>>, det: &Detection) -> Result<Features, String>;

    /// The appearance of `det` in `frame` (tracker frame number `frame_number`), `None` when
    /// the extractor computes none (the default). Called only for detections the tracker
    /// needs appearance for. A failure is treated as "no appearance": the terms that would
    /// read it drop out for this detection.
    fn describe(
        &self,
        frame: &Frame<'_>,
        det: &Detection,
        frame_number: u32,
    ) -> Result<Option<Appearance>, String> {
        let _ = (frame, det, frame_number);
        Ok(None)
    }
}

/// The default extractor: the centroid only. Needs no image.
#[derive(Debug, Clone, Copy, Default)]
pub struct BoxFeatures;

impl FeatureExtractor for BoxFeatures {
    fn extract(&self, _frame: Option<&Frame<'_>>, det: &Detection) -> Result<Features, String> {
        let mut f = Features::with_centroid(det.centroid());
        f.area = match &det.mask {
            Some(m) => m.area() as f64,
            None => det.bbox.area(),
        };
        Ok(f)
    }
}

/// Builds a new track's motion filter from its first box.
type MotionBuilder = Box<dyn Fn(&BBox) -> Result<BoxMotion, MotionError> + Send>;

/// Largest box coordinate or size accepted (pixels): far beyond any image, far below overflow.
const MAX_COORDINATE: f64 = 1e9;

/// A detection that survived `prepare` (its mask clipped to the frame when needed).
struct Prepared<'a> {
    index: usize,
    det: Cow<'a, Detection>,
    features: Features,
    high: bool,
}

/// A match decided by the assign phase: track index, prepared-detection index, cost.
#[derive(Debug, Clone, Copy)]
struct Pair {
    track: usize,
    det: usize,
    cost: f64,
}

/// An allowed pair: track, prepared detection, the cost the assignment minimises, and the
/// cost thresholds compare (see [`PairScore`]).
type Edge = (usize, usize, f64, f64);

/// Which tracks and detections the assignment stages have taken so far.
struct Used {
    tracks: Vec<bool>,
    dets: Vec<bool>,
}

/// The online multi-object tracker. Owns its tracks and its id counter.
pub struct Tracker {
    config: Config,
    costs: CostModel,
    reid_costs: CostModel,
    extractor: Box<dyn FeatureExtractor>,
    /// Appearance parts the registered terms read.
    needs: Needs,
    motion: MotionBuilder,
    tracks: Vec<Track>,
    frame: u32,
    next_id: u64,
    /// Size of the frames seen so far (width, height).
    frame_size: Option<(u32, u32)>,
    /// A clock (seconds) for [`Tracker::phase_times`]; `None`: no timing.
    clock: Option<Clock>,
    times: PhaseTimes,
    /// Seconds spent describing appearance since the clock started (read around phases).
    appearance_time: std::cell::Cell<f64>,
    /// Seconds spent scoring re-identification pairs (inside the assignment phase).
    reid_score_time: std::cell::Cell<f64>,
}

/// A monotonic clock in seconds, supplied by the caller: the core never reads the time
/// itself (`std::time::Instant` panics on wasm32-unknown-unknown).
type Clock = Box<dyn Fn() -> f64 + Send>;

/// Where a tracker's time went, accumulated over the frames since timing started (see
/// [`Tracker::with_clock`]), in seconds. The phases partition [`Tracker::update`]'s time.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct PhaseTimes {
    /// Frames timed.
    pub frames: u64,
    /// Per-detection features: validation, centroids and shells, and every appearance
    /// description (SIFT, contour descriptor, colour sample), wherever it was asked for.
    pub features: f64,
    /// Motion prediction and region estimation (shells, broad phase, GJK, clusters).
    pub regions: f64,
    /// Pair costs: the ambiguity test, the main association's and re-identification's terms.
    pub costs: f64,
    /// The assignment stages (optimal assignment per stage).
    pub assignment: f64,
    /// Track updates: fragments, filters, lifecycle, coasting, spawning.
    pub update: f64,
}

impl PhaseTimes {
    /// Total time over the frames.
    pub fn total(&self) -> f64 {
        self.features + self.regions + self.costs + self.assignment + self.update
    }
}

impl std::fmt::Debug for Tracker {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Tracker")
            .field("config", &self.config)
            .field("costs", &self.costs)
            .field("reid_costs", &self.reid_costs)
            .field("tracks", &self.tracks)
            .field("frame", &self.frame)
            .field("next_id", &self.next_id)
            .finish_non_exhaustive()
    }
}

/// Registers the appearance terms of `terms` (those with a positive weight) on `model`.
fn register_appearance(
    model: &mut CostModel,
    terms: &Terms,
    config: &Config,
    side: TrackSide,
    colour: ColourMode,
) {
    model.push(
        Box::new(ShapeContextCost {
            config: config.appearance.shape_context,
            variant: config.shape_variant,
            matching: config.sift_matching.clone(),
            side,
        }),
        terms.shape_context.weight,
        terms.shape_context.gate,
    );
    model.push(
        Box::new(ColourCost {
            config: config.appearance.colour,
            mode: colour,
            side,
        }),
        terms.colour.weight,
        terms.colour.gate,
    );
    model.push(
        Box::new(SiftCost {
            matching: config.sift_matching.clone(),
            min_keypoints: config.sift_min_keypoints,
            side,
        }),
        terms.sift.weight,
        terms.sift.gate,
    );
}

impl Tracker {
    /// A tracker with the terms of `config` (geometry, motion and appearance), the
    /// constant-velocity box Kalman filter and the [`MaskFeatures`] extractor (which gives box
    /// detections their centre only, so box mode needs nothing else).
    pub fn new(config: Config) -> Result<Self, TrackError> {
        config.validate()?;
        let params = config.motion;
        let motion: MotionBuilder = Box::new(move |z: &BBox| -> Result<BoxMotion, MotionError> {
            Ok(Box::new(BoxKalman::new(z, params)?))
        });
        // The IoA buffer grows like the search region: twice the per-side margin growth.
        let ioa_growth = 2.0 * config.region_margin_per_miss;
        let mut costs = CostModel::from_terms_with(&config.terms, ioa_growth);
        register_appearance(
            &mut costs,
            &config.terms,
            &config,
            TrackSide::Last,
            ColourMode::Aligned,
        );
        let mut reid_costs = CostModel::from_terms_with(&config.reid_terms, ioa_growth);
        register_appearance(
            &mut reid_costs,
            &config.reid_terms,
            &config,
            TrackSide::Reference,
            ColourMode::Contained,
        );
        let needs = config.appearance_needs();
        Ok(Self {
            costs,
            reid_costs,
            extractor: Box::new(MaskFeatures::new(config.appearance.clone(), needs)),
            needs,
            config,
            motion,
            tracks: Vec::new(),
            frame: 0,
            next_id: 1,
            frame_size: None,
            clock: None,
            times: PhaseTimes::default(),
            appearance_time: std::cell::Cell::new(0.0),
            reid_score_time: std::cell::Cell::new(0.0),
        })
    }

    /// Replaces the motion filter of tracks born from now on with one built by `factory`.
    pub fn with_motion<F>(mut self, factory: F) -> Self
    where
        F: MotionFactory + Send + 'static,
    {
        self.motion = Box::new(move |z: &BBox| -> Result<BoxMotion, MotionError> {
            Ok(Box::new(factory.init(z)?))
        });
        self
    }

    /// Times the phases of every [`Tracker::update`] with `clock` (a monotonic time in
    /// seconds, e.g. from `std::time::Instant` natively or `performance.now()` in a browser);
    /// see [`Tracker::phase_times`].
    pub fn with_clock<C>(mut self, clock: C) -> Self
    where
        C: Fn() -> f64 + Send + 'static,
    {
        self.clock = Some(Box::new(clock));
        self.times = PhaseTimes::default();
        self
    }

    /// Time spent per phase since [`Tracker::with_clock`] (all zero without a clock).
    pub fn phase_times(&self) -> PhaseTimes {
        self.times
    }

    /// Replaces the feature extractor. The tracker still asks it for appearance only where
    /// the registered terms need it.
    pub fn with_extractor(mut self, extractor: Box<dyn FeatureExtractor>) -> Self {
        self.extractor = extractor;
        self
    }

    /// Adds a pair-cost term to the main association (e.g. shape context with
    /// `config.terms.shape_context.weight`). A weight that is not positive disables it.
    pub fn add_term(&mut self, term: Box<dyn PairCost>, weight: f64, gate: Option<f64>) {
        self.costs.push(term, weight, gate);
    }

    /// Adds a pair-cost term to the re-identification stage (e.g. colour with
    /// `config.reid_terms.colour.weight`). A weight that is not positive disables it.
    pub fn add_reid_term(&mut self, term: Box<dyn PairCost>, weight: f64, gate: Option<f64>) {
        self.reid_costs.push(term, weight, gate);
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The live tracks (tentative, confirmed and lost).
    pub fn tracks(&self) -> &[Track] {
        &self.tracks
    }

    /// Number of frames processed so far (the last frame's number, 1-based).
    pub fn frame(&self) -> u32 {
        self.frame
    }

    /// Number of ids handed out so far.
    pub fn ids_issued(&self) -> u64 {
        self.next_id - 1
    }

    /// Processes one frame: see the module docs for the phases and what is reported.
    ///
    /// `frame` is the image, when there is one (box mode passes `None`). Invalid detections
    /// (NaN or infinite values, negative sizes) and a change of frame size are rejected with an
    /// error before the tracker's state changes.
    pub fn update(
        &mut self,
        frame: Option<&Frame<'_>>,
        detections: &[Detection],
    ) -> Result<Vec<TrackedShape>, TrackError> {
        let size = frame.map(|f| (f.width(), f.height()));
        if let (Some((width, height)), Some((expected_width, expected_height))) =
            (size, self.frame_size)
        {
            if (width, height) != (expected_width, expected_height) {
                return Err(TrackError::FrameSize {
                    width,
                    height,
                    expected_width,
                    expected_height,
                });
            }
        }
        // Checkpoints: (time, appearance time so far, re-identification scoring so far).
        let mark = |s: &Self| {
            s.now()
                .map(|t| (t, s.appearance_time.get(), s.reid_score_time.get()))
        };
        let m0 = mark(self);
        let mut dets = self.prepare(frame, detections)?;
        if size.is_some() {
            self.frame_size = size;
        }
        self.frame += 1;
        let m1 = mark(self);
        self.predict();
        let regions = self.estimate_regions(&dets);
        let m2 = mark(self);
        self.describe(frame, &regions, &mut dets);
        let m3 = mark(self);
        let main = self.score(&self.costs, &regions, &dets, |_| true);
        let m4 = mark(self);
        let matches = self.assign(frame, &main, &regions, &mut dets)?;
        let m5 = mark(self);
        let mut det_used = vec![false; dets.len()];
        for m in &matches {
            det_used[m.det] = true;
        }
        if self.config.merge_fragments {
            self.merge_fragments(frame, &matches, &main, &mut dets, &mut det_used)?;
        }
        let mut out = Vec::new();
        let matched_tracks = self.update_matched(&matches, &dets, &mut out)?;
        self.refresh_appearance(frame, &matches, &dets);
        self.age_lost(&matched_tracks);
        self.coast(&mut out);
        self.spawn(frame, &dets, &det_used, &mut out)?;
        if let (Some(m0), Some(m1), Some(m2), Some(m3), Some(m4), Some(m5), Some(m6)) =
            (m0, m1, m2, m3, m4, m5, mark(self))
        {
            // Time and appearance time of the interval between two checkpoints.
            let span = |a: (f64, f64, f64), b: (f64, f64, f64)| (b.0 - a.0, b.1 - a.1, b.2 - a.2);
            let (prepare, ..) = span(m0, m1);
            let (regions, ..) = span(m1, m2);
            let (describe, ..) = span(m2, m3);
            let (score, ..) = span(m3, m4);
            let (assign, app_assign, reid) = span(m4, m5);
            let (update, app_update, _) = span(m5, m6);
            // Appearance described outside the describe phase (re-identification, refresh,
            // new tracks) counts as features, not as the phase that asked for it.
            let p = &mut self.times;
            p.frames += 1;
            p.features += prepare + describe + app_assign + app_update;
            p.regions += regions;
            p.costs += score + reid;
            p.assignment += (assign - reid - app_assign).max(0.0);
            p.update += (update - app_update).max(0.0);
        }
        Ok(out)
    }

    /// Phase 0: validate, clip, filter, classify and extract the cheap features.
    fn prepare<'a>(
        &self,
        frame: Option<&Frame<'_>>,
        detections: &'a [Detection],
    ) -> Result<Vec<Prepared<'a>>, TrackError> {
        let mut out = Vec::with_capacity(detections.len());
        for (index, det) in detections.iter().enumerate() {
            let b = det.bbox;
            for (field, value) in [
                ("bbox.x", b.x),
                ("bbox.y", b.y),
                ("bbox.w", b.w),
                ("bbox.h", b.h),
            ] {
                // Finite is not enough: squaring 1e300 in an area or a covariance overflows.
                if !(value.is_finite() && value.abs() <= MAX_COORDINATE) {
                    return Err(TrackError::InvalidDetection {
                        index,
                        field,
                        value,
                        expected: "a finite number within ±1e9",
                    });
                }
            }
            for (field, value) in [("bbox.w", b.w), ("bbox.h", b.h)] {
                if value < 0.0 {
                    return Err(TrackError::InvalidDetection {
                        index,
                        field,
                        value,
                        expected: "a size ≥ 0",
                    });
                }
            }
            if !det.score.is_finite() {
                return Err(TrackError::InvalidDetection {
                    index,
                    field: "score",
                    value: det.score,
                    expected: "a finite number",
                });
            }
            // Zero-area boxes carry no overlap information; they are skipped, not errors.
            if det.score < self.config.min_score || b.w <= 0.0 || b.h <= 0.0 {
                continue;
            }
            let Some(det) = clip_to_frame(det, frame) else {
                continue;
            };
            let features = self
                .extractor
                .extract(frame, &det)
                .map_err(|message| TrackError::Features { index, message })?;
            let high = det.score >= self.config.high_score;
            out.push(Prepared {
                index,
                det,
                features,
                high,
            });
        }
        Ok(out)
    }

    /// Phase 1: every filter steps one frame.
    fn predict(&mut self) {
        for t in &mut self.tracks {
            if t.state == TrackState::Lost && self.config.lost_velocity_decay < 1.0 {
                t.motion.damp_velocity(self.config.lost_velocity_decay);
            }
            t.motion.predict();
            t.predicted = t.motion.project();
        }
    }

    /// Margin factor of a track's search region: grows while it is unmatched.
    fn margin_factor(&self, t: &Track) -> f64 {
        self.config.region_margin + self.config.region_margin_per_miss * t.misses as f64
    }

    /// Phase 2: which pairs are close enough to compare (thesis Alg. 2).
    fn estimate_regions(&self, dets: &[Prepared<'_>]) -> Regions {
        let shells_mode = dets.iter().any(|d| d.features.shell.is_some())
            || self
                .tracks
                .iter()
                .any(|t| t.features.as_ref().is_some_and(|f| f.shell.is_some()));
        if !shells_mode {
            let shells: Vec<BBox> = self
                .tracks
                .iter()
                .map(|t| {
                    let f = self.margin_factor(t);
                    let p = t.predicted;
                    BBox::from_center(p.center(), p.w * (1.0 + 2.0 * f), p.h * (1.0 + 2.0 * f))
                })
                .collect();
            let det_shells: Vec<BBox> = dets.iter().map(|d| d.det.bbox).collect();
            return estimate_regions(&shells, &det_shells);
        }
        let track_shells: Vec<ConvexShell> = self
            .tracks
            .iter()
            .map(|t| search_shell(t, self.margin_factor(t)))
            .collect();
        let det_shells: Vec<ConvexShell> = dets
            .iter()
            .map(|d| match &d.features.shell {
                Some(s) => s.as_ref().clone(),
                None => ConvexShell::from_bbox(&d.det.bbox).unwrap_or_default(),
            })
            .collect();
        Regions::from(region_clusters(&track_shells, &det_shells))
    }

    /// Phase 3: appearance for the detections geometry cannot decide (module docs).
    ///
    /// A region cluster is ambiguous when, by the geometric and motion terms alone, one of its
    /// tracks has two candidate detections (or a detection two candidate tracks) whose costs
    /// pass `max_cost` and lie within `appearance.ambiguity` of each other; then every
    /// detection of the cluster is described. A 1×1 cluster, or a crossing that geometry
    /// already resolves, costs no appearance at all. With [`Config::lost_reid_only`], lost
    /// tracks do not take part in the main association and do not count: the
    /// re-identification stage describes the detections it needs once the others have taken
    /// theirs.
    fn describe(&self, frame: Option<&Frame<'_>>, regions: &Regions, dets: &mut [Prepared<'_>]) {
        let Some(frame) = frame else {
            return;
        };
        if self.needs.is_empty() {
            return;
        }
        let want = if self.config.appearance.lazy {
            self.ambiguous(regions, dets)
        } else {
            vec![true; dets.len()]
        };
        for (d, w) in dets.iter_mut().zip(want) {
            if w && d.features.appearance.is_none() {
                d.features.appearance = self.appearance_of(frame, &d.det);
            }
        }
    }

    /// Which detections lie in an ambiguous cluster (see [`Tracker::describe`]).
    fn ambiguous(&self, regions: &Regions, dets: &[Prepared<'_>]) -> Vec<bool> {
        let reid_only = self.config.lost_reid_only;
        let counted = |t: usize| {
            self.tracks
                .get(t)
                .is_some_and(|t| !(reid_only && t.state == TrackState::Lost))
        };
        // Detections carry no appearance yet, so the appearance terms have no data here.
        let geometric = self.score(&self.costs, regions, dets, |&(t, _)| counted(t));
        let max = self.config.max_cost;
        let margin = self.config.appearance.ambiguity;
        // Best and second-best passing cost per track and per detection.
        let mut best_t = vec![(f64::INFINITY, f64::INFINITY); self.tracks.len()];
        let mut best_d = vec![(f64::INFINITY, f64::INFINITY); dets.len()];
        let push = |b: &mut (f64, f64), c: f64| {
            if c < b.0 {
                *b = (c, b.0);
            } else if c < b.1 {
                b.1 = c;
            }
        };
        for &(t, d, _, gate) in &geometric {
            if gate <= max {
                push(&mut best_t[t], gate);
                push(&mut best_d[d], gate);
            }
        }
        let close = |b: &(f64, f64)| b.1.is_finite() && b.1 - b.0 < margin;
        let mut want = vec![false; dets.len()];
        for c in &regions.clusters {
            let ambiguous = c
                .tracks
                .iter()
                .any(|&t| counted(t) && best_t.get(t).is_some_and(close))
                || c.dets.iter().any(|&d| best_d.get(d).is_some_and(close))
                || (!reid_only
                    && c.tracks.iter().any(|&t| {
                        self.tracks
                            .get(t)
                            .is_some_and(|t| t.state == TrackState::Lost)
                    }));
            if ambiguous {
                for &d in &c.dets {
                    if let Some(w) = want.get_mut(d) {
                        *w = true;
                    }
                }
            }
        }
        want
    }

    /// The appearance of one detection (`None` without a mask, or if the extractor fails).
    fn appearance_of(&self, frame: &Frame<'_>, det: &Detection) -> Option<Arc<Appearance>> {
        det.mask.as_ref()?;
        let t0 = self.now();
        let a = match self.extractor.describe(frame, det, self.frame) {
            Ok(a) => a.map(Arc::new),
            Err(_) => None,
        };
        if let (Some(t0), Some(t1)) = (t0, self.now()) {
            self.appearance_time
                .set(self.appearance_time.get() + (t1 - t0));
        }
        a
    }

    /// The clock's time, when timing.
    fn now(&self) -> Option<f64> {
        self.clock.as_ref().map(|c| c())
    }

    /// Phase 4: the combined cost under `model` of the candidate pairs of `regions` that
    /// `keep` accepts (sparse: a track only has the few candidates its region estimate found).
    fn score(
        &self,
        model: &CostModel,
        regions: &Regions,
        dets: &[Prepared<'_>],
        keep: impl Fn(&(usize, usize)) -> bool,
    ) -> Vec<Edge> {
        let cands: Vec<Candidate<'_>> = dets
            .iter()
            .map(|d| Candidate {
                index: d.index,
                detection: &d.det,
                features: Some(&d.features),
            })
            .collect();
        // Tracks of different known classes never match (MOTS: cars are not pedestrians).
        let same_class = |t: usize, d: usize| {
            let (tc, dc) = (self.tracks[t].last.class, dets[d].det.class);
            tc < 0 || dc < 0 || tc == dc
        };
        let kept: Vec<usize> = (0..regions.pairs.len())
            .filter(|&k| keep(&regions.pairs[k]))
            .collect();
        let sub;
        let regions = if kept.len() == regions.pairs.len() {
            regions
        } else {
            sub = Regions {
                pairs: kept.iter().map(|&k| regions.pairs[k]).collect(),
                pair_cluster: kept.iter().map(|&k| regions.pair_cluster[k]).collect(),
                clusters: regions.clusters.clone(),
            };
            &sub
        };
        let scores = model.score_pairs(&self.tracks, &cands, regions);
        regions
            .pairs
            .iter()
            .zip(scores)
            .filter_map(|(&(t, d), s): (&(usize, usize), Option<PairScore>)| {
                let s = s.filter(|_| same_class(t, d))?;
                Some((t, d, s.cost, s.absolute))
            })
            .collect()
    }

    /// Phase 5: the assignment stages (module docs). The re-identification stage is scored
    /// when its turn comes, on the lost tracks' pairs with detections nobody took, which are
    /// described first if they need appearance.
    fn assign(
        &self,
        frame: Option<&Frame<'_>>,
        main: &[Edge],
        regions: &Regions,
        dets: &mut [Prepared<'_>],
    ) -> Result<Vec<Pair>, TrackError> {
        let cfg = &self.config;
        let mut used = Used {
            tracks: vec![false; self.tracks.len()],
            dets: vec![false; dets.len()],
        };
        let mut out = Vec::new();
        let recent = |t: &Track| t.state == TrackState::Confirmed;
        let lost = |t: &Track| t.state == TrackState::Lost;
        let active = |t: &Track| recent(t) || lost(t);
        let tentative = |t: &Track| t.state == TrackState::Tentative;
        let high = |d: &Prepared<'_>| d.high;
        let low = |d: &Prepared<'_>| !d.high;
        let (max, max_low) = (cfg.max_cost, cfg.max_cost_low);
        let max_t = cfg.max_cost_tentative;
        if cfg.lost_reid_only {
            self.stage(main, &recent, dets, &high, max, &mut used, &mut out)?;
        } else if cfg.lost_second {
            self.stage(main, &recent, dets, &high, max, &mut used, &mut out)?;
            self.stage(main, &lost, dets, &high, max, &mut used, &mut out)?;
        } else {
            self.stage(main, &active, dets, &high, max, &mut used, &mut out)?;
        }
        self.stage(main, &recent, dets, &low, max_low, &mut used, &mut out)?;
        if cfg.lost_reid_only {
            // Lost tracks are re-identified before tentative tracks take what is left.
            self.reid_stage(frame, regions, dets, &mut used, &mut out)?;
            self.stage(main, &tentative, dets, &high, max_t, &mut used, &mut out)?;
        } else {
            self.stage(main, &tentative, dets, &high, max_t, &mut used, &mut out)?;
            self.reid_stage(frame, regions, dets, &mut used, &mut out)?;
        }
        Ok(out)
    }

    /// The re-identification stage: lost tracks × high detections nobody took.
    fn reid_stage(
        &self,
        frame: Option<&Frame<'_>>,
        regions: &Regions,
        dets: &mut [Prepared<'_>],
        used: &mut Used,
        out: &mut Vec<Pair>,
    ) -> Result<(), TrackError> {
        if self.reid_costs.terms().is_empty() {
            return Ok(());
        }
        let high: Vec<bool> = dets.iter().map(|d| d.high).collect();
        let wanted = |&(t, d): &(usize, usize)| {
            self.tracks[t].state == TrackState::Lost
                && !used.tracks[t]
                && !used.dets[d]
                && high.get(d).copied().unwrap_or(false)
        };
        if let (Some(frame), false) = (frame, self.needs.is_empty()) {
            let mut need = vec![false; dets.len()];
            for p in regions.pairs.iter().filter(|p| wanted(p)) {
                need[p.1] = true;
            }
            for (d, n) in dets.iter_mut().zip(need) {
                if n && d.features.appearance.is_none() {
                    d.features.appearance = self.appearance_of(frame, &d.det);
                }
            }
        }
        let t0 = self.now();
        let reid = self.score(&self.reid_costs, regions, dets, wanted);
        if let (Some(t0), Some(t1)) = (t0, self.now()) {
            self.reid_score_time
                .set(self.reid_score_time.get() + (t1 - t0));
        }
        let lost = |t: &Track| t.state == TrackState::Lost;
        let is_high = |d: &Prepared<'_>| d.high;
        let max_r = self.config.reid_max_cost;
        self.stage(&reid, &lost, dets, &is_high, max_r, used, out)
    }

    /// One assignment stage: the unused tracks and detections that pass the filters, pairs
    /// costing at most `max_cost`, solved optimally.
    #[allow(clippy::too_many_arguments)]
    fn stage(
        &self,
        scores: &[Edge],
        track_ok: &dyn Fn(&Track) -> bool,
        dets: &[Prepared<'_>],
        det_ok: &dyn Fn(&Prepared<'_>) -> bool,
        max_cost: f64,
        used: &mut Used,
        out: &mut Vec<Pair>,
    ) -> Result<(), TrackError> {
        let edges: Vec<Edge> = scores
            .iter()
            .copied()
            .filter(|&(t, d, _, gate)| {
                gate <= max_cost
                    && !used.tracks[t]
                    && !used.dets[d]
                    && track_ok(&self.tracks[t])
                    && det_ok(&dets[d])
            })
            .collect();
        if edges.is_empty() {
            return Ok(());
        }
        let policy = match self.config.unmatched_cost {
            Some(l) => Unmatched::Cost(l),
            None => Unmatched::MaxMatches,
        };
        let (nt, nd) = (self.tracks.len(), dets.len());
        let costs: Vec<(usize, usize, f64)> = edges.iter().map(|&(t, d, c, _)| (t, d, c)).collect();
        for m in assign::solve_sparse(nt, nd, &costs, policy)?.matches {
            let (t, d) = (m.row, m.col);
            used.tracks[t] = true;
            used.dets[d] = true;
            out.push(Pair {
                track: t,
                det: d,
                cost: m.cost,
            });
        }
        Ok(())
    }

    /// Phase 5b ([`Config::merge_fragments`]): a matched mask detection smaller than its
    /// track's whole shape, touching an unmatched detection that lies where the track is
    /// predicted and that no other track can take, is one shape split in two by the detector:
    /// the two are merged (mask union) before the track is updated, and the fragment starts no
    /// track of its own.
    fn merge_fragments(
        &self,
        frame: Option<&Frame<'_>>,
        matches: &[Pair],
        main: &[Edge],
        dets: &mut [Prepared<'_>],
        det_used: &mut [bool],
    ) -> Result<(), TrackError> {
        let max = self.config.max_cost;
        let whole = self.config.appearance.whole_ratio;
        for m in matches {
            let Some(t) = self.tracks.get(m.track) else {
                continue;
            };
            let ref_area = t.ref_area;
            let (Some(md), true) = (dets.get(m.det), ref_area > 0.0) else {
                continue;
            };
            if md.det.mask.is_none() || md.features.area >= whole * ref_area {
                continue;
            }
            let near = t.predicted.expanded(0.1 * t.predicted.w.max(t.predicted.h));
            let Some(m_shell) = md.features.shell.clone() else {
                continue;
            };
            let mut best: Option<(usize, f64)> = None;
            for (j, f) in dets.iter().enumerate() {
                let free = !det_used.get(j).copied().unwrap_or(true);
                let claimed = main
                    .iter()
                    .any(|&(ot, od, _, gate)| od == j && ot != m.track && gate <= max);
                let (Some(fs), true) = (f.features.shell.as_ref(), free && !claimed) else {
                    continue;
                };
                let union_area = md.features.area + f.features.area;
                if f.det.bbox.ioa(&near) < 0.8 || union_area > 1.3 * ref_area {
                    continue;
                }
                let gap = m_shell.distance(fs);
                if gap <= FRAGMENT_GAP && best.is_none_or(|(_, g)| gap < g) {
                    best = Some((j, gap));
                }
            }
            let Some((j, _)) = best else {
                continue;
            };
            let (Some(a), Some(b)) = (
                dets.get(m.det).and_then(|d| d.det.mask.as_ref()),
                dets.get(j).and_then(|d| d.det.mask.as_ref()),
            ) else {
                continue;
            };
            let union = mask_union(a, b);
            let (score, class, index) = match (dets.get(m.det), dets.get(j)) {
                (Some(a), Some(b)) => (a.det.score.max(b.det.score), a.det.class, a.index),
                _ => continue,
            };
            let merged = Detection {
                bbox: union.bbox(),
                mask: Some(union),
                score,
                class,
            };
            let features = self
                .extractor
                .extract(frame, &merged)
                .map_err(|message| TrackError::Features { index, message })?;
            if let Some(d) = dets.get_mut(m.det) {
                d.det = Cow::Owned(merged);
                d.features = features;
            }
            if let Some(u) = det_used.get_mut(j) {
                *u = true;
            }
        }
        Ok(())
    }

    /// Phase 6: correct the matched tracks, confirm and re-identify. Returns which tracks were
    /// matched.
    fn update_matched(
        &mut self,
        matches: &[Pair],
        dets: &[Prepared<'_>],
        out: &mut Vec<TrackedShape>,
    ) -> Result<Vec<bool>, TrackError> {
        let mut matched = vec![false; self.tracks.len()];
        let mut confirming = Vec::new();
        for m in matches {
            let (Some(d), true) = (dets.get(m.det), m.track < self.tracks.len()) else {
                continue;
            };
            matched[m.track] = true;
            self.correct(m.track, d)?;
            let frame = self.frame;
            let min_hits = self.config.min_hits;
            let report = self.config.report_tentative;
            let t = &mut self.tracks[m.track];
            let shape = |id: u64, state: TrackState| shape_of(frame, id, state, d, m.cost);
            match t.state {
                TrackState::Tentative => {
                    if t.hits >= min_hits {
                        confirming.push(*m);
                    } else if report {
                        t.pending.push(shape(0, TrackState::Tentative));
                    }
                }
                TrackState::Confirmed | TrackState::Lost | TrackState::Removed => {
                    t.state = TrackState::Confirmed;
                    if let Some(id) = t.id {
                        out.push(shape(id, TrackState::Confirmed));
                        t.reported_until = frame;
                    }
                }
            }
        }
        for m in confirming {
            let Some(d) = dets.get(m.det) else {
                continue;
            };
            // A shape that reappears from behind an occluder may start a new track before it
            // is recognised (its first views are slivers); at confirmation, with min_hits views
            // of evidence, a lost track it matches takes it over, history included.
            let target = match self.reidentify_at_confirmation(m.track, d, &matched) {
                Some(lost) => {
                    matched[lost] = true;
                    self.correct(lost, d)?;
                    let hits = self.tracks[m.track].hits;
                    let pending = std::mem::take(&mut self.tracks[m.track].pending);
                    self.tracks[m.track].state = TrackState::Removed;
                    let l = &mut self.tracks[lost];
                    l.hits += hits.saturating_sub(1);
                    // Frames the lost track was already reported in (coasting) keep that shape.
                    let until = l.reported_until;
                    l.pending = pending.into_iter().filter(|s| s.frame > until).collect();
                    lost
                }
                None => {
                    let id = self.next_id;
                    self.next_id += 1;
                    self.tracks[m.track].id = Some(id);
                    m.track
                }
            };
            let frame = self.frame;
            let report = self.config.report_tentative;
            let t = &mut self.tracks[target];
            t.state = TrackState::Confirmed;
            let Some(id) = t.id else {
                continue;
            };
            if report {
                for mut s in t.pending.drain(..) {
                    s.id = id;
                    s.state = TrackState::Confirmed;
                    out.push(s);
                }
            }
            t.pending = Vec::new();
            out.push(shape_of(frame, id, TrackState::Confirmed, d, m.cost));
            t.reported_until = frame;
        }
        Ok(matched)
    }

    /// The lost track that the tentative track `tentative`, about to be confirmed with the
    /// detection `d`, is most likely to be (lowest re-identification cost within
    /// `reid_max_cost`), if [`Config::reid_at_confirmation`] is on.
    fn reidentify_at_confirmation(
        &self,
        tentative: usize,
        d: &Prepared<'_>,
        matched: &[bool],
    ) -> Option<usize> {
        if !self.config.reid_at_confirmation || self.reid_costs.terms().is_empty() {
            return None;
        }
        let class = self.tracks.get(tentative)?.last.class;
        let cand = Candidate {
            index: d.index,
            detection: &d.det,
            features: Some(&d.features),
        };
        let mut best: Option<(usize, f64)> = None;
        for (i, t) in self.tracks.iter().enumerate() {
            if i == tentative
                || t.state != TrackState::Lost
                || t.id.is_none()
                || matched.get(i).copied().unwrap_or(true)
                || (class >= 0 && t.last.class >= 0 && class != t.last.class)
            {
                continue;
            }
            let costs: Vec<Option<f64>> = self
                .reid_costs
                .terms()
                .iter()
                .map(|w| w.term.cost(t, &cand))
                .collect();
            let Some(c) = self.reid_costs.combine(&costs) else {
                continue;
            };
            if c <= self.config.reid_max_cost && best.is_none_or(|(_, b)| c < b) {
                best = Some((i, c));
            }
        }
        best.map(|(i, _)| i)
    }

    /// Corrects track `ti` with its matched detection `d`: motion filter (amodal box of a
    /// partial view), reference size, appearance, last detection.
    fn correct(&mut self, ti: usize, d: &Prepared<'_>) -> Result<(), TrackError> {
        let cfg = &self.config;
        let frame = self.frame;
        let Some(t) = self.tracks.get_mut(ti) else {
            return Ok(());
        };
        let area = d.features.area;
        let ratio = if t.ref_area > 0.0 && area > 0.0 {
            area / t.ref_area
        } else {
            1.0
        };
        let whole = ratio >= cfg.appearance.whole_ratio;
        let amodal = cfg.amodal && d.det.mask.is_some();
        let z = if amodal {
            // The last detection tells which side stands still if it is recent; after a longer
            // gap the shape is reappearing.
            let last = (t.misses < REAPPEAR_GAP).then_some((&t.last.bbox, t.misses + 1));
            if last.is_none() {
                // A new view after a gap: the occlusion that cut the last views is over.
                t.cuts = [None; 2];
            }
            let v = t.motion.velocity();
            let (p, r) = (t.predicted, t.ref_size);
            amodal_box(&p, &d.det.bbox, last, v, r, whole, &mut t.cuts)
        } else {
            d.det.bbox
        };
        if cfg.reupdate_after_gap && t.misses > 0 {
            if let Some(snap) = &t.snapshot {
                // With amodal completion the whole shape's boxes, else the boxes as seen.
                let (from, to) = if amodal {
                    (&t.anchor, &z)
                } else {
                    (&t.last.bbox, &d.det.bbox)
                };
                t.motion = reupdate(snap.as_ref(), from, to, t.misses)?;
            }
        }
        // A sliver (a shape mostly hidden) says little about where the whole shape is:
        // matching it keeps the track alive, but the filter coasts on its prediction rather
        // than having its velocity dragged by the occluder's edge. Not after a gap, when the
        // prediction has drifted and the sliver is the only news.
        let sliver = amodal && ratio < cfg.sliver_ratio && t.misses == 0 && t.hits >= cfg.min_hits;
        if !sliver {
            t.motion.update(&z)?;
        }
        t.anchor = t.motion.project();
        if cfg.reupdate_after_gap {
            t.snapshot = Some(t.motion.clone_box());
        }
        t.last_ratio = ratio;
        t.last_whole = whole;
        if area > 0.0 {
            let b = d.det.bbox;
            t.sizes.push(area, b.w, b.h);
            (t.ref_area, t.ref_size) = t.sizes.reference();
        }
        if let Some(a) = &d.features.appearance {
            t.appearance = Some(a.clone());
            if whole {
                t.reference = Some(a.clone());
            }
        }
        t.hits += 1;
        t.misses = 0;
        t.last_frame = frame;
        t.last = d.det.clone().into_owned();
        t.features = Some(d.features.clone());
        Ok(())
    }

    /// Phase 7: compute now the appearance matched tracks will need later (module docs).
    fn refresh_appearance(
        &mut self,
        frame: Option<&Frame<'_>>,
        matches: &[Pair],
        dets: &[Prepared<'_>],
    ) {
        let Some(frame) = frame else {
            return;
        };
        if self.needs.is_empty() || matches.is_empty() {
            return;
        }
        let crowded = self.crowded_next_frame();
        let refresh = self.config.appearance.refresh;
        for m in matches {
            let Some(d) = dets.get(m.det) else {
                continue;
            };
            if d.features.appearance.is_some() || d.det.mask.is_none() {
                continue;
            }
            let Some(t) = self.tracks.get(m.track) else {
                continue;
            };
            let whole = t.last_whole;
            let stale = t
                .reference
                .as_ref()
                .is_none_or(|r| self.frame.saturating_sub(r.frame) >= refresh);
            let near = crowded.get(m.track).copied().unwrap_or(false);
            if !(near || (whole && stale) || t.appearance.is_none()) {
                continue;
            }
            let a = self.appearance_of(frame, &d.det);
            if let (Some(a), Some(t)) = (a, self.tracks.get_mut(m.track)) {
                t.appearance = Some(a.clone());
                if whole {
                    t.reference = Some(a);
                }
            }
        }
    }

    /// Which tracks' boxes will touch another track's by the next frame: their next frame's
    /// clusters are likely to be ambiguous, and their appearance must be taken now. Only the
    /// tracks the main association will consider count (not lost ones with
    /// [`Config::lost_reid_only`], whose wide search regions would make every track crowded).
    fn crowded_next_frame(&self) -> Vec<bool> {
        let counted = |t: &Track| !(self.config.lost_reid_only && t.state == TrackState::Lost);
        let boxes: Vec<BBox> = self
            .tracks
            .iter()
            .map(|t| {
                if !counted(t) {
                    return BBox::new(f64::NAN, f64::NAN, 0.0, 0.0);
                }
                // Boxes that will touch by the next frame, give or take one frame of motion.
                let v = t.motion.velocity();
                let next = t.anchor.translated(v.x, v.y);
                next.expanded(v.x.hypot(v.y).min(next.w.max(next.h)))
            })
            .collect();
        let mut crowded = vec![false; boxes.len()];
        for (i, j) in overlapping_box_pairs(&boxes, &boxes, 0.0) {
            if i != j {
                crowded[i] = true;
                crowded[j] = true;
            }
        }
        crowded
    }

    /// Phase 8: unmatched tracks miss a frame; lost ones past `max_lost` are removed.
    fn age_lost(&mut self, matched: &[bool]) {
        let cfg = &self.config;
        for (i, t) in self.tracks.iter_mut().enumerate() {
            if matched.get(i).copied().unwrap_or(false) {
                continue;
            }
            t.misses += 1;
            match t.state {
                TrackState::Tentative if t.misses > cfg.max_tentative_misses => {
                    t.state = TrackState::Removed;
                }
                TrackState::Confirmed | TrackState::Lost => {
                    t.state = if t.misses > cfg.max_lost {
                        TrackState::Removed
                    } else {
                        TrackState::Lost
                    };
                }
                _ => {}
            }
        }
        self.tracks.retain(|t| t.state != TrackState::Removed);
    }

    /// Phase 9: report confirmed tracks missed right after a whole view at their predicted
    /// place ([`Config::coast_frames`]).
    fn coast(&mut self, out: &mut Vec<TrackedShape>) {
        let cfg = &self.config;
        if cfg.coast_frames == 0 {
            return;
        }
        let (frame, size) = (self.frame, self.frame_size);
        for t in &mut self.tracks {
            let Some(id) = t.id else {
                continue;
            };
            if t.state != TrackState::Lost || t.misses > cfg.coast_frames || !t.last_whole {
                continue;
            }
            let s = t.predicted_shift();
            if !(s.x.is_finite() && s.y.is_finite()) {
                continue;
            }
            let (mask, bbox) = match &t.last.mask {
                Some(m) => {
                    let (dx, dy) = (
                        s.x.round().clamp(-1e6, 1e6) as i32,
                        s.y.round().clamp(-1e6, 1e6) as i32,
                    );
                    let mut moved = m.translated(dx, dy);
                    if let Some((w, h)) = size {
                        moved = moved.clipped(w, h);
                    }
                    if moved.is_empty() {
                        continue;
                    }
                    let b = moved.bbox();
                    (Some(moved), b)
                }
                None => (None, t.predicted),
            };
            let centroid = t
                .features
                .as_ref()
                .map_or(t.predicted.center(), |f| f.centroid);
            t.reported_until = frame;
            out.push(TrackedShape {
                id,
                frame,
                bbox,
                mask,
                centroid: centroid + s,
                state: TrackState::Lost,
                score: t.last.score,
                class: t.last.class,
                cost: 0.0,
                det_index: None,
                interpolated: true,
            });
        }
    }

    /// Phase 10: confident unmatched detections start tentative tracks (confirmed at once when
    /// `min_hits` is 1).
    fn spawn(
        &mut self,
        frame: Option<&Frame<'_>>,
        dets: &[Prepared<'_>],
        det_used: &[bool],
        out: &mut Vec<TrackedShape>,
    ) -> Result<(), TrackError> {
        let max_iou = self.config.spawn_max_iou;
        let duplicate = |d: &Prepared<'_>| {
            max_iou < 1.0
                && dets
                    .iter()
                    .zip(det_used)
                    .any(|(o, &used)| used && o.det.bbox.iou(&d.det.bbox) > max_iou)
        };
        for (j, d) in dets.iter().enumerate() {
            if det_used.get(j).copied().unwrap_or(true)
                || !d.high
                || d.det.score < self.config.new_track_score
                || duplicate(d)
            {
                continue;
            }
            let motion = (self.motion)(&d.det.bbox)?;
            // Every track carries an appearance from birth, so that in an ambiguous cluster
            // no track's pairs lack the appearance terms that its rivals' pairs have.
            let appearance = match (&d.features.appearance, frame) {
                (Some(a), _) => Some(a.clone()),
                (None, Some(f)) if !self.needs.is_empty() => self.appearance_of(f, &d.det),
                _ => None,
            };
            let mut t = Track {
                id: None,
                state: TrackState::Tentative,
                predicted: d.det.bbox,
                anchor: d.det.bbox,
                ref_area: d.features.area,
                ref_size: (d.det.bbox.w, d.det.bbox.h),
                sizes: {
                    let mut s = Sizes::default();
                    s.push(d.features.area, d.det.bbox.w, d.det.bbox.h);
                    s
                },
                cuts: [None; 2],
                last_ratio: 1.0,
                last_whole: true,
                reported_until: 0,
                reference: appearance.clone(),
                appearance,
                snapshot: self.config.reupdate_after_gap.then(|| motion.clone_box()),
                motion,
                hits: 1,
                misses: 0,
                last_frame: self.frame,
                last: d.det.clone().into_owned(),
                features: Some(d.features.clone()),
                pending: Vec::new(),
            };
            if self.config.min_hits <= 1 {
                let id = self.next_id;
                self.next_id += 1;
                t.id = Some(id);
                t.state = TrackState::Confirmed;
                out.push(shape_of(self.frame, id, TrackState::Confirmed, d, 0.0));
            } else if self.config.report_tentative {
                t.pending
                    .push(shape_of(self.frame, 0, TrackState::Tentative, d, 0.0));
            }
            self.tracks.push(t);
        }
        Ok(())
    }
}

/// A mask detection reaching outside the frame, clipped to it (`None` when nothing is left);
/// detections inside the frame, box detections and frame-less calls are passed through.
/// An empty mask is dropped: it carries no shape.
fn clip_to_frame<'a>(det: &'a Detection, frame: Option<&Frame<'_>>) -> Option<Cow<'a, Detection>> {
    let Some(m) = det.mask.as_ref() else {
        return Some(Cow::Borrowed(det));
    };
    if m.is_empty() {
        return None;
    }
    let Some(f) = frame else {
        return Some(Cow::Borrowed(det));
    };
    let (w, h) = (f.width() as i64, f.height() as i64);
    let inside = m.x() >= 0
        && m.y() >= 0
        && m.x() as i64 + m.width() as i64 <= w
        && m.y() as i64 + m.height() as i64 <= h;
    if inside {
        return Some(Cow::Borrowed(det));
    }
    let clipped = m.clipped(f.width(), f.height());
    if clipped.is_empty() {
        return None;
    }
    Some(Cow::Owned(Detection {
        bbox: clipped.bbox(),
        mask: Some(clipped),
        score: det.score,
        class: det.class,
    }))
}

/// Which side of a partly hidden shape an occluder covers, on one axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Cut {
    /// The low side (left or top): the high side is seen and anchors the completion.
    Low,
    /// The high side (right or bottom).
    High,
    /// Both sides (or undecided): complete around the detection's centre.
    Both,
}

/// The whole shape's box for a partly hidden detection `d` (amodal completion): on each axis
/// where `d` is clearly shorter than the reference size `(rw, rh)` of the whole shape, `d` is
/// extended to it away from the occluded side.
///
/// The occluded side is decided once per occlusion, when the axis first needs completion, and
/// kept in `cuts` until the shape is seen whole again (deciding anew every frame would compare
/// with a prediction the occlusion has already dragged):
/// - a shape reappearing after a gap (`last` is `None`) shows its leading part first: the side
///   behind it along its velocity `v` is hidden;
/// - otherwise, comparing with the last detection `last` (seen `n` frames ago), per frame: the
///   side that stood still while the other moved (held by a static occluder: a bar, the frame
///   border); else
///   the side that strayed from moving with the shape's velocity (a moving occluder); else the
///   side that disagrees with the prediction `p`;
/// - else both sides: the view is a part of the shape that could lie anywhere in it, and the
///   completed box keeps the prediction's centre on that axis.
///
/// The reference size, not the prediction, is the target, so the completed box cannot shrink
/// with the view.
fn amodal_box(
    p: &BBox,
    d: &BBox,
    last: Option<(&BBox, u32)>,
    v: Point,
    (rw, rh): (f64, f64),
    whole: bool,
    cuts: &mut [Option<Cut>; 2],
) -> BBox {
    #[allow(clippy::too_many_arguments)]
    fn axis(
        (p0, pw): (f64, f64),
        (d0, dw): (f64, f64),
        last: Option<(f64, f64, f64)>,
        v: f64,
        rw: f64,
        whole: bool,
        cut: &mut Option<Cut>,
    ) -> (f64, f64) {
        let tol = (0.1 * rw).max(3.0);
        if !(rw.is_finite() && p0.is_finite() && pw.is_finite() && dw < rw - tol) {
            // Not cut on this axis now: a later cut is a new occlusion, decided afresh.
            *cut = None;
            return (d0, dw);
        }
        let side = *cut.get_or_insert_with(|| {
            // The side that disagrees with the prediction (displacements inwards).
            let (e0, e1) = (d0 - p0, (p0 + pw) - (d0 + dw));
            let by_prediction = if e1.abs() + tol <= e0 {
                Some(Cut::Low)
            } else if e0.abs() + tol <= e1 {
                Some(Cut::High)
            } else {
                None
            };
            // Motion along this axis that tells leading from trailing.
            let moving = v.abs() >= 0.5;
            let Some((l0, lw, k)) = last else {
                // After a gap the prediction is the only reference; a shape reappearing right
                // where predicted shows its leading part first.
                return by_prediction.unwrap_or(match (moving, v > 0.0) {
                    (false, _) => Cut::Both,
                    (true, true) => Cut::Low,
                    (true, false) => Cut::High,
                });
            };
            // Side motion per frame since the last detection: an occluder that does not move
            // (a bar, the frame border) holds its side still while the other follows the
            // shape; the prediction may already lag behind.
            let (s0, s1) = ((d0 - l0) / k, (d0 + dw - (l0 + lw)) / k);
            let step = (0.5 * v.abs()).max(1.0);
            if moving && s0.abs() + step <= s1.abs() && s0.abs() <= 1.0 {
                return Cut::Low;
            }
            if moving && s1.abs() + step <= s0.abs() && s1.abs() <= 1.0 {
                return Cut::High;
            }
            // A moving occluder: the side that strayed from moving with the shape.
            let (m0, m1) = ((s0 - v).abs(), (s1 - v).abs());
            if m1 + step <= m0 {
                return Cut::Low;
            }
            if m0 + step <= m1 {
                return Cut::High;
            }
            by_prediction.unwrap_or(Cut::Both)
        });
        match side {
            Cut::Low => (d0 + dw - rw, rw),
            Cut::High => (d0, rw),
            // No side to anchor on. A whole view (by area) is narrower because the shape
            // turned: its centre holds. A partial view is a cut-down part of the shape that
            // could lie anywhere in it and says nothing about the centre on this axis: keep
            // the prediction's.
            Cut::Both if whole => (d0 + dw / 2.0 - rw / 2.0, rw),
            Cut::Both => (p0 + pw / 2.0 - rw / 2.0, rw),
        }
    }
    let [cx, cy] = cuts;
    let k = |n: u32| n.max(1) as f64;
    let (x, w) = axis(
        (p.x, p.w),
        (d.x, d.w),
        last.map(|(l, n)| (l.x, l.w, k(n))),
        v.x,
        rw,
        whole,
        cx,
    );
    let (y, h) = axis(
        (p.y, p.h),
        (d.y, d.h),
        last.map(|(l, n)| (l.y, l.h, k(n))),
        v.y,
        rh,
        whole,
        cy,
    );
    BBox::new(x, y, w, h)
}

/// Largest gap, in pixels, between the shells of a detection and a fragment merged into it.
const FRAGMENT_GAP: f64 = 3.0;

/// The union of two masks, in the bitmap of their joint rectangle.
fn mask_union(a: &Mask, b: &Mask) -> Mask {
    let x0 = a.x().min(b.x());
    let y0 = a.y().min(b.y());
    let x1 = (a.x() as i64 + a.width() as i64).max(b.x() as i64 + b.width() as i64);
    let y1 = (a.y() as i64 + a.height() as i64).max(b.y() as i64 + b.height() as i64);
    let (w, h) = ((x1 - x0 as i64) as u32, (y1 - y0 as i64) as u32);
    let mut bits = vec![0u8; w as usize * h as usize];
    for (x, y) in a.pixels().chain(b.pixels()) {
        let i = (y - y0) as usize * w as usize + (x - x0) as usize;
        if let Some(v) = bits.get_mut(i) {
            *v = 1;
        }
    }
    Mask::new(x0, y0, w, h, bits).unwrap_or_else(|_| a.clone())
}

/// Frames without a match after which a shape's next view counts as a reappearance.
const REAPPEAR_GAP: u32 = 3;

/// A track's search shell in mask mode: its last shell moved by the predicted displacement
/// (swept along it when the track is lost or moves more than half its size per frame, so a
/// detection found part-way still meets it), merged with the predicted box (which, with amodal
/// completion, covers the whole shape even when the last view was partial), grown by
/// `factor` times the predicted box's geometric mean size.
fn search_shell(t: &Track, factor: f64) -> ConvexShell {
    let p = t.predicted;
    let shift = t.predicted_shift();
    let base = match t.features.as_ref().and_then(|f| f.shell.as_deref()) {
        Some(s) => s.clone(),
        None => ConvexShell::from_bbox(&t.anchor).unwrap_or_default(),
    };
    let size = (p.w.max(1.0) * p.h.max(1.0)).sqrt();
    let fast = shift.x.hypot(shift.y) > 0.5 * size;
    let moved = if fast || t.misses > 0 {
        base.swept(shift.x, shift.y)
    } else {
        base.translated(shift.x, shift.y)
    };
    let mut pts = moved.vertices().to_vec();
    if p.is_valid() {
        pts.extend(p.corners());
    }
    let merged = ConvexShell::from_points(&pts).unwrap_or(moved);
    merged.grown(factor * size)
}

/// OC-SORT's observation-centric re-update: a track matched again after `misses` unmatched
/// frames has a filter that drifted on predictions alone (its velocity and covariance are off).
/// Restart from the snapshot taken at the last match and feed it virtual observations on the
/// straight line from the last box to the new one, one per missed frame; the caller then
/// applies the real update. The filter leaves the gap with the velocity the gap implies.
fn reupdate(
    snapshot: &dyn BoxMotionModel,
    last: &BBox,
    new: &BBox,
    misses: u32,
) -> Result<BoxMotion, MotionError> {
    let mut m = snapshot.clone_box();
    let n = misses as f64 + 1.0;
    for i in 1..=misses {
        let a = i as f64 / n;
        let lerp = |p: f64, q: f64| p + (q - p) * a;
        m.predict();
        m.update(&BBox::new(
            lerp(last.x, new.x),
            lerp(last.y, new.y),
            lerp(last.w, new.w),
            lerp(last.h, new.h),
        ))?;
    }
    m.predict();
    Ok(m)
}

fn shape_of(frame: u32, id: u64, state: TrackState, d: &Prepared<'_>, cost: f64) -> TrackedShape {
    TrackedShape {
        id,
        frame,
        bbox: d.det.bbox,
        mask: d.det.mask.clone(),
        centroid: d.features.centroid,
        state,
        score: d.det.score,
        class: d.det.class,
        cost,
        det_index: Some(d.index),
        interpolated: false,
    }
}
