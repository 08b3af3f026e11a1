//! Tracking speed (frames per second, single thread; criterion reports `elem/s` = frames per
//! second):
//!
//! - box mode: MOT15-train sequences from their `det/det.txt`, and synthetic scenes with 50
//!   and 200 moving boxes per frame;
//! - mask mode (`Config::masks`, frames given, appearance where needed): the browser demo's
//!   scene (`SynthConfig::demo()`, 1280×720, 12 shapes) and the occlusion scene of
//!   `tests/track_synth.rs` (640×480, 10 shapes). Frames are rendered before timing;
//! - mask mode by shape count and resolution (`track_mask_scaling`: 10, 20, 50 and 200 shapes
//!   at 640×480 and 1280×720, the scenes of `shapetrack bench`), for the scaling target of
//!   issue 10 (200 shapes ≤ 12× the 20-shape cost).
//!
//! - the dense crowd of issue 64 (`track_pedestrians`): the online tracker on the
//!   pedestrian family's scenes (`SynthConfig::pedestrians`, 1920×1080) with about 50, 100
//!   and 200 people in view per frame, box mode (the visible parts' jittered boxes,
//!   `Config::default()`) and mask mode (visible masks with frames, `Config::masks()`), for
//!   the near-linear cost asked there; figures in docs/benchmarks.md.
//!
//! `cargo bench --bench track`. For the per-phase split and more sizes: `shapetrack bench`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use shapetrack::frame::{BBox, Detection};
use shapetrack::io::motchallenge::{parse_mot, SeqInfo};
use shapetrack::io::read_text;
use shapetrack::synth::{Scene, SynthConfig, SynthFrame};
use shapetrack::track::{detections_by_frame, track_sequence, Config, Tracker};
use std::hint::black_box;
use std::path::PathBuf;

const SEQUENCES: [&str; 4] = ["ETH-Bahnhof", "PETS09-S2L1", "TUD-Stadtmitte", "Venice-2"];

fn mot15(seq: &str) -> Vec<Vec<Detection>> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/mot15-train")
        .join(seq);
    let info = SeqInfo::read(&dir.join("seqinfo.ini")).expect("seqinfo.ini");
    let path = dir.join("det/det.txt");
    let recs = parse_mot(&read_text(&path).expect("det.txt"), "det.txt").expect("parse");
    detections_by_frame(&recs, 1, info.seq_length)
}

/// `n` boxes wandering in a 1920×1080 frame with constant velocity plus jitter; each detection
/// is missed with probability 5 %.
fn random_scene(n: usize, frames: usize, seed: u64) -> Vec<Vec<Detection>> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut objs: Vec<[f64; 6]> = (0..n)
        .map(|_| {
            let w = rng.gen_range(20.0..80.0);
            [
                rng.gen_range(0.0..1900.0),
                rng.gen_range(0.0..1000.0),
                rng.gen_range(-4.0..4.0),
                rng.gen_range(-2.0..2.0),
                w,
                w * rng.gen_range(1.5..3.0),
            ]
        })
        .collect();
    (0..frames)
        .map(|_| {
            let mut dets = Vec::with_capacity(n);
            for o in &mut objs {
                o[0] = (o[0] + o[2]).rem_euclid(1900.0);
                o[1] = (o[1] + o[3]).rem_euclid(1000.0);
                if rng.gen_bool(0.05) {
                    continue;
                }
                let j = |r: &mut Xoshiro256PlusPlus| r.gen_range(-1.5..1.5);
                let b = BBox::new(o[0] + j(&mut rng), o[1] + j(&mut rng), o[4], o[5]);
                dets.push(Detection::from_box(b, rng.gen_range(0.5..1.0)));
            }
            dets
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("track_box_mode");
    g.sample_size(20);
    for seq in SEQUENCES {
        let frames = mot15(seq);
        g.throughput(Throughput::Elements(frames.len() as u64));
        g.bench_with_input(BenchmarkId::new("mot15", seq), &frames, |b, f| {
            b.iter(|| black_box(track_sequence(Config::default(), f).expect("track")))
        });
    }
    for n in [50usize, 200] {
        let frames = random_scene(n, 100, 7 + n as u64);
        g.throughput(Throughput::Elements(frames.len() as u64));
        g.bench_with_input(BenchmarkId::new("random_boxes", n), &frames, |b, f| {
            b.iter(|| black_box(track_sequence(Config::default(), f).expect("track")))
        });
    }
    g.finish();
}

fn track_masks(frames: &[SynthFrame]) -> usize {
    // Run *on* a one-thread rayon pool, as the CLI does (src/bin/shapetrack/main.rs): linfa's
    // k-means then runs its rayon calls inline instead of handing each one to a worker
    // thread, the browser's situation (one thread per worker).
    on_one_thread_pool(|| {
        let mut t = Tracker::new(Config::masks()).expect("config");
        let mut n = 0;
        for f in frames {
            let frame = f.frame().expect("frame");
            n += t.update(Some(&frame), &f.detections).expect("track").len();
        }
        n
    })
}

/// `f` run on the single thread of a fresh one-thread rayon pool.
fn on_one_thread_pool<T: Send>(f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("rayon pool")
        .install(f)
}

fn bench_masks(c: &mut Criterion) {
    let mut g = c.benchmark_group("track_mask_mode");
    g.sample_size(10);
    let demo = SynthConfig {
        frames: 150,
        ..SynthConfig::demo()
    };
    let occlusion = SynthConfig {
        shapes: 10,
        frames: 150,
        ..SynthConfig::occlusion_scene(1)
    };
    for (name, cfg) in [("demo_1280x720", demo), ("occlusion_640x480", occlusion)] {
        let frames: Vec<SynthFrame> = Scene::new(cfg).expect("scene").collect();
        g.throughput(Throughput::Elements(frames.len() as u64));
        g.bench_with_input(BenchmarkId::new("synth", name), &frames, |b, f| {
            b.iter(|| black_box(track_masks(f)))
        });
    }
    g.finish();
}

/// Masks with frames by shape count and resolution, on the scenes `shapetrack bench` times
/// (`SynthConfig::default()` resized, seed 1): criterion's per-element throughput makes the
/// scaling (200 vs 20 shapes) readable from the report. 40 frames per scene keeps one sample
/// of the 200-shape scene in seconds.
fn bench_mask_scaling(c: &mut Criterion) {
    let mut g = c.benchmark_group("track_mask_scaling");
    g.sample_size(10);
    for (width, height) in [(640u32, 480u32), (1280, 720)] {
        for shapes in [10u32, 20, 50, 200] {
            let cfg = SynthConfig {
                seed: 1,
                frames: 40,
                shapes,
                width,
                height,
                ..SynthConfig::default()
            };
            let frames: Vec<SynthFrame> = Scene::new(cfg).expect("scene").collect();
            g.throughput(Throughput::Elements(frames.len() as u64));
            let id = BenchmarkId::new(format!("{width}x{height}"), format!("{shapes}_shapes"));
            g.bench_with_input(id, &frames, |b, f| b.iter(|| black_box(track_masks(f))));
        }
    }
    g.finish();
}

/// Frames of the pedestrian crowd timed per sample: 30 keep the 200-person mask scene's
/// frames (6 MB each at 1080p) and one sample within seconds.
const CROWD_FRAMES: u32 = 30;

/// The online tracker on the dense crowd with about 50, 100 and 200 people in view, box and
/// mask mode. The walkers alive at once are scaled so that about `people` are in view (46 of
/// the family's 51 are); `cargo run --release --example pedestrian_stats` measures the scenes.
fn bench_pedestrians(c: &mut Criterion) {
    let mut g = c.benchmark_group("track_pedestrians");
    g.sample_size(10);
    for people in [50u32, 100, 200] {
        let alive = (people as f64 * shapetrack::synth::PEDESTRIANS as f64 / 46.4).round() as u32;
        let cfg = SynthConfig {
            frames: CROWD_FRAMES,
            ..SynthConfig::pedestrians(7, alive)
        };
        let (w, h) = (cfg.width, cfg.height);
        let frames: Vec<SynthFrame> = Scene::new(cfg).expect("scene").collect();
        g.throughput(Throughput::Elements(frames.len() as u64));
        g.bench_with_input(BenchmarkId::new("boxes", people), &frames, |b, f| {
            b.iter(|| {
                let mut t = Tracker::new(Config::default())
                    .expect("config")
                    .with_image_size(w, h);
                let mut n = 0;
                for fr in f {
                    n += t.update(None, &fr.box_detections).expect("track").len();
                }
                black_box(n)
            })
        });
        g.bench_with_input(BenchmarkId::new("masks", people), &frames, |b, f| {
            b.iter(|| black_box(track_masks(f)))
        });
    }
    g.finish();
}

criterion_group!(
    benches,
    bench,
    bench_masks,
    bench_mask_scaling,
    bench_pedestrians
);
criterion_main!(benches);
