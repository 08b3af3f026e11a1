//! Ablation of the mask tracker's cost terms on the synthetic occlusion scenes of
//! `tests/track_synth.rs` (10 shapes, 300 frames, crossings, ~10-frame occlusions behind two
//! bars, 5% missed detections; seeds 1–3), scored with our metrics on mask IoU.
//!
//! ```text
//! cargo run --release --example ablation            # the term ablation
//! cargo run --release --example ablation -- --all   # plus variants (Alg. 5, the thesis'
//!                                                   # Canny shell, eager appearance,
//!                                                   # colour sample sizes)
//! ```
//!
//! Rows:
//! - geometry only: box IoU, IoA and mask IoU with the (amodal) prediction; lost tracks
//!   re-identified by motion (IoA inside the predicted box) alone;
//! - + shape context: C1 (Alg. 4) joins the main association in ambiguous clusters;
//! - + colour: C2 (Alg. 6) too, and re-identification checks colour;
//! - + SIFT: re-identification also matches SIFT keypoints (the mask preset, `Config::masks`).
//!
//! Per row: HOTA, IDF1, IDSW and MOTA of the three seeds combined, the worst seed's HOTA and
//! IDF1, the appearance descriptions per detection and the tracker's time per frame.

use shapetrack::eval::{evaluate, EvalConfig, Preprocessing, SequenceInput, Similarity};
use shapetrack::synth::{Scene, SynthConfig, SynthFrame};
use shapetrack::track::{
    to_records, Appearance, Config, FeatureExtractor, Features, MaskFeatures, ShapeVariant,
    ShellMode, TermConfig, Tracker,
};
use shapetrack::{Detection, Frame};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Instant;

const SEEDS: [u64; 3] = [1, 2, 3];

/// The scene of `tests/track_synth.rs`.
fn scene(seed: u64) -> Vec<SynthFrame> {
    let cfg = SynthConfig {
        shapes: 10,
        frames: 300,
        ..SynthConfig::occlusion_scene(seed)
    };
    Scene::new(cfg).expect("scene").collect()
}

/// Counts appearance descriptions.
struct Counting(MaskFeatures, Arc<AtomicUsize>);

impl FeatureExtractor for Counting {
    fn extract(&self, f: Option<&Frame<'_>>, d: &Detection) -> Result<Features, String> {
        self.0.extract(f, d)
    }
    fn describe(&self, f: &Frame<'_>, d: &Detection, n: u32) -> Result<Option<Appearance>, String> {
        self.1.fetch_add(1, Ordering::Relaxed);
        self.0.describe(f, d, n)
    }
}

struct Outcome {
    hota: f64,
    idf1: f64,
    idsw: u64,
    mota: f64,
    worst_hota: f64,
    worst_idf1: f64,
    described: f64,
    ms: f64,
}

fn run(config: &Config, scenes: &[Vec<SynthFrame>]) -> Outcome {
    let mut inputs = Vec::new();
    let (mut dets, mut described, mut secs) = (0usize, 0usize, 0.0);
    for (seed, frames) in SEEDS.iter().zip(scenes) {
        let count = Arc::new(AtomicUsize::new(0));
        // The extractor the tracker would build itself, counting its descriptions.
        let fx = Counting(
            MaskFeatures::new(config.appearance.clone(), config.appearance_needs()),
            count.clone(),
        );
        let mut tracker = Tracker::new(config.clone())
            .expect("config")
            .with_extractor(Box::new(fx));
        let (mut gt, mut out) = (Vec::new(), Vec::new());
        let t0 = Instant::now();
        for f in frames {
            gt.extend(f.gt_records());
            dets += f.detections.len();
            let frame = f.frame().expect("frame");
            out.extend(tracker.update(Some(&frame), &f.detections).expect("update"));
        }
        secs += t0.elapsed().as_secs_f64();
        described += count.load(Ordering::Relaxed);
        let (w, h) = (frames[0].width, frames[0].height);
        let res = to_records(&out, 1, Some((w, h)));
        inputs.push(SequenceInput::new(
            format!("seed{seed}"),
            frames.len() as u32,
            gt,
            res,
        ));
    }
    let ec = EvalConfig {
        preprocessing: Preprocessing::None,
        similarity: Similarity::MaskIou,
        threshold: 0.5,
    };
    let s = evaluate(&inputs, &ec).expect("eval").summary();
    let n_frames: usize = scenes.iter().map(Vec::len).sum();
    Outcome {
        hota: s.combined.hota,
        idf1: s.combined.idf1,
        idsw: s.combined.idsw,
        mota: s.combined.mota,
        worst_hota: s
            .sequences
            .values()
            .map(|r| r.hota)
            .fold(f64::MAX, f64::min),
        worst_idf1: s
            .sequences
            .values()
            .map(|r| r.idf1)
            .fold(f64::MAX, f64::min),
        described: described as f64 / dets.max(1) as f64,
        ms: 1e3 * secs / n_frames as f64,
    }
}

fn row(name: &str, o: &Outcome) {
    println!(
        "| {name:<34} | {:>6.2} | {:>6.2} | {:>4} | {:>6.2} | {:>6.2} | {:>6.2} | {:>5.2} | {:>6.2} |",
        o.hota, o.idf1, o.idsw, o.mota, o.worst_hota, o.worst_idf1, o.described, o.ms
    );
}

fn main() {
    let all = std::env::args().any(|a| a == "--all");
    let scenes: Vec<Vec<SynthFrame>> = SEEDS.iter().map(|&s| scene(s)).collect();
    println!(
        "| {:<34} | {:>6} | {:>6} | {:>4} | {:>6} | {:>6} | {:>6} | {:>5} | {:>6} |",
        "configuration (seeds 1-3)",
        "HOTA",
        "IDF1",
        "IDSW",
        "MOTA",
        "HOTA↓",
        "IDF1↓",
        "desc",
        "ms/f"
    );
    println!("|{}|", ["---"; 9].join("|"));
    let full = Config::masks();
    let off = TermConfig::weighted(0.0);
    let mut geometry = full.clone();
    geometry.terms.shape_context = off;
    geometry.terms.colour = off;
    geometry.reid_terms.shape_context = off;
    geometry.reid_terms.colour = off;
    geometry.reid_terms.sift = off;
    let mut shape = geometry.clone();
    shape.terms.shape_context = full.terms.shape_context;
    let mut colour = shape.clone();
    colour.terms.colour = full.terms.colour;
    colour.reid_terms.colour = full.reid_terms.colour;
    let sift = full.clone();
    for (name, c) in [
        ("geometry only", &geometry),
        ("+ shape context (C1)", &shape),
        ("+ colour (C2)", &colour),
        ("+ SIFT (= Config::masks)", &sift),
    ] {
        row(name, &run(c, &scenes));
    }
    if !all {
        return;
    }
    let mut alg5 = full.clone();
    alg5.shape_variant = ShapeVariant::Sift;
    row("masks, C1 by Alg. 5 (SIFT fit)", &run(&alg5, &scenes));
    for side in [64u32, 128] {
        let mut canny = full.clone();
        canny.appearance.shell = ShellMode::Canny { max_side: side };
        row(
            &format!("masks, thesis Canny shell ≤ {side} px"),
            &run(&canny, &scenes),
        );
    }
    let mut eager = full.clone();
    eager.appearance.lazy = false;
    row("masks, appearance for every det", &run(&eager, &scenes));
    for n in [50usize, 100, 200, 600, 1500] {
        let mut c = full.clone();
        c.appearance.colour.max_samples = n;
        row(&format!("masks, colour samples ≤ {n}"), &run(&c, &scenes));
    }
}
