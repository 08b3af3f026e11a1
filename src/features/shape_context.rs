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

use super::transform::{
    ransac, PointIndex, RansacConfig, Similarity, Transform, TransformError, TransformKind,
    DEFAULT_MIN_RELATIVE_AREA,
};
use crate::frame::Point;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use thiserror::Error;

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

/// χ² cost between two normalised histograms (eq. 38):
/// `C = ½ Σ_k (A(k) − B(k))² / (A(k) + B(k))`, terms with `A(k) + B(k) = 0` skipped.
///
/// For histograms that each sum to 1 the cost lies in `[0, 1]`; it is 0 iff they are equal.
pub fn chi2_cost(a: &[f64], b: &[f64]) -> Result<f64, ShapeContextError> {
    if a.len() != b.len() {
        return Err(ShapeContextError::HistogramLength {
            a: a.len(),
            b: b.len(),
        });
    }
    Ok(chi2_unchecked(a, b))
}

#[inline]
fn chi2_unchecked(a: &[f64], b: &[f64]) -> f64 {
    let mut c = 0.0;
    for (&x, &y) in a.iter().zip(b) {
        let s = x + y;
        if s > 0.0 {
            let d = x - y;
            c += d * d / s;
        }
    }
    0.5 * c
}

/// The `a.len() × b.len()` matrix of χ² costs between every A and every B histogram
/// (row-major).
pub fn chi2_matrix(
    a: &ShapeDescriptor,
    b: &ShapeDescriptor,
) -> Result<Vec<f64>, ShapeContextError> {
    if a.bins != b.bins {
        return Err(ShapeContextError::HistogramLength {
            a: a.bins,
            b: b.bins,
        });
    }
    // χ² over A's non-zero bins only: where A(k) = 0 the term is B(k)²/B(k) = B(k), so those
    // bins together contribute ΣB − Σ_{A(k)>0} B(k). Contour histograms are sparse (n − 1
    // points over 60 bins), so this skips most of the divisions of the dense formula.
    let sums_b: Vec<f64> = b
        .histograms
        .chunks_exact(b.bins)
        .map(|h| h.iter().sum())
        .collect();
    let mut nz: Vec<(usize, f64)> = Vec::with_capacity(a.bins);
    let mut m = Vec::with_capacity(a.len() * b.len());
    for ha in a.histograms.chunks_exact(a.bins) {
        nz.clear();
        nz.extend(ha.iter().copied().enumerate().filter(|&(_, v)| v > 0.0));
        for (hb, &sum_b) in b.histograms.chunks_exact(b.bins).zip(&sums_b) {
            let (mut acc, mut covered) = (0.0, 0.0);
            for &(k, x) in &nz {
                let y = hb.get(k).copied().unwrap_or(0.0);
                let d = x - y;
                acc += d * d / (x + y);
                covered += y;
            }
            m.push((0.5 * (acc + sum_b - covered)).max(0.0));
        }
    }
    Ok(m)
}

/// Matched vertex pairs `(index in A, index in B, χ² cost)` under `rule`.
pub fn match_vertices(
    a: &ShapeDescriptor,
    b: &ShapeDescriptor,
    rule: VertexMatching,
) -> Result<Vec<(usize, usize, f64)>, ShapeContextError> {
    let cost = chi2_matrix(a, b)?;
    let (na, nb) = (a.len(), b.len());
    match rule {
        VertexMatching::Optimal => {
            let (rows, cols) =
                lsap::solve(na, nb, &cost, false).map_err(|e| ShapeContextError::Assignment {
                    reason: e.to_string(),
                })?;
            Ok(rows
                .into_iter()
                .zip(cols)
                .filter_map(|(i, j)| cost.get(i * nb + j).map(|&c| (i, j, c)))
                .collect())
        }
        VertexMatching::NearestCost => Ok(cost
            .chunks_exact(nb)
            .enumerate()
            .filter_map(|(i, row)| {
                row.iter()
                    .enumerate()
                    .min_by(|x, y| x.1.total_cmp(y.1))
                    .map(|(j, &c)| (i, j, c))
            })
            .collect()),
    }
}

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

/// How [`normalize_in_cluster`] maps a region cluster's raw costs into `[0, 1]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum ClusterNorm {
    /// `v / max` (default). Keeps 0 at 0 and keeps ratios, so a perfect pair stays perfect and
    /// two equally good pairs stay equal; only the worst pair is pinned to 1.
    #[default]
    DivideByMax,
    /// `(v − min) / (max − min)`. Stretches the spread, but makes the best pair 0 even when
    /// it is poor, and cannot tell "all equally bad" from "all perfect".
    MinMax,
}

/// Normalises one cost (C1 or C2) over the pairs of one region cluster into `[0, 1]`, so that
/// eq. 39 weighs shape and colour on the same footing (thesis: "normalised within the
/// cluster").
///
/// Rules: negative values count as 0; NaN and infinite values (pairs that could not be
/// compared) become 1, the worst; the extrema are taken over the finite values only; if those
/// are all equal (including a single pair) every finite value maps to 0 under
/// [`ClusterNorm::MinMax`], and under [`ClusterNorm::DivideByMax`] to 0 when the maximum is 0
/// and to 1 otherwise. Because normalised values are only comparable within one cluster,
/// gating (rejecting a pair outright) must use the raw costs.
pub fn normalize_in_cluster(costs: &[f64], rule: ClusterNorm) -> Vec<f64> {
    let finite = || costs.iter().filter(|v| v.is_finite()).map(|v| v.max(0.0));
    let max = finite().fold(f64::NEG_INFINITY, f64::max);
    let min = finite().fold(f64::INFINITY, f64::min);
    costs
        .iter()
        .map(|&v| {
            if !v.is_finite() {
                return 1.0;
            }
            let v = v.max(0.0);
            let out = match rule {
                ClusterNorm::DivideByMax => {
                    if max > 0.0 {
                        v / max
                    } else {
                        0.0
                    }
                }
                ClusterNorm::MinMax => {
                    if max > min {
                        (v - min) / (max - min)
                    } else {
                        0.0
                    }
                }
            };
            out.clamp(0.0, 1.0)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(side: f64) -> Vec<Point> {
        vec![
            Point::new(0.0, 0.0),
            Point::new(side, 0.0),
            Point::new(side, side),
            Point::new(0.0, side),
        ]
    }

    #[test]
    fn resample_is_even_and_wound_positively() {
        let mut sq = square(10.0);
        let r = resample_contour(&sq, 8).unwrap();
        assert_eq!(r.len(), 8);
        for i in 0..8 {
            assert!((r[i].dist(r[(i + 1) % 8]) - 5.0).abs() < 1e-9);
        }
        assert!(signed_area2(&r) > 0.0);
        sq.reverse();
        assert!(signed_area2(&resample_contour(&sq, 8).unwrap()) > 0.0);
    }

    #[test]
    fn median_of_pairwise_distances() {
        // Distances of a unit square: four sides 1 and two diagonals √2 → median 1.
        let sq = square(1.0);
        assert!((median_pairwise_distance(&sq) - 1.0).abs() < 1e-12);
        // Three collinear points 0,1,3: distances 1,2,3 → median 2.
        let p = [
            Point::new(0.0, 0.0),
            Point::new(1.0, 0.0),
            Point::new(3.0, 0.0),
        ];
        assert!((median_pairwise_distance(&p) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn histograms_sum_to_one_and_bins_follow_belongie_edges() {
        let cfg = ShapeContextConfig::default();
        let e = cfg.radius_edges();
        let want = [0.125, 0.25, 0.5, 1.0, 2.0];
        for (x, y) in e.iter().zip(want) {
            assert!((x - y).abs() < 1e-12);
        }
        let d = ShapeDescriptor::from_contour(&square(10.0), &cfg).unwrap();
        for i in 0..d.len() {
            let s: f64 = d.histogram(i).unwrap().iter().sum();
            assert!((s - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn sparse_chi2_matrix_equals_dense_formula() {
        let cfg = ShapeContextConfig::default();
        let l = [
            Point::new(0.0, 0.0),
            Point::new(10.0, 0.0),
            Point::new(10.0, 20.0),
            Point::new(20.0, 20.0),
            Point::new(20.0, 30.0),
            Point::new(0.0, 30.0),
        ];
        let a = ShapeDescriptor::from_contour(&square(10.0), &cfg).unwrap();
        let b = ShapeDescriptor::from_contour(&l, &cfg).unwrap();
        let m = chi2_matrix(&a, &b).unwrap();
        for i in 0..a.len() {
            for j in 0..b.len() {
                let dense = chi2_cost(a.histogram(i).unwrap(), b.histogram(j).unwrap()).unwrap();
                assert!((m[i * b.len() + j] - dense).abs() < 1e-12);
            }
        }
        assert!(chi2_matrix(&a, &a)
            .unwrap()
            .iter()
            .step_by(a.len() + 1)
            .all(|&c| c == 0.0));
    }

    #[test]
    fn diamond_angle_is_monotone_in_the_polar_angle() {
        let mut last = -1.0;
        for k in 0..3600 {
            let t = 2.0 * PI * k as f64 / 3600.0;
            let d = diamond_angle(t.cos(), t.sin());
            assert!(d > last && (0.0..4.0).contains(&d), "{k}: {d} after {last}");
            last = d;
        }
        assert_eq!(diamond_angle(0.0, 0.0), 0.0);
        assert_eq!(diamond_angle(-1.0, 0.0), 2.0);
    }

    #[test]
    fn angle_bins_match_atan2() {
        // Vertex 0 at the origin sees every other vertex once; rebuild its histogram by hand.
        let cfg = ShapeContextConfig::default();
        let mut v = vec![Point::new(0.0, 0.0)];
        for k in 0..40 {
            let t = 0.37 + 2.0 * PI * k as f64 / 40.0;
            let r = 1.0 + (k % 5) as f64 * 0.7;
            v.push(Point::new(r * t.cos(), r * t.sin()));
        }
        let d = ShapeDescriptor::from_vertices(&v, &cfg).unwrap();
        let edges = cfg.radius_edges();
        let mut want = vec![0.0; cfg.bins()];
        let mut total = 0.0;
        for q in &v[1..] {
            let r = q.dist(v[0]) / d.median_distance();
            let Some(rb) = edges.iter().position(|&e| r < e) else {
                continue;
            };
            let theta = q.y.atan2(q.x).rem_euclid(2.0 * PI);
            let ab = ((theta / (2.0 * PI / 12.0)) as usize).min(11);
            want[rb * 12 + ab] += 1.0;
            total += 1.0;
        }
        want.iter_mut().for_each(|x| *x /= total);
        assert_eq!(d.histogram(0).unwrap(), &want[..]);
    }

    #[test]
    fn normalisation_rules() {
        let v = [2.0, 4.0, f64::NAN, -1.0];
        assert_eq!(
            normalize_in_cluster(&v, ClusterNorm::DivideByMax),
            vec![0.5, 1.0, 1.0, 0.0]
        );
        assert_eq!(
            normalize_in_cluster(&v, ClusterNorm::MinMax),
            vec![0.5, 1.0, 1.0, 0.0]
        );
        assert_eq!(
            normalize_in_cluster(&[0.0, 0.0], ClusterNorm::DivideByMax),
            vec![0.0, 0.0]
        );
        assert_eq!(normalize_in_cluster(&[3.0], ClusterNorm::MinMax), vec![0.0]);
        assert_eq!(
            normalize_in_cluster(&[3.0], ClusterNorm::DivideByMax),
            vec![1.0]
        );
        assert!(normalize_in_cluster(&[], ClusterNorm::DivideByMax).is_empty());
    }
}
