//! The online tracker on all eleven MOT15-train sequences (box mode, `det/det.txt`), with the
//! default configuration: the output must be well-formed, and its scores (our metrics, which
//! equal TrackEval's) must beat the peers run on the same detections.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::eval::{evaluate, EvalConfig, SequenceInput};
use shapetrack::frame::BBox;
use shapetrack::io::motchallenge::{parse_mot, SeqInfo};
use shapetrack::io::{read_text, Record};
use shapetrack::track::{detections_by_frame, to_records, track_sequence, Config};
use std::collections::HashSet;
use std::path::PathBuf;

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

fn seq_dir(seq: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/mot15-train")
        .join(seq)
}

/// Tracks one MOT15-train sequence with the default config. Returns its ground truth, its
/// detections and the tracker's results, all as records with MOTChallenge frame numbers.
fn track_mot15_sequence(seq: &str) -> (Vec<Record>, Vec<Record>, Vec<Record>) {
    let dir = seq_dir(seq);
    let info = SeqInfo::read(&dir.join("seqinfo.ini")).unwrap();
    let det_path = dir.join("det/det.txt");
    let dets = parse_mot(
        &read_text(&det_path).unwrap(),
        &det_path.display().to_string(),
    )
    .unwrap();
    let gt_path = dir.join("gt/gt.txt");
    let gt = parse_mot(
        &read_text(&gt_path).unwrap(),
        &gt_path.display().to_string(),
    )
    .unwrap();
    let frames = detections_by_frame(&dets, 1, info.seq_length);
    // As the CLI runs it: the defaults, told the video's frame rate.
    let cfg = Config {
        frame_rate: Some(info.frame_rate),
        ..Config::default()
    };
    let shapes = track_sequence(cfg, &frames).unwrap();
    let res = to_records(&shapes, 1, Some((info.im_width, info.im_height)));
    (gt, dets, res)
}

#[test]
fn default_config_output_is_well_formed_on_all_mot15_sequences() {
    let mut total_tracks = 0;
    for seq in SEQUENCES {
        let (gt, dets, res) = track_mot15_sequence(seq);
        assert!(!gt.is_empty());
        assert!(!res.is_empty(), "{seq}: no output");
        let n_frames = SeqInfo::read(&seq_dir(seq).join("seqinfo.ini"))
            .unwrap()
            .seq_length;

        // Ids are unique within each frame; frames are in range; boxes are valid.
        let mut seen: HashSet<(u32, i64)> = HashSet::new();
        for r in &res {
            assert!(
                seen.insert((r.frame, r.id)),
                "{seq}: id {} twice in frame {}",
                r.id,
                r.frame
            );
            assert!(
                (1..=n_frames).contains(&r.frame),
                "{seq}: frame {}",
                r.frame
            );
            assert!(r.id >= 1, "{seq}: id {}", r.id);
            assert!(
                r.bbox.is_valid() && r.bbox.area() > 0.0,
                "{seq}: {:?}",
                r.bbox
            );
        }

        // Every output box is one of that frame's detections — smoothed, once smoothing has
        // proved to help on this sequence (`Config::report_box`): it lags a detection that
        // jumps, so it overlaps one by IoU ≥ 0.3, and nine in ten by ≥ 0.5 — except those
        // coasted over a missed detection (marked interpolated): at most 8 frames at 30 fps
        // after a whole view and only where this tracker's gaps of that length usually close,
        // so well under a tenth of the output.
        let mut per_frame: std::collections::HashMap<u32, Vec<BBox>> = Default::default();
        for d in &dets {
            per_frame.entry(d.frame).or_default().push(d.bbox);
        }
        let coasted = res.iter().filter(|r| r.flags.interpolated).count();
        assert!(
            coasted * 10 < res.len(),
            "{seq}: {coasted} of {} coasted",
            res.len()
        );
        let (mut close, mut seen_boxes) = (0, 0);
        for r in res.iter().filter(|r| !r.flags.interpolated) {
            let best = per_frame
                .get(&r.frame)
                .into_iter()
                .flatten()
                .map(|b| b.iou(&r.bbox))
                .fold(0.0, f64::max);
            assert!(
                best >= 0.3,
                "{seq}: frame {} box {:?} is no detection's (IoU {best})",
                r.frame,
                r.bbox
            );
            seen_boxes += 1;
            close += usize::from(best >= 0.5);
        }
        assert!(
            close * 10 >= seen_boxes * 9,
            "{seq}: {close} of {seen_boxes}"
        );

        // Ids are dense from 1 (handed out at confirmation).
        let ids: HashSet<i64> = res.iter().map(|r| r.id).collect();
        let max = *ids.iter().max().unwrap();
        assert_eq!(ids.len() as i64, max, "{seq}: ids are not 1..={max}");
        total_tracks += ids.len();

        // The same input gives the same output (no hidden state, no randomness).
        let (_, _, again) = track_mot15_sequence(seq);
        assert_eq!(again, res, "{seq}: not deterministic");
    }
    // A sanity bound on fragmentation: the 11 sequences have 500 ground-truth identities;
    // a tracker that broke every track would report thousands.
    assert!(total_tracks < 2000, "{total_tracks} tracks");
}

/// Issue 3's acceptance: one global config, online, box mode, combined HOTA ≥ 36.7 (SORT scores
/// 36.640 and ByteTrack 36.566 on the same `det.txt`; ../shared/data/README.md). IDF1 and IDSW
/// must also beat SORT's (47.456, 708). Regression gate: the defaults chosen on the robustness
/// grid (issue 9) score 38.76 here (38.03 before the adaptive reported box and camera
/// following; the earlier defaults, fitted to this detector alone, scored 39.02 without frame
/// rates and lost to the peers elsewhere) and must stay ≥ 37.5.
#[test]
fn online_box_mode_beats_the_peers_on_mot15() {
    let inputs: Vec<SequenceInput> = SEQUENCES
        .iter()
        .map(|seq| {
            let n = SeqInfo::read(&seq_dir(seq).join("seqinfo.ini"))
                .unwrap()
                .seq_length;
            let (gt, _, res) = track_mot15_sequence(seq);
            SequenceInput::new(*seq, n, gt, res)
        })
        .collect();
    let results = evaluate(&inputs, &EvalConfig::for_benchmark("MOT15", false)).unwrap();
    let c = results.summary().combined;
    eprintln!(
        "MOT15 online: HOTA {:.3} IDF1 {:.3} MOTA {:.3} IDSW {}",
        c.hota, c.idf1, c.mota, c.idsw
    );
    assert!(c.hota >= 36.7, "combined HOTA {:.3} < 36.7", c.hota);
    assert!(
        c.hota >= 37.5,
        "combined HOTA {:.3} regressed below 37.5",
        c.hota
    );
    assert!(
        c.idf1 > 47.456,
        "combined IDF1 {:.3} not above SORT's",
        c.idf1
    );
    assert!(c.idsw < 708, "IDSW {} not below SORT's", c.idsw);
}
