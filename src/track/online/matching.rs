//! Which detection goes to which track: appearance described only for the detections
//! geometry cannot decide, then the association stages in turn, the re-identification stage
//! scoring its own pairs (and describing its detections) when its turn comes.

use std::borrow::Cow;
use std::sync::Arc;

use super::Tracker;
use crate::assign::Unmatched;
use crate::frame::{Detection, Frame, TrackState};
use crate::track::associate::{score_edges, score_edges_reusing, Edge, Pair, StageCosts, Used};
use crate::track::cost::CheapTerms;
use crate::track::describe::{ambiguous_detections, Ambiguity};
use crate::track::features::Appearance;
use crate::track::prepare::Prepared;
use crate::track::regions::Regions;
use crate::track::search::{in_frame_regions, reid_regions};
use crate::track::timing::Phase;
use crate::track::TrackError;

impl Tracker {
    /// Appearance for the detections geometry cannot decide (see `describe`). With
    /// [`Config::lost_reid_only`], the lost tracks outside the main association do not count:
    /// they are not in the frame's regions (`search::in_frame_regions`, on a frame with its
    /// image, the only kind described here), and the reid stage describes the detections it
    /// needs once the others have taken theirs.
    pub(super) fn describe(
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
    pub(super) fn appearance_of(
        &self,
        frame: &Frame<'_>,
        det: &Detection,
    ) -> Option<Arc<Appearance>> {
        det.mask.as_ref()?;
        self.timer.time(Phase::Features, || {
            match self.extractor.describe(frame, det, self.frame) {
                Ok(a) => a.map(Arc::new),
                Err(_) => None,
            }
        })
    }

    /// Runs the association stages in turn (see [`super::super::associate`]); the matches,
    /// and how many of them (the first) the main stage made. With
    /// [`Config::adaptive_gate`] the main stage's gate is this sequence's (see
    /// [`crate::track::gate`]).
    pub(super) fn associate(
        &self,
        frame: Option<&Frame<'_>>,
        main: &[Edge],
        regions: &Regions,
        dets: &mut [Prepared<'_>],
    ) -> Result<(Vec<Pair>, usize), TrackError> {
        let mut used = Used::new(self.tracks.len(), dets.len());
        let mut out = Vec::new();
        let policy = match self.config.unmatched_cost {
            Some(l) => Unmatched::Cost(l),
            None => Unmatched::MaxMatches,
        };
        let mut from_main = 0;
        for (i, stage) in self.stages.for_frame(frame.is_some()).iter().enumerate() {
            let mut stage = *stage;
            if let (0, Some(k)) = (i, self.config.adaptive_gate) {
                stage.max_cost = self.gate.gate(stage.max_cost, k);
            }
            let edges = match stage.costs {
                StageCosts::Main => Cow::Borrowed(main),
                StageCosts::Reid if self.reid_costs.terms().is_empty() => continue,
                StageCosts::Reid => Cow::Owned(self.reid_edges(frame, regions, dets, &used)),
            };
            stage.run(&self.tracks, dets, &edges, policy, &mut used, &mut out)?;
            if i == 0 {
                from_main = out.len();
            }
        }
        Ok((out, from_main))
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
}
