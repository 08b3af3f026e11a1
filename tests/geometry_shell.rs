//! Convex shells: hull invariants, growing, and the per-mask geometry's containment guarantees.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

mod common;

use common::*;
use proptest::prelude::*;
use shapetrack::geometry::{mask_geometry, ConvexShell, GeometryConfig, Moments};
use shapetrack::Point;

/// Distance from `p` to a shell (0 inside), by brute force.
fn dist_to_shell(s: &ConvexShell, p: Point) -> f64 {
    if point_in_polygon(s, p) {
        return 0.0;
    }
    edges(s)
        .iter()
        .map(|&(a, b)| point_segment_distance(p, a, b))
        .fold(f64::INFINITY, f64::min)
}

proptest! {
    #![proptest_config(config(1000))]

    /// The hull of any point cloud is strictly convex, counter-clockwise (positive area) and
    /// contains every input point.
    #[test]
    fn hull_is_convex_ccw_and_contains_input(
        o in offset(),
        pts in prop::collection::vec((-100.0..100.0f64, -100.0..100.0f64), 0..60),
    ) {
        let pts: Vec<Point> = pts.iter().map(|&(x, y)| Point::new(o.x + x, o.y + y)).collect();
        let s = ConvexShell::from_points(&pts).unwrap();
        prop_assert!(is_strictly_convex_ccw(&s), "{:?}", s);
        prop_assert_eq!(s.is_empty(), pts.is_empty());
        for &p in &pts {
            prop_assert!(s.contains(p), "{:?} not in {:?}", p, s);
        }
        // Every hull vertex is an input point.
        for v in s.vertices() {
            prop_assert!(pts.contains(v));
        }
    }

    /// `moved_with` (the tracker's search shell in one buffer) gives, vertex for vertex, the
    /// shell `translated` or `swept` and then `from_points` with the extra points give; the
    /// moved shell alone when an extra point is not finite.
    #[test]
    fn moved_with_equals_moving_then_merging(
        s in shell(),
        dx in prop_oneof![-60.0..60.0f64, Just(f64::NAN), Just(1e-13)],
        dy in -60.0..60.0f64,
        sweep in any::<bool>(),
        extra in prop::collection::vec((-100.0..100.0f64, -100.0..100.0f64), 0..5),
        poison in any::<bool>(),
    ) {
        let o = s.vertices()[0];
        let mut extra: Vec<Point> = extra.iter().map(|&(x, y)| Point::new(o.x + x, o.y + y)).collect();
        if poison && !extra.is_empty() {
            extra[0].x = f64::INFINITY;
        }
        let moved = if sweep { s.swept(dx, dy) } else { s.translated(dx, dy) };
        let mut pts = moved.vertices().to_vec();
        pts.extend_from_slice(&extra);
        let expected = ConvexShell::from_points(&pts).unwrap_or(moved);
        prop_assert_eq!(s.moved_with(dx, dy, sweep, &extra), expected);
    }

    /// `grown(m)` contains the original shell and every point within distance `m` of it, is
    /// still convex and CCW, and overshoots by at most m·(1/cos(π/8) − 1).
    #[test]
    fn grown_contains_every_point_within_margin(
        s in shell(),
        m in 0.01..25.0f64,
        samples in prop::collection::vec((any::<prop::sample::Index>(), 0.0..1.0f64, 0.0..std::f64::consts::TAU, 0.0..1.0f64), 32),
    ) {
        let g = s.grown(m);
        prop_assert!(is_strictly_convex_ccw(&g), "{:?}", g);
        prop_assert!(g.len() >= 3);
        let tol = 1e-9 * (1.0 + s.vertices()[0].x.abs().max(s.vertices()[0].y.abs()));
        for &v in s.vertices() {
            prop_assert!(g.contains_within(v, tol));
        }
        let e = edges(&s);
        for (ei, t, a, r) in samples {
            let (p, q) = e[ei.index(e.len())];
            // A point of the original boundary, pushed up to m away in any direction.
            let base = p + (q - p) * t;
            let x = Point::new(base.x + m * r * a.cos(), base.y + m * r * a.sin());
            prop_assert!(g.contains_within(x, tol), "{:?} (dist {}) not in grown", x, dist_to_shell(&s, x));
        }
        let bound = m / (std::f64::consts::PI / 8.0).cos() + tol;
        for &v in g.vertices() {
            prop_assert!(dist_to_shell(&s, v) <= bound, "vertex {:?} is {} away", v, dist_to_shell(&s, v));
        }
    }

    /// For random masks (several parts, holes, lines, single pixels, anywhere in the image):
    /// the shell is convex and CCW and contains every Canny edge point, every contour point of
    /// every part, the centroid and every foreground pixel centre; the Delaunay mesh's outer
    /// boundary is exactly the shell, its triangles are CCW, and the centroid matches
    /// `Mask::centroid`.
    #[test]
    fn mask_shell_contains_edges_and_contours(seed in any::<u64>()) {
        let mask = random_mask(seed);
        let cfg = GeometryConfig::default();
        let g = match mask_geometry(&mask, &cfg) {
            Ok(g) => g,
            Err(e) => {
                prop_assert!(mask.is_empty(), "{}", e);
                return Ok(());
            }
        };
        let eps = 1e-9;
        prop_assert!(is_strictly_convex_ccw(&g.shell));
        for p in g.edge_points.iter().chain(&g.contour).chain(g.parts.iter().flatten()) {
            prop_assert!(g.shell.contains_within(*p, eps), "{:?} outside", p);
        }
        prop_assert!(g.shell.contains_within(g.centroid, eps));
        for (x, y) in mask.pixels() {
            prop_assert!(g.shell.contains_within(Point::new(x as f64 + 0.5, y as f64 + 0.5), eps));
        }
        prop_assert_eq!(g.mesh.outer_boundary(), g.shell.clone());
        for t in &g.mesh.triangles {
            let (a, b, c) = (g.mesh.vertices[t[0]], g.mesh.vertices[t[1]], g.mesh.vertices[t[2]]);
            prop_assert!((b - a).x * (c - a).y - (b - a).y * (c - a).x > 0.0);
        }
        prop_assert!(g.mesh.vertices.len() <= cfg.max_mesh_points.max(g.shell.len() + 1));
        let c = mask.centroid().unwrap();
        prop_assert!(g.centroid.dist(c) < 1e-9);
        prop_assert_eq!(Moments::of_mask(&mask).unwrap(), g.moments);
        // Contour points are foreground pixel centres.
        for p in g.contour.iter().chain(g.parts.iter().flatten()) {
            prop_assert!(mask.get((p.x - 0.5) as i32, (p.y - 0.5) as i32));
        }
    }
}
