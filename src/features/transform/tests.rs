//! Unit tests of `features::transform` (a file of their own: the module's code is long enough).

use super::*;

fn pts(v: &[(f64, f64)]) -> Vec<Point> {
    v.iter().map(|&(x, y)| Point::new(x, y)).collect()
}

#[test]
fn similarity_roundtrip_and_inverse() {
    let t = Similarity {
        scale: 1.7,
        angle: 0.4,
        tx: 3.0,
        ty: -2.0,
    };
    let src = pts(&[(0.0, 0.0), (10.0, 0.0), (3.0, 7.0), (-4.0, 2.0)]);
    let m: Vec<_> = src.iter().map(|&p| (p, t.apply(p))).collect();
    let f = Similarity::fit(&m).unwrap();
    assert!((f.scale - 1.7).abs() < 1e-12 && (f.angle - 0.4).abs() < 1e-12);
    assert!((f.tx - 3.0).abs() < 1e-10 && (f.ty + 2.0).abs() < 1e-10);
    let inv = f.inverse().unwrap();
    for p in &src {
        assert!(inv.apply(f.apply(*p)).dist(*p) < 1e-10);
    }
}

#[test]
fn affine_recovers_shear_and_inverse() {
    let t = Affine {
        a: 1.2,
        b: 0.3,
        c: -0.2,
        d: 0.9,
        tx: 5.0,
        ty: 1.0,
    };
    let src = pts(&[(0.0, 0.0), (10.0, 0.0), (3.0, 7.0), (-4.0, 2.0)]);
    let m: Vec<_> = src.iter().map(|&p| (p, t.apply(p))).collect();
    let f = Affine::fit(&m, DEFAULT_MIN_RELATIVE_AREA).unwrap();
    for (p, q) in &m {
        assert!(f.apply(*p).dist(*q) < 1e-10);
    }
    let inv = f.inverse().unwrap();
    for (p, q) in &m {
        assert!(inv.apply(*q).dist(*p) < 1e-9);
    }
}

#[test]
fn relative_area_is_one_for_equilateral_and_zero_for_collinear() {
    let h = 3f64.sqrt() / 2.0;
    assert!((relative_area(&pts(&[(0.0, 0.0), (1.0, 0.0), (0.5, h)])) - 1.0).abs() < 1e-12);
    assert_eq!(
        relative_area(&pts(&[(0.0, 0.0), (1.0, 1.0), (2.0, 2.0)])),
        0.0
    );
    assert_eq!(relative_area(&pts(&[(0.0, 0.0), (1.0, 1.0)])), 0.0);
}

#[test]
fn degenerate_inputs_are_typed_errors() {
    let p = Point::new(1.0, 1.0);
    assert!(matches!(
        Similarity::fit(&[(p, p)]),
        Err(TransformError::TooFewMatches { needed: 2, .. })
    ));
    assert!(matches!(
        Similarity::fit(&[(p, p), (p, p)]),
        Err(TransformError::Coincident { .. })
    ));
    assert!(matches!(
        Translation::fit(&[]),
        Err(TransformError::TooFewMatches { .. })
    ));
    let nan = Point::new(f64::NAN, 0.0);
    assert!(matches!(
        Translation::fit(&[(p, p), (nan, p)]),
        Err(TransformError::NonFinite { index: 1 })
    ));
    let singular = Affine {
        a: 1.0,
        b: 2.0,
        c: 2.0,
        d: 4.0,
        tx: 0.0,
        ty: 0.0,
    };
    assert!(matches!(
        singular.inverse(),
        Err(TransformError::NotInvertible { .. })
    ));
    assert!(matches!(
        ransac(
            TransformKind::Similarity,
            &[(p, p), (p, p), (p, p)],
            &RansacConfig::default()
        ),
        Err(TransformError::NoConsensus { .. })
    ));
}

#[test]
fn point_index_agrees_with_brute_force() {
    let mut s = 12345u64;
    let mut next = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((s >> 11) as f64 / (1u64 << 53) as f64) * 100.0
    };
    let points: Vec<Point> = (0..300).map(|_| Point::new(next(), next())).collect();
    let index = PointIndex::new(&points);
    assert_eq!(index.len(), 300);
    for _ in 0..200 {
        let q = Point::new(next() * 1.2 - 10.0, next() * 1.2 - 10.0);
        let (i, d) = index.nearest(q).unwrap();
        let brute = points
            .iter()
            .map(|p| p.dist(q))
            .fold(f64::INFINITY, f64::min);
        assert!((d - brute).abs() < 1e-12);
        assert!((points[i].dist(q) - d).abs() < 1e-12);
    }
    assert!(PointIndex::new(&[]).nearest(Point::default()).is_none());
}

/// The cell index keeps what "the nearest point, if within `r`" keeps: the same point
/// (lowest index among ties) and distance, on scattered points, points on a grid with
/// duplicates (exact ties), odd cell sizes and radii on both sides of the spacing.
#[test]
fn cell_index_agrees_with_the_nearest_point() {
    let mut s = 777u64;
    let mut next = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    for case in 0..40 {
        let points: Vec<Point> = if case % 2 == 0 {
            (0..1 + case * 7)
                .map(|_| Point::new(next() * 80.0, next() * 50.0))
                .collect()
        } else {
            // A sample grid 3 px apart, with some points repeated.
            (0..1 + case * 7)
                .map(|i| Point::new((i % 13) as f64 * 3.0 + 0.5, (i / 13) as f64 * 3.0 + 0.5))
                .chain((0..case).map(|i| Point::new((i % 5) as f64 * 3.0 + 0.5, 0.5)))
                .collect()
        };
        let cell = [3.0, 0.1, 17.0, 0.0, f64::NAN][case % 5];
        let (cells, tree) = (CellIndex::new(&points, cell), PointIndex::new(&points));
        assert_eq!(cells.len(), points.len());
        for _ in 0..200 {
            let q = Point::new(next() * 100.0 - 10.0, next() * 70.0 - 10.0);
            let r = [1.5, 3.0, 0.0, 40.0][(next() * 4.0) as usize % 4];
            let want = tree.nearest(q).filter(|&(_, d)| d <= r);
            let got = cells.nearest_within(q, r).filter(|&(_, d)| d <= r);
            assert_eq!(got, want, "case {case} q {q:?} r {r}");
        }
        // Queries exactly on grid points (distance 0; ties between repeats).
        for p in &points {
            assert_eq!(
                cells.nearest_within(*p, 1.0),
                tree.nearest(*p),
                "case {case}"
            );
        }
    }
    assert!(CellIndex::new(&[], 1.0)
        .nearest_within(Point::default(), 5.0)
        .is_none());
    let one = CellIndex::new(&[Point::new(1.0, 1.0)], 1.0);
    assert!(one.nearest_within(Point::new(f64::NAN, 0.0), 5.0).is_none());
    assert!(one.nearest_within(Point::new(9.0, 9.0), 1.0).is_none());
}
