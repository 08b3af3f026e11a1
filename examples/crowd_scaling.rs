//! What the mask tracker's appearance terms buy and cost as a frame gets crowded (issue 10):
//! the bench scenes of `shapetrack bench --modes mask` (seeds 7–9, 100 frames each) with 20
//! shapes at 640×480, and 200 shapes either on the same frame (ten times as crowded) or on
//! 2024×1518 (ten times the pixels: as crowded as the 20). Per configuration: HOTA, IDF1 and
//! ID switches of the three seeds combined (mask IoU), the tracker's time per frame (fastest
//! of three passes, frames decoded beforehand) and the 200/20 time ratio.
//!
//! ```text
//! cargo run --release --example crowd_scaling            # 200 shapes at 640×480
//! cargo run --release --example crowd_scaling -- --wide  # 200 shapes at 2024×1518
//! ```
//!
//! Rows: the mask preset (`Config::masks`); without appearance in the main association;
//! without it in re-identification; without colour anywhere; geometry only. The geometry-only
//! row is the floor of the ratio on a crowded frame: no appearance policy, however frugal,
//! scales better than no appearance at all.

use shapetrack::eval::{evaluate, EvalConfig, Preprocessing, SequenceInput, Similarity};
use shapetrack::synth::{Scene, SynthConfig, SynthFrame};
use shapetrack::track::{to_records, Config, TermConfig, Tracker};
use std::time::Instant;

const SEEDS: [u64; 3] = [7, 8, 9];

/// Passes timed per configuration and scene set; the fastest counts (the machine is shared).
const PASSES: usize = 3;

/// The bench's scene: `SynthConfig::default()` with this many shapes and frame size.
fn scene(seed: u64, shapes: u32, width: u32, height: u32) -> Vec<SynthFrame> {
    let cfg = SynthConfig {
        seed,
        frames: 100,
        shapes,
        width,
        height,
        ..SynthConfig::default()
    };
    Scene::new(cfg).expect("scene").collect()
}

struct Outcome {
    hota: f64,
    idf1: f64,
    idsw: u64,
    ms: f64,
}

fn run(config: &Config, scenes: &[Vec<SynthFrame>]) -> Outcome {
    let mut inputs = Vec::new();
    let mut fastest = f64::INFINITY;
    for pass in 0..PASSES {
        let (mut secs, mut n) = (0.0, 0usize);
        for (seed, frames) in SEEDS.iter().zip(scenes) {
            let decoded: Vec<_> = frames.iter().map(|f| f.frame().expect("frame")).collect();
            let mut tracker = Tracker::new(config.clone()).expect("config");
            let mut out = Vec::new();
            let t0 = Instant::now();
            for (f, frame) in frames.iter().zip(&decoded) {
                out.extend(tracker.update(Some(frame), &f.detections).expect("update"));
            }
            secs += t0.elapsed().as_secs_f64();
            n += frames.len();
            // The tracker is deterministic: every pass gives the same tracks.
            if pass == 0 {
                let gt = frames.iter().flat_map(|f| f.gt_records()).collect();
                let (w, h) = (frames[0].width, frames[0].height);
                inputs.push(SequenceInput::new(
                    format!("seed{seed}"),
                    frames.len() as u32,
                    gt,
                    to_records(&out, 1, Some((w, h))),
                ));
            }
        }
        fastest = fastest.min(1e3 * secs / n.max(1) as f64);
    }
    let ec = EvalConfig {
        preprocessing: Preprocessing::None,
        similarity: Similarity::MaskIou,
        threshold: 0.5,
    };
    let s = evaluate(&inputs, &ec).expect("eval").summary();
    Outcome {
        hota: s.combined.hota,
        idf1: s.combined.idf1,
        idsw: s.combined.idsw,
        ms: fastest,
    }
}

fn main() {
    let wide = std::env::args().any(|a| a == "--wide");
    let (w, h) = if wide { (2024, 1518) } else { (640, 480) };
    let few: Vec<_> = SEEDS.iter().map(|&s| scene(s, 20, 640, 480)).collect();
    let many: Vec<_> = SEEDS.iter().map(|&s| scene(s, 200, w, h)).collect();
    let full = Config::masks();
    let off = TermConfig::weighted(0.0);
    let mut no_main = full.clone();
    no_main.terms.shape_context = off;
    no_main.terms.colour = off;
    let mut no_reid = full.clone();
    no_reid.reid_terms.shape_context = off;
    no_reid.reid_terms.colour = off;
    no_reid.reid_terms.sift = off;
    let mut no_colour = full.clone();
    no_colour.terms.colour = off;
    no_colour.reid_terms.colour = off;
    let mut geometry = no_main.clone();
    geometry.reid_terms = no_reid.reid_terms.clone();
    println!(
        "| configuration | 20 @ 640x480: HOTA | IDF1 | IDSW | ms/f | 200 @ {w}x{h}: HOTA | IDF1 | IDSW | ms/f | time × |"
    );
    println!("|{}|", ["---"; 10].join("|"));
    for (name, c) in [
        ("mask preset (Config::masks)", &full),
        ("no appearance in the main association", &no_main),
        ("no appearance in re-identification", &no_reid),
        ("no colour", &no_colour),
        ("geometry only", &geometry),
    ] {
        let (a, b) = (run(c, &few), run(c, &many));
        println!(
            "| {name} | {:.2} | {:.2} | {} | {:.3} | {:.2} | {:.2} | {} | {:.3} | {:.1} |",
            a.hota,
            a.idf1,
            a.idsw,
            a.ms,
            b.hota,
            b.idf1,
            b.idsw,
            b.ms,
            b.ms / a.ms
        );
    }
}
