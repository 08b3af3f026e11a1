//! When appearance is worth computing. Appearance (shape context, SIFT, colour) costs far more
//! than geometry, so the tracker describes a detection only where it can change a decision:
//!
//! - in an **ambiguous** region cluster ([`ambiguous_detections`]): geometry and motion alone
//!   rank two candidates of a track (or of a detection) within
//!   [`AppearanceConfig::ambiguity`](super::AppearanceConfig::ambiguity) of each other. A 1×1
//!   cluster, or a crossing that motion already resolves, costs no appearance;
//! - for **re-identification**, on the detections a lost track could take (the tracker's
//!   reid stage);
//! - **before it is too late**: a matched track's appearance is taken now when its box will
//!   touch another track's by the next frame ([`crowded_next_frame`]: a crossing is coming and
//!   the views will be mixed), or when its reference appearance is missing or stale while the
//!   shape is seen whole (so a track lost behind an occluder is re-identified by a whole view).

use super::associate::Edge;
use super::lifecycle::Track;
use super::regions::Regions;
use crate::frame::{BBox, TrackState};
use crate::geometry::overlapping_box_pairs;

/// When a cluster is ambiguous (see [`ambiguous_detections`]).
pub(crate) struct Ambiguity {
    /// Candidates must pass this cost ([`Config::max_cost`](super::Config::max_cost)).
    pub(crate) max_cost: f64,
    /// Two candidates within this much of each other are ambiguous.
    pub(crate) margin: f64,
    /// Lost tracks take part in the main association: a cluster holding one is ambiguous
    /// (its prediction has drifted, so geometry alone says little).
    pub(crate) lost_in_main: bool,
}

/// Which detections lie in an ambiguous cluster of `regions`, given the `geometric` costs
/// (appearance terms without data) of the pairs of the tracks that `counted` accepts: a
/// cluster is ambiguous when one of its counted tracks has two candidates whose costs pass
/// `max_cost` and lie within `margin` of each other, or one of its detections two such
/// tracks, or (`lost_in_main`) it holds a lost track.
pub(crate) fn ambiguous_detections(
    tracks: &[Track],
    num_dets: usize,
    regions: &Regions,
    geometric: &[Edge],
    counted: impl Fn(usize) -> bool,
    a: &Ambiguity,
) -> Vec<bool> {
    let (max_cost, margin, lost_in_main) = (a.max_cost, a.margin, a.lost_in_main);
    // Best and second-best passing cost per track and per detection.
    let mut best_t = vec![(f64::INFINITY, f64::INFINITY); tracks.len()];
    let mut best_d = vec![(f64::INFINITY, f64::INFINITY); num_dets];
    let push = |b: &mut (f64, f64), c: f64| {
        if c < b.0 {
            *b = (c, b.0);
        } else if c < b.1 {
            b.1 = c;
        }
    };
    for &(t, d, _, gate) in geometric {
        if gate <= max_cost {
            push(&mut best_t[t], gate);
            push(&mut best_d[d], gate);
        }
    }
    let close = |b: &(f64, f64)| b.1.is_finite() && b.1 - b.0 < margin;
    let mut want = vec![false; num_dets];
    for c in &regions.clusters {
        let ambiguous = c
            .tracks
            .iter()
            .any(|&t| counted(t) && best_t.get(t).is_some_and(close))
            || c.dets.iter().any(|&d| best_d.get(d).is_some_and(close))
            || (lost_in_main
                && c.tracks
                    .iter()
                    .any(|&t| tracks.get(t).is_some_and(|t| t.state() == TrackState::Lost)));
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

/// Which of `tracks` will touch another counted track's box by the next frame (give or take
/// one frame of motion): their next frame's clusters are likely to be ambiguous, and their
/// appearance must be taken now, while they are apart. Tracks `counted` rejects (lost ones
/// that only re-identification matches, whose wide search regions would make every track
/// crowded) neither count nor get marked.
pub(crate) fn crowded_next_frame(tracks: &[Track], counted: impl Fn(&Track) -> bool) -> Vec<bool> {
    let boxes: Vec<BBox> = tracks
        .iter()
        .map(|t| {
            if !counted(t) {
                return BBox::new(f64::NAN, f64::NAN, 0.0, 0.0);
            }
            let v = t.motion().velocity();
            let next = t.anchor_box().translated(v.x, v.y);
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
