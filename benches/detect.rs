//! Speed of the background subtractor and its stages on synthetic frames.
//!
//! `cargo bench --bench detect`; medians are in `target/criterion/*/new/estimates.json`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use shapetrack::detect::{
    BackgroundConfig, BackgroundSubtractor, Components, Connectivity, Detector, Morphology,
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
    for (w, h) in [(640u32, 480u32), (1280, 720)] {
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

criterion_group!(benches, bench_subtractor, bench_stages);
criterion_main!(benches);
