//! SIFT on wasm32: the same keypoints and descriptors as OpenCV on the committed fixture (the
//! float maths must not drift between targets), plus a rough timing printed for the report. Run
//! with
//! `CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUNNER=wasm-bindgen-test-runner \
//!  cargo test --release --target wasm32-unknown-unknown --no-default-features --test sift_wasm -- --nocapture`.
#![cfg(target_arch = "wasm32")]

use shapetrack::features::sift::{detect_and_compute, match_descriptors, MatchConfig, SiftConfig};
use wasm_bindgen_test::{console_log, wasm_bindgen_test};

const SCENE: &[u8] = include_bytes!("data/sift/scene.png");
const WARPED: &[u8] = include_bytes!("data/sift/warped.png");
const FIXTURE: &str = include_str!("data/sift/opencv_sift.json");

fn decode(png: &[u8]) -> image::GrayImage {
    image::load_from_memory(png).unwrap().to_luma8()
}

#[wasm_bindgen_test]
fn wasm_keypoints_match_opencv() {
    let fx: serde_json::Value = serde_json::from_str(FIXTURE).unwrap();
    let mut feats = Vec::new();
    for (name, png) in [("scene.png", SCENE), ("warped.png", WARPED)] {
        let ours = detect_and_compute(&decode(png), None, &SiftConfig::default()).unwrap();
        let cv = fx["images"][name].as_array().unwrap();
        assert_eq!(ours.len(), cv.len(), "{name}");
        // Every OpenCV keypoint has one of ours at the same place (OpenCV coordinates + 0.25).
        let paired = cv
            .iter()
            .filter(|c| {
                let (x, y) = (
                    c["x"].as_f64().unwrap() as f32 + 0.25,
                    c["y"].as_f64().unwrap() as f32 + 0.25,
                );
                ours.keypoints
                    .iter()
                    .any(|k| (k.x - x).abs() < 0.01 && (k.y - y).abs() < 0.01)
            })
            .count();
        assert!(paired as f32 >= 0.95 * cv.len() as f32, "{name}: {paired}");
        feats.push(ours);
    }
    let m = match_descriptors(&feats[0], &feats[1], &MatchConfig::default());
    let n_cv = fx["matches"].as_array().unwrap().len();
    assert!((m.len() as f32 / n_cv as f32 - 1.0).abs() <= 0.1);
}

#[wasm_bindgen_test]
fn wasm_timing() {
    let img = decode(SCENE);
    let cfg = SiftConfig::default();
    let now = || js_sys::Date::now();
    let reps = 20;
    let t = now();
    let mut n = 0;
    for _ in 0..reps {
        n = detect_and_compute(&img, None, &cfg).unwrap().len();
    }
    console_log!(
        "wasm: 160x120 detect_and_compute {:.2} ms/call ({n} keypoints)",
        (now() - t) / reps as f64
    );
}
