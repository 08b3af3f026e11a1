//! Test-only generators and a brute-force oracle shared by the geometry and region tests.
//!
//! The oracle deliberately shares no code with the library: exact-as-f64 segment tests and
//! point-in-polygon, the textbook way.
#![allow(dead_code)]

use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use shapetrack::geometry::ConvexShell;
use shapetrack::{Mask, Point};

/// Property-test config with a fixed seed, so CI runs are repeatable.
pub fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_seed: RngSeed::Fixed(0x5_4a9e_7ac4),
        failure_persistence: None,
        ..Config::default()
    }
}

/// Shells closer than this (separation or penetration depth, in px) may be reported either
/// way: "touching" for parry2d's f32 GJK (see `TOUCH_TOLERANCE`).
pub const PARRY_BAND: f64 = 1e-3;
/// The same for the f64 thesis GJK.
pub const THESIS_BAND: f64 = 1e-6;

// ---------------------------------------------------------------------------------------------
// Generators

/// Where a pair of shapes lives in the image: near 0, in a 4K frame, and far beyond any frame
/// (f32 precision matters there).
pub fn offset() -> impl Strategy<Value = Point> {
    prop_oneof![
        Just(Point::new(0.0, 0.0)),
        Just(Point::new(1234.5, 987.25)),
        Just(Point::new(1.0e5, -3.0e4)),
        Just(Point::new(3.3e6, 2.1e6)),
    ]
}

/// A random convex shell around `c`: 1–11 points on a rotated ellipse (jittered radially),
/// hulled. One or two points give the degenerate point and segment shells.
pub fn shell_near(c: Point) -> impl Strategy<Value = ConvexShell> {
    (
        -40.0..40.0f64,
        -40.0..40.0f64,
        0.5..30.0f64,
        0.5..30.0f64,
        0.0..std::f64::consts::PI,
        prop::collection::vec((0.0..std::f64::consts::TAU, 0.3..1.0f64), 1..12),
    )
        .prop_map(move |(dx, dy, rx, ry, rot, pts)| {
            let (s, co) = rot.sin_cos();
            let v: Vec<Point> = pts
                .iter()
                .map(|&(a, r)| {
                    let (x, y) = (rx * r * a.cos(), ry * r * a.sin());
                    Point::new(c.x + dx + co * x - s * y, c.y + dy + s * x + co * y)
                })
                .collect();
            ConvexShell::from_points(&v).unwrap()
        })
}

/// A random shell at a random offset.
pub fn shell() -> impl Strategy<Value = ConvexShell> {
    offset().prop_flat_map(shell_near)
}

/// Which kind of pair a generated case is, for coverage counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PairKind {
    /// Independent shapes near each other.
    Random,
    /// One inside the other.
    Nested,
    /// Sharing (part of) an edge, then pushed apart or together by `delta`.
    EdgeTouch,
    /// Sharing one vertex (point reflection), then pushed apart or together.
    VertexTouch,
}

fn unit(v: Point) -> Point {
    let n = v.x.hypot(v.y);
    if n > 0.0 {
        v * (1.0 / n)
    } else {
        Point::new(1.0, 0.0)
    }
}

/// Pushes used for touching cases: well apart, just apart, exactly touching, just overlapping.
fn delta() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(0.0),
        Just(1e-9),
        Just(-1e-9),
        Just(1e-4),
        Just(-1e-4),
        Just(1e-2),
        Just(-1e-2),
        Just(0.3),
        Just(-0.3),
        Just(3.0),
    ]
}

/// Pairs of shells covering random, nested, edge-touching and vertex-touching configurations.
pub fn shell_pair() -> impl Strategy<Value = (PairKind, ConvexShell, ConvexShell)> {
    offset().prop_flat_map(|o| {
        let random = (shell_near(o), shell_near(o)).prop_map(|(a, b)| (PairKind::Random, a, b));
        let nested = (shell_near(o), 0.05..0.95f64, any::<bool>()).prop_map(|(a, s, swap)| {
            let c = a.center().unwrap();
            let v: Vec<Point> = a.vertices().iter().map(|&p| c + (p - c) * s).collect();
            let b = ConvexShell::from_points(&v).unwrap();
            if swap {
                (PairKind::Nested, b, a)
            } else {
                (PairKind::Nested, a, b)
            }
        });
        let edge = (
            shell_near(o),
            any::<prop::sample::Index>(),
            0.0..0.5f64,
            0.5..1.0f64,
            prop::collection::vec((0.0..1.0f64, 0.1..20.0f64), 1..6),
            delta(),
        )
            .prop_map(|(a, ei, t0, t1, beyond, d)| {
                let v = a.vertices();
                if v.len() < 2 {
                    return (PairKind::EdgeTouch, a.clone(), a);
                }
                let i = ei.index(v.len());
                let (p, q) = (v[i], v[(i + 1) % v.len()]);
                let e = q - p;
                // Outward normal of a CCW (positive area) edge: the edge turned clockwise in
                // y-up terms.
                let n = unit(Point::new(e.y, -e.x));
                let (s0, s1) = (p + e * t0, p + e * t1);
                let mut pts = vec![s0, s1];
                for &(t, h) in &beyond {
                    pts.push(p + e * (t0 + (t1 - t0) * t) + n * h);
                }
                let pts: Vec<Point> = pts.into_iter().map(|x| x + n * d).collect();
                (
                    PairKind::EdgeTouch,
                    a,
                    ConvexShell::from_points(&pts).unwrap(),
                )
            });
        let vertex =
            (shell_near(o), any::<prop::sample::Index>(), delta()).prop_map(|(a, vi, d)| {
                let v = a.vertices();
                let p = v[vi.index(v.len())];
                let dir = unit(p - a.center().unwrap());
                let pts: Vec<Point> = v.iter().map(|&x| p * 2.0 - x + dir * d).collect();
                (
                    PairKind::VertexTouch,
                    a.clone(),
                    ConvexShell::from_points(&pts).unwrap(),
                )
            });
        prop_oneof![random, nested, edge, vertex]
    })
}

/// A random mask from a seed: a few filled ellipses and rectangles, thin lines and isolated
/// pixels, at a random image position (so several parts, holes and one-pixel features occur).
pub fn random_mask(seed: u64) -> Mask {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let w: u32 = rng.gen_range(1..48);
    let h: u32 = rng.gen_range(1..48);
    let mut d = vec![0u8; (w * h) as usize];
    let set = |d: &mut Vec<u8>, x: i64, y: i64, v: u8| {
        if x >= 0 && y >= 0 && (x as u32) < w && (y as u32) < h {
            d[(y as u32 * w + x as u32) as usize] = v;
        }
    };
    for _ in 0..rng.gen_range(1..5) {
        let kind = rng.gen_range(0..4);
        let cx = rng.gen_range(0.0..w as f64);
        let cy = rng.gen_range(0.0..h as f64);
        let rx = rng.gen_range(0.5..(w as f64).max(1.0));
        let ry = rng.gen_range(0.5..(h as f64).max(1.0));
        let v = if rng.gen_bool(0.8) { 1 } else { 0 };
        match kind {
            0 => {
                for y in 0..h as i64 {
                    for x in 0..w as i64 {
                        let (dx, dy) = ((x as f64 + 0.5 - cx) / rx, (y as f64 + 0.5 - cy) / ry);
                        if dx * dx + dy * dy <= 1.0 {
                            set(&mut d, x, y, v);
                        }
                    }
                }
            }
            1 => {
                for y in (cy - ry / 2.0) as i64..(cy + ry / 2.0) as i64 {
                    for x in (cx - rx / 2.0) as i64..(cx + rx / 2.0) as i64 {
                        set(&mut d, x, y, v);
                    }
                }
            }
            2 => {
                let (x1, y1) = (rng.gen_range(0.0..w as f64), rng.gen_range(0.0..h as f64));
                for k in 0..=64 {
                    let t = k as f64 / 64.0;
                    set(
                        &mut d,
                        (cx + (x1 - cx) * t) as i64,
                        (cy + (y1 - cy) * t) as i64,
                        1,
                    );
                }
            }
            _ => {
                for _ in 0..rng.gen_range(1..6) {
                    set(
                        &mut d,
                        rng.gen_range(0..w) as i64,
                        rng.gen_range(0..h) as i64,
                        1,
                    );
                }
            }
        }
    }
    let x0 = rng.gen_range(-50..2000);
    let y0 = rng.gen_range(-50..2000);
    Mask::new(x0, y0, w, h, d).unwrap()
}

// ---------------------------------------------------------------------------------------------
// Brute-force oracle

fn cross(a: Point, b: Point) -> f64 {
    a.x * b.y - a.y * b.x
}

fn orient(a: Point, b: Point, c: Point) -> f64 {
    cross(b - a, c - a)
}

fn within(a: Point, b: Point, p: Point) -> bool {
    p.x >= a.x.min(b.x) && p.x <= a.x.max(b.x) && p.y >= a.y.min(b.y) && p.y <= a.y.max(b.y)
}

/// Whether closed segments `p1p2` and `q1q2` meet (zero-length segments allowed).
pub fn segments_intersect(p1: Point, p2: Point, q1: Point, q2: Point) -> bool {
    let d1 = orient(q1, q2, p1);
    let d2 = orient(q1, q2, p2);
    let d3 = orient(p1, p2, q1);
    let d4 = orient(p1, p2, q2);
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    (d1 == 0.0 && within(q1, q2, p1))
        || (d2 == 0.0 && within(q1, q2, p2))
        || (d3 == 0.0 && within(p1, p2, q1))
        || (d4 == 0.0 && within(p1, p2, q2))
}

/// The boundary segments of a shell (a point is one zero-length segment).
pub fn edges(s: &ConvexShell) -> Vec<(Point, Point)> {
    let v = s.vertices();
    match v.len() {
        0 => vec![],
        1 => vec![(v[0], v[0])],
        2 => vec![(v[0], v[1])],
        n => (0..n).map(|i| (v[i], v[(i + 1) % n])).collect(),
    }
}

/// Point in a closed convex polygon with ≥ 3 CCW vertices.
pub fn point_in_polygon(s: &ConvexShell, p: Point) -> bool {
    let v = s.vertices();
    v.len() >= 3 && (0..v.len()).all(|i| orient(v[i], v[(i + 1) % v.len()], p) >= 0.0)
}

/// Brute-force intersection: some pair of edges meets, or one shape has a vertex inside the
/// other (nesting).
pub fn brute_intersects(a: &ConvexShell, b: &ConvexShell) -> bool {
    if a.is_empty() || b.is_empty() {
        return false;
    }
    let (ea, eb) = (edges(a), edges(b));
    ea.iter().any(|&(p1, p2)| {
        eb.iter()
            .any(|&(q1, q2)| segments_intersect(p1, p2, q1, q2))
    }) || point_in_polygon(b, a.vertices()[0])
        || point_in_polygon(a, b.vertices()[0])
}

/// Distance from `p` to segment `ab`.
pub fn point_segment_distance(p: Point, a: Point, b: Point) -> f64 {
    let ab = b - a;
    let l2 = ab.x * ab.x + ab.y * ab.y;
    if l2 == 0.0 {
        return p.dist(a);
    }
    let t = (((p - a).x * ab.x + (p - a).y * ab.y) / l2).clamp(0.0, 1.0);
    p.dist(a + ab * t)
}

/// Distance between the closed shells when disjoint (min over vertex–edge pairs); when they
/// overlap, minus the penetration depth (smallest projection overlap over all edge normals,
/// the separating-axis theorem). Near zero means touching.
pub fn signed_distance(a: &ConvexShell, b: &ConvexShell) -> f64 {
    if !brute_intersects(a, b) {
        let mut best = f64::INFINITY;
        for (s, t) in [(a, b), (b, a)] {
            for &v in s.vertices() {
                for &(e0, e1) in &edges(t) {
                    best = best.min(point_segment_distance(v, e0, e1));
                }
            }
        }
        return best;
    }
    let mut depth = f64::INFINITY;
    for s in [a, b] {
        for (e0, e1) in edges(s) {
            let e = e1 - e0;
            let l = e.x.hypot(e.y);
            if l == 0.0 {
                continue;
            }
            let n = Point::new(-e.y / l, e.x / l);
            let proj = |t: &ConvexShell| {
                t.vertices()
                    .iter()
                    .map(|p| p.x * n.x + p.y * n.y)
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                        (lo.min(v), hi.max(v))
                    })
            };
            let (alo, ahi) = proj(a);
            let (blo, bhi) = proj(b);
            depth = depth.min((ahi - blo).min(bhi - alo));
        }
    }
    if depth.is_infinite() {
        0.0
    } else {
        -depth
    }
}

/// Strict convexity and positive orientation of a shell's vertex list.
pub fn is_strictly_convex_ccw(s: &ConvexShell) -> bool {
    let v = s.vertices();
    let n = v.len();
    if n < 3 {
        return v.windows(2).all(|w| w[0] != w[1]);
    }
    let area2: f64 = (0..n).map(|i| cross(v[i], v[(i + 1) % n])).sum();
    area2 > 0.0 && (0..n).all(|i| orient(v[i], v[(i + 1) % n], v[(i + 2) % n]) > 0.0)
}
