//! `shapetrack track` end to end: box mode on a MOT15 sequence, mask mode with real frames
//! (DAVIS car-shadow, MOTS in and out, 0-based frames), and the flags' error paths.

use shapetrack::frame::Mask;
use shapetrack::io::motchallenge::{parse_mot, parse_mots, write_mots};
use shapetrack::io::{read_text, Record, RecordFlags, Rle};
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
    let o = track(&[
        "--det",
        s(&det),
        "--fps",
        "5",
        "--format",
        "scalabel",
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
