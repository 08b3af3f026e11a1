//! Hindsight: the earlier views of an object that was confirmed late.
//!
//! A track is confirmed after enough matches ([`Config::min_hits`], weighed by score), and a
//! tentative track is removed after a short gap ([`Config::max_tentative_misses`]). An object
//! that enters with low scores and is missed now and then (a detector's typical first views of
//! something small, partly visible or far away) therefore starts several tentative tracks
//! before one of them lasts long enough to be confirmed; with [`Config::report_tentative`]
//! only the last one's views are reported, and the others are lost recall. Letting tentative
//! tracks live longer or confirm sooner is not the fix: on noisy detections (ragged masks,
//! false boxes) that confirms false tracks too.
//!
//! So the confirmation decisions stay as they are, and hindsight only adds views: a removed
//! tentative track's views are kept for a while, and when a track is confirmed, the removed
//! tentative track whose motion leads to the new track's first view (and the new track's
//! motion, rolled back, to its last view) becomes the new track's beginning, reported under its
//! id like the new track's own tentative views. A removed tentative track that leads to a
//! later removed one is chained to it, so two early pieces of one object join the same way.
//! Nothing is reported that is not attached to a confirmed track, so no false track is born.
//!
//! [`Config::min_hits`]: super::Config::min_hits
//! [`Config::max_tentative_misses`]: super::Config::max_tentative_misses
//! [`Config::report_tentative`]: super::Config::report_tentative

use crate::frame::{BBox, TrackedShape};
use serde::{Deserialize, Serialize};

/// Hindsight settings ([`Config::hindsight`](super::Config::hindsight)). Every field has a
/// default, so `{}` is the default.
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Hindsight {
    /// The longest gap, in frames at [`Config::frame_counts_at`] fps (scaled to the video's
    /// frame rate), between a removed tentative track's last view and the first view of the
    /// track it is attached to. Default 8, the coasting span.
    ///
    /// [`Config::frame_counts_at`]: super::Config::frame_counts_at
    pub max_gap: u32,
    /// The least box IoU between either end and the other piece's motion carried over the
    /// gap (the mean of both directions). Default 0.2 (chosen on the robustness grid with the
    /// other defaults: `tests/data/quality/README.md`).
    pub min_iou: f64,
    /// Removed tentative tracks with fewer views are forgotten (one view has no motion).
    /// Default 2.
    pub min_views: u32,
}

impl Default for Hindsight {
    fn default() -> Self {
        Self {
            max_gap: 8,
            min_iou: 0.2,
            min_views: 2,
        }
    }
}

impl Hindsight {
    /// Checks the IoU lies in `[0, 1]`.
    pub fn validate(&self) -> Result<(), (&'static str, f64, &'static str)> {
        let v = self.min_iou;
        if v.is_finite() && (0.0..=1.0).contains(&v) {
            Ok(())
        } else {
            Err(("hindsight.min_iou", v, "must be in [0, 1]"))
        }
    }
}

/// How many of a piece's views at each end its motion is measured over.
const MOTION_VIEWS: usize = 5;

/// Removed tentative tracks' views, kept until too old to be attached.
#[derive(Debug, Clone, Default)]
pub(crate) struct Removed {
    /// Each piece's views in frame order.
    pieces: Vec<Vec<TrackedShape>>,
}

impl Removed {
    /// Keeps a removed tentative track's views (`shapes`, in frame order), chained behind the
    /// removed piece that leads to them if there is one.
    pub(crate) fn keep(&mut self, mut shapes: Vec<TrackedShape>, h: &Hindsight, max_gap: u32) {
        if shapes.len() < h.min_views.max(1) as usize {
            return;
        }
        if let Some(mut earlier) = self.take_leading_to(&shapes, h, max_gap) {
            earlier.append(&mut shapes);
            shapes = earlier;
        }
        self.pieces.push(shapes);
    }

    /// The views of the removed piece that leads to `later` (a track's views in frame order),
    /// removed from the store; `None` when none does.
    pub(crate) fn take_leading_to(
        &mut self,
        later: &[TrackedShape],
        h: &Hindsight,
        max_gap: u32,
    ) -> Option<Vec<TrackedShape>> {
        let first = later.first()?;
        let mut best: Option<(usize, f64)> = None;
        for (i, p) in self.pieces.iter().enumerate() {
            let Some(last) = p.last() else { continue };
            if last.frame >= first.frame
                || first.frame - last.frame > max_gap.saturating_add(1)
                || (last.class >= 0 && first.class >= 0 && last.class != first.class)
            {
                continue;
            }
            let forward = carried(tail(p), first.frame).iou(&first.bbox);
            let backward = carried(head(later), last.frame).iou(&last.bbox);
            let iou = 0.5 * (forward + backward);
            if iou >= h.min_iou && best.is_none_or(|(_, b)| iou > b) {
                best = Some((i, iou));
            }
        }
        best.map(|(i, _)| self.pieces.swap_remove(i))
    }

    /// Forgets pieces that ended before `frame`.
    pub(crate) fn forget_before(&mut self, frame: u32) {
        self.pieces
            .retain(|p| p.last().is_some_and(|s| s.frame >= frame));
    }

    /// Number of pieces kept.
    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.pieces.len()
    }
}

fn tail(p: &[TrackedShape]) -> &[TrackedShape] {
    &p[p.len().saturating_sub(MOTION_VIEWS)..]
}

fn head(p: &[TrackedShape]) -> &[TrackedShape] {
    &p[..p.len().min(MOTION_VIEWS)]
}

/// The box of the end of `views` nearest `frame`, moved there at the views' mean velocity
/// (centre and size; from the first to the last of them).
fn carried(views: &[TrackedShape], frame: u32) -> BBox {
    let (Some(a), Some(b)) = (views.first(), views.last()) else {
        return BBox::new(0.0, 0.0, 0.0, 0.0);
    };
    let end = if frame >= b.frame { b } else { a };
    let span = f64::from(b.frame) - f64::from(a.frame);
    if span <= 0.0 {
        return end.bbox;
    }
    let t = f64::from(frame) - f64::from(end.frame);
    let rate = |f: fn(&BBox) -> f64| (f(&b.bbox) - f(&a.bbox)) / span * t;
    let (cx, cy) = (
        end.bbox.x + 0.5 * end.bbox.w + rate(|r| r.x + 0.5 * r.w),
        end.bbox.y + 0.5 * end.bbox.h + rate(|r| r.y + 0.5 * r.h),
    );
    let w = (end.bbox.w + rate(|r| r.w)).max(0.5 * end.bbox.w);
    let h = (end.bbox.h + rate(|r| r.h)).max(0.5 * end.bbox.h);
    BBox::new(cx - 0.5 * w, cy - 0.5 * h, w, h)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{Point, TrackState};

    fn view(frame: u32, x: f64) -> TrackedShape {
        let bbox = BBox::new(x, 10.0, 20.0, 40.0);
        TrackedShape {
            id: 0,
            frame,
            bbox,
            mask: None,
            centroid: Point::new(x + 10.0, 30.0),
            state: TrackState::Tentative,
            score: 0.4,
            class: -1,
            cost: 0.0,
            det_index: Some(0),
            interpolated: false,
        }
    }

    fn run(frames: std::ops::Range<u32>, x0: f64, step: f64) -> Vec<TrackedShape> {
        frames.map(|f| view(f, x0 + step * f64::from(f))).collect()
    }

    #[test]
    fn a_piece_on_the_same_path_is_attached_and_one_elsewhere_is_not() {
        let h = Hindsight::default();
        let mut r = Removed::default();
        // An object moving 4 px a frame: views 1–5, missed 6–8, then a new track from 9.
        r.keep(run(1..6, 0.0, 4.0), &h, 8);
        // Another piece that ended at the same time far away.
        r.keep(run(1..6, 300.0, 4.0), &h, 8);
        let later = run(9..14, 0.0, 4.0);
        let got = r.take_leading_to(&later, &h, 8).expect("the same path");
        assert_eq!(got.first().map(|s| s.frame), Some(1));
        assert!((got[0].bbox.x - 4.0).abs() < 1e-9);
        assert_eq!(r.len(), 1);
        // The far piece leads nowhere near it.
        assert!(r.take_leading_to(&later, &h, 8).is_none());
    }

    #[test]
    fn gaps_too_long_and_single_views_are_not_attached() {
        let h = Hindsight::default();
        let mut r = Removed::default();
        r.keep(run(1..6, 0.0, 0.0), &h, 8);
        assert!(r.take_leading_to(&run(15..20, 0.0, 0.0), &h, 8).is_none());
        assert!(r.take_leading_to(&run(14..20, 0.0, 0.0), &h, 8).is_some());
        r.keep(run(1..2, 0.0, 0.0), &h, 8);
        assert_eq!(r.len(), 0);
    }

    #[test]
    fn pieces_chain_and_old_ones_are_forgotten() {
        let h = Hindsight::default();
        let mut r = Removed::default();
        r.keep(run(1..4, 0.0, 2.0), &h, 8);
        r.keep(run(6..9, 0.0, 2.0), &h, 8);
        assert_eq!(r.len(), 1);
        let got = r.take_leading_to(&run(11..15, 0.0, 2.0), &h, 8).unwrap();
        assert_eq!(
            got.iter().map(|s| s.frame).collect::<Vec<_>>(),
            [1, 2, 3, 6, 7, 8]
        );
        r.keep(run(1..4, 0.0, 2.0), &h, 8);
        r.forget_before(4);
        assert_eq!(r.len(), 0);
    }
}
