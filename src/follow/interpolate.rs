//! Shape-aware interpolation between two keyframe masks (issue 12, item 2).
//!
//! A box lerp moves and stretches a rectangle; a person who marked a bending arm at two
//! keyframes wants the outline in between. So: both outlines are resampled to the same number
//! of points, described by shape context (thesis Alg. 4), matched by optimal assignment on χ²
//! plus a small centred-position term, and the matches vote for one cyclic offset between the
//! two point orders — an order-preserving correspondence, so the morphed polygon never folds
//! over itself the way a free one-to-one assignment can. Matched points are moved linearly and
//! the polygon is rasterised.

use thiserror::Error;

use crate::assign::{self, AssignError, CostMatrix, Unmatched};
use crate::features::shape_context::{
    chi2_matrix, resample_contour, ShapeContextConfig, ShapeContextError, ShapeDescriptor,
};
use crate::frame::{Mask, Point};
use crate::geometry::MaskCrop;

use super::warp::rasterize_polygon;

/// Points each outline is resampled to: the shape context default, enough for DAVIS-sized
/// outlines at a few ms per pair.
const OUTLINE_POINTS: usize = 64;

/// Weight of the centred-position distance (in units of the shapes' mean radius) beside χ²
/// (which lies in [0, 1]): small, it only breaks ties between look-alike outline parts.
const POSITION_WEIGHT: f64 = 0.3;

/// Errors of [`interpolate_masks`].
#[derive(Debug, Error, Clone, PartialEq)]
pub enum InterpolateError {
    /// A keyframe mask has no foreground.
    #[error("keyframe mask {which} is empty")]
    EmptyMask {
        /// "a" or "b".
        which: &'static str,
    },
    /// `t` is not in [0, 1].
    #[error("interpolation position {t} is not in [0, 1]")]
    Position {
        /// The value given.
        t: f64,
    },
    /// The outline could not be described (degenerate shape).
    #[error(transparent)]
    Shape(#[from] ShapeContextError),
    /// The assignment failed.
    #[error(transparent)]
    Assign(#[from] AssignError),
}

/// The outer outline of a mask's largest part, in image coordinates.
fn outline(m: &Mask, which: &'static str) -> Result<Vec<Point>, InterpolateError> {
    let crop = MaskCrop::new(m, 1).map_err(|_| InterpolateError::EmptyMask { which })?;
    crop.outer_contours()
        .into_iter()
        .next()
        .filter(|c| !c.is_empty())
        .ok_or(InterpolateError::EmptyMask { which })
}

fn centre(p: &[Point]) -> Point {
    let n = p.len().max(1) as f64;
    p.iter().fold(Point::default(), |a, &b| a + b) * (1.0 / n)
}

/// Corresponding points of two outlines (`a[i]` ↔ `b[i]`, both resampled to the same count
/// and winding): shape-context assignment votes for the cyclic offset of B's order.
pub fn outline_correspondence(
    a: &[Point],
    b: &[Point],
) -> Result<(Vec<Point>, Vec<Point>), InterpolateError> {
    let n = OUTLINE_POINTS;
    let ra = resample_contour(a, n)?;
    let rb = resample_contour(b, n)?;
    let cfg = ShapeContextConfig::default();
    let cost = match (
        ShapeDescriptor::from_vertices(&ra, &cfg),
        ShapeDescriptor::from_vertices(&rb, &cfg),
    ) {
        (Ok(da), Ok(db)) => chi2_matrix(&da, &db)?,
        // Too small to describe (a few pixels): position alone decides.
        _ => vec![0.0; n * n],
    };
    let (ca, cb) = (centre(&ra), centre(&rb));
    let radius = (ra.iter().map(|p| p.dist(ca)).sum::<f64>()
        + rb.iter().map(|p| p.dist(cb)).sum::<f64>())
        / (2 * n) as f64;
    let radius = radius.max(1e-9);
    let pair = |i: usize, j: usize| {
        cost[i * n + j] + POSITION_WEIGHT * (ra[i] - ca).dist(rb[j] - cb) / radius
    };
    let m = CostMatrix::from_fn(n, n, |i, j| Some(pair(i, j)))?;
    let asg = assign::solve(&m, Unmatched::MaxMatches)?;
    // Circular mean of the offsets the matches vote for.
    let (mut sx, mut sy) = (0.0, 0.0);
    for mt in &asg.matches {
        let off = (mt.col + n - mt.row) % n;
        let ang = off as f64 / n as f64 * std::f64::consts::TAU;
        sx += ang.cos();
        sy += ang.sin();
    }
    let mean = sy.atan2(sx).rem_euclid(std::f64::consts::TAU) / std::f64::consts::TAU * n as f64;
    let guess = mean.round() as usize % n;
    // The vote is noisy where shapes differ: settle on the best offset near it.
    let total = |s: usize| (0..n).map(|i| pair(i, (i + s) % n)).sum::<f64>();
    let span = n / 8;
    let best = (0..=2 * span)
        .map(|k| (guess + n + k - span) % n)
        .min_by(|&x, &y| total(x).total_cmp(&total(y)))
        .unwrap_or(guess);
    let bs: Vec<Point> = (0..n).map(|i| rb[(i + best) % n]).collect();
    Ok((ra, bs))
}

/// The mask at position `t ∈ [0, 1]` between keyframe masks `a` (t = 0) and `b` (t = 1), in a
/// `width × height` frame: matched outlines moved linearly and rasterised.
pub fn interpolate_masks(
    a: &Mask,
    b: &Mask,
    t: f64,
    width: u32,
    height: u32,
) -> Result<Mask, InterpolateError> {
    if !(0.0..=1.0).contains(&t) {
        return Err(InterpolateError::Position { t });
    }
    if a.is_empty() || a.area() == 0 {
        return Err(InterpolateError::EmptyMask { which: "a" });
    }
    if b.is_empty() || b.area() == 0 {
        return Err(InterpolateError::EmptyMask { which: "b" });
    }
    if t == 0.0 {
        return Ok(a.clipped(width, height).tight());
    }
    if t == 1.0 {
        return Ok(b.clipped(width, height).tight());
    }
    let (oa, ob) = outline_correspondence(&outline(a, "a")?, &outline(b, "b")?)?;
    let poly: Vec<Point> = oa
        .iter()
        .zip(&ob)
        .map(|(&p, &q)| p * (1.0 - t) + q * t)
        .collect();
    Ok(rasterize_polygon(&poly, width, height))
}
