//! Unit tests of the SIFT port: geometry of keypoints, descriptor normalisation, matching,
//! masks, bounds and bad input.

use super::*;
use image::{imageops, GrayImage, Luma};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// Deterministic grey texture: a mid-grey field with `n` soft Gaussian blobs and `n / 2`
/// hard-edged rectangles of random size, contrast and position, so there are blobs and corners
/// at many scales.
fn texture(w: u32, h: u32, seed: u64, n: usize) -> GrayImage {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut f = vec![128f32; (w * h) as usize];
    for _ in 0..n {
        let cx = rng.gen_range(0.0..w as f32);
        let cy = rng.gen_range(0.0..h as f32);
        let s = rng.gen_range(1.0f32..5.0);
        let a = rng.gen_range(-90.0f32..90.0);
        let (sx, sy) = (s, s * rng.gen_range(0.6f32..1.0));
        for y in 0..h {
            for x in 0..w {
                let (dx, dy) = ((x as f32 + 0.5 - cx) / sx, (y as f32 + 0.5 - cy) / sy);
                let d2 = dx * dx + dy * dy;
                if d2 < 16.0 {
                    f[(y * w + x) as usize] += a * (-0.5 * d2).exp();
                }
            }
        }
    }
    for _ in 0..n / 2 {
        let x0 = rng.gen_range(0..w);
        let y0 = rng.gen_range(0..h);
        let (rw, rh) = (rng.gen_range(2..12), rng.gen_range(2..12));
        let a = rng.gen_range(-60.0f32..60.0);
        for y in y0..(y0 + rh).min(h) {
            for x in x0..(x0 + rw).min(w) {
                f[(y * w + x) as usize] += a;
            }
        }
    }
    GrayImage::from_fn(w, h, |x, y| {
        Luma([f[(y * w + x) as usize].round().clamp(0.0, 255.0) as u8])
    })
}

fn gaussian_blob(size: u32, centre: f32, sigma: f32) -> GrayImage {
    GrayImage::from_fn(size, size, |x, y| {
        let (dx, dy) = (x as f32 + 0.5 - centre, y as f32 + 0.5 - centre);
        let v = 20.0 + 200.0 * (-(dx * dx + dy * dy) / (2.0 * sigma * sigma)).exp();
        Luma([v.round() as u8])
    })
}

fn angle_diff(a: f32, b: f32) -> f32 {
    ((a - b).rem_euclid(360.0)).min((b - a).rem_euclid(360.0))
}

#[test]
fn blob_gives_keypoint_at_centre_with_size_proportional_to_sigma() {
    let mut ratios = Vec::new();
    for &sigma in &[2.0f32, 3.0, 4.5, 6.0] {
        let img = gaussian_blob(128, 64.0, sigma);
        let f = detect_and_compute(&img, None, &SiftConfig::default()).unwrap();
        // The strongest keypoint is the blob itself.
        let k = f.keypoints.first().expect("a blob must give a keypoint");
        assert!(
            (k.x - 64.0).abs() < 0.3 && (k.y - 64.0).abs() < 0.3,
            "sigma {sigma}: keypoint at ({}, {})",
            k.x,
            k.y
        );
        ratios.push(k.size / sigma);
    }
    // size = 2 x detection scale, and the DoG of a Gaussian blob of std s peaks near scale s.
    let mean = ratios.iter().sum::<f32>() / ratios.len() as f32;
    assert!((1.6..2.8).contains(&mean), "size/sigma ratios {ratios:?}");
    for r in &ratios {
        assert!(
            (r / mean - 1.0).abs() < 0.15,
            "size/sigma ratios {ratios:?}"
        );
    }
}

/// Pairs each keypoint of `a` with the keypoints of `b` at its position after a clockwise 90°
/// rotation of an `h`-row image (same scale within 10 %), and returns (paired, how many of
/// those have a keypoint whose angle is the original + 90° within `tol` degrees).
fn rotated_angle_agreement(a: &SiftFeatures, b: &SiftFeatures, h: f32, tol: f32) -> (usize, usize) {
    let (mut paired, mut agree) = (0, 0);
    for ka in &a.keypoints {
        // Clockwise rotation maps the continuous point (x, y) to (h - y, x).
        let (x, y) = (h - ka.y, ka.x);
        let near: Vec<&Keypoint> = b
            .keypoints
            .iter()
            .filter(|kb| (kb.x - x).hypot(kb.y - y) < 0.75 && (kb.size / ka.size).ln().abs() < 0.1)
            .collect();
        if near.is_empty() {
            continue;
        }
        paired += 1;
        let expected = (ka.angle + 90.0).rem_euclid(360.0);
        let best = near
            .iter()
            .map(|kb| angle_diff(kb.angle, expected))
            .fold(f32::INFINITY, f32::min);
        if best < tol {
            agree += 1;
        }
    }
    (paired, agree)
}

#[test]
fn rotating_the_image_90_degrees_rotates_keypoint_angles_by_90() {
    // Without upsampling and with a side of 2^k + 1, every octave's sampling grid maps onto
    // itself under the rotation, so the whole pyramid is rotation-equivariant and the angles
    // must follow the rotation almost exactly.
    let img = texture(129, 129, 7, 90);
    let rot = imageops::rotate90(&img);
    let cfg = SiftConfig {
        upsample: false,
        ..SiftConfig::default()
    };
    let a = detect_and_compute(&img, None, &cfg).unwrap();
    let b = detect_and_compute(&rot, None, &cfg).unwrap();
    let (paired, agree) = rotated_angle_agreement(&a, &b, 129.0, 1.0);
    eprintln!("equivariant: {agree}/{paired} of {} within 1 deg", a.len());
    assert!(
        paired >= 30 && paired as f32 >= 0.8 * a.len() as f32,
        "{paired}/{}",
        a.len()
    );
    assert!(
        agree as f32 >= 0.95 * paired as f32,
        "{agree}/{paired} within 1 deg"
    );

    // With OpenCV's default upsampling, octaves >= 0 take the odd samples of the rotated
    // upsampled image where the original takes the even ones: a half-pixel shift that moves
    // angles by a few degrees (octave -1 stays exact).
    let img = texture(128, 128, 7, 90);
    let rot = imageops::rotate90(&img);
    let cfg = SiftConfig::default();
    let a = detect_and_compute(&img, None, &cfg).unwrap();
    let b = detect_and_compute(&rot, None, &cfg).unwrap();
    let (paired, agree) = rotated_angle_agreement(&a, &b, 128.0, 5.0);
    eprintln!("default: {agree}/{paired} of {} within 5 deg", a.len());
    assert!(
        paired >= 40,
        "only {paired} of {} keypoints re-found",
        a.len()
    );
    assert!(
        agree as f32 >= 0.85 * paired as f32,
        "{agree}/{paired} within 5 deg"
    );
}

#[test]
fn descriptors_are_unit_norm_before_byte_scaling() {
    let img = texture(96, 96, 3, 40);
    let plane = Plane {
        w: 96,
        h: 96,
        data: img.as_raw().iter().map(|&v| f32::from(v)).collect(),
    };
    let (kps, desc) = detect_float(plane, 96, 96, None, &SiftConfig::default()).unwrap();
    assert!(kps.len() >= 20);
    for d in &desc {
        let n: f32 = d.iter().map(|v| v * v).sum::<f32>().sqrt();
        assert!((n - 1.0).abs() < 1e-4, "norm {n}");
        // Clipping at 0.2 of the pre-clip norm bounds every entry after renormalisation.
        assert!(d.iter().all(|&v| (0.0..=0.5).contains(&v)));
        let q = quantize(d);
        let qn: f32 = q.iter().map(|&v| f32::from(v).powi(2)).sum::<f32>().sqrt();
        assert!((qn - 512.0).abs() < 8.0, "byte norm {qn}");
    }
    // The public entry point stores exactly these quantised vectors.
    let f = detect_and_compute(&img, None, &SiftConfig::default()).unwrap();
    assert_eq!(f.descriptors, desc.iter().map(quantize).collect::<Vec<_>>());
}

#[test]
fn ratio_test_rejects_ambiguous_matches() {
    let img = texture(96, 96, 11, 40);
    let a = detect_and_compute(&img, None, &SiftConfig::default()).unwrap();
    assert!(a.len() >= 20);
    // Against itself every descriptor is its own, unambiguous, nearest neighbour…
    let self_matches = match_descriptors(&a, &a, &MatchConfig::default());
    let exact = self_matches
        .iter()
        .filter(|m| m.query == m.train && m.distance == 0.0)
        .count();
    assert!(exact as f32 >= 0.9 * a.len() as f32, "{exact}/{}", a.len());
    // …but when every train descriptor appears twice, best = second and nothing passes.
    let doubled: Vec<[u8; 128]> = a.descriptors.iter().flat_map(|d| [*d, *d]).collect();
    let m = match_descriptor_sets(&a.descriptors, &doubled, &MatchConfig::default());
    assert!(m.is_empty(), "{} ambiguous matches kept", m.len());
    // A lone train descriptor has no rival: it is matched.
    let one = match_descriptor_sets(
        &a.descriptors[..1],
        &a.descriptors[..1],
        &MatchConfig::default(),
    );
    assert_eq!(one.len(), 1);
}

#[test]
fn cross_check_keeps_only_mutual_nearest() {
    let img = texture(96, 96, 5, 40);
    let a = detect_and_compute(&img, None, &SiftConfig::default()).unwrap();
    let cfg = MatchConfig {
        ratio: 1.0,
        cross_check: true,
    };
    // Train set = a's descriptors plus a copy of the first one slightly perturbed: both the
    // original and the copy have query 0 as nearest, but query 0 picks only one.
    let mut train = a.descriptors.clone();
    let mut near = a.descriptors[0];
    near[0] = near[0].saturating_add(1);
    train.push(near);
    let m = match_descriptor_sets(&a.descriptors, &train, &cfg);
    for mm in &m {
        let back = (0..a.len())
            .min_by_key(|&q| {
                a.descriptors[q]
                    .iter()
                    .zip(&train[mm.train])
                    .map(|(&x, &y)| (i32::from(x) - i32::from(y)).pow(2))
                    .sum::<i32>()
            })
            .unwrap();
        assert_eq!(back, mm.query);
    }
    assert!(!m.iter().any(|mm| mm.train == a.len()));
}

#[test]
fn mask_keeps_exactly_the_keypoints_inside_it() {
    let img = texture(120, 100, 9, 60);
    let cfg = SiftConfig::default();
    let all = detect_and_compute(&img, None, &cfg).unwrap();
    let mask = GrayImage::from_fn(120, 100, |x, _| Luma([if x < 60 { 255 } else { 0 }]));
    let masked = detect_and_compute(&img, Some(&mask), &cfg).unwrap();
    assert!(!masked.is_empty());
    assert!(masked.keypoints.iter().all(|k| k.x < 60.0));
    let expected: Vec<Keypoint> = all
        .keypoints
        .iter()
        .filter(|k| k.x < 60.0)
        .copied()
        .collect();
    assert_eq!(masked.keypoints, expected);
    assert!(masked.len() < all.len());
    // An all-zero mask keeps nothing.
    let none = detect_and_compute(&img, Some(&GrayImage::new(120, 100)), &cfg).unwrap();
    assert!(none.is_empty());
}

#[test]
fn max_keypoints_keeps_the_strongest() {
    let img = texture(128, 128, 13, 80);
    let all = detect_and_compute(&img, None, &SiftConfig::default()).unwrap();
    assert!(all.len() > 30);
    let cfg = SiftConfig {
        max_keypoints: Some(25),
        ..SiftConfig::default()
    };
    let best = detect_and_compute(&img, None, &cfg).unwrap();
    assert!(best.len() >= 25 && best.len() <= 28, "{}", best.len());
    assert_eq!(best.keypoints[..], all.keypoints[..best.len()]);
    let min_kept = best.keypoints.last().unwrap().response;
    assert!(all.keypoints[best.len()..]
        .iter()
        .all(|k| k.response < min_kept));
    assert!(all
        .keypoints
        .windows(2)
        .all(|p| p[0].response >= p[1].response));
}

#[test]
fn max_side_downscales_and_maps_back_to_input_coordinates() {
    let img = texture(160, 120, 17, 70);
    let cfg = SiftConfig {
        max_side: Some(80),
        ..SiftConfig::default()
    };
    let f = detect_and_compute(&img, None, &cfg).unwrap();
    assert!(!f.is_empty());
    // Reference: detection on the 2x2 block means, coordinates doubled.
    let small: Vec<f32> = (0..60u32)
        .flat_map(|y| (0..80u32).map(move |x| (x, y)))
        .map(|(x, y)| {
            let p = |dx, dy| f32::from(img.get_pixel(2 * x + dx, 2 * y + dy).0[0]);
            (p(0, 0) + p(1, 0) + p(0, 1) + p(1, 1)) / 4.0
        })
        .collect();
    let r = detect_and_compute_f32(&small, 80, 60, None, &SiftConfig::default()).unwrap();
    assert_eq!(f.len(), r.len());
    for (a, b) in f.keypoints.iter().zip(&r.keypoints) {
        assert!((a.x - 2.0 * b.x).abs() < 1e-3 && (a.y - 2.0 * b.y).abs() < 1e-3);
        assert!((a.size - 2.0 * b.size).abs() < 1e-3);
        assert_eq!(a.angle, b.angle);
    }
    assert_eq!(f.descriptors, r.descriptors);
    // Keypoints lie inside the input.
    assert!(f
        .keypoints
        .iter()
        .all(|k| k.x >= 0.0 && k.y >= 0.0 && k.x < 160.0 && k.y < 120.0));
    // The mask is read at input resolution.
    let mask = GrayImage::from_fn(160, 120, |_, y| Luma([u8::from(y >= 60) * 255]));
    let fm = detect_and_compute(&img, Some(&mask), &cfg).unwrap();
    assert!(fm.keypoints.iter().all(|k| k.y >= 60.0));
}

#[test]
fn region_of_a_frame_gives_frame_coordinates() {
    use crate::frame::{BBox, Frame, Mask, PixelFormat};
    // A 200x150 RGB frame holding a textured patch at (60, 40).
    let patch = texture(80, 64, 21, 50);
    let (fw, fh) = (200u32, 150u32);
    let mut rgb = vec![128u8; (fw * fh * 3) as usize];
    for (x, y, p) in patch.enumerate_pixels() {
        let i = (((y + 40) * fw + x + 60) * 3) as usize;
        rgb[i..i + 3].copy_from_slice(&[p.0[0]; 3]);
    }
    let frame = Frame::new(&rgb, fw, fh, (fw * 3) as usize, PixelFormat::Rgb8).unwrap();
    let region = BBox::new(60.0, 40.0, 80.0, 64.0);
    let cfg = SiftConfig::default();
    let f = detect_in_region(&frame, &region, None, &cfg).unwrap();
    let direct = detect_and_compute(&patch, None, &cfg).unwrap();
    assert!(!f.is_empty());
    assert_eq!(f.len(), direct.len());
    for (a, b) in f.keypoints.iter().zip(&direct.keypoints) {
        assert!((a.x - b.x - 60.0).abs() < 1e-4 && (a.y - b.y - 40.0).abs() < 1e-4);
    }
    assert_eq!(f.descriptors, direct.descriptors);
    // A mask over the region's left half (in frame coordinates) keeps the keypoints there.
    let half: Vec<u8> = (0..64 * 40).map(|_| 1).collect();
    let mask = Mask::new(60, 40, 40, 64, half).unwrap();
    let fm = detect_in_region(&frame, &region, Some(&mask), &cfg).unwrap();
    let expected: Vec<_> = f
        .keypoints
        .iter()
        .filter(|k| k.x < 100.0)
        .copied()
        .collect();
    assert_eq!(fm.keypoints, expected);
    // A region outside the frame has no features.
    let outside = BBox::new(500.0, 500.0, 10.0, 10.0);
    assert!(detect_in_region(&frame, &outside, None, &cfg)
        .unwrap()
        .is_empty());
}

#[test]
fn no_upsampling_mode_works() {
    let img = gaussian_blob(96, 48.0, 4.0);
    let cfg = SiftConfig {
        upsample: false,
        ..SiftConfig::default()
    };
    let f = detect_and_compute(&img, None, &cfg).unwrap();
    let k = f.keypoints.first().unwrap();
    assert!((k.x - 48.0).abs() < 0.3 && (k.y - 48.0).abs() < 0.3);
    assert!(f.keypoints.iter().all(|k| k.octave >= 0));
}

#[test]
fn tiny_and_flat_images_give_empty_results() {
    let cfg = SiftConfig::default();
    for (w, h) in [
        (1, 1),
        (2, 2),
        (1, 300),
        (300, 1),
        (5, 5),
        (7, 40),
        (16, 16),
    ] {
        let img = texture(w, h, 1, 3);
        let f = detect_and_compute(&img, None, &cfg).unwrap();
        assert_eq!(f.keypoints.len(), f.descriptors.len());
    }
    let flat = GrayImage::from_pixel(64, 64, Luma([90]));
    assert!(detect_and_compute(&flat, None, &cfg).unwrap().is_empty());
}

#[test]
fn bad_input_is_a_typed_error() {
    let cfg = SiftConfig::default();
    assert_eq!(
        detect_and_compute(&GrayImage::new(0, 10), None, &cfg),
        Err(SiftError::EmptyImage {
            width: 0,
            height: 10
        })
    );
    let img = texture(20, 20, 2, 5);
    assert!(matches!(
        detect_and_compute(&img, Some(&GrayImage::new(20, 21)), &cfg),
        Err(SiftError::MaskSize { .. })
    ));
    assert!(matches!(
        detect_and_compute_f32(&[0.0; 10], 4, 4, None, &cfg),
        Err(SiftError::BufferSize { .. })
    ));
    let mut px = vec![1.0f32; 16];
    px[5] = f32::NAN;
    assert!(matches!(
        detect_and_compute_f32(&px, 4, 4, None, &cfg),
        Err(SiftError::NonFinitePixel { index: 5, .. })
    ));
    let bad = [
        SiftConfig {
            n_octave_layers: 0,
            ..cfg.clone()
        },
        SiftConfig {
            sigma: f32::NAN,
            ..cfg.clone()
        },
        SiftConfig {
            sigma: 0.0,
            ..cfg.clone()
        },
        SiftConfig {
            edge_threshold: -1.0,
            ..cfg.clone()
        },
        SiftConfig {
            contrast_threshold: f32::INFINITY,
            ..cfg.clone()
        },
        SiftConfig {
            max_side: Some(0),
            ..cfg.clone()
        },
    ];
    for c in &bad {
        assert!(matches!(
            detect_and_compute(&img, None, c),
            Err(SiftError::InvalidConfig { .. })
        ));
    }
}

#[test]
fn configs_deserialise_with_defaults() {
    let c: SiftConfig = serde_json::from_str(r#"{"max_side": 128, "upsample": false}"#).unwrap();
    assert_eq!(
        c,
        SiftConfig {
            max_side: Some(128),
            upsample: false,
            ..SiftConfig::default()
        }
    );
    let m: MatchConfig = serde_json::from_str("{}").unwrap();
    assert_eq!(m, MatchConfig::default());
}

#[test]
fn empty_sets_match_nothing() {
    let d = [[7u8; 128]; 3];
    assert!(match_descriptor_sets(&[], &d, &MatchConfig::default()).is_empty());
    assert!(match_descriptor_sets(&d, &[], &MatchConfig::default()).is_empty());
    let nan = MatchConfig {
        ratio: f32::NAN,
        cross_check: false,
    };
    assert!(match_descriptor_sets(&d[..1], &d[1..], &nan).len() <= 1);
}

// proptest is a native-only dev-dependency (its fork support does not build for wasm32).
#[cfg(not(target_arch = "wasm32"))]
mod props {
    use super::*;
    use proptest::prelude::{any, prop_assert, prop_assert_eq, proptest, ProptestConfig};

    proptest! {
        #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

        /// Arbitrary small images, masks and settings never panic and keep the invariants.
        #[test]
        fn never_panics_on_small_images(
            w in 1u32..48,
            h in 1u32..48,
            seed in any::<u64>(),
            upsample in any::<bool>(),
            layers in 1u32..5,
            max_side in proptest::option::of(1u32..40),
            max_kp in proptest::option::of(0usize..10),
        ) {
            let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
            let img = GrayImage::from_fn(w, h, |_, _| Luma([rng.gen::<u8>()]));
            let mask = GrayImage::from_fn(w, h, |_, _| Luma([rng.gen_range(0u8..2) * 255]));
            let cfg = SiftConfig {
                upsample,
                n_octave_layers: layers,
                max_side,
                max_keypoints: max_kp,
                ..SiftConfig::default()
            };
            let f = detect_and_compute(&img, Some(&mask), &cfg).unwrap();
            prop_assert_eq!(f.keypoints.len(), f.descriptors.len());
            for k in &f.keypoints {
                prop_assert!(k.x >= 0.0 && k.y >= 0.0 && k.x < w as f32 && k.y < h as f32);
                prop_assert!(mask.get_pixel(k.x as u32, k.y as u32).0[0] != 0);
                prop_assert!((0.0..360.0).contains(&k.angle));
                prop_assert!(k.size > 0.0 && k.response > 0.0);
            }
            let m = match_descriptors(&f, &f, &MatchConfig::default());
            prop_assert!(m.iter().all(|mm| mm.query < f.len() && mm.train < f.len()));
        }
    }
}

/// A region cut out now and described later gives exactly the features of the grey crop and
/// mask taken from the frame at once, for RGB and RGBA frames and regions clipped by the
/// frame's border.
#[test]
fn region_crop_equals_the_grey_crop_of_the_frame() {
    let (w, h) = (160u32, 120u32);
    let grey = texture(w, h, 11, 40);
    let rgb: Vec<u8> = grey
        .as_raw()
        .iter()
        .enumerate()
        .flat_map(|(i, &v)| [v, v.wrapping_add((i % 7) as u8), 255 - v])
        .collect();
    let rgba: Vec<u8> = rgb.chunks(3).flat_map(|p| [p[0], p[1], p[2], 9]).collect();
    let mask = Mask::from_bbox(&BBox::new(30.0, 20.0, 90.0, 70.0));
    let cfg = SiftConfig::default();
    for frame in [
        Frame::rgb(&rgb, w, h).unwrap(),
        Frame::rgba(&rgba, w, h).unwrap(),
    ] {
        for region in [
            BBox::new(26.0, 16.0, 98.0, 78.0),
            BBox::new(-10.0, 60.0, 200.0, 90.0),
        ] {
            let ((x0, y0, cw, ch), crop) = frame.gray_crop(&region).unwrap();
            let mask_crop = GrayImage::from_fn(cw, ch, |x, y| {
                Luma([u8::from(mask.get((x0 + x) as i32, (y0 + y) as i32)) * 255])
            });
            let mut direct = detect_and_compute(&crop, Some(&mask_crop), &cfg).unwrap();
            for k in &mut direct.keypoints {
                k.x += x0 as f32;
                k.y += y0 as f32;
            }
            let later = RegionCrop::new(&frame, &region, Some(&mask)).unwrap();
            let feats = later.detect(&cfg).unwrap();
            assert!(!feats.is_empty());
            assert_eq!(feats, direct);
        }
        let outside = BBox::new(500.0, 500.0, 10.0, 10.0);
        assert!(RegionCrop::new(&frame, &outside, None).is_none());
    }
}
