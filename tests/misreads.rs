//! Issue 65, classes 5 and 7: no silent misreads, errors a person can act on. MOTS masks of
//! another size than the sequence (with or without a seqinfo), format sniffing (an all-digit
//! RLE is a mask, not a box height; a byte-order mark is accepted), Label Studio ids that read
//! as one number, detect-eval's ground truth of the wrong size, settings that make tracking
//! impossible, ids beyond 2⁵³, numbers printed short.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::detect::MovingConfig;
use shapetrack::io::label_studio::parse_label_studio;
use shapetrack::io::motchallenge::{parse_mot, parse_mots};
use shapetrack::io::yolo::parse_yolo;
use shapetrack::io::{read_text, Rle};
use shapetrack::track::Config;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

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

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A `w`×`h` mask with a `k`×`k` square at its top-left corner, as a MOTS RLE string.
fn square(w: u32, h: u32, k: u32) -> String {
    let mut bits = vec![0u8; (w * h) as usize];
    for y in 0..k {
        for x in 0..k {
            bits[(y * w + x) as usize] = 1;
        }
    }
    Rle::encode(w, h, &bits).unwrap().to_compressed()
}

#[test]
fn mots_masks_of_two_sizes_are_refused_without_a_seqinfo() {
    let dir = scratch("misread_mots_sizes");
    let det = dir.join("masks.txt");
    let out = dir.join("out.txt");
    let mut t = String::new();
    for f in 1..=4 {
        // Frame 3's mask is of another video: once tracked as if it fitted the first's.
        let (w, h) = if f == 3 { (64, 48) } else { (32, 24) };
        let _ = writeln!(t, "{f} 1 1 {h} {w} {}", square(w, h, 8));
    }
    std::fs::write(&det, t).unwrap();
    let o = shapetrack(&["track", "--det", s(&det), "--out", s(&out)]);
    assert!(
        !o.status.success(),
        "a 64x48 mask among 32x24 ones was accepted"
    );
    let e = stderr(&o);
    assert!(
        e.contains("masks.txt:3") && e.contains("64x48 mask") && e.contains("first mask"),
        "{e}"
    );
}

#[test]
fn eval_refuses_mots_masks_of_another_size_than_the_seqinfo() {
    let dir = scratch("misread_eval_sizes");
    let seq = dir.join("gt/MOTS-train/s1");
    std::fs::create_dir_all(seq.join("gt")).unwrap();
    std::fs::create_dir_all(dir.join("res")).unwrap();
    // The seqinfo says 100x50; every mask (gt and results alike) is 32x24.
    std::fs::write(
        seq.join("seqinfo.ini"),
        "[Sequence]\nname=s1\nimDir=img1\nframeRate=30\nseqLength=2\nimWidth=100\nimHeight=50\nimExt=.png\n",
    )
    .unwrap();
    let line = |f: u32| format!("{f} 2001 2 24 32 {}\n", square(32, 24, 8));
    let text = line(1) + &line(2);
    std::fs::write(seq.join("gt/gt.txt"), &text).unwrap();
    std::fs::write(dir.join("res/s1.txt"), &text).unwrap();
    let o = shapetrack(&[
        "eval",
        "--gt",
        s(&dir.join("gt")),
        "--tracker",
        s(&dir.join("res")),
        "--benchmark",
        "MOTS",
        "--masks",
    ]);
    assert!(!o.status.success(), "32x24 masks scored in a 100x50 video");
    let e = stderr(&o);
    assert!(
        e.contains("gt.txt:1") && e.contains("32x24 mask") && e.contains("100x50"),
        "{e}"
    );
}

/// `shapetrack track` of `det`, MOTS written to `out`.
fn track_mots(det: &Path, out: &Path) -> Output {
    shapetrack(&[
        "track",
        "--det",
        s(det),
        "--out",
        s(out),
        "--format",
        "mots",
    ])
}

#[test]
fn an_all_digit_rle_is_read_as_a_mask_not_a_box() {
    // "538" is a 4×4 mask's runs 5, 3, 8: a number, once taken for a box's height.
    let dir = scratch("misread_sniff_digits");
    let det = dir.join("masks.txt");
    let out = dir.join("out.txt");
    let rle = "538";
    assert_eq!(Rle::from_compressed(rle, 4, 4).unwrap().area(), 3);
    let t: String = (1..=12).map(|f| format!("{f} 1 1 4 4 {rle}\n")).collect();
    std::fs::write(&det, t).unwrap();
    let o = track_mots(&det, &out);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("mask mode"));
    let text = read_text(&out).unwrap();
    let records = parse_mots(&text, "out").unwrap_or_else(|e| panic!("{e}\n{text}"));
    assert!(!records.is_empty() && records.iter().all(|r| r.mask.is_some()));
}

#[test]
fn scalabel_boxes_are_told_from_masks_by_their_records_not_their_text() {
    // Boxes whose category is "rle" and whose attributes say "counts": once taken for masks
    // (the mask preset, which tracked nothing in six frames).
    let dir = scratch("misread_sniff_scalabel");
    let det = dir.join("det.json");
    let out = dir.join("out.json");
    let labels: Vec<String> = (1..=6)
        .map(|f| {
            format!(
                r#"{{"name": "f{f}", "videoName": "v", "frameIndex": {}, "labels": [{{"id": "a", "category": "rle", "attributes": {{"counts": true}}, "box2d": {{"x1": {x}, "y1": 20, "x2": {x2}, "y2": 80}}}}]}}"#,
                f - 1,
                x = 10 + 2 * f,
                x2 = 40 + 2 * f
            )
        })
        .collect();
    std::fs::write(&det, format!("[{}]", labels.join(","))).unwrap();
    let o = shapetrack(&["track", "--det", s(&det), "--out", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let so = String::from_utf8_lossy(&o.stdout);
    assert!(so.contains("box mode") && so.contains("shapes=6"), "{so}");
}

#[test]
fn a_byte_order_mark_is_accepted() {
    let dir = scratch("misread_bom");
    let out = dir.join("out.txt");
    let bom = "\u{feff}";
    // MOT boxes, read line by line while tracking.
    let det = dir.join("det.txt");
    let boxes: String = (1..=6)
        .map(|f| format!("{f},-1,{},20,30,60,0.9\n", 10 + 2 * f))
        .collect();
    std::fs::write(&det, format!("{bom}{boxes}")).unwrap();
    let o = shapetrack(&["track", "--det", s(&det), "--out", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!parse_mot(&read_text(&out).unwrap(), "out")
        .unwrap()
        .is_empty());
    // MOTS masks, told apart from boxes after the mark.
    let masks: String = (1..=12)
        .map(|f| format!("{f} 1 1 24 32 {}\n", square(32, 24, 8)))
        .collect();
    std::fs::write(&det, format!("{bom}{masks}")).unwrap();
    let o = track_mots(&det, &out);
    assert!(o.status.success(), "{}", stderr(&o));
    let res = parse_mots(&read_text(&out).unwrap(), "out").unwrap();
    assert!(!res.is_empty() && res.iter().all(|r| r.mask.is_some()));
    // The mark alone on the first line.
    std::fs::write(&det, format!("{bom}\n{masks}")).unwrap();
    let o = track_mots(&det, &out);
    assert!(o.status.success(), "{}", stderr(&o));
    // A Scalabel JSON file, taken for JSON after the mark.
    let json = dir.join("det.json");
    let labels: Vec<String> = (1..=6)
        .map(|f| {
            format!(
                r#"{{"name": "f{f}", "videoName": "v", "frameIndex": {}, "labels": [{{"id": "a", "category": "car", "box2d": {{"x1": {x}, "y1": 20, "x2": {x2}, "y2": 80}}}}]}}"#,
                f - 1,
                x = 10 + 2 * f,
                x2 = 40 + 2 * f
            )
        })
        .collect();
    std::fs::write(&json, format!("{bom}[{}]", labels.join(","))).unwrap();
    let o = shapetrack(&["track", "--det", s(&json), "--out", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    // And by every reader of whole files.
    std::fs::write(&det, format!("{bom}1,1,1,1,5,5,1\n")).unwrap();
    assert_eq!(parse_mot(&read_text(&det).unwrap(), "d").unwrap().len(), 1);
}

#[test]
fn label_studio_ids_that_read_as_one_number_are_refused() {
    let region = |id: &str, x: u32| {
        format!(
            r#"{{"id": "{id}", "type": "videorectangle", "value": {{"sequence": [{{"frame": 1, "enabled": true, "x": {x}, "y": 10, "width": 10, "height": 10}}], "labels": ["car"]}}}}"#
        )
    };
    let file = |a: &str, b: &str| {
        format!(
            "[{{\"data\": {{}}, \"annotations\": [{{\"result\": [\n{},\n{}\n]}}]}}]",
            region(a, 10),
            region(b, 50)
        )
    };
    // Two regions "7" and "07": once merged into one track 7.
    let e = parse_label_studio(&file("7", "07"), "ls.json", (100, 100), None)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("ls.json:3") && e.contains("\"7\"") && e.contains("\"07\""),
        "{e}"
    );
    // Different numbers stay two tracks.
    let a = parse_label_studio(&file("7", "8"), "ls.json", (100, 100), None).unwrap();
    assert_eq!(a.records.len(), 2);
    // An id JavaScript cannot hold exactly is named as such.
    let e = parse_label_studio(&file("1", "9007199254740993"), "ls.json", (100, 100), None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("9007199254740993") && e.contains("2^53"), "{e}");
}

#[test]
fn ids_beyond_2_53_are_named_as_such() {
    for id in [
        "9007199254740993",
        "-9007199254740993",
        "99999999999999999999",
    ] {
        let e = parse_mot(&format!("1,1,1,1,5,5,1\n1,{id},1,1,5,5,1\n"), "d.txt")
            .unwrap_err()
            .to_string();
        assert!(e.contains("d.txt:2:2") && e.contains("2^53"), "{e}");
        let rle = square(4, 4, 2);
        let e = parse_mots(&format!("1 {id} 1 4 4 {rle}\n"), "m.txt")
            .unwrap_err()
            .to_string();
        assert!(e.contains("m.txt:1:2") && e.contains("2^53"), "{e}");
    }
    let e = parse_yolo(
        "1 0 0.5 0.5 0.1 0.1 9007199254740993\n",
        "y.txt",
        (100, 100),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("y.txt:1") && e.contains("2^53"), "{e}");
    // 2⁵³ itself is exact, and read.
    let r = parse_mot("1,9007199254740992,1,1,5,5,1\n", "d.txt").unwrap();
    assert_eq!(r[0].id, 1 << 53);
}

#[test]
fn detect_eval_refuses_ground_truth_of_another_size() {
    let dir = scratch("misread_detect_eval");
    let frames = dir.join("DAVIS/JPEGImages/480p/s1");
    let gt = dir.join("DAVIS/Annotations/480p/s1");
    std::fs::create_dir_all(&frames).unwrap();
    std::fs::create_dir_all(&gt).unwrap();
    for i in 0..2 {
        image::RgbImage::from_pixel(64, 48, image::Rgb([90, 120, 150]))
            .save(frames.join(format!("{i:05}.jpg")))
            .unwrap();
        // The annotation is 32x24: once its box scored against 64x48 frames.
        let mut m = image::GrayImage::new(32, 24);
        for y in 4..12 {
            for x in 4..12 {
                m.put_pixel(x, y, image::Luma([255]));
            }
        }
        m.save(gt.join(format!("{i:05}.png"))).unwrap();
    }
    let o = shapetrack(&["detect-eval", "--davis", s(&dir), "--methods", "box"]);
    assert!(
        !o.status.success(),
        "32x24 ground truth scored on 64x48 frames"
    );
    let e = stderr(&o);
    assert!(
        e.contains("00000.png") && e.contains("32x24") && e.contains("64x48"),
        "{e}"
    );
}

#[test]
fn settings_that_make_tracking_impossible_name_their_field() {
    let err = |c: Config| c.validate().unwrap_err().to_string();
    // Every main weight 0: no pair is ever scored.
    let mut c = Config::default();
    c.terms.iou.weight = 0.0;
    c.terms.mask_iou.weight = 0.0;
    c.terms.shape_context.weight = 0.0;
    c.terms.colour.weight = 0.0;
    assert!(err(c).contains("terms"), "all weights 0 accepted");
    // A negative gate refuses every pair (costs are ≥ 0); named in its own section.
    let mut c = Config::default();
    c.terms.centre.gate = Some(-1.0);
    let e = err(c);
    assert!(e.contains("terms.centre.gate = -1"), "{e}");
    let mut c = Config::default();
    c.reid_terms.colour.gate = Some(-0.5);
    let e = err(c);
    assert!(e.contains("reid_terms.colour.gate = -0.5"), "{e}");
    // Absurd margins.
    let c = Config {
        region_margin: 1e300,
        ..Config::default()
    };
    let e = err(c);
    assert!(e.contains("region_margin = 1e300"), "{e}");
    let c = Config {
        region_margin_per_miss: 5000.0,
        ..Config::default()
    };
    assert!(err(c).contains("region_margin_per_miss"));
    // NaN, as a JS settings object can give.
    let c = Config {
        max_cost: f64::NAN,
        ..Config::default()
    };
    assert!(err(c).contains("max_cost = NaN"));
    // Valid presets still are.
    Config::default().validate().unwrap();
    Config::masks().validate().unwrap();
}

#[test]
fn a_config_file_that_makes_tracking_impossible_is_named_with_its_field() {
    let dir = scratch("misread_config");
    let det = dir.join("det.txt");
    let out = dir.join("out.txt");
    std::fs::write(&det, "1,-1,10,20,30,60,0.9\n").unwrap();
    let cfg = dir.join("cfg.json");
    std::fs::write(
        &cfg,
        r#"{"terms": {"centre": {"weight": 1, "gate": -0.1}}}"#,
    )
    .unwrap();
    let o = shapetrack(&[
        "track",
        "--det",
        s(&det),
        "--out",
        s(&out),
        "--config",
        s(&cfg),
    ]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("cfg.json") && e.contains("terms.centre.gate = -0.1"),
        "{e}"
    );
}

#[test]
fn numbers_in_messages_are_printed_short() {
    // An f32 setting of 1.3 once printed as 1.2999999523162842.
    let c = MovingConfig {
        alpha: 1.3,
        ..MovingConfig::default()
    };
    let e = c.validate().unwrap_err().to_string();
    assert!(e.contains("alpha = 1.3:"), "{e}");
}
