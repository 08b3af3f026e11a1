//! Camera motion from the tracks themselves: when the camera pans or shakes, every object's
//! detection lands away from its prediction by about the same offset. The tracker measures
//! that common offset between the tracks seen in the previous frame and this frame's
//! detections, and, when the tracks agree on it, moves the tracks that were not seen in the last
//! frame (lost ones, and tentative ones that missed) by it before associating — so a lost
//! track's prediction follows the camera. Tracks seen in the last frame are left alone: their
//! own detection corrects them.
//!
//! Box mode has no image to estimate camera motion from (BoT-SORT registers frames; we may
//! have no frames), but the objects are many independent witnesses of it. The offset is the
//! median of the mutual-nearest (track, detection) displacements; it is applied only when it
//! is significant — larger than the spread of the displacements allows for a static camera
//! (a median's standard error) — and nearly all pairs agree with it ([`AGREE_SHARE`]), so a
//! static camera with noisy detections, a crowd walking one way or a driving car's spreading
//! view is left alone, unless they all move the same way at once, which a constant-velocity
//! filter would not have predicted either.

use super::lifecycle::Track;
use super::prepare::Prepared;
use crate::frame::{BBox, Point, TrackState};
use crate::geometry::overlapping_box_pairs;

/// Fewest agreeing (track, detection) pairs for an estimate.
const MIN_PAIRS: usize = 3;

/// Furthest a detection may lie from a track's prediction to be its witness, in the track's
/// box size (geometric mean of width and height): camera jolts move objects by a good part of
/// their size between frames.
const MAX_DISTANCE: f64 = 1.5;

/// Largest size ratio (either way) between a track's predicted box and its witness.
const MAX_SIZE_RATIO: f64 = 1.5;

/// A pair agrees with the estimated offset when its displacement lies within this share of
/// the track's size of the offset.
const AGREE: f64 = 0.25;

/// Share of the pairs that must agree with the offset: a camera's motion moves nearly every
/// object alike, while a driving car's own motion spreads them (objects ahead and beside move
/// differently), and a half-agreeing estimate moved lost tracks the wrong way there (BDD100K's
/// real boxes: −0.9 HOTA at 1/2, −0.1 at 0.8; a panning SportsMOT camera gains the same
/// ≈ +2 either way).
const AGREE_SHARE: f64 = 0.8;

/// Smallest offset applied, as a share of the witnesses' median size: with precise detections
/// (masks) a static camera's offsets of a pixel or two pass the significance test whenever the
/// objects accelerate alike, and moving lost tracks by them every frame drifts them away (the
/// browser's occlusion scene: 25 → 27 ids online). A jolt worth following moves objects by
/// more; 0.05 scored best on both grids (box cells 55.51 → 55.55 mean HOTA, at 0.1 55.50, at
/// 0.2 55.19; mask cells 71.05 → 71.10).
const MIN_SHIFT: f64 = 0.05;

/// Significance of the offset: its length must exceed this many standard errors of the
/// median (≈ 1.25 · MAD-sigma / √n).
const SIGNIFICANCE: f64 = 3.0;

/// The camera's motion as the tracker follows it, frame by frame.
#[derive(Debug, Clone, Default)]
pub(crate) struct Camera {
    /// The offset followed in this frame, if any.
    offset: Option<Point>,
}

impl Camera {
    /// Moves the tracks that went unmatched in the last frame by the camera's motion, when
    /// the tracks that were seen agree on one ([`common_offset`]): the tracks seen in the last
    /// frame are left alone (their own detection corrects them; moving them too lost 0.3 HOTA
    /// on the grid), and those of them that go unmatched in this frame follow it after the
    /// association ([`Camera::follow_missed`]). Nothing when `enabled`
    /// ([`Config::camera_motion`]) is off.
    ///
    /// [`Config::camera_motion`]: super::Config::camera_motion
    pub(crate) fn follow(&mut self, tracks: &mut [Track], dets: &[Prepared<'_>], enabled: bool) {
        self.offset = None;
        if !enabled {
            return;
        }
        let Some(o) = common_offset(tracks, dets) else {
            return;
        };
        for t in tracks.iter_mut().filter(|t| t.misses() > 0) {
            t.translate(o.x, o.y);
        }
        self.offset = Some(o);
    }

    /// A track seen in the last frame and missed in this one, in a frame where the camera
    /// moved ([`Camera::follow`]): it was left where its filter put it, so it follows the
    /// camera now, before its miss is counted.
    pub(crate) fn follow_missed(&self, t: &mut Track) {
        if let (Some(o), 0) = (self.offset, t.misses()) {
            t.translate(o.x, o.y);
        }
    }
}

/// The common offset (pixels) between the tracks seen in the previous frame and `dets`, when
/// significant and agreed on (module docs).
pub(crate) fn common_offset(tracks: &[Track], dets: &[Prepared<'_>]) -> Option<Point> {
    let witnesses: Vec<usize> = (0..tracks.len())
        .filter(|&i| tracks[i].state() == TrackState::Confirmed && tracks[i].misses() == 0)
        .collect();
    if witnesses.len() < MIN_PAIRS || dets.len() < MIN_PAIRS {
        return None;
    }
    let size = |b: &BBox| (b.w.max(1.0) * b.h.max(1.0)).sqrt();
    let close = |t: usize, d: usize| -> Option<f64> {
        let (p, b) = (tracks[t].predicted_box(), dets[d].det.bbox);
        let (sp, sb) = (size(&p), size(&b));
        let ratio = sp.max(sb) / sp.min(sb);
        let dist = b.center().dist(p.center()) / sp;
        (ratio <= MAX_SIZE_RATIO && dist <= MAX_DISTANCE).then_some(dist)
    };
    // Candidate pairs from the project's sort-and-sweep broad phase (a detection's centre in
    // the square around a witness's prediction that holds its `MAX_DISTANCE` circle), not
    // every witness against every detection: this runs every frame, and with hundreds of
    // boxes the double loop cost more than the rest of box-mode tracking.
    let reach: Vec<BBox> = witnesses
        .iter()
        .map(|&t| {
            let p = tracks[t].predicted_box();
            let r = 2.0 * MAX_DISTANCE * size(&p);
            BBox::from_center(p.center(), r, r)
        })
        .collect();
    // Only confident detections witness (a non-finite box matches nothing).
    let centres: Vec<BBox> = dets
        .iter()
        .map(|d| match d.high {
            true => BBox::from_center(d.det.bbox.center(), 0.0, 0.0),
            false => BBox::new(f64::NAN, f64::NAN, 0.0, 0.0),
        })
        .collect();
    // Per witness its nearest detection, per detection its nearest witness (the first of
    // equals, in index order).
    let mut det_of = vec![None::<(usize, f64)>; witnesses.len()];
    let mut witness_of = vec![None::<(usize, f64)>; dets.len()];
    let nearer = |best: &Option<(usize, f64)>, c: f64| {
        best.is_none_or(|(_, b)| c.total_cmp(&b) == std::cmp::Ordering::Less)
    };
    for (k, d) in overlapping_box_pairs(&reach, &centres, 0.0) {
        let Some(c) = close(witnesses[k], d) else {
            continue;
        };
        if nearer(&det_of[k], c) {
            det_of[k] = Some((d, c));
        }
        if nearer(&witness_of[d], c) {
            witness_of[d] = Some((k, c));
        }
    }
    // (displacement, track size) of the mutual nearest pairs.
    let pairs: Vec<(Point, f64)> = (0..witnesses.len())
        .filter_map(|k| {
            let (d, _) = det_of[k]?;
            (witness_of[d].map(|(w, _)| w) == Some(k)).then(|| {
                let p = tracks[witnesses[k]].predicted_box();
                (dets[d].det.bbox.center() - p.center(), size(&p))
            })
        })
        .collect();
    if pairs.len() < MIN_PAIRS {
        return None;
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        let n = v.len();
        if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        }
    };
    let offset = Point::new(
        median(&mut pairs.iter().map(|p| p.0.x).collect()),
        median(&mut pairs.iter().map(|p| p.0.y).collect()),
    );
    let agree = pairs
        .iter()
        .filter(|(d, s)| d.dist(offset) <= AGREE * s)
        .count();
    if (agree as f64) < AGREE_SHARE * pairs.len() as f64 || agree < MIN_PAIRS {
        return None;
    }
    // The spread of the displacements around the offset, robustly: the median distance of a
    // 2-D normal from its centre is σ·√(2 ln 2) ≈ 1.1774 σ.
    let sigma = median(&mut pairs.iter().map(|p| p.0.dist(offset)).collect()) / 1.1774;
    let stderr = 1.2533 * sigma / (pairs.len() as f64).sqrt();
    let shift = offset.dist(Point::default());
    let size = median(&mut pairs.iter().map(|p| p.1).collect());
    (shift > SIGNIFICANCE * stderr && shift > MIN_SHIFT * size).then_some(offset)
}
