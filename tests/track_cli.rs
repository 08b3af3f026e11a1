//! `shapetrack track` end to end: box mode on a MOT15 sequence, mask mode with real frames
//! (DAVIS car-shadow, MOTS in and out, 0-based frames), and the flags' error paths; and hostile
//! or careless input: sizes and frame numbers a few bytes can declare, outputs that would
//! destroy inputs, missing frames, masks of the wrong size; memory that stays flat over a long
//! video (the online output streams).
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::frame::Mask;
use shapetrack::io::motchallenge::{parse_mot, parse_mots, write_mots};
use shapetrack::io::{read_text, Record, RecordFlags, Rle};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

fn data(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data")
        .join(rel)
}

fn scratch(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn track(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_shapetrack"))
        .arg("track")
        .args(args)
        .output()
        .unwrap()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn box_mode_on_a_mot15_sequence() {
    let dir = scratch("cli_box");
    let out = dir.join("TUD-Campus.txt");
    let det = data("mot15-train/TUD-Campus/det/det.txt");
    let o = track(&["--det", s(&det), "--out", s(&out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let summary = String::from_utf8_lossy(&o.stdout);
    // seqinfo.ini two levels above det.txt gave the frame count and fps.
    assert!(
        summary.contains("frames=71") && summary.contains("fps 25"),
        "{summary}"
    );
    let res = parse_mot(&read_text(&out).unwrap(), "out").unwrap();
    assert!(res.len() > 100);
    assert!(res.iter().all(|r| (1..=71).contains(&r.frame) && r.id >= 1));

    // A config file changes the behaviour: min_hits = 1000 confirms nothing.
    let cfg = dir.join("config.json");
    std::fs::write(&cfg, r#"{"min_hits": 1000}"#).unwrap();
    let out2 = dir.join("none.txt");
    let o = track(&["--det", s(&det), "--out", s(&out2), "--config", s(&cfg)]);
    assert!(o.status.success());
    assert!(read_text(&out2).unwrap().is_empty());
    // A config file may name its preset, as the browser's settings objects do.
    std::fs::write(&cfg, r#"{"preset": "masks", "min_hits": 1000}"#).unwrap();
    let o = track(&["--det", s(&det), "--out", s(&out2), "--config", s(&cfg)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(read_text(&out2).unwrap().is_empty());
}

#[test]
fn flag_errors_are_reported_not_panicked() {
    let dir = scratch("cli_errors");
    let det = data("mot15-train/TUD-Campus/det/det.txt");
    let out = dir.join("x.txt");
    // The offline pass exists now (tests/offline_cli.rs); its config is checked like --config.
    let bad_offline = dir.join("bad_offline.json");
    std::fs::write(&bad_offline, r#"{"relink": {"max_slave": 3}}"#).unwrap();
    let o = track(&[
        "--det",
        s(&det),
        "--out",
        s(&out),
        "--offline",
        "--offline-config",
        s(&bad_offline),
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("max_slave"));

    let cfg = dir.join("bad.json");
    std::fs::write(&cfg, r#"{"max_lots": 3}"#).unwrap();
    let o = track(&["--det", s(&det), "--out", s(&out), "--config", s(&cfg)]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("max_lots"));
    // The same settings objects as the browser's: a "preset" field, errors naming the field.
    for (text, field) in [
        (r#"{"preset": "mask"}"#, "preset"),
        (
            r#"{"terms": {"iou": {"weight": "heavy"}}}"#,
            "terms.iou.weight",
        ),
    ] {
        std::fs::write(&cfg, text).unwrap();
        let o = track(&["--det", s(&det), "--out", s(&out), "--config", s(&cfg)]);
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(field), "{text}: {err}");
    }

    let bad = dir.join("bad_det.txt");
    std::fs::write(&bad, "1,-1,0,0,nan,10,0.9\n").unwrap();
    let o = track(&["--det", s(&bad), "--out", s(&out)]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("bad_det.txt:1:5"));

    let o = track(&["--det", s(&dir.join("missing.txt")), "--out", s(&out)]);
    assert!(!o.status.success());
}

#[test]
fn mask_mode_with_frames_reads_and_writes_mots() {
    let dir = scratch("cli_mots");
    let ann = data("davis-car-shadow/DAVIS/Annotations/480p/car-shadow");
    let jpg = data("davis-car-shadow/DAVIS/JPEGImages/480p/car-shadow");
    let mut pngs: Vec<PathBuf> = std::fs::read_dir(&ann)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    pngs.sort();
    let pngs = &pngs[..12];
    // MOTS detections from the ground-truth masks, numbered from 0 as KITTI-MOTS does.
    let mut recs = Vec::new();
    for (k, p) in pngs.iter().enumerate() {
        let img = image::open(p).unwrap().to_luma8();
        let (w, h) = img.dimensions();
        let m = Mask::from_full(w, h, img.as_raw()).unwrap();
        recs.push(Record {
            frame: k as u32,
            id: 1,
            bbox: m.bbox(),
            score: 1.0,
            class: 1,
            visibility: -1.0,
            mask: Some(Rle::from_mask(&m, w, h)),
            flags: RecordFlags::default(),
        });
    }
    let det = dir.join("masks.txt");
    std::fs::write(&det, write_mots(&recs)).unwrap();
    let out = dir.join("result.txt");
    let o = track(&[
        "--det",
        s(&det),
        "--frames",
        s(&jpg),
        "--out",
        s(&out),
        "--format",
        "mots",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("mask mode"));
    let res = parse_mots(&read_text(&out).unwrap(), "out").unwrap();
    // One car, one id, every frame (the tentative frames are reported once it is confirmed),
    // frames numbered as in the input, masks written back unchanged.
    assert_eq!(res.len(), 12);
    for (r, d) in res.iter().zip(&recs) {
        assert_eq!((r.frame, r.id, r.class), (d.frame, 1, 1));
        assert_eq!(r.mask, d.mask);
    }
}

#[test]
fn scalabel_detections_in_scalabel_tracks_out() {
    use shapetrack::io::scalabel::{parse_scalabel, to_records, Categories, IdMap};
    let dir = scratch("cli_scalabel");
    let out = dir.join("tracks.json");
    let det = data("bdd100k-sample/box_track/track_predictions.json");
    // Boxes as detected (the default reports them smoothed once smoothing has proved to
    // help), so each output box can be found among the detections below.
    let cfg = dir.join("exact.json");
    std::fs::write(&cfg, r#"{"report_box": "detection"}"#).unwrap();
    let o = track(&[
        "--det",
        s(&det),
        "--fps",
        "5",
        "--format",
        "scalabel",
        "--config",
        s(&cfg),
        "--out",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let frames = parse_scalabel(&read_text(&out).unwrap(), "tracks.json").unwrap();
    assert_eq!(frames.len(), 202);
    assert!(frames
        .iter()
        .all(|f| f.video_name.as_deref() == Some("b1c66a42-6f7d68ca")));
    let mut ids = IdMap::default();
    let recs = to_records(&frames, &mut ids, &mut Categories::default(), false);
    // Every output box is one of the detections (ids given by the tracker), categories kept.
    let dets = parse_scalabel(&read_text(&det).unwrap(), "det").unwrap();
    let boxes: Vec<_> = dets
        .iter()
        .flat_map(|f| &f.labels)
        .filter_map(|l| l.bbox)
        .collect();
    assert!(recs.len() > 1000 && ids.len() > 20);
    // Boxes coasted over a missed detection keep their flag through Scalabel.
    assert!(recs.iter().any(|r| r.flags.interpolated));
    for r in recs.iter().filter(|r| !r.flags.interpolated).take(200) {
        assert!(boxes
            .iter()
            .any(|b| (b.x - r.bbox.x).abs() < 1e-6 && (b.w - r.bbox.w).abs() < 1e-6));
    }
    assert!(frames
        .iter()
        .flat_map(|f| &f.labels)
        .all(|l| l.category.is_some() && l.score.is_some()));

    // Two videos in one file: the tracker asks which one.
    let two = dir.join("two.json");
    std::fs::write(
        &two,
        r#"[{"frameIndex": 0, "videoName": "a", "labels": [{"id": "1", "score": 0.9,
             "box2d": {"x1": 0, "y1": 0, "x2": 9, "y2": 9}}]},
            {"frameIndex": 0, "videoName": "b", "labels": []}]"#,
    )
    .unwrap();
    let o = track(&["--det", s(&two), "--out", s(&dir.join("x.txt"))]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--video"));
    let o = track(&[
        "--det",
        s(&two),
        "--video",
        "a",
        "--out",
        s(&dir.join("x.txt")),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let bad = dir.join("bad.json");
    std::fs::write(&bad, "[{\"labels\": []}]").unwrap();
    let o = track(&["--det", s(&bad), "--out", s(&dir.join("y.txt"))]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("frameIndex"));
}

// ---------------------------------------------------------------------------------------------
// Hostile and careless input

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `n` frames of `k` boxes walking right, MOTChallenge det.txt.
fn walking_boxes(frames: u32, k: u32) -> String {
    let mut t = String::new();
    for f in 1..=frames {
        for j in 0..k {
            let x = (f % 500) as f64 * 2.0 + j as f64 * 60.0;
            let y = 50.0 + j as f64 * 40.0;
            let _ = writeln!(t, "{f},-1,{x},{y},30,60,0.9");
        }
    }
    t
}

fn seqinfo(dir: &Path, len: &str, w: u32, h: u32) -> PathBuf {
    let p = dir.join("seqinfo.ini");
    std::fs::write(
        &p,
        format!("[Sequence]\nname=s\nimDir=img1\nframeRate=30\nseqLength={len}\nimWidth={w}\nimHeight={h}\nimExt=.png\n"),
    )
    .unwrap();
    p
}

#[test]
fn absurd_frame_numbers_and_lengths_are_typed_errors() {
    let dir = scratch("robust_frames");
    let out = dir.join("out.txt");
    // Frame 4294967295 on the second line: once an abort allocating 100 GB.
    let det = dir.join("det.txt");
    std::fs::write(&det, "1,-1,1,1,5,5,1\n4294967295,-1,1,1,5,5,1\n").unwrap();
    let o = track(&["--det", s(&det), "--out", s(&out)]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("det.txt:2:1") && stderr(&o).contains("cap"),
        "{}",
        stderr(&o)
    );
    // seqLength of four billion.
    std::fs::write(&det, walking_boxes(60, 2)).unwrap();
    let ini = seqinfo(&dir, "4294967295", 640, 480);
    let o = track(&["--det", s(&det), "--seqinfo", s(&ini), "--out", s(&out)]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("seqLength"), "{}", stderr(&o));
    // A million declared frames with 60 detected ones: a correct result (the empty stretch
    // after the last track is skipped, not tracked frame by frame into memory).
    let ini = seqinfo(&dir, "1000000", 640, 480);
    let o = track(&["--det", s(&det), "--seqinfo", s(&ini), "--out", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("frames=1000000"));
    let res = parse_mot(&read_text(&out).unwrap(), "out").unwrap();
    assert!(res.len() > 100 && res.iter().all(|r| r.frame <= 70));
    // A zero image width.
    let ini = seqinfo(&dir, "60", 0, 480);
    let o = track(&["--det", s(&det), "--seqinfo", s(&ini), "--out", s(&out)]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("imWidth"), "{}", stderr(&o));
}

#[test]
fn huge_mots_masks_and_masks_of_another_size_are_refused() {
    let dir = scratch("robust_mots");
    let out = dir.join("out.txt");
    // 25 bytes declaring a 65536 × 65536 mask: once 89 s and 6.3 GB.
    let rle = Rle {
        height: 65536,
        width: 65536,
        counts: vec![0, 1 << 31, 1 << 31],
    };
    let det = dir.join("masks.txt");
    std::fs::write(
        &det,
        format!("1 -1 -1 65536 65536 {}\n", rle.to_compressed()),
    )
    .unwrap();
    let o = track(&["--det", s(&det), "--out", s(&out)]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("masks.txt:1"), "{}", stderr(&o));
    // 320×240 masks in a video seqinfo says is 100×50: once every mask written empty.
    let mut bitmap = vec![0u8; 320 * 240];
    bitmap[240 * 320 / 2 + 160] = 1;
    let m = Rle::encode(320, 240, &bitmap).unwrap();
    std::fs::write(&det, format!("1 1 1 240 320 {}\n", m.to_compressed())).unwrap();
    let ini = seqinfo(&dir, "1", 100, 50);
    let o = track(&["--det", s(&det), "--seqinfo", s(&ini), "--out", s(&out)]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("320x240 mask"), "{}", stderr(&o));
}

#[test]
fn outputs_never_destroy_inputs_or_old_results() {
    let dir = scratch("robust_out");
    let det = dir.join("det.txt");
    let text = walking_boxes(30, 2);
    std::fs::write(&det, &text).unwrap();
    // --out naming the detections (spelt differently) is refused; the file is untouched.
    let same = dir.join(".").join("det.txt");
    let o = track(&["--det", s(&det), "--out", s(&same)]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("is an input"), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(&det).unwrap(), text);
    // --joins naming --out (neither written yet) is refused: the second write would replace
    // the first.
    let (out1, joins1) = (dir.join("o.txt"), dir.join(".").join("o.txt"));
    let o = track(&[
        "--det",
        s(&det),
        "--offline",
        "--out",
        s(&out1),
        "--joins",
        s(&joins1),
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("are the same file"), "{}", stderr(&o));
    assert!(!out1.exists());
    // A run that fails after the output was opened leaves the old result as it was: a
    // config error is found before tracking, a bad line half way is found by the first pass.
    let out = dir.join("out.txt");
    std::fs::write(&out, "old result\n").unwrap();
    let bad = dir.join("bad.txt");
    std::fs::write(&bad, format!("{text}31,-1,0,0,nan,10,0.9\n")).unwrap();
    let o = track(&["--det", s(&bad), "--out", s(&out)]);
    assert!(!o.status.success());
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "old result\n");
    // No partial files are left behind.
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".partial"))
        .collect();
    assert!(left.is_empty());
}

#[test]
fn missing_frames_are_an_error() {
    let dir = scratch("robust_images");
    let det = dir.join("det.txt");
    std::fs::write(&det, walking_boxes(12, 1)).unwrap();
    let out = dir.join("out.txt");
    let img = dir.join("img");
    std::fs::create_dir_all(&img).unwrap();
    // An empty folder, then fewer images than frames: once appearance silently dropped.
    let o = track(&["--det", s(&det), "--frames", s(&img), "--out", s(&out)]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("holds 0 images"), "{}", stderr(&o));
    for k in 1..=5 {
        image::RgbImage::new(640, 480)
            .save(img.join(format!("{k}.png")))
            .unwrap();
    }
    let o = track(&["--det", s(&det), "--frames", s(&img), "--out", s(&out)]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("holds 5 images"), "{}", stderr(&o));
    // Twelve images named 1.png … 12.png (their order is unit-tested with `natural_cmp`).
    for k in 6..=12 {
        image::RgbImage::new(640, 480)
            .save(img.join(format!("{k}.png")))
            .unwrap();
    }
    let o = track(&["--det", s(&det), "--frames", s(&img), "--out", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Peak resident memory the run reported (Linux).
fn peak_kb(o: &std::process::Output) -> u64 {
    let text = String::from_utf8_lossy(&o.stdout);
    let v = text
        .split_whitespace()
        .find_map(|w| w.strip_prefix("peak_mem_kb="))
        .unwrap_or_else(|| panic!("no peak memory in {text}"));
    v.parse().unwrap()
}

#[test]
fn memory_stays_flat_over_a_long_video() {
    let dir = scratch("robust_memory");
    let mut peaks = Vec::new();
    for frames in [10_000u32, 40_000] {
        let det = dir.join(format!("det{frames}.txt"));
        std::fs::write(&det, walking_boxes(frames, 10)).unwrap();
        let out = dir.join(format!("out{frames}.txt"));
        let o = track(&["--det", s(&det), "--out", s(&out)]);
        assert!(o.status.success(), "{}", stderr(&o));
        peaks.push(peak_kb(&o));
        let lines = read_text(&out).unwrap().lines().count();
        assert!(lines as u32 > frames * 9, "{lines}");
    }
    // Four times the frames (and the detections file): well within twice the memory.
    assert!(peaks[1] < 2 * peaks[0], "peak memory {peaks:?} kB");
}

#[test]
fn a_frame_of_too_many_detections_is_an_error_that_changes_nothing() {
    use shapetrack::frame::{BBox, Detection};
    use shapetrack::track::{Config, TrackError, Tracker, MAX_DETECTIONS};
    let mut t = Tracker::new(Config::default()).unwrap();
    let many: Vec<Detection> = (0..=MAX_DETECTIONS)
        .map(|k| Detection::from_box(BBox::new((k % 100) as f64, 0.0, 50.0, 50.0), 0.9))
        .collect();
    let e = t.update(None, &many).unwrap_err();
    assert!(matches!(e, TrackError::TooManyDetections { .. }), "{e}");
    assert_eq!(t.frame(), 0);
    assert!(t.update(None, &many[..10]).is_ok());
}
