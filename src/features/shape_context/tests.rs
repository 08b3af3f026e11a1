//! Unit tests of `features::shape_context` (a file of their own: the module's code is long enough).

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
