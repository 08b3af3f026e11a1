//! Shape context descriptor and the shape cost C1 (`features::shape_context`).
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use shapetrack::features::shape_context::*;
use shapetrack::features::transform::*;
use shapetrack::Point;
use std::f64::consts::PI;

fn circle(r: f64, n: usize) -> Vec<Point> {
    (0..n)
        .map(|i| {
            let t = 2.0 * PI * i as f64 / n as f64;
            Point::new(r * t.cos(), r * t.sin())
        })
        .collect()
}

fn star(r: f64) -> Vec<Point> {
    (0..10)
        .map(|i| {
            let t = 2.0 * PI * i as f64 / 10.0 - PI / 2.0;
            let rr = if i % 2 == 0 { r } else { 0.45 * r };
            Point::new(rr * t.cos(), rr * t.sin())
        })
        .collect()
}

fn rectangle(w: f64, h: f64) -> Vec<Point> {
    vec![
        Point::new(-w / 2.0, -h / 2.0),
        Point::new(w / 2.0, -h / 2.0),
        Point::new(w / 2.0, h / 2.0),
        Point::new(-w / 2.0, h / 2.0),
    ]
}

fn ell(s: f64) -> Vec<Point> {
    [
        (0.0, 0.0),
        (1.0, 0.0),
        (1.0, 2.0),
        (2.0, 2.0),
        (2.0, 3.0),
        (0.0, 3.0),
    ]
    .iter()
    .map(|&(x, y)| Point::new(x * s, y * s))
    .collect()
}

fn shapes() -> Vec<(&'static str, Vec<Point>)> {
    vec![
        ("circle", circle(40.0, 48)),
        ("star", star(45.0)),
        ("rectangle", rectangle(90.0, 45.0)),
        ("L", ell(25.0)),
    ]
}

/// `contour` moved by `t`, starting `start` vertices later, with a deterministic jitter of up
/// to `jitter` pixels per coordinate (a stand-in for the contour extractor's pixel noise).
fn moved(contour: &[Point], t: &Similarity, start: usize, jitter: f64, seed: u64) -> Vec<Point> {
    let mut s = seed | 1;
    let mut noise = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        ((s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0) * jitter
    };
    let mut out: Vec<Point> = contour
        .iter()
        .map(|p| {
            let q = t.apply(*p);
            Point::new(q.x + noise(), q.y + noise())
        })
        .collect();
    let k = start % out.len();
    out.rotate_left(k);
    out
}

fn assert_sane(m: &ShapeMatch) {
    assert!(m.cost.is_finite() && m.cost >= 0.0, "cost {:?}", m);
    assert!(
        m.mean_distance.is_finite() && m.mean_distance >= 0.0,
        "{:?}",
        m
    );
    assert!(m.scale.is_finite() && m.scale > 0.0);
    if let Some(c) = m.descriptor_cost {
        assert!((0.0..=1.0).contains(&c));
    }
    assert!(m.inliers <= m.matched);
}

/// For every shape, its moved copy must be cheaper than every other shape moved the same way.
fn check_same_shape_wins(cfg: &ShapeContextConfig, t: &Similarity, start: usize, seed: u64) {
    let sh = shapes();
    for (na, a) in &sh {
        let mut same = f64::NAN;
        let mut best_other = f64::INFINITY;
        for (nb, b) in &sh {
            let bt = moved(b, t, start, 0.3, seed);
            let m = shape_cost(a, &bt, cfg).unwrap();
            assert_sane(&m);
            if na == nb {
                same = m.cost;
            } else {
                best_other = best_other.min(m.cost);
            }
        }
        assert!(
            same < best_other,
            "{na}: same-shape cost {same} not below other shapes' {best_other} ({t:?}, {cfg:?})"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 24,
        rng_seed: RngSeed::Fixed(0xdec0de),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    /// The acceptance property: same shape moved, rotated slightly and scaled beats a
    /// different shape, for random similarity transforms; no cost is ever NaN.
    #[test]
    fn same_shape_under_random_similarity_beats_other_shapes(
        scale in 0.6f64..1.6,
        angle in -0.2f64..0.2,
        tx in -300.0f64..300.0,
        ty in -300.0f64..300.0,
        start in 0usize..48,
        seed in any::<u64>(),
    ) {
        let t = Similarity { scale, angle, tx, ty };
        check_same_shape_wins(&ShapeContextConfig { seed, ..Default::default() }, &t, start, seed);
    }

    /// χ² (eq. 38) is 0 on identical histograms, symmetric, and within [0, 1] for normalised
    /// histograms.
    #[test]
    fn chi2_is_a_bounded_symmetric_dissimilarity(
        a in prop::collection::vec(0.0f64..1.0, 60),
        b in prop::collection::vec(0.0f64..1.0, 60),
        zero_a in prop::collection::vec(any::<bool>(), 60),
    ) {
        let norm = |v: &[f64], zero: &[bool]| {
            let v: Vec<f64> = v.iter().zip(zero).map(|(x, &z)| if z { 0.0 } else { *x }).collect();
            let s: f64 = v.iter().sum();
            if s > 0.0 { v.iter().map(|x| x / s).collect() } else { v }
        };
        let a = norm(&a, &zero_a);
        let b = norm(&b, &[false; 60]);
        let ab = chi2_cost(&a, &b).unwrap();
        let ba = chi2_cost(&b, &a).unwrap();
        prop_assert!(ab.is_finite() && (0.0..=1.0 + 1e-12).contains(&ab));
        prop_assert!((ab - ba).abs() < 1e-12);
        prop_assert_eq!(chi2_cost(&a, &a).unwrap(), 0.0);
    }
}

#[test]
fn chi2_known_values_and_length_check() {
    // Disjoint histograms: ½ Σ (a² + b²)/(a + b) over separate bins = ½ (1 + 1) = 1.
    assert_eq!(chi2_cost(&[1.0, 0.0], &[0.0, 1.0]).unwrap(), 1.0);
    // Both zero in every bin: all terms skipped.
    assert_eq!(chi2_cost(&[0.0; 4], &[0.0; 4]).unwrap(), 0.0);
    // ½ ((0.5−0.25)²/0.75 + (0.5−0.75)²/1.25) = ½ (1/12 + 1/20) = 1/15.
    assert!((chi2_cost(&[0.5, 0.5], &[0.25, 0.75]).unwrap() - 1.0 / 15.0).abs() < 1e-15);
    assert!(matches!(
        chi2_cost(&[1.0], &[0.5, 0.5]),
        Err(ShapeContextError::HistogramLength { a: 1, b: 2 })
    ));
}

#[test]
fn descriptor_is_translation_and_scale_invariant() {
    let cfg = ShapeContextConfig::default();
    let l = ell(20.0);
    let a = ShapeDescriptor::from_contour(&l, &cfg).unwrap();
    // Scale by 2 and shift by integers: exact in floating point, so bins cannot flip.
    let moved: Vec<Point> = l
        .iter()
        .map(|p| Point::new(2.0 * p.x + 64.0, 2.0 * p.y - 32.0))
        .collect();
    let b = ShapeDescriptor::from_contour(&moved, &cfg).unwrap();
    assert_eq!(a.len(), 64);
    assert!((b.median_distance() - 2.0 * a.median_distance()).abs() < 1e-9);
    for i in 0..a.len() {
        assert_eq!(a.histogram(i), b.histogram(i), "vertex {i}");
    }
    let m = match_shapes(&a, &b, &cfg).unwrap();
    assert!(m.cost < 1e-9, "{m:?}");
    assert_eq!(m.descriptor_cost, Some(0.0));
    let Transform::Similarity(s) = m.transform else {
        panic!("expected a similarity, got {:?}", m.transform)
    };
    assert!((s.scale - 0.5).abs() < 1e-9 && s.angle.abs() < 1e-9);
}

#[test]
fn thesis_matching_and_affine_model_also_separate_shapes() {
    let t = Similarity {
        scale: 1.3,
        angle: 0.12,
        tx: 40.0,
        ty: -25.0,
    };
    for cfg in [
        ShapeContextConfig {
            matching: VertexMatching::NearestCost,
            ..Default::default()
        },
        ShapeContextConfig {
            transform: TransformKind::Affine,
            ..Default::default()
        },
        ShapeContextConfig {
            icp_iterations: 0,
            ..Default::default()
        },
    ] {
        check_same_shape_wins(&cfg, &t, 5, 7);
    }
}

#[test]
fn rotation_invariant_orientations_survive_large_rotations() {
    let t = Similarity {
        scale: 1.1,
        angle: PI / 2.0 + 0.3,
        tx: 10.0,
        ty: 20.0,
    };
    let cfg = ShapeContextConfig {
        orientation: Orientation::Tangent,
        ..Default::default()
    };
    check_same_shape_wins(&cfg, &t, 3, 11);
    // The principal axis is ill-defined on the 5-fold star and the circle, so only compare
    // shapes that have one.
    let cfg = ShapeContextConfig {
        orientation: Orientation::PrincipalAxis,
        ..Default::default()
    };
    let (rect, l) = (rectangle(90.0, 45.0), ell(25.0));
    for (a, b) in [(&rect, &l), (&l, &rect)] {
        let same = shape_cost(a, &moved(a, &t, 1, 0.3, 5), &cfg).unwrap();
        let other = shape_cost(a, &moved(b, &t, 1, 0.3, 5), &cfg).unwrap();
        assert!(same.cost < other.cost, "{} vs {}", same.cost, other.cost);
    }
}

#[test]
fn sift_variant_with_perfect_matches_costs_nothing() {
    let cfg = ShapeContextConfig::default();
    let a = resample_contour(&star(50.0), 64).unwrap();
    let t = Similarity {
        scale: 0.8,
        angle: -0.3,
        tx: 120.0,
        ty: 45.0,
    };
    let b: Vec<Point> = a.iter().map(|p| t.apply(*p)).collect();
    // Keypoints anywhere on the object, not only on the outline.
    let keypoints = [
        (0.0, 0.0),
        (10.0, 5.0),
        (-12.0, 20.0),
        (25.0, -7.0),
        (-3.0, -30.0),
    ];
    let mut matches: Vec<(Point, Point)> = keypoints
        .iter()
        .map(|&(x, y)| {
            let p = Point::new(x, y);
            (p, t.apply(p))
        })
        .collect();
    let m = shape_cost_from_matches(&a, &b, &matches, &cfg).unwrap();
    assert_sane(&m);
    assert!(m.fitted && m.inliers == 5 && m.matched == 5);
    assert!(m.cost < 1e-9, "{m:?}");
    assert_eq!(m.descriptor_cost, None);
    // A third of wrong matches: RANSAC keeps the right transform.
    matches.push((Point::new(0.0, 0.0), Point::new(300.0, 300.0)));
    matches.push((Point::new(10.0, 5.0), Point::new(-50.0, 80.0)));
    let m = shape_cost_from_matches(&a, &b, &matches, &cfg).unwrap();
    assert!(m.fitted && m.inliers == 5 && m.matched == 7);
    assert!(m.cost < 1e-9, "{m:?}");
    // One match only: a translation cannot be verified, so the centroid fallback is used;
    // the cost is still finite and the scale ratio still right.
    let m = shape_cost_from_matches(&a, &b, &matches[..1], &cfg).unwrap();
    assert_sane(&m);
    assert!(!m.fitted && m.inliers == 0);
    assert!((m.transform.scale() - 1.0 / 0.8).abs() < 1e-9);
    let none = shape_cost_from_matches(&a, &b, &[], &cfg).unwrap();
    assert_eq!(none.cost, m.cost);
}

#[test]
fn sift_variant_translation_fallback_with_two_matches() {
    let cfg = ShapeContextConfig::default();
    let a = resample_contour(&rectangle(80.0, 40.0), 64).unwrap();
    let b: Vec<Point> = a
        .iter()
        .map(|p| Point::new(p.x + 17.0, p.y - 9.0))
        .collect();
    let matches = [
        (Point::new(0.0, 0.0), Point::new(17.0, -9.0)),
        (Point::new(5.0, 5.0), Point::new(22.0, -4.0)),
    ];
    // Two matches cannot verify a similarity (needs 3) but do verify a translation (needs 2).
    let m = shape_cost_from_matches(&a, &b, &matches, &cfg).unwrap();
    assert!(m.fitted && m.inliers == 2);
    assert_eq!(m.transform.kind(), TransformKind::Translation);
    assert!(m.cost < 1e-9);
}

#[test]
fn degenerate_inputs_are_typed_errors_never_panics() {
    let cfg = ShapeContextConfig::default();
    let p = Point::new(3.0, 4.0);
    assert!(matches!(
        ShapeDescriptor::from_contour(&[], &cfg),
        Err(ShapeContextError::TooFewVertices { got: 0, .. })
    ));
    assert!(matches!(
        ShapeDescriptor::from_contour(&[p], &cfg),
        Err(ShapeContextError::TooFewVertices { got: 1, .. })
    ));
    assert!(matches!(
        ShapeDescriptor::from_contour(&[p, p], &cfg),
        Err(ShapeContextError::Degenerate { .. })
    ));
    assert!(matches!(
        ShapeDescriptor::from_contour(&[p; 10], &cfg),
        Err(ShapeContextError::Degenerate { .. })
    ));
    assert!(matches!(
        ShapeDescriptor::from_vertices(&[p, Point::new(1.0, 1.0)], &cfg),
        Err(ShapeContextError::TooFewVertices { got: 2, .. })
    ));
    assert!(matches!(
        ShapeDescriptor::from_vertices(&[p; 5], &cfg),
        Err(ShapeContextError::Degenerate { .. })
    ));
    assert!(matches!(
        ShapeDescriptor::from_contour(&[p, Point::new(f64::NAN, 0.0), p], &cfg),
        Err(ShapeContextError::NonFinite { index: 1 })
    ));
    assert!(matches!(
        ShapeDescriptor::from_contour(
            &circle(5.0, 8),
            &ShapeContextConfig {
                angle_bins: 0,
                ..cfg
            }
        ),
        Err(ShapeContextError::InvalidConfig {
            field: "angle_bins",
            ..
        })
    ));
    let tri = [
        Point::new(0.0, 0.0),
        Point::new(10.0, 0.0),
        Point::new(0.0, 10.0),
    ];
    assert!(matches!(
        shape_cost_from_matches(&tri, &[p, p], &[], &cfg),
        Err(ShapeContextError::TooFewVertices { got: 2, .. })
    ));
    assert!(matches!(
        shape_cost_from_matches(&tri, &[p, p, p], &[], &cfg),
        Err(ShapeContextError::Degenerate { .. })
    ));
    let bad = [(Point::new(f64::INFINITY, 0.0), p); 4];
    assert!(matches!(
        shape_cost_from_matches(&tri, &tri, &bad, &cfg),
        Err(ShapeContextError::Transform(
            TransformError::NonFinite { .. }
        ))
    ));
    // Different bin layouts cannot be compared.
    let a = ShapeDescriptor::from_contour(&circle(5.0, 8), &cfg).unwrap();
    let b = ShapeDescriptor::from_contour(
        &circle(5.0, 8),
        &ShapeContextConfig {
            angle_bins: 8,
            ..cfg
        },
    )
    .unwrap();
    assert!(matches!(
        match_shapes(&a, &b, &cfg),
        Err(ShapeContextError::HistogramLength { .. })
    ));
}

#[test]
fn thin_and_tiny_shapes_still_give_finite_costs() {
    // A segment (a 1-pixel-wide object's outline) and a 3-vertex sliver: collinear vertices
    // defeat the affine fit, so the translation or centroid fallback must take over.
    let segment = [Point::new(0.0, 0.0), Point::new(30.0, 0.0)];
    let sliver = [
        Point::new(0.0, 0.0),
        Point::new(30.0, 0.0),
        Point::new(15.0, 1e-9),
    ];
    for kind in [TransformKind::Similarity, TransformKind::Affine] {
        let cfg = ShapeContextConfig {
            transform: kind,
            ..Default::default()
        };
        for (a, b) in [
            (&segment[..], &sliver[..]),
            (&sliver[..], &segment[..]),
            (&segment[..], &circle(10.0, 12)[..]),
            (&rectangle(2.0, 1.0)[..], &segment[..]),
        ] {
            let m = shape_cost(a, b, &cfg).unwrap();
            assert_sane(&m);
        }
    }
}
