//! Amodal completion (see [`Config::amodal`](super::Config::amodal)): the box of the whole
//! shape behind a partial view, so that an occluder's edge does not drag a track's motion
//! filter.
//!
//! A shape sliding behind a bar shows a shrinking part of itself; the part's box moves with the
//! bar's edge on one side and with the shape on the other. Completing it to the shape's
//! reference size, anchored on the side that still moves with the shape, keeps the filter on
//! the shape's own path.

use crate::frame::{BBox, Point};

/// A side counts as cut when the view is shorter than the reference size by more than this
/// fraction of it (or [`CUT_TOLERANCE_PX`], whichever is larger): erosion or dilation by the
/// detector changes a side by a pixel or two without any occlusion.
const CUT_TOLERANCE: f64 = 0.1;
/// Smallest cut tolerance, in pixels (see [`CUT_TOLERANCE`]).
const CUT_TOLERANCE_PX: f64 = 3.0;
/// Below this speed (pixels per frame) an axis has no direction of motion to tell a leading
/// side from a trailing one.
const MOVING_SPEED: f64 = 0.5;
/// A side moving by at most this many pixels per frame stands still: it is held by a static
/// occluder (a bar, the frame border).
const STILL_SIDE_PX: f64 = 1.0;
/// How much more (in units of the axis speed, at least [`MIN_SIDE_STEP_PX`]) one side must
/// move than the other before it counts as the one following the shape: half a frame's motion
/// separates a moving side from detector noise on the synthetic scenes.
const SIDE_STEP: f64 = 0.5;
/// Smallest side-step margin, in pixels (see [`SIDE_STEP`]).
const MIN_SIDE_STEP_PX: f64 = 1.0;
/// Frames without a match after which a shape's next view counts as a reappearance: the last
/// detection is too old to tell which side stands still, and the occlusion that cut the last
/// views is over.
pub(crate) const REAPPEAR_GAP: u32 = 3;

/// Which side of a partly hidden shape an occluder covers, on one axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Cut {
    /// The low side (left or top): the high side is seen and anchors the completion.
    Low,
    /// The high side (right or bottom).
    High,
    /// Both sides (or undecided): complete around the detection's centre.
    Both,
}

/// The whole shape's box for a partly hidden detection `d` (amodal completion): on each axis
/// where `d` is clearly shorter than the reference size `(rw, rh)` of the whole shape, `d` is
/// extended to it away from the occluded side.
///
/// The occluded side is decided once per occlusion, when the axis first needs completion, and
/// kept in `cuts` until the shape is seen whole again (deciding anew every frame would compare
/// with a prediction the occlusion has already dragged):
/// - a shape reappearing after a gap (`last` is `None`) shows its leading part first: the side
///   behind it along its velocity `v` is hidden;
/// - otherwise, comparing with the last detection `last` (seen `n` frames ago), per frame: the
///   side that stood still while the other moved (held by a static occluder: a bar, the frame
///   border); else
///   the side that strayed from moving with the shape's velocity (a moving occluder); else the
///   side that disagrees with the prediction `p`;
/// - else both sides: the view is a part of the shape that could lie anywhere in it, and the
///   completed box keeps the prediction's centre on that axis.
///
/// The reference size, not the prediction, is the target, so the completed box cannot shrink
/// with the view.
pub(crate) fn amodal_box(
    p: &BBox,
    d: &BBox,
    last: Option<(&BBox, u32)>,
    v: Point,
    (rw, rh): (f64, f64),
    whole: bool,
    cuts: &mut [Option<Cut>; 2],
) -> BBox {
    #[allow(clippy::too_many_arguments)]
    fn axis(
        (p0, pw): (f64, f64),
        (d0, dw): (f64, f64),
        last: Option<(f64, f64, f64)>,
        v: f64,
        rw: f64,
        whole: bool,
        cut: &mut Option<Cut>,
    ) -> (f64, f64) {
        let tol = (CUT_TOLERANCE * rw).max(CUT_TOLERANCE_PX);
        if !(rw.is_finite() && p0.is_finite() && pw.is_finite() && dw < rw - tol) {
            // Not cut on this axis now: a later cut is a new occlusion, decided afresh.
            *cut = None;
            return (d0, dw);
        }
        let side = *cut.get_or_insert_with(|| {
            // The side that disagrees with the prediction (displacements inwards).
            let (e0, e1) = (d0 - p0, (p0 + pw) - (d0 + dw));
            let by_prediction = if e1.abs() + tol <= e0 {
                Some(Cut::Low)
            } else if e0.abs() + tol <= e1 {
                Some(Cut::High)
            } else {
                None
            };
            // Motion along this axis that tells leading from trailing.
            let moving = v.abs() >= MOVING_SPEED;
            let Some((l0, lw, k)) = last else {
                // After a gap the prediction is the only reference; a shape reappearing right
                // where predicted shows its leading part first.
                return by_prediction.unwrap_or(match (moving, v > 0.0) {
                    (false, _) => Cut::Both,
                    (true, true) => Cut::Low,
                    (true, false) => Cut::High,
                });
            };
            // Side motion per frame since the last detection: an occluder that does not move
            // (a bar, the frame border) holds its side still while the other follows the
            // shape; the prediction may already lag behind.
            let (s0, s1) = ((d0 - l0) / k, (d0 + dw - (l0 + lw)) / k);
            let step = (SIDE_STEP * v.abs()).max(MIN_SIDE_STEP_PX);
            if moving && s0.abs() + step <= s1.abs() && s0.abs() <= STILL_SIDE_PX {
                return Cut::Low;
            }
            if moving && s1.abs() + step <= s0.abs() && s1.abs() <= STILL_SIDE_PX {
                return Cut::High;
            }
            // A moving occluder: the side that strayed from moving with the shape.
            let (m0, m1) = ((s0 - v).abs(), (s1 - v).abs());
            if m1 + step <= m0 {
                return Cut::Low;
            }
            if m0 + step <= m1 {
                return Cut::High;
            }
            by_prediction.unwrap_or(Cut::Both)
        });
        match side {
            Cut::Low => (d0 + dw - rw, rw),
            Cut::High => (d0, rw),
            // No side to anchor on. A whole view (by area) is narrower because the shape
            // turned: its centre holds. A partial view is a cut-down part of the shape that
            // could lie anywhere in it and says nothing about the centre on this axis: keep
            // the prediction's.
            Cut::Both if whole => (d0 + dw / 2.0 - rw / 2.0, rw),
            Cut::Both => (p0 + pw / 2.0 - rw / 2.0, rw),
        }
    }
    let [cx, cy] = cuts;
    let k = |n: u32| n.max(1) as f64;
    let (x, w) = axis(
        (p.x, p.w),
        (d.x, d.w),
        last.map(|(l, n)| (l.x, l.w, k(n))),
        v.x,
        rw,
        whole,
        cx,
    );
    let (y, h) = axis(
        (p.y, p.h),
        (d.y, d.h),
        last.map(|(l, n)| (l.y, l.h, k(n))),
        v.y,
        rh,
        whole,
        cy,
    );
    BBox::new(x, y, w, h)
}
