//! Speed of synthetic frame generation (rendering, ground truth, noisy detections).
//!
//! `cargo bench --bench synth`; medians are in `target/criterion/*/new/estimates.json`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use shapetrack::synth::{Scene, SynthConfig};
use std::hint::black_box;

fn bench_frames(c: &mut Criterion) {
    let mut g = c.benchmark_group("synth_frame");
    let cases = [
        ("default", SynthConfig::default()),
        ("occlusion", SynthConfig::occlusion_scene(1)),
        ("demo_1280x720", SynthConfig::demo()),
        (
            "default_1280x720",
            SynthConfig {
                width: 1280,
                height: 720,
                ..SynthConfig::default()
            },
        ),
        (
            "50_shapes_640x480",
            SynthConfig {
                shapes: 50,
                ..SynthConfig::default()
            },
        ),
    ];
    for (name, cfg) in cases {
        let mut scene = Scene::new(SynthConfig {
            frames: u32::MAX,
            ..cfg
        })
        .unwrap();
        g.bench_function(BenchmarkId::from_parameter(name), |b| {
            b.iter(|| black_box(scene.frame()))
        });
    }
    g.finish();
}

fn bench_setup(c: &mut Criterion) {
    c.bench_function("synth_scene_new_640x480", |b| {
        b.iter(|| black_box(Scene::new(SynthConfig::default()).unwrap()))
    });
}

criterion_group!(benches, bench_frames, bench_setup);
criterion_main!(benches);
