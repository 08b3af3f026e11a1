//! Speed of the background subtractor and its stages, the dense flow and the moving-camera
//! detector, on synthetic frames.
//!
//! `cargo bench --bench detect`; medians are in `target/criterion/*/new/estimates.json`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use shapetrack::detect::{
    BackgroundConfig, BackgroundSubtractor, Components, Connectivity, DenseFlow, Detector,
    FlowConfig, FlowField, Morphology, MotionCue, MovingCameraDetector, MovingConfig,
};
use shapetrack::synth::{Scene, SynthConfig};
use shapetrack::{Frame, PixelFormat};
use std::hint::black_box;

fn frames(w: u32, h: u32, n: u32) -> Vec<Vec<u8>> {
    let cfg = SynthConfig {
        width: w,
        height: h,
        frames: n,
        ..SynthConfig::with_seed(1)
    };
    Scene::new(cfg).unwrap().map(|f| f.image).collect()
}

fn rgba(rgb: &[u8]) -> Vec<u8> {
    rgb.chunks_exact(3)
        .flat_map(|p| [p[0], p[1], p[2], 255])
        .collect()
}

fn bench_subtractor(c: &mut Criterion) {
    let mut g = c.benchmark_group("background_subtractor");
    for (w, h) in [(640u32, 480u32), (1280, 720)] {
        let imgs = frames(w, h, 60);
        for format in [PixelFormat::Rgb8, PixelFormat::Rgba8] {
            let bufs: Vec<Vec<u8>> = match format {
                PixelFormat::Rgb8 => imgs.clone(),
                PixelFormat::Rgba8 => imgs.iter().map(|i| rgba(i)).collect(),
            };
            let stride = w as usize * format.channels();
            let mut bs = BackgroundSubtractor::new(BackgroundConfig::default()).unwrap();
            // Past the initial frames and the ghosts, as in steady use.
            for b in &bufs[..50] {
                bs.detect(&Frame::new(b, w, h, stride, format).unwrap())
                    .unwrap();
            }
            let mut k = 0usize;
            g.bench_function(
                BenchmarkId::new(format!("{format:?}"), format!("{w}x{h}")),
                |bch| {
                    bch.iter(|| {
                        let b = &bufs[50 + k % 10];
                        k += 1;
                        let f = Frame::new(b, w, h, stride, format).unwrap();
                        black_box(bs.detect(&f).unwrap())
                    })
                },
            );
        }
    }
    g.finish();
}

/// A realistic foreground bitmap: the first frame's ground-truth masks.
fn foreground(w: u32, h: u32) -> Vec<u8> {
    let cfg = SynthConfig {
        width: w,
        height: h,
        frames: 1,
        ..SynthConfig::with_seed(1)
    };
    let f = Scene::new(cfg).unwrap().next().unwrap();
    let mut bits = vec![0u8; (w * h) as usize];
    for g in &f.gt {
        for (x, y) in g.mask.pixels() {
            bits[y as usize * w as usize + x as usize] = 1;
        }
    }
    // Sprinkle specks, as a thresholded difference image has.
    for i in (0..bits.len()).step_by(997) {
        bits[i] = 1;
    }
    bits
}

fn bench_stages(c: &mut Criterion) {
    let mut g = c.benchmark_group("stages");
    for (w, h) in [(640u32, 480u32), (1280, 720), (1920, 1080)] {
        let bits = foreground(w, h);
        let size = format!("{w}x{h}");
        let mut m = Morphology::new();
        g.bench_function(BenchmarkId::new("open_close_3x3_own", &size), |b| {
            b.iter(|| {
                let mut x = bits.clone();
                m.open(&mut x, w as usize, h as usize, 1);
                m.close(&mut x, w as usize, h as usize, 1);
                black_box(x)
            })
        });
        let img =
            image::GrayImage::from_raw(w, h, bits.iter().map(|&v| v * 255).collect()).unwrap();
        g.bench_function(BenchmarkId::new("open_close_3x3_imageproc", &size), |b| {
            b.iter(|| {
                let o =
                    imageproc::morphology::open(&img, imageproc::distance_transform::Norm::LInf, 1);
                black_box(imageproc::morphology::close(
                    &o,
                    imageproc::distance_transform::Norm::LInf,
                    1,
                ))
            })
        });
        let mut comps = Components::new();
        g.bench_function(BenchmarkId::new("components_own", &size), |b| {
            b.iter(|| black_box(comps.label(&bits, w, h, Connectivity::Eight).unwrap().len()))
        });
        g.bench_function(BenchmarkId::new("components_imageproc", &size), |b| {
            b.iter(|| {
                black_box(imageproc::region_labelling::connected_components(
                    &img,
                    imageproc::region_labelling::Connectivity::Eight,
                    image::Luma([0u8]),
                ))
            })
        });
    }
    g.finish();
}

/// Grey levels of a smooth texture moved by `(dx, dy)`.
fn grey(w: usize, h: usize, dx: f32, dy: f32) -> Vec<f32> {
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32 + dx, (i / w) as f32 + dy);
            128.0
                + 40.0 * (0.31 * x).sin()
                + 35.0 * (0.17 * y).sin()
                + 25.0 * (0.23 * (x + y)).cos()
        })
        .collect()
}

fn bench_flow(c: &mut Criterion) {
    let mut g = c.benchmark_group("dense_flow");
    // 213×120 is the moving-camera detector's working size for 854×480 (and 16:9 video).
    for (w, h) in [(213usize, 120usize), (320, 180)] {
        let (a, b) = (grey(w, h, 0.0, 0.0), grey(w, h, 2.3, -1.1));
        let mut flow = DenseFlow::new(FlowConfig::default());
        let mut out = FlowField::default();
        g.bench_function(BenchmarkId::new("dis", format!("{w}x{h}")), |bch| {
            bch.iter(|| {
                flow.compute(&a, &b, w, h, &mut out);
                black_box(out.u[0])
            })
        });
    }
    g.finish();
}

fn bench_moving(c: &mut Criterion) {
    let mut g = c.benchmark_group("moving_detector");
    g.sample_size(20);
    let (w, h) = (854u32, 480u32);
    let imgs = frames(w, h, 40);
    for cue in [MotionCue::Flow, MotionCue::Background] {
        let mut det = MovingCameraDetector::new(MovingConfig {
            cue,
            ..MovingConfig::default()
        })
        .unwrap();
        for i in &imgs[..20] {
            det.detect(&Frame::rgb(i, w, h).unwrap()).unwrap();
        }
        let mut k = 0usize;
        g.bench_function(
            BenchmarkId::new(format!("{cue:?}"), format!("{w}x{h}")),
            |bch| {
                bch.iter(|| {
                    // Frames in order, as a video gives them (the detectors compare consecutive
                    // frames); the wrap back every 20 frames is one jump in 20.
                    let f = &imgs[20 + k % 20];
                    k += 1;
                    black_box(det.detect(&Frame::rgb(f, w, h).unwrap()).unwrap())
                })
            },
        );
    }
    g.finish();
}

criterion_group!(
    benches,
    bench_subtractor,
    bench_stages,
    bench_flow,
    bench_moving
);
criterion_main!(benches);
