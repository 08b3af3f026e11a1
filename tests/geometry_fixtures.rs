//! Contours, moments and edges against references: OpenCV fixtures (made by
//! `tests/data/geometry/make_opencv_fixture.py`) and shapes with known answers.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use serde::Deserialize;
use shapetrack::geometry::{mask_geometry, GeometryConfig, MaskCrop, Moments, CROP_PAD};
use shapetrack::{Mask, Point};

#[derive(Deserialize)]
struct Fixture {
    cases: Vec<Case>,
}

#[derive(Deserialize)]
struct Case {
    width: u32,
    height: u32,
    rows: Vec<String>,
    outer_contours: Vec<Vec<[i64; 2]>>,
    moments: CvMoments,
}

#[derive(Deserialize)]
struct CvMoments {
    m00: f64,
    m10: f64,
    m01: f64,
    mu20: f64,
    mu02: f64,
    mu11: f64,
}

fn load() -> Vec<Case> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/geometry/opencv_contours.json"
    );
    let f: Fixture = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    f.cases
}

fn mask_of(c: &Case) -> Mask {
    let full: Vec<u8> = c
        .rows
        .iter()
        .flat_map(|r| r.bytes().map(|b| (b == b'1') as u8))
        .collect();
    Mask::from_full(c.width, c.height, &full).unwrap()
}

/// One place that compares our outer contours with OpenCV's (as pixel indices, any order of
/// contours, each in OpenCV's point order).
fn check_contours(mask: &Mask, expected: &[Vec<[i64; 2]>]) {
    let crop = MaskCrop::new(mask, CROP_PAD).unwrap();
    let mut ours: Vec<Vec<[i64; 2]>> = crop
        .outer_contours()
        .into_iter()
        .map(|c| {
            c.iter()
                .map(|p| [(p.x - 0.5) as i64, (p.y - 0.5) as i64])
                .collect()
        })
        .collect();
    let mut want = expected.to_vec();
    ours.sort();
    want.sort();
    assert_eq!(ours, want);
}

/// Our border following + `approx_simple` reproduces OpenCV's
/// `findContours(..., CHAIN_APPROX_SIMPLE)` outer borders point for point on 30 random masks
/// (blobs, ellipses, lines, a ring with an island in its hole, sparse noise).
#[test]
fn contours_match_opencv_chain_approx_simple() {
    let cases = load();
    assert_eq!(cases.len(), 30);
    for c in &cases {
        check_contours(&mask_of(c), &c.outer_contours);
    }
}

/// Area and central moments equal OpenCV's `moments(binaryImage=True)`; the centroid differs by
/// exactly half a pixel (OpenCV uses pixel indices, we use pixel centres).
#[test]
fn moments_match_opencv() {
    for c in &load() {
        let m = Moments::of_mask(&mask_of(c)).unwrap();
        let cv = &c.moments;
        assert_eq!(m.m00, cv.m00);
        assert!((m.centroid.x - (cv.m10 / cv.m00 + 0.5)).abs() < 1e-9);
        assert!((m.centroid.y - (cv.m01 / cv.m00 + 0.5)).abs() < 1e-9);
        for (ours, theirs) in [(m.mu20, cv.mu20), (m.mu02, cv.mu02), (m.mu11, cv.mu11)] {
            assert!(
                (ours - theirs).abs() <= 1e-9 * (1.0 + theirs.abs()),
                "{ours} vs {theirs}"
            );
        }
    }
}

fn disc(cx: f64, cy: f64, r: f64) -> Mask {
    let n = (2.0 * r).ceil() as i32 + 4;
    let (x0, y0) = ((cx - n as f64 / 2.0) as i32, (cy - n as f64 / 2.0) as i32);
    let mut d = Vec::new();
    for y in 0..n {
        for x in 0..n {
            let (px, py) = ((x0 + x) as f64 + 0.5, (y0 + y) as f64 + 0.5);
            d.push(((px - cx).hypot(py - cy) <= r) as u8);
        }
    }
    Mask::new(x0, y0, n as u32, n as u32, d).unwrap()
}

/// Canny on a disc mask gives a closed ring of edge pixels at radius ≈ r: every edge point
/// within 1 px of the circle, covering every direction, none inside.
#[test]
fn canny_on_disc_is_ring_at_radius() {
    for r in [6.0, 15.0, 40.0] {
        let (cx, cy) = (321.0, 123.0);
        let g = mask_geometry(&disc(cx, cy, r), &GeometryConfig::default()).unwrap();
        assert!(
            g.edge_points.len() as f64 > 4.0 * r,
            "r {r}: {}",
            g.edge_points.len()
        );
        let mut sectors = [false; 36];
        for p in &g.edge_points {
            let d = p.dist(Point::new(cx, cy));
            assert!((d - r).abs() <= 1.0, "r {r}: edge point at distance {d}");
            let a = (p.y - cy).atan2(p.x - cx) + std::f64::consts::PI;
            sectors[((a / std::f64::consts::TAU * 36.0) as usize).min(35)] = true;
        }
        assert!(sectors.iter().all(|&s| s), "r {r}: ring has gaps");
        let mean = g
            .edge_points
            .iter()
            .map(|p| p.dist(Point::new(cx, cy)))
            .sum::<f64>()
            / g.edge_points.len() as f64;
        assert!((mean - r).abs() < 0.5, "r {r}: mean radius {mean}");
        // The shell of a disc is close to the disc: area within 10%.
        let area = std::f64::consts::PI * r * r;
        assert!(
            (g.shell.area() - area).abs() < 0.1 * area,
            "{} vs {area}",
            g.shell.area()
        );
    }
}

/// Symmetric shapes have their centroid on the centre of symmetry, and axis-aligned ones no
/// orientation: a plus sign, an annulus and a 4-fold symmetric blob.
#[test]
fn centroid_of_symmetric_shapes() {
    // Plus sign centred on pixel (50, 60): centroid at its centre (50.5, 60.5).
    let mut d = vec![0u8; 21 * 21];
    for i in 0..21 {
        for k in 8..13 {
            d[i * 21 + k] = 1;
            d[k * 21 + i] = 1;
        }
    }
    let plus = Mask::new(40, 50, 21, 21, d).unwrap();
    let g = mask_geometry(&plus, &GeometryConfig::default()).unwrap();
    assert!(g.centroid.dist(Point::new(50.5, 60.5)) < 1e-12);
    assert!(g.moments.mu11.abs() < 1e-9);
    assert!((g.moments.mu20 - g.moments.mu02).abs() < 1e-9);
    assert!(g.moments.elongation() < 1e-12);
    // The plus's contour: 8 convex corners, and each of the 4 concave corners cut diagonally
    // by 8-connected border following (2 points each) — 16, as OpenCV gives.
    assert_eq!(g.contour.len(), 16);

    // An annulus (centre not in the mask) still has its centroid at the centre.
    let (cx, cy) = (200.0, 100.0);
    let outer = disc(cx, cy, 20.0);
    let inner = disc(cx, cy, 10.0);
    let ring: Vec<u8> = outer
        .pixels()
        .fold(vec![0u8; outer.data().len()], |mut acc, (x, y)| {
            if !inner.get(x, y) {
                let i =
                    (y - outer.y()) as usize * outer.width() as usize + (x - outer.x()) as usize;
                acc[i] = 1;
            }
            acc
        });
    let ring = Mask::new(outer.x(), outer.y(), outer.width(), outer.height(), ring).unwrap();
    let g = mask_geometry(&ring, &GeometryConfig::default()).unwrap();
    assert!(
        g.centroid.dist(Point::new(cx, cy)) < 1e-9,
        "{:?}",
        g.centroid
    );
    assert!(!ring.get(cx as i32, cy as i32));
    assert!(g.shell.contains(Point::new(cx, cy)));
}

/// An elongated, rotated bar: orientation and elongation from the central moments.
#[test]
fn bar_orientation() {
    // A 41×5 bar along the image diagonal y = x.
    let n = 60;
    let mut d = vec![0u8; n * n];
    for y in 0..n {
        for x in 0..n {
            let (u, v) = (x as f64 - 30.0, y as f64 - 30.0);
            let along = (u + v) / 2f64.sqrt();
            let across = (v - u) / 2f64.sqrt();
            if along.abs() <= 20.0 && across.abs() <= 2.5 {
                d[y * n + x] = 1;
            }
        }
    }
    let m = Moments::of_mask(&Mask::new(0, 0, n as u32, n as u32, d).unwrap()).unwrap();
    assert!((m.orientation() - std::f64::consts::FRAC_PI_4).abs() < 1e-9);
    assert!(m.elongation() > 0.95);
    let (major, minor) = m.axis_std();
    // Uniform bar: std along = 40/√12 ≈ 11.5, across ≈ 5/√12 ≈ 1.4 (pixelised).
    assert!((major - 40.0 / 12f64.sqrt()).abs() < 0.5, "{major}");
    assert!((minor - 5.0 / 12f64.sqrt()).abs() < 0.3, "{minor}");
}
