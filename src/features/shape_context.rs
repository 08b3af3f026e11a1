//! Shape context descriptor and the shape cost C1 (thesis ch. 4.3, Alg. 4 and 5;
//! Belongie, Malik & Puzicha 2002).
//!
//! Pipeline for two shapes A (frame n) and B (frame n+1):
//!
//! 1. **Vertices.** Each contour is resampled to [`ShapeContextConfig::vertices`] points evenly
//!    spaced along its closed outline ([`resample_contour`]), so that the cost does not depend
//!    on how densely the contour extractor emitted points, and stays `O(n²)` with a small `n`.
//! 2. **Histograms.** For every vertex, a log-polar histogram of the other vertices
//!    (12 angle × 5 log-radius bins by default). Distances are divided by the shape's **median
//!    pairwise distance** — the median of all `n(n−1)/2` distances between distinct vertices
//!    of that shape (mean of the two middle values when the count is even) — which makes the
//!    descriptor scale invariant. Radius bin edges are log-spaced over `[1/8, 2]` as in
//!    Belongie's code: a point closer than 1/8 goes to the innermost bin, a point at 2 or beyond
//!    is not counted. Each histogram is normalised to sum 1.
//! 3. **χ² cost** (eq. 38) between every A and B histogram ([`chi2_cost`]).
//! 4. **Vertex matching.** [`VertexMatching::Optimal`] (default) solves the one-to-one linear
//!    assignment on the χ² matrix with `lsap`; [`VertexMatching::NearestCost`] is the thesis'
//!    literal rule (each A vertex takes its cheapest B vertex, so several A vertices may share
//!    one B vertex). The optimal assignment is better defined: it cannot collapse many vertices
//!    onto one distinctive B vertex, which would make the transform fit lean on duplicates.
//! 5. **Transform.** A similarity (default) or affine map B → A is fitted to the matched
//!    vertices by seeded RANSAC (χ² matches on near-symmetric shapes contain outliers).
//! 6. **Cost C1.** B's vertices are projected into A's frame and the nearest-vertex distances
//!    are summed with a k-d tree ([`PointIndex`]).
//!
//! Decisions beyond the thesis:
//!
//! - C1 is **symmetric**: `½·(Σ_b d(T(b), A) + Σ_a d(a, T(B)))`. The one-sided sum of step 10 of
//!   Alg. 4 rewards a transform that shrinks B onto a few of A's vertices; the symmetric form
//!   cannot be gamed that way and is close to the one-sided one for a good alignment.
//! - C1 is divided by A's median pairwise distance, so it does not grow with object size
//!   ([`ShapeMatch::scale`] keeps that distance to convert back to pixels).
//! - The RANSAC fit is refined by a few iterative-closest-point steps (re-pair each B vertex
//!   with its nearest A vertex, refit, keep the refit only if C1 drops). χ² matches of two
//!   resampled outlines are off by up to a sample spacing along the contour, which biases the
//!   fit; this removes most of that bias, so C1 of the same shape drops to the sampling floor.
//! - A fit is accepted only when it has at least one inlier beyond its minimal sample (3 for a
//!   similarity, 4 for an affine map: the thesis' "at least 3 vertices"). Otherwise a
//!   translation is tried, and if that fails too, the **fallback** alignment maps B's vertex
//!   centroid onto A's and scales by the ratio of median distances ([`ShapeMatch::fitted`] is
//!   then false). A cost is always produced for valid shapes: the tracker needs a number for
//!   every pair in a cluster. Non-collinearity (step 8) is enforced where it matters, in the
//!   affine fit; a similarity is well defined by any two distinct points.
//! - [`Orientation`] makes the descriptor rotation invariant on request. It is off by default:
//!   between consecutive frames objects barely rotate, and absolute angles tell a shape from
//!   its rotated neighbour (a "6" from a "9").
//!
//! [`normalize_in_cluster`] is the thesis' "normalised within the cluster" step for C1 and C2.

mod chi2;
mod cluster;
mod cost;
#[cfg(test)]
mod tests;

pub use chi2::{chi2_cost, chi2_matrix, match_vertices};
pub use cluster::{normalize_in_cluster, ClusterNorm};
pub use cost::{match_shapes, shape_cost, shape_cost_from_matches, ShapeMatch};

use super::transform::{TransformError, TransformKind, DEFAULT_MIN_RELATIVE_AREA};
use crate::frame::Point;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use thiserror::Error;

#[cfg(doc)]
use super::transform::PointIndex;

/// Errors from building shape descriptors or comparing shapes.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ShapeContextError {
    /// Too few vertices (or contour points) to describe a shape.
    #[error("shape has {got} vertices, at least {needed} are needed")]
    TooFewVertices {
        /// Minimum count.
        needed: usize,
        /// Count given.
        got: usize,
    },
    /// A vertex has a NaN or infinite coordinate.
    #[error("vertex {index} has a non-finite coordinate")]
    NonFinite {
        /// Index of the offending vertex.
        index: usize,
    },
    /// The vertices (mostly) coincide: the median pairwise distance is zero.
    #[error("shape is degenerate: {reason}")]
    Degenerate {
        /// What is degenerate.
        reason: &'static str,
    },
    /// A configuration value is out of range.
    #[error("invalid configuration: {field} {reason}")]
    InvalidConfig {
        /// The field.
        field: &'static str,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// Two descriptors were built with different bin layouts.
    #[error("histogram lengths differ: {a} vs {b}")]
    HistogramLength {
        /// Bins of the first.
        a: usize,
        /// Bins of the second.
        b: usize,
    },
    /// The assignment solver rejected the cost matrix.
    #[error("vertex assignment failed: {reason}")]
    Assignment {
        /// Solver message.
        reason: String,
    },
    /// A transform operation failed where no fallback applies.
    #[error(transparent)]
    Transform(#[from] TransformError),
}

/// Reference direction for the angle bins.
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Orientation {
    /// Angles in image coordinates (Belongie's default; not rotation invariant).
    #[default]
    Absolute,
    /// Angles relative to the contour tangent at each vertex (needs vertices in contour order;
    /// [`resample_contour`] also fixes the winding so both shapes agree). Fully rotation
    /// invariant, but noisy where the outline is jagged.
    Tangent,
    /// Angles relative to the principal axis of the vertex set, its sign fixed by the third
    /// moment along the axis. Rotation invariant up to the axis' ambiguity on near-isotropic or
    /// symmetric shapes (a circle or a square has no stable axis).
    PrincipalAxis,
}

/// How matched vertex pairs are chosen from the χ² matrix.
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum VertexMatching {
    /// Optimal one-to-one assignment (Hungarian / Jonker–Volgenant via `lsap`).
    #[default]
    Optimal,
    /// The thesis' rule: every A vertex takes its minimum-cost B vertex (many-to-one allowed).
    NearestCost,
}

/// Settings for [`ShapeDescriptor`] and the shape costs. `Default` gives the documented values.
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ShapeContextConfig {
    /// Angle bins (default 12).
    pub angle_bins: usize,
    /// Log-radius bins (default 5).
    pub radius_bins: usize,
    /// Inner radius edge in median-distance units (default 1/8).
    pub r_inner: f64,
    /// Outer radius edge in median-distance units (default 2).
    pub r_outer: f64,
    /// Vertices a contour is resampled to (default 64).
    pub vertices: usize,
    /// Angle reference (default [`Orientation::Absolute`]).
    pub orientation: Orientation,
    /// Vertex matching rule (default [`VertexMatching::Optimal`]).
    pub matching: VertexMatching,
    /// Model fitted from the matches (default [`TransformKind::Similarity`]).
    pub transform: TransformKind,
    /// RANSAC inlier threshold as a fraction of A's median pairwise distance (default 0.1).
    pub ransac_threshold: f64,
    /// RANSAC iteration cap (default 200).
    pub ransac_max_iterations: usize,
    /// Minimum relative area of affine samples (see
    /// [`relative_area`](super::transform::relative_area)).
    pub min_relative_area: f64,
    /// RANSAC seed.
    pub seed: u64,
    /// Iterative-closest-point refinements of a fitted transform (default 3; 0 disables).
    pub icp_iterations: usize,
}

impl Default for ShapeContextConfig {
    fn default() -> Self {
        Self {
            angle_bins: 12,
            radius_bins: 5,
            r_inner: 0.125,
            r_outer: 2.0,
            vertices: 64,
            orientation: Orientation::Absolute,
            matching: VertexMatching::Optimal,
            transform: TransformKind::Similarity,
            ransac_threshold: 0.1,
            ransac_max_iterations: 200,
            min_relative_area: DEFAULT_MIN_RELATIVE_AREA,
            seed: 0x5c5c_5c5c,
            icp_iterations: 3,
        }
    }
}

impl ShapeContextConfig {
    /// Number of bins of one histogram.
    pub fn bins(&self) -> usize {
        self.angle_bins * self.radius_bins
    }

    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), ShapeContextError> {
        let bad = |field, reason| Err(ShapeContextError::InvalidConfig { field, reason });
        if self.angle_bins == 0 || self.angle_bins > 360 {
            return bad("angle_bins", "must be in 1..=360");
        }
        if self.radius_bins == 0 || self.radius_bins > 64 {
            return bad("radius_bins", "must be in 1..=64");
        }
        if !(self.r_inner.is_finite() && self.r_inner > 0.0) {
            return bad("r_inner", "must be finite and > 0");
        }
        if !(self.r_outer.is_finite() && self.r_outer > self.r_inner) {
            return bad("r_outer", "must be finite and > r_inner");
        }
        if self.vertices < 3 || self.vertices > 4096 {
            return bad("vertices", "must be in 3..=4096");
        }
        if !(self.ransac_threshold.is_finite() && self.ransac_threshold > 0.0) {
            return bad("ransac_threshold", "must be finite and > 0");
        }
        if self.ransac_max_iterations == 0 {
            return bad("ransac_max_iterations", "must be ≥ 1");
        }
        if !(self.min_relative_area.is_finite() && self.min_relative_area >= 0.0) {
            return bad("min_relative_area", "must be finite and ≥ 0");
        }
        Ok(())
    }

    /// Radius bin edges, log-spaced from `r_inner` to `r_outer` (one edge per bin).
    fn radius_edges(&self) -> Vec<f64> {
        let r = self.radius_bins;
        if r == 1 {
            return vec![self.r_outer];
        }
        let ratio = (self.r_outer / self.r_inner).ln();
        (0..r)
            .map(|m| self.r_inner * (ratio * m as f64 / (r - 1) as f64).exp())
            .collect()
    }
}

/// One shape's vertices and their log-polar histograms; build once per detection and reuse.
///
/// Serialisable for caching and export, but deliberately not deserialisable: its invariants
/// (histogram size, positive median) are only established by the constructors.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ShapeDescriptor {
    vertices: Vec<Point>,
    /// `vertices.len() × bins`, row-major; each row sums to 1 (or is all zero when no other
    /// vertex falls within `r_outer`).
    histograms: Vec<f64>,
    bins: usize,
    median_distance: f64,
}

fn check_finite(points: &[Point]) -> Result<(), ShapeContextError> {
    match points
        .iter()
        .position(|p| !(p.x.is_finite() && p.y.is_finite()))
    {
        Some(index) => Err(ShapeContextError::NonFinite { index }),
        None => Ok(()),
    }
}

/// Twice the signed area of a closed polygon (shoelace); positive when the vertices turn from
/// +x towards +y.
fn signed_area2(points: &[Point]) -> f64 {
    let n = points.len();
    (0..n)
        .map(|i| {
            let (p, q) = (points[i], points[(i + 1) % n]);
            p.x * q.y - q.x * p.y
        })
        .sum()
}

/// `n` points evenly spaced by arc length along the closed polyline through `contour`
/// (the last point joins the first), starting at `contour[0]`.
///
/// The result always winds with positive shoelace area (in image coordinates: clockwise on
/// screen), whatever the input winding, so that tangent-relative angles agree between shapes.
/// Errors: fewer than 2 points, a non-finite point, or zero perimeter.
pub fn resample_contour(contour: &[Point], n: usize) -> Result<Vec<Point>, ShapeContextError> {
    if contour.len() < 2 {
        return Err(ShapeContextError::TooFewVertices {
            needed: 2,
            got: contour.len(),
        });
    }
    if n == 0 {
        return Err(ShapeContextError::InvalidConfig {
            field: "vertices",
            reason: "must be ≥ 1",
        });
    }
    check_finite(contour)?;
    let mut pts: Vec<Point> = contour.to_vec();
    if signed_area2(&pts) < 0.0 {
        pts[1..].reverse();
    }
    let m = pts.len();
    let seg_len: Vec<f64> = (0..m).map(|i| pts[i].dist(pts[(i + 1) % m])).collect();
    let perimeter: f64 = seg_len.iter().sum();
    if !(perimeter.is_finite() && perimeter > 0.0) {
        return Err(ShapeContextError::Degenerate {
            reason: "contour has zero perimeter",
        });
    }
    let step = perimeter / n as f64;
    let mut out = Vec::with_capacity(n);
    let (mut seg, mut seg_start) = (0usize, 0.0f64);
    for k in 0..n {
        let s = k as f64 * step;
        while seg + 1 < m && seg_start + seg_len[seg] <= s {
            seg_start += seg_len[seg];
            seg += 1;
        }
        let (p, q) = (pts[seg], pts[(seg + 1) % m]);
        let len = seg_len[seg];
        let t = if len > 0.0 {
            ((s - seg_start) / len).clamp(0.0, 1.0)
        } else {
            0.0
        };
        out.push(p + (q - p) * t);
    }
    Ok(out)
}

/// Median of all pairwise distances between distinct vertices.
fn median_pairwise_distance(points: &[Point]) -> f64 {
    let n = points.len();
    let mut d = Vec::with_capacity(n * n.saturating_sub(1) / 2);
    for i in 0..n {
        for j in i + 1..n {
            d.push(points[i].dist2(points[j]));
        }
    }
    if d.is_empty() {
        return 0.0;
    }
    let len = d.len();
    let mid = len / 2;
    // Squared distances order like distances, and skip a square root per pair.
    let (lower, &mut upper, _) = d.select_nth_unstable_by(mid, f64::total_cmp);
    if len % 2 == 1 {
        upper.sqrt()
    } else {
        let below = lower.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        0.5 * (below.sqrt() + upper.sqrt())
    }
}

/// A monotone function of the polar angle of `(x, y)` onto `[0, 4)` (0 along +x, 1 along
/// +y, 2 along −x, 3 along −y), exact at the axes; 0 for the zero vector.
#[inline]
fn diamond_angle(x: f64, y: f64) -> f64 {
    let l1 = x.abs() + y.abs();
    if l1 == 0.0 || !l1.is_finite() {
        return 0.0;
    }
    if y >= 0.0 {
        if x >= 0.0 {
            y / l1
        } else {
            1.0 - x / l1
        }
    } else if x < 0.0 {
        2.0 - y / l1
    } else {
        3.0 + x / l1
    }
}

/// Principal axis angle of the points, its sign fixed by the third moment along the axis.
fn principal_axis_angle(points: &[Point]) -> f64 {
    let n = points.len().max(1) as f64;
    let c = points.iter().fold(Point::default(), |a, p| a + *p) * (1.0 / n);
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for p in points {
        let d = *p - c;
        sxx += d.x * d.x;
        sxy += d.x * d.y;
        syy += d.y * d.y;
    }
    let phi = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let (s, co) = phi.sin_cos();
    let m3: f64 = points
        .iter()
        .map(|p| {
            let t = (p.x - c.x) * co + (p.y - c.y) * s;
            t * t * t
        })
        .sum();
    if m3 < 0.0 {
        phi + PI
    } else {
        phi
    }
}

impl ShapeDescriptor {
    /// Resamples `contour` to `cfg.vertices` points ([`resample_contour`]) and describes them.
    pub fn from_contour(
        contour: &[Point],
        cfg: &ShapeContextConfig,
    ) -> Result<Self, ShapeContextError> {
        cfg.validate()?;
        let vertices = resample_contour(contour, cfg.vertices)?;
        Self::from_vertices(&vertices, cfg)
    }

    /// Describes the given vertices as they are (≥ 3, not all coincident). For
    /// [`Orientation::Tangent`] they must be in contour order.
    pub fn from_vertices(
        vertices: &[Point],
        cfg: &ShapeContextConfig,
    ) -> Result<Self, ShapeContextError> {
        cfg.validate()?;
        let n = vertices.len();
        if n < 3 {
            return Err(ShapeContextError::TooFewVertices { needed: 3, got: n });
        }
        check_finite(vertices)?;
        let median = median_pairwise_distance(vertices);
        let extent = vertices
            .iter()
            .fold(0.0f64, |m, p| m.max(p.x.abs()).max(p.y.abs()));
        if !(median.is_finite() && median > 1e-9 * (1.0 + extent)) {
            return Err(ShapeContextError::Degenerate {
                reason: "median pairwise vertex distance is zero",
            });
        }
        let bins = cfg.bins();
        let edges = cfg.radius_edges();
        let r_outer = cfg.r_outer;
        let abins = cfg.angle_bins;
        let abin_width = 2.0 * PI / abins as f64;
        let axis = match cfg.orientation {
            Orientation::PrincipalAxis => principal_axis_angle(vertices),
            _ => 0.0,
        };
        let inv_median = 1.0 / median;
        let reference: Vec<f64> = (0..n)
            .map(|i| match cfg.orientation {
                Orientation::Absolute => 0.0,
                Orientation::PrincipalAxis => axis,
                Orientation::Tangent => {
                    let t = vertices[(i + 1) % n] - vertices[(i + n - 1) % n];
                    if t.x == 0.0 && t.y == 0.0 {
                        0.0
                    } else {
                        t.y.atan2(t.x)
                    }
                }
            })
            .collect();
        // Angle bins without atan2 (half the descriptor's time otherwise): every direction is
        // rotated into its vertex's reference frame and ranked by its "diamond angle", a cheap
        // monotone stand-in for the polar angle, against the bins' boundaries in the same units.
        let boundaries: Vec<f64> = (1..abins)
            .map(|k| {
                let (s, c) = (k as f64 * abin_width).sin_cos();
                diamond_angle(c, s)
            })
            .collect();
        let rotations: Vec<(f64, f64)> = reference.iter().map(|r| (-r).sin_cos()).collect();
        let angle_bin = |d: Point, (s, c): (f64, f64)| -> usize {
            let (x, y) = (c * d.x - s * d.y, s * d.x + c * d.y);
            let a = diamond_angle(x, y);
            boundaries.partition_point(|&b| b <= a)
        };
        let mut histograms = vec![0.0; n * bins];
        let mut totals = vec![0.0f64; n];
        // Each pair is measured once and binned into both endpoints' histograms.
        for i in 0..n {
            let p = vertices[i];
            for j in i + 1..n {
                let d = vertices[j] - p;
                let r = (d.x * d.x + d.y * d.y).sqrt() * inv_median;
                if r >= r_outer {
                    continue;
                }
                let Some(rb) = edges.iter().position(|&e| r < e) else {
                    continue;
                };
                let (ri, rj) = (rotations[i], rotations[j]);
                let bi = i * bins + rb * abins + angle_bin(d, ri);
                let bj = j * bins + rb * abins + angle_bin(d * -1.0, rj);
                for (b, k) in [(bi, i), (bj, j)] {
                    if let (Some(cell), Some(t)) = (histograms.get_mut(b), totals.get_mut(k)) {
                        *cell += 1.0;
                        *t += 1.0;
                    }
                }
            }
        }
        for (row, &total) in histograms.chunks_exact_mut(bins).zip(&totals) {
            if total > 0.0 {
                row.iter_mut().for_each(|v| *v /= total);
            }
        }
        Ok(Self {
            vertices: vertices.to_vec(),
            histograms,
            bins,
            median_distance: median,
        })
    }

    /// The described vertices (resampled when built from a contour).
    pub fn vertices(&self) -> &[Point] {
        &self.vertices
    }

    /// Number of vertices.
    pub fn len(&self) -> usize {
        self.vertices.len()
    }

    /// Whether there is no vertex (never true for a built descriptor).
    pub fn is_empty(&self) -> bool {
        self.vertices.is_empty()
    }

    /// Bins per histogram.
    pub fn bins(&self) -> usize {
        self.bins
    }

    /// The normalised histogram of vertex `i` (radius-major: bin `r·angle_bins + a`).
    pub fn histogram(&self, i: usize) -> Option<&[f64]> {
        self.histograms.get(i * self.bins..(i + 1) * self.bins)
    }

    /// The shape's median pairwise vertex distance, in pixels.
    pub fn median_distance(&self) -> f64 {
        self.median_distance
    }
}
