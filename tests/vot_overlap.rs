//! Property tests of region overlap: rotated boxes, polygons (convex, non-convex,
//! self-intersecting) against a pixel-count brute force, masks, bounds.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use proptest::prelude::*;
use shapetrack::eval::vot::{overlap, region_area, OverlapMethod};
use shapetrack::frame::Mask;
use shapetrack::io::vot::Region;
use shapetrack::Point;

fn rotated_box(cx: f64, cy: f64, w: f64, h: f64, a: f64) -> Vec<Point> {
    let (s, c) = a.sin_cos();
    [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)]
        .iter()
        .map(|&(u, v)| Point::new(cx + c * u * w - s * v * h, cy + s * u * w + c * v * h))
        .collect()
}

/// Sample points `((i + ½)·c, (k + ½)·c)` of a grid of pitch `c` inside the even-odd polygon,
/// counted row by row: in each sample row the polygon's crossings split the row into inside
/// intervals and the samples in each interval are counted arithmetically (so very fine grids
/// stay cheap). Returns (count A, count B, count A∩B).
fn pixel_counts(
    a: &[Point],
    b: &[Point],
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    c: f64,
) -> (f64, f64, f64) {
    fn row(p: &[Point], y: f64) -> Vec<(f64, f64)> {
        let mut xs: Vec<f64> = Vec::new();
        for i in 0..p.len() {
            let (u, v) = (p[i], p[(i + 1) % p.len()]);
            if (u.y <= y) != (v.y <= y) {
                xs.push(u.x + (y - u.y) * (v.x - u.x) / (v.y - u.y));
            }
        }
        xs.sort_by(f64::total_cmp);
        xs.chunks(2)
            .filter(|c| c.len() == 2)
            .map(|c| (c[0], c[1]))
            .collect()
    }
    // Number of sample columns i with x0 + (i+½)c in [a, b).
    let cols = ((x1 - x0) / c).round();
    let count = |lo: f64, hi: f64| {
        let first = ((lo - x0) / c - 0.5).ceil().max(0.0);
        let last = ((hi - x0) / c - 0.5).ceil().min(cols);
        (last - first).max(0.0)
    };
    let (mut na, mut nb, mut nab) = (0.0, 0.0, 0.0);
    let rows = ((y1 - y0) / c).ceil() as usize;
    for k in 0..rows {
        let y = y0 + (k as f64 + 0.5) * c;
        let (ra, rb) = (row(a, y), row(b, y));
        na += ra.iter().map(|&(l, h)| count(l, h)).sum::<f64>();
        nb += rb.iter().map(|&(l, h)| count(l, h)).sum::<f64>();
        for &(l1, h1) in &ra {
            for &(l2, h2) in &rb {
                let (l, h) = (l1.max(l2), h1.min(h2));
                if h > l {
                    nab += count(l, h);
                }
            }
        }
    }
    (na, nb, nab)
}

/// A star-shaped polygon (non-convex in general) around `(cx, cy)`.
fn star(cx: f64, cy: f64, radii: &[f64], jitter: &[f64]) -> Vec<Point> {
    let n = radii.len();
    (0..n)
        .map(|i| {
            let a = (i as f64 + 0.45 * jitter[i]) / n as f64 * std::f64::consts::TAU;
            Point::new(cx + radii[i] * a.cos(), cy + radii[i] * a.sin())
        })
        .collect()
}

fn star_strategy() -> impl Strategy<Value = Vec<Point>> {
    (3usize..10)
        .prop_flat_map(|n| {
            (
                3.0f64..7.0,
                3.0f64..7.0,
                prop::collection::vec(1.5f64..4.5, n),
                prop::collection::vec(-1.0f64..1.0, n),
            )
        })
        .prop_map(|(cx, cy, r, j)| star(cx, cy, &r, &j))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, rng_seed: proptest::test_runner::RngSeed::Fixed(7), failure_persistence: None, ..ProptestConfig::default() })]

    /// A rotated box overlaps itself exactly once and a disjoint copy not at all.
    #[test]
    fn rotated_box_self_and_disjoint(cx in -50.0f64..50.0, cy in -50.0f64..50.0, w in 0.5f64..40.0, h in 0.5f64..40.0, a in 0.0f64..6.3) {
        let r = Region::Polygon(rotated_box(cx, cy, w, h, a));
        prop_assert!((overlap(&r, &r, None, OverlapMethod::Exact) - 1.0).abs() < 1e-12);
        let far = Region::Polygon(rotated_box(cx + w + h + 1.0, cy, w, h, a));
        prop_assert_eq!(overlap(&r, &far, None, OverlapMethod::Exact), 0.0);
        prop_assert!((region_area(&r, None) - w * h).abs() < 1e-9 * (1.0 + w * h));
        prop_assert_eq!(overlap(&r, &r, None, OverlapMethod::Toolkit), 1.0);
    }

    /// Polygon IoU (convex or not, self-intersecting ones included) equals the IoU of a
    /// 2000 × 2000 sample-point count over [0, 10]² within 1e-3.
    #[test]
    fn polygon_overlap_matches_pixel_count(a in star_strategy(), b in star_strategy()) {
        let (ra, rb) = (Region::Polygon(a.clone()), Region::Polygon(b.clone()));
        let exact = overlap(&ra, &rb, Some((10, 10)), OverlapMethod::Exact);
        let (na, nb, nab) = pixel_counts(&a, &b, 0.0, 10.0, 0.0, 10.0, 0.005);
        let brute = if na + nb - nab > 0.0 { nab / (na + nb - nab) } else { 1.0 };
        prop_assert!((exact - brute).abs() < 1e-3, "exact {} brute {}", exact, brute);
        prop_assert!((0.0..=1.0).contains(&exact));
        prop_assert!((exact - overlap(&rb, &ra, Some((10, 10)), OverlapMethod::Exact)).abs() < 1e-12);
    }

    /// Unbounded polygon IoU against the same count over a window that holds both.
    #[test]
    fn unbounded_polygon_overlap_matches_pixel_count(a in star_strategy(), b in star_strategy()) {
        let exact = overlap(&Region::Polygon(a.clone()), &Region::Polygon(b.clone()), None, OverlapMethod::Exact);
        let (na, nb, nab) = pixel_counts(&a, &b, -2.0, 12.0, -2.0, 12.0, 0.005);
        let brute = nab / (na + nb - nab);
        prop_assert!((exact - brute).abs() < 1e-3, "exact {} brute {}", exact, brute);
    }

    /// A mask against a polygon equals the polygon against the mask's pixels as a polygon set,
    /// and a mask made of one rectangle overlaps that rectangle exactly.
    #[test]
    fn mask_against_shapes(x in -3i32..8, y in -3i32..8, w in 1u32..6, h in 1u32..6, p in star_strategy()) {
        let m = Region::Mask(Mask::new(x, y, w, h, vec![1; (w * h) as usize]).unwrap());
        let rect = Region::Rectangle(shapetrack::BBox::new(x as f64, y as f64, w as f64, h as f64));
        prop_assert!((overlap(&m, &rect, None, OverlapMethod::Exact) - 1.0).abs() < 1e-12);
        let poly = Region::Polygon(p);
        let a = overlap(&m, &poly, None, OverlapMethod::Exact);
        let b = overlap(&rect, &poly, None, OverlapMethod::Exact);
        prop_assert!((a - b).abs() < 1e-9, "{} vs {}", a, b);
        // Bounds clip masks and polygons alike.
        let a = overlap(&m, &poly, Some((6, 7)), OverlapMethod::Exact);
        let b = overlap(&rect, &poly, Some((6, 7)), OverlapMethod::Exact);
        prop_assert!((a - b).abs() < 1e-9, "{} vs {}", a, b);
    }
}
