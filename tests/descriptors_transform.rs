//! 2-D transforms, least-squares fits and RANSAC (`features::transform`).
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256Plus;
use shapetrack::features::transform::*;
use shapetrack::Point;
use std::f64::consts::PI;

/// `n` matches of `t`: sources uniform in a 200×200 box, targets with uniform noise of
/// ±`noise` pixels; a fraction `outliers` of them replaced by random targets. Returns the
/// matches and whether each one is an inlier.
fn noisy_matches(
    t: &Transform,
    n: usize,
    noise: f64,
    outliers: f64,
    seed: u64,
) -> (Vec<(Point, Point)>, Vec<bool>) {
    let mut rng = Xoshiro256Plus::seed_from_u64(seed);
    let n_out = (n as f64 * outliers).round() as usize;
    let mut m = Vec::with_capacity(n);
    let mut good = Vec::with_capacity(n);
    for i in 0..n {
        let p = Point::new(rng.gen_range(0.0..200.0), rng.gen_range(0.0..200.0));
        let q = if i < n_out {
            Point::new(rng.gen_range(-400.0..400.0), rng.gen_range(-400.0..400.0))
        } else {
            let q = t.apply(p);
            Point::new(
                q.x + rng.gen_range(-noise..noise),
                q.y + rng.gen_range(-noise..noise),
            )
        };
        m.push((p, q));
        good.push(i >= n_out);
    }
    (m, good)
}

fn angle_diff(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(2.0 * PI);
    d.min(2.0 * PI - d)
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 64,
        rng_seed: RngSeed::Fixed(0x7a45),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    /// RANSAC recovers a known similarity from noisy matches with 30% outliers.
    #[test]
    fn ransac_recovers_similarity_with_30_percent_outliers(
        scale in 0.5f64..2.0,
        angle in -PI..PI,
        tx in -100.0f64..100.0,
        ty in -100.0f64..100.0,
        seed in any::<u64>(),
    ) {
        let truth = Similarity { scale, angle, tx, ty };
        let (m, good) = noisy_matches(&Transform::Similarity(truth), 40, 0.5, 0.3, seed);
        let cfg = RansacConfig { threshold: 2.5, seed, ..Default::default() };
        let fit = ransac(TransformKind::Similarity, &m, &cfg).unwrap();
        let Transform::Similarity(s) = fit.transform else {
            return Err(TestCaseError::fail("not a similarity"));
        };
        prop_assert!((s.scale / scale - 1.0).abs() < 0.02, "{s:?} vs {truth:?}");
        prop_assert!(angle_diff(s.angle, angle) < 0.02, "{s:?} vs {truth:?}");
        // Compare the maps where the data is, not the raw translations (which trade off
        // against the angle far from the origin).
        for p in [Point::new(0.0, 0.0), Point::new(200.0, 200.0), Point::new(100.0, 50.0)] {
            prop_assert!(s.apply(p).dist(truth.apply(p)) < 2.0);
        }
        let true_in = good.iter().filter(|&&g| g).count();
        let found_true = fit.inliers.iter().filter(|&&i| good[i]).count();
        prop_assert!(found_true * 10 >= true_in * 9, "{found_true}/{true_in}");
        prop_assert!(fit.inliers.len() - found_true <= 1);
        prop_assert!(fit.rms.is_finite() && fit.rms < 1.0);
    }

    /// Every model's inverse undoes it.
    #[test]
    fn inverses_roundtrip(
        a in -3.0f64..3.0, b in -3.0f64..3.0, c in -3.0f64..3.0, d in -3.0f64..3.0,
        tx in -100.0f64..100.0, ty in -100.0f64..100.0,
        x in -500.0f64..500.0, y in -500.0f64..500.0,
    ) {
        let p = Point::new(x, y);
        let aff = Affine { a, b, c, d, tx, ty };
        let sim = Similarity { scale: a.abs() + 0.1, angle: b, tx, ty };
        let tr = Translation { dx: tx, dy: ty };
        for t in [Transform::Affine(aff), Transform::Similarity(sim), Transform::Translation(tr)] {
            match t.inverse() {
                Ok(inv) => {
                    prop_assert_eq!(inv.kind(), t.kind());
                    let back = inv.apply(t.apply(p));
                    let tol = 1e-6 * (1.0 + x.abs() + y.abs()) / aff.det().abs().clamp(1e-3, 1.0);
                    prop_assert!(back.dist(p) < tol, "{t:?}: {back:?} vs {p:?}");
                }
                Err(TransformError::NotInvertible { det }) => {
                    prop_assert!(det.abs() < 1e-9, "{t:?} refused with det {det}");
                }
                Err(e) => return Err(TestCaseError::fail(format!("{e}"))),
            }
        }
    }

    /// The k-d tree's nearest point is the brute-force nearest (ties allowed), duplicates
    /// included.
    #[test]
    fn point_index_matches_brute_force(
        pts in prop::collection::vec((-50i32..50, -50i32..50), 1..120),
        queries in prop::collection::vec((-70.0f64..70.0, -70.0f64..70.0), 1..40),
    ) {
        let pts: Vec<Point> = pts.iter().map(|&(x, y)| Point::new(x as f64, y as f64)).collect();
        let index = PointIndex::new(&pts);
        for (x, y) in queries {
            let q = Point::new(x, y);
            let (i, d) = index.nearest(q).unwrap();
            let brute = pts.iter().map(|p| p.dist(q)).fold(f64::INFINITY, f64::min);
            prop_assert!((d - brute).abs() < 1e-12);
            prop_assert!((pts[i].dist(q) - d).abs() < 1e-12);
        }
    }
}

#[test]
fn ransac_recovers_affine_with_outliers() {
    let truth = Affine {
        a: 1.1,
        b: 0.25,
        c: -0.15,
        d: 0.8,
        tx: 30.0,
        ty: -12.0,
    };
    let (m, _) = noisy_matches(&Transform::Affine(truth), 50, 0.5, 0.3, 99);
    let cfg = RansacConfig {
        threshold: 2.5,
        ..Default::default()
    };
    let fit = ransac(TransformKind::Affine, &m, &cfg).unwrap();
    for p in [
        Point::new(0.0, 0.0),
        Point::new(200.0, 0.0),
        Point::new(0.0, 200.0),
        Point::new(200.0, 200.0),
    ] {
        assert!(fit.transform.apply(p).dist(truth.apply(p)) < 1.5, "{fit:?}");
    }
    assert!(fit.inliers.len() >= 33, "{}", fit.inliers.len());
}

#[test]
fn ransac_is_deterministic_for_a_seed() {
    let truth = Transform::Similarity(Similarity {
        scale: 1.2,
        angle: 0.7,
        tx: 5.0,
        ty: 9.0,
    });
    let (m, _) = noisy_matches(&truth, 30, 1.0, 0.4, 3);
    let cfg = RansacConfig {
        threshold: 3.0,
        seed: 42,
        ..Default::default()
    };
    let a = ransac(TransformKind::Similarity, &m, &cfg).unwrap();
    let b = ransac(TransformKind::Similarity, &m, &cfg).unwrap();
    assert_eq!(a, b);
}

#[test]
fn affine_fit_rejects_collinear_points() {
    let line: Vec<(Point, Point)> = (0..6)
        .map(|i| {
            let p = Point::new(i as f64 * 10.0, i as f64 * 5.0 + 3.0);
            (p, Point::new(p.x + 1.0, p.y * 2.0))
        })
        .collect();
    assert!(matches!(
        Affine::fit(&line, DEFAULT_MIN_RELATIVE_AREA),
        Err(TransformError::Collinear { relative_area, .. }) if relative_area == 0.0
    ));
    // Nearly collinear: the third point 0.5 px off a 100 px line.
    let near = [
        (Point::new(0.0, 0.0), Point::new(0.0, 0.0)),
        (Point::new(100.0, 0.0), Point::new(100.0, 0.0)),
        (Point::new(50.0, 0.5), Point::new(50.0, 0.5)),
    ];
    assert!(matches!(
        Affine::fit(&near, DEFAULT_MIN_RELATIVE_AREA),
        Err(TransformError::Collinear { relative_area, threshold })
            if relative_area > 0.0 && relative_area < threshold
    ));
    // The same points pass with the check relaxed, and a proper triangle passes by default.
    assert!(Affine::fit(&near, 1e-6).is_ok());
    let tri = [
        (Point::new(0.0, 0.0), Point::new(0.0, 0.0)),
        (Point::new(100.0, 0.0), Point::new(100.0, 0.0)),
        (Point::new(50.0, 60.0), Point::new(50.0, 60.0)),
    ];
    assert!(Affine::fit(&tri, DEFAULT_MIN_RELATIVE_AREA).is_ok());
    // RANSAC over only collinear sources never finds a model.
    assert!(matches!(
        ransac(TransformKind::Affine, &line, &RansacConfig::default()),
        Err(TransformError::NoConsensus { .. })
    ));
    // Similarity needs no spread across the line.
    assert!(Similarity::fit(&line).is_ok());
}

#[test]
fn fits_reject_too_few_and_non_finite_matches() {
    let p = Point::new(1.0, 2.0);
    for (kind, needed) in [
        (TransformKind::Translation, 1),
        (TransformKind::Similarity, 2),
        (TransformKind::Affine, 3),
    ] {
        let few = vec![(p, p); needed - 1];
        assert_eq!(
            Transform::fit(kind, &few, DEFAULT_MIN_RELATIVE_AREA),
            Err(TransformError::TooFewMatches {
                kind,
                needed,
                got: needed - 1
            })
        );
        assert!(matches!(
            ransac(kind, &few, &RansacConfig::default()),
            Err(TransformError::TooFewMatches { .. })
        ));
        let mut bad = vec![(p, Point::new(p.x + 1.0, p.y)); needed + 2];
        bad[needed].1 = Point::new(0.0, f64::NAN);
        assert_eq!(
            ransac(kind, &bad, &RansacConfig::default()),
            Err(TransformError::NonFinite { index: needed })
        );
    }
    for cfg in [
        RansacConfig {
            threshold: 0.0,
            ..Default::default()
        },
        RansacConfig {
            max_iterations: 0,
            ..Default::default()
        },
        RansacConfig {
            confidence: 1.0,
            ..Default::default()
        },
    ] {
        assert!(matches!(
            ransac(TransformKind::Translation, &[(p, p), (p, p)], &cfg),
            Err(TransformError::InvalidConfig { .. })
        ));
    }
}

#[test]
fn models_agree_through_to_affine_and_thesis_parameters() {
    // Thesis eq. 32–37: x' = a·x − b·y + c, y' = b·x + a·y + d, s = √(a² + b²).
    let s = Similarity {
        scale: 2.0,
        angle: PI / 6.0,
        tx: 1.0,
        ty: -1.0,
    };
    let aff = s.to_affine();
    let (a, b) = (aff.a, aff.c);
    assert!(((a * a + b * b).sqrt() - 2.0).abs() < 1e-12);
    assert!((aff.b + b).abs() < 1e-12 && (aff.d - a).abs() < 1e-12);
    for p in [Point::new(3.0, 4.0), Point::new(-7.0, 0.5)] {
        assert!(aff.apply(p).dist(s.apply(p)) < 1e-12);
        let t = Translation { dx: 2.0, dy: 3.0 };
        assert!(t.to_affine().apply(p).dist(t.apply(p)) < 1e-12);
    }
    assert!((Transform::Similarity(s).scale() - 2.0).abs() < 1e-12);
    assert!((Transform::Affine(aff).scale() - 2.0).abs() < 1e-12);
}
