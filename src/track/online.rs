//! The online tracker: one [`Tracker::update`] per frame, a short sequence of named phases.
//!
//! ```text
//! prepare → predict → estimate regions → describe → score pairs → associate
//!   → merge fragments → update matched → refresh appearance → age → coast → spawn
//! ```
//!
//! - **prepare** (`prepare`): validate the detections (typed errors, before any state
//!   changes), clip masks to the frame, drop detections below `min_score`, with zero area or
//!   an empty mask, split the rest into high and low confidence, and compute each one's cheap
//!   [`Features`](super::Features) once (centroid, area, and for masks the convex shell).
//! - **predict**: every track's motion filter steps one frame (`Track::predict`).
//! - **estimate regions** (thesis Alg. 2): box mode: the predicted boxes, grown by a margin
//!   that widens while a track is unmatched, meet the detections' boxes
//!   ([`super::regions::estimate_regions`]). With masks: each track's search shell
//!   (`Track::search_shell`) meets the detections' shells by GJK
//!   ([`crate::region::region_clusters`]). Only pairs inside a cluster are ever scored. The
//!   lost tracks that only re-identification looks for wait for its stage (`search`).
//! - **describe** (`describe`): appearance for the detections of clusters that
//!   geometry cannot decide.
//! - **score pairs**: the [`CostModel`] combines the enabled [`PairCost`] terms per pair;
//!   cluster-normalised terms (C1, C2) rank pairs, thresholds compare the others.
//! - **associate** ([`super::associate`]): the stages [`super::associate::stages`] builds
//!   from the config, run in turn, each an optimal assignment; the re-identification stage
//!   scores its pairs when its turn comes (describing its detections then).
//! - **merge fragments** (`fragments`): a detector-split shape is put back together.
//! - **update matched**: `Track::hit` for every match (amodal completion, filter, sizes,
//!   appearance; not the filter for a view merged with a neighbour's, `fragments`); tentative
//!   tracks with enough hits are confirmed and get an id (or, with
//!   [`Config::reid_at_confirmation`], a lost track they re-identify takes them over,
//!   `Track::absorb`); lost tracks are re-identified under their old id.
//! - **refresh appearance**: matched tracks' appearance is taken now when it will be needed
//!   and this frame is the last chance to see it (`describe`).
//! - **age**: unmatched tracks miss a frame (`Track::miss`): tentative ones are removed after
//!   `max_tentative_misses`, confirmed ones become lost and are removed after `max_lost`.
//! - **coast**: with [`Config::coast_frames`], confirmed tracks seen whole and missed for at
//!   most that many frames are reported at their predicted place (`Track::coast`).
//! - **spawn**: confident unmatched detections start tentative tracks (`Track::born`), each
//!   with an appearance (so that no track lacks the appearance terms its rivals have).
//!
//! **What is reported.** Each call returns the confirmed tracks matched in this frame, with the
//! matched detection's box, mask and score (boxes are never invented online). With
//! `report_tentative`, the call that confirms a track also returns its earlier tentative frames
//! (with their own frame numbers), so a track's first `min_hits − 1` frames are not lost. Lost
//! tracks are not reported (except short coasts, above): filling their gaps is the offline
//! pass's job.
//!
//! **Bad input.** Non-finite or negative boxes and scores are typed errors
//! ([`TrackError::InvalidDetection`]), so is a frame whose size differs from the previous
//! frames' ([`TrackError::FrameSize`]: start a new tracker for a new video size); a mask is
//! clipped to the frame, and dropped like a zero-area box if empty. None change the state.

mod apply;
mod matching;

use super::appearance::cost_models;
use super::associate::{score_edges_reusing, Stage, StagePlan};
use super::camera::Camera;
use super::coasting::GapStats;
use super::config::Config;
use super::cost::{CheapTerms, CostModel, PairCost};
use super::estimate::NoiseFit;
use super::features::{FeatureExtractor, MaskFeatures, Needs};
use super::fragments::{merge_fragments, Merge};
use super::hindsight::Removed;
use super::lifecycle::{BoxMotion, Track};
use super::prepare::{check_frame_size, kept, prepare, validate};
use super::scores::{ScoreStats, Thresholds};
use super::search::frame_regions;
use super::timing::{Phase, PhaseTimes, Timer};
use super::TrackError;
use crate::frame::{BBox, Detection, Frame, TrackedShape};
use crate::motion::{BoxKalman, MotionError, MotionFactory};

/// Builds a new track's motion filter from its first box.
type MotionBuilder = Box<dyn Fn(&BBox) -> Result<BoxMotion, MotionError> + Send>;

/// The online multi-object tracker. Owns its tracks and its id counter.
pub struct Tracker {
    config: Config,
    /// The association stages, built from `config` (and its rules without frames).
    stages: StagePlan,
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
    /// The sequence's scores, for adaptive thresholds.
    scores: ScoreStats,
    /// The score thresholds of the current frame.
    thresholds: Thresholds,
    /// How this tracker's gaps ended, for adaptive coasting.
    gaps: GapStats,
    /// Removed tentative tracks' views, for [`Config::hindsight`].
    removed: Removed,
    timer: Timer,
    /// The camera's motion as followed so far.
    camera: Camera,
    /// How well each smoothing of the reported boxes has agreed with what came next in this
    /// sequence (see [`super::estimate`]).
    noise: NoiseFit,
    /// The frame's cheap pair terms, kept between its two scorings (see `update`); emptied
    /// at each frame, its buffers reused.
    cheap: CheapTerms,
    /// Whether the detector boxes visible parts ([`Config::complete_cut_boxes`]).
    cut: super::cut_views::CutJudge,
    /// The unambiguous matches' costs ([`Config::adaptive_gate`]).
    gate: super::gate::GateStats,
}

impl std::fmt::Debug for Tracker {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Tracker")
            .field("config", &self.config)
            .field("stages", &self.stages)
            .field("costs", &self.costs)
            .field("reid_costs", &self.reid_costs)
            .field("tracks", &self.tracks)
            .field("frame", &self.frame)
            .field("next_id", &self.next_id)
            .finish_non_exhaustive()
    }
}

impl Tracker {
    /// A tracker with the terms of `config` (geometry, motion and appearance), the
    /// constant-velocity box Kalman filter and the [`MaskFeatures`] extractor (which gives box
    /// detections their centre only, so box mode needs nothing else).
    pub fn new(config: Config) -> Result<Self, TrackError> {
        config.validate()?;
        let params = config.motion_params();
        let motion: MotionBuilder = Box::new(move |z: &BBox| -> Result<BoxMotion, MotionError> {
            Ok(Box::new(BoxKalman::new(z, params)?))
        });
        let (costs, reid_costs) = cost_models(&config);
        let needs = config.appearance_needs();
        let scores = ScoreStats::new(config.score_adaptation.unwrap_or_default());
        let thresholds = Thresholds {
            high: config.high_score,
            birth: config.new_track_score,
        };
        Ok(Self {
            stages: StagePlan::new(&config),
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
            scores,
            thresholds,
            gaps: GapStats::default(),
            removed: Removed::default(),
            timer: Timer::default(),
            camera: Camera::default(),
            noise: NoiseFit::default(),
            cheap: CheapTerms::default(),
            cut: Default::default(),
            gate: Default::default(),
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
        self.timer = Timer::with_clock(Box::new(clock));
        self
    }

    /// Time spent per phase since [`Tracker::with_clock`] (all zero without a clock).
    pub fn phase_times(&self) -> PhaseTimes {
        self.timer.times()
    }

    /// Tells the tracker the frame size when it gets no frames (box mode), so that box tracks
    /// predicted out of view are not coasted; frames of another size are then an error.
    pub fn with_image_size(mut self, width: u32, height: u32) -> Self {
        self.frame_size = Some((width, height));
        self
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

    /// The association stages on frames given with their image, in the order they run
    /// (without it, those of [`Config::without_frames`]).
    pub fn stages(&self) -> &[Stage] {
        self.stages.for_frame(true)
    }

    /// The live tracks (tentative, confirmed and lost).
    pub fn tracks(&self) -> &[Track] {
        &self.tracks
    }

    /// Number of frames processed so far (the last frame's number, 1-based).
    pub fn frame(&self) -> u32 {
        self.frame
    }

    /// Skips `n` frames without detections while the tracker has no live track: nothing can
    /// change then but the frame count, so a long empty stretch (a sequence whose declared
    /// length runs far past its detections) costs nothing. Returns how many frames were
    /// skipped: `n` when there is no live track, else 0 (the caller updates frame by frame).
    pub fn skip_idle(&mut self, n: u32) -> u32 {
        if !self.tracks.is_empty() {
            return 0;
        }
        let n = n.min(u32::MAX - self.frame);
        self.frame += n;
        n
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
        check_frame_size(frame, self.frame_size)?;
        validate(detections)?;
        self.thresholds = self.next_thresholds(detections);
        let (min, high) = (self.config.min_score, self.thresholds.high);
        let extractor = self.extractor.as_ref();
        let mut dets = self.timer.time(Phase::Features, || {
            prepare(detections, frame, min, high, extractor)
        })?;
        if let Some(f) = frame {
            self.frame_size = Some((f.width(), f.height()));
        }
        self.frame += 1;
        let regions = self.timed(Phase::Regions, |t| {
            t.predict();
            t.camera
                .follow(&mut t.tracks, &dets, t.config.camera_motion);
            // Mask detections are completed anyway: the judgement is only needed (and its
            // cost only paid) for frames with box detections.
            let boxes_only = detections.iter().any(|d| d.mask.is_none());
            if t.config.amodal && t.config.complete_cut_boxes && boxes_only {
                let boxes: Vec<BBox> = detections.iter().map(|d| d.bbox).collect();
                t.cut.observe(&boxes);
            }
            frame_regions(&t.config, &t.tracks, &dets, frame.is_some())
        });
        // The cheap terms of the pairs, when `describe` scores them by geometry first, are
        // read again by the main scoring rather than computed twice.
        let mut cheap = std::mem::take(&mut self.cheap);
        cheap.clear();
        self.timed(Phase::Features, |t| {
            t.describe(frame, &regions, &mut dets, &mut cheap)
        });
        let main = self.timed(Phase::Costs, |t| {
            score_edges_reusing(&t.costs, &t.tracks, &regions, &dets, |_| true, &mut cheap)
        });
        self.cheap = cheap;
        let matches = self.timed(Phase::Assignment, |t| {
            let (matches, from_main) = t.associate(frame, &main, &regions, &mut dets)?;
            if t.config.adaptive_gate.is_some() {
                t.gate
                    .observe(&main, &matches[..from_main], t.config.main_max_cost());
            }
            Ok::<_, TrackError>(matches)
        })?;
        let out = self.timed(Phase::Update, |t| {
            let mut det_used = vec![false; dets.len()];
            for m in &matches {
                det_used[m.det] = true;
            }
            if t.config.merge_fragments {
                let merge = Merge {
                    max_cost: t.config.main_max_cost(),
                    whole_ratio: t.config.appearance.whole_ratio,
                    extractor: t.extractor.as_ref(),
                };
                merge_fragments(
                    &t.tracks,
                    &matches,
                    &main,
                    &mut dets,
                    &mut det_used,
                    &merge,
                    frame,
                )?;
            }
            let mut out = Vec::new();
            let matched = t.update_matched(&matches, &dets, &mut out)?;
            t.refresh_appearance(frame, &matches, &dets);
            t.age(&matched, frame.is_some());
            t.coast(&mut out);
            t.spawn(frame, &dets, &det_used, &mut out)?;
            Ok::<_, TrackError>(out)
        })?;
        self.timer.frame_done();
        Ok(out)
    }

    /// The score thresholds of this frame: the fixed ones, or with
    /// [`Config::score_adaptation`] quantiles of the sequence's scores including this frame's
    /// (so the first frame already has some).
    fn next_thresholds(&mut self, detections: &[Detection]) -> Thresholds {
        let fixed = Thresholds {
            high: self.config.high_score,
            birth: self.config.new_track_score,
        };
        if self.config.score_adaptation.is_none() {
            return fixed;
        }
        for d in detections.iter().filter(|d| kept(d, self.config.min_score)) {
            self.scores.observe(d.score);
        }
        self.scores.thresholds(fixed)
    }

    /// The score thresholds in force for the last frame.
    pub fn thresholds(&self) -> Thresholds {
        self.thresholds
    }

    /// Runs `f` on the tracker as phase `phase` of the timing.
    fn timed<T>(&mut self, phase: Phase, f: impl FnOnce(&mut Self) -> T) -> T {
        self.timer.enter(phase);
        let r = f(self);
        self.timer.exit();
        r
    }

    /// Every filter steps one frame.
    fn predict(&mut self) {
        for t in &mut self.tracks {
            t.predict(self.config.lost_velocity_decay);
        }
    }
}
