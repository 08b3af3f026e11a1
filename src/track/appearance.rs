//! Appearance pair-cost terms: the thesis' shape context C1 (Alg. 4 / Alg. 5) and spatial
//! colour C2 (Alg. 6), and a SIFT match term, each reading the [`Appearance`] of the track
//! and of the detection. A term has no data (and drops out, the other weights renormalising)
//! unless both sides carry the part it reads: box mode, a missing frame, or a detection in a
//! cluster where the tracker did not need appearance.
//!
//! C1 and C2 are normalised within the region cluster (thesis §4.3 step 4, Alg. 6 step 8):
//! their raw values are only comparable between the pairs of one cluster. Their gates, when
//! configured, apply to the raw values ([`super::CostModel`] gates before normalising).
//!
//! Which track appearance a term reads is its [`TrackSide`]: the latest one (main
//! association: compare frame n with frame n+1, as the thesis) or the reference one, the last
//! appearance computed while the shape was seen whole (re-identification after an occlusion,
//! when the last view was a sliver at an occluder's edge).

use crate::features::color::{
    color_cost, color_cost_per_view, foreign_share_at_least_in, joint_palette, palette_distance,
    ColorConfig, ColorSample,
};
use crate::features::shape_context::{match_shapes, shape_cost_from_matches, ShapeContextConfig};
use crate::features::sift::{match_descriptors, MatchConfig};
use crate::frame::Point;
use serde::{Deserialize, Serialize};

use super::config::{Config, ShapeVariant, Terms};
use super::cost::{Candidate, CostModel, PairCost};
use super::features::Appearance;
use super::lifecycle::Track;

/// Which of the track's appearances a term compares with the detection.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum TrackSide {
    /// The latest appearance computed for the track.
    Last,
    /// The latest appearance computed while the track was seen whole (falls back to the
    /// latest when there is none).
    Reference,
}

impl TrackSide {
    fn of(self, t: &Track) -> Option<&Appearance> {
        match self {
            TrackSide::Last => t.appearance(),
            TrackSide::Reference => t.reference_appearance().or_else(|| t.appearance()),
        }
    }
}

fn det_appearance<'d>(d: &Candidate<'d>) -> Option<&'d Appearance> {
    d.features?.appearance.as_deref()
}

/// Thesis C1 (shape context): the symmetric sum of nearest contour-vertex distances after
/// aligning the detection onto the track, in units of the track's median vertex distance.
/// Normalised within the cluster.
#[derive(Debug, Clone, PartialEq)]
pub struct ShapeContextCost {
    /// Descriptor and fitting settings (must be those the descriptors were built with).
    pub config: ShapeContextConfig,
    /// Alg. 4 or Alg. 5.
    pub variant: ShapeVariant,
    /// SIFT matching settings ([`ShapeVariant::Sift`] only).
    pub matching: MatchConfig,
    /// Which track appearance to compare.
    pub side: TrackSide,
}

impl PairCost for ShapeContextCost {
    fn name(&self) -> &str {
        "shape_context"
    }

    fn expensive(&self) -> bool {
        true
    }

    fn cost(&self, track: &Track, det: &Candidate<'_>) -> Option<f64> {
        let (a, b) = (self.side.of(track)?, det_appearance(det)?);
        let (sa, sb) = (a.shape.as_ref()?, b.shape.as_ref()?);
        let m = match self.variant {
            ShapeVariant::Contour => match_shapes(sa, sb, &self.config).ok()?,
            ShapeVariant::Sift => {
                let (ka, kb) = (a.sift()?, b.sift()?);
                let pt = |k: &crate::features::sift::Keypoint| Point::new(k.x as f64, k.y as f64);
                let pairs: Vec<(Point, Point)> = match_descriptors(ka, kb, &self.matching)
                    .iter()
                    .filter_map(|m| {
                        Some((
                            pt(ka.keypoints.get(m.query)?),
                            pt(kb.keypoints.get(m.train)?),
                        ))
                    })
                    .collect();
                shape_cost_from_matches(sa.vertices(), sb.vertices(), &pairs, &self.config).ok()?
            }
        };
        m.cost.is_finite().then_some(m.cost)
    }

    fn normalise_in_cluster(&self) -> bool {
        true
    }
}

/// How C2 compares two colour samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum ColourMode {
    /// Alg. 6: one joint k-means++ palette, the detection aligned onto the track by their
    /// sample centroids, C2 = fraction of overlapping samples whose colours differ. Frames are
    /// consecutive, so the motion between the two views is mostly a translation; aligning by
    /// the shape context fit instead would fit the transform a second time per pair, and
    /// would inherit its errors on partly occluded shapes. Normalised within the cluster.
    /// With [`ColorConfig::per_view`], each view's own palette replaces the joint one.
    #[default]
    Aligned,
    /// Alignment-free: Hellinger distance between the two label histograms over the joint
    /// palette. Not normalised (an absolute colour distance gates a lone candidate).
    Palette,
    /// Alignment-free and partial-view tolerant: the fraction of the detection's samples whose
    /// palette colour is rare (under 3% of the samples) in the track's view. A sliver of a
    /// shape emerging from behind an occluder shows only some of its colours, all of them
    /// present in the whole view: a histogram distance would call it a different shape, this
    /// measure does not; a different shape brings colours the track never had. For
    /// re-identification, against the track's reference (whole) view. Not normalised. Under a
    /// tight gate, pairs almost wholly foreign by a cheaper measure skip the joint palette
    /// ([`ColourCost`]'s screen).
    Contained,
}

/// Share of a label in a view's samples under which a detection's sample of that label counts
/// as a colour the view does not have.
const RARE_LABEL: f64 = 0.03;

/// Share of a detection's samples, each taken to its nearest colour of the reference view's
/// own palette, that lie outside what the view has ([`foreign_share`](crate::features::color::foreign_share)) from which
/// [`ColourMode::Contained`] rejects the pair without its joint palette, when the term's gate is
/// at most [`SCREEN_MAX_GATE`].
const SCREEN_SHARE: f64 = 0.9;

/// The highest colour gate under which [`SCREEN_SHARE`] screens pairs: far enough below it
/// that a pair the screen rejects fails the gate by the joint palette too: of the 15,234 pairs
/// the mask preset compared this way on the robustness grid's mask cells (online) and the
/// 200-shape bench, the screen rejects 11,452, and 9 of those would have passed its gate of
/// 0.35 by the joint palette.
const SCREEN_MAX_GATE: f64 = 0.5;

/// Thesis C2 (spatial colour), see [`ColourMode`].
#[derive(Debug, Clone, PartialEq)]
pub struct ColourCost {
    /// k-means and sampling settings.
    pub config: ColorConfig,
    /// Aligned (thesis) or palette-only.
    pub mode: ColourMode,
    /// Which track appearance to compare.
    pub side: TrackSide,
    /// The term's gate (pairs above it are rejected), which lets
    /// [`ColourMode::Contained`] screen pairs (see `ColourCost::screened`).
    pub gate: Option<f64>,
}

impl ColourCost {
    /// Whether a [`ColourMode::Contained`] pair is rejected before its joint palette: with a
    /// gate of at most [`SCREEN_MAX_GATE`], when at least [`SCREEN_SHARE`] of the detection's
    /// samples have no colour near a common one of the reference view's own palette
    /// ([`foreign_share`](crate::features::color::foreign_share)): the view's k-means and its
    /// colours' reaches are computed once per view ([`Appearance::colour_reach`]), the pair
    /// costs one pass over the detection's samples, often cut short. Re-identification
    /// compares each new detection with every lost track in reach; in a crowd that was a joint
    /// k-means for each of ~100 pairs a frame on the 200-shape bench, and nearly all of them
    /// failed the gate (issue 10).
    fn screened(&self, view: &Appearance, b: &ColorSample) -> bool {
        if !self.gate.is_some_and(|g| g <= SCREEN_MAX_GATE) {
            return false;
        }
        let Some(reach) = view.colour_reach(&self.config) else {
            return false;
        };
        foreign_share_at_least_in(reach, b, RARE_LABEL, SCREEN_SHARE, &self.config).unwrap_or(false)
    }
}

impl PairCost for ColourCost {
    fn name(&self) -> &str {
        "colour"
    }

    fn expensive(&self) -> bool {
        true
    }

    fn cost(&self, track: &Track, det: &Candidate<'_>) -> Option<f64> {
        let (a, b) = (self.side.of(track)?, det_appearance(det)?);
        let (ca, cb) = (a.colour.as_ref()?, b.colour.as_ref()?);
        let cfg = &self.config;
        let c = match self.mode {
            ColourMode::Aligned if cfg.per_view => {
                let (pa, pb, ia) = (a.palette(cfg)?, b.palette(cfg)?, a.colour_index()?);
                color_cost_per_view((ca, pa, ia), (cb, pb), None, cfg)
                    .ok()?
                    .cost
            }
            ColourMode::Aligned => color_cost(ca, cb, None, &self.config).ok()?.cost,
            ColourMode::Palette => palette_distance(ca, cb, &self.config).ok()?,
            ColourMode::Contained => {
                if self.screened(a, cb) {
                    return Some(1.0);
                }
                let p = joint_palette(ca, cb, &self.config).ok()?;
                let (ha, _) = p.histograms();
                if p.labels_b.is_empty() {
                    return None;
                }
                let foreign = p
                    .labels_b
                    .iter()
                    .filter(|&&l| ha.get(l).copied().unwrap_or(0.0) < RARE_LABEL)
                    .count();
                foreign as f64 / p.labels_b.len() as f64
            }
        };
        c.is_finite().then_some(c.clamp(0.0, 1.0))
    }

    fn normalise_in_cluster(&self) -> bool {
        self.mode == ColourMode::Aligned
    }
}

/// SIFT evidence: `1 − matches / min(|A|, |B|)`, matches by Lowe's ratio test, in `[0, 1]`.
/// No data when either side has fewer than `min_keypoints` keypoints (a smooth shape has no
/// texture to match, which says nothing about identity).
#[derive(Debug, Clone, PartialEq)]
pub struct SiftCost {
    /// Ratio test settings.
    pub matching: MatchConfig,
    /// Fewest keypoints on each side for the term to have data.
    pub min_keypoints: usize,
    /// Which track appearance to compare.
    pub side: TrackSide,
}

impl PairCost for SiftCost {
    fn name(&self) -> &str {
        "sift"
    }

    fn expensive(&self) -> bool {
        true
    }

    fn cost(&self, track: &Track, det: &Candidate<'_>) -> Option<f64> {
        let (a, b) = (self.side.of(track)?, det_appearance(det)?);
        let (ka, kb) = (a.sift()?, b.sift()?);
        let n = ka.len().min(kb.len());
        if n < self.min_keypoints.max(1) {
            return None;
        }
        let m = match_descriptors(ka, kb, &self.matching).len().min(n);
        Some(1.0 - m as f64 / n as f64)
    }
}
/// The cost models of the main association (the last view, colour as the thesis aligns it)
/// and of re-identification (the reference view, colour by containment), each skipping the
/// appearance of pairs it could not accept ([`CostModel::with_prefilter`]): the main scores
/// serve the stages up to their highest threshold (fragments merge under `max_cost` too), the
/// re-identification scores `reid_max_cost`.
pub(crate) fn cost_models(config: &Config) -> (CostModel, CostModel) {
    let main_max = [
        config.max_cost,
        config.max_cost_low,
        config.max_cost_tentative,
    ];
    let main = cost_model(&config.terms, config, TrackSide::Last, ColourMode::Aligned)
        .with_prefilter(main_max.into_iter().fold(f64::MIN, f64::max));
    let reid = cost_model(
        &config.reid_terms,
        config,
        TrackSide::Reference,
        ColourMode::Contained,
    )
    .with_prefilter(config.reid_max_cost);
    (main, reid)
}

/// The cost model of one association: the geometric and motion terms of `terms` and the
/// appearance terms registered here (those with a positive weight), reading the track's
/// `side` appearance, colour compared as `colour`.
pub(crate) fn cost_model(
    terms: &Terms,
    config: &Config,
    side: TrackSide,
    colour: ColourMode,
) -> CostModel {
    // The IoA buffer grows like the search region: twice the per-side margin growth.
    let ioa_growth = 2.0 * config.region_margin_per_miss;
    let mut model = CostModel::from_terms_with(terms, ioa_growth);
    register_appearance(&mut model, terms, config, side, colour);
    model
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
            gate: terms.colour.gate,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{BBox, Detection};
    use crate::motion::BoxKalman;
    use crate::track::features::{AppearanceConfig, Features};
    use std::sync::Arc;

    /// Samples on a row, one pixel apart: each part's count of its colour in turn, with a small
    /// deterministic jitter.
    fn sample(parts: &[([u8; 3], usize)]) -> ColorSample {
        let rgb: Vec<[u8; 3]> = parts
            .iter()
            .flat_map(|&(c, n)| (0..n).map(move |i| c.map(|v| v.saturating_add((i % 5) as u8))))
            .collect();
        let positions = (0..rgb.len())
            .map(|i| Point::new(i as f64 + 0.5, 0.5))
            .collect();
        ColorSample::new(positions, rgb, 1.0).unwrap()
    }

    fn view(s: ColorSample) -> Arc<Appearance> {
        Arc::new(Appearance::new(1, None, None, Some(s)))
    }

    #[test]
    fn containment_screens_out_almost_wholly_foreign_pairs_under_a_tight_gate() {
        let (red, blue, green) = ([200, 20, 20], [20, 20, 200], [20, 200, 20]);
        let b = BBox::new(0.0, 0.0, 40.0, 80.0);
        let motion = Box::new(BoxKalman::new(&b, Config::default().motion_params()).unwrap());
        let det = Detection::from_box(b, 1.0);
        let reference = view(sample(&[(red, 60), (blue, 40)]));
        let track = Track::born(
            &det,
            &Features::default(),
            motion,
            Some(reference),
            1,
            false,
            false,
        );
        let cost_of = |gate: Option<f64>, colours: &[([u8; 3], usize)]| {
            let features = Features {
                appearance: Some(view(sample(colours))),
                ..Features::default()
            };
            let cand = Candidate {
                index: 0,
                detection: &det,
                features: Some(&features),
            };
            let term = ColourCost {
                config: AppearanceConfig::default().colour,
                mode: ColourMode::Contained,
                side: TrackSide::Reference,
                gate,
            };
            term.cost(&track, &cand).unwrap()
        };
        // 95 % of the detection is a colour the view lacks: by the joint palette its share is
        // 0.95; under a gate of 0.35 the screen rejects it at once (cost 1, over any gate).
        let mostly_green = [(green, 95), (red, 5)];
        assert!((cost_of(None, &mostly_green) - 0.95).abs() < 1e-9);
        assert!((cost_of(Some(0.6), &mostly_green) - 0.95).abs() < 1e-9);
        assert_eq!(cost_of(Some(0.35), &mostly_green), 1.0);
        // A sliver of the view's own colours is not screened and keeps the joint measure.
        assert_eq!(cost_of(Some(0.35), &[(red, 20), (blue, 10)]), 0.0);
        // Half foreign: under the screen's share, so the joint palette decides.
        let half = [(green, 50), (red, 50)];
        assert_eq!(cost_of(Some(0.35), &half), cost_of(None, &half));
    }
}
