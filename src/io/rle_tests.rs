//! Unit tests of `io::rle` (a file of their own: the module's code is long enough).

use super::columns::KEPT_CHANGES;
use super::*;

#[test]
fn bitmap_runs_start_with_background_and_decode_back() {
    assert_eq!(bitmap_runs(&[]), [0]);
    assert_eq!(bitmap_runs(&[1, 1, 0]), [0, 2, 1]);
    assert_eq!(bitmap_runs(&[0, 0, 1, 0, 1, 1]), [2, 1, 1, 2]);
    // A 3-wide bitmap round trips through (row, column) positions.
    let bitmap = [0u8, 1, 1, 1, 0, 0, 0, 0, 1];
    let mut back = [0u8; 9];
    for_each_run_pixel(&bitmap_runs(&bitmap), 3, |row, col| {
        back[(row * 3 + col) as usize] = 1;
    });
    assert_eq!(back, bitmap);
    // A zero-length foreground run paints nothing.
    for_each_run_pixel(&[2, 0, 1], 3, |_, _| panic!("no foreground"));
}

/// Strings produced by pycocotools 2.0 (`mask.encode(np.asfortranarray(m))['counts']`).
#[test]
fn matches_pycocotools_strings() {
    // 4x3 image, foreground at (row 1, col 0), (row 2, col 0), (row 0, col 2).
    let (h, w) = (4u32, 3u32);
    let mut m = vec![0u8; (h * w) as usize];
    for (r, c) in [(1, 0), (2, 0), (0, 2)] {
        m[r * w as usize + c] = 1;
    }
    let rle = Rle::encode(w, h, &m).unwrap();
    assert_eq!(rle.counts, vec![1, 2, 5, 1, 3]);
    // Verified with pycocotools 2.0: mask.encode(np.asfortranarray(m))["counts"] == b"125ON".
    assert_eq!(rle.to_compressed(), "125ON");
    let back = Rle::from_compressed("125ON", h, w).unwrap();
    assert_eq!(back, rle);
    assert_eq!(back.decode(), m);
}

#[test]
fn roundtrip_large_runs() {
    let (w, h) = (640u32, 480u32);
    let mut m = vec![0u8; (w * h) as usize];
    for y in 100..300 {
        for x in 50..400 {
            m[y * w as usize + x] = 1;
        }
    }
    let rle = Rle::encode(w, h, &m).unwrap();
    let s = rle.to_compressed();
    let back = Rle::from_compressed(&s, h, w).unwrap();
    assert_eq!(back.decode(), m);
    assert_eq!(back.area(), 200 * 350);
    let mask = back.to_mask();
    assert_eq!(Rle::from_mask(&mask, w, h), rle);
}

/// The straightforward encoder: every image pixel, column by column.
fn from_mask_per_pixel(mask: &Mask, width: u32, height: u32) -> Rle {
    let mut full = vec![0u8; (width * height) as usize];
    for (x, y) in mask.pixels() {
        if x >= 0 && y >= 0 && (x as u32) < width && (y as u32) < height {
            full[y as usize * width as usize + x as usize] = 1;
        }
    }
    Rle::encode(width, height, &full).unwrap()
}

#[test]
fn from_mask_equals_per_pixel_encoding() {
    let bits: Vec<u8> = (0..12 * 9)
        .map(|i| ((i * 7 + i / 5) % 3 == 0) as u8)
        .collect();
    let m = Mask::new(0, 0, 12, 9, bits).unwrap();
    // Inside, touching each border, partly and wholly outside the image.
    for (dx, dy) in [
        (3, 2),
        (0, 0),
        (28, 21),
        (-5, -4),
        (35, 3),
        (3, 40),
        (-20, 0),
        (45, 3),
        (45, 40),
    ] {
        let mm = m.translated(dx, dy);
        let rle = Rle::from_mask(&mm, 40, 30);
        assert_eq!(rle, from_mask_per_pixel(&mm, 40, 30), "{dx},{dy}");
        // The packed string is what compressing the unpacked runs gives (the bindings
        // hand it out as it is).
        let packed = PackedRle::new(&rle);
        assert_eq!(packed.compressed(), packed.unpack().to_compressed());
    }
    assert_eq!(Rle::from_mask(&Mask::empty(), 5, 4), Rle::empty(5, 4));
}

#[test]
fn from_mask_equals_per_pixel_encoding_on_wide_random_masks() {
    // Masks wider and taller than the fixed pattern above: a blob with speckle (many runs
    // per column, runs crossing column ends), clipped on every side.
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    for (w, h) in [(53u32, 37u32), (16, 5), (17, 1), (1, 23), (70, 40)] {
        let bits: Vec<u8> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let blob = (x as i64 - 20).pow(2) + (y as i64 - 15).pow(2) < 150;
                (blob ^ (next() % 13 == 0)) as u8
            })
            .collect();
        let m = Mask::new(0, 0, w, h, bits).unwrap();
        for (dx, dy) in [
            (0, 0),
            (5, 3),
            (-9, -4),
            (30, 20),
            (-60, 0),
            (0, 45),
            (70, 2),
        ] {
            let mm = m.translated(dx, dy);
            assert_eq!(
                Rle::from_mask(&mm, 64, 48),
                from_mask_per_pixel(&mm, 64, 48),
                "{w}x{h} at {dx},{dy}"
            );
        }
    }
}

#[test]
fn a_ragged_mask_leaves_no_large_buffers_and_the_next_mask_encodes_alike() {
    // A checkerboard changes value at every pixel of every column: more changes than the
    // reused buffers keep.
    let (w, h) = (600u32, 300u32);
    let bits: Vec<u8> = (0..w * h).map(|i| ((i % w + i / w) % 2) as u8).collect();
    let ragged = Mask::new(0, 0, w, h, bits).unwrap();
    assert_eq!(
        Rle::from_mask(&ragged, w, h),
        from_mask_per_pixel(&ragged, w, h)
    );
    CHANGES.with(|c| assert!(c.borrow().found.capacity() <= KEPT_CHANGES));
    let blob: Vec<u8> = (0..40 * 30)
        .map(|i| (((i % 40) as i64 - 20).pow(2) + ((i / 40) as i64 - 15).pow(2) < 120) as u8)
        .collect();
    let m = Mask::new(7, 5, 40, 30, blob).unwrap();
    assert_eq!(Rle::from_mask(&m, 64, 48), from_mask_per_pixel(&m, 64, 48));
}

#[test]
fn to_mask_equals_full_bitmap_decoding() {
    let bits: Vec<u8> = (0..12 * 9)
        .map(|i| ((i * 5 + i / 7) % 4 == 0) as u8)
        .collect();
    let m = Mask::new(0, 0, 12, 9, bits).unwrap();
    for (dx, dy) in [(3, 2), (0, 0), (28, 21), (-5, -4), (35, 3), (-20, 0)] {
        let rle = Rle::from_mask(&m.translated(dx, dy), 40, 30);
        let full = Mask::from_full(40, 30, &rle.decode()).unwrap();
        assert_eq!(rle.to_mask(), full, "{dx},{dy}");
    }
    // A run crossing a column boundary: bottom of column 0 and top of column 1.
    let rle = Rle {
        height: 4,
        width: 3,
        counts: vec![3, 2, 7],
    };
    assert_eq!(rle.to_mask(), Mask::from_full(3, 4, &rle.decode()).unwrap());
    assert!(Rle::empty(3, 4).to_mask().is_empty());
}

#[test]
fn rejects_bad_strings() {
    assert!(matches!(
        Rle::from_compressed("1 2", 2, 2),
        Err(RleError::BadChar { .. })
    ));
    assert!(matches!(
        Rle::from_compressed("1", 2, 2),
        Err(RleError::SizeMismatch { .. })
    ));
    assert!(matches!(
        Rle::from_compressed("P", 2, 2),
        Err(RleError::Truncated)
    ));
}

#[test]
fn iou_by_runs_equals_bitmap_iou() {
    let (w, h) = (7u32, 5u32);
    let a: Vec<u8> = (0..35).map(|i| ((i * 7 + 3) % 5 < 2) as u8).collect();
    let b: Vec<u8> = (0..35).map(|i| ((i * 3 + 1) % 4 < 2) as u8).collect();
    let (ra, rb) = (
        Rle::encode(w, h, &a).unwrap(),
        Rle::encode(w, h, &b).unwrap(),
    );
    let inter = a
        .iter()
        .zip(&b)
        .filter(|(x, y)| **x == 1 && **y == 1)
        .count() as u64;
    assert_eq!(ra.intersection(&rb), inter);
    let union = a
        .iter()
        .zip(&b)
        .filter(|(x, y)| **x == 1 || **y == 1)
        .count() as f64;
    assert!((ra.iou(&rb) - inter as f64 / union).abs() < 1e-15);
    assert_eq!(ra.union(&rb).area() as f64, union);
}
