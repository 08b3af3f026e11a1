//! Which tracker settings the browser app uses with its default detector: the synthetic demo
//! scene (`SynthConfig::demo()`, what `npm start` shows) and the occlusion scene, detected by the
//! adaptive background subtractor (as in the app), tracked online with the box-mode defaults and
//! with the mask preset, each with the background detector's score thresholds (its score is a
//! contrast, see `www/src/worker/detectors.js`). Scored with our metrics on mask IoU against the
//! visible-part ground truth.
//!
//! ```text
//! cargo run --release --example demo_presets
//! ```

use shapetrack::detect::{BackgroundConfig, BackgroundSubtractor, Detector};
use shapetrack::eval::{evaluate, EvalConfig, Preprocessing, SequenceInput, Similarity};
use shapetrack::synth::{Scene, SynthConfig};
use shapetrack::track::offline::{OfflineConfig, OfflineTracker};
use shapetrack::track::{to_records, Config, Tracker};
use std::time::Instant;

/// The background detector's thresholds in the app.
fn with_background_scores(c: Config) -> Config {
    Config {
        high_score: 0.25,
        new_track_score: 0.5,
        ..c
    }
}

fn main() {
    let scenes = [
        ("demo", SynthConfig::demo()),
        ("occlusion seed 0", SynthConfig::occlusion_scene(0)),
        ("occlusion seed 1", SynthConfig::occlusion_scene(1)),
        ("occlusion seed 2", SynthConfig::occlusion_scene(2)),
    ];
    let configs = [
        ("defaults", with_background_scores(Config::default())),
        ("mask preset", with_background_scores(Config::masks())),
    ];
    println!(
        "{:18} {:17} {:>7} {:>7} {:>5} {:>7} {:>6} {:>9}",
        "scene", "config", "HOTA", "IDF1", "IDSW", "MOTA", "ids", "ms/frame"
    );
    for (scene_name, sc) in &scenes {
        let (w, h, n) = (sc.width, sc.height, sc.frames);
        // Detect once; both configs track the same detections.
        let mut bs = BackgroundSubtractor::new(BackgroundConfig::default()).unwrap();
        let mut frames = Vec::new();
        let mut gt = Vec::new();
        for f in Scene::new(sc.clone()).unwrap() {
            gt.extend(f.gt_records());
            let frame = f.frame().unwrap();
            let dets = bs.detect(&frame).unwrap();
            frames.push((f, dets));
        }
        for (config_name, config) in &configs {
            for offline in [false, true] {
                let mut tracker = Tracker::new(config.clone()).unwrap();
                let oc = OfflineConfig {
                    online: config.clone(),
                    ..OfflineConfig::default()
                };
                let mut off = OfflineTracker::new(oc, sc.fps).unwrap();
                let mut out = Vec::new();
                let t0 = Instant::now();
                for (f, dets) in &frames {
                    let frame = f.frame().unwrap();
                    if offline {
                        off.push_frame(Some(&frame), dets).unwrap();
                    } else {
                        out.extend(tracker.update(Some(&frame), dets).unwrap());
                    }
                }
                if offline {
                    out = off.finish(|_| {}).unwrap().shapes;
                }
                let ms = t0.elapsed().as_secs_f64() * 1e3 / n as f64;
                let config_name = format!("{config_name}{}", if offline { " +off" } else { "" });
                let res = to_records(&out, 1, Some((w, h)));
                let ec = EvalConfig {
                    preprocessing: Preprocessing::None,
                    similarity: Similarity::MaskIou,
                    threshold: 0.5,
                };
                let input = SequenceInput::new(scene_name.to_string(), n, gt.clone(), res);
                let c = evaluate(&[input], &ec).unwrap().summary().combined;
                println!(
                    "{:18} {:17} {:7.3} {:7.3} {:5} {:7.3} {:6} {:9.2}",
                    scene_name, config_name, c.hota, c.idf1, c.idsw, c.mota, c.ids, ms
                );
            }
        }
    }
}
