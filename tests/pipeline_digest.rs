//! The browser build computes what the native build computes, bit for bit.
//!
//! The wasm module is built with SIMD (`+simd128`, `.cargo/config.toml`) and a different
//! optimisation level than the native binary, and its maths library is not the platform's. A
//! difference in the last bit of one float can change a match, so the whole pipeline is
//! checked, not single functions: the browser's default scene rendered, the background
//! subtractor (the app's default detector) over it, the moving-camera detector, and the
//! tracker with the mask preset and frames. Every detection (box, score, mask) and every
//! tracked shape (identity, box, score, mask, state) goes into one FNV-1a digest. The colour
//! palettes (k-means over many generated samples: centroids and labels) get a digest of their
//! own: the scene's tracks need not depend on them (a wrong distance computed in wasm changed
//! the palettes and the moving-camera detector's digests, not the tracker's).
//!
//! The native test compares the digest with `tests/data/track/pipeline_digest.txt` (rewrite it
//! with `REGENERATE=1` when a change of behaviour is meant); the same test, run in wasm by
//! wasm-bindgen-test (`npm test`'s wasm-bindgen step, under Node), compares the wasm digest
//! with the same file, so the wasm build equals the native one.

use shapetrack::detect::{BackgroundConfig, BackgroundSubtractor, Detector};
use shapetrack::detect::{MovingCameraDetector, MovingConfig};
use shapetrack::features::color::{view_palette, ColorConfig, ColorSample};
use shapetrack::io::Rle;
use shapetrack::synth::{Scene, SynthConfig};
use shapetrack::track::{Config, Tracker};
use shapetrack::{BBox, Detection, TrackedShape};

/// Frames of the scene digested: past the background model's warm-up, through crossings.
const FRAMES: u32 = 90;

#[path = "common/fnv.rs"]
mod fnv;
use fnv::{committed_lines, Fnv, OFFSET};

/// What the pipeline's stages report, taken into a digest.
impl Fnv {
    fn bbox(&mut self, b: &BBox) {
        for v in [b.x, b.y, b.w, b.h] {
            self.f64(v);
        }
    }

    fn mask(&mut self, m: Option<&shapetrack::Mask>, w: u32, h: u32) {
        match m {
            Some(m) => {
                let rle = Rle::from_mask(m, w, h);
                self.u64(rle.counts.len() as u64);
                for &c in &rle.counts {
                    self.u64(u64::from(c));
                }
            }
            None => self.u64(u64::MAX),
        }
    }

    fn detections(&mut self, dets: &[Detection], w: u32, h: u32) {
        self.u64(dets.len() as u64);
        for d in dets {
            self.bbox(&d.bbox);
            self.f64(d.score);
            self.mask(d.mask.as_ref(), w, h);
        }
    }

    fn shapes(&mut self, shapes: &[TrackedShape], w: u32, h: u32) {
        self.u64(shapes.len() as u64);
        for s in shapes {
            self.u64(s.id);
            self.u64(u64::from(s.frame));
            self.bbox(&s.bbox);
            self.f64(s.score);
            self.f64(s.centroid.x);
            self.f64(s.centroid.y);
            self.bytes(format!("{:?}{}", s.state, s.interpolated).as_bytes());
            self.mask(s.mask.as_ref(), w, h);
        }
    }
}

/// The digests of the pipeline's three stages over the browser's default scene.
fn digest() -> [u64; 3] {
    let cfg = SynthConfig::default();
    let (w, h) = (cfg.width, cfg.height);
    let mut background = BackgroundSubtractor::new(BackgroundConfig::default()).unwrap();
    let mut moving = MovingCameraDetector::new(MovingConfig::default()).unwrap();
    let mut tracker = Tracker::new(Config::masks()).unwrap();
    let (mut bg, mut mv, mut tr) = (Fnv(OFFSET), Fnv(1), Fnv(2));
    for f in Scene::new(cfg).unwrap().take(FRAMES as usize) {
        let frame = f.frame().unwrap();
        let dets = background.detect(&frame).unwrap();
        bg.detections(&dets, w, h);
        mv.detections(&moving.detect(&frame).unwrap(), w, h);
        let shapes = tracker.update(Some(&frame), &dets).unwrap();
        tr.shapes(&shapes, w, h);
    }
    [bg.0, mv.0, tr.0]
}

/// The digest of the colour palettes (centroids and labels, [`view_palette`]) of generated
/// samples: sizes from one colour to the tracker's cap, few distinct shades (ties, equal
/// distances, empty clusters) and many, odd and even numbers of clusters, runs stopped by the
/// iteration cap and by the tolerance.
fn palettes() -> u64 {
    let mut x: u64 = 0x2545_f491_4f6c_dd1d;
    let mut next = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    };
    let mut d = Fnv(3);
    // The sizes, shades, cluster counts and caps vary at different rates, so the cases mix them.
    for case in 0..60u64 {
        let n = [1usize, 2, 7, 50, 151, 300, 1500][case as usize % 7];
        let levels = [2u64, 5, 256][case as usize % 3];
        let positions: Vec<shapetrack::Point> = (0..n)
            .map(|i| shapetrack::Point::new((i % 40) as f64, (i / 40) as f64))
            .collect();
        let rgb: Vec<[u8; 3]> = (0..n)
            .map(|_| [0u8; 3].map(|_| (next() % levels * 255 / levels) as u8))
            .collect();
        let sample = ColorSample::new(positions, rgb, 1.0).unwrap();
        let cfg = ColorConfig {
            clusters: [1usize, 2, 3, 9, 10, 11, 16][case as usize / 7 % 7],
            max_iterations: [30u64, 2, 100][case as usize / 3 % 3],
            seed: case,
            ..ColorConfig::default()
        };
        let p = view_palette(&sample, &cfg).unwrap();
        d.u64(p.centroids.len() as u64);
        for c in &p.centroids {
            c.iter().for_each(|&v| d.f64(v));
        }
        p.labels.iter().for_each(|&l| d.u64(l as u64));
    }
    d.0
}

/// The committed digests, one hexadecimal line per stage.
const COMMITTED: &str = include_str!("data/track/pipeline_digest.txt");

fn committed() -> Vec<String> {
    committed_lines(COMMITTED)
}

fn lines(d: [u64; 3]) -> Vec<String> {
    ["background", "moving", "tracker", "palettes"]
        .iter()
        .zip(d.into_iter().chain([palettes()]))
        .map(|(name, v)| format!("{name} {v:016x}"))
        .collect()
}

#[cfg(not(target_arch = "wasm32"))]
#[test]
fn native_pipeline_matches_the_committed_digest() {
    let got = lines(digest());
    if std::env::var_os("REGENERATE").is_some() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/data/track/pipeline_digest.txt"
        );
        let text = format!(
            "# tests/pipeline_digest.rs: the native pipeline's digests, which the wasm build must equal\n{}\n",
            got.join("\n")
        );
        std::fs::write(path, text).unwrap();
        return;
    }
    assert_eq!(
        got,
        committed(),
        "the pipeline's output changed; if meant, REGENERATE=1 cargo test --test pipeline_digest"
    );
}

#[cfg(target_arch = "wasm32")]
#[wasm_bindgen_test::wasm_bindgen_test]
fn wasm_pipeline_equals_the_native_one() {
    assert_eq!(lines(digest()), committed());
}
