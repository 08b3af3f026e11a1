//! `shapetrack track --offline` end to end: box mode on a MOT15 sequence in every output
//! format (the interpolated flag must survive the COCO-video and CVAT exports), mask mode with
//! frames on a synthetic occlusion scene, and the offline flags' error paths.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::io::coco_video::parse_coco_video;
use shapetrack::io::cvat::parse_cvat;
use shapetrack::io::motchallenge::{parse_mot, parse_mots};
use shapetrack::io::read_text;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

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

fn shapetrack(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shapetrack"))
        .args(args)
        .output()
        .unwrap()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The `key=value` number printed in the summary line.
fn summary_value(out: &Output, key: &str) -> usize {
    let text = String::from_utf8_lossy(&out.stdout);
    let at = text
        .find(&format!(" {key}="))
        .unwrap_or_else(|| panic!("no {key} in {text}"));
    text[at + key.len() + 2..]
        .split(|c: char| !c.is_ascii_digit())
        .next()
        .unwrap()
        .parse()
        .unwrap()
}

#[test]
fn offline_box_mode_writes_every_format_and_keeps_the_interpolated_flag() {
    let dir = scratch("offline_cli_box");
    let det = data("mot15-train/TUD-Campus/det/det.txt");
    let run = |out: &Path, extra: &[&str]| {
        let mut args = vec!["track", "--det", s(&det), "--out", s(out), "--offline"];
        args.extend_from_slice(extra);
        let o = shapetrack(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        o
    };

    // MOT text: the online pass's shapes plus fills less dropped coasting, fewer ids (joins).
    let online = dir.join("online.txt");
    let o = shapetrack(&["track", "--det", s(&det), "--out", s(&online)]);
    assert!(o.status.success());
    let online = parse_mot(&read_text(&online).unwrap(), "online").unwrap();
    let mot = dir.join("offline.txt");
    let joins = dir.join("joins.json");
    let o = run(&mot, &["--joins", s(&joins)]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("offline") && text.contains("fps 25"),
        "{text}"
    );
    let filled = summary_value(&o, "filled");
    let n_joins = summary_value(&o, "joins");
    assert!(filled > 0, "{text}");
    let dropped = summary_value(&o, "coasted_dropped");
    let res = parse_mot(&read_text(&mot).unwrap(), "offline").unwrap();
    // Coasted shapes the fill replaced, or past a track's last observation, are left out.
    assert_eq!(res.len() + dropped, online.len() + filled);
    let ids = |r: &[shapetrack::io::Record]| r.iter().map(|r| r.id).collect::<BTreeSet<_>>();
    assert_eq!(ids(&res).len() + n_joins, ids(&online).len());
    let j: serde_json::Value = serde_json::from_str(&read_text(&joins).unwrap()).unwrap();
    assert_eq!(j.as_array().unwrap().len(), n_joins);

    // CVAT: filled shapes are keyframe="0", read back as interpolated.
    let xml = dir.join("offline.xml");
    run(&xml, &[]);
    let cvat = parse_cvat(&read_text(&xml).unwrap(), "offline.xml", None).unwrap();
    let interp = |recs: &[shapetrack::io::Record]| -> BTreeSet<(u32, i64)> {
        recs.iter()
            .filter(|r| r.flags.interpolated)
            .map(|r| (r.frame, r.id))
            .collect()
    };
    // Interpolated: the fills plus the online pass's coasting over missed detections.
    let from_cvat = interp(&cvat.records);
    assert_eq!(from_cvat.len(), summary_value(&o, "interpolated"));
    assert!(from_cvat.len() >= filled);
    assert_eq!(cvat.records.len(), res.len());

    // COCO-video (chosen by the extension): the per-frame `interpolated` list.
    let json = dir.join("offline.json");
    run(&json, &[]);
    let coco = parse_coco_video(&read_text(&json).unwrap(), "offline.json").unwrap();
    let recs = &coco.videos[0].records;
    assert_eq!(recs.len(), res.len());
    assert_eq!(interp(recs), from_cvat);

    // The same flags from an explicit --format, and MOTS (boxes as masks) still works.
    let mots = dir.join("offline_mots.txt");
    run(&mots, &["--format", "mots"]);
    assert_eq!(
        parse_mots(&read_text(&mots).unwrap(), "mots")
            .unwrap()
            .len(),
        res.len()
    );

    // An offline config changes the behaviour: no fill, no joins, no smoothing, coasted tails
    // kept = the online output.
    let cfg = dir.join("offline_config.json");
    std::fs::write(
        &cfg,
        r#"{"relink": {"max_gap_seconds": 0}, "fill": {"max_gap": 0, "coasted_tails": true}, "smooth": {"enabled": false}}"#,
    )
    .unwrap();
    let plain = dir.join("plain.txt");
    run(&plain, &["--offline-config", s(&cfg)]);
    let plain = parse_mot(&read_text(&plain).unwrap(), "plain").unwrap();
    assert_eq!(plain, online);
}

#[test]
fn offline_mask_mode_with_frames_on_a_synthetic_occlusion_scene() {
    let dir = scratch("offline_cli_synth");
    let seq = dir.join("seq");
    let o = shapetrack(&[
        "synth",
        "--preset",
        "occlusion",
        "--seed",
        "3",
        "--frames",
        "120",
        "--out",
        s(&seq),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (det, seqinfo, img) = (
        seq.join("det/det_mots.txt"),
        seq.join("seqinfo.ini"),
        seq.join("img1"),
    );
    let track = |out: &std::path::Path, extra: &[&str]| {
        let mut args = vec![
            "track",
            "--det",
            s(&det),
            "--seqinfo",
            s(&seqinfo),
            "--frames",
            s(&img),
            "--out",
            s(out),
            "--offline",
        ];
        args.extend_from_slice(extra);
        let o = shapetrack(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        assert!(text.contains("mask mode, offline"), "{text}");
        let cvat = parse_cvat(&read_text(out).unwrap(), "out.xml", None).unwrap();
        assert!(!cvat.records.is_empty());
        // Masks were written (CVAT <mask>).
        assert!(cvat.records.iter().all(|r| r.mask.is_some()));
        (o, text, cvat)
    };
    // The box-mode defaults as the online pass: objects hidden behind the bars come back under
    // new ids, the re-linker joins them (with SIFT snapshots from the frames) and fills short
    // gaps, each marked interpolated (as are the online pass's coasted shapes).
    let (o, text, cvat) = track(&dir.join("default.xml"), &["--preset", "default"]);
    let filled = summary_value(&o, "filled");
    assert!(summary_value(&o, "joins") > 0 && filled > 0, "{text}");
    let interpolated = cvat.records.iter().filter(|r| r.flags.interpolated).count();
    assert_eq!(interpolated, summary_value(&o, "interpolated"));
    assert!(interpolated >= filled);
    // The mask preset (the default for MOTS input) re-identifies them online already: fewer
    // tracks than the defaults' online pass; interpolated shapes are the fills plus the online
    // pass's coasting over missed detections.
    let (o, text, cvat) = track(&dir.join("masks.xml"), &[]);
    let tracks = |o: &Output| summary_value(o, "tracks");
    let masks_tracks = tracks(&o);
    let o_default = shapetrack(&[
        "track",
        "--det",
        s(&seq.join("det/det_mots.txt")),
        "--frames",
        s(&seq.join("img1")),
        "--preset",
        "default",
        "--out",
        s(&dir.join("default_online.txt")),
    ]);
    assert!(o_default.status.success());
    assert!(
        masks_tracks < tracks(&o_default),
        "{text} vs {}",
        String::from_utf8_lossy(&o_default.stdout)
    );
    assert!(
        cvat.records.iter().filter(|r| r.flags.interpolated).count() >= summary_value(&o, "filled")
    );
}

#[test]
fn offline_flags_error_paths() {
    let dir = scratch("offline_cli_errors");
    let det = data("mot15-train/TUD-Campus/det/det.txt");
    let out = dir.join("x.txt");

    // --offline-config and --joins need --offline.
    let cfg = dir.join("c.json");
    std::fs::write(&cfg, "{}").unwrap();
    let o = shapetrack(&[
        "track",
        "--det",
        s(&det),
        "--out",
        s(&out),
        "--offline-config",
        s(&cfg),
    ]);
    assert!(!o.status.success());

    // Out-of-range values are refused with the field's name.
    std::fs::write(&cfg, r#"{"relink": {"max_size_ratio": 0.5}}"#).unwrap();
    let o = shapetrack(&[
        "track",
        "--det",
        s(&det),
        "--out",
        s(&out),
        "--offline",
        "--offline-config",
        s(&cfg),
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("relink.max_size_ratio"));

    // A bad fps is refused before any work.
    let o = shapetrack(&[
        "track",
        "--det",
        s(&det),
        "--out",
        s(&out),
        "--offline",
        "--fps",
        "0",
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("fps"));
}
