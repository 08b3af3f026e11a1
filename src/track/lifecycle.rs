//! One track and its lifecycle: born tentative from an unmatched detection, confirmed after
//! enough matches, lost while unmatched, removed after too long; every transition is a method
//! here ([`Track::hit`], [`Track::confirm`], [`Track::miss`], [`Track::absorb`] …), so the
//! tracker's phases only decide *which* transition happens, never how.

use std::sync::Arc;

use super::amodal::{amodal_box, Cut, REAPPEAR_GAP};
use super::config::{Config, ReportBox};
use super::estimate::{BoxEstimate, NoiseFit};
use super::features::{Appearance, Features};
use crate::frame::{BBox, Detection, Point, TrackState, TrackedShape};
use crate::geometry::ConvexShell;
use crate::motion::{BoxMotionModel, MotionError, MotionModel};

/// The boxed motion filter a track owns (any [`MotionModel`] on boxes).
pub(crate) type BoxMotion = Box<dyn BoxMotionModel>;

/// A track moving more than this fraction of its size per frame is fast: its search shell is
/// swept along the predicted displacement, so a detection found part-way still meets it.
const FAST_MOTION: f64 = 0.5;

/// The areas and box sizes of a track's last [`Sizes::LEN`] matched detections, whose upper
/// quartiles are the reference size of the whole shape.
///
/// An upper quantile over a window rather than a running mean over "whole" views: partial views
/// (an occlusion starting or ending) are smaller and stay below it unless they fill three
/// quarters of the window, mask noise (erosion, dilation by a pixel or two) mostly cancels out,
/// and a transient
/// outlier (two touching shapes detected as one) leaves the window after a while. A running
/// mean fed only by views judged whole can lock up: one inflated value makes every later view
/// look partial, and the reference never updates again.
#[derive(Debug, Clone, Default)]
pub(crate) struct Sizes {
    ring: std::collections::VecDeque<[f64; 3]>,
}

impl Sizes {
    /// Views kept.
    pub(crate) const LEN: usize = 20;

    /// Adds a view's area and box size.
    pub(crate) fn push(&mut self, area: f64, w: f64, h: f64) {
        if self.ring.len() == Self::LEN {
            self.ring.pop_front();
        }
        self.ring.push_back([area, w, h]);
    }

    /// The upper quartile of each of area, width and height over the window.
    pub(crate) fn reference(&self) -> (f64, (f64, f64)) {
        // On the stack: this runs at every match of every track. The quartile is one order
        // statistic, so a selection finds it without sorting the window: the same value (the
        // order is total), and three insertion sorts of 20 values were a third of
        // `Track::hit` in the browser build's profile (issue 10).
        let q = |k: usize| -> f64 {
            let mut buf = [0.0; Self::LEN];
            let n = self.ring.len().min(Self::LEN);
            for (d, r) in buf.iter_mut().zip(&self.ring) {
                *d = r[k];
            }
            let v = &mut buf[..n];
            if v.is_empty() {
                return 0.0;
            }
            *v.select_nth_unstable_by((3 * (n - 1)) / 4, f64::total_cmp)
                .1
        };
        (q(0), (q(1), q(2)))
    }
}

/// One track. Its fields are private: pair-cost terms and the tracker's phases read it through
/// the accessors and change it only through the lifecycle methods.
pub struct Track {
    id: Option<u64>,
    state: TrackState,
    motion: BoxMotion,
    /// The filter right after the last match, kept for the re-update after a gap.
    snapshot: Option<BoxMotion>,
    /// Kalman prediction for the current frame (set by the predict phase).
    predicted: BBox,
    /// The filter's box right after the last match: where the predicted shift starts from.
    /// With amodal completion it is the whole shape's box even when only part was seen.
    anchor: BBox,
    /// Reference area of the whole shape (pixels; box area in box mode): see [`Sizes`].
    ref_area: f64,
    /// Reference box size `(w, h)` of the whole shape: see [`Sizes`].
    ref_size: (f64, f64),
    /// Areas and box sizes of the last matched detections.
    sizes: Sizes,
    /// The occluded side on each axis during the current partial view (amodal completion).
    cuts: [Option<Cut>; 2],
    /// Area of the last matched detection over `ref_area` (before updating it): below the
    /// whole ratio the last view was partial (occluded or leaving the frame).
    last_ratio: f64,
    /// Whether the last matched detection showed the whole shape: its area near the reference
    /// and no side needing amodal completion.
    last_whole: bool,
    /// The latest appearance computed for the track.
    appearance: Option<Arc<Appearance>>,
    /// The latest appearance computed while the shape was seen whole.
    reference: Option<Arc<Appearance>>,
    /// Frames matched, in total.
    hits: u32,
    /// Evidence for confirmation (see [`Config::birth_evidence`]): matches weighted by score.
    evidence: f64,
    /// Consecutive frames without a match (0 when matched this or the previous frame).
    misses: u32,
    /// Frame of the last match (tracker frame numbers, 1-based).
    last_frame: u32,
    /// The last matched detection.
    last: Detection,
    /// Its features (centroid, area, shell, appearance when described).
    features: Option<Features>,
    /// Last frame a shape was reported under the track's id (matched or coasted).
    reported_until: u32,
    /// Shapes matched while tentative, reported if the track is confirmed.
    pending: Vec<TrackedShape>,
    /// The reported box's filters (see [`super::estimate`]): only under
    /// [`ReportBox::Adaptive`], the one setting that reads them (they would run every frame
    /// for nothing otherwise).
    estimate: Option<BoxEstimate>,
}

impl std::fmt::Debug for Track {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Track")
            .field("id", &self.id)
            .field("state", &self.state)
            .field("predicted", &self.predicted)
            .field("hits", &self.hits)
            .field("misses", &self.misses)
            .field("last_frame", &self.last_frame)
            .finish_non_exhaustive()
    }
}

/// What the tracker knows of a matched view beyond the detection itself (see [`Track::hit`]).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct HitView {
    /// The detector merged the view with a neighbour's.
    pub(crate) merged: bool,
    /// This sequence's detector boxes visible parts, so a box detection is completed like a
    /// mask ([`super::Config::complete_cut_boxes`]).
    pub(crate) boxes_cut: bool,
}

impl Track {
    /// The track's id; `None` while tentative (ids are given at confirmation).
    pub fn id(&self) -> Option<u64> {
        self.id
    }

    /// Lifecycle state.
    pub fn state(&self) -> TrackState {
        self.state
    }

    /// Where the motion filter expects the track in the current frame.
    pub fn predicted_box(&self) -> BBox {
        self.predicted
    }

    /// The track's motion filter.
    pub fn motion(&self) -> &dyn MotionModel<Measurement = BBox> {
        self.motion.as_ref()
    }

    /// The detection last matched to the track (its last appearance).
    pub fn last_detection(&self) -> &Detection {
        &self.last
    }

    /// The features of the last matched detection, when an extractor computed them.
    pub fn features(&self) -> Option<&Features> {
        self.features.as_ref()
    }

    /// Number of frames the track was matched in.
    pub fn hits(&self) -> u32 {
        self.hits
    }

    /// Consecutive frames without a match, up to the previous frame.
    pub fn misses(&self) -> u32 {
        self.misses
    }

    /// Frame number (1-based, the tracker's count) of the last match.
    pub fn last_frame(&self) -> u32 {
        self.last_frame
    }

    /// The displacement from the filter's box at the last match to the predicted box: how far
    /// the last appearance (mask, shell) is expected to have moved by the current frame.
    pub fn predicted_shift(&self) -> Point {
        self.predicted.center() - self.anchor.center()
    }

    /// `shape` (of a detection matched to this track) with the box the track reports (see
    /// [`Config::report_box`] and [`super::estimate`]); a mask keeps its mask and centroid,
    /// and reports its mask's box unless the box is adaptive.
    pub(crate) fn reported_shape(
        &self,
        config: &Config,
        fit: &NoiseFit,
        mut shape: TrackedShape,
    ) -> TrackedShape {
        let b = match (config.report_box, shape.mask.is_some()) {
            (ReportBox::Detection, _) | (ReportBox::Filter, true) => return shape,
            (ReportBox::Filter, false) => self.anchor,
            (ReportBox::Adaptive, _) => match &self.estimate {
                Some(e) => e.current(fit, &self.last.bbox, self.smoother_box(&self.last).as_ref()),
                None => return shape,
            },
        };
        if b.is_valid() {
            if shape.mask.is_none() {
                shape.centroid = b.center();
            }
            shape.bbox = b;
        }
        shape
    }

    /// The association filter's box as a candidate of the reported box's bank (see
    /// [`super::estimate`]), for box detections only: a mask track's filter follows the whole
    /// shape's (amodal) box, not the detection's, and on crowds of ragged masks reporting it
    /// cost 8 HOTA (robustness grid). `det` is the detection the track is matched to.
    fn smoother_box(&self, det: &Detection) -> Option<BBox> {
        det.mask.is_none().then_some(self.anchor)
    }

    /// The filter's box right after the last match.
    pub fn anchor_box(&self) -> BBox {
        self.anchor
    }

    /// Reference area of the whole shape (running mean over detections seen whole).
    pub fn reference_area(&self) -> f64 {
        self.ref_area
    }

    /// Area of the last matched detection over the reference area at that time (1 = seen
    /// whole; small = partly hidden).
    pub fn last_visible_ratio(&self) -> f64 {
        self.last_ratio
    }

    /// Whether the last matched detection showed the whole shape (see
    /// [`Config::amodal`](super::Config::amodal)).
    pub fn last_seen_whole(&self) -> bool {
        self.last_whole
    }

    /// The latest appearance computed for the track (`None` until one was needed).
    pub fn appearance(&self) -> Option<&Appearance> {
        self.appearance.as_deref()
    }

    /// The latest appearance computed while the shape was seen whole: what a lost track is
    /// re-identified by.
    pub fn reference_appearance(&self) -> Option<&Appearance> {
        self.reference.as_deref()
    }
}

/// The lifecycle: every change of a track's state or counters.
impl Track {
    /// A tentative track born from detection `det` (with its `features`) in tracker frame
    /// `frame`. `appearance` is its first appearance, if described; `snapshot` keeps a copy of
    /// the filter for [`Config::reupdate_after_gap`]; `smooth` runs the reported box's filters
    /// (under [`ReportBox::Adaptive`], for box and mask detections alike).
    pub(crate) fn born(
        det: &Detection,
        features: &Features,
        motion: BoxMotion,
        appearance: Option<Arc<Appearance>>,
        frame: u32,
        snapshot: bool,
        smooth: bool,
    ) -> Track {
        let b = det.bbox;
        let mut sizes = Sizes::default();
        sizes.push(features.area, b.w, b.h);
        Track {
            id: None,
            state: TrackState::Tentative,
            predicted: b,
            anchor: b,
            ref_area: features.area,
            ref_size: (b.w, b.h),
            sizes,
            cuts: [None; 2],
            last_ratio: 1.0,
            last_whole: true,
            reported_until: 0,
            reference: appearance.clone(),
            appearance,
            snapshot: snapshot.then(|| motion.clone_box()),
            motion,
            hits: 1,
            evidence: 0.0,
            misses: 0,
            last_frame: frame,
            last: det.clone(),
            features: Some(features.clone()),
            pending: Vec::new(),
            estimate: smooth.then(|| BoxEstimate::new(&b)),
        }
    }

    /// Steps the motion filter one frame; a lost track's velocity is first multiplied by
    /// `lost_velocity_decay` (see [`Config::lost_velocity_decay`]).
    pub(crate) fn predict(&mut self, lost_velocity_decay: f64) {
        if self.state == TrackState::Lost && lost_velocity_decay < 1.0 {
            self.motion.damp_velocity(lost_velocity_decay);
        }
        self.motion.predict();
        self.predicted = self.motion.project();
        if let Some(e) = &mut self.estimate {
            e.predict();
        }
    }

    /// The whole image moved by `(dx, dy)` since the last frame (camera motion, see
    /// [`super::camera`]): the filter, the prediction, the last box and the reported-box
    /// filters move with it, so the track is looked for where the camera took it.
    pub(crate) fn translate(&mut self, dx: f64, dy: f64) {
        self.motion.translate(dx, dy);
        if let Some(snap) = &mut self.snapshot {
            snap.translate(dx, dy);
        }
        self.predicted = self.motion.project();
        let mv = |b: &BBox| BBox::new(b.x + dx, b.y + dy, b.w, b.h);
        self.anchor = mv(&self.anchor);
        if self.last.mask.is_none() {
            self.last.bbox = mv(&self.last.bbox);
        }
        if let Some(e) = &mut self.estimate {
            e.translate(dx, dy);
        }
    }

    /// A match in tracker frame `frame` with detection `det` (and its `features`): the motion
    /// filter is corrected (with the amodal box of a partial mask view, not at all with a
    /// sliver, see [`Config::amodal`]), the reference size and appearance follow the view, and
    /// the counters restart; a view `merged` with a neighbour's (see
    /// [`AppearanceConfig::merged_ratio`](super::AppearanceConfig::merged_ratio)) corrects
    /// neither the filter nor the reference appearance. The state is left to
    /// [`Track::confirm`] / [`Track::found`].
    pub(crate) fn hit(
        &mut self,
        det: &Detection,
        features: &Features,
        frame: u32,
        cfg: &Config,
        view: HitView,
        fit: &mut NoiseFit,
    ) -> Result<(), MotionError> {
        let HitView { merged, boxes_cut } = view;
        let area = features.area;
        let ratio = if self.ref_area > 0.0 && area > 0.0 {
            area / self.ref_area
        } else {
            1.0
        };
        let whole = ratio >= cfg.appearance.whole_ratio;
        let amodal = cfg.amodal && (det.mask.is_some() || boxes_cut);
        let z = if amodal {
            // The last detection tells which side stands still if it is recent; after a longer
            // gap the shape is reappearing and the occlusion that cut the last views is over.
            let last = (self.misses < REAPPEAR_GAP).then_some((&self.last.bbox, self.misses + 1));
            if last.is_none() {
                self.cuts = [None; 2];
            }
            let v = self.motion.velocity();
            let (p, r) = (self.predicted, self.ref_size);
            amodal_box(&p, &det.bbox, last, v, r, whole, &mut self.cuts)
        } else {
            det.bbox
        };
        if cfg.reupdate_after_gap && self.misses > 0 {
            if let Some(snap) = &self.snapshot {
                // With amodal completion the whole shape's boxes, else the boxes as seen.
                let (from, to) = if amodal {
                    (&self.anchor, &z)
                } else {
                    (&self.last.bbox, &det.bbox)
                };
                self.motion = reupdate(snap.as_ref(), from, to, self.misses)?;
            }
        }
        // A sliver (a shape mostly hidden) says little about where the whole shape is:
        // matching it keeps the track alive, but the filter coasts on its prediction rather
        // than having its velocity dragged by the occluder's edge. Not after a gap, when the
        // prediction has drifted and the sliver is the only news.
        let sliver = amodal
            && ratio < cfg.sliver_ratio
            && self.misses == 0
            && self.hits >= cfg.confirm_hits();
        // A view the detector merged with a neighbour is as little news of where the shape is
        // (or of its look): following it drags the track towards the neighbour, and when the
        // two part, the tracks swap. The sizes still take it (a median, robust to a few).
        if !sliver && !merged {
            self.motion.update(&z)?;
        }
        self.anchor = self.motion.project();
        if cfg.reupdate_after_gap {
            self.snapshot = Some(self.motion.clone_box());
        }
        self.last_ratio = ratio;
        self.last_whole = whole;
        if area > 0.0 {
            let b = det.bbox;
            self.sizes.push(area, b.w, b.h);
            (self.ref_area, self.ref_size) = self.sizes.reference();
        }
        if let Some(a) = &features.appearance {
            self.set_appearance(a.clone(), whole && !merged);
        }
        let filter = self.smoother_box(det);
        if let Some(e) = &mut self.estimate {
            e.update(&det.bbox, filter.as_ref(), fit);
        }
        self.hits += 1;
        self.misses = 0;
        self.last_frame = frame;
        self.last = det.clone();
        self.features = Some(features.clone());
        Ok(())
    }

    /// The track's latest appearance is `a`, and its reference appearance too when the shape
    /// was seen `whole`.
    pub(crate) fn set_appearance(&mut self, a: Arc<Appearance>, whole: bool) {
        if whole {
            self.reference = Some(a.clone());
        }
        self.appearance = Some(a);
    }

    /// Adds `w` to the track's evidence for confirmation; returns the total.
    pub(crate) fn add_evidence(&mut self, w: f64) -> f64 {
        self.evidence += w;
        self.evidence
    }

    /// A tentative track gets its id and is confirmed.
    pub(crate) fn confirm(&mut self, id: u64) {
        self.id = Some(id);
        self.state = TrackState::Confirmed;
    }

    /// A confirmed or lost track matched again: confirmed (a lost track is re-identified under
    /// its old id).
    pub(crate) fn found(&mut self) {
        self.state = TrackState::Confirmed;
    }

    /// Records that a shape was reported under the track's id in tracker frame `frame`.
    pub(crate) fn reported(&mut self, frame: u32) {
        self.reported_until = frame;
    }

    /// Keeps `shape` (a tentative frame) to report if the track is confirmed.
    pub(crate) fn hold(&mut self, shape: TrackedShape) {
        self.pending.push(shape);
    }

    /// The held tentative shapes, under the track's id and confirmed (none without an id).
    pub(crate) fn release(&mut self) -> Vec<TrackedShape> {
        let Some(id) = self.id else {
            return Vec::new();
        };
        let mut out = std::mem::take(&mut self.pending);
        for s in &mut out {
            s.id = id;
            s.state = TrackState::Confirmed;
        }
        out
    }

    /// The held tentative shapes, in frame order.
    pub(crate) fn held(&self) -> &[TrackedShape] {
        &self.pending
    }

    /// Takes the held tentative shapes away (a removed track's, for hindsight).
    pub(crate) fn take_held(&mut self) -> Vec<TrackedShape> {
        std::mem::take(&mut self.pending)
    }

    /// Puts `earlier` (shapes of frames before the held ones) in front of the held shapes.
    pub(crate) fn prepend_held(&mut self, mut earlier: Vec<TrackedShape>) {
        earlier.append(&mut self.pending);
        self.pending = earlier;
    }

    /// Forgets the held tentative shapes (when they are not reported).
    pub(crate) fn drop_held(&mut self) {
        self.pending = Vec::new();
    }

    /// A frame without a match: a tentative track is removed after `max_tentative_misses`
    /// misses; a confirmed one is lost, and removed after `max_lost`.
    pub(crate) fn miss(&mut self, max_tentative_misses: u32, max_lost: u32) {
        self.misses += 1;
        if let Some(e) = &mut self.estimate {
            e.missed();
        }
        match self.state {
            TrackState::Tentative if self.misses > max_tentative_misses => {
                self.state = TrackState::Removed;
            }
            TrackState::Confirmed | TrackState::Lost => {
                self.state = if self.misses > max_lost {
                    TrackState::Removed
                } else {
                    TrackState::Lost
                };
            }
            _ => {}
        }
    }

    /// This lost track takes over `newer`, a tentative track found to be its reappearance (see
    /// [`Config::reid_at_confirmation`]): its hits (the confirming one is counted by this
    /// track's own [`Track::hit`]) and its held shapes, except those of frames this track was
    /// already reported in (coasting). `newer` is removed.
    pub(crate) fn absorb(&mut self, newer: &mut Track) {
        self.hits += newer.hits.saturating_sub(1);
        let until = self.reported_until;
        let pending = std::mem::take(&mut newer.pending);
        self.pending = pending.into_iter().filter(|s| s.frame > until).collect();
        newer.state = TrackState::Removed;
    }

    /// The shape to report for a confirmed track missed for at most `max_frames` frames right
    /// after a whole view (see [`Config::coast_frames`]): its last mask (or box) moved by the
    /// predicted motion and clipped to the frame `size`, marked interpolated. `None` when the
    /// track does not coast in tracker frame `frame`, or when the track is predicted mostly out
    /// of the frame (it has left).
    pub(crate) fn coast(
        &mut self,
        frame: u32,
        size: Option<(u32, u32)>,
        max_frames: u32,
    ) -> Option<TrackedShape> {
        let id = self.id?;
        if self.state != TrackState::Lost || self.misses > max_frames || !self.last_whole {
            return None;
        }
        let s = self.predicted_shift();
        if !(s.x.is_finite() && s.y.is_finite()) {
            return None;
        }
        if let (None, Some((w, h))) = (&self.last.mask, size) {
            // A box predicted mostly out of view has left: reporting it would be a false box.
            let view = BBox::new(0.0, 0.0, w as f64, h as f64);
            if self.predicted.ioa(&view) < 0.5 {
                return None;
            }
        }
        let (mask, bbox) = match &self.last.mask {
            Some(m) => {
                let (dx, dy) = (
                    s.x.round().clamp(-1e6, 1e6) as i32,
                    s.y.round().clamp(-1e6, 1e6) as i32,
                );
                let mut moved = m.translated(dx, dy);
                if let Some((w, h)) = size {
                    let whole = moved.area();
                    moved = moved.clipped(w, h);
                    // As for boxes: a mask predicted mostly out of view has left, and the
                    // sliver left at the border would be a false shape.
                    if (moved.area() as f64) < 0.5 * whole as f64 {
                        return None;
                    }
                }
                if moved.is_empty() {
                    return None;
                }
                let b = moved.bbox();
                (Some(moved), b)
            }
            None => (None, self.predicted),
        };
        let centroid = self
            .features
            .as_ref()
            .map_or(self.predicted.center(), |f| f.centroid);
        self.reported_until = frame;
        Some(TrackedShape {
            id,
            frame,
            bbox,
            mask,
            centroid: centroid + s,
            state: TrackState::Lost,
            score: self.last.score,
            class: self.last.class,
            cost: 0.0,
            det_index: None,
            interpolated: true,
        })
    }

    /// The track's search shell in mask mode: its last shell moved by the predicted
    /// displacement (swept along it when the track is lost or fast, so a detection found
    /// part-way still meets it), merged with the predicted box (which, with amodal completion,
    /// covers the whole shape even when the last view was partial), grown by `factor` times the
    /// predicted box's geometric mean size.
    pub(crate) fn search_shell(&self, factor: f64) -> ConvexShell {
        let p = self.predicted;
        let shift = self.predicted_shift();
        let anchor;
        let base = match self.features.as_ref().and_then(|f| f.shell.as_deref()) {
            Some(s) => s,
            None => {
                anchor = ConvexShell::from_bbox(&self.anchor).unwrap_or_default();
                &anchor
            }
        };
        let size = (p.w.max(1.0) * p.h.max(1.0)).sqrt();
        let fast = shift.x.hypot(shift.y) > FAST_MOTION * size;
        let corners = p.corners();
        let extra: &[Point] = if p.is_valid() { &corners } else { &[] };
        // Moved (or swept) and merged with the predicted box in one buffer: the same hull as
        // `translated`/`swept` then `from_points`, with two allocations per track and frame
        // instead of about nine (issue 10).
        let merged = base.moved_with(shift.x, shift.y, fast || self.misses > 0, extra);
        merged.grown(factor * size)
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

/// Mutable references to two different tracks.
pub(super) fn two_mut(tracks: &mut [Track], a: usize, b: usize) -> (&mut Track, &mut Track) {
    debug_assert_ne!(a, b);
    if a < b {
        let (lo, hi) = tracks.split_at_mut(b);
        (&mut lo[a], &mut hi[0])
    } else {
        let (lo, hi) = tracks.split_at_mut(a);
        (&mut hi[0], &mut lo[b])
    }
}

#[cfg(test)]
mod tests {
    use super::Sizes;

    /// The upper quartile the window's sorted values give (what `Sizes::reference` picks).
    fn sorted_quartile(mut v: Vec<f64>) -> f64 {
        if v.is_empty() {
            return 0.0;
        }
        v.sort_by(f64::total_cmp);
        v[(3 * (v.len() - 1)) / 4]
    }

    #[test]
    fn the_reference_size_is_the_upper_quartile_of_the_window() {
        // Windows of every length up to past the cap, with repeats and a wide spread.
        let mut sizes = Sizes::default();
        let mut pushed: Vec<[f64; 3]> = Vec::new();
        let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
        for i in 0..3 * Sizes::LEN {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let v = (x % 97) as f64 * if i % 5 == 0 { 10.0 } else { 1.0 };
            let view = [v, (x % 13) as f64, ((x >> 8) % 7) as f64];
            sizes.push(view[0], view[1], view[2]);
            pushed.push(view);
            let window = &pushed[pushed.len().saturating_sub(Sizes::LEN)..];
            let col = |k: usize| sorted_quartile(window.iter().map(|r| r[k]).collect());
            assert_eq!(
                sizes.reference(),
                (col(0), (col(1), col(2))),
                "after {}",
                i + 1
            );
        }
        assert_eq!(Sizes::default().reference(), (0.0, (0.0, 0.0)));
    }
}
