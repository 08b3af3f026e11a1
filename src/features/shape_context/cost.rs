//! The shape cost C1: a transform B → A fitted to matched pairs (χ² vertex matches or
//! keypoint matches), refined, with fallbacks, and the nearest-vertex distances under it.

use super::{check_finite, match_vertices, median_pairwise_distance};
use super::{ShapeContextConfig, ShapeContextError, ShapeDescriptor};
use crate::features::transform::{
    ransac, PointIndex, RansacConfig, Similarity, Transform, TransformError, TransformKind,
};
use crate::frame::Point;
use serde::{Deserialize, Serialize};

/// The result of comparing two shapes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShapeMatch {
    /// C1: the symmetric sum of nearest-vertex distances after aligning B onto A,
    /// `½·(Σ_b d(T(b), A) + Σ_a d(a, T(B)))`, divided by [`scale`](Self::scale). ≥ 0, finite.
    pub cost: f64,
    /// The same distances averaged per vertex (`cost / ((|A| + |B|) / 2)`), in units of
    /// [`scale`](Self::scale).
    pub mean_distance: f64,
    /// The map from B's frame into A's.
    pub transform: Transform,
    /// Matches consistent with `transform` (0 when the fallback alignment was used).
    pub inliers: usize,
    /// Matched pairs the fit was drawn from (χ² vertex pairs or keypoint pairs).
    pub matched: usize,
    /// Whether `transform` was fitted from matches (false: centroid-and-scale fallback).
    pub fitted: bool,
    /// A's median pairwise vertex distance in pixels: the unit of `cost`.
    pub scale: f64,
    /// Mean χ² cost of the matched vertex pairs (`None` for keypoint matches).
    pub descriptor_cost: Option<f64>,
}

/// Compares two described shapes (Alg. 4): χ² matching, robust transform fit, C1.
pub fn match_shapes(
    a: &ShapeDescriptor,
    b: &ShapeDescriptor,
    cfg: &ShapeContextConfig,
) -> Result<ShapeMatch, ShapeContextError> {
    cfg.validate()?;
    let pairs = match_vertices(a, b, cfg.matching)?;
    let descriptor_cost = if pairs.is_empty() {
        None
    } else {
        Some(pairs.iter().map(|p| p.2).sum::<f64>() / pairs.len() as f64)
    };
    // Source = B, target = A: the fitted map takes B into A's frame.
    let matches: Vec<(Point, Point)> = pairs
        .iter()
        .filter_map(|&(i, j, _)| Some((*b.vertices.get(j)?, *a.vertices.get(i)?)))
        .collect();
    let mut m = align_and_score(
        &a.vertices,
        a.median_distance,
        &b.vertices,
        b.median_distance,
        &matches,
        cfg,
    )?;
    m.descriptor_cost = descriptor_cost;
    Ok(m)
}

/// Convenience: describes both contours with `cfg` and compares them ([`match_shapes`]).
pub fn shape_cost(
    a_contour: &[Point],
    b_contour: &[Point],
    cfg: &ShapeContextConfig,
) -> Result<ShapeMatch, ShapeContextError> {
    let a = ShapeDescriptor::from_contour(a_contour, cfg)?;
    let b = ShapeDescriptor::from_contour(b_contour, cfg)?;
    match_shapes(&a, &b, cfg)
}

/// The SIFT variant (Alg. 5): the transform B → A is fitted (RANSAC) to matched keypoint
/// pairs `(position in A, position in B)`, image coordinates, instead of χ² vertex matches;
/// then C1 is measured over the contour vertices exactly as in [`match_shapes`].
///
/// The vertex sets are used as given (pass [`ShapeDescriptor::vertices`] for resampled ones);
/// each needs ≥ 3 vertices that do not all coincide. With too few or inconsistent matches the
/// translation and then the centroid fallback are used (see the module doc).
pub fn shape_cost_from_matches(
    a_vertices: &[Point],
    b_vertices: &[Point],
    matches: &[(Point, Point)],
    cfg: &ShapeContextConfig,
) -> Result<ShapeMatch, ShapeContextError> {
    cfg.validate()?;
    for v in [a_vertices, b_vertices] {
        if v.len() < 3 {
            return Err(ShapeContextError::TooFewVertices {
                needed: 3,
                got: v.len(),
            });
        }
        check_finite(v)?;
    }
    let scale_of = |v: &[Point]| -> Result<f64, ShapeContextError> {
        let m = median_pairwise_distance(v);
        let extent = v
            .iter()
            .fold(0.0f64, |e, p| e.max(p.x.abs()).max(p.y.abs()));
        if m.is_finite() && m > 1e-9 * (1.0 + extent) {
            Ok(m)
        } else {
            Err(ShapeContextError::Degenerate {
                reason: "median pairwise vertex distance is zero",
            })
        }
    };
    let (sa, sb) = (scale_of(a_vertices)?, scale_of(b_vertices)?);
    let b_to_a: Vec<(Point, Point)> = matches.iter().map(|&(pa, pb)| (pb, pa)).collect();
    align_and_score(a_vertices, sa, b_vertices, sb, &b_to_a, cfg)
}

/// Fits B → A from `(b, a)` matches with the configured model, degrading to a translation and
/// then to the centroid fallback; returns C1 under the chosen transform.
fn align_and_score(
    a: &[Point],
    scale_a: f64,
    b: &[Point],
    scale_b: f64,
    matches: &[(Point, Point)],
    cfg: &ShapeContextConfig,
) -> Result<ShapeMatch, ShapeContextError> {
    let rcfg = RansacConfig {
        threshold: cfg.ransac_threshold * scale_a,
        max_iterations: cfg.ransac_max_iterations,
        confidence: 0.999,
        seed: cfg.seed,
        min_relative_area: cfg.min_relative_area,
    };
    let mut chosen: Option<(Transform, usize)> = None;
    for kind in [cfg.transform, TransformKind::Translation] {
        // One supporting match beyond the minimal sample, so a fit is never unverified.
        let needed = kind.min_matches() + 1;
        if matches.len() < needed {
            continue;
        }
        match ransac(kind, matches, &rcfg) {
            Ok(fit) if fit.inliers.len() >= needed => {
                chosen = Some((fit.transform, fit.inliers.len()));
                break;
            }
            // Invalid matches are the caller's bug, not a weak fit: report them.
            Err(e @ TransformError::NonFinite { .. }) => return Err(e.into()),
            _ => {}
        }
        if kind == TransformKind::Translation {
            break;
        }
    }
    let (transform, inliers, fitted) = match chosen {
        Some((t, k)) => (t, k, true),
        None => (centroid_fallback(a, scale_a, b, scale_b), 0, false),
    };
    let (transform, (cost, mean)) = if fitted {
        refine_icp(a, b, transform, scale_a, cfg)
    } else {
        (transform, symmetric_nearest_cost(a, b, &transform, scale_a))
    };
    Ok(ShapeMatch {
        cost,
        mean_distance: mean,
        transform,
        inliers,
        matched: matches.len(),
        fitted,
        scale: scale_a,
        descriptor_cost: None,
    })
}

/// Iterative closest point refinement of a fitted transform: re-pairs every B vertex with its
/// nearest A vertex and refits, keeping a refit only while it lowers C1.
fn refine_icp(
    a: &[Point],
    b: &[Point],
    mut t: Transform,
    scale_a: f64,
    cfg: &ShapeContextConfig,
) -> (Transform, (f64, f64)) {
    let mut best = symmetric_nearest_cost(a, b, &t, scale_a);
    let index_a = PointIndex::new(a);
    for _ in 0..cfg.icp_iterations {
        let pairs: Vec<(Point, Point)> = b
            .iter()
            .filter_map(|p| {
                let (i, _) = index_a.nearest(t.apply(*p))?;
                Some((*p, *a.get(i)?))
            })
            .collect();
        let Ok(refit) = Transform::fit(t.kind(), &pairs, cfg.min_relative_area) else {
            break;
        };
        let c = symmetric_nearest_cost(a, b, &refit, scale_a);
        if c.0 < best.0 {
            t = refit;
            best = c;
        } else {
            break;
        }
    }
    (t, best)
}

/// B's vertex centroid onto A's, scaled by the ratio of median distances, no rotation.
fn centroid_fallback(a: &[Point], scale_a: f64, b: &[Point], scale_b: f64) -> Transform {
    let mean =
        |v: &[Point]| v.iter().fold(Point::default(), |s, p| s + *p) * (1.0 / v.len() as f64);
    let (ca, cb) = (mean(a), mean(b));
    let s = scale_a / scale_b;
    Transform::Similarity(Similarity {
        scale: s,
        angle: 0.0,
        tx: ca.x - s * cb.x,
        ty: ca.y - s * cb.y,
    })
}

/// `(C1, mean)`: symmetric nearest-vertex distance sums between A and T(B), over `scale`.
fn symmetric_nearest_cost(a: &[Point], b: &[Point], t: &Transform, scale: f64) -> (f64, f64) {
    let projected: Vec<Point> = b.iter().map(|p| t.apply(*p)).collect();
    let index_a = PointIndex::new(a);
    let index_b = PointIndex::new(&projected);
    // A non-finite projection (an absurd transform) has no nearest point: count it at the
    // largest finite distance seen so the cost stays finite yet clearly bad.
    let sum_side = |pts: &[Point], index: &PointIndex| -> f64 {
        let mut worst = 0.0f64;
        let mut missing = 0usize;
        let mut s = 0.0;
        for p in pts {
            match index.nearest(*p) {
                Some((_, d)) if d.is_finite() => {
                    s += d;
                    worst = worst.max(d);
                }
                _ => missing += 1,
            }
        }
        let fill = if worst > 0.0 { worst } else { scale };
        s + missing as f64 * fill
    };
    let total = sum_side(&projected, &index_a) + sum_side(a, &index_b);
    let cost = 0.5 * total / scale;
    let mean = total / (a.len() + b.len()).max(1) as f64 / scale;
    if cost.is_finite() && mean.is_finite() {
        (cost, mean)
    } else {
        (f64::MAX, f64::MAX)
    }
}
