//! Shape context and colour cost per pair of shapes.
//!
//! `cargo bench --bench descriptors`

use criterion::{criterion_group, criterion_main, Criterion};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256Plus;
use shapetrack::features::color::{color_cost, joint_palette, ColorConfig, ColorSample};
use shapetrack::features::shape_context::{
    chi2_matrix, match_shapes, match_vertices, shape_cost, shape_cost_from_matches,
    ShapeContextConfig, ShapeDescriptor, VertexMatching,
};
use shapetrack::features::transform::{ransac, RansacConfig, Similarity, TransformKind};
use shapetrack::{BBox, Frame, Mask, Point};
use std::f64::consts::PI;
use std::hint::black_box;

/// A wobbly blob outline with `n` points: a typical detection contour.
fn blob(n: usize, r: f64, phase: f64) -> Vec<Point> {
    (0..n)
        .map(|i| {
            let t = 2.0 * PI * i as f64 / n as f64;
            let rr = r * (1.0 + 0.2 * (3.0 * t + phase).sin() + 0.1 * (5.0 * t).cos());
            Point::new(200.0 + rr * t.cos(), 150.0 + rr * t.sin())
        })
        .collect()
}

/// `n` colour samples on a grid, four base colours in bands plus noise.
fn colour_sample(n: usize, seed: u64, offset: f64) -> ColorSample {
    let mut rng = Xoshiro256Plus::seed_from_u64(seed);
    let side = (n as f64).sqrt().ceil() as usize;
    let base = [[200, 30, 30], [30, 40, 190], [30, 160, 60], [240, 230, 40]];
    let mut positions = Vec::with_capacity(n);
    let mut rgb = Vec::with_capacity(n);
    for i in 0..n {
        let (x, y) = ((i % side) as f64, (i / side) as f64);
        positions.push(Point::new(x * 1.5 + offset, y * 1.5 + offset));
        let c: [i32; 3] = base[(i % side) * 4 / side];
        rgb.push(c.map(|v| (v + rng.gen_range(-12..=12)).clamp(0, 255) as u8));
    }
    ColorSample::new(positions, rgb, 1.5).expect("valid sample")
}

fn bench_shape(c: &mut Criterion) {
    let cfg = ShapeContextConfig::default();
    let a_contour = blob(300, 60.0, 0.0);
    let t = Similarity {
        scale: 1.1,
        angle: 0.1,
        tx: 15.0,
        ty: -8.0,
    };
    let b_contour: Vec<Point> = blob(280, 60.0, 0.2).iter().map(|p| t.apply(*p)).collect();
    let a = ShapeDescriptor::from_contour(&a_contour, &cfg).expect("a");
    let b = ShapeDescriptor::from_contour(&b_contour, &cfg).expect("b");
    assert_eq!((a.len(), b.len()), (64, 64));

    c.bench_function("shape_context/descriptor_64", |bch| {
        bch.iter(|| ShapeDescriptor::from_contour(black_box(&a_contour), &cfg))
    });
    c.bench_function("shape_context/match_64x64", |bch| {
        bch.iter(|| match_shapes(black_box(&a), black_box(&b), &cfg))
    });
    c.bench_function("shape_context/chi2_matrix_64x64", |bch| {
        bch.iter(|| chi2_matrix(black_box(&a), black_box(&b)))
    });
    c.bench_function("shape_context/match_vertices_optimal_64x64", |bch| {
        bch.iter(|| match_vertices(black_box(&a), black_box(&b), VertexMatching::Optimal))
    });
    c.bench_function("shape_context/shape_cost_64_from_contours", |bch| {
        bch.iter(|| shape_cost(black_box(&a_contour), black_box(&b_contour), &cfg))
    });
    let keypairs: Vec<(Point, Point)> = a.vertices()[..30]
        .iter()
        .map(|p| (*p, t.apply(*p)))
        .collect();
    c.bench_function("shape_context/sift_variant_64_30matches", |bch| {
        bch.iter(|| shape_cost_from_matches(a.vertices(), b.vertices(), &keypairs, &cfg))
    });
    c.bench_function("transform/ransac_similarity_64", |bch| {
        let m: Vec<(Point, Point)> = a.vertices().iter().map(|p| (*p, t.apply(*p))).collect();
        bch.iter(|| {
            ransac(
                TransformKind::Similarity,
                black_box(&m),
                &RansacConfig::default(),
            )
        })
    });
}

fn bench_colour(c: &mut Criterion) {
    let cfg = ColorConfig::default();
    let a = colour_sample(1500, 1, 0.0);
    let b = colour_sample(1500, 2, 3.0);
    c.bench_function("color/joint_palette_1500+1500_k10", |bch| {
        bch.iter(|| joint_palette(black_box(&a), black_box(&b), &cfg))
    });
    c.bench_function("color/color_cost_1500+1500_k10", |bch| {
        bch.iter(|| color_cost(black_box(&a), black_box(&b), None, &cfg))
    });
    for iters in [5u64, 10] {
        let capped = ColorConfig {
            max_iterations: iters,
            ..cfg
        };
        c.bench_function(
            &format!("color/joint_palette_1500+1500_k10_max{iters}it"),
            |bch| bch.iter(|| joint_palette(black_box(&a), black_box(&b), &capped)),
        );
    }
    let (w, h) = (640u32, 480u32);
    let buf: Vec<u8> = (0..w * h * 3).map(|i| (i % 253) as u8).collect();
    let frame = Frame::rgb(&buf, w, h).expect("frame");
    let mask = Mask::from_bbox(&BBox::new(100.0, 80.0, 200.0, 300.0));
    c.bench_function("color/sample_from_mask_60k_px_to_1500", |bch| {
        bch.iter(|| ColorSample::from_mask(&frame, black_box(&mask), 1500))
    });
}

criterion_group!(benches, bench_shape, bench_colour);
criterion_main!(benches);
