//! Gap filling: shapes for the frames an identity was not observed in, marked interpolated.
//!
//! After the joins, each identity's shapes are walked in frame order; a gap of `1..=max_gap`
//! missing frames between two observed shapes `a` (before) and `b` (after) is filled when it
//! lies between two joined tracks, or inside one track when `within_tracks` is set, unless it
//! is a hide: both ends partial mask views (below `hidden_ratio` of the usual area), the shape
//! going behind something and coming out again, where a visible-part mask would be wrong.
//!
//! - **Centroid**: along the configured [`Trajectory`]: the straight line from `a`'s centroid
//!   to `b`'s at constant speed, or the two-sided constant-acceleration Kalman bridge.
//! - **Box**: width, height and the box centre's offset from the centroid interpolate linearly
//!   from `a` to `b`, placed on the trajectory.
//! - **Mask**: carried along the trajectory, translated by whole pixels: `a`'s mask for the
//!   first half of the gap, `b`'s for the second (the closer observation of the shape); the
//!   box is then the translated mask's box, so box and mask agree.
//! - Score: the lower of the two ends'; state [`TrackState::Lost`]; no detection index;
//!   `interpolated = true`.
//!
//! Only frames strictly between two shapes of the same identity are filled, so a filled shape
//! can never share its (frame, id) with another one.

use super::config::{FillConfig, RelinkConfig, Trajectory};
use super::relink::{history_frames, rollout_backward, rollout_forward, track_end, Side};
use super::{OfflineError, Phase, Progress};
use crate::features::transform::{Affine, Transform};
use crate::follow::warp_mask;
use crate::frame::{BBox, Point, TrackState, TrackedShape};

/// Fills the gaps of `shapes` (final ids; `origin[i]` is shape `i`'s id before the joins;
/// `areas[i]` its mask area, given apart from the mask because a compact history carries the
/// bitmaps of run ends only). Returns the filled shapes (not yet merged into `shapes`).
#[allow(clippy::too_many_arguments)]
pub(crate) fn fill_gaps(
    shapes: &[TrackedShape],
    areas: &[Option<u64>],
    origin: &[u64],
    image_size: Option<(u32, u32)>,
    cfg: &FillConfig,
    relink: &RelinkConfig,
    fps: f64,
    progress: &mut dyn FnMut(Progress),
) -> Result<Vec<TrackedShape>, OfflineError> {
    let mut out = Vec::new();
    let max_gap = cfg.max_gap_frames(fps);
    if max_gap == 0 {
        return Ok(out);
    }
    let mut by_id: std::collections::BTreeMap<u64, Vec<usize>> = Default::default();
    for (i, s) in shapes.iter().enumerate() {
        by_id.entry(s.id).or_default().push(i);
    }
    let history = history_frames(relink, fps);
    let budget = fill_budget(shapes, areas);
    let (mut made, mut mask_pixels) = (0u64, 0u64);
    let n = by_id.len().max(1);
    for (done, idx) in by_id.values_mut().enumerate() {
        if done % 64 == 0 {
            progress(Progress {
                phase: Phase::Filling,
                fraction: done as f64 / n as f64,
            });
        }
        idx.sort_by_key(|&i| shapes[i].frame);
        for k in 1..idx.len() {
            let (ia, ib) = (idx[k - 1], idx[k]);
            let (a, b) = (&shapes[ia], &shapes[ib]);
            let missing = b.frame.saturating_sub(a.frame).saturating_sub(1);
            if missing == 0 || missing > max_gap {
                continue;
            }
            let joined = origin.get(ia) != origin.get(ib);
            if !joined && !cfg.within_tracks {
                continue;
            }
            if cfg.hidden_ratio > 0.0 && is_hide(areas, &idx[..k], &idx[k..], cfg.hidden_ratio) {
                continue;
            }
            // Checked before the path is made: `missing` is the input's claim, not yet work.
            made += u64::from(missing);
            if made > budget.shapes {
                return Err(OfflineError::FillBudget {
                    what: "shapes",
                    cap: budget.shapes,
                });
            }
            let path = match cfg.trajectory {
                Trajectory::Linear => linear_path(a.centroid, b.centroid, missing),
                Trajectory::Kalman => {
                    let before = &idx[..k];
                    let after = &idx[k..];
                    kalman_path(shapes, before, after, missing, history, relink, fps)?
                }
            };
            for (j, c) in path.iter().enumerate() {
                let step = j as u32 + 1;
                let alpha = f64::from(step) / f64::from(missing + 1);
                let scale_in = image_size.filter(|_| cfg.scale_masks);
                let s = filled_shape(a, b, a.frame + step, *c, alpha, scale_in);
                mask_pixels += s.mask.as_ref().map_or(0, |m| m.data().len() as u64);
                if mask_pixels > budget.mask_pixels {
                    return Err(OfflineError::FillBudget {
                        what: "mask pixels",
                        cap: budget.mask_pixels,
                    });
                }
                out.push(s);
            }
        }
    }
    progress(Progress {
        phase: Phase::Filling,
        fraction: 1.0,
    });
    Ok(out)
}

/// How much the fill may make for one input (see [`fill_budget`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FillBudget {
    /// Most filled shapes.
    pub shapes: u64,
    /// Most mask pixels (bitmap bytes) of the filled shapes together.
    pub mask_pixels: u64,
}

/// Filled shapes allowed per input shape above the fixed allowance. A gap is filled from the
/// observed shape before it, so with the default `max_gap` of 10 the fill makes at most 10
/// shapes per input shape and never reaches this budget; only a wider setting over a sparse
/// input can.
pub const FILL_PER_SHAPE: u64 = 16;

/// The fill's budget for `shapes` (with mask areas `areas`): [`MAX_RECORDS`] filled shapes
/// plus [`FILL_PER_SHAPE`] per input shape, and [`MAX_TOTAL_PIXELS`] mask pixels plus
/// [`FILL_PER_SHAPE`] times the input's own. The output is thus bounded by what the input
/// holds, not by what the gaps between its frame numbers claim (issue 65).
///
/// [`MAX_RECORDS`]: crate::io::limits::MAX_RECORDS
/// [`MAX_TOTAL_PIXELS`]: crate::io::limits::MAX_TOTAL_PIXELS
pub fn fill_budget(shapes: &[TrackedShape], areas: &[Option<u64>]) -> FillBudget {
    use crate::io::limits::{MAX_RECORDS, MAX_TOTAL_PIXELS};
    let input_pixels: u64 = shapes
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let bitmap = s.mask.as_ref().map_or(0, |m| m.data().len() as u64);
            bitmap.max(areas.get(i).copied().flatten().unwrap_or(0))
        })
        .fold(0u64, u64::saturating_add);
    FillBudget {
        shapes: MAX_RECORDS.saturating_add(FILL_PER_SHAPE.saturating_mul(shapes.len() as u64)),
        mask_pixels: MAX_TOTAL_PIXELS.saturating_add(FILL_PER_SHAPE.saturating_mul(input_pixels)),
    }
}

/// Shapes on each side of a gap whose median mask area is the reference for that end.
const HIDE_REFERENCE: usize = 10;

/// Whether the gap between the last shape of `before` and the first of `after` (indices into
/// `areas`, the shapes' mask areas, in frame order) is a hide: both ends are masks smaller
/// than `ratio` times the median mask area of up to [`HIDE_REFERENCE`] shapes on their side.
fn is_hide(areas: &[Option<u64>], before: &[usize], after: &[usize], ratio: f64) -> bool {
    let area = |i: usize| areas.get(i).copied().flatten();
    let partial = |side: &mut dyn Iterator<Item = &usize>, end: Option<&usize>| -> bool {
        let Some(end_area) = end.and_then(|&i| area(i)) else {
            return false;
        };
        let mut side_areas: Vec<u64> = side.take(HIDE_REFERENCE).filter_map(|&i| area(i)).collect();
        if side_areas.is_empty() {
            return false;
        }
        side_areas.sort_unstable();
        let median = side_areas[side_areas.len() / 2] as f64;
        (end_area as f64) < ratio * median
    };
    partial(&mut before.iter().rev(), before.last()) && partial(&mut after.iter(), after.first())
}

/// Centroids of the `missing` frames between `ca` and `cb` on the straight line.
fn linear_path(ca: Point, cb: Point, missing: u32) -> Vec<Point> {
    let n = f64::from(missing + 1);
    (1..=missing)
        .map(|k| ca + (cb - ca) * (f64::from(k) / n))
        .collect()
}

/// The two-sided Kalman bridge: the forward rollout from the end of `before` and the backward
/// rollout from the start of `after` (each from its anchor, see
/// [`track_end`](super::relink::track_end)), each shifted to pass through its observed end
/// centroid, blended linearly in time.
fn kalman_path(
    shapes: &[TrackedShape],
    before: &[usize],
    after: &[usize],
    missing: u32,
    history: u32,
    relink: &RelinkConfig,
    fps: f64,
) -> Result<Vec<Point>, OfflineError> {
    let (Some(&ia), Some(&ib)) = (before.last(), after.first()) else {
        return Ok(Vec::new());
    };
    let (a, b) = (&shapes[ia], &shapes[ib]);
    let r = relink.reliable_size;
    let (Some(ea), Some(sb)) = (
        track_end(shapes, before, Side::End, history, r, fps),
        track_end(shapes, after, Side::Start, history, r, fps),
    ) else {
        return Ok(linear_path(a.centroid, b.centroid, missing));
    };
    // Positions for frames ea.frame+1 ..= b.frame and sb.frame-1 down to a.frame.
    let fwd = rollout_forward(&ea, b.frame - ea.frame, fps, relink.acceleration)?;
    let bwd = rollout_backward(&sb, sb.frame - a.frame, fps, relink.acceleration)?;
    let at_fwd = |f: u32| -> Option<Point> {
        if f == ea.frame {
            Some(ea.position)
        } else {
            fwd.get((f - ea.frame - 1) as usize).copied()
        }
    };
    let at_bwd = |f: u32| -> Option<Point> {
        if f == sb.frame {
            Some(sb.position)
        } else {
            bwd.get((sb.frame - f - 1) as usize).copied()
        }
    };
    let (Some(fa), Some(bb)) = (at_fwd(a.frame), at_bwd(b.frame)) else {
        return Ok(linear_path(a.centroid, b.centroid, missing));
    };
    let (oa, ob) = (a.centroid - fa, b.centroid - bb);
    let n = f64::from(missing + 1);
    let mut path = Vec::with_capacity(missing as usize);
    for k in 1..=missing {
        let alpha = f64::from(k) / n;
        let f = a.frame + k;
        let (Some(pf), Some(pb)) = (at_fwd(f), at_bwd(f)) else {
            return Ok(linear_path(a.centroid, b.centroid, missing));
        };
        path.push((pf + oa) * (1.0 - alpha) + (pb + ob) * alpha);
    }
    Ok(path)
}

/// The nearer end's mask scaled about its centroid to the box size a fraction `alpha` of the
/// way from `a`'s mask box to `b`'s, with its centroid at `c`, in a `w × h` frame; `None`
/// unless both ends have masks and the result has pixels.
fn scaled_mask(
    a: &TrackedShape,
    b: &TrackedShape,
    c: Point,
    alpha: f64,
    w: u32,
    h: u32,
) -> Option<crate::frame::Mask> {
    let (ma, mb) = (a.mask.as_ref()?, b.mask.as_ref()?);
    let (ba, bb) = (ma.bbox(), mb.bbox());
    let (src, m, box_src) = if alpha <= 0.5 {
        (a, ma, ba)
    } else {
        (b, mb, bb)
    };
    if box_src.w <= 0.0 || box_src.h <= 0.0 {
        return None;
    }
    let sx = lerp(ba.w, bb.w, alpha) / box_src.w;
    let sy = lerp(ba.h, bb.h, alpha) / box_src.h;
    let t = Transform::Affine(Affine {
        a: sx,
        b: 0.0,
        c: 0.0,
        d: sy,
        tx: c.x - sx * src.centroid.x,
        ty: c.y - sy * src.centroid.y,
    });
    let out = warp_mask(m, &t, w, h);
    (out.area() > 0).then_some(out)
}

fn lerp(p: f64, q: f64, a: f64) -> f64 {
    p + (q - p) * a
}

/// The shape filled in at `frame`, centroid `c`, a fraction `alpha` of the way from `a` to `b`;
/// with `scale_in` (the image size), a mask is scaled to the size between the ends
/// ([`scaled_mask`]) where it can be, else translated.
fn filled_shape(
    a: &TrackedShape,
    b: &TrackedShape,
    frame: u32,
    c: Point,
    alpha: f64,
    scale_in: Option<(u32, u32)>,
) -> TrackedShape {
    let scaled = scale_in.and_then(|(w, h)| scaled_mask(a, b, c, alpha, w, h));
    let src = match (&a.mask, &b.mask) {
        (Some(_), Some(_)) => Some(if alpha <= 0.5 { a } else { b }),
        (Some(_), None) => Some(a),
        (None, Some(_)) => Some(b),
        (None, None) => None,
    };
    let translate = src.and_then(|s| s.mask.as_ref().map(|m| (s, m)));
    let (bbox, mask, centroid) = match (scaled, translate) {
        (Some(m), _) => (m.bbox(), Some(m), c),
        (None, Some((s, m))) => {
            let d = c - s.centroid;
            let (dx, dy) = (d.x.round(), d.y.round());
            (
                s.bbox.translated(dx, dy),
                Some(m.translated(dx as i32, dy as i32)),
                s.centroid + Point::new(dx, dy),
            )
        }
        (None, None) => {
            let oa = a.bbox.center() - a.centroid;
            let ob = b.bbox.center() - b.centroid;
            let o = oa + (ob - oa) * alpha;
            let w = lerp(a.bbox.w, b.bbox.w, alpha);
            let h = lerp(a.bbox.h, b.bbox.h, alpha);
            (BBox::from_center(c + o, w, h), None, c)
        }
    };
    TrackedShape {
        id: a.id,
        frame,
        bbox,
        mask,
        centroid,
        state: TrackState::Lost,
        score: a.score.min(b.score),
        class: a.class,
        cost: 0.0,
        det_index: None,
        interpolated: true,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::Mask;

    /// The mask area of each shape (`None` for a box), as [`fill_gaps`] reads it.
    fn mask_areas(shapes: &[TrackedShape]) -> Vec<Option<u64>> {
        super::super::OfflineInput::from_shapes(shapes.to_vec())
            .mask_areas()
            .to_vec()
    }

    fn shape(id: u64, frame: u32, b: BBox) -> TrackedShape {
        TrackedShape {
            id,
            frame,
            bbox: b,
            mask: None,
            centroid: b.center(),
            state: TrackState::Confirmed,
            score: 0.9,
            class: 1,
            cost: 0.0,
            det_index: Some(0),
            interpolated: false,
        }
    }

    /// A track of 20×20 masks moving right, with `width(frame)` choosing each mask's width (a
    /// shape going behind something shrinks) and frames `gap` missing.
    fn masked_track(
        gap: std::ops::RangeInclusive<u32>,
        width: impl Fn(u32) -> f64,
    ) -> Vec<TrackedShape> {
        (1..=30)
            .filter(|f| !gap.contains(f))
            .map(|f| {
                let b = BBox::new(2.0 * f64::from(f), 0.0, width(f), 20.0);
                let mut s = shape(1, f, b);
                s.mask = Some(Mask::from_bbox(&b));
                s
            })
            .collect()
    }

    #[test]
    fn gaps_between_partial_mask_views_are_hides_and_stay_empty() {
        let fill = |shapes: &[TrackedShape], cfg: &FillConfig| {
            let origin = vec![1; shapes.len()];
            fill_gaps(
                shapes,
                &mask_areas(shapes),
                &origin,
                None,
                cfg,
                &RelinkConfig::default(),
                25.0,
                &mut |_| {},
            )
            .unwrap()
            .len()
        };
        // The rule is off by default (measured on the grid); with it on:
        let cfg = FillConfig {
            hidden_ratio: 0.5,
            ..FillConfig::default()
        };
        // Going behind an occluder (shrinking to a quarter) and coming out (growing back).
        let hide = masked_track(12..=16, |f| match f {
            11 | 17 => 5.0,
            10 | 18 => 10.0,
            _ => 20.0,
        });
        assert_eq!(fill(&hide, &cfg), 0);
        // Without the rule (the default), the hide is filled like any gap.
        assert_eq!(fill(&hide, &FillConfig::default()), 5);
        // A missed detection between whole views, or with only one end partial, is filled.
        assert_eq!(fill(&masked_track(12..=16, |_| 20.0), &cfg), 5);
        let one_side = masked_track(12..=16, |f| if f == 11 { 5.0 } else { 20.0 });
        assert_eq!(fill(&one_side, &cfg), 5);
        // Boxes carry no area to judge by: always filled.
        let boxes: Vec<TrackedShape> = hide
            .iter()
            .map(|s| TrackedShape {
                mask: None,
                ..s.clone()
            })
            .collect();
        assert_eq!(fill(&boxes, &cfg), 5);
        // Out-of-range ratios are config errors.
        let bad = super::super::OfflineConfig {
            fill: FillConfig {
                hidden_ratio: 1.5,
                ..FillConfig::default()
            },
            ..Default::default()
        };
        assert!(bad.validate().is_err());
    }

    #[test]
    fn linear_fill_interpolates_boxes() {
        let a = shape(1, 10, BBox::new(0.0, 0.0, 10.0, 20.0));
        let mut b = shape(1, 14, BBox::new(40.0, 8.0, 14.0, 24.0));
        b.score = 0.5;
        let shapes = vec![a, b];
        let out = fill_gaps(
            &shapes,
            &mask_areas(&shapes),
            &[1, 1],
            None,
            &FillConfig::default(),
            &RelinkConfig::default(),
            25.0,
            &mut |_| {},
        )
        .unwrap();
        assert_eq!(out.len(), 3);
        for (k, s) in out.iter().enumerate() {
            let a = (k + 1) as f64 / 4.0;
            assert_eq!(s.frame, 11 + k as u32);
            assert!(s.interpolated && s.det_index.is_none());
            assert_eq!(s.score, 0.5);
            let want = BBox::new(40.0 * a, 8.0 * a, 10.0 + 4.0 * a, 20.0 + 4.0 * a);
            for (g, w) in [
                (s.bbox.x, want.x),
                (s.bbox.y, want.y),
                (s.bbox.w, want.w),
                (s.bbox.h, want.h),
            ] {
                assert!((g - w).abs() < 1e-9, "{:?} vs {want:?}", s.bbox);
            }
        }
        // Within-track filling off: nothing; joined gaps are still filled.
        let cfg = FillConfig {
            within_tracks: false,
            ..FillConfig::default()
        };
        let none = fill_gaps(
            &shapes,
            &mask_areas(&shapes),
            &[1, 1],
            None,
            &cfg,
            &RelinkConfig::default(),
            25.0,
            &mut |_| {},
        );
        assert!(none.unwrap().is_empty());
        let joined = fill_gaps(
            &shapes,
            &mask_areas(&shapes),
            &[1, 2],
            None,
            &cfg,
            &RelinkConfig::default(),
            25.0,
            &mut |_| {},
        );
        assert_eq!(joined.unwrap().len(), 3);
        // Too long a gap is left alone.
        let cfg = FillConfig {
            max_gap: 2,
            ..FillConfig::default()
        };
        let none = fill_gaps(
            &shapes,
            &mask_areas(&shapes),
            &[1, 1],
            None,
            &cfg,
            &RelinkConfig::default(),
            25.0,
            &mut |_| {},
        );
        assert!(none.unwrap().is_empty());
    }

    #[test]
    fn masks_are_translated_along_the_path() {
        let m = Mask::from_bbox(&BBox::new(0.0, 0.0, 4.0, 4.0));
        let mut a = shape(3, 1, m.bbox());
        a.mask = Some(m.clone());
        a.centroid = m.centroid().unwrap();
        let mb = m.translated(30, 0);
        let mut b = shape(3, 4, mb.bbox());
        b.mask = Some(mb.clone());
        b.centroid = mb.centroid().unwrap();
        let shapes = [a, b];
        let out = fill_gaps(
            &shapes,
            &mask_areas(&shapes),
            &[3, 3],
            None,
            &FillConfig::default(),
            &RelinkConfig::default(),
            10.0,
            &mut |_| {},
        )
        .unwrap();
        assert_eq!(out.len(), 2);
        let xs: Vec<i32> = out.iter().map(|s| s.mask.as_ref().unwrap().x()).collect();
        assert_eq!(xs, vec![10, 20]);
        for s in &out {
            let mk = s.mask.as_ref().unwrap();
            assert_eq!(mk.area(), 16);
            assert_eq!(s.bbox, mk.bbox());
            assert_eq!(Some(s.centroid), mk.centroid());
        }
    }

    #[test]
    fn masks_are_scaled_to_the_size_between_the_ends() {
        // A shape that grows from 10×10 to 30×30 while moving right, missed for 3 frames.
        let ma = Mask::from_bbox(&BBox::new(0.0, 20.0, 10.0, 10.0));
        let mb = Mask::from_bbox(&BBox::new(40.0, 10.0, 30.0, 30.0));
        let mut a = shape(3, 1, ma.bbox());
        a.mask = Some(ma.clone());
        a.centroid = ma.centroid().unwrap();
        let mut b = shape(3, 5, mb.bbox());
        b.mask = Some(mb.clone());
        b.centroid = mb.centroid().unwrap();
        let shapes = [a, b];
        let run = |size: Option<(u32, u32)>, scale: bool| {
            let cfg = FillConfig {
                scale_masks: scale,
                ..FillConfig::default()
            };
            fill_gaps(
                &shapes,
                &mask_areas(&shapes),
                &[3, 3],
                size,
                &cfg,
                &RelinkConfig::default(),
                10.0,
                &mut |_| {},
            )
            .unwrap()
        };
        let widths = |out: &[TrackedShape]| -> Vec<f64> {
            out.iter()
                .map(|s| s.mask.as_ref().unwrap().bbox().w)
                .collect()
        };
        let scaled = run(Some((100, 60)), true);
        assert_eq!(widths(&scaled), [15.0, 20.0, 25.0]);
        for s in &scaled {
            let mk = s.mask.as_ref().unwrap();
            assert_eq!(s.bbox, mk.bbox());
            // Square to a pixel (nearest-pixel sampling).
            assert!((mk.bbox().w - mk.bbox().h).abs() <= 1.0, "{:?}", mk.bbox());
            let c = mk.centroid().unwrap();
            assert!((c.x - s.centroid.x).abs() <= 1.0 && (c.y - s.centroid.y).abs() <= 1.0);
        }
        // Translated only: the nearer end's size; and without an image size, whatever asked.
        assert_eq!(widths(&run(Some((100, 60)), false)), [10.0, 10.0, 30.0]);
        assert_eq!(widths(&run(None, true)), [10.0, 10.0, 30.0]);
    }
}
