//! The quality gate (STYLE item 9): the tracker's scores on real and synthetic data, online and
//! offline, recomputed and compared with the committed baseline
//! `tests/data/quality/baseline.json`. A change that lowers any HOTA, IDF1 or MOTA (beyond
//! [`TOLERANCE`]) or raises any IDSW fails here.
//!
//! - **MOT15-train**, all 11 sequences combined, box mode (`det/det.txt`, the detections the
//!   peers were run on), default configs, fps and image size from `seqinfo.ini`, scored with
//!   our metrics (equal to TrackEval's): HOTA, IDF1, IDSW, MOTA, online and offline.
//! - **Synthetic occlusion scenes**, seeds 1–5 (the offline defaults were chosen on other seeds):
//!   [`occlusion_scene`], mask detections with frames (appearance snapshots on), scored with box
//!   IoU against the visible-part boxes: HOTA, IDF1, IDSW per seed, online and offline, with
//!   the default config and with the mask preset (`Config::masks`).
//!
//! Independently of the baseline, the issue's acceptance bars are asserted: offline MOT15
//! HOTA ≥ 39.0, IDF1 ≥ 52.0, IDSW ≤ 400, and better than online on HOTA, IDF1 and IDSW; on
//! every synthetic seed offline cuts IDSW by at least 30 % and never lowers HOTA.
//!
//! **Updating the baseline deliberately**: when a change is meant to move the scores (a better
//! tracker, a fixed metric), run
//!
//! ```text
//! REGENERATE=1 cargo test --test quality_gate
//! ```
//!
//! which rewrites `tests/data/quality/baseline.json` with the current scores (the test still
//! checks the acceptance bars), then review the diff and commit it with the change, saying in
//! the commit message why the scores moved.

use serde::{Deserialize, Serialize};
use shapetrack::eval::{evaluate, EvalConfig, Preprocessing, SequenceInput, Similarity};
use shapetrack::io::motchallenge::{parse_mot, SeqInfo};
use shapetrack::io::{read_text, Record};
use shapetrack::synth::{OccluderRect, Scene, SynthConfig};
use shapetrack::track::offline::{track_offline, OfflineConfig, OfflineTracker, SequenceInfo};
use shapetrack::track::{detections_by_frame, to_records, track_sequence, Config, Tracker};
use shapetrack::TrackedShape;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// Scores may differ from the baseline by this much (percentage points) before the gate
/// fails: room for floating-point reassociation, nothing a real change hides in.
const TOLERANCE: f64 = 1e-6;

const SEQUENCES: [&str; 11] = [
    "ADL-Rundle-6",
    "ADL-Rundle-8",
    "ETH-Bahnhof",
    "ETH-Pedcross2",
    "ETH-Sunnyday",
    "KITTI-13",
    "KITTI-17",
    "PETS09-S2L1",
    "TUD-Campus",
    "TUD-Stadtmitte",
    "Venice-2",
];

/// Synthetic seeds of the gate (the offline defaults were tuned on seeds 11–13).
const SYNTH_SEEDS: [u64; 5] = [1, 2, 3, 4, 5];

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
struct Scores {
    hota: f64,
    idf1: f64,
    idsw: u64,
    /// Absent for the synthetic scenes (the gate tracks HOTA, IDF1, IDSW there).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    mota: Option<f64>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Pair {
    online: Scores,
    offline: Scores,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Baseline {
    /// How the file was made and how to update it.
    about: String,
    /// MOT15-train, 11 sequences combined, box mode.
    mot15: Pair,
    /// Synthetic occlusion scenes by seed, default config (the box-mode defaults, tracking
    /// the mask detections).
    synthetic: BTreeMap<String, Pair>,
    /// The same scenes with the mask preset ([`Config::masks`]) as the online pass (and the
    /// offline one's online part): what `shapetrack track` and the web app use for masks.
    synthetic_masks: BTreeMap<String, Pair>,
}

fn baseline_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/quality/baseline.json")
}

fn scores(inputs: &[SequenceInput], eval: &EvalConfig, with_mota: bool) -> Scores {
    let c = evaluate(inputs, eval).unwrap().summary().combined;
    Scores {
        hota: c.hota,
        idf1: c.idf1,
        idsw: c.idsw,
        mota: with_mota.then_some(c.mota),
    }
}

/// MOT15-train combined, online and offline, default configs.
fn mot15() -> Pair {
    let mut online = Vec::new();
    let mut offline = Vec::new();
    for seq in SEQUENCES {
        let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../shared/data/mot15-train")
            .join(seq);
        let info = SeqInfo::read(&dir.join("seqinfo.ini")).unwrap();
        let read = |rel: &str| {
            let p = dir.join(rel);
            parse_mot(&read_text(&p).unwrap(), &p.display().to_string()).unwrap()
        };
        let (dets, gt) = (read("det/det.txt"), read("gt/gt.txt"));
        let frames = detections_by_frame(&dets, 1, info.seq_length);
        let size = Some((info.im_width, info.im_height));
        let on = track_sequence(Config::default(), &frames).unwrap();
        let sinfo =
            SequenceInfo::new(info.frame_rate).with_image_size(info.im_width, info.im_height);
        let off = track_offline(&OfflineConfig::default(), &sinfo, &frames, |_| {}).unwrap();
        let n = info.seq_length;
        online.push(SequenceInput::new(
            seq,
            n,
            gt.clone(),
            to_records(&on, 1, size),
        ));
        offline.push(SequenceInput::new(
            seq,
            n,
            gt,
            to_records(&off.shapes, 1, size),
        ));
    }
    let eval = EvalConfig::for_benchmark("MOT15", false);
    Pair {
        online: scores(&online, &eval, true),
        offline: scores(&offline, &eval, true),
    }
}

/// The occlusion preset widened so objects stay hidden for up to ~30 frames: an 800-px-wide
/// frame, two bars sized for 20-frame hides (120 px) and a 60-px pillar near the right edge
/// for short ones, plus the preset's crossings and 5 % missed detections.
fn occlusion_scene(seed: u64) -> SynthConfig {
    let mut c = SynthConfig::occlusion_scene(seed);
    c.width = 800;
    c.occlusion.hidden_frames = 20.0;
    c.occlusion.rects = vec![OccluderRect {
        x: 700,
        y: 0,
        w: 60,
        h: c.height,
    }];
    c
}

/// Online and offline on one synthetic scene; also returns the lengths of the ground truth's
/// full hides (runs of frames an object is absent between two appearances, 2 frames or more).
fn synthetic(seed: u64, config: Config) -> (Pair, Vec<u32>) {
    let cfg = occlusion_scene(seed);
    let (w, h, n, fps) = (cfg.width, cfg.height, cfg.frames, cfg.fps);
    let mut scene = Scene::new(cfg).unwrap();
    let mut online = Tracker::new(config.clone()).unwrap();
    let offline_config = OfflineConfig {
        online: config,
        ..OfflineConfig::default()
    };
    let mut offline = OfflineTracker::new(offline_config, fps).unwrap();
    let mut on_shapes: Vec<TrackedShape> = Vec::new();
    let mut gt: Vec<Record> = Vec::new();
    let mut seen: BTreeMap<u64, Vec<u32>> = BTreeMap::new();
    while let Some(f) = scene.frame() {
        for g in &f.gt {
            seen.entry(g.id).or_default().push(f.index);
        }
        gt.extend(
            f.gt_records()
                .into_iter()
                .map(|r| Record { mask: None, ..r }),
        );
        let frame = f.frame().unwrap();
        on_shapes.extend(online.update(Some(&frame), &f.detections).unwrap());
        offline.push_frame(Some(&frame), &f.detections).unwrap();
    }
    let off = offline.finish(|_| {}).unwrap();
    let hides = seen
        .values()
        .flat_map(|fr| fr.windows(2).map(|p| p[1] - p[0] - 1).collect::<Vec<_>>())
        .filter(|&k| k >= 2)
        .collect();
    let eval = EvalConfig {
        preprocessing: Preprocessing::None,
        similarity: Similarity::BoxIou,
        threshold: 0.5,
    };
    let score = |shapes: &[TrackedShape]| {
        let boxes: Vec<TrackedShape> = shapes
            .iter()
            .map(|s| TrackedShape {
                mask: None,
                ..s.clone()
            })
            .collect();
        let res = to_records(&boxes, 1, Some((w, h)));
        scores(
            &[SequenceInput::new("synthetic", n, gt.clone(), res)],
            &eval,
            false,
        )
    };
    (
        Pair {
            online: score(&on_shapes),
            offline: score(&off.shapes),
        },
        hides,
    )
}

fn row(name: &str, s: &Scores) -> String {
    let mota = s.mota.map_or(String::new(), |m| format!(" MOTA {m:.3}"));
    format!(
        "{name:28} HOTA {:.3} IDF1 {:.3} IDSW {}{mota}",
        s.hota, s.idf1, s.idsw
    )
}

/// Every way `now` is worse than `base`.
fn regressions(name: &str, now: &Scores, base: &Scores) -> Vec<String> {
    let mut out = Vec::new();
    let mut lower = |metric: &str, n: f64, b: f64| {
        if n < b - TOLERANCE {
            out.push(format!("{name}: {metric} fell from {b:.4} to {n:.4}"));
        }
    };
    lower("HOTA", now.hota, base.hota);
    lower("IDF1", now.idf1, base.idf1);
    if let (Some(n), Some(b)) = (now.mota, base.mota) {
        lower("MOTA", n, b);
    }
    if now.idsw > base.idsw {
        out.push(format!(
            "{name}: IDSW rose from {} to {}",
            base.idsw, now.idsw
        ));
    }
    out
}

#[test]
fn quality_gate() {
    let mot = mot15();
    let mut synth = BTreeMap::new();
    let mut synth_masks = BTreeMap::new();
    let mut all_hides = Vec::new();
    for seed in SYNTH_SEEDS {
        let (pair, hides) = synthetic(seed, Config::default());
        all_hides.extend(hides);
        synth.insert(format!("seed{seed}"), pair);
        synth_masks.insert(format!("seed{seed}"), synthetic(seed, Config::masks()).0);
    }
    let current = Baseline {
        about: "Scores recomputed by tests/quality_gate.rs; regenerate deliberately with \
                `REGENERATE=1 cargo test --test quality_gate` (see that file)."
            .to_string(),
        mot15: mot.clone(),
        synthetic: synth.clone(),
        synthetic_masks: synth_masks.clone(),
    };
    eprintln!("{}", row("MOT15 online", &mot.online));
    eprintln!("{}", row("MOT15 offline", &mot.offline));
    for (k, p) in &synth {
        eprintln!("{}", row(&format!("synthetic {k} online"), &p.online));
        eprintln!("{}", row(&format!("synthetic {k} offline"), &p.offline));
    }
    for (k, p) in &synth_masks {
        eprintln!("{}", row(&format!("synthetic {k} masks online"), &p.online));
        eprintln!(
            "{}",
            row(&format!("synthetic {k} masks offline"), &p.offline)
        );
    }

    // The scene really hides objects for 5 to about 30 frames.
    all_hides.sort_unstable();
    let long = all_hides.iter().filter(|&&k| k >= 20).count();
    let mid = all_hides.iter().filter(|&&k| (5..20).contains(&k)).count();
    eprintln!(
        "synthetic full hides: {} (5–19 frames: {mid}, ≥ 20: {long}, longest {:?})",
        all_hides.len(),
        all_hides.last()
    );
    assert!(mid >= 20 && long >= 20, "hides: {all_hides:?}");
    assert!(all_hides.iter().any(|&k| k >= 28));

    // Issue 5's acceptance bars.
    let (on, off) = (&mot.online, &mot.offline);
    assert!(
        off.hota >= 39.0 && off.idf1 >= 52.0 && off.idsw <= 400,
        "{off:?}"
    );
    assert!(
        off.hota > on.hota && off.idf1 > on.idf1 && off.idsw < on.idsw,
        "{off:?} vs {on:?}"
    );
    for (k, p) in &synth {
        assert!(
            p.offline.hota >= p.online.hota,
            "{k}: offline HOTA {} < online {}",
            p.offline.hota,
            p.online.hota
        );
        assert!(
            (p.offline.idsw as f64) <= 0.7 * p.online.idsw as f64,
            "{k}: offline IDSW {} is not 30 % below online {}",
            p.offline.idsw,
            p.online.idsw
        );
    }

    // The mask preset is what masks are tracked with: it must beat the box-mode defaults on
    // mask detections, online, and the re-linker must not add identity switches to it (its
    // online pass already re-identifies by appearance, so there is little left to join).
    for (k, p) in &synth_masks {
        let d = &synth[k];
        assert!(
            p.online.hota > d.online.hota + 20.0 && p.online.idf1 > d.online.idf1 + 20.0,
            "{k}: mask preset {:?} not far above the defaults {:?}",
            p.online,
            d.online
        );
        assert!(p.offline.idsw <= p.online.idsw, "{k}: {p:?}");
        // Gaps between partial views (hides) are not filled (`fill.hidden_ratio`), so the
        // offline pass adds no shapes nobody can see; what it does fill (missed detections)
        // leaves HOTA within a hair of online at worst (seed 2: −0.014 when it was added).
        assert!(p.offline.hota >= p.online.hota - 0.05, "{k}: {p:?}");
    }

    if std::env::var_os("REGENERATE").is_some() {
        let text = serde_json::to_string_pretty(&current).unwrap() + "\n";
        std::fs::write(baseline_path(), text).unwrap();
        eprintln!("baseline rewritten: {}", baseline_path().display());
        return;
    }
    let base: Baseline = serde_json::from_str(
        &read_text(&baseline_path()).expect("baseline missing: run with REGENERATE=1"),
    )
    .unwrap();
    let mut bad = Vec::new();
    bad.extend(regressions("MOT15 online", &mot.online, &base.mot15.online));
    bad.extend(regressions(
        "MOT15 offline",
        &mot.offline,
        &base.mot15.offline,
    ));
    for (k, b) in &base.synthetic {
        let now = synth
            .get(k)
            .unwrap_or_else(|| panic!("baseline has {k}, the gate does not"));
        bad.extend(regressions(
            &format!("synthetic {k} online"),
            &now.online,
            &b.online,
        ));
        bad.extend(regressions(
            &format!("synthetic {k} offline"),
            &now.offline,
            &b.offline,
        ));
    }
    for (k, b) in &base.synthetic_masks {
        let now = synth_masks
            .get(k)
            .unwrap_or_else(|| panic!("baseline has masks {k}, the gate does not"));
        bad.extend(regressions(
            &format!("synthetic {k} masks online"),
            &now.online,
            &b.online,
        ));
        bad.extend(regressions(
            &format!("synthetic {k} masks offline"),
            &now.offline,
            &b.offline,
        ));
    }
    assert!(
        bad.is_empty(),
        "quality regressions against tests/data/quality/baseline.json:\n  {}\n\
         (if intended, regenerate with REGENERATE=1 cargo test --test quality_gate)",
        bad.join("\n  ")
    );
    if current != base {
        eprintln!(
            "scores improved on the baseline; consider REGENERATE=1 cargo test --test quality_gate"
        );
    }
}
