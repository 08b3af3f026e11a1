//! Detector-split shapes put back together ([`Config::merge_fragments`]): a matched mask
//! detection smaller than its track's whole shape, touching an unmatched detection that lies
//! where the track is predicted and that no other track can take, is one shape the detector
//! split in two (a limb cut off at a thin joint, a shadow line across a car): the two are
//! merged (mask union) before the track is updated, and the fragment starts no track of its
//! own.
//!
//! The opposite damage, two touching shapes in one detection, is recognised by
//! [`merged_views`] (see [`AppearanceConfig::merged_ratio`]): the track that takes such a
//! view is not moved by it.
//!
//! [`Config::merge_fragments`]: super::Config::merge_fragments

use std::borrow::Cow;

use super::associate::{Edge, Pair};
use super::features::{AppearanceConfig, FeatureExtractor};
use super::lifecycle::Track;
use super::prepare::Prepared;
use super::TrackError;
use crate::frame::{Detection, Frame, Mask, TrackState};

/// Largest gap, in pixels, between the shells of a detection and a fragment merged into it:
/// the pieces of one split mask touch, up to the detector's morphology (1–2 px).
const FRAGMENT_GAP_PX: f64 = 3.0;
/// A fragment must lie inside the track's predicted box grown by this fraction of its larger
/// side ...
const NEAR_MARGIN: f64 = 0.1;
/// ... by at least this fraction of its own box (intersection over its area).
const MIN_INSIDE: f64 = 0.8;
/// The merged area may exceed the track's reference area by at most this factor: two pieces
/// of one shape add up to about the shape (plus dilation), a neighbour would add much more.
const MAX_UNION_RATIO: f64 = 1.3;

/// A merged view covers at least this fraction of the other track's predicted box: two
/// touching shapes in one detection, not a neighbour grazed by a large box.
const MERGED_COVER: f64 = 0.5;

/// Which of `matches` took a view the detector merged with a neighbour's: the detection's
/// box is more than [`AppearanceConfig::merged_ratio`] times the track's predicted box, and
/// it covers most of the predicted box of another identified track that no match took (the
/// neighbour whose shape went into it). None without a ratio.
pub(crate) fn merged_views(
    tracks: &[Track],
    matches: &[Pair],
    dets: &[Prepared<'_>],
    config: &AppearanceConfig,
) -> Vec<bool> {
    let Some(ratio) = config.merged_ratio else {
        return vec![false; matches.len()];
    };
    let mut taken = vec![false; tracks.len()];
    for m in matches {
        if let Some(t) = taken.get_mut(m.track) {
            *t = true;
        }
    }
    matches
        .iter()
        .map(|m| {
            let (Some(d), Some(t)) = (dets.get(m.det), tracks.get(m.track)) else {
                return false;
            };
            let b = &d.det.bbox;
            b.area() > ratio * t.predicted_box().area()
                && tracks.iter().zip(&taken).any(|(o, &taken)| {
                    !taken
                        && o.id().is_some()
                        && o.state() != TrackState::Removed
                        && o.predicted_box().ioa(b) >= MERGED_COVER
                })
        })
        .collect()
}

/// The tracks whose main edge to one detection passes the gate.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Claim {
    /// No track.
    None,
    /// This track only.
    One(usize),
    /// Two tracks or more.
    Many,
}

impl Claim {
    /// With track `t`'s edge added.
    fn with(self, t: usize) -> Self {
        match self {
            Claim::None => Claim::One(t),
            Claim::One(o) if o == t => self,
            _ => Claim::Many,
        }
    }

    /// Whether a track other than `t` claims the detection.
    fn by_other_than(self, t: usize) -> bool {
        match self {
            Claim::None => false,
            Claim::One(o) => o != t,
            Claim::Many => true,
        }
    }
}

/// What the merge reads from the tracker.
pub(crate) struct Merge<'x> {
    /// A fragment another track could take with a cost up to this is claimed, not merged
    /// (the main stage's gate, [`Config::main_max_cost`](super::Config::main_max_cost)).
    pub(crate) max_cost: f64,
    /// Views smaller than this fraction of the reference area are partial
    /// ([`AppearanceConfig::whole_ratio`](super::AppearanceConfig::whole_ratio)).
    pub(crate) whole_ratio: f64,
    /// Computes the merged detection's features.
    pub(crate) extractor: &'x dyn FeatureExtractor,
}

/// Merges fragments into the matched detections of `matches` (module docs): a merged
/// fragment is marked used in `det_used`, and its partner's detection and features are
/// replaced by the union's (features from `limits.extractor`, on `frame`).
pub(crate) fn merge_fragments(
    tracks: &[Track],
    matches: &[Pair],
    main: &[Edge],
    dets: &mut [Prepared<'_>],
    det_used: &mut [bool],
    limits: &Merge<'_>,
    frame: Option<&Frame<'_>>,
) -> Result<(), TrackError> {
    // Which tracks could take each detection within the gate, gathered once (scanning the
    // edges per fragment and candidate was quadratic in the crowd: 7 % of a 200-shape frame).
    let mut claims = vec![Claim::None; dets.len()];
    for &(ot, od, _, gate) in main {
        if let (Some(c), true) = (claims.get_mut(od), gate <= limits.max_cost) {
            *c = c.with(ot);
        }
    }
    for m in matches {
        let Some(t) = tracks.get(m.track) else {
            continue;
        };
        let ref_area = t.reference_area();
        let (Some(md), true) = (dets.get(m.det), ref_area > 0.0) else {
            continue;
        };
        if md.det.mask.is_none() || md.features.area >= limits.whole_ratio * ref_area {
            continue;
        }
        let p = t.predicted_box();
        let near = p.expanded(NEAR_MARGIN * p.w.max(p.h));
        let Some(m_shell) = md.features.shell.clone() else {
            continue;
        };
        let mut best: Option<(usize, f64)> = None;
        for (j, f) in dets.iter().enumerate() {
            let free = !det_used.get(j).copied().unwrap_or(true);
            let claimed = claims.get(j).is_some_and(|c| c.by_other_than(m.track));
            let (Some(fs), true) = (f.features.shell.as_ref(), free && !claimed) else {
                continue;
            };
            let union_area = md.features.area + f.features.area;
            if f.det.bbox.ioa(&near) < MIN_INSIDE || union_area > MAX_UNION_RATIO * ref_area {
                continue;
            }
            let gap = m_shell.distance(fs);
            if gap <= FRAGMENT_GAP_PX && best.is_none_or(|(_, g)| gap < g) {
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
        let features = limits
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A detection is claimed against track `t` exactly when some edge within the gate comes
    /// from another track, whatever the order and repetition of the edges.
    #[test]
    fn claims_match_a_scan_of_the_edges() {
        let edge_sets: [&[usize]; 6] = [&[], &[1], &[1, 1], &[1, 2], &[2, 1, 2], &[3, 3, 3]];
        for edges in edge_sets {
            let claim = edges.iter().fold(Claim::None, |c, &t| c.with(t));
            for t in 0..5 {
                let scan = edges.iter().any(|&o| o != t);
                assert_eq!(claim.by_other_than(t), scan, "edges {edges:?}, track {t}");
            }
        }
    }
}
