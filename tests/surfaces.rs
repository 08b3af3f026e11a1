//! What a third probe of the CLI (issue 65, "the new surfaces hold") found: an error that
//! came after the output was replaced, result lines and boxes beyond the frames dropped
//! without a word, paletted masks read by colour instead of index, truncated JPEGs decoded
//! grey, settings accepted that do nothing, and eval-vot holding every anchor's masks. Each
//! case failed before: exit 0 with a wrong result, a destroyed file, or memory beyond the work.
// A native suite (`cargo test`); for wasm32 it compiles to nothing.
#![cfg(not(target_arch = "wasm32"))]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shapetrack"))
        .args(args)
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("shapetrack-surf-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `n` textured frames of 48 × 40 in `dir` (`ext`: "png" or "jpg").
fn frames(dir: &Path, n: u32, ext: &str) {
    std::fs::create_dir_all(dir).unwrap();
    for k in 0..n {
        let img = image::RgbImage::from_fn(48, 40, |x, y| {
            let c = if ((x + k) / 6 + y / 6) % 2 == 0 {
                220
            } else {
                40
            };
            image::Rgb([c, (x * 5) as u8, (y * 6) as u8])
        });
        img.save(dir.join(format!("{:05}.{ext}", k + 1))).unwrap();
    }
}

/// An 8-bit greyscale mask of 48 × 40: 255 inside `[x0, x1) × [y0, y1)`.
fn grey_mask(path: &Path, (x0, y0, x1, y1): (u32, u32, u32, u32)) {
    image::GrayImage::from_fn(48, 40, |x, y| {
        image::Luma([if (x0..x1).contains(&x) && (y0..y1).contains(&y) {
            255
        } else {
            0
        }])
    })
    .save(path)
    .unwrap();
}

/// A paletted PNG of `w × h`: index 1 inside the box, 0 elsewhere, with `palette` (RGB per
/// index) and `depth` bits a pixel.
fn paletted(path: &Path, w: u32, h: u32, b: (u32, u32, u32, u32), palette: &[u8], depth: u8) {
    let mut enc = png::Encoder::new(std::fs::File::create(path).unwrap(), w, h);
    enc.set_color(png::ColorType::Indexed);
    enc.set_depth(match depth {
        1 => png::BitDepth::One,
        2 => png::BitDepth::Two,
        4 => png::BitDepth::Four,
        _ => png::BitDepth::Eight,
    });
    enc.set_palette(palette.to_vec());
    let mut data = Vec::new();
    for y in 0..h {
        let mut row = vec![0u8; (w as usize * depth as usize).div_ceil(8)];
        for x in 0..w {
            if (b.0..b.2).contains(&x) && (b.1..b.3).contains(&y) {
                let bit = x as usize * depth as usize;
                row[bit / 8] |= 1 << (8 - depth as usize - bit % 8);
            }
        }
        data.extend(row);
    }
    enc.write_header().unwrap().write_image_data(&data).unwrap();
}

#[test]
fn follow_keeps_an_existing_output_when_its_ground_truth_is_bad() {
    // --gt was read after --out was written: a wrong mask count replaced the user's file.
    let dir = scratch("follow-gt");
    frames(&dir.join("f"), 3, "png");
    grey_mask(&dir.join("init.png"), (10, 10, 30, 30));
    std::fs::create_dir_all(dir.join("gt")).unwrap();
    grey_mask(&dir.join("gt/00000.png"), (10, 10, 30, 30));
    let out = dir.join("out.txt");
    std::fs::write(&out, "precious\n").unwrap();
    let o = run(&[
        "follow",
        "--frames",
        s(&dir.join("f")),
        "--init",
        s(&dir.join("init.png")),
        "--method",
        "copy",
        "--gt",
        s(&dir.join("gt")),
        "--out",
        s(&out),
    ]);
    assert!(!o.status.success(), "accepted");
    assert!(stderr(&o).contains("--gt"), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "precious\n");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn eval_vot_refuses_result_lines_beyond_the_frames() {
    // A run (anchor) or trajectory (reset) longer than the sequence: its extra lines were
    // ignored (anchor) or reported without the file (reset).
    let dir = scratch("vot-extra");
    let gt: String = (0..5).map(|k| format!("{},10,20,20\n", 10 + k)).collect();
    std::fs::write(dir.join("groundtruth.txt"), &gt).unwrap();
    let res = dir.join("res");
    std::fs::create_dir_all(&res).unwrap();
    let run_file = res.join("seq_00000000.txt");
    let lines = format!("1\n{}", gt.lines().skip(1).collect::<Vec<_>>().join("\n"));
    std::fs::write(&run_file, format!("{lines}\n")).unwrap();
    let args = |p: &str, t: &Path| {
        run(&[
            "eval-vot",
            "--gt",
            s(&dir),
            "--tracker",
            s(t),
            "--sequence",
            "seq",
            "--size",
            "64x48",
            "--protocol",
            p,
        ])
    };
    assert!(args("anchor", &res).status.success());
    std::fs::write(&run_file, format!("{lines}\n10,10,20,20\n")).unwrap();
    let o = args("anchor", &res);
    assert!(!o.status.success(), "accepted");
    let want = format!("{}:6:", run_file.display());
    assert!(stderr(&o).contains(&want), "{}", stderr(&o));
    let traj = res.join("seq_001.txt");
    std::fs::write(&traj, format!("{lines}\n10,10,20,20\n")).unwrap();
    let o = args("reset", &traj);
    assert!(!o.status.success(), "accepted");
    assert!(
        stderr(&o).contains(&format!("{}:6:", traj.display())),
        "{}",
        stderr(&o)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn detect_refuses_a_box_for_a_frame_the_folder_lacks() {
    let dir = scratch("boxes");
    frames(&dir.join("f"), 2, "png");
    let boxes = dir.join("b.txt");
    std::fs::write(&boxes, "1,-1,5,5,20,20,1\n3,-1,5,5,20,20,1\n").unwrap();
    let o = run(&[
        "detect",
        "--frames",
        s(&dir.join("f")),
        "--detector",
        "refine",
        "--boxes",
        s(&boxes),
        "--model",
        "none",
        "--out",
        s(&dir.join("o.txt")),
    ]);
    assert!(!o.status.success(), "accepted");
    let e = stderr(&o);
    assert!(e.contains(&format!("{}:2:", boxes.display())), "{e}");
    assert!(e.contains("holds 2 frames"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn paletted_masks_are_read_by_index_not_colour() {
    let dir = scratch("palette");
    frames(&dir.join("f"), 2, "png");
    let b = (10, 10, 30, 30);
    // Index 0 white, index 1 black: by colour, the object is the background.
    for (name, palette, depth) in [
        ("black.png", vec![255, 255, 255, 0, 0, 0], 8),
        ("same.png", vec![0, 0, 0, 0, 0, 0], 8),
        ("packed.png", vec![255, 255, 255, 0, 0, 0], 1),
    ] {
        let init = dir.join(name);
        paletted(&init, 48, 40, b, &palette, depth);
        let out = dir.join("o.txt");
        let o = run(&[
            "follow",
            "--frames",
            s(&dir.join("f")),
            "--init",
            s(&init),
            "--method",
            "copy",
            "--out",
            s(&out),
        ]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let text = std::fs::read_to_string(&out).unwrap();
        let recs = shapetrack::io::motchallenge::parse_mots(&text, "o.txt").unwrap();
        assert_eq!(recs.len(), 2, "{name}: {text}");
        let m = recs[0].mask_bitmap().unwrap();
        assert_eq!(m.area(), 400, "{name}");
        // The instance-map reader: index 1 is object 1 (was refused as an RGB image).
        let f = shapetrack::io::png_masks::read_png_masks(
            &init,
            1,
            shapetrack::io::png_masks::EightBit::Ids,
        )
        .unwrap();
        assert_eq!(f.records.len(), 1, "{name}");
        assert_eq!(f.records[0].id, 1);
        assert_eq!(f.records[0].mask_bitmap().unwrap().area(), 400);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_truncated_jpeg_frame_is_refused_naming_it() {
    let dir = scratch("jpeg");
    let f = dir.join("f");
    frames(&f, 3, "jpg");
    let cut = f.join("00002.jpg");
    let bytes = std::fs::read(&cut).unwrap();
    assert!(shapetrack::io::read_rgb(&cut).is_ok());
    std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).unwrap();
    let e = shapetrack::io::read_rgb(&cut).unwrap_err().to_string();
    assert!(e.contains("00002.jpg") && e.contains("truncated"), "{e}");
    // Bytes after the end marker (some cameras append data) are no truncation.
    let mut tail = bytes.clone();
    tail.extend_from_slice(b"\xff\xda trailing");
    std::fs::write(&cut, &tail).unwrap();
    assert!(shapetrack::io::read_rgb(&cut).is_ok());
    std::fs::write(&cut, &bytes[..bytes.len() - 2]).unwrap();
    let o = run(&[
        "detect",
        "--frames",
        s(&f),
        "--detector",
        "background",
        "--model",
        "none",
        "--out",
        s(&dir.join("o.txt")),
    ]);
    assert!(!o.status.success(), "accepted");
    assert!(stderr(&o).contains("00002.jpg"), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn detect_checks_its_segment_settings_without_a_model() {
    let dir = scratch("segment");
    frames(&dir.join("f"), 2, "png");
    let o = run(&[
        "detect",
        "--frames",
        s(&dir.join("f")),
        "--detector",
        "background",
        "--model",
        "none",
        "--segment",
        r#"{"no_such_field": 1}"#,
        "--out",
        s(&dir.join("o.txt")),
    ]);
    assert!(!o.status.success(), "accepted");
    assert!(stderr(&o).contains("no_such_field"), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_absent_object_is_no_failure_under_either_protocol() {
    use shapetrack::eval::vot::{
        evaluate_anchor_sequence, run_reset_protocol, AnchorParams, ResetParams,
    };
    use shapetrack::io::vot::{parse_regions, Anchor, Direction, Region};
    // Frames 3..6 hide the object (NaN, VOT's "absent"); a tracker that keeps reporting it
    // where it was is no failure there under the anchor protocol, and was one under reset.
    let text: String = (0..10)
        .map(|k| {
            if (3..6).contains(&k) {
                "NaN,NaN,NaN,NaN\n".to_string()
            } else {
                "10,10,20,20\n".to_string()
            }
        })
        .collect();
    let gt = parse_regions(&text, "groundtruth.txt").unwrap();
    assert_eq!(gt[4], Region::Special(0));
    let still = Region::Rectangle(shapetrack::frame::BBox::new(10.0, 10.0, 20.0, 20.0));
    let traj = run_reset_protocol(&gt, &ResetParams::default(), |start, _| {
        vec![still.clone(); gt.len() - start - 1]
    });
    assert!(traj.iter().all(|r| r.special() != Some(2)), "{traj:?}");
    let anchor = Anchor {
        frame: 0,
        direction: Direction::Forward,
    };
    let mut run = vec![Region::Special(1)];
    run.extend(std::iter::repeat_n(still.clone(), 9));
    let params = AnchorParams {
        grace: 1,
        ..AnchorParams::default()
    };
    let s = evaluate_anchor_sequence(&gt, &[anchor], &[run], &params).unwrap();
    assert!(!s.runs[0].failed);
}

#[test]
fn track_refuses_weights_its_detections_cannot_feed() {
    // Boxes, and only mask and appearance terms weighted: no pair was ever scored, and the
    // run ended with no track and exit 0.
    let dir = scratch("weights");
    let det = dir.join("det.txt");
    let text: String = (1..=5)
        .map(|k| format!("{k},-1,{},10,20,30,0.9,-1,-1,-1\n", 10 + k))
        .collect();
    std::fs::write(&det, text).unwrap();
    let cfg = dir.join("cfg.json");
    std::fs::write(&cfg, r#"{"terms": {"iou": {"weight": 0}}}"#).unwrap();
    let o = run(&[
        "track",
        "--det",
        s(&det),
        "--config",
        s(&cfg),
        "--out",
        s(&dir.join("t.txt")),
    ]);
    assert!(!o.status.success(), "accepted");
    let e = stderr(&o);
    assert!(e.contains("cfg.json") && e.contains("terms.{iou"), "{e}");
    // One geometry term is enough.
    std::fs::write(
        &cfg,
        r#"{"terms": {"iou": {"weight": 0}, "giou": {"weight": 1}}}"#,
    )
    .unwrap();
    let o = run(&[
        "track",
        "--det",
        s(&det),
        "--config",
        s(&cfg),
        "--out",
        s(&dir.join("t.txt")),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
#[cfg(target_os = "linux")]
fn eval_vot_scores_anchor_runs_without_holding_their_masks() {
    // 600 frames, an anchor every 10: 60 runs of ~450 frames, each frame a 100×100 mask in a
    // few bytes of RLE. Held, the 27,000 masks are 270 MB; scored run by run, one run's text.
    let dir = scratch("vot-memory");
    let n = 600usize;
    let gt: Vec<(usize, usize)> = (0..n).map(|k| (10 + k % 300, 20)).collect();
    let text: String = gt
        .iter()
        .map(|(x, y)| format!("{x},{y},100,100\n"))
        .collect();
    std::fs::write(dir.join("groundtruth.txt"), text).unwrap();
    let res = dir.join("res");
    std::fs::create_dir_all(&res).unwrap();
    for a in (0..n).step_by(10) {
        let frames: Vec<usize> = if n - a > a {
            (a..n).collect()
        } else {
            (0..=a).rev().collect()
        };
        let mut lines = vec!["1".to_string()];
        for &f in &frames[1..] {
            lines.push(format!("m{},{},100,100,0,10000", gt[f].0 + 2, gt[f].1));
        }
        std::fs::write(res.join(format!("seq_{a:08}.txt")), lines.join("\n") + "\n").unwrap();
    }
    // Address space capped at 160 MB: the scores must come out under it.
    let o = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v 160000 && exec \"$0\" eval-vot --gt {} --tracker {} --sequence seq \
             --size 640x480 --anchor-spacing 10",
            s(&dir),
            s(&res)
        ))
        .arg(env!("CARGO_BIN_EXE_shapetrack"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("R    1.0000"), "{out}");
    let _ = std::fs::remove_dir_all(&dir);
}
