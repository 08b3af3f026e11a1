//! What a frame's matches change: matched tracks updated (tentative ones confirmed, or taken
//! over by the lost track they re-identify), appearance refreshed, unmatched tracks aged or
//! coasted, and confident unmatched detections spawned as new tracks.

use super::Tracker;
use crate::frame::{Frame, TrackState, TrackedShape};
use crate::track::associate::{in_main, Pair};
use crate::track::config::ReportBox;
use crate::track::describe::crowded_next_frame;
use crate::track::fragments::merged_views;
use crate::track::lifecycle::{two_mut, HitView, Track};
use crate::track::prepare::{shape_of, Prepared};
use crate::track::TrackError;

impl Tracker {
    /// Every match updates its track (`Track::hit`); tentative tracks with enough hits are
    /// confirmed (or absorbed by the lost track they re-identify), confirmed and lost ones
    /// report their shape. Returns which tracks were matched.
    pub(super) fn update_matched(
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
        // The judgement changes only when the judge sees a frame of box detections.
        let boxes_cut = self.config.complete_cut_boxes && self.cut.cuts();
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
            let view = HitView { merged, boxes_cut };
            t.hit(&d.det, &d.features, frame, cfg, view, &mut self.noise)?;
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
                    let view = HitView {
                        merged: false,
                        boxes_cut,
                    };
                    l.hit(&d.det, &d.features, frame, cfg, view, &mut self.noise)?;
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
    pub(super) fn refresh_appearance(
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
    pub(super) fn age(&mut self, matched: &[bool], has_frame: bool) {
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
    pub(super) fn coast(&mut self, out: &mut Vec<TrackedShape>) {
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
    pub(super) fn spawn(
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
