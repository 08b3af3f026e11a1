//! Geometry and region-estimator speed: `mask_geometry` by mask size, the per-shape RLE and
//! grown search shell (`per_shape`), and `region_clusters`
//! by shape count with the sort-and-sweep broad phase against GJK on all pairs (thesis Alg. 2).
//!
//! Run: `cargo bench --bench geometry`

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use shapetrack::geometry::{intersects_thesis, mask_geometry, ConvexShell, GeometryConfig};
use shapetrack::io::Rle;
use shapetrack::region::{predicted_shell, region_clusters_with, BroadPhase};
use shapetrack::{Mask, Point};

/// A blobby mask filling most of an `n × n` bitmap: a disc with a few bumps and a notch, so
/// the contour and edges are not trivially regular.
fn blob_mask(n: u32) -> Mask {
    let c = n as f64 / 2.0;
    let r = n as f64 * 0.4;
    let mut d = Vec::with_capacity((n * n) as usize);
    for y in 0..n {
        for x in 0..n {
            let (dx, dy) = (x as f64 + 0.5 - c, y as f64 + 0.5 - c);
            let a = dy.atan2(dx);
            let rr = r * (1.0 + 0.12 * (5.0 * a).sin());
            let notch = dx > 0.0 && dy.abs() < n as f64 * 0.05;
            d.push((dx.hypot(dy) <= rr && !notch) as u8);
        }
    }
    Mask::new(500, 300, n, n, d).unwrap()
}

fn bench_mask_geometry(c: &mut Criterion) {
    let cfg = GeometryConfig::default();
    let mut g = c.benchmark_group("mask_geometry");
    for n in [64u32, 256] {
        let m = blob_mask(n);
        g.bench_with_input(
            BenchmarkId::from_parameter(format!("{n}x{n}")),
            &m,
            |b, m| b.iter(|| mask_geometry(black_box(m), &cfg).unwrap()),
        );
    }
    g.finish();
}

/// The per-shape steps of a tracked frame that `mask_geometry` does not time: a mask's COCO
/// RLE (the offline tracker keeps every shape's mask as one) and a search shell grown by a
/// margin (every track, every frame).
fn bench_per_shape(c: &mut Criterion) {
    let mut g = c.benchmark_group("per_shape");
    for n in [64u32, 256] {
        let m = blob_mask(n);
        g.bench_with_input(
            BenchmarkId::new("rle_from_mask", format!("{n}x{n}")),
            &m,
            |b, m| b.iter(|| Rle::from_mask(black_box(m), 1920, 1080)),
        );
    }
    let shell = shapetrack::geometry::shell::pixel_hull(&blob_mask(64));
    g.bench_function(BenchmarkId::new("shell_grown", shell.len()), |b| {
        b.iter(|| black_box(&shell).grown(6.0))
    });
    g.finish();
}

/// `n` detections' shells (random convex polygons, 8–25 px radius, 6–16 vertices, like mask
/// shells) over a 1920×1080 frame, and the tracks' shells: the same shapes one frame earlier,
/// moved back by their motion, then predicted forward and grown by 4 px as the tracker does.
fn scene(n: usize, seed: u64) -> (Vec<ConvexShell>, Vec<ConvexShell>) {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut tracks = Vec::with_capacity(n);
    let mut dets = Vec::with_capacity(n);
    for _ in 0..n {
        let c = Point::new(rng.gen_range(0.0..1920.0), rng.gen_range(0.0..1080.0));
        let r = rng.gen_range(8.0..25.0);
        let k = rng.gen_range(6..16);
        let pts: Vec<Point> = (0..k)
            .map(|_| {
                let a: f64 = rng.gen_range(0.0..std::f64::consts::TAU);
                let rr = r * rng.gen_range(0.6..1.0);
                Point::new(c.x + rr * a.cos(), c.y + rr * a.sin())
            })
            .collect();
        let det = ConvexShell::from_points(&pts).unwrap();
        let (vx, vy) = (rng.gen_range(-6.0..6.0), rng.gen_range(-6.0..6.0));
        let last = det.translated(-vx, -vy);
        // Prediction a little off, as in practice.
        tracks.push(predicted_shell(&last, vx * 0.9, vy * 1.1, 4.0));
        dets.push(det);
    }
    (tracks, dets)
}

fn bench_region(c: &mut Criterion) {
    let mut g = c.benchmark_group("region_clusters");
    // Issue 10 asks the broad phase to stay O(n log n) up to 500 shapes: sort-and-sweep's time
    // per shape should stay about flat from 200 to 500, where all pairs' grows with n.
    for n in [10usize, 50, 200, 500] {
        let (tracks, dets) = scene(n, 42 + n as u64);
        for (name, phase) in [
            ("sort_and_sweep", BroadPhase::SortAndSweep),
            ("all_pairs", BroadPhase::AllPairs),
        ] {
            g.bench_with_input(BenchmarkId::new(name, n), &phase, |b, &phase| {
                b.iter(|| region_clusters_with(black_box(&tracks), black_box(&dets), phase))
            });
        }
    }
    g.finish();
}

fn bench_gjk_pair(c: &mut Criterion) {
    let (tracks, dets) = scene(50, 7);
    // Pairs that overlap, so both tests run to completion rather than exiting early.
    let pairs: Vec<(ConvexShell, ConvexShell)> = tracks
        .iter()
        .zip(&dets)
        .filter(|(t, d)| t.intersects(d))
        .map(|(t, d)| (t.clone(), d.clone()))
        .collect();
    let mut g = c.benchmark_group("gjk_overlapping_pairs");
    g.bench_function("parry2d", |b| {
        b.iter(|| pairs.iter().filter(|(t, d)| t.intersects(d)).count())
    });
    g.bench_function("thesis", |b| {
        b.iter(|| {
            pairs
                .iter()
                .filter(|(t, d)| intersects_thesis(t, d))
                .count()
        })
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().measurement_time(std::time::Duration::from_secs(3));
    targets = bench_mask_geometry, bench_per_shape, bench_region, bench_gjk_pair
}
criterion_main!(benches);
