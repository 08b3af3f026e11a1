//! Agreement with OpenCV 4.x's SIFT on committed fixtures.
//!
//! `tests/data/sift/make_fixture.py` (run once, offline, with OpenCV 4.14) wrote two small grey
//! images and OpenCV's keypoints, descriptors and ratio-test matches for them. OpenCV
//! coordinates put pixel centres at integers and carry a quarter-pixel shift from its upsampled
//! first octave; ours put them at `i + 0.5` without the shift, so `ours = opencv + 0.25`.
//!
//! Pairing: an OpenCV keypoint is *paired* with ours when one of ours lies within 0.1 px with
//! the same octave, a size within 1 % and an angle within 1°.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use image::GrayImage;
use serde_json::Value;
use shapetrack::features::sift::{
    detect_and_compute, match_descriptors, Keypoint, MatchConfig, SiftConfig, SiftFeatures,
};
use std::path::PathBuf;

/// Converting OpenCV's coordinates to ours (see the module docs).
const SHIFT: f32 = 0.25;

struct CvKeypoint {
    kp: Keypoint,
    descriptor: [u8; 128],
}

fn data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/sift")
}

fn fixture() -> Value {
    let text = std::fs::read_to_string(data_dir().join("opencv_sift.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn load(name: &str) -> GrayImage {
    image::open(data_dir().join(name)).unwrap().to_luma8()
}

fn cv_keypoints(fx: &Value, name: &str) -> Vec<CvKeypoint> {
    let f = |v: &Value, k: &str| v[k].as_f64().unwrap() as f32;
    fx["images"][name]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| {
            let hex = v["descriptor"].as_str().unwrap();
            let descriptor =
                std::array::from_fn(|i| u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).unwrap());
            CvKeypoint {
                kp: Keypoint {
                    x: f(v, "x") + SHIFT,
                    y: f(v, "y") + SHIFT,
                    size: f(v, "size"),
                    angle: f(v, "angle"),
                    response: f(v, "response"),
                    octave: v["octave"].as_i64().unwrap() as i32,
                },
                descriptor,
            }
        })
        .collect()
}

fn angle_diff(a: f32, b: f32) -> f32 {
    ((a - b).rem_euclid(360.0)).min((b - a).rem_euclid(360.0))
}

/// Index of our keypoint paired with OpenCV's `c`, if any.
fn pair(c: &Keypoint, ours: &SiftFeatures) -> Option<usize> {
    ours.keypoints.iter().position(|k| {
        (k.x - c.x).hypot(k.y - c.y) < 0.1
            && k.octave == c.octave
            && (k.size / c.size - 1.0).abs() < 0.01
            && angle_diff(k.angle, c.angle) < 1.0
    })
}

fn l2(a: &[u8; 128], b: &[u8; 128]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(&x, &y)| (f32::from(x) - f32::from(y)).powi(2))
        .sum::<f32>()
        .sqrt()
}

/// Compares our features on `name` with OpenCV's; returns our features and, for each OpenCV
/// keypoint, the index of its pair among ours.
fn check(fx: &Value, name: &str) -> (SiftFeatures, Vec<Option<usize>>) {
    let cv = cv_keypoints(fx, name);
    let ours = detect_and_compute(&load(name), None, &SiftConfig::default()).unwrap();

    // Counts agree within 5 %.
    let (n_cv, n_ours) = (cv.len() as f32, ours.len() as f32);
    assert!(
        (n_ours / n_cv - 1.0).abs() <= 0.05,
        "{name}: {n_ours} vs OpenCV {n_cv}"
    );

    // The brief's bar: >= 80 % of OpenCV's keypoints have one of ours within 1 px and 1 octave.
    let loose = cv
        .iter()
        .filter(|c| {
            ours.keypoints.iter().any(|k| {
                (k.x - c.kp.x).hypot(k.y - c.kp.y) <= 1.0 && (k.octave - c.kp.octave).abs() <= 1
            })
        })
        .count();
    // The port's own bar: >= 95 % are paired almost exactly (0.1 px, 1 %, 1 degree).
    let pairs: Vec<Option<usize>> = cv.iter().map(|c| pair(&c.kp, &ours)).collect();
    let paired = pairs.iter().flatten().count();
    // Descriptors of paired keypoints: OpenCV's byte vectors have norm ~512.
    let mut dists: Vec<f32> = cv
        .iter()
        .zip(&pairs)
        .filter_map(|(c, p)| p.map(|i| l2(&c.descriptor, &ours.descriptors[i])))
        .collect();
    dists.sort_by(f32::total_cmp);
    let median = dists[dists.len() / 2];
    let p95 = dists[(dists.len() * 95 / 100).min(dists.len() - 1)];
    eprintln!(
        "{name}: OpenCV {n_cv} keypoints, ours {n_ours}; within 1 px & 1 octave {loose}; \
         paired exactly {paired}; descriptor L2 median {median:.2}, p95 {p95:.2}"
    );
    assert!(loose as f32 >= 0.8 * n_cv, "{name}: {loose}/{n_cv} near");
    assert!(
        paired as f32 >= 0.95 * n_cv,
        "{name}: {paired}/{n_cv} paired"
    );
    assert!(
        median <= 2.0 && p95 <= 10.0,
        "{name}: median {median}, p95 {p95}"
    );
    (ours, pairs)
}

#[test]
fn keypoints_and_descriptors_match_opencv() {
    let fx = fixture();
    assert!(fx["opencv_version"].as_str().unwrap().starts_with("4."));
    check(&fx, "scene.png");
    check(&fx, "warped.png");
}

#[test]
fn ratio_test_matches_match_opencv() {
    let fx = fixture();
    let (a, pa) = check(&fx, "scene.png");
    let (b, pb) = check(&fx, "warped.png");
    let ours = match_descriptors(&a, &b, &MatchConfig::default());
    let cv: Vec<(usize, usize)> = fx["matches"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| {
            (
                m["query"].as_u64().unwrap() as usize,
                m["train"].as_u64().unwrap() as usize,
            )
        })
        .collect();
    // An OpenCV match is reproduced when both its keypoints are paired with ours and we match
    // those two.
    let reproduced = cv
        .iter()
        .filter(|&&(q, t)| match (pa[q], pb[t]) {
            (Some(i), Some(j)) => ours.iter().any(|m| m.query == i && m.train == j),
            _ => false,
        })
        .count();
    eprintln!(
        "matches: OpenCV {}, ours {}, OpenCV's reproduced {reproduced}",
        cv.len(),
        ours.len()
    );
    assert!(reproduced as f32 >= 0.9 * cv.len() as f32);
    assert!((ours.len() as f32 / cv.len() as f32 - 1.0).abs() <= 0.1);
}
