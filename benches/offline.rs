//! Offline-mode speed (frames per second, single thread): what the offline pass costs on top of
//! the online one.
//!
//! - `mot15/online|offline/<seq>`: box mode from `det/det.txt`, the whole pipeline.
//! - `relink_only/<seq>`: the offline stages alone (linking and filling) on a finished online
//!   output.
//! - `crowd/relink_only/<n>`: the offline stages on `n` boxes per frame whose online tracks
//!   break often (10 % missed detections, short `max_lost`), to show the candidate search
//!   scales with the tracks, not their square.
//! - `synthetic/online|offline`: mask mode with frames (appearance snapshots and SIFT on), the
//!   occlusion scene of the quality gate, 150 frames rendered once up front.
//!
//! `cargo bench --bench offline` (criterion reports `elem/s` = frames per second).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use shapetrack::frame::{BBox, Detection};
use shapetrack::io::motchallenge::{parse_mot, SeqInfo};
use shapetrack::io::read_text;
use shapetrack::synth::{OccluderRect, Scene, SynthConfig, SynthFrame};
use shapetrack::track::offline::{
    relink, track_offline, OfflineConfig, OfflineTracker, SequenceInfo,
};
use shapetrack::track::{detections_by_frame, track_sequence, Config, Tracker};
use std::hint::black_box;
use std::path::PathBuf;

const SEQUENCES: [&str; 3] = ["ETH-Bahnhof", "PETS09-S2L1", "Venice-2"];

fn mot15(seq: &str) -> (Vec<Vec<Detection>>, SequenceInfo) {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/mot15-train")
        .join(seq);
    let info = SeqInfo::read(&dir.join("seqinfo.ini")).expect("seqinfo.ini");
    let path = dir.join("det/det.txt");
    let recs = parse_mot(&read_text(&path).expect("det.txt"), "det.txt").expect("parse");
    let seq = SequenceInfo::new(info.frame_rate).with_image_size(info.im_width, info.im_height);
    (detections_by_frame(&recs, 1, info.seq_length), seq)
}

fn bench_mot15(c: &mut Criterion) {
    let mut g = c.benchmark_group("mot15");
    g.sample_size(20);
    for seq in SEQUENCES {
        let (frames, info) = mot15(seq);
        g.throughput(Throughput::Elements(frames.len() as u64));
        g.bench_with_input(BenchmarkId::new("online", seq), &frames, |b, f| {
            b.iter(|| black_box(track_sequence(Config::default(), f).expect("track")))
        });
        let cfg = OfflineConfig::default();
        g.bench_with_input(BenchmarkId::new("offline", seq), &frames, |b, f| {
            b.iter(|| black_box(track_offline(&cfg, &info, f, |_| {}).expect("offline")))
        });
        let online = track_sequence(Config::default(), &frames).expect("track");
        g.bench_with_input(BenchmarkId::new("relink_only", seq), &online, |b, s| {
            b.iter(|| black_box(relink(s.clone(), None, &cfg, &info, &mut |_| {}).expect("relink")))
        });
    }
    g.finish();
}

/// `n` boxes moving at constant velocity in a 1920×1080 frame, 10 % of detections missed.
fn crowd(n: usize, frames: usize, seed: u64) -> Vec<Vec<Detection>> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut objs: Vec<[f64; 6]> = (0..n)
        .map(|_| {
            let w = rng.gen_range(20.0..60.0);
            [
                rng.gen_range(0.0..1900.0),
                rng.gen_range(0.0..1000.0),
                rng.gen_range(-3.0..3.0),
                rng.gen_range(-1.5..1.5),
                w,
                w * 2.0,
            ]
        })
        .collect();
    (0..frames)
        .map(|_| {
            let mut dets = Vec::with_capacity(n);
            for o in &mut objs {
                o[0] = (o[0] + o[2]).rem_euclid(1900.0);
                o[1] = (o[1] + o[3]).rem_euclid(1000.0);
                if !rng.gen_bool(0.1) {
                    dets.push(Detection::from_box(BBox::new(o[0], o[1], o[4], o[5]), 0.95));
                }
            }
            dets
        })
        .collect()
}

fn bench_crowd(c: &mut Criterion) {
    let mut g = c.benchmark_group("crowd");
    g.sample_size(10);
    let online_cfg = Config {
        max_lost: 1,
        ..Config::default()
    };
    let info = SequenceInfo::new(25.0).with_image_size(1920, 1080);
    for n in [50usize, 200] {
        let frames = crowd(n, 300, 7);
        let online = track_sequence(online_cfg.clone(), &frames).expect("track");
        let cfg = OfflineConfig::default();
        g.throughput(Throughput::Elements(frames.len() as u64));
        g.bench_with_input(BenchmarkId::new("relink_only", n), &online, |b, s| {
            b.iter(|| black_box(relink(s.clone(), None, &cfg, &info, &mut |_| {}).expect("relink")))
        });
    }
    g.finish();
}

fn synthetic_frames() -> Vec<SynthFrame> {
    let mut cfg = SynthConfig::occlusion_scene(1);
    cfg.width = 800;
    cfg.frames = 150;
    cfg.occlusion.hidden_frames = 20.0;
    cfg.occlusion.rects = vec![OccluderRect {
        x: 700,
        y: 0,
        w: 60,
        h: cfg.height,
    }];
    Scene::new(cfg).expect("scene").collect()
}

fn bench_synthetic(c: &mut Criterion) {
    let frames = synthetic_frames();
    let mut g = c.benchmark_group("synthetic");
    g.sample_size(10);
    g.throughput(Throughput::Elements(frames.len() as u64));
    g.bench_function("online", |b| {
        b.iter(|| {
            let mut t = Tracker::new(Config::default()).expect("tracker");
            for f in &frames {
                let frame = f.frame().expect("frame");
                black_box(t.update(Some(&frame), &f.detections).expect("update"));
            }
        })
    });
    g.bench_function("offline", |b| {
        b.iter(|| {
            let mut t = OfflineTracker::new(OfflineConfig::default(), 25.0).expect("tracker");
            for f in &frames {
                let frame = f.frame().expect("frame");
                t.push_frame(Some(&frame), &f.detections).expect("push");
            }
            black_box(t.finish(|_| {}).expect("finish"))
        })
    });
    g.finish();
}

criterion_group!(benches, bench_mot15, bench_crowd, bench_synthetic);
criterion_main!(benches);
