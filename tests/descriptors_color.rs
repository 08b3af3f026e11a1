//! Spatial colour analyser and the colour cost C2 (`features::color`).
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::features::color::*;
use shapetrack::features::transform::{Similarity, Transform, Translation};
use shapetrack::{BBox, Frame, Mask, Point};

const W: u32 = 240;
const H: u32 = 180;

/// Colour of a textured object at object coordinates `(u, v)`: three vertical bands with a
/// diagonal stripe and mild deterministic shading, like a shirt with a pattern.
fn striped(u: f64, v: f64) -> [u8; 3] {
    let base = if (u + v) % 24.0 < 6.0 {
        [240, 230, 40]
    } else if u < 20.0 {
        [200, 30, 30]
    } else if u < 40.0 {
        [30, 40, 190]
    } else {
        [30, 160, 60]
    };
    let shade = ((u * 7.0 + v * 13.0) as i32 % 9) - 4;
    base.map(|c: i32| (c + shade).clamp(0, 255) as u8)
}

/// Same geometry, different colours.
fn recoloured(u: f64, v: f64) -> [u8; 3] {
    let [r, g, b] = striped(u, v);
    [b, r / 2 + 60, g]
}

/// Same colours as `striped`, laid out differently (bands in reverse order).
fn rearranged(u: f64, v: f64) -> [u8; 3] {
    striped(59.0 - u, v)
}

/// An RGB frame with a disk-with-a-notch object of radius 30 centred at `(cx, cy)`, scaled
/// by `scale` and textured by `tex` in object coordinates; the rest is grey noise.
fn scene(cx: f64, cy: f64, scale: f64, tex: fn(f64, f64) -> [u8; 3]) -> (Vec<u8>, Mask) {
    let mut buf = vec![0u8; (W * H * 3) as usize];
    let mut full = vec![0u8; (W * H) as usize];
    for y in 0..H {
        for x in 0..W {
            let i = (y * W + x) as usize;
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            // Object coordinates: (0..60, 0..60), origin at the disk's top-left.
            let (u, v) = ((px - cx) / scale + 30.0, (py - cy) / scale + 30.0);
            let inside = (u - 30.0).hypot(v - 30.0) < 30.0 && !(u > 40.0 && v < 20.0);
            let c = if inside {
                full[i] = 1;
                tex(u, v)
            } else {
                let g = ((x * 31 + y * 17) % 40 + 100) as u8;
                [g, g, g]
            };
            buf[i * 3..i * 3 + 3].copy_from_slice(&c);
        }
    }
    (buf, Mask::from_full(W, H, &full).unwrap())
}

fn sample(cx: f64, cy: f64, scale: f64, tex: fn(f64, f64) -> [u8; 3]) -> ColorSample {
    let (buf, mask) = scene(cx, cy, scale, tex);
    let frame = Frame::rgb(&buf, W, H).unwrap();
    ColorSample::from_mask(&frame, &mask, ColorConfig::default().max_samples)
}

fn assert_sane(m: &ColorMatch) {
    assert!((0.0..=1.0).contains(&m.cost), "{m:?}");
    assert!((0.0..=1.0).contains(&m.overlap), "{m:?}");
    assert!((0.0..=1.0).contains(&m.palette_distance), "{m:?}");
    assert!(m.differing <= m.compared);
}

#[test]
fn identical_inputs_cost_zero() {
    let cfg = ColorConfig::default();
    let a = sample(80.0, 70.0, 1.0, striped);
    assert!(a.len() > 1000 && a.len() <= 1500, "{}", a.len());
    for t in [None, Some(&Transform::identity())] {
        let m = color_cost(&a, &a, t, &cfg).unwrap();
        assert_sane(&m);
        assert_eq!(m.cost, 0.0, "{m:?}");
        assert_eq!(m.overlap, 1.0);
        assert_eq!(m.compared, a.len());
        assert_eq!(m.palette_distance, 0.0);
    }
}

#[test]
fn moved_textured_shape_is_cheaper_than_a_recoloured_or_rearranged_one() {
    let cfg = ColorConfig::default();
    let a = sample(80.0, 70.0, 1.0, striped);
    let (dx, dy) = (57.0, 31.0);
    let moved = sample(80.0 + dx, 70.0 + dy, 1.0, striped);
    let other = sample(80.0 + dx, 70.0 + dy, 1.0, recoloured);
    let shuffled = sample(80.0 + dx, 70.0 + dy, 1.0, rearranged);
    let t = Transform::Translation(Translation { dx: -dx, dy: -dy });
    for align in [Some(&t), None] {
        let same = color_cost(&a, &moved, align, &cfg).unwrap();
        let diff = color_cost(&a, &other, align, &cfg).unwrap();
        let shuf = color_cost(&a, &shuffled, align, &cfg).unwrap();
        for m in [&same, &diff, &shuf] {
            assert_sane(m);
            assert!(m.overlap > 0.95, "{m:?}");
        }
        assert!(same.cost < 0.05, "{same:?}");
        assert!(diff.cost > 0.5, "{diff:?}");
        // Same colours in another layout: only the spatial comparison sees it.
        assert!(shuf.cost > 0.3, "{shuf:?}");
        assert!(shuf.palette_distance < 0.1, "{shuf:?}");
        assert!(same.cost < diff.cost && same.cost < shuf.cost);
    }
    assert!(palette_distance(&a, &moved, &cfg).unwrap() < 0.05);
    assert!(palette_distance(&a, &other, &cfg).unwrap() > 0.5);
}

/// The per-view form of C2 (each shape's own palette, computed once) tells the same shapes
/// apart as the joint one: a moved shape is cheap, a recoloured or rearranged one is not, and
/// a shape against itself costs nothing.
#[test]
fn per_view_palettes_separate_what_the_joint_palette_separates() {
    let cfg = ColorConfig {
        per_view: true,
        ..ColorConfig::default()
    };
    let a = sample(80.0, 70.0, 1.0, striped);
    let (dx, dy) = (57.0, 31.0);
    let moved = sample(80.0 + dx, 70.0 + dy, 1.0, striped);
    let other = sample(80.0 + dx, 70.0 + dy, 1.0, recoloured);
    let shuffled = sample(80.0 + dx, 70.0 + dy, 1.0, rearranged);
    let pal = |s: &ColorSample| view_palette(s, &cfg).unwrap();
    let pa = pal(&a);
    let ia = a.index();
    assert_eq!(pa.labels.len(), a.len());
    assert!(pa.centroids.len() <= cfg.clusters);
    let itself = color_cost_per_view((&a, &pa, &ia), (&a, &pa), None, &cfg).unwrap();
    assert_sane(&itself);
    assert_eq!((itself.cost, itself.overlap), (0.0, 1.0));
    assert!(itself.palette_distance < 1e-9, "{itself:?}");
    let cost = |b: &ColorSample| {
        let m = color_cost_per_view((&a, &pa, &ia), (b, &pal(b)), None, &cfg).unwrap();
        assert_sane(&m);
        assert!(m.overlap > 0.95, "{m:?}");
        m
    };
    let (same, diff, shuf) = (cost(&moved), cost(&other), cost(&shuffled));
    assert!(same.cost < 0.05, "{same:?}");
    assert!(diff.cost > 0.5, "{diff:?}");
    assert!(shuf.cost > 0.3, "{shuf:?}");
    assert!(
        same.palette_distance < 0.1 && shuf.palette_distance < 0.1,
        "{same:?} {shuf:?}"
    );
    assert!(diff.palette_distance > 0.5, "{diff:?}");
    // Within a few points of the joint palette's C2 on each pair.
    for (b, m) in [(&moved, &same), (&other, &diff), (&shuffled, &shuf)] {
        let joint = color_cost(&a, b, None, &cfg).unwrap();
        assert!((joint.cost - m.cost).abs() < 0.1, "{joint:?} vs {m:?}");
    }
    // Labels that do not belong to the samples are refused, not read out of bounds.
    let short = ViewPalette {
        labels: vec![0],
        ..pa.clone()
    };
    assert!(color_cost_per_view((&a, &short, &ia), (&a, &pa), None, &cfg).is_err());
    let empty = ColorSample::default();
    assert!(view_palette(&empty, &cfg).is_err());
}

#[test]
fn scaled_shape_aligned_by_similarity_stays_cheap() {
    let cfg = ColorConfig::default();
    let a = sample(70.0, 70.0, 1.0, striped);
    let b = sample(150.0, 95.0, 1.4, striped);
    // B → A: undo the scale about B's centre, then move onto A's centre.
    let s = 1.0 / 1.4;
    let t = Transform::Similarity(Similarity {
        scale: s,
        angle: 0.0,
        tx: 70.0 - s * 150.0,
        ty: 70.0 - s * 95.0,
    });
    let m = color_cost(&a, &b, Some(&t), &cfg).unwrap();
    assert_sane(&m);
    assert!(m.cost < 0.1 && m.overlap > 0.9, "{m:?}");
    // The thesis' literal rule (any palette difference counts) reads the resampled shading as
    // colour changes: that is what the tolerance is for.
    let literal = ColorConfig {
        color_tolerance: 0.0,
        ..cfg
    };
    let strict = color_cost(&a, &b, Some(&t), &literal).unwrap();
    assert!(strict.cost > m.cost, "{strict:?}");
    let wrong = color_cost(&a, &sample(150.0, 95.0, 1.4, recoloured), Some(&t), &cfg).unwrap();
    assert!(wrong.cost > 0.5, "{wrong:?}");
}

#[test]
fn kmeans_is_deterministic_for_a_seed() {
    let cfg = ColorConfig::default();
    let a = sample(80.0, 70.0, 1.0, striped);
    let b = sample(100.0, 60.0, 1.0, recoloured);
    let p1 = joint_palette(&a, &b, &cfg).unwrap();
    let p2 = joint_palette(&a, &b, &cfg).unwrap();
    assert_eq!(p1, p2);
    assert_eq!(p1.centroids.len(), 10);
    assert_eq!((p1.labels_a.len(), p1.labels_b.len()), (a.len(), b.len()));
    assert!(p1.labels_a.iter().chain(&p1.labels_b).all(|&l| l < 10));
    assert_eq!(
        color_cost(&a, &b, None, &cfg).unwrap(),
        color_cost(&a, &b, None, &cfg).unwrap()
    );
}

#[test]
fn no_overlap_gives_the_documented_worst_cost() {
    let cfg = ColorConfig::default();
    let a = sample(80.0, 70.0, 1.0, striped);
    let far = Transform::Translation(Translation {
        dx: 1000.0,
        dy: 0.0,
    });
    let m = color_cost(&a, &a, Some(&far), &cfg).unwrap();
    assert_sane(&m);
    assert_eq!((m.cost, m.overlap, m.compared), (1.0, 0.0, 0));
    // A transform that sends everything to NaN is "no overlap", not a NaN cost.
    let nan = Transform::Translation(Translation {
        dx: f64::NAN,
        dy: 0.0,
    });
    let m = color_cost(&a, &a, Some(&nan), &cfg).unwrap();
    assert_eq!((m.cost, m.overlap), (1.0, 0.0));
}

#[test]
fn degenerate_samples_are_typed_errors_or_well_defined() {
    let cfg = ColorConfig::default();
    let a = sample(80.0, 70.0, 1.0, striped);
    let empty = ColorSample::default();
    assert_eq!(
        color_cost(&a, &empty, None, &cfg),
        Err(ColorError::EmptySample { which: "B" })
    );
    assert_eq!(
        color_cost(&empty, &a, None, &cfg),
        Err(ColorError::EmptySample { which: "A" })
    );
    assert_eq!(
        palette_distance(&empty, &empty, &cfg),
        Err(ColorError::EmptySample { which: "A" })
    );
    assert!(matches!(
        ColorSample::new(vec![Point::new(0.0, 0.0)], vec![], 1.0),
        Err(ColorError::LengthMismatch { .. })
    ));
    assert!(matches!(
        ColorSample::new(vec![Point::new(f64::NAN, 0.0)], vec![[0; 3]], 1.0),
        Err(ColorError::NonFinite { index: 0 })
    ));
    assert!(matches!(
        color_cost(&a, &a, None, &ColorConfig { clusters: 0, ..cfg }),
        Err(ColorError::InvalidConfig { .. })
    ));
    // One sample each (fewer than K) and a single flat colour: k-means still runs.
    let one = ColorSample::new(vec![Point::new(5.0, 5.0)], vec![[10, 20, 30]], 1.0).unwrap();
    let m = color_cost(&one, &one, None, &cfg).unwrap();
    assert_eq!((m.cost, m.overlap), (0.0, 1.0));
    let flat_pos: Vec<Point> = (0..50)
        .map(|i| Point::new((i % 10) as f64, (i / 10) as f64))
        .collect();
    let flat = ColorSample::new(flat_pos, vec![[7, 7, 7]; 50], 1.0).unwrap();
    let m = color_cost(&flat, &flat, None, &cfg).unwrap();
    assert_sane(&m);
    assert_eq!(m.cost, 0.0);
    // An empty or off-frame mask samples nothing.
    let (buf, _) = scene(80.0, 70.0, 1.0, striped);
    let frame = Frame::rgb(&buf, W, H).unwrap();
    assert!(ColorSample::from_mask(&frame, &Mask::empty(), 100).is_empty());
    let off = Mask::from_bbox(&BBox::new(500.0, 500.0, 10.0, 10.0));
    assert!(ColorSample::from_mask(&frame, &off, 100).is_empty());
}

#[test]
fn rgba_frames_sample_the_same_colours() {
    let (buf, mask) = scene(80.0, 70.0, 1.0, striped);
    let rgba: Vec<u8> = buf
        .chunks_exact(3)
        .flat_map(|c| [c[0], c[1], c[2], 255])
        .collect();
    let a = ColorSample::from_mask(&Frame::rgb(&buf, W, H).unwrap(), &mask, 1500);
    let b = ColorSample::from_mask(&Frame::rgba(&rgba, W, H).unwrap(), &mask, 1500);
    assert_eq!(a, b);
}
