//! The background subtractor's wasm SIMD path (RGBA frames, four pixels at a time) against its
//! scalar path (RGB frames), bit for bit: the same scene as RGBA and as RGB must give the same
//! background model (every f32 to the bit), foreground and detections. Natively both are
//! scalar and the test checks that the two pixel layouts agree; under
//! `wasm-bindgen-test-runner` (`npm test` runs it) it checks the SIMD code. The width is not a
//! multiple of 4, so the rows' scalar tails are covered too.

use shapetrack::detect::{BackgroundConfig, BackgroundSubtractor, Detector};
use shapetrack::frame::Frame;
use shapetrack::synth::{Scene, SynthConfig};

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
