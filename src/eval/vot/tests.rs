//! Unit tests of region overlap (both methods) and anchor placement.

use super::*;
use crate::frame::{BBox, Mask, Point};
use crate::io::vot::Direction;

fn poly(p: &[(f64, f64)]) -> Region {
    Region::Polygon(p.iter().map(|&(x, y)| Point::new(x, y)).collect())
}

#[test]
fn exact_overlap_of_rectangles_and_rotated_boxes() {
    let a = Region::Rectangle(BBox::new(0.0, 0.0, 10.0, 10.0));
    let b = Region::Rectangle(BBox::new(5.0, 5.0, 10.0, 10.0));
    assert!((overlap(&a, &b, None, OverlapMethod::Exact) - 25.0 / 175.0).abs() < 1e-12);
    let d = poly(&[(5.0, 0.0), (10.0, 5.0), (5.0, 10.0), (0.0, 5.0)]);
    assert!((overlap(&d, &d, None, OverlapMethod::Exact) - 1.0).abs() < 1e-12);
    // The diamond inscribed in the square covers half of it.
    assert!((overlap(&a, &d, None, OverlapMethod::Exact) - 0.5).abs() < 1e-12);
    let far = poly(&[(105.0, 0.0), (110.0, 5.0), (105.0, 10.0), (100.0, 5.0)]);
    assert_eq!(overlap(&d, &far, None, OverlapMethod::Exact), 0.0);
    // Bounds clip: half of b lies outside a 10x10 image... a quarter of it inside.
    let inside = overlap(&a, &b, Some((10, 10)), OverlapMethod::Exact);
    assert!((inside - 25.0 / 100.0).abs() < 1e-12);
    // Two empty regions overlap 1, one empty region 0.
    let s = Region::Special(0);
    assert_eq!(overlap(&s, &s, None, OverlapMethod::Exact), 1.0);
    assert_eq!(overlap(&s, &a, None, OverlapMethod::Exact), 0.0);
}

#[test]
fn non_convex_and_self_intersecting_polygons() {
    // An L shape: 3x3 square minus its top-right 2x2 → area 5.
    let l = poly(&[
        (0.0, 0.0),
        (1.0, 0.0),
        (1.0, 2.0),
        (3.0, 2.0),
        (3.0, 3.0),
        (0.0, 3.0),
    ]);
    assert!((region_area(&l, None) - 5.0).abs() < 1e-12);
    let sq = Region::Rectangle(BBox::new(0.0, 0.0, 3.0, 3.0));
    assert!((overlap(&l, &sq, None, OverlapMethod::Exact) - 5.0 / 9.0).abs() < 1e-12);
    // A bow tie (two triangles of area 1 each, even-odd).
    let bow = poly(&[(0.0, 0.0), (2.0, 2.0), (2.0, 0.0), (0.0, 2.0)]);
    assert!((region_area(&bow, None) - 2.0).abs() < 1e-12);
}

#[test]
fn polygon_against_mask_counts_pixel_squares() {
    let mut data = vec![0u8; 16];
    data[5] = 1; // pixel (1,1) of a 4x4 mask at (2, 3)
    data[6] = 1;
    let m = Region::Mask(Mask::new(2, 3, 4, 4, data).unwrap());
    let r = Region::Rectangle(BBox::new(3.0, 4.0, 2.0, 1.0));
    assert!((overlap(&m, &r, None, OverlapMethod::Exact) - 1.0).abs() < 1e-12);
    let half = Region::Rectangle(BBox::new(3.5, 4.0, 1.0, 1.0));
    assert!((overlap(&m, &half, None, OverlapMethod::Exact) - 0.5).abs() < 1e-12);
    assert!((overlap(&m, &m, None, OverlapMethod::Exact) - 1.0).abs() < 1e-12);
}

#[test]
fn toolkit_raster_matches_known_values() {
    let a = Region::Rectangle(BBox::new(0.0, 0.0, 10.0, 10.0));
    let b = Region::Rectangle(BBox::new(5.0, 5.0, 10.0, 10.0));
    // vot-toolkit 0.9: calculate_overlap(Rectangle(0,0,10,10), Rectangle(5,5,10,10)).
    assert!((overlap(&a, &b, Some((480, 360)), OverlapMethod::Toolkit) - 1.0 / 7.0).abs() < 1e-15);
    let s = Region::Special(1);
    assert_eq!(overlap(&s, &s, None, OverlapMethod::Toolkit), 1.0);
    assert_eq!(
        overlap(&s, &a, Some((480, 360)), OverlapMethod::Toolkit),
        0.0
    );
}

#[test]
fn anchors_run_towards_the_longer_side() {
    let a = anchors_every(196, 50);
    let f: Vec<(usize, Direction)> = a.iter().map(|a| (a.frame, a.direction)).collect();
    assert_eq!(
        f,
        vec![
            (0, Direction::Forward),
            (50, Direction::Forward),
            (100, Direction::Backward),
            (150, Direction::Backward)
        ]
    );
    assert_eq!(anchor_frames(&a[2], 196).len(), 101);
    assert_eq!(anchor_frames(&a[1], 196).len(), 146);
}
