//! The online tracker: one [`Tracker::update`] per frame, in named phases.
//!
//! ```text
//! prepare → predict → estimate regions → score pairs → assign → update matched → age lost → spawn
//! ```
//!
//! - **prepare**: validate the detections (typed errors, before any state changes), drop those
//!   below `min_score` or with zero area, split the rest into high and low confidence, and
//!   compute each one's [`Features`] once.
//! - **predict**: every track's motion filter steps one frame.
//! - **estimate regions**: the predicted boxes, grown by a margin that widens while a track is
//!   unmatched, meet the detections' boxes ([`estimate_regions`]); only those pairs are scored.
//! - **score pairs**: the [`CostModel`] combines the enabled [`PairCost`] terms per pair.
//! - **assign**: optimal assignment in three stages (ByteTrack-style): (1) confirmed and lost
//!   tracks × high detections, (2) tracks still unmatched that were matched last frame × low
//!   detections, (3) tentative tracks × the remaining high detections.
//! - **update matched**: filters correct, tentative tracks with enough hits are confirmed and
//!   get an id, lost tracks are re-identified under their old id.
//! - **age lost**: unmatched tracks become lost, and are removed after `max_lost` frames
//!   (tentative ones after `max_tentative_misses`).
//! - **spawn**: confident unmatched detections start tentative tracks.
//!
//! **What is reported.** Each call returns the confirmed tracks matched in this frame, with the
//! matched detection's box, mask and score (boxes are never invented online). With
//! `report_tentative`, the call that confirms a track also returns its earlier tentative frames
//! (with their own frame numbers), so a track's first `min_hits − 1` frames are not lost. Lost
//! tracks are not reported: filling their gaps is the offline pass's job.

use super::config::Config;
use super::cost::{Candidate, CostModel, PairCost};
use super::lifecycle::{BoxMotion, Track};
use super::regions::{estimate_regions, Regions};
use super::TrackError;
use crate::assign::{self, Unmatched};
use crate::frame::{BBox, Detection, Frame, Point, TrackState, TrackedShape};
use crate::motion::{BoxKalman, BoxMotionModel, MotionError, MotionFactory};

/// Per-detection features, computed once per frame by a [`FeatureExtractor`] and kept on the
/// track as its last appearance when the detection is matched.
///
/// Appearance modules add their descriptors here (shape context, colour palette, SIFT
/// keypoints); the pair-cost terms that read them return "no data" while a field is absent.
#[derive(Debug, Clone, Default, PartialEq)]
#[non_exhaustive]
pub struct Features {
    /// Centroid: mask moments (thesis eq. 10) when there is a mask, else the box centre.
    pub centroid: Point,
}

impl Features {
    /// Features holding a centroid only.
    pub fn with_centroid(centroid: Point) -> Self {
        Self { centroid }
    }
}

/// Computes a detection's [`Features`] (once per detection per frame).
pub trait FeatureExtractor: Send {
    /// The features of `det` in `frame` (`None` in box mode, where there are no pixels).
    fn extract(&self, frame: Option<&Frame<'_>>, det: &Detection) -> Result<Features, String>;
}

/// The default extractor: the centroid only. Needs no image.
#[derive(Debug, Clone, Copy, Default)]
pub struct BoxFeatures;

impl FeatureExtractor for BoxFeatures {
    fn extract(&self, _frame: Option<&Frame<'_>>, det: &Detection) -> Result<Features, String> {
        Ok(Features::with_centroid(det.centroid()))
    }
}

/// Builds a new track's motion filter from its first box.
type MotionBuilder = Box<dyn Fn(&BBox) -> Result<BoxMotion, MotionError> + Send>;

/// Largest box coordinate or size accepted (pixels): far beyond any image, far below overflow.
const MAX_COORDINATE: f64 = 1e9;

/// A detection that survived `prepare`.
struct Prepared<'a> {
    index: usize,
    det: &'a Detection,
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

/// An allowed (track, prepared detection) pair and its combined cost.
type Edge = (usize, usize, f64);

/// The allowed pairs of one frame, sparse: a track only has the few candidates its region
/// estimate found, so nothing here is `tracks × detections`.
struct Scores {
    main: Vec<Edge>,
    reid: Option<Vec<Edge>>,
}

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
    motion: MotionBuilder,
    tracks: Vec<Track>,
    frame: u32,
    next_id: u64,
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

impl Tracker {
    /// A tracker with the built-in terms of `config`, the constant-velocity box Kalman filter
    /// and the centroid-only feature extractor.
    pub fn new(config: Config) -> Result<Self, TrackError> {
        config.validate()?;
        let params = config.motion;
        let motion: MotionBuilder = Box::new(move |z: &BBox| -> Result<BoxMotion, MotionError> {
            Ok(Box::new(BoxKalman::new(z, params)?))
        });
        Ok(Self {
            costs: CostModel::from_terms(&config.terms),
            reid_costs: CostModel::from_terms(&config.reid_terms),
            config,
            extractor: Box::new(BoxFeatures),
            motion,
            tracks: Vec::new(),
            frame: 0,
            next_id: 1,
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

    /// Replaces the feature extractor.
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
    /// (NaN or infinite values, negative sizes) are rejected with an error before the tracker's
    /// state changes.
    pub fn update(
        &mut self,
        frame: Option<&Frame<'_>>,
        detections: &[Detection],
    ) -> Result<Vec<TrackedShape>, TrackError> {
        let dets = self.prepare(frame, detections)?;
        self.frame += 1;
        self.predict();
        let regions = self.estimate_regions(&dets);
        let scores = self.score_pairs(&regions, &dets);
        let matches = self.assign(&scores, &dets)?;
        let mut out = Vec::new();
        let matched_tracks = self.update_matched(&matches, &dets, &mut out)?;
        self.age_lost(&matched_tracks);
        let mut det_used = vec![false; dets.len()];
        for m in &matches {
            det_used[m.det] = true;
        }
        self.spawn(&dets, &det_used, &mut out)?;
        Ok(out)
    }

    /// Phase 0: validate, filter, classify and extract features.
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
            let features = self
                .extractor
                .extract(frame, det)
                .map_err(|message| TrackError::Features { index, message })?;
            out.push(Prepared {
                index,
                det,
                features,
                high: det.score >= self.config.high_score,
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

    /// Phase 2: which pairs are close enough to compare.
    fn estimate_regions(&self, dets: &[Prepared<'_>]) -> Regions {
        let shells: Vec<BBox> = self
            .tracks
            .iter()
            .map(|t| {
                let f = self.config.region_margin
                    + self.config.region_margin_per_miss * t.misses as f64;
                let p = t.predicted;
                BBox::from_center(p.center(), p.w * (1.0 + 2.0 * f), p.h * (1.0 + 2.0 * f))
            })
            .collect();
        let det_shells: Vec<BBox> = dets.iter().map(|d| d.det.bbox).collect();
        estimate_regions(&shells, &det_shells)
    }

    /// Phase 3: the combined cost of every candidate pair (sparse): the main association's,
    /// and the re-identification stage's (lost tracks only).
    fn score_pairs(&self, regions: &Regions, dets: &[Prepared<'_>]) -> Scores {
        let cands: Vec<Candidate<'_>> = dets
            .iter()
            .map(|d| Candidate {
                index: d.index,
                detection: d.det,
                features: Some(&d.features),
            })
            .collect();
        // Tracks of different known classes never match (MOTS: cars are not pedestrians).
        let same_class = |t: usize, d: usize| {
            let (tc, dc) = (self.tracks[t].last.class, dets[d].det.class);
            tc < 0 || dc < 0 || tc == dc
        };
        let fill = |model: &CostModel, regions: &Regions| -> Vec<Edge> {
            let costs = model.score(&self.tracks, &cands, regions);
            regions
                .pairs
                .iter()
                .zip(costs)
                .filter_map(|(&(t, d), c)| Some((t, d, c.filter(|_| same_class(t, d))?)))
                .collect()
        };
        let main = fill(&self.costs, regions);
        let reid = if self.reid_costs.terms().is_empty() {
            None
        } else {
            let lost = |t: usize| self.tracks[t].state == TrackState::Lost;
            let pairs: Vec<usize> = (0..regions.pairs.len())
                .filter(|&k| lost(regions.pairs[k].0))
                .collect();
            let sub = Regions {
                pairs: pairs.iter().map(|&k| regions.pairs[k]).collect(),
                pair_cluster: pairs.iter().map(|&k| regions.pair_cluster[k]).collect(),
                clusters: regions.clusters.clone(),
            };
            Some(fill(&self.reid_costs, &sub))
        };
        Scores { main, reid }
    }

    /// Phase 4: the assignment stages (module docs).
    fn assign(&self, scores: &Scores, dets: &[Prepared<'_>]) -> Result<Vec<Pair>, TrackError> {
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
        let main = &scores.main;
        if cfg.lost_second {
            self.stage(
                main,
                &recent,
                dets,
                &high,
                cfg.max_cost,
                &mut used,
                &mut out,
            )?;
            self.stage(main, &lost, dets, &high, cfg.max_cost, &mut used, &mut out)?;
        } else {
            self.stage(
                main,
                &active,
                dets,
                &high,
                cfg.max_cost,
                &mut used,
                &mut out,
            )?;
        }
        self.stage(
            main,
            &recent,
            dets,
            &low,
            cfg.max_cost_low,
            &mut used,
            &mut out,
        )?;
        let max_t = cfg.max_cost_tentative;
        self.stage(main, &tentative, dets, &high, max_t, &mut used, &mut out)?;
        if let Some(reid) = &scores.reid {
            let max_r = cfg.reid_max_cost;
            self.stage(reid, &lost, dets, &high, max_r, &mut used, &mut out)?;
        }
        Ok(out)
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
            .filter(|&(t, d, c)| {
                c <= max_cost
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
        for m in assign::solve_sparse(nt, nd, &edges, policy)?.matches {
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

    /// Phase 5: correct the matched tracks, confirm and re-identify. Returns which tracks were
    /// matched.
    fn update_matched(
        &mut self,
        matches: &[Pair],
        dets: &[Prepared<'_>],
        out: &mut Vec<TrackedShape>,
    ) -> Result<Vec<bool>, TrackError> {
        let mut matched = vec![false; self.tracks.len()];
        for m in matches {
            let (Some(t), Some(d)) = (self.tracks.get_mut(m.track), dets.get(m.det)) else {
                continue;
            };
            matched[m.track] = true;
            if self.config.reupdate_after_gap && t.misses > 0 {
                if let Some(snap) = &t.snapshot {
                    t.motion = reupdate(snap.as_ref(), &t.last.bbox, &d.det.bbox, t.misses)?;
                }
            }
            t.motion.update(&d.det.bbox)?;
            if self.config.reupdate_after_gap {
                t.snapshot = Some(t.motion.clone_box());
            }
            t.hits += 1;
            t.misses = 0;
            t.last_frame = self.frame;
            t.last = d.det.clone();
            t.features = Some(d.features.clone());
            let shape = |id: u64, state: TrackState| shape_of(self.frame, id, state, d, m.cost);
            match t.state {
                TrackState::Tentative => {
                    if t.hits >= self.config.min_hits {
                        let id = self.next_id;
                        self.next_id += 1;
                        t.id = Some(id);
                        t.state = TrackState::Confirmed;
                        if self.config.report_tentative {
                            for mut s in t.pending.drain(..) {
                                s.id = id;
                                s.state = TrackState::Confirmed;
                                out.push(s);
                            }
                        }
                        t.pending = Vec::new();
                        out.push(shape(id, TrackState::Confirmed));
                    } else if self.config.report_tentative {
                        t.pending.push(shape(0, TrackState::Tentative));
                    }
                }
                TrackState::Confirmed | TrackState::Lost | TrackState::Removed => {
                    t.state = TrackState::Confirmed;
                    if let Some(id) = t.id {
                        out.push(shape(id, TrackState::Confirmed));
                    }
                }
            }
        }
        Ok(matched)
    }

    /// Phase 6: unmatched tracks miss a frame; lost ones past `max_lost` are removed.
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

    /// Phase 7: confident unmatched detections start tentative tracks (confirmed at once when
    /// `min_hits` is 1).
    fn spawn(
        &mut self,
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
            let mut t = Track {
                id: None,
                state: TrackState::Tentative,
                predicted: d.det.bbox,
                snapshot: self.config.reupdate_after_gap.then(|| motion.clone_box()),
                motion,
                hits: 1,
                misses: 0,
                last_frame: self.frame,
                last: d.det.clone(),
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
