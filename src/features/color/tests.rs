//! Unit tests of `features::color` (a file of their own: the module's code is long enough).

use super::compare::hellinger;
use super::palette::kmeans;
use super::*;
use linfa::traits::{Fit, Predict};
use linfa::DatasetBase;
use linfa_clustering::{KMeans, KMeansInit};
use ndarray::Array2;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256Plus;

#[test]
fn grid_sampling_is_bounded_and_inside_the_mask() {
    let (w, h) = (120u32, 90u32);
    let buf: Vec<u8> = (0..w * h * 3).map(|i| (i % 251) as u8).collect();
    let frame = Frame::rgb(&buf, w, h).unwrap();
    let mask = Mask::from_bbox(&crate::frame::BBox::new(10.0, 5.0, 100.0, 80.0));
    for max in [1usize, 7, 100, 1500, 10_000] {
        let s = ColorSample::from_mask(&frame, &mask, max);
        assert!(!s.is_empty() && s.len() <= max, "{max}: {}", s.len());
        for p in &s.positions {
            assert!(mask.get(p.x.floor() as i32, p.y.floor() as i32));
        }
    }
    // Small enough to keep every pixel.
    assert_eq!(ColorSample::from_mask(&frame, &mask, 8000).len(), 8000);
    assert!(ColorSample::from_mask(&frame, &Mask::empty(), 10).is_empty());
}

/// The grid's samples are those of testing every grid point with `Mask::get` and
/// `Frame::rgb_at` (the per-point form the row reads replaced), for masks partly outside
/// the frame on every side, RGB and RGBA frames, and spacings above and below a pixel.
#[test]
fn grid_sampling_reads_the_points_the_per_point_tests_would() {
    let reference = |frame: &Frame<'_>, mask: &Mask, spacing: f64| {
        let b = mask.bbox();
        let (nx, ny) = (
            (b.w / spacing).ceil() as usize,
            (b.h / spacing).ceil() as usize,
        );
        let mut out = Vec::new();
        for j in 0..ny {
            let py = (b.y + (j as f64 + 0.5) * spacing).floor();
            for i in 0..nx {
                let px = (b.x + (i as f64 + 0.5) * spacing).floor();
                let (xi, yi) = (px as i64, py as i64);
                if !mask.get(xi as i32, yi as i32) || xi < 0 || yi < 0 {
                    continue;
                }
                if let Some(c) = frame.rgb_at(xi as u32, yi as u32) {
                    out.push((Point::new(px + 0.5, py + 0.5), c));
                }
            }
        }
        out
    };
    let (w, h) = (64u32, 48u32);
    let rgb: Vec<u8> = (0..w * h * 3).map(|i| (i * 7 % 253) as u8).collect();
    let rgba: Vec<u8> = (0..w * h * 4).map(|i| (i * 5 % 251) as u8).collect();
    let frames = [
        Frame::rgb(&rgb, w, h).unwrap(),
        Frame::rgba(&rgba, w, h).unwrap(),
    ];
    let mut seed = 17u32;
    let mut next = |n: u32| {
        seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12_345);
        (seed >> 8) % n
    };
    for case in 0..200 {
        let (mw, mh) = (1 + next(40), 1 + next(40));
        let (mx, my) = (next(w + 30) as i32 - 20, next(h + 30) as i32 - 20);
        let bits: Vec<u8> = (0..mw * mh).map(|_| u8::from(next(3) > 0)).collect();
        let mask = Mask::new(mx, my, mw, mh, bits).unwrap();
        if mask.area() == 0 {
            continue;
        }
        let spacing = [0.7, 1.0, 1.6, 3.3][case % 4];
        let frame = &frames[case % 2];
        let mut got = ColorSample::default();
        let bb = mask.bbox();
        grid_sample_into(frame, &mask, (bb.x, bb.y, bb.w, bb.h), spacing, &mut got);
        let got: Vec<(Point, [u8; 3])> = got
            .positions
            .iter()
            .copied()
            .zip(got.rgb.iter().copied())
            .collect();
        assert_eq!(got, reference(frame, &mask, spacing), "case {case}");
    }
}

/// The screen's early decision is the full share compared with the threshold, for
/// views and candidates of mixed colours and thresholds across the range.
#[test]
fn the_screen_decides_as_the_full_share_does() {
    let cfg = ColorConfig::default();
    let colours = [
        [200, 20, 20],
        [20, 20, 200],
        [20, 200, 20],
        [220, 220, 0],
        [90, 90, 90],
    ];
    let mut seed = 5u32;
    let mut next = |n: u32| {
        seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12_345);
        ((seed >> 8) % n) as usize
    };
    let mut decided = [0usize; 2];
    for case in 0..300 {
        let mix = |next: &mut dyn FnMut(u32) -> usize| {
            let parts: Vec<ColorSample> = (0..1 + next(3))
                .map(|_| samples(1 + next(40), colours[next(5)]))
                .collect();
            joined(&parts)
        };
        let a = mix(&mut next);
        let pa = view_palette(&a, &cfg).unwrap();
        // One view's reach, built once and read by several detections, as the
        // re-identification screen reads a lost track's.
        let view = ViewReach::new(&a, &pa).unwrap();
        for probe in 0..3 {
            let b = mix(&mut next);
            let min_share = [0.0, 0.1, 0.5, 0.9, 1.0][(case + probe) % 5];
            let full = foreign_share((&a, &pa), &b, 0.03, &cfg).unwrap();
            let early = foreign_share_at_least((&a, &pa), &b, 0.03, min_share, &cfg).unwrap();
            let cached = foreign_share_at_least_in(&view, &b, 0.03, min_share, &cfg).unwrap();
            assert_eq!(
                early,
                full >= min_share,
                "case {case}: share {full}, at {min_share}"
            );
            assert_eq!(
                cached, early,
                "case {case}.{probe}: the cached view disagrees"
            );
            decided[usize::from(early)] += 1;
        }
    }
    assert!(decided[0] > 30 && decided[1] > 30, "{decided:?}");
}

#[test]
fn kmeans_is_linfas() {
    use rand::Rng;
    let mut gen = Xoshiro256Plus::seed_from_u64(5);
    for case in 0..240u64 {
        let n = 1 + (case as usize * 7) % 300;
        // Few distinct colours in some cases: repeated points and all-zero distances.
        let levels = [2u32, 5, 256][case as usize % 3];
        let rgb: Vec<[u8; 3]> = (0..n)
            .map(|_| [0; 3].map(|_: u8| (gen.gen_range(0..levels) * 255 / levels) as u8))
            .collect();
        let cfg = ColorConfig {
            seed: case,
            clusters: 1 + case as usize % 12,
            // Runs stopped by the iteration cap and by the tolerance, loose and tight.
            max_iterations: [30, 1, 3, 100][case as usize % 4],
            tolerance: [0.5, 1e-3, 5.0][case as usize % 3],
            ..ColorConfig::default()
        };
        let ours = kmeans(rgb.iter(), n, &cfg).unwrap();
        // linfa's own k-means on the same colours and generator.
        let mut data = Array2::<f64>::zeros((n, 3));
        for (mut row, c) in data.rows_mut().into_iter().zip(&rgb) {
            row.iter_mut().zip(c).for_each(|(v, &c)| *v = c as f64);
        }
        let k = cfg.clusters.min(n);
        let model = KMeans::params_with_rng(k, Xoshiro256Plus::seed_from_u64(case))
            .init_method(KMeansInit::KMeansPlusPlus)
            .n_runs(1)
            .max_n_iterations(cfg.max_iterations)
            .tolerance(cfg.tolerance)
            .fit(&DatasetBase::from(data.clone()))
            .unwrap();
        let labels = model.predict(&data).to_vec();
        let centroids: Vec<[f64; 3]> = model
            .centroids()
            .rows()
            .into_iter()
            .map(|r| [r[0], r[1], r[2]])
            .collect();
        assert_eq!(ours.0, centroids, "case {case}");
        assert_eq!(ours.1, labels, "case {case}");
    }
}

/// `n` samples on a row, one pixel apart, each `colour` with a small deterministic jitter.
fn samples(n: usize, colour: [u8; 3]) -> ColorSample {
    let positions = (0..n).map(|i| Point::new(i as f64 + 0.5, 0.5)).collect();
    let rgb = (0..n)
        .map(|i| colour.map(|c| c.saturating_add((i % 5) as u8)))
        .collect();
    ColorSample::new(positions, rgb, 1.0).unwrap()
}

fn joined(parts: &[ColorSample]) -> ColorSample {
    let rgb: Vec<[u8; 3]> = parts.iter().flat_map(|p| p.rgb.clone()).collect();
    let positions = (0..rgb.len())
        .map(|i| Point::new(i as f64 + 0.5, 0.5))
        .collect();
    ColorSample::new(positions, rgb, 1.0).unwrap()
}

#[test]
fn foreign_share_counts_the_colours_a_view_does_not_have() {
    let cfg = ColorConfig::default();
    let (red, blue, green, yellow) = ([200, 20, 20], [20, 20, 200], [20, 200, 20], [220, 220, 0]);
    // A whole view: red and blue, and a speck of yellow (2 of 102 samples).
    let a = joined(&[samples(60, red), samples(40, blue), samples(2, yellow)]);
    let pa = view_palette(&a, &cfg).unwrap();
    let share = |b: &ColorSample| foreign_share((&a, &pa), b, 0.03, &cfg).unwrap();
    // A sliver showing one of its colours has nothing foreign.
    assert_eq!(share(&samples(20, red)), 0.0);
    assert_eq!(share(&joined(&[samples(10, red), samples(10, blue)])), 0.0);
    // A colour it never had, and one it had too little of, are foreign.
    assert_eq!(share(&samples(20, green)), 1.0);
    assert_eq!(share(&samples(20, yellow)), 1.0);
    assert_eq!(share(&joined(&[samples(10, red), samples(10, green)])), 0.5);
    // Nothing to compare is an error, not a share.
    assert!(foreign_share((&a, &pa), &ColorSample::default(), 0.03, &cfg).is_err());
    let other = view_palette(&samples(5, red), &cfg).unwrap();
    assert!(foreign_share((&a, &other), &samples(3, red), 0.03, &cfg).is_err());
    // The cached view checks the same: a palette of another view, and an empty detection.
    assert!(ViewReach::new(&a, &other).is_err());
    let view = ViewReach::new(&a, &pa).unwrap();
    let empty = ColorSample::default();
    assert!(foreign_share_at_least_in(&view, &empty, 0.03, 0.5, &cfg).is_err());
}

#[test]
fn hellinger_bounds() {
    assert_eq!(hellinger(&[0.5, 0.5], &[0.5, 0.5]), 0.0);
    assert!((hellinger(&[1.0, 0.0], &[0.0, 1.0]) - 1.0).abs() < 1e-12);
}
