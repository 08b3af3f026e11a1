//! When appearance is worth computing. Appearance (shape context, SIFT, colour) costs far more
//! than geometry, so the tracker describes a detection only where it can change a decision:
//!
//! - in an **ambiguous** group of competing pairs ([`ambiguous_detections`]): geometry and
//!   motion alone rank two candidates of a track (or of a detection) within
//!   [`AppearanceConfig::ambiguity`](super::AppearanceConfig::ambiguity) of each other, or
//!   one of the tracks is lost (its prediction has drifted). A group is a connected component
//!   of the pairs geometry lets through, not a whole region cluster: in a crowd the search
//!   shells chain most shapes into one cluster, while the pairs that can actually compete
//!   form small groups. A 1×1 group, or a crossing that motion already resolves, costs no
//!   appearance;
//! - for **re-identification**, on the detections a lost track could take (the tracker's
//!   reid stage);
//! - **before it is too late**: a matched track's appearance is taken now when its box will
//!   touch another track's by the next frame ([`crowded_next_frame`]: a crossing is coming and
//!   the views will be mixed), or when its reference appearance is missing or stale while the
//!   shape is seen whole (so a track lost behind an occluder is re-identified by a whole view).

use super::associate::Edge;
use super::lifecycle::Track;
use crate::assign::Dsu;
use crate::frame::{BBox, TrackState};
use crate::geometry::overlapping_box_pairs;

/// When a group of competing pairs is ambiguous (see [`ambiguous_detections`]).
pub(crate) struct Ambiguity {
    /// Pairs must pass this cost ([`Config::max_cost`](super::Config::max_cost)) to compete.
    pub(crate) max_cost: f64,
    /// Two candidates within this much of each other are ambiguous.
    pub(crate) margin: f64,
}

/// Which detections need appearance, given the `geometric` costs (appearance terms without
/// data) of the pairs of the tracks that take part in the main association: the pairs
/// passing `max_cost` link tracks and detections into groups (connected components), and
/// every detection of a group is described when one of its tracks has two candidates within
/// `margin` of each other, or one of its detections two such tracks, or one of its tracks is
/// lost. Appearance then enters every competing pair of an ambiguous group alike (a term
/// without data drops out of a pair's cost, so a group described in part would weigh its
/// pairs unevenly), and no group geometry already decides pays for it.
///
/// Before, every detection of an ambiguous region cluster was described: 200 shapes at
/// 640×480 computed 162 palettes a frame for 161 detections, and colour comparisons took half
/// the frame (issue 10). Lost tracks of the main association (the mask preset's recent ones)
/// now make their group ambiguous too (mask cells of the robustness grid: mean HOTA
/// +0.02 online and offline; `tests/data/quality/README.md`).
pub(crate) fn ambiguous_detections(
    tracks: &[Track],
    num_dets: usize,
    geometric: &[Edge],
    a: &Ambiguity,
) -> Vec<bool> {
    let (max_cost, margin) = (a.max_cost, a.margin);
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
    let mut pairs = Vec::with_capacity(geometric.len());
    for &(t, d, _, gate) in geometric {
        if gate <= max_cost && t < tracks.len() && d < num_dets {
            push(&mut best_t[t], gate);
            push(&mut best_d[d], gate);
            pairs.push((t, d));
        }
    }
    let close = |b: &(f64, f64)| b.1.is_finite() && b.1 - b.0 < margin;
    // The groups are the connected components of `pairs` (tracks 0.., detections after
    // them), found by union–find: only whether each group is ambiguous is needed, not its
    // member lists (which cost two allocations per group and frame; issue 10).
    let nt = tracks.len();
    let mut groups = Dsu::new(nt + num_dets);
    for &(t, d) in &pairs {
        groups.join(t, nt + d);
    }
    let mut ambiguous = vec![false; nt + num_dets];
    for &(t, d) in &pairs {
        let track_says = best_t.get(t).is_some_and(close)
            || tracks.get(t).is_some_and(|t| t.state() == TrackState::Lost);
        if track_says || best_d.get(d).is_some_and(close) {
            ambiguous[groups.find(t)] = true;
        }
    }
    let mut want = vec![false; num_dets];
    for &(_, d) in &pairs {
        want[d] = ambiguous[groups.find(nt + d)];
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::Detection;
    use crate::motion::BoxKalman;
    use crate::track::features::Features;
    use crate::track::Config;

    fn track_at(x: f64) -> Track {
        let b = BBox::new(x, 0.0, 40.0, 80.0);
        let motion = Box::new(BoxKalman::new(&b, Config::default().motion_params()).unwrap());
        let det = Detection::from_box(b, 1.0);
        Track::born(&det, &Features::default(), motion, None, 1, false, false)
    }

    const A: Ambiguity = Ambiguity {
        max_cost: 0.75,
        margin: 0.2,
    };

    #[test]
    fn only_the_groups_geometry_cannot_decide_are_described() {
        let tracks: Vec<Track> = [0.0, 100.0, 200.0, 300.0].map(track_at).into();
        // Track 0 has two candidates 0.1 apart (d0, d1): ambiguous. Track 1 has one clear
        // candidate (d2) and one far beyond the gate (d1, 0.9): the gate-failing pair does
        // not link it to track 0's group. Tracks 2 and 3 each have a clear best (d3, d4) and
        // share a second candidate (d5) that is worse for both by more than the margin.
        let geometric: Vec<Edge> = vec![
            (0, 0, 0.2, 0.2),
            (0, 1, 0.3, 0.3),
            (1, 1, 0.9, 0.9),
            (1, 2, 0.1, 0.1),
            (2, 3, 0.1, 0.1),
            (3, 4, 0.1, 0.1),
            (2, 5, 0.6, 0.6),
            (3, 5, 0.5, 0.5),
        ];
        let want = ambiguous_detections(&tracks, 7, &geometric, &A);
        // d5 has two tracks 0.1 apart: its group (tracks 2, 3; d3, d4, d5) is ambiguous.
        assert_eq!(want, [true, true, false, true, true, true, false]);
        // Without d5's second pair, nothing links or ties tracks 2 and 3.
        let fewer: Vec<Edge> = geometric[..7].to_vec();
        let want = ambiguous_detections(&tracks, 7, &fewer, &A);
        assert_eq!(want, [true, true, false, false, false, false, false]);
    }

    #[test]
    fn a_lost_track_makes_its_group_ambiguous() {
        let mut tracks: Vec<Track> = [0.0, 100.0].map(track_at).into();
        let geometric: Vec<Edge> = vec![(0, 0, 0.1, 0.1), (1, 1, 0.1, 0.1)];
        assert_eq!(
            ambiguous_detections(&tracks, 2, &geometric, &A),
            [false, false]
        );
        tracks[1].confirm(1);
        tracks[1].miss(1, 30);
        assert_eq!(tracks[1].state(), TrackState::Lost);
        assert_eq!(
            ambiguous_detections(&tracks, 2, &geometric, &A),
            [false, true]
        );
    }
}
