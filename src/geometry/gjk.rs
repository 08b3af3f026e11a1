//! GJK intersection tests between convex shells: parry2d's (used by the tracker) and the
//! thesis' own Algorithm 2 (kept as a documented cross-check).

use parry2d::math::{Pose, Vector};
use parry2d::query::details::{
    distance_support_map_support_map, intersection_test_support_map_support_map,
};
use parry2d::shape::{ConvexPolygon, Segment, SupportMap};
use std::sync::OnceLock;

use super::shell::{aabbs_overlap, cross, point_segment_distance, ConvexShell, TOUCH_TOLERANCE};
use crate::frame::{BBox, Point};

// The shells' GJK queries live here, beside the prepared shapes they run on, so that
// `shell` (the triangulation and hull) does not depend back on this module.
impl ConvexShell {
    /// Whether the two closed shells intersect (touching counts, up to f32 rounding), by
    /// parry2d's GJK after a bounding-box early-out. Empty shells intersect nothing.
    pub fn intersects(&self, other: &ConvexShell) -> bool {
        if !aabbs_overlap(&self.aabb(), &other.aabb(), TOUCH_TOLERANCE)
            || self.is_empty()
            || other.is_empty()
        {
            return false;
        }
        PreparedShell::new(self).intersects(&PreparedShell::new(other))
    }

    /// Euclidean distance between the shells (0 when they intersect), by parry2d's GJK, which
    /// stops when its bounds agree to ~0.35% (relative) — meant for gating, not measuring;
    /// `f64::INFINITY` when either is empty.
    pub fn distance(&self, other: &ConvexShell) -> f64 {
        PreparedShell::new(self).distance(&PreparedShell::new(other))
    }
}

/// How far inside a shell, in pixels, a point must lie for [`PreparedShell::intersects_fast`]
/// to accept a pair without GJK: far above parry's f32 rounding on the shells' local
/// coordinates (~1e-4 px at a few thousand pixels), far below a pixel.
const DEEP_INSIDE: f64 = 0.01;

/// A shell converted once into parry2d's f32 representation, for repeated GJK queries.
///
/// parry2d computes in f32 (glam `Vec2`). Image coordinates of a 4K frame already lose
/// ~5·10⁻⁴ px in f32, and a tracker fed with georeferenced or stitched images can see much
/// larger values, so each shell is stored relative to its own local origin (its first vertex,
/// kept in f64), and a pair query passes the difference of the two origins — computed in f64,
/// small whenever the shells are close enough to matter — as parry's relative pose. The f32
/// error is then relative to the shells' sizes and separation, not to their position.
#[derive(Debug, Clone)]
pub struct PreparedShell<'a> {
    origin: Point,
    /// The mean of the vertices: a point inside the shell (convex), for
    /// [`PreparedShell::intersects`]' fast accept.
    inner: Point,
    aabb: BBox,
    /// The f32 form for parry, built on the first GJK query ([`PreparedShell::new`]).
    local: OnceLock<Local>,
    /// The f64 shell, for the exact fallback when the f32 conversion is unusable: borrowed,
    /// where a copy was one more allocation per shell and frame (issue 10).
    shell: &'a ConvexShell,
}

#[derive(Debug, Clone)]
enum Local {
    Empty,
    Polygon(ConvexPolygon),
    /// A segment or, with both ends equal, a point (what one-pixel masks give).
    Segment(Segment),
    /// Coordinates too large for f32 even locally: queries use the f64 thesis GJK.
    Unrepresentable,
}

/// `shell`'s vertices relative to `origin`, in f32, as the parry shape GJK queries.
fn local_shape(shell: &ConvexShell, origin: Point) -> Local {
    let verts = shell.vertices();
    let mut local: Vec<Vector> = Vec::with_capacity(verts.len());
    let mut finite = true;
    for p in verts {
        let v = Vector::new((p.x - origin.x) as f32, (p.y - origin.y) as f32);
        finite &= v.x.is_finite() && v.y.is_finite();
        // Distinct f64 vertices can round to the same f32 point; parry needs distinct
        // consecutive vertices to compute edge normals.
        if local.last() != Some(&v) {
            local.push(v);
        }
    }
    if local.len() > 1 && local.first() == local.last() {
        local.pop();
    }
    if !finite {
        return Local::Unrepresentable;
    }
    match local.len() {
        0 => Local::Empty,
        1 => Local::Segment(Segment::new(local[0], local[0])),
        2 => Local::Segment(Segment::new(local[0], local[1])),
        // No vertex removal here: parry's `from_convex_polyline` drops vertices whose
        // edges turn by less than ~1.5° (its f32 epsilon), which can shave a pixel off
        // a long edge; our hull already has no collinear vertex.
        _ => match ConvexPolygon::from_convex_polyline_unmodified(local) {
            Some(p) => Local::Polygon(p),
            None => Local::Unrepresentable,
        },
    }
}

impl<'a> PreparedShell<'a> {
    /// Prepares `shell` for queries. Its f32 form for parry (the local vertices and parry's
    /// edge normals: two allocations) is built on the first query that needs GJK, then
    /// reused: most pairs of a crowd are accepted without GJK ([`PreparedShell::intersects_fast`]),
    /// and building it for every shell of every frame was the tracker's largest source of
    /// allocations (issue 10: 47 of 370 a frame on the default scene).
    pub fn new(shell: &'a ConvexShell) -> Self {
        let verts = shell.vertices();
        let origin = verts.first().copied().unwrap_or_default();
        let inner = if verts.is_empty() {
            origin
        } else {
            let sum = verts.iter().fold(Point::default(), |acc, p| acc + *p);
            sum * (1.0 / verts.len() as f64)
        };
        Self {
            origin,
            inner,
            aabb: shell.aabb(),
            local: OnceLock::new(),
            shell,
        }
    }

    /// The shell in parry's f32 form, relative to `origin` (built on first use).
    fn shape(&self) -> &Local {
        self.local
            .get_or_init(|| local_shape(self.shell, self.origin))
    }

    /// Whether the shell has no vertex (never intersects anything).
    fn is_empty(&self) -> bool {
        self.shell.vertices().is_empty()
    }

    /// The shell's bounding box.
    pub fn aabb(&self) -> BBox {
        self.aabb
    }

    /// The f64 shell this was built from.
    pub fn shell(&self) -> &'a ConvexShell {
        self.shell
    }

    fn support_map(&self) -> Option<&dyn SupportMap> {
        match self.shape() {
            Local::Polygon(p) => Some(p),
            Local::Segment(s) => Some(s),
            Local::Empty | Local::Unrepresentable => None,
        }
    }

    /// Pose of `other`'s local frame in `self`'s, or `None` if it does not fit in f32.
    fn pose_to(&self, other: &PreparedShell) -> Option<Pose> {
        let dx = (other.origin.x - self.origin.x) as f32;
        let dy = (other.origin.y - self.origin.y) as f32;
        (dx.is_finite() && dy.is_finite()).then(|| Pose::translation(dx, dy))
    }

    /// Whether `p` lies inside this shell by at least [`DEEP_INSIDE`] from every edge: then
    /// any shell containing `p` meets this one, and parry's GJK (in f32) says so too, since
    /// the overlap is far deeper than its rounding. `O(n)` with no root or division, against
    /// GJK's iterations of support-point searches: in a crowd most candidate pairs overlap
    /// deeply (issue 10: GJK was a sixth of the 200-shape frame's region time).
    fn surely_contains(&self, p: Point) -> bool {
        let v = self.shell.vertices();
        if v.len() < 3 || !(p.x.is_finite() && p.y.is_finite()) {
            return false;
        }
        // Inside a convex polygon: on the same side of every edge, whichever the winding.
        let (mut pos, mut neg) = (true, true);
        for (i, &a) in v.iter().enumerate() {
            let b = v[(i + 1) % v.len()];
            let (ex, ey) = (b.x - a.x, b.y - a.y);
            let c = ex * (p.y - a.y) - ey * (p.x - a.x);
            // Distance to the edge's line is |c| / |e|: compare squares.
            let deep = c * c >= DEEP_INSIDE * DEEP_INSIDE * (ex * ex + ey * ey);
            pos &= c > 0.0 && deep;
            neg &= c < 0.0 && deep;
            if !(pos || neg) {
                return false;
            }
        }
        pos || neg
    }

    /// Whether the shells intersect: accepted at once when `other`'s inner point lies deep
    /// inside this shell (`surely_contains`), else parry2d's GJK test
    /// ([`PreparedShell::intersects_gjk`]); the same answer as GJK alone. No bounding-box
    /// early-out (the broad phase does that).
    pub fn intersects_fast(&self, other: &PreparedShell) -> bool {
        if self.is_empty() || other.is_empty() {
            return false;
        }
        self.surely_contains(other.inner) || self.intersects_gjk(other)
    }

    /// parry2d's GJK intersection test, without any bounding-box early-out (the broad phase
    /// does that). Touching shells may go either way within f32 rounding.
    pub fn intersects_gjk(&self, other: &PreparedShell) -> bool {
        if self.is_empty() || other.is_empty() {
            return false;
        }
        match (self.support_map(), other.support_map(), self.pose_to(other)) {
            (Some(a), Some(b), Some(pos12)) => {
                intersection_test_support_map_support_map(&pos12, a, b)
            }
            _ => intersects_thesis(self.shell, other.shell),
        }
    }

    /// Bounding-box early-out (with [`TOUCH_TOLERANCE`] slack), then GJK.
    pub fn intersects(&self, other: &PreparedShell) -> bool {
        aabbs_overlap(&self.aabb, &other.aabb, TOUCH_TOLERANCE) && self.intersects_gjk(other)
    }

    /// Distance between the shells by parry2d's GJK (0 when they intersect); `f64::INFINITY`
    /// when either is empty.
    pub fn distance(&self, other: &PreparedShell) -> f64 {
        if self.is_empty() || other.is_empty() {
            return f64::INFINITY;
        }
        match (self.support_map(), other.support_map(), self.pose_to(other)) {
            (Some(a), Some(b), Some(pos12)) => {
                distance_support_map_support_map(&pos12, a, b) as f64
            }
            _ => distance_exact(self.shell, other.shell),
        }
    }
}

/// Exact f64 distance between two shells by brute force over vertex–edge pairs (`O(nm)`), 0
/// when they intersect. The fallback for shells f32 cannot represent.
fn distance_exact(a: &ConvexShell, b: &ConvexShell) -> f64 {
    if a.is_empty() || b.is_empty() {
        return f64::INFINITY;
    }
    if intersects_thesis(a, b) {
        return 0.0;
    }
    let edges = |s: &ConvexShell| -> Vec<(Point, Point)> {
        let v = s.vertices();
        (0..v.len()).map(|i| (v[i], v[(i + 1) % v.len()])).collect()
    };
    let mut best = f64::INFINITY;
    for (p, q) in [(a, b), (b, a)] {
        for &v in p.vertices() {
            for (e0, e1) in edges(q) {
                best = best.min(point_segment_distance(v, e0, e1));
            }
        }
    }
    best
}

/// Iteration cap for [`intersects_thesis`]. Algorithm 2 loops "while true"; on polygons GJK
/// adds a new Minkowski-difference vertex every round unless the origin sits on the
/// difference's boundary (touching shells), where rounding can make it cycle.
const THESIS_MAX_ITER: usize = 64;

/// The thesis' GJK (Algorithm 2, `GJK`/`supportPoint`/`lineCase`/`triangleCase`), in f64.
///
/// The support point of the Minkowski difference `A ⊖ B` in direction `d` is
/// `A.furthest(d) − B.furthest(−d)` (eq. 11–12). Starting from the direction between the
/// shells' centres, each round adds the support point towards the origin; if it does not pass
/// the origin (`A·d < 0`, eq. 13) the shells are disjoint. Two points: the next direction is
/// the segment's normal towards the origin, by the triple product `(AB × AO) × AB`. Three
/// points: the origin is tested against the Voronoi regions of edges AB and AC (eq. 14–15);
/// outside one of them, the far vertex is dropped and the search continues along that edge's
/// normal; inside neither, the triangle encloses the origin and the shells intersect.
///
/// Additions to the thesis, for termination and degenerate input: empty shells never
/// intersect; a zero direction (the origin lies on the current segment, i.e. the shells touch)
/// returns `true`; the loop stops after a fixed number of rounds and then answers `false`
/// (only reached when the origin is on the boundary, i.e. touching within rounding).
pub fn intersects_thesis(a: &ConvexShell, b: &ConvexShell) -> bool {
    let (Some(ca), Some(cb)) = (a.center(), b.center()) else {
        return false;
    };
    // supportPoint: differences of image coordinates, so the simplex lives near the origin
    // whatever the shells' position in the image.
    let support = |d: Point| -> Option<Point> {
        let pa = a.support(d)?;
        let pb = b.support(Point::new(-d.x, -d.y))?;
        Some(pa - pb)
    };
    let dot = |u: Point, v: Point| u.x * v.x + u.y * v.y;
    let mut d = normalize(ca - cb).unwrap_or(Point::new(1.0, 0.0));
    let Some(first) = support(d) else {
        return false;
    };
    let mut simplex: Vec<Point> = vec![first];
    // d = O − simplex[0]
    d = match normalize(Point::new(-first.x, -first.y)) {
        Some(d) => d,
        // The origin is itself a support point: the shells touch.
        None => return true,
    };
    let max_iter = THESIS_MAX_ITER + a.len() + b.len();
    for _ in 0..max_iter {
        let Some(p) = support(d) else {
            return false;
        };
        if dot(p, d) < 0.0 {
            return false;
        }
        simplex.push(p);
        match simplex.as_slice() {
            // lineCase
            [bp, ap] => {
                let (bp, ap) = (*bp, *ap);
                let ab = bp - ap;
                let ao = Point::new(-ap.x, -ap.y);
                match normalize(triple_product(ab, ao, ab)) {
                    Some(n) => d = n,
                    // AO ∥ AB: the origin is on the line through A and B, and A passed it
                    // coming from B, so it lies on the segment.
                    None => return true,
                }
            }
            // triangleCase
            [cp, bp, ap] => {
                let (cp, bp, ap) = (*cp, *bp, *ap);
                let ab = bp - ap;
                let ac = cp - ap;
                let ao = Point::new(-ap.x, -ap.y);
                let ab_perp = triple_product(ac, ab, ab);
                let ac_perp = triple_product(ab, ac, ac);
                if dot(ab_perp, ao) > 0.0 {
                    simplex.remove(0); // C
                    match normalize(ab_perp) {
                        Some(n) => d = n,
                        None => return false,
                    }
                } else if dot(ac_perp, ao) > 0.0 {
                    simplex.remove(1); // B
                    match normalize(ac_perp) {
                        Some(n) => d = n,
                        None => return false,
                    }
                } else {
                    // A zero-area triangle "contains" the origin only if the origin is on it.
                    let o = Point::default();
                    if cross(ab, ac).abs() <= 1e-12 * ab.dist(o) * ac.dist(o) {
                        return point_segment_distance(o, bp, ap)
                            .min(point_segment_distance(o, cp, ap))
                            <= 1e-12 * (1.0 + ap.dist(o));
                    }
                    return true;
                }
            }
            _ => return false,
        }
    }
    false
}

/// `(a × b) × c` for 2-D vectors embedded in 3-D: `b(a·c) − a(b·c)`.
fn triple_product(a: Point, b: Point, c: Point) -> Point {
    let ac = a.x * c.x + a.y * c.y;
    let bc = b.x * c.x + b.y * c.y;
    Point::new(b.x * ac - a.x * bc, b.y * ac - a.y * bc)
}

/// The unit vector along `v`, or `None` if `v` is (numerically) zero or not finite.
fn normalize(v: Point) -> Option<Point> {
    let n = v.x.hypot(v.y);
    (n > f64::MIN_POSITIVE * 1e10 && n.is_finite()).then(|| Point::new(v.x / n, v.y / n))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(x: f64, y: f64, s: f64) -> ConvexShell {
        ConvexShell::from_bbox(&BBox::new(x, y, s, s)).unwrap()
    }

    #[test]
    fn thesis_and_parry_on_simple_cases() {
        let a = square(0.0, 0.0, 10.0);
        for (b, want) in [
            (square(5.0, 5.0, 10.0), true),
            (square(11.0, 0.0, 10.0), false),
            (square(2.0, 2.0, 1.0), true), // nested
            (square(-20.0, -20.0, 5.0), false),
        ] {
            assert_eq!(intersects_thesis(&a, &b), want, "{b:?}");
            assert_eq!(intersects_thesis(&b, &a), want, "{b:?}");
            assert_eq!(a.intersects(&b), want, "{b:?}");
            assert_eq!(b.intersects(&a), want, "{b:?}");
        }
        let p = ConvexShell::from_points(&[Point::new(3.0, 3.0)]).unwrap();
        assert!(intersects_thesis(&a, &p) && a.intersects(&p));
        let far = ConvexShell::from_points(&[Point::new(30.0, 3.0)]).unwrap();
        assert!(!intersects_thesis(&a, &far) && !a.intersects(&far));
        assert!(!a.intersects(&ConvexShell::empty()));
        assert!(!intersects_thesis(&a, &ConvexShell::empty()));
    }

    #[test]
    fn distance_is_gap() {
        let a = square(0.0, 0.0, 10.0);
        let b = square(13.0, 0.0, 10.0);
        assert!((a.distance(&b) - 3.0).abs() < 1e-4);
        assert_eq!(a.distance(&square(5.0, 5.0, 2.0)), 0.0);
        assert!((distance_exact(&a, &b) - 3.0).abs() < 1e-12);
        assert_eq!(a.distance(&ConvexShell::empty()), f64::INFINITY);
    }

    #[test]
    fn local_origin_keeps_precision_far_from_zero() {
        // At x = 10⁷ one f32 ulp is 1 px: absolute f32 coordinates could not tell a 0.05 px
        // gap from an overlap; relative coordinates can.
        let a = square(1e7, 1e7, 10.0);
        let b = square(1e7 + 10.05, 1e7, 10.0);
        assert!(!a.intersects(&b));
        assert!((a.distance(&b) - 0.05).abs() < 1e-3);
        let c = square(1e7 + 9.95, 1e7, 10.0);
        assert!(a.intersects(&c));
    }
}
