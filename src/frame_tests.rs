//! Unit tests of `frame` (a file of their own: the module's code is long enough).

use super::mask::{count_common, count_ones};
use super::*;

/// `round_u8` is `f32::round` then the clamp, on every luma a pixel can have, on the
/// values next to every half (where `floor(v + 0.5)` would differ), and past 255.
#[test]
fn round_u8_is_round() {
    let want = |v: f32| v.round().clamp(0.0, 255.0) as u8;
    for r in (0..=255u32).step_by(5) {
        for g in 0..=255u32 {
            for b in (0..=255u32).step_by(3) {
                let v = 0.299 * r as f32 + 0.587 * g as f32 + 0.114 * b as f32;
                assert_eq!(round_u8(v), want(v), "{v}");
            }
        }
    }
    for k in 0..=256u32 {
        let half = k as f32 + 0.5;
        for v in [
            half,
            f32::from_bits(half.to_bits() - 1),
            f32::from_bits(half.to_bits() + 1),
            k as f32,
        ] {
            assert_eq!(round_u8(v), want(v), "{v}");
        }
    }
    assert_eq!(round_u8(0.49999997), 0);
    assert_eq!(round_u8(300.0), 255);
}

#[test]
fn frame_checks_sizes() {
    let buf = vec![0u8; 10];
    assert!(matches!(
        Frame::rgb(&buf, 2, 2),
        Err(FrameError::BufferTooSmall { .. })
    ));
    assert!(matches!(
        Frame::new(&buf, 2, 1, 5, PixelFormat::Rgb8),
        Err(FrameError::StrideTooSmall { .. })
    ));
    assert!(matches!(
        Frame::rgb(&buf, 0, 1),
        Err(FrameError::Empty { .. })
    ));
    let buf = vec![7u8; 16];
    let f = Frame::rgba(&buf, 2, 2).unwrap();
    assert_eq!(f.rgb_at(1, 1), Some([7, 7, 7]));
    assert_eq!(f.rgb_at(2, 0), None);
}

#[test]
fn bbox_iou_matches_hand_computation() {
    let a = BBox::new(0.0, 0.0, 10.0, 10.0);
    let b = BBox::new(5.0, 5.0, 10.0, 10.0);
    assert!((a.iou(&b) - 25.0 / 175.0).abs() < 1e-12);
    assert_eq!(a.iou(&BBox::new(20.0, 0.0, 5.0, 5.0)), 0.0);
    assert_eq!(a.iou(&BBox::new(0.0, 0.0, 0.0, 5.0)), 0.0);
    assert!((a.iou(&a) - 1.0).abs() < 1e-12);
}

/// The area and box are counted when a mask is built; every way of building one must
/// agree with a recount of its bitmap, and a stored mask must check its bitmap.
#[test]
fn cached_area_and_box_match_a_recount_and_stored_masks_are_checked() {
    let recount = |m: &Mask| {
        let full = m.to_full(40, 30);
        let again = Mask::from_full(40, 30, &full).unwrap();
        (full.iter().map(|&v| v as u64).sum::<u64>(), again.bbox())
    };
    let mut full = vec![0u8; 40 * 30];
    for (x, y) in [(12, 11), (13, 11), (13, 12), (15, 14), (20, 20)] {
        full[y * 40 + x] = 1;
    }
    let a = Mask::from_full(40, 30, &full).unwrap();
    let sparse = Mask::new(
        3,
        4,
        5,
        3,
        vec![0, 0, 0, 0, 0, 0, 1, 0, 7, 0, 0, 0, 0, 0, 0],
    )
    .unwrap();
    let masks = [
        a.clone(),
        a.translated(-3, 5),
        a.translated(30, 0).clipped(40, 30),
        sparse.clone(),
        sparse.tight(),
        Mask::from_bbox(&BBox::new(2.2, 3.7, 6.0, 4.1)),
        Mask::empty().translated(4, 4),
    ];
    for m in &masks {
        let (area, bbox) = recount(m);
        assert_eq!(m.area(), area);
        assert_eq!(m.is_empty(), area == 0);
        if area > 0 {
            assert_eq!(m.bbox(), bbox);
        } else {
            assert_eq!(m.bbox(), BBox::default());
        }
        let json = serde_json::to_string(m).unwrap();
        assert_eq!(&serde_json::from_str::<Mask>(&json).unwrap(), m);
    }
    assert_eq!(sparse.bbox(), BBox::new(4.0, 5.0, 3.0, 1.0));
    let short = r#"{"x":0,"y":0,"width":3,"height":3,"data":[1,1]}"#;
    assert!(serde_json::from_str::<Mask>(short).is_err());
}

#[test]
fn mask_roundtrips_through_full_bitmap() {
    let mut full = vec![0u8; 8 * 6];
    for (x, y) in [(2, 1), (3, 1), (3, 2), (5, 4)] {
        full[y * 8 + x] = 255;
    }
    let m = Mask::from_full(8, 6, &full).unwrap();
    assert_eq!((m.x(), m.y(), m.width(), m.height()), (2, 1, 4, 4));
    assert_eq!(m.area(), 4);
    assert_eq!(
        m.to_full(8, 6),
        full.iter().map(|&v| (v != 0) as u8).collect::<Vec<_>>()
    );
    assert_eq!(m.bbox(), BBox::new(2.0, 1.0, 4.0, 4.0));
    let c = m.centroid().unwrap();
    assert!((c.x - (2.0 + 3.0 + 3.0 + 5.0) / 4.0 - 0.5).abs() < 1e-12);
    assert!((m.iou(&m) - 1.0).abs() < 1e-12);
    assert_eq!(m.iou(&m.translated(10, 0)), 0.0);
    // Shifting in place equals copying the mask moved, for every offset around it.
    let other = Mask::from_bbox(&BBox::new(1.0, 0.0, 5.0, 3.0));
    for dx in -6..=6 {
        for dy in -5..=5 {
            let moved = m.translated(dx, dy);
            assert_eq!(
                m.intersection_shifted(dx, dy, &other),
                moved.intersection(&other)
            );
            assert_eq!(m.iou_shifted(dx, dy, &other), moved.iou(&other));
            // Against a pixel-by-pixel count on full images (a 20 × 20 canvas offset so
            // every shift stays inside).
            let (fa, fb) = (
                moved.translated(7, 7).to_full(20, 20),
                other.translated(7, 7).to_full(20, 20),
            );
            let want = fa.iter().zip(&fb).filter(|(a, b)| **a & **b != 0).count();
            assert_eq!(m.intersection_shifted(dx, dy, &other), want as u64);
        }
    }
}

/// Byte-block counting equals a plain count, across block boundaries and on all-ones
/// runs longer than a block (where a byte counter would wrap).
#[test]
fn bitmap_counts_are_exact() {
    let mut s = 99u64;
    for len in [0usize, 1, 254, 255, 256, 511, 1000, 4099] {
        let mut bit = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1);
            ((s >> 33) % 3 != 0) as u8
        };
        let (a, b): (Vec<u8>, Vec<u8>) = (0..len).map(|_| (bit(), bit())).unzip();
        let naive = |v: &[u8]| v.iter().filter(|&&x| x != 0).count() as u64;
        assert_eq!(count_ones(&a), naive(&a), "len {len}");
        let both: Vec<u8> = a.iter().zip(&b).map(|(x, y)| x & y).collect();
        assert_eq!(count_common(&a, &b), naive(&both), "len {len}");
        let ones = vec![1u8; len];
        assert_eq!(count_ones(&ones), len as u64);
        assert_eq!(count_common(&ones, &ones), len as u64);
    }
}

#[test]
fn mask_from_bbox_covers_pixel_centres() {
    let m = Mask::from_bbox(&BBox::new(1.0, 2.0, 3.0, 2.0));
    assert_eq!(
        (m.x(), m.y(), m.width(), m.height(), m.area()),
        (1, 2, 3, 2, 6)
    );
    assert!(Mask::from_bbox(&BBox::new(1.0, 1.0, 0.2, 0.2)).is_empty());
}

#[test]
fn a_box_clipped_to_the_image_keeps_only_its_part_inside() {
    let b = BBox::new(-1e9, 5.0, 3e9, 4.0).clipped(640, 480);
    assert_eq!((b.x, b.y, b.w, b.h), (0.0, 5.0, 640.0, 4.0));
    let outside = BBox::new(700.0, 10.0, 20.0, 20.0).clipped(640, 480);
    assert_eq!(outside.area(), 0.0);
    assert!(Mask::from_bbox(&outside).is_empty());
    let inside = BBox::new(1.5, 2.5, 3.0, 4.0);
    assert_eq!(inside.clipped(640, 480), inside);
}
