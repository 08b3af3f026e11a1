//! The background subtractor's wasm SIMD paths against its scalar paths, bit for bit.
//!
//! - The grey conversion (RGBA frames, four pixels at a time): the same scene as RGBA and as
//!   RGB (scalar in every build) must give the same background model (every f32 to the bit),
//!   foreground and detections. Natively both are scalar and the test checks that the two
//!   pixel layouts agree.
//! - The model update (every layout, four pixels at a time): a digest of the model, the
//!   foreground and the detections over a scene, under three learning policies, must equal
//!   the one the native (scalar) build committed in `tests/data/detect/background_digest.txt`
//!   (rewrite it natively with `REGENERATE=1` when a change of behaviour is meant).
//!
//! Under `wasm-bindgen-test-runner` (`npm test` runs it) both check the SIMD code. The width is
//! not a multiple of 4, so the rows' scalar tails are covered too.

use shapetrack::detect::{BackgroundConfig, BackgroundSubtractor, Detector, UpdatePolicy};
use shapetrack::frame::Frame;
use shapetrack::synth::{Scene, SynthConfig};

#[path = "common/fnv.rs"]
mod fnv;
use fnv::{committed_lines, Fnv, OFFSET};

#[cfg(target_arch = "wasm32")]
use wasm_bindgen_test::wasm_bindgen_test as test;

#[test]
fn rgba_frames_give_the_rgb_path_s_model_to_the_bit() {
    let (w, h) = (157, 96);
    let mut scene = Scene::new(SynthConfig::demo().scaled_to(w, h)).unwrap();
    let cfg = BackgroundConfig {
        init_frames: 5,
        ..BackgroundConfig::default()
    };
    let mut rgb_det = BackgroundSubtractor::new(cfg.clone()).unwrap();
    let mut rgba_det = BackgroundSubtractor::new(cfg).unwrap();
    let mut found = 0;
    for _ in 0..40 {
        let f = scene.frame().unwrap();
        let rgba: Vec<u8> = f
            .image
            .chunks_exact(3)
            .flat_map(|p| [p[0], p[1], p[2], 255])
            .collect();
        let a = rgb_det
            .detect(&Frame::rgb(&f.image, w, h).unwrap())
            .unwrap();
        let b = rgba_det.detect(&Frame::rgba(&rgba, w, h).unwrap()).unwrap();
        let bits = |d: &BackgroundSubtractor| -> Vec<u32> {
            d.background()
                .unwrap_or(&[])
                .iter()
                .map(|v| v.to_bits())
                .collect()
        };
        assert_eq!(bits(&rgb_det), bits(&rgba_det), "frame {}", f.index);
        assert_eq!(
            rgb_det.foreground(),
            rgba_det.foreground(),
            "frame {}",
            f.index
        );
        assert_eq!(a, b, "frame {}", f.index);
        found += a.len();
    }
    // The scene's shapes were detected: the comparison covered foreground pixels too.
    assert!(found > 0);
}

/// FNV-1a, 64 bits, over the subtractor's state and output after each frame.
fn digest(cfg: BackgroundConfig) -> u64 {
    let (w, h) = (157, 96);
    let mut scene = Scene::new(SynthConfig::demo().scaled_to(w, h)).unwrap();
    let mut det = BackgroundSubtractor::new(cfg).unwrap();
    let mut d = Fnv(OFFSET);
    let mut found = 0;
    for _ in 0..40 {
        let f = scene.frame().unwrap();
        let dets = det.detect(&Frame::rgb(&f.image, w, h).unwrap()).unwrap();
        for v in det.background().unwrap_or(&[]) {
            d.bytes(&v.to_bits().to_le_bytes());
        }
        d.bytes(det.foreground());
        for x in &dets {
            for v in [x.bbox.x, x.bbox.y, x.bbox.w, x.bbox.h, x.score] {
                d.f64(v);
            }
            d.u64(x.mask.as_ref().map_or(0, |m| m.area()));
        }
        found += dets.len();
    }
    // Shapes were found: foreground pixels, and their scores (the update's `|Z − B|`), count.
    assert!(found > 0);
    d.0
}

/// The model update under three policies: the default (foreground pixels learn only once
/// still for `absorb_frames`), a short absorb with a slow foreground rate (the stillness
/// counter reaches its limit and both rates are used), and the thesis' eq. 2 as written.
fn digests() -> Vec<String> {
    let base = BackgroundConfig {
        init_frames: 5,
        ..BackgroundConfig::default()
    };
    let policies = [
        ("default", base.clone()),
        (
            "absorb",
            BackgroundConfig {
                absorb_frames: 2,
                update: UpdatePolicy::Selective {
                    foreground_alpha: 0.01,
                },
                threshold: 12.0,
                ..base.clone()
            },
        ),
        (
            "all",
            BackgroundConfig {
                update: UpdatePolicy::All,
                ..base
            },
        ),
    ];
    policies
        .into_iter()
        .map(|(name, cfg)| format!("{name} {:016x}", digest(cfg)))
        .collect()
}

const COMMITTED: &str = include_str!("data/detect/background_digest.txt");

fn committed() -> Vec<String> {
    committed_lines(COMMITTED)
}

#[test]
fn the_model_update_matches_the_native_digest() {
    let got = digests();
    #[cfg(not(target_arch = "wasm32"))]
    if std::env::var_os("REGENERATE").is_some() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/data/detect/background_digest.txt"
        );
        let text = format!(
            "# The background subtractor's model, foreground and detections over a scene, per \
             learning policy (tests/detect_simd.rs).\n{}\n",
            got.join("\n")
        );
        std::fs::write(path, text).unwrap();
        return;
    }
    assert_eq!(got, committed());
}
