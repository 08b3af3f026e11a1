//! Unit tests of `detect::refine` (a file of their own: the module's code is long enough).

use super::*;

/// A red disc on a striped green/blue background.
fn disc_image(w: u32, h: u32, cx: f64, cy: f64, r: f64) -> (Vec<u8>, Vec<u8>) {
    let mut img = vec![0u8; (w * h * 3) as usize];
    let mut gt = vec![0u8; (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let inside = ((x as f64 + 0.5 - cx).powi(2) + (y as f64 + 0.5 - cy).powi(2)).sqrt() < r;
            let c = if inside {
                [200, 40, 30]
            } else if (x / 6 + y / 9) % 2 == 0 {
                [40, 160, 60]
            } else {
                [50, 70, 170]
            };
            img[3 * i..3 * i + 3].copy_from_slice(&c);
            gt[i] = inside as u8;
        }
    }
    (img, gt)
}

#[test]
fn a_hint_keeps_ground_the_blob_joined_out_of_the_mask() {
    // A disc with a yellow patch of "ground" under it, both inside the box; the ring
    // around the box shows only the striped background, so without a hint nothing tells
    // the refinement that the yellow is not the object.
    let (w, h) = (160, 140);
    let (mut img, gt) = disc_image(w, h, 80.0, 55.0, 28.0);
    for y in 84..112u32 {
        for x in 46..114u32 {
            let i = (y * w + x) as usize;
            img[3 * i..3 * i + 3].copy_from_slice(&[230, 210, 40]);
        }
    }
    let gt = Mask::from_full(w, h, &gt).unwrap();
    let f = Frame::rgb(&img, w, h).unwrap();
    let b = BBox::new(44.0, 22.0, 72.0, 92.0);
    let cfg = RefineConfig::default();
    let plain = refine_box(&f, &b, &cfg)
        .unwrap()
        .map_or(0.0, |m| m.iou(&gt));
    // The hint: the disc on a grid of 4-pixel cells (as a working foreground would be).
    let (hw, hh) = (w as usize / 4, h as usize / 4);
    let bits: Vec<u8> = (0..hw * hh)
        .map(|k| {
            let (x, y) = ((k % hw) as f64 * 4.0 + 2.0, (k / hw) as f64 * 4.0 + 2.0);
            ((x - 80.0).hypot(y - 55.0) < 26.0) as u8
        })
        .collect();
    let hint = Hint {
        bits: &bits,
        width: hw,
        height: hh,
        scale: 4.0,
    };
    let hinted = refine_box_hinted(&f, &b, &cfg, Some(hint))
        .unwrap()
        .map_or(0.0, |m| m.iou(&gt));
    assert!(hinted >= 0.85, "with the hint IoU {hinted}");
    assert!(
        plain < 0.7,
        "without it IoU {plain}: the test no longer shows the gain"
    );
    // A hint that marks nothing inside the box is ignored.
    let empty = Hint {
        bits: &vec![0u8; hw * hh],
        ..hint
    };
    let ignored = refine_box_hinted(&f, &b, &cfg, Some(empty))
        .unwrap()
        .map_or(0.0, |m| m.iou(&gt));
    assert_eq!(ignored, plain);
}

#[test]
fn disc_in_loose_box() {
    let (w, h) = (160, 120);
    let (img, gt) = disc_image(w, h, 80.0, 60.0, 30.0);
    let f = Frame::rgb(&img, w, h).unwrap();
    let gt = Mask::from_full(w, h, &gt).unwrap();
    let b = BBox::new(40.0, 20.0, 80.0, 80.0);
    let m = refine_box(&f, &b, &RefineConfig::default())
        .unwrap()
        .unwrap();
    let filled = Mask::from_bbox(&b);
    eprintln!(
        "iou {} box {} area {}",
        m.iou(&gt),
        filled.iou(&gt),
        m.area()
    );
    assert!(m.iou(&gt) > 0.9);
}

#[test]
fn the_outline_follows_the_frames_pixels_not_the_working_crops() {
    // A disc 4× wider than the working crop: one working pixel spans ~5 frame pixels.
    let (w, h) = (640, 480);
    let (img, gt) = disc_image(w, h, 320.0, 240.0, 170.0);
    let f = Frame::rgb(&img, w, h).unwrap();
    let gt = Mask::from_full(w, h, &gt).unwrap();
    let b = BBox::new(140.0, 60.0, 360.0, 360.0);
    let run = |boundary_prior| {
        let cfg = RefineConfig {
            boundary_prior,
            ..RefineConfig::default()
        };
        refine_box(&f, &b, &cfg).unwrap().unwrap().iou(&gt)
    };
    let (bilinear, colour) = (run(-1.0), run(2.0));
    assert!(colour > 0.99, "with colour {colour}");
    assert!(colour > bilinear + 0.005, "{colour} vs bilinear {bilinear}");
}

#[test]
fn texture_tells_a_smooth_object_from_a_fine_pattern_of_its_average_colour() {
    // A flat grey disc on a one-pixel checkerboard whose average is the disc's grey: the
    // working crop (one working pixel ≈ 5 frame pixels) averages the board to the disc's
    // colour, so only the texture value tells them apart.
    let (w, h) = (640, 480);
    let (cx, cy, r) = (320.0, 240.0, 150.0);
    let mut img = vec![0u8; (w * h * 3) as usize];
    let mut gt = vec![0u8; (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let inside = ((x as f64 + 0.5 - cx).powi(2) + (y as f64 + 0.5 - cy).powi(2)).sqrt() < r;
            let v = if inside {
                128
            } else if (x + y) % 2 == 0 {
                88
            } else {
                168
            };
            img[3 * i..3 * i + 3].fill(v);
            gt[i] = inside as u8;
        }
    }
    let f = Frame::rgb(&img, w, h).unwrap();
    let gt = Mask::from_full(w, h, &gt).unwrap();
    let b = BBox::new(cx - r, cy - r, 2.0 * r, 2.0 * r);
    let run = |texture| {
        let cfg = RefineConfig {
            texture,
            ..RefineConfig::default()
        };
        refine_box(&f, &b, &cfg)
            .unwrap()
            .map(|m| m.iou(&gt))
            .unwrap_or(0.0)
    };
    let (colour, textured) = (run(0.0), run(1.0));
    assert!(textured > 0.9, "with texture {textured}");
    assert!(
        textured > colour + 0.1,
        "{textured} vs colour alone {colour}"
    );
}

#[test]
fn a_non_finite_boundary_prior_or_texture_is_refused() {
    for (field, cfg) in [
        (
            "boundary_prior",
            RefineConfig {
                boundary_prior: f64::NAN,
                ..RefineConfig::default()
            },
        ),
        (
            "texture",
            RefineConfig {
                texture: f64::INFINITY,
                ..RefineConfig::default()
            },
        ),
        (
            "texture",
            RefineConfig {
                texture: -1.0,
                ..RefineConfig::default()
            },
        ),
    ] {
        assert!(
            matches!(cfg.validate(), Err(DetectError::InvalidConfig { field: f, .. }) if f == field),
            "{field}"
        );
    }
}

#[test]
fn the_palette_fitted_on_a_sample_finds_the_disc_as_the_full_one_does() {
    let (w, h) = (160, 120);
    let (img, gt) = disc_image(w, h, 80.0, 60.0, 30.0);
    let f = Frame::rgb(&img, w, h).unwrap();
    let gt = Mask::from_full(w, h, &gt).unwrap();
    let b = BBox::new(40.0, 20.0, 80.0, 80.0);
    let run = |samples| {
        let cfg = RefineConfig {
            palette_samples: samples,
            ..RefineConfig::default()
        };
        refine_box(&f, &b, &cfg).unwrap().unwrap()
    };
    let full = run(0);
    // The default (1,024 of the crop's ~6,900 pixels) and a sample so sparse (a stride
    // of ~100) that it still holds each of the three colours.
    for samples in [1024, 64] {
        let m = run(samples);
        assert!(m.iou(&gt) > 0.9, "{samples}: {}", m.iou(&gt));
        assert!(m.iou(&full) > 0.95, "{samples}: {}", m.iou(&full));
    }
}

/// The cut's unary cost is GrabCut's data term: the pixel's own (most likely) Gaussian,
/// not the mixture's log-sum. Two labels with the same pixels make two equal Gaussians of
/// weight ½: the mixture's likelihood at the mean is one Gaussian's, GrabCut's cost is
/// ln 2 above it. Fails with the mixture's `−ln Σ`.
#[test]
fn the_unary_cost_is_the_most_likely_gaussians_alone() {
    let feat: Vec<[f32; 4]> = (0..40)
        .map(|i| {
            let v = (i % 10) as f32;
            [v, 2.0 * v, 50.0 - v, (i % 3) as f32]
        })
        .collect();
    let both: Vec<[f32; 4]> = feat.iter().chain(&feat).copied().collect();
    let labels: Vec<usize> = (0..both.len()).map(|i| i / feat.len()).collect();
    let weights = vec![1.0; both.len()];
    let one =
        Mixture::fit(&feat, &vec![1.0; feat.len()], &vec![0; feat.len()], 1).expect("one Gaussian");
    let two = Mixture::fit(&both, &weights, &labels, 2).expect("two Gaussians");
    assert_eq!(two.parts.len(), 2);
    let mean = one.parts[0].mean;
    let c = [
        mean[0] as f32,
        mean[1] as f32,
        mean[2] as f32,
        mean[3] as f32,
    ];
    let (k1, single) = one.eval(&c);
    let (k2, grabcut) = two.eval(&c);
    assert_eq!((k1, k2), (0, 0), "ties go to the first Gaussian");
    assert!(
        (grabcut - single - std::f64::consts::LN_2).abs() < 1e-6,
        "{grabcut} vs {single} + ln 2"
    );
}
