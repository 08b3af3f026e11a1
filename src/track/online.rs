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
//! - **associate** ([`super::associate`]): the stages [`stages`] builds from the config, run
//!   in turn, each an optimal assignment; the re-identification stage scores its pairs when
//!   its turn comes (describing its detections then).
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

use std::borrow::Cow;
use std::sync::Arc;

use super::appearance::cost_models;
use super::associate::{
    in_main, score_edges, score_edges_reusing, Edge, Pair, Stage, StageCosts, StagePlan, Used,
};
use super::camera::Camera;
use super::coasting::GapStats;
use super::config::{Config, ReportBox};
use super::cost::{CheapTerms, CostModel, PairCost};
use super::describe::{ambiguous_detections, crowded_next_frame, Ambiguity};
use super::estimate::NoiseFit;
use super::features::{Appearance, FeatureExtractor, MaskFeatures, Needs};
use super::fragments::{merge_fragments, merged_views, Merge};
use super::hindsight::Removed;
use super::lifecycle::{two_mut, BoxMotion, Track};
use super::prepare::{check_frame_size, kept, prepare, shape_of, validate, Prepared};
use super::regions::Regions;
use super::scores::{ScoreStats, Thresholds};
use super::search::{frame_regions, in_frame_regions, reid_regions};
use super::timing::{Phase, PhaseTimes, Timer};
use super::TrackError;
use crate::assign::Unmatched;
use crate::frame::{BBox, Detection, Frame, TrackState, TrackedShape};
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
            t.associate(frame, &main, &regions, &mut dets)
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

    /// Appearance for the detections geometry cannot decide (see `describe`). With
    /// [`Config::lost_reid_only`], the lost tracks outside the main association do not count:
    /// they are not in the frame's regions (`search::in_frame_regions`, on a frame with its
    /// image, the only kind described here), and the reid stage describes the detections it
    /// needs once the others have taken theirs.
    fn describe(
        &self,
        frame: Option<&Frame<'_>>,
        regions: &Regions,
        dets: &mut [Prepared<'_>],
        cheap: &mut CheapTerms,
    ) {
        let Some(frame) = frame else {
            return;
        };
        if self.needs.is_empty() {
            return;
        }
        let want = if self.config.appearance.lazy {
            // Detections carry no appearance yet, so the appearance terms have no data here.
            // Every pair of the frame's regions, as the main scoring reads them: that scoring
            // then reuses these cheap terms.
            let geometric =
                score_edges_reusing(&self.costs, &self.tracks, regions, dets, |_| true, cheap);
            let ambiguity = Ambiguity {
                max_cost: self.config.max_cost,
                margin: self.config.appearance.ambiguity,
            };
            ambiguous_detections(&self.tracks, dets.len(), &geometric, &ambiguity)
        } else {
            vec![true; dets.len()]
        };
        for (d, w) in dets.iter_mut().zip(want) {
            if w && d.features.appearance.is_none() {
                d.features.appearance = self.appearance_of(frame, &d.det);
            }
        }
    }

    /// The appearance of one detection (`None` without a mask, or if the extractor fails),
    /// timed as features wherever it is asked for.
    fn appearance_of(&self, frame: &Frame<'_>, det: &Detection) -> Option<Arc<Appearance>> {
        det.mask.as_ref()?;
        self.timer.time(Phase::Features, || {
            match self.extractor.describe(frame, det, self.frame) {
                Ok(a) => a.map(Arc::new),
                Err(_) => None,
            }
        })
    }

    /// Runs the association stages in turn (see [`super::associate`]).
    fn associate(
        &self,
        frame: Option<&Frame<'_>>,
        main: &[Edge],
        regions: &Regions,
        dets: &mut [Prepared<'_>],
    ) -> Result<Vec<Pair>, TrackError> {
        let mut used = Used::new(self.tracks.len(), dets.len());
        let mut out = Vec::new();
        let policy = match self.config.unmatched_cost {
            Some(l) => Unmatched::Cost(l),
            None => Unmatched::MaxMatches,
        };
        for stage in self.stages.for_frame(frame.is_some()) {
            let edges = match stage.costs {
                StageCosts::Main => Cow::Borrowed(main),
                StageCosts::Reid if self.reid_costs.terms().is_empty() => continue,
                StageCosts::Reid => Cow::Owned(self.reid_edges(frame, regions, dets, &used)),
            };
            stage.run(&self.tracks, dets, &edges, policy, &mut used, &mut out)?;
        }
        Ok(out)
    }

    /// The re-identification costs of the lost tracks' pairs with the high detections nobody
    /// took yet, those detections described first if the terms need appearance.
    fn reid_edges(
        &self,
        frame: Option<&Frame<'_>>,
        regions: &Regions,
        dets: &mut [Prepared<'_>],
        used: &Used,
    ) -> Vec<Edge> {
        let high: Vec<bool> = dets.iter().map(|d| d.high).collect();
        let wanted = |&(t, d): &(usize, usize)| {
            self.tracks[t].state() == TrackState::Lost
                && !used.tracks[t]
                && !used.dets[d]
                && high.get(d).copied().unwrap_or(false)
        };
        // The lost tracks the frame's regions left out are met with the detections still
        // free (see `search::in_frame_regions`); otherwise the frame's regions have every pair.
        let has_frame = frame.is_some();
        let own;
        let regions = if self
            .tracks
            .iter()
            .all(|t| in_frame_regions(&self.config, t, has_frame))
        {
            regions
        } else {
            let cfg = &self.config;
            let found = self.timer.time(Phase::Regions, || {
                reid_regions(cfg, &self.tracks, dets, &used.tracks, &used.dets)
            });
            // Nothing to re-identify (most frames of a sparse scene): no edges.
            let Some(found) = found else {
                return Vec::new();
            };
            own = found;
            &own
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
        self.timer.time(Phase::Costs, || {
            score_edges(&self.reid_costs, &self.tracks, regions, dets, wanted)
        })
    }

    /// Every match updates its track (`Track::hit`); tentative tracks with enough hits are
    /// confirmed (or absorbed by the lost track they re-identify), confirmed and lost ones
    /// report their shape. Returns which tracks were matched.
    fn update_matched(
        &mut self,
        matches: &[Pair],
        dets: &[Prepared<'_>],
        out: &mut Vec<TrackedShape>,
    ) -> Result<Vec<bool>, TrackError> {
        let (frame, min_hits) = (self.frame, self.config.confirm_hits());
        let report = self.config.report_tentative;
        let mut matched = vec![false; self.tracks.len()];
        let mut confirming = Vec::new();
        let merged = merged_views(&self.tracks, matches, dets, &self.config.appearance);
        for (m, merged) in matches.iter().zip(merged) {
            let (Some(d), true) = (dets.get(m.det), m.track < self.tracks.len()) else {
                continue;
            };
            matched[m.track] = true;
            let t = &mut self.tracks[m.track];
            if t.id().is_some() {
                self.gaps.closed(t.misses());
            }
            let cfg = &self.config;
            t.hit(&d.det, &d.features, frame, cfg, merged, &mut self.noise)?;
            let enough = match self.config.birth_evidence {
                Some(low) => {
                    let w = if d.det.score >= self.thresholds.birth {
                        1.0
                    } else {
                        low
                    };
                    // Matches weigh by score; a tiny tolerance absorbs float sums like 10 × 0.1.
                    t.add_evidence(w) + 1e-9 >= min_hits as f64
                }
                None => t.hits() >= min_hits,
            };
            match t.state() {
                TrackState::Tentative if enough => confirming.push(*m),
                TrackState::Tentative => {
                    if report {
                        let sh = shape_of(frame, 0, TrackState::Tentative, d, m.cost);
                        let sh = t.reported_shape(&self.config, &self.noise, sh);
                        t.hold(sh);
                    }
                }
                _ => {
                    t.found();
                    self.scores.observe_matched(d.det.score);
                    if let Some(id) = t.id() {
                        let sh = shape_of(frame, id, TrackState::Confirmed, d, m.cost);
                        out.push(t.reported_shape(&self.config, &self.noise, sh));
                        t.reported(frame);
                    }
                }
            }
        }
        for m in confirming {
            let Some(d) = dets.get(m.det) else {
                continue;
            };
            if let Some(h) = &self.config.hindsight {
                let gap = self.config.frames(h.max_gap);
                let t = &mut self.tracks[m.track];
                if let Some(earlier) = self.removed.take_leading_to(t.held(), h, gap) {
                    t.prepend_held(earlier);
                }
            }
            // A shape that reappears from behind an occluder may start a new track before it
            // is recognised (its first views are slivers); at confirmation, with min_hits views
            // of evidence, a lost track it matches takes it over, history included.
            let target = match self.reidentify_at_confirmation(m.track, d, &matched) {
                Some(lost) => {
                    matched[lost] = true;
                    let (l, newer) = two_mut(&mut self.tracks, lost, m.track);
                    self.gaps.closed(l.misses());
                    let cfg = &self.config;
                    l.hit(&d.det, &d.features, frame, cfg, false, &mut self.noise)?;
                    l.absorb(newer);
                    lost
                }
                None => {
                    let id = self.new_id();
                    self.tracks[m.track].confirm(id);
                    m.track
                }
            };
            self.scores.observe_matched(d.det.score);
            let t = &mut self.tracks[target];
            t.found();
            let Some(id) = t.id() else {
                continue;
            };
            if report {
                out.extend(t.release());
            }
            t.drop_held();
            let sh = shape_of(frame, id, TrackState::Confirmed, d, m.cost);
            out.push(t.reported_shape(&self.config, &self.noise, sh));
            t.reported(frame);
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
        let class = self.tracks.get(tentative)?.last_detection().class;
        let cand = d.candidate();
        let mut best: Option<(usize, f64)> = None;
        for (i, t) in self.tracks.iter().enumerate() {
            let tc = t.last_detection().class;
            if i == tentative
                || t.state() != TrackState::Lost
                || t.id().is_none()
                || matched.get(i).copied().unwrap_or(true)
                || (class >= 0 && tc >= 0 && class != tc)
            {
                continue;
            }
            let max = self.config.reid_max_cost;
            if let Some(c) = self
                .reid_costs
                .cost_within(t, &cand, max, best.map(|b| b.1))
            {
                best = Some((i, c));
            }
        }
        best.map(|(i, _)| i)
    }

    /// Takes now the appearance matched tracks will need later (see `describe`):
    /// before a crossing, and while the reference view is missing or stale.
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
        let crowded = crowded_next_frame(&self.tracks, |t| in_main(&self.config, t));
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
            let whole = t.last_seen_whole();
            let stale = t
                .reference_appearance()
                .is_none_or(|r| self.frame.saturating_sub(r.frame) >= refresh);
            let near = crowded.get(m.track).copied().unwrap_or(false);
            if !(near || (whole && stale) || t.appearance().is_none()) {
                continue;
            }
            let a = self.appearance_of(frame, &d.det);
            if let (Some(a), Some(t)) = (a, self.tracks.get_mut(m.track)) {
                t.set_appearance(a, whole);
            }
        }
    }

    /// Unmatched tracks miss a frame; removed ones are dropped.
    fn age(&mut self, matched: &[bool], has_frame: bool) {
        let (tentative, lost) = (
            self.config.frames(self.config.max_tentative_misses),
            self.config.max_lost_frames(has_frame),
        );
        let hindsight = self
            .config
            .hindsight
            .map(|h| (h, self.config.frames(h.max_gap)));
        for (i, t) in self.tracks.iter_mut().enumerate() {
            if !matched.get(i).copied().unwrap_or(false) {
                self.camera.follow_missed(t);
                t.miss(tentative, lost);
                if t.state() == TrackState::Removed && t.id().is_some() {
                    self.gaps.ended(t.misses());
                }
                if let (TrackState::Removed, None, Some((h, gap))) = (t.state(), t.id(), &hindsight)
                {
                    self.removed.keep(t.take_held(), h, *gap);
                }
            }
        }
        if let Some((_, gap)) = hindsight {
            // A piece can still be attached to a track whose first view is `gap` frames after
            // it and that is confirmed later; a track still tentative after this many frames
            // has long been removed (every miss beyond `max_tentative_misses` removes it).
            let span = gap + 1 + 4 * self.config.confirm_hits() * (tentative + 1);
            self.removed.forget_before(self.frame.saturating_sub(span));
        }
        self.tracks.retain(|t| t.state() != TrackState::Removed);
    }

    /// Reports confirmed tracks missed right after a whole view at their predicted place
    /// ([`Config::coast_frames`]).
    fn coast(&mut self, out: &mut Vec<TrackedShape>) {
        let max = self.config.frames(self.config.coast_frames);
        if max == 0 {
            return;
        }
        let (frame, size) = (self.frame, self.frame_size);
        let (gaps, adaptive) = (&self.gaps, self.config.coasting);
        let likely = |misses: u32| {
            adaptive.is_none_or(|c| gaps.closes_within(misses, max) >= c.min_probability)
        };
        out.extend(
            self.tracks
                .iter_mut()
                .filter(|t| likely(t.misses()))
                .filter_map(|t| t.coast(frame, size, max)),
        );
    }

    /// Confident unmatched detections start tentative tracks (confirmed at once when
    /// `min_hits` is 1). An unmatched detection overlapping a matched one by more than
    /// [`Config::spawn_max_iou`] is taken for a duplicate and starts nothing.
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
            let weak = d.det.score < self.thresholds.birth;
            if det_used.get(j).copied().unwrap_or(true)
                || !d.high
                || (weak && self.config.birth_evidence.is_none())
                || duplicate(d)
            {
                continue;
            }
            let motion = (self.motion)(&d.det.bbox)?;
            // Every track carries an appearance from birth, so that in an ambiguous group
            // no track's pairs lack the appearance terms that its rivals' pairs have.
            let appearance = match (&d.features.appearance, frame) {
                (Some(a), _) => Some(a.clone()),
                (None, Some(f)) if !self.needs.is_empty() => self.appearance_of(f, &d.det),
                _ => None,
            };
            let snapshot = self.config.reupdate_after_gap;
            let mut t = Track::born(
                &d.det,
                &d.features,
                motion,
                appearance,
                self.frame,
                snapshot,
                self.config.report_box == ReportBox::Adaptive,
            );
            let evidence = match self.config.birth_evidence {
                Some(low) => t.add_evidence(if weak { low } else { 1.0 }),
                None => 1.0,
            };
            if evidence + 1e-9 >= self.config.confirm_hits() as f64 {
                let id = self.new_id();
                t.confirm(id);
                out.push(shape_of(self.frame, id, TrackState::Confirmed, d, 0.0));
                t.reported(self.frame);
            } else if self.config.report_tentative {
                t.hold(shape_of(self.frame, 0, TrackState::Tentative, d, 0.0));
            }
            self.tracks.push(t);
        }
        Ok(())
    }

    /// The next id of this tracker's own counter.
    fn new_id(&mut self) -> u64 {
        let id = self.next_id;
        self.next_id += 1;
        id
    }
}
