//! Convex shells: the convex polygons the region estimator intersects, and the Delaunay mesh
//! whose outer boundary they are (thesis §3.2.5, property 5).
//!
//! Orientation convention: a shell's vertices run counter-clockwise in the mathematical sense,
//! i.e. their shoelace area `½Σ(xᵢ·yᵢ₊₁ − xᵢ₊₁·yᵢ)` is positive. Image y grows downwards, so on
//! screen the same polygon appears clockwise. This is the orientation parry2d expects for its
//! `ConvexPolygon` (outward normals on the right of each edge in y-up terms).

use serde::{Deserialize, Serialize};
use spade::{DelaunayTriangulation, Point2, Triangulation};

use super::GeometryError;
use crate::frame::{BBox, Mask, Point};
use crate::runs::{first_nonzero, last_nonzero};
use crate::scratch::with_scratch;

/// Distance under which two shells count as touching, in pixels.
///
/// Used as slack wherever a cheap bounding-box test decides that a pair cannot intersect, so the
/// broad phase never rejects a pair the exact test (parry2d's f32 GJK, whose own tolerance is
/// about 1e-6 of the shapes' size) might accept. A thousandth of a pixel is far below anything
/// the tracker can see and far above f32 rounding for shapes up to ~10⁴ px across.
pub const TOUCH_TOLERANCE: f64 = 1e-3;

/// Absolute tolerance of [`ConvexShell::contains`], in pixels: hull construction and
/// translation round coordinates, so a point that was used to build the hull may end up a few
/// ulps outside it.
pub const CONTAINS_TOLERANCE: f64 = 1e-7;

/// Largest angle (radians) one polygon edge may turn through when [`ConvexShell::grown`]
/// rounds a corner. π/4 makes a grown point an octagon circumscribing the disc; the grown shell
/// then overshoots the exact Minkowski sum by at most `margin·(1/cos(π/8) − 1) ≈ 8%` of the
/// margin, a fair trade for few vertices (GJK cost grows with vertex count).
const MAX_ARC_STEP: f64 = std::f64::consts::FRAC_PI_4;

/// A convex polygon in f64 image coordinates, vertices counter-clockwise (positive shoelace
/// area), no repeated and no collinear vertices.
///
/// Degenerate shells are valid: no vertex (nothing, intersects nothing), one vertex (a point)
/// or two (a segment) — what a one-pixel or one-line mask gives.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(try_from = "Vec<Point>", into = "Vec<Point>")]
pub struct ConvexShell {
    vertices: Vec<Point>,
}

impl TryFrom<Vec<Point>> for ConvexShell {
    type Error = GeometryError;

    /// Rebuilds the hull, so deserialised data always satisfies the invariants.
    fn try_from(points: Vec<Point>) -> Result<Self, GeometryError> {
        ConvexShell::from_points(&points)
    }
}

impl From<ConvexShell> for Vec<Point> {
    fn from(s: ConvexShell) -> Vec<Point> {
        s.vertices
    }
}

impl ConvexShell {
    /// The empty shell.
    pub fn empty() -> Self {
        Self::default()
    }

    /// The convex hull of `points` (Andrew's monotone chain, `O(n log n)`). Duplicates and
    /// collinear points are dropped. Rejects non-finite coordinates.
    pub fn from_points(points: &[Point]) -> Result<Self, GeometryError> {
        if let Some(p) = points
            .iter()
            .find(|p| !(p.x.is_finite() && p.y.is_finite()))
        {
            return Err(GeometryError::NonFinitePoint { x: p.x, y: p.y });
        }
        let mut vertices = points.to_vec();
        hull_tail(&mut vertices, 0);
        Ok(Self { vertices })
    }

    /// The box's four corners (a segment or point when the box is flat). Rejects invalid boxes.
    pub fn from_bbox(b: &BBox) -> Result<Self, GeometryError> {
        if !b.is_valid() {
            return Err(GeometryError::InvalidBox {
                x: b.x,
                y: b.y,
                w: b.w,
                h: b.h,
            });
        }
        Self::from_points(&b.corners())
    }

    /// Vertices, counter-clockwise (positive shoelace area), starting at the smallest `(x, y)`.
    pub fn vertices(&self) -> &[Point] {
        &self.vertices
    }

    /// Number of vertices.
    pub fn len(&self) -> usize {
        self.vertices.len()
    }

    /// Whether the shell has no vertex.
    pub fn is_empty(&self) -> bool {
        self.vertices.is_empty()
    }

    /// The shell moved by `(dx, dy)`. A non-finite offset is treated as zero: offsets come from
    /// motion prediction, and a diverged filter must not poison every later intersection test.
    pub fn translated(&self, dx: f64, dy: f64) -> ConvexShell {
        let mut vertices = Vec::with_capacity(self.vertices.len());
        self.translated_onto(dx, dy, &mut vertices);
        ConvexShell { vertices }
    }

    /// Appends the vertices of [`ConvexShell::translated`] to `out` (no allocation of its
    /// own: the per-frame search shells are built in one buffer, issue 10).
    fn translated_onto(&self, dx: f64, dy: f64, out: &mut Vec<Point>) {
        let start = out.len();
        if self.shifted_onto(dx, dy, out) {
            // Translation keeps convexity, but rounding can make nearly collinear vertices
            // collinear; rebuilding the hull keeps the invariant exact.
            hull_tail(out, start);
        }
    }

    /// Appends the vertices moved by `(dx, dy)` (a non-finite offset counting as zero) to
    /// `out`, without rebuilding their hull; the vertices unmoved when a moved one would not
    /// be finite. Whether they moved: only then may their hull differ from the shell.
    fn shifted_onto(&self, dx: f64, dy: f64, out: &mut Vec<Point>) -> bool {
        let dx = if dx.is_finite() { dx } else { 0.0 };
        let dy = if dy.is_finite() { dy } else { 0.0 };
        let start = out.len();
        out.extend(self.vertices.iter().map(|p| Point::new(p.x + dx, p.y + dy)));
        if out[start..]
            .iter()
            .all(|p| p.x.is_finite() && p.y.is_finite())
        {
            true
        } else {
            out.truncate(start);
            out.extend_from_slice(&self.vertices);
            false
        }
    }

    /// The shell grown outwards by `margin`: a convex polygon that contains the Minkowski sum
    /// of the shell with a disc of radius `margin` (every point within `margin` of the shell)
    /// and exceeds it by at most ~8% of `margin`.
    ///
    /// Every edge moves outwards by exactly `margin`; each corner is rounded by tangent segments
    /// at most π/4 apart. A point grows into an octagon, a segment into a stadium-like octagon.
    /// A margin that is not a positive finite number returns the shell unchanged.
    pub fn grown(&self, margin: f64) -> ConvexShell {
        if !(margin > 0.0 && margin.is_finite()) || self.vertices.is_empty() {
            return self.clone();
        }
        let n = self.vertices.len();
        let mut out = Vec::with_capacity(n * 3);
        // Outward normal directions (angles) of each edge i → i+1. For a point the "edges" are
        // undefined, so the whole turn of 2π happens at its single corner.
        let edge_angle = |i: usize| -> f64 {
            let a = self.vertices[i];
            let b = self.vertices[(i + 1) % n];
            // Outward normal of a CCW edge (y-up sense) is the edge direction turned clockwise.
            (-(b.x - a.x)).atan2(b.y - a.y)
        };
        // Unit outward normal of edge i → i+1 (`edge_angle`'s direction), without the angle.
        let edge_normal = |i: usize| -> Point {
            let a = self.vertices[i];
            let b = self.vertices[(i + 1) % n];
            let (x, y) = (b.y - a.y, -(b.x - a.x));
            let len = x.hypot(y);
            Point::new(x / len, y / len)
        };
        let (cos_step, mut next_normal) = (MAX_ARC_STEP.cos(), edge_normal(n - 1));
        for i in 0..n {
            let v = self.vertices[i];
            // A corner that turns through at most one step (most corners: the turns add up to
            // a full turn) is one point on the bisector of its edges' normals, at
            // margin / cos(turn / 2): with s the normals' sum, |s| = 2·cos(turn / 2), so the
            // point is v + 2·margin·s / |s|². No trigonometry: in wasm sin, cos and atan2 are
            // library calls, a tenth of the region estimate's time in the page (issue 10).
            let (prev, next) = (next_normal, edge_normal(i));
            next_normal = next;
            let dot = prev.x * next.x + prev.y * next.y;
            if n > 1 && cross(prev, next) >= 0.0 && dot >= cos_step {
                let s = prev + next;
                out.push(v + s * (2.0 * margin / (s.x * s.x + s.y * s.y)));
                continue;
            }
            let (start, turn) = if n == 1 {
                (0.0, std::f64::consts::TAU)
            } else {
                let prev = edge_angle((i + n - 1) % n);
                let next = edge_angle(i);
                let mut turn = next - prev;
                while turn < 0.0 {
                    turn += std::f64::consts::TAU;
                }
                while turn > std::f64::consts::TAU {
                    turn -= std::f64::consts::TAU;
                }
                // A segment's two "edges" are antiparallel: each end turns through π.
                (prev, turn)
            };
            let steps = ((turn / MAX_ARC_STEP).ceil() as usize).max(1);
            let step = turn / steps as f64;
            // Corner of two tangent lines `step` apart sits at margin / cos(step/2) along the
            // bisector: this circumscribes the arc, so the polygon contains the exact sum.
            let r = margin / (step / 2.0).cos();
            for k in 0..steps {
                let a = start + step * (k as f64 + 0.5);
                out.push(Point::new(v.x + r * a.cos(), v.y + r * a.sin()));
            }
        }
        if out.iter().all(|p| p.x.is_finite() && p.y.is_finite()) {
            hull_tail(&mut out, 0);
            ConvexShell { vertices: out }
        } else {
            self.clone()
        }
    }

    /// The convex hull of the shell and its copy moved by `(dx, dy)`: the area swept by a
    /// shape moving in a straight line, for gating shapes that moved more than their own size.
    pub fn swept(&self, dx: f64, dy: f64) -> ConvexShell {
        let mut vertices = Vec::with_capacity(2 * self.vertices.len());
        self.swept_onto(dx, dy, &mut vertices);
        ConvexShell { vertices }
    }

    /// Appends the vertices of [`ConvexShell::swept`] to `out`.
    fn swept_onto(&self, dx: f64, dy: f64, out: &mut Vec<Point>) {
        let start = out.len();
        out.extend_from_slice(&self.vertices);
        // One hull of both copies: a point the moved copy's own hull would drop is no vertex
        // of the union's either.
        self.shifted_onto(dx, dy, out);
        hull_tail(out, start);
    }

    /// The hull of this shell moved by `(dx, dy)` (swept along the move when `sweep`) and of
    /// `extra` points: what [`ConvexShell::translated`] or [`ConvexShell::swept`] then
    /// [`ConvexShell::from_points`] with `extra` give, vertex for vertex, with one allocation
    /// where those calls made five (seven when swept). Falls back to the moved shell alone
    /// when an `extra` point is not finite (as `from_points` would reject it).
    pub fn moved_with(&self, dx: f64, dy: f64, sweep: bool, extra: &[Point]) -> ConvexShell {
        let mut vertices = Vec::with_capacity(2 * self.vertices.len() + extra.len());
        // One hull of every point, where moving (or sweeping) then merging built two or
        // three, each with its sort (the tracker builds this shell for every track and
        // frame; issue 10). A point the moved shell's own hull would drop lies inside or on
        // it, so it is no vertex of the merged hull either.
        if sweep {
            vertices.extend_from_slice(&self.vertices);
        }
        let moved = self.shifted_onto(dx, dy, &mut vertices);
        let merged = extra.iter().all(|p| p.x.is_finite() && p.y.is_finite());
        if merged {
            vertices.extend_from_slice(extra);
        }
        // Unmoved, unswept and unmerged, the vertices are the shell's hull already.
        if merged || sweep || moved {
            hull_tail(&mut vertices, 0);
        }
        ConvexShell { vertices }
    }

    /// Axis-aligned bounding box (the zero box when empty).
    pub fn aabb(&self) -> BBox {
        let Some(first) = self.vertices.first() else {
            return BBox::default();
        };
        let (mut x0, mut y0, mut x1, mut y1) = (first.x, first.y, first.x, first.y);
        for p in &self.vertices[1..] {
            x0 = x0.min(p.x);
            y0 = y0.min(p.y);
            x1 = x1.max(p.x);
            y1 = y1.max(p.y);
        }
        BBox::from_xyxy(x0, y0, x1, y1)
    }

    /// Area (0 for points and segments).
    pub fn area(&self) -> f64 {
        signed_area(&self.vertices).max(0.0)
    }

    /// Area centroid; the vertex mean for points and segments; `None` when empty.
    pub fn center(&self) -> Option<Point> {
        let n = self.vertices.len();
        if n == 0 {
            return None;
        }
        let o = self.vertices[0];
        let mean = || {
            let s = self
                .vertices
                .iter()
                .fold(Point::default(), |acc, &p| acc + (p - o));
            o + s * (1.0 / n as f64)
        };
        if n < 3 {
            return Some(mean());
        }
        // Relative to the first vertex so large image coordinates do not cancel.
        let (mut a2, mut cx, mut cy) = (0.0, 0.0, 0.0);
        for i in 0..n {
            let p = self.vertices[i] - o;
            let q = self.vertices[(i + 1) % n] - o;
            let c = p.x * q.y - q.x * p.y;
            a2 += c;
            cx += (p.x + q.x) * c;
            cy += (p.y + q.y) * c;
        }
        if a2.abs() <= f64::MIN_POSITIVE {
            return Some(mean());
        }
        Some(o + Point::new(cx / (3.0 * a2), cy / (3.0 * a2)))
    }

    /// Whether `p` lies in the closed shell, within [`CONTAINS_TOLERANCE`] pixels.
    pub fn contains(&self, p: Point) -> bool {
        self.contains_within(p, CONTAINS_TOLERANCE)
    }

    /// Whether `p` lies within distance `tol` of the closed shell (approximately: for polygons
    /// the test is against each edge's line, which is exact inside and up to `tol·√2` loose
    /// near sharp corners).
    pub fn contains_within(&self, p: Point, tol: f64) -> bool {
        match self.vertices.len() {
            0 => false,
            1 => self.vertices[0].dist(p) <= tol,
            2 => point_segment_distance(p, self.vertices[0], self.vertices[1]) <= tol,
            n => (0..n).all(|i| {
                let a = self.vertices[i];
                let b = self.vertices[(i + 1) % n];
                let e = b - a;
                let len = e.x.hypot(e.y);
                // Signed distance of p to the edge's line, positive inside (left of a CCW edge).
                cross(e, p - a) >= -tol * len
            }),
        }
    }

    /// The vertex furthest in direction `d` (thesis eq. 12); `None` when empty. Ties go to the
    /// first such vertex so results are repeatable.
    pub fn support(&self, d: Point) -> Option<Point> {
        let mut best: Option<(f64, Point)> = None;
        for &v in &self.vertices {
            let s = v.x * d.x + v.y * d.y;
            if best.is_none_or(|(bs, _)| s > bs) {
                best = Some((s, v));
            }
        }
        best.map(|(_, v)| v)
    }
}

/// Whether two boxes overlap or lie within `slack` of each other (closed test).
pub(crate) fn aabbs_overlap(a: &BBox, b: &BBox, slack: f64) -> bool {
    a.x <= b.x2() + slack && b.x <= a.x2() + slack && a.y <= b.y2() + slack && b.y <= a.y2() + slack
}

/// 2-D cross product (z of the 3-D one).
#[inline]
pub(crate) fn cross(a: Point, b: Point) -> f64 {
    a.x * b.y - a.y * b.x
}

/// Shoelace area, positive for counter-clockwise (y-up sense) polygons.
pub(crate) fn signed_area(poly: &[Point]) -> f64 {
    let n = poly.len();
    if n < 3 {
        return 0.0;
    }
    let o = poly[0];
    let mut s = 0.0;
    for i in 1..n - 1 {
        s += cross(poly[i] - o, poly[i + 1] - o);
    }
    s / 2.0
}

/// Distance from `p` to the segment `ab`.
pub(crate) fn point_segment_distance(p: Point, a: Point, b: Point) -> f64 {
    let ab = b - a;
    let l2 = ab.x * ab.x + ab.y * ab.y;
    if l2 <= 0.0 {
        return p.dist(a);
    }
    let t = (((p.x - a.x) * ab.x + (p.y - a.y) * ab.y) / l2).clamp(0.0, 1.0);
    p.dist(a + ab * t)
}

/// Andrew's monotone chain. Points must be finite. Returns the hull CCW (positive area) from the
/// smallest `(x, y)`, without duplicate or collinear vertices; 0–2 points for degenerate input.
pub(crate) fn convex_hull(mut pts: Vec<Point>) -> Vec<Point> {
    hull_tail(&mut pts, 0);
    pts
}

thread_local! {
    /// The monotone chain's output before it is copied back over its input: one buffer per
    /// thread, reused by every hull, where each hull allocated its own (issue 10: the shells
    /// the tracker builds every frame were a fifth of its allocations).
    static CHAIN: std::cell::RefCell<Vec<Point>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Replaces `pts[start..]` by its convex hull ([`convex_hull`]'s, vertex for vertex), in place.
fn hull_tail(pts: &mut Vec<Point>, start: usize) {
    let tail = &mut pts[start..];
    tail.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    // `Vec::dedup` on the tail alone.
    let mut kept = 0;
    for i in 0..tail.len() {
        if i == 0 || tail[i] != tail[kept - 1] {
            tail[kept] = tail[i];
            kept += 1;
        }
    }
    pts.truncate(start + kept);
    if kept <= 2 {
        return;
    }
    with_scratch(&CHAIN, |hull| {
        monotone_chain_into(&pts[start..], hull);
        pts.truncate(start);
        pts.extend_from_slice(hull);
    });
}

/// The convex hull of `pts` (at least three), sorted by `(x, y)` without repeats, into `hull`,
/// which is cleared first (Andrew's monotone chain, as [`convex_hull`] returns it).
fn monotone_chain_into(pts: &[Point], hull: &mut Vec<Point>) {
    hull.clear();
    hull.reserve(pts.len() + 1);
    // The lower chain left to right, then the upper one back: one generic function per
    // direction, where a boxed iterator cost two allocations and a dynamic call per point
    // (8 % of the native tracker's samples on the demo scene went to this function).
    chain(hull, pts.iter());
    chain(hull, pts.iter().rev());
    if hull.len() == 2 && hull[0] == hull[1] {
        hull.truncate(1);
    }
}

/// One chain of [`monotone_chain_into`], appended to `hull`.
fn chain<'a>(hull: &mut Vec<Point>, pts: impl Iterator<Item = &'a Point>) {
    let start = hull.len();
    for &p in pts {
        while hull.len() >= start + 2 {
            let a = hull[hull.len() - 2];
            let b = hull[hull.len() - 1];
            if cross(b - a, p - a) <= 0.0 {
                hull.pop();
            } else {
                break;
            }
        }
        hull.push(p);
    }
    // The last point of each chain is the first of the other.
    hull.pop();
}

/// The convex hull of a mask's pixel squares ([`ConvexShell::from_points`] of every pixel's
/// corners, vertex for vertex) in time linear in its rows: only each row's leftmost and
/// rightmost corners can be vertices, and they come sorted by `y`, so the monotone chain
/// runs on the transposed points without a sort. Every detection's shell is this hull; the
/// sort was most of its cost (issue 10).
pub fn pixel_hull(mask: &Mask) -> ConvexShell {
    let w = mask.width() as usize;
    if w == 0 {
        return ConvexShell::empty();
    }
    let (x0, y0) = (f64::from(mask.x()), f64::from(mask.y()));
    // Per corner height y: the leftmost and rightmost corner x, as two transposed points
    // (y, l), (y, r) in one list, already sorted by (y, x).
    let mut transposed: Vec<Point> = Vec::with_capacity(2 * mask.height() as usize + 2);
    // Comparisons, not `f64::min` / `max`: their NaN rules make them calls in wasm, and these
    // are whole numbers.
    let mut level = |y: f64, l: f64, r: f64| match transposed.len() {
        n if n >= 2 && transposed[n - 2].x == y => {
            if l < transposed[n - 2].y {
                transposed[n - 2].y = l;
            }
            if r > transposed[n - 1].y {
                transposed[n - 1].y = r;
            }
        }
        _ => transposed.extend([Point::new(y, l), Point::new(y, r)]),
    };
    for (ly, row) in mask.data().chunks_exact(w).enumerate() {
        let (Some(a), Some(b)) = (first_nonzero(row), last_nonzero(row)) else {
            continue;
        };
        let y = y0 + ly as f64;
        let (l, r) = (x0 + a as f64, x0 + b as f64 + 1.0);
        level(y, l, r);
        level(y + 1.0, l, r);
    }
    // A row's corners differ in x by at least 1: no repeats. Transposing mirrors the plane:
    // the chain comes back clockwise; reverse it, and start at the smallest (x, y) as
    // `convex_hull` does. The chain is built in the shared buffer, so the points and the
    // hull are this function's only allocations (there were four).
    let back =
        |pts: &[Point]| -> Vec<Point> { pts.iter().rev().map(|p| Point::new(p.y, p.x)).collect() };
    let mut hull = if transposed.len() <= 2 {
        back(&transposed)
    } else {
        with_scratch(&CHAIN, |chain| {
            monotone_chain_into(&transposed, chain);
            back(chain)
        })
    };
    if let Some(first) = hull
        .iter()
        .enumerate()
        .min_by(|(_, a), (_, b)| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)))
        .map(|(i, _)| i)
    {
        hull.rotate_left(first);
    }
    ConvexShell { vertices: hull }
}

/// A triangle mesh for drawing: the Delaunay triangulation behind a shell.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Mesh {
    /// Vertex positions in image coordinates.
    pub vertices: Vec<Point>,
    /// Triangles as indices into `vertices`, each counter-clockwise (positive area).
    pub triangles: Vec<[usize; 3]>,
}

impl Mesh {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// The Delaunay triangulation (spade) of `points`, computed relative to `origin` so the
    /// robust predicates see small coordinates. Fewer than three non-collinear points give a
    /// mesh with vertices and no triangle.
    pub fn delaunay(points: &[Point], origin: Point) -> Result<Mesh, GeometryError> {
        let local: Vec<Point2<f64>> = points
            .iter()
            .map(|p| Point2::new(p.x - origin.x, p.y - origin.y))
            .collect();
        // The stable bulk load keeps vertex handles in input order, so the mesh indexes the
        // caller's points and the result does not depend on hashing or insertion order.
        let tri = DelaunayTriangulation::<Point2<f64>>::bulk_load_stable(local).map_err(|e| {
            GeometryError::Triangulation {
                reason: format!("{e:?}"),
            }
        })?;
        let vertices: Vec<Point> = tri
            .vertices()
            .map(|v| {
                let p = v.position();
                Point::new(p.x + origin.x, p.y + origin.y)
            })
            .collect();
        let triangles = tri
            .inner_faces()
            .map(|f| {
                let [a, b, c] = f.vertices();
                [a.fix().index(), b.fix().index(), c.fix().index()]
            })
            .collect();
        Ok(Mesh {
            vertices,
            triangles,
        })
    }

    /// The outer boundary of the mesh (thesis: "the triangular mesh's outermost boundary forms
    /// a convex polygon shell"), rebuilt as a [`ConvexShell`] from the triangles' vertices;
    /// for a mesh without triangles, the hull of its vertices.
    pub fn outer_boundary(&self) -> ConvexShell {
        let pts: Vec<Point> = if self.triangles.is_empty() {
            self.vertices.clone()
        } else {
            self.triangles
                .iter()
                .flat_map(|t| t.iter().filter_map(|&i| self.vertices.get(i).copied()))
                .collect()
        };
        ConvexShell {
            vertices: convex_hull(pts),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The row-by-row pixel hull is the hull of every pixel's corners, vertex for vertex, on
    /// random blobs with holes, gaps between rows, single pixels, lines and offsets.
    #[test]
    fn pixel_hull_is_the_hull_of_every_pixel_corner() {
        let mut s = 31u64;
        let mut next = |n: u64| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 33) % n
        };
        for case in 0..300 {
            let (w, h) = (1 + next(14) as u32, 1 + next(14) as u32);
            let density = 1 + next(4);
            let bits: Vec<u8> = (0..w * h).map(|_| u8::from(next(4) < density)).collect();
            let (x, y) = (next(50) as i32 - 25, next(50) as i32 - 25);
            let mask = Mask::new(x, y, w, h, bits).unwrap();
            let corners: Vec<Point> = (0..h as i32)
                .flat_map(|ly| (0..w as i32).map(move |lx| (lx, ly)))
                .filter(|&(lx, ly)| mask.get(x + lx, y + ly))
                .flat_map(|(lx, ly)| {
                    let (px, py) = (f64::from(x + lx), f64::from(y + ly));
                    [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                        .map(|(dx, dy)| Point::new(px + dx, py + dy))
                })
                .collect();
            let want = ConvexShell::from_points(&corners).unwrap();
            assert_eq!(pixel_hull(&mask), want, "case {case}: {mask:?}");
        }
        assert_eq!(pixel_hull(&Mask::empty()), ConvexShell::empty());
    }

    fn sq() -> ConvexShell {
        ConvexShell::from_points(&[
            Point::new(0.0, 0.0),
            Point::new(4.0, 0.0),
            Point::new(4.0, 4.0),
            Point::new(0.0, 4.0),
            Point::new(2.0, 2.0),
            Point::new(2.0, 0.0),
        ])
        .unwrap()
    }

    #[test]
    fn hull_drops_interior_and_collinear_points() {
        let s = sq();
        assert_eq!(
            s.vertices(),
            &[
                Point::new(0.0, 0.0),
                Point::new(4.0, 0.0),
                Point::new(4.0, 4.0),
                Point::new(0.0, 4.0)
            ]
        );
        assert!((s.area() - 16.0).abs() < 1e-12);
        assert!(signed_area(s.vertices()) > 0.0);
        assert_eq!(s.center(), Some(Point::new(2.0, 2.0)));
    }

    #[test]
    fn degenerate_hulls() {
        let p = ConvexShell::from_points(&[Point::new(1.0, 1.0); 3]).unwrap();
        assert_eq!(p.len(), 1);
        let s = ConvexShell::from_points(&[
            Point::new(0.0, 0.0),
            Point::new(2.0, 2.0),
            Point::new(1.0, 1.0),
        ])
        .unwrap();
        assert_eq!(s.len(), 2);
        assert!(s.contains(Point::new(0.5, 0.5)));
        assert!(!s.contains(Point::new(0.5, 0.6)));
        assert!(ConvexShell::from_points(&[]).unwrap().is_empty());
        assert!(matches!(
            ConvexShell::from_points(&[Point::new(f64::NAN, 0.0)]),
            Err(GeometryError::NonFinitePoint { .. })
        ));
    }

    #[test]
    fn grown_point_is_octagon_around_disc() {
        let p = ConvexShell::from_points(&[Point::new(10.0, 10.0)]).unwrap();
        let g = p.grown(2.0);
        assert_eq!(g.len(), 8);
        for k in 0..64 {
            let a = k as f64 / 64.0 * std::f64::consts::TAU;
            assert!(g.contains(Point::new(10.0 + 2.0 * a.cos(), 10.0 + 2.0 * a.sin())));
        }
        // Overshoot bound: no vertex further than margin / cos(π/8).
        for v in g.vertices() {
            assert!(
                v.dist(Point::new(10.0, 10.0)) <= 2.0 / (std::f64::consts::PI / 8.0).cos() + 1e-9
            );
        }
        assert_eq!(p.grown(-1.0), p);
        assert_eq!(p.grown(f64::NAN), p);
    }

    /// Many-sided shells take `grown`'s corner-on-the-bisector path (no trigonometry) at
    /// nearly every corner: the result must still contain every point `margin` from the shell
    /// and have no vertex nearer than `margin` or farther than `margin / cos(π/8)`.
    #[test]
    fn grown_many_sided_shells_keep_the_disc_sum_within_its_bound() {
        let dist_to_shell = |s: &ConvexShell, p: Point| -> f64 {
            let v = s.vertices();
            (0..v.len())
                .map(|i| point_segment_distance(p, v[i], v[(i + 1) % v.len()]))
                .fold(f64::INFINITY, f64::min)
        };
        for (sides, stretch) in [(7, 1.0), (24, 1.0), (40, 3.5), (5, 0.2)] {
            let pts: Vec<Point> = (0..sides)
                .map(|k| {
                    let a = k as f64 / sides as f64 * std::f64::consts::TAU + 0.1;
                    Point::new(50.0 + 20.0 * stretch * a.cos(), 40.0 + 20.0 * a.sin())
                })
                .collect();
            let shell = ConvexShell::from_points(&pts).unwrap();
            let margin = 3.0;
            let g = shell.grown(margin);
            let bound = margin / (std::f64::consts::PI / 8.0).cos();
            for &v in g.vertices() {
                let d = dist_to_shell(&shell, v);
                assert!(d >= margin - 1e-9 && d <= bound + 1e-9, "{sides}: {d}");
            }
            for &v in shell.vertices() {
                for k in 0..32 {
                    let a = k as f64 / 32.0 * std::f64::consts::TAU;
                    let p = Point::new(v.x + margin * a.cos(), v.y + margin * a.sin());
                    assert!(g.contains(p), "{sides}: {p:?} outside");
                }
            }
        }
    }

    #[test]
    fn translated_and_swept() {
        let s = sq().translated(1.0, -1.0);
        assert_eq!(s.aabb(), BBox::new(1.0, -1.0, 4.0, 4.0));
        assert_eq!(sq().translated(f64::INFINITY, 0.0), sq());
        let w = sq().swept(10.0, 0.0);
        assert_eq!(w.aabb(), BBox::new(0.0, 0.0, 14.0, 4.0));
        assert!((w.area() - 56.0).abs() < 1e-9);
    }

    #[test]
    fn serde_rebuilds_hull() {
        let json = "[{\"x\":0,\"y\":0},{\"x\":0,\"y\":4},{\"x\":4,\"y\":0},{\"x\":1,\"y\":1}]";
        let s: ConvexShell = serde_json::from_str(json).unwrap();
        assert_eq!(s.len(), 3);
        assert!(signed_area(s.vertices()) > 0.0);
    }

    #[test]
    fn delaunay_boundary_is_hull() {
        let pts = [
            Point::new(100.0, 100.0),
            Point::new(104.0, 100.0),
            Point::new(104.0, 104.0),
            Point::new(100.0, 104.0),
            Point::new(102.0, 102.0),
        ];
        let m = Mesh::delaunay(&pts, Point::new(100.0, 100.0)).unwrap();
        assert_eq!(m.triangle_count(), 4);
        assert_eq!(m.vertices, pts.to_vec());
        for t in &m.triangles {
            let tri = [m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]]];
            assert!(signed_area(&tri) > 0.0);
        }
        assert_eq!(m.outer_boundary(), ConvexShell::from_points(&pts).unwrap());
    }
}
