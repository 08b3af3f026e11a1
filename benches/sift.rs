//! SIFT speed: `detect_and_compute` on square crops of a seeded texture (64, 128, 256 px; OpenCV
//! defaults, i.e. with 2× upsampling, and without upsampling), and ratio-test matching of
//! 200 × 200 descriptors (with and without cross check).
//!
//! Run with `cargo bench --bench sift`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use image::{GrayImage, Luma};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use shapetrack::features::sift::{
    detect_and_compute, match_descriptor_sets, MatchConfig, SiftConfig,
};
use std::hint::black_box;

/// Grey texture with blobs and rectangles at a density of one feature per ~60 px².
fn texture(side: u32, seed: u64) -> GrayImage {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let n = (side * side / 60) as usize;
    let mut f = vec![128f32; (side * side) as usize];
    for _ in 0..n {
        let (cx, cy) = (
            rng.gen_range(0.0..side as f32),
            rng.gen_range(0.0..side as f32),
        );
        let s = rng.gen_range(1.0f32..5.0);
        let a = rng.gen_range(-80.0f32..80.0);
        let r = (4.0 * s).ceil() as i64;
        for y in (cy as i64 - r).max(0)..(cy as i64 + r).min(side as i64) {
            for x in (cx as i64 - r).max(0)..(cx as i64 + r).min(side as i64) {
                let d2 = ((x as f32 + 0.5 - cx).powi(2) + (y as f32 + 0.5 - cy).powi(2)) / (s * s);
                f[(y * side as i64 + x) as usize] += a * (-0.5 * d2).exp();
            }
        }
    }
    GrayImage::from_fn(side, side, |x, y| {
        Luma([f[(y * side + x) as usize].round().clamp(0.0, 255.0) as u8])
    })
}

fn bench_detect(c: &mut Criterion) {
    let mut g = c.benchmark_group("sift_detect_and_compute");
    g.sample_size(20);
    for side in [64u32, 128, 256] {
        let img = texture(side, 42);
        let n = detect_and_compute(&img, None, &SiftConfig::default())
            .unwrap()
            .len();
        eprintln!("{side}x{side}: {n} keypoints");
        g.bench_with_input(BenchmarkId::new("default", side), &img, |b, img| {
            b.iter(|| detect_and_compute(black_box(img), None, &SiftConfig::default()).unwrap())
        });
        // Without OpenCV's 2x upsampling: the cheap setting for the tracker's crops.
        let cheap = SiftConfig {
            upsample: false,
            ..SiftConfig::default()
        };
        g.bench_with_input(BenchmarkId::new("no_upsample", side), &img, |b, img| {
            b.iter(|| detect_and_compute(black_box(img), None, &cheap).unwrap())
        });
    }
    g.finish();
}

fn bench_match(c: &mut Criterion) {
    // Real descriptors (not random bytes), so early exit behaves as in use.
    let a = detect_and_compute(&texture(256, 1), None, &SiftConfig::default()).unwrap();
    let b = detect_and_compute(&texture(256, 2), None, &SiftConfig::default()).unwrap();
    assert!(a.len() >= 200 && b.len() >= 200);
    let (qa, tb) = (&a.descriptors[..200], &b.descriptors[..200]);
    let mut g = c.benchmark_group("sift_match_200x200");
    g.bench_function("ratio", |bch| {
        bch.iter(|| match_descriptor_sets(black_box(qa), black_box(tb), &MatchConfig::default()))
    });
    let cross = MatchConfig {
        cross_check: true,
        ..MatchConfig::default()
    };
    g.bench_function("ratio_cross_check", |bch| {
        bch.iter(|| match_descriptor_sets(black_box(qa), black_box(tb), &cross))
    });
    g.finish();
}

criterion_group!(benches, bench_detect, bench_match);
criterion_main!(benches);
