//! Pair costs: how unlike a track and a detection are, as a weighted sum of terms.
//!
//! Every term implements [`PairCost`] and returns a cost in `[0, 1]` for a (track, detection)
//! pair, or `None` when it has no data for that pair (no mask, no image, no features). The
//! [`CostModel`] combines the terms that have data as `Σ wᵢ·cᵢ / Σ wᵢ`, so a missing term drops
//! out and the remaining weights renormalise: with shape context and colour only (w_a = w_b =
//! 0.5) this is the thesis' eq. 39, and in box mode, where neither has data, geometry and motion
//! carry the decision alone. A term may also gate: a pair whose cost for it exceeds its gate is
//! never matched.
//!
//! Terms that are only meaningful relative to their neighbours (the thesis normalises C1 and C2
//! "within the cluster") say so with [`PairCost::normalise_in_cluster`]; their costs are then
//! divided by the largest cost in the pair's region cluster before combining.

use super::config::Terms;
use super::features::Features;
use super::lifecycle::Track;
use super::regions::Regions;
use crate::frame::{BBox, Detection};

/// A detection as the pair-cost terms see it.
#[derive(Debug, Clone, Copy)]
pub struct Candidate<'a> {
    /// Index of the detection in the frame's input slice.
    pub index: usize,
    /// The detection.
    pub detection: &'a Detection,
    /// Its features, computed once this frame (reused as the track's last appearance).
    pub features: Option<&'a Features>,
}

/// One term of the pair cost.
pub trait PairCost: Send {
    /// Short name, for diagnostics.
    fn name(&self) -> &str;

    /// The cost in `[0, 1]` of matching `det` to `track`, `None` when the term has no data.
    fn cost(&self, track: &Track, det: &Candidate<'_>) -> Option<f64>;

    /// Whether the costs should be divided by the largest one in the region cluster before
    /// combining (thesis' "normalised" C1 and C2). Default: no.
    fn normalise_in_cluster(&self) -> bool {
        false
    }

    /// Whether the term is expensive (appearance: k-means, descriptor matching): with a
    /// [`CostModel::with_prefilter`] threshold it is computed only for pairs the cheap terms
    /// leave acceptable. Default: no.
    fn expensive(&self) -> bool {
        false
    }
}

/// `1 − IoU` between the track's predicted box and the detection, both optionally grown by a
/// buffer (C-BIoU: Yang et al., "Hard to track objects with irregular motions and similar
/// appearances? Make it easier by buffering the matching space", WACV 2023).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IouCost {
    /// Box scale factor before the IoU: 1 = plain IoU, 1.3 grows each box by 15 % of its size
    /// on every side.
    pub buffer: f64,
}

fn buffered(b: &BBox, scale: f64) -> BBox {
    if scale == 1.0 {
        return *b;
    }
    BBox::from_center(b.center(), b.w * scale, b.h * scale)
}

impl PairCost for IouCost {
    fn name(&self) -> &str {
        "iou"
    }
    fn cost(&self, track: &Track, det: &Candidate<'_>) -> Option<f64> {
        let a = buffered(&track.predicted_box(), self.buffer);
        let b = buffered(&det.detection.bbox, self.buffer);
        Some(1.0 - a.iou(&b))
    }
}

/// `1 − IoU` between the track's last *observed* box (not its prediction) and the detection:
/// OC-SORT's observation-centric recovery. A track lost while its prediction drifted away can
/// still be found where it was last seen.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LastIouCost;

impl PairCost for LastIouCost {
    fn name(&self) -> &str {
        "last_iou"
    }
    fn cost(&self, track: &Track, det: &Candidate<'_>) -> Option<f64> {
        Some(1.0 - track.last_detection().bbox.iou(&det.detection.bbox))
    }
}

/// Generalised IoU (Rezatofighi et al. 2019): IoU minus the share of the enclosing box that
/// neither box covers, in `[-1, 1]`.
pub fn giou(a: &BBox, b: &BBox) -> f64 {
    let c = a.union(b).area();
    if c <= f64::EPSILON {
        return 0.0;
    }
    let inter = a.intersection_area(b);
    let u = a.area() + b.area() - inter;
    let iou = if u > f64::EPSILON { inter / u } else { 0.0 };
    iou - (c - u) / c
}

/// `(1 − GIoU)/2` between the predicted box and the detection.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GiouCost;

impl PairCost for GiouCost {
    fn name(&self) -> &str {
        "giou"
    }
    fn cost(&self, track: &Track, det: &Candidate<'_>) -> Option<f64> {
        Some((1.0 - giou(&track.predicted_box(), &det.detection.bbox)) / 2.0)
    }
}

/// `1 − |D ∩ P| / |D|` between the detection's box `D` and the predicted box `P` grown by a
/// buffer: 0 when the detection lies inside where the track is expected (whole or partly
/// hidden), 1 when it lies outside. The buffer widens by `per_miss` for every frame the track
/// went unmatched, as the prediction's uncertainty does (a velocity off by 10% puts a shape
/// hidden for 20 frames two frames' motion away from where it is predicted).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IoaCost {
    /// Scale factor of the predicted box: 1 = as predicted.
    pub buffer: f64,
    /// Growth of the scale factor per missed frame.
    pub per_miss: f64,
}

impl PairCost for IoaCost {
    fn name(&self) -> &str {
        "ioa"
    }
    fn cost(&self, track: &Track, det: &Candidate<'_>) -> Option<f64> {
        let scale = self.buffer + self.per_miss * track.misses() as f64;
        let p = buffered(&track.predicted_box(), scale);
        Some(1.0 - det.detection.bbox.ioa(&p))
    }
}

/// Distance between the predicted and detected centres, over `scale` times the predicted
/// box's diagonal, clipped to 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CentreDistanceCost {
    /// Distance, in predicted-box diagonals, that costs 1.
    pub scale: f64,
}

impl PairCost for CentreDistanceCost {
    fn name(&self) -> &str {
        "centre"
    }
    fn cost(&self, track: &Track, det: &Candidate<'_>) -> Option<f64> {
        let p = track.predicted_box();
        let diag = p.w.hypot(p.h).max(1.0);
        let d = p.center().dist(det.detection.bbox.center());
        Some((d / (self.scale * diag)).min(1.0))
    }
}

/// Size change `|ln(w'/w)| + |ln(h'/h)|` between the predicted box and the detection, over
/// `scale`, clipped to 1. Degenerate boxes give no data.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SizeCost {
    /// Log-size change that costs 1.
    pub scale: f64,
}

impl PairCost for SizeCost {
    fn name(&self) -> &str {
        "size"
    }
    fn cost(&self, track: &Track, det: &Candidate<'_>) -> Option<f64> {
        let (p, d) = (track.predicted_box(), det.detection.bbox);
        if p.w <= 1e-9 || p.h <= 1e-9 || d.w <= 1e-9 || d.h <= 1e-9 {
            return None;
        }
        let c = (d.w / p.w).ln().abs() + (d.h / p.h).ln().abs();
        Some((c / self.scale).min(1.0))
    }
}

/// Squared Mahalanobis distance from the track's motion filter, over `scale`, clipped to 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MahalanobisCost {
    /// Squared distance (χ² units) that costs 1.
    pub scale: f64,
}

impl PairCost for MahalanobisCost {
    fn name(&self) -> &str {
        "mahalanobis"
    }
    fn cost(&self, track: &Track, det: &Candidate<'_>) -> Option<f64> {
        let d2 = track.motion().mahalanobis2(&det.detection.bbox)?;
        Some((d2 / self.scale).min(1.0))
    }
}

/// `1 − mask IoU` between the track's last mask, moved by the predicted displacement, and the
/// detection's mask. No data unless both have masks.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MaskIouCost;

impl PairCost for MaskIouCost {
    fn name(&self) -> &str {
        "mask_iou"
    }
    fn cost(&self, track: &Track, det: &Candidate<'_>) -> Option<f64> {
        let (a, b) = (
            track.last_detection().mask.as_ref()?,
            det.detection.mask.as_ref()?,
        );
        let s = track.predicted_shift();
        if !(s.x.is_finite() && s.y.is_finite()) {
            return None;
        }
        // Whole-pixel shift: clamp first so a wild prediction cannot overflow the cast.
        let (dx, dy) = (
            s.x.round().clamp(-1e6, 1e6) as i32,
            s.y.round().clamp(-1e6, 1e6) as i32,
        );
        Some(1.0 - a.iou_shifted(dx, dy, b))
    }
}

/// A term with its weight and optional gate.
pub struct WeightedTerm {
    /// The term.
    pub term: Box<dyn PairCost>,
    /// Its weight (> 0).
    pub weight: f64,
    /// Pairs whose cost for this term exceeds the gate are never matched.
    pub gate: Option<f64>,
}

impl std::fmt::Debug for WeightedTerm {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WeightedTerm")
            .field("term", &self.term.name())
            .field("weight", &self.weight)
            .field("gate", &self.gate)
            .finish()
    }
}

/// The weighted, renormalised combination of pair-cost terms (module docs).
#[derive(Debug, Default)]
pub struct CostModel {
    terms: Vec<WeightedTerm>,
    /// The highest cost any user of these scores accepts (see [`CostModel::with_prefilter`]).
    prefilter: Option<f64>,
}

impl CostModel {
    /// The built-in geometric and motion terms of `terms` that have a positive weight. The
    /// appearance terms are not built in: their modules register them with [`CostModel::push`].
    pub fn from_terms(terms: &Terms) -> Self {
        Self::from_terms_with(terms, 0.0)
    }

    /// Skips the expensive terms ([`PairCost::expensive`]) of a pair that no value of theirs
    /// could bring within `max_cost` (its cost compared with thresholds, even with every
    /// expensive term at 0, is above it) or that a cheap term gates: such a pair is never
    /// matched, so its appearance need not be compared. In a crowded cluster this skips most
    /// pairs. The cluster normalisation of an expensive term then runs over the pairs that
    /// could match (issue 10: bounded work per cluster).
    pub fn with_prefilter(mut self, max_cost: f64) -> Self {
        self.prefilter = Some(max_cost);
        self
    }

    /// [`CostModel::from_terms`], with the IoA term's buffer widening by `ioa_per_miss` per
    /// missed frame.
    pub fn from_terms_with(terms: &Terms, ioa_per_miss: f64) -> Self {
        let mut m = Self::default();
        let t = terms;
        m.push(
            Box::new(IouCost {
                buffer: t.iou.scale,
            }),
            t.iou.weight,
            t.iou.gate,
        );
        m.push(Box::new(LastIouCost), t.last_iou.weight, t.last_iou.gate);
        m.push(Box::new(GiouCost), t.giou.weight, t.giou.gate);
        m.push(
            Box::new(IoaCost {
                buffer: t.ioa.scale,
                per_miss: ioa_per_miss,
            }),
            t.ioa.weight,
            t.ioa.gate,
        );
        m.push(
            Box::new(CentreDistanceCost {
                scale: t.centre.scale,
            }),
            t.centre.weight,
            t.centre.gate,
        );
        m.push(
            Box::new(SizeCost {
                scale: t.size.scale,
            }),
            t.size.weight,
            t.size.gate,
        );
        m.push(
            Box::new(MahalanobisCost {
                scale: t.mahalanobis.scale,
            }),
            t.mahalanobis.weight,
            t.mahalanobis.gate,
        );
        m.push(Box::new(MaskIouCost), t.mask_iou.weight, t.mask_iou.gate);
        m
    }

    /// Adds a term. Terms with a weight that is not finite and positive are ignored (disabled).
    pub fn push(&mut self, term: Box<dyn PairCost>, weight: f64, gate: Option<f64>) {
        if weight.is_finite() && weight > 0.0 {
            self.terms.push(WeightedTerm { term, weight, gate });
        }
    }

    /// The active terms.
    pub fn terms(&self) -> &[WeightedTerm] {
        &self.terms
    }

    /// Combines one pair's term costs (in [`CostModel::terms`] order): `None` when a gate
    /// rejects the pair or no term has data, else the renormalised weighted mean.
    /// Non-finite term costs count as "no data".
    pub fn combine(&self, costs: &[Option<f64>]) -> Option<f64> {
        let (mut num, mut den) = (0.0, 0.0);
        for (t, c) in self.terms.iter().zip(costs) {
            let Some(c) = c.filter(|c| c.is_finite()) else {
                continue;
            };
            if t.gate.is_some_and(|g| c > g) {
                return None;
            }
            num += t.weight * c;
            den += t.weight;
        }
        (den > 0.0).then(|| num / den)
    }

    /// One pair's combined cost ([`CostModel::combine`] of every term's cost) when it is at
    /// most `max_cost` and, given `beat`, below it; `None` otherwise (gated, no data, or not
    /// good enough). The cheap terms are computed first and each expensive one only while
    /// the pair can still qualify: with the remaining terms at their best (0, or no data),
    /// the cost could not fall below what is known. A search for the best of many pairs
    /// (re-identification at confirmation compares a new track with every lost one) then
    /// compares appearance only for the few that are near and plausible (issue 10).
    pub fn cost_within(
        &self,
        track: &Track,
        det: &Candidate<'_>,
        max_cost: f64,
        beat: Option<f64>,
    ) -> Option<f64> {
        // Far above rounding: the bound is summed in another order than `combine`.
        const MARGIN: f64 = 1e-9;
        let mut costs: Vec<Option<f64>> = vec![None; self.terms.len()];
        let (mut num, mut den) = (0.0, 0.0);
        let mut remaining: f64 = self.terms.iter().map(|w| w.weight).sum();
        let order = (self.terms.iter().enumerate())
            .filter(|(_, w)| !w.term.expensive())
            .chain(
                self.terms
                    .iter()
                    .enumerate()
                    .filter(|(_, w)| w.term.expensive()),
            );
        for (k, w) in order {
            let c = w.term.cost(track, det).filter(|c| c.is_finite());
            remaining -= w.weight;
            if let Some(c) = c {
                if w.gate.is_some_and(|g| c > g) {
                    return None;
                }
                num += w.weight * c;
                den += w.weight;
            }
            costs[k] = c;
            let total = den + remaining.max(0.0);
            if total > 0.0 {
                let bound = num / total;
                if bound > max_cost + MARGIN || beat.is_some_and(|b| bound >= b + MARGIN) {
                    return None;
                }
            }
        }
        self.combine(&costs)
            .filter(|&c| c <= max_cost && beat.is_none_or(|b| c < b))
    }

    /// The combined cost of every candidate pair of `regions` (`None` = not allowed), in the
    /// order of `regions.pairs` ([`CostModel::score_pairs`]'s `cost`).
    pub fn score(
        &self,
        tracks: &[Track],
        dets: &[Candidate<'_>],
        regions: &Regions,
    ) -> Vec<Option<f64>> {
        self.score_pairs(tracks, dets, regions)
            .into_iter()
            .map(|s| s.map(|s| s.cost))
            .collect()
    }

    /// Scores every candidate pair of `regions`, in the order of `regions.pairs`: `None` when
    /// a term's gate rejects the pair (gates compare the *raw* term costs) or no term has data.
    ///
    /// Terms that [`PairCost::normalise_in_cluster`] are divided by their largest value in the
    /// pair's cluster before combining into [`PairScore::cost`], which ranks the pairs of a
    /// cluster (the assignment minimises it). Such values mean nothing across clusters (a
    /// cluster where every candidate looks alike pins them all near 1), so
    /// [`PairScore::absolute`], which the tracker's thresholds compare, combines only the
    /// other terms.
    pub fn score_pairs(
        &self,
        tracks: &[Track],
        dets: &[Candidate<'_>],
        regions: &Regions,
    ) -> Vec<Option<PairScore>> {
        self.score_pairs_reusing(tracks, dets, regions, &mut CheapTerms::default())
    }

    /// [`CostModel::score_pairs`], reading the cheap terms from `cheap` when it holds them
    /// for these pairs, and leaving them there otherwise: the tracker scores a frame's pairs
    /// twice with the same model, geometry alone first (to see which detections need
    /// appearance) and then with appearance, and the cheap terms (mask IoU above all) do not
    /// change in between (issue 10: each was computed twice per pair and frame). The result
    /// is the same as without the cache.
    pub fn score_pairs_reusing(
        &self,
        tracks: &[Track],
        dets: &[Candidate<'_>],
        regions: &Regions,
        cheap: &mut CheapTerms,
    ) -> Vec<Option<PairScore>> {
        let nt = self.terms.len();
        let np = regions.pairs.len();
        let reuse = cheap.pairs == regions.pairs && cheap.raw.len() == np * nt;
        let mut raw: Vec<Option<f64>> = Vec::with_capacity(np * nt);
        // Weight of the expensive terms that count towards the thresholded cost.
        let expensive_weight: f64 = self
            .terms
            .iter()
            .filter(|w| w.term.expensive() && !w.term.normalise_in_cluster())
            .map(|w| w.weight)
            .sum();
        let any_expensive = self.terms.iter().any(|w| w.term.expensive());
        let prefilter = self.prefilter.filter(|_| any_expensive);
        // Pass 1: the cheap terms of every pair, and whether its expensive ones are worth
        // computing at all (`hopeless`: see `with_prefilter`).
        let mut hopeless = vec![false; np];
        for (p, &(ti, di)) in regions.pairs.iter().enumerate() {
            let (Some(t), Some(d)) = (tracks.get(ti), dets.get(di)) else {
                raw.extend(std::iter::repeat_n(None, nt));
                hopeless[p] = true;
                continue;
            };
            let start = raw.len();
            if reuse {
                raw.extend_from_slice(&cheap.raw[start..start + nt]);
            } else {
                raw.extend(self.terms.iter().map(|w| {
                    (!w.term.expensive())
                        .then(|| w.term.cost(t, d).filter(|c| c.is_finite()))
                        .flatten()
                }));
            }
            let cheap = &raw[start..];
            hopeless[p] = prefilter.is_some_and(|max_cost| {
                let (mut num, mut den, mut gated) = (0.0, 0.0, false);
                for (w, c) in self.terms.iter().zip(cheap) {
                    if let Some(c) = c {
                        gated |= w.gate.is_some_and(|g| *c > g);
                        if !w.term.normalise_in_cluster() {
                            num += w.weight * c;
                            den += w.weight;
                        }
                    }
                }
                gated || (den > 0.0 && num / (den + expensive_weight) > max_cost)
            });
        }
        if !reuse {
            cheap.pairs.clone_from(&regions.pairs);
            cheap.raw.clone_from(&raw);
        }
        let ranked = self.rank_only_where_close(tracks.len(), dets.len(), regions, &raw, &hopeless);
        // Pass 2: the expensive terms of the pairs that could match; the cluster-normalised
        // ones only where they could change which candidate a track or a detection prefers.
        for (p, &(ti, di)) in regions.pairs.iter().enumerate() {
            if hopeless[p] {
                continue;
            }
            let (Some(t), Some(d)) = (tracks.get(ti), dets.get(di)) else {
                continue;
            };
            // Once a gate rejects the pair it is never matched: its remaining terms are not
            // computed, except the cluster-normalised ones, whose values set the cluster's
            // scale for the other pairs (re-identification: a colour that fails its gate
            // spares the SIFT match).
            let over_gate = |raw: &[Option<f64>], k: usize| {
                let w = &self.terms[k];
                matches!((w.gate, raw[p * nt + k]), (Some(g), Some(c)) if c > g)
            };
            let mut rejected = (0..nt).any(|k| over_gate(&raw, k));
            for (k, w) in self.terms.iter().enumerate() {
                if !w.term.expensive() || (rejected && !w.term.normalise_in_cluster()) {
                    continue;
                }
                raw[p * nt + k] = if ranked[p] || !w.term.normalise_in_cluster() {
                    w.term.cost(t, d).filter(|c| c.is_finite())
                } else {
                    // Not compared: the worst value a term may take (see
                    // `rank_only_where_close`). It also enters the cluster's normalisation as
                    // the pair would have: leaving it out made the compared pairs' spread
                    // look larger and lost 0.6 HOTA on a ragged crowd.
                    Some(1.0)
                };
                rejected |= over_gate(&raw, k);
            }
        }
        let gated: Vec<bool> = raw
            .chunks(nt.max(1))
            .map(|c| {
                self.terms
                    .iter()
                    .zip(c)
                    .any(|(t, c)| matches!((t.gate, c), (Some(g), Some(c)) if *c > g))
            })
            .collect();
        for (k, w) in self.terms.iter().enumerate() {
            if !w.term.normalise_in_cluster() {
                continue;
            }
            let mut max = vec![0.0f64; regions.clusters.len()];
            for (p, &cl) in regions.pair_cluster.iter().enumerate() {
                if let (Some(Some(c)), Some(m)) = (raw.get(p * nt + k), max.get_mut(cl)) {
                    *m = m.max(*c);
                }
            }
            for (p, &cl) in regions.pair_cluster.iter().enumerate() {
                let m = max.get(cl).copied().unwrap_or(0.0);
                if let Some(Some(c)) = raw.get_mut(p * nt + k) {
                    *c = if m > 0.0 {
                        (*c / m).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                }
            }
        }
        let mean = |c: &[Option<f64>], only_absolute: bool| -> Option<f64> {
            let (mut num, mut den) = (0.0, 0.0);
            for (t, c) in self.terms.iter().zip(c) {
                if only_absolute && t.term.normalise_in_cluster() {
                    continue;
                }
                if let Some(c) = c {
                    num += t.weight * c;
                    den += t.weight;
                }
            }
            (den > 0.0).then(|| num / den)
        };
        (0..np)
            .map(|p| {
                if gated.get(p).copied().unwrap_or(true) {
                    return None;
                }
                let c = raw.get(p * nt..(p + 1) * nt)?;
                let cost = mean(c, false)?;
                Some(PairScore {
                    cost,
                    absolute: mean(c, true).unwrap_or(cost),
                })
            })
            .collect()
    }

    /// Which pairs get their cluster-normalised expensive terms (the thesis' appearance costs
    /// C1 and C2), given the cheap terms in `raw`: those whose cheap cost is within the
    /// appearance terms' reach of the best cheap cost of their track or of their detection.
    ///
    /// Why (issue 10: bounded appearance work per cluster): with cheap weight `Wg` and
    /// expensive weight `Wa`, every term in `[0, 1]`, a pair whose cheap cost exceeds another
    /// candidate's of the same track by `Wa / Wg` or more ranks behind it whatever their
    /// appearance, and it still does whatever value its appearance terms are given (each
    /// takes any value in `[0, 1]`). Comparing it cannot change which candidate its track or
    /// its detection prefers, so the appearance of a pair dominated on both sides is not
    /// compared and takes the worst value, 1. In a crowd each track has a few close
    /// candidates and many distant ones in the same cluster: without this bound the pairs
    /// compared grew with the square of the crowd (the 200-shape bench compared ~5 pairs per
    /// detection, each with a k-means). Only the assignment's global trade-offs could still
    /// pick such a pair, when both preferred partners go elsewhere.
    fn rank_only_where_close(
        &self,
        num_tracks: usize,
        num_dets: usize,
        regions: &Regions,
        raw: &[Option<f64>],
        hopeless: &[bool],
    ) -> Vec<bool> {
        let nt = self.terms.len();
        let np = regions.pairs.len();
        let any_ranked = self
            .terms
            .iter()
            .any(|w| w.term.expensive() && w.term.normalise_in_cluster());
        if !any_ranked {
            return vec![true; np];
        }
        let expensive: f64 = self
            .terms
            .iter()
            .filter(|w| w.term.expensive())
            .map(|w| w.weight)
            .sum();
        // Each pair's cheap cost and the reach of the expensive terms over it.
        let cheap: Vec<Option<(f64, f64)>> = (0..np)
            .map(|p| {
                let c = raw.get(p * nt..(p + 1) * nt)?;
                let (mut num, mut den) = (0.0, 0.0);
                for (w, c) in self.terms.iter().zip(c) {
                    if let (false, Some(c)) = (w.term.expensive(), c) {
                        num += w.weight * c;
                        den += w.weight;
                    }
                }
                (den > 0.0).then(|| (num / den, expensive / den))
            })
            .collect();
        let mut best_t = vec![f64::INFINITY; num_tracks];
        let mut best_d = vec![f64::INFINITY; num_dets];
        for (p, &(t, d)) in regions.pairs.iter().enumerate() {
            if let (false, Some((g, _))) = (hopeless[p], cheap[p]) {
                if let Some(b) = best_t.get_mut(t) {
                    *b = b.min(g);
                }
                if let Some(b) = best_d.get_mut(d) {
                    *b = b.min(g);
                }
            }
        }
        regions
            .pairs
            .iter()
            .zip(&cheap)
            .map(|(&(t, d), c)| match c {
                // Without a cheap cost nothing bounds the pair: compare its appearance.
                None => true,
                Some((g, reach)) => {
                    let close = |b: Option<&f64>| b.is_some_and(|b| *g < b + reach);
                    close(best_t.get(t)) || close(best_d.get(d))
                }
            })
            .collect()
    }
}

/// The cheap terms of a set of pairs, kept between two scorings of the same pairs with the
/// same model ([`CostModel::score_pairs_reusing`]). Empty by default. The values belong to
/// the tracks and detections they were computed on: [`CheapTerms::clear`] it when those
/// change (a new frame), or the same pairs would read stale values.
#[derive(Debug, Clone, Default)]
pub struct CheapTerms {
    /// The pairs the values belong to.
    pairs: Vec<(usize, usize)>,
    /// Per pair, each term's cost (`None` for the expensive terms and where a term has no
    /// data), in [`CostModel::terms`] order.
    raw: Vec<Option<f64>>,
}

impl CheapTerms {
    /// Forgets the values (keeping the buffers, so a tracker reuses them frame after frame).
    pub fn clear(&mut self) {
        self.pairs.clear();
        self.raw.clear();
    }
}

/// The scores of one candidate pair (see [`CostModel::score_pairs`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairScore {
    /// Weighted mean of every term with data, the cluster-normalised ones normalised: what the
    /// assignment minimises.
    pub cost: f64,
    /// Weighted mean of the terms that are not cluster-normalised (`cost` when only those have
    /// data): what thresholds such as `max_cost` compare.
    pub absolute: f64,
}

#[cfg(test)]
#[path = "cost_tests.rs"]
mod tests;
