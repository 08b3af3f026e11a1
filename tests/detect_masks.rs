//! Instance masks without a segmentation model (issue 11): box → mask refinement on a generated
//! image, the moving-camera detector on a generated panning scene, and `shapetrack detect` end
//! to end with its error paths. Quality only; speed is measured by `shapetrack detect-eval`.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::detect::{
    refine_box, CameraJudge, Detector, MotionCue, MovingCameraDetector, MovingConfig, RefineConfig,
};
use shapetrack::io::motchallenge::parse_mots;
use shapetrack::io::read_text;
use shapetrack::segment::VideoDetectorKind;
use shapetrack::{BBox, Frame, Mask};
use std::path::{Path, PathBuf};
use std::process::Command;

/// A smooth colourful texture, different everywhere (so a shifted copy is easy to register),
/// evaluated at world position `(x, y)`.
fn texture(x: f64, y: f64) -> [u8; 3] {
    let a = (x * 0.21).sin() + (y * 0.17).cos() + (0.05 * (x + 2.0 * y)).sin();
    let b = (x * 0.11 + y * 0.07).sin() + ((x - y) * 0.13).cos();
    let c = ((x * y).sqrt() * 0.3).sin();
    let v = |t: f64| (128.0 + 60.0 * t).clamp(0.0, 255.0) as u8;
    [v(a), v(b), v(c)]
}

/// An ellipse of a flat orange with a darker band, centred at `(cx, cy)`.
fn object(x: f64, y: f64, cx: f64, cy: f64, rx: f64, ry: f64) -> Option<[u8; 3]> {
    let (dx, dy) = ((x - cx) / rx, (y - cy) / ry);
    if dx * dx + dy * dy > 1.0 {
        return None;
    }
    Some(if dy.abs() < 0.2 {
        [170, 60, 20]
    } else {
        [235, 120, 30]
    })
}

/// A frame of a camera at `(ox, oy)` over the textured world, with the object at world
/// position `(cx, cy)`; returns the pixels and the object's ground-truth mask.
fn render(w: u32, h: u32, ox: f64, oy: f64, obj: (f64, f64, f64, f64)) -> (Vec<u8>, Mask) {
    let mut img = vec![0u8; (w * h * 3) as usize];
    let mut gt = vec![0u8; (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            let (wx, wy) = (x as f64 + 0.5 + ox, y as f64 + 0.5 + oy);
            let i = (y * w + x) as usize;
            let c = match object(wx, wy, obj.0, obj.1, obj.2, obj.3) {
                Some(c) => {
                    gt[i] = 1;
                    c
                }
                None => texture(wx, wy),
            };
            img[3 * i..3 * i + 3].copy_from_slice(&c);
        }
    }
    (img, Mask::from_full(w, h, &gt).unwrap())
}

#[test]
fn refinement_recovers_a_shape_inside_a_loose_box() {
    let (w, h) = (200, 150);
    let (img, gt) = render(w, h, 0.0, 0.0, (100.0, 75.0, 40.0, 28.0));
    let frame = Frame::rgb(&img, w, h).unwrap();
    // A loose, off-centre box: 20–30 % wider than the object on each axis.
    let b = BBox::new(52.0, 40.0, 108.0, 66.0);
    let filled = Mask::from_bbox(&b).iou(&gt);
    let m = refine_box(&frame, &b, &RefineConfig::default())
        .unwrap()
        .expect("a mask");
    let iou = m.iou(&gt);
    assert!(filled < 0.6, "the filled box is a weak answer: {filled}");
    assert!(
        iou >= 0.85,
        "refined IoU {iou} (filled box {filled}); a filled box would fail this"
    );
}

#[test]
fn refinement_rejects_bad_settings_and_degenerate_boxes() {
    let (img, _) = render(40, 30, 0.0, 0.0, (20.0, 15.0, 8.0, 6.0));
    let f = Frame::rgb(&img, 40, 30).unwrap();
    let bad = RefineConfig {
        max_side: 0,
        ..RefineConfig::default()
    };
    assert!(refine_box(&f, &BBox::new(5.0, 5.0, 20.0, 20.0), &bad).is_err());
    let cfg = RefineConfig::default();
    // Outside the frame, empty, non-finite: no mask, no panic.
    for b in [
        BBox::new(100.0, 100.0, 10.0, 10.0),
        BBox::new(5.0, 5.0, 0.0, 0.0),
        BBox::new(f64::NAN, 5.0, 10.0, 10.0),
    ] {
        assert_eq!(refine_box(&f, &b, &cfg).unwrap(), None, "{b:?}");
    }
    // A box covering the whole frame still works (the border stands in for the ring).
    assert!(refine_box(&f, &BBox::new(0.0, 0.0, 40.0, 30.0), &cfg).is_ok());
}

/// A camera panning right and down over the texture while the object moves left.
fn panning_frame(t: u32, w: u32, h: u32) -> (Vec<u8>, Mask) {
    let t = t as f64;
    render(
        w,
        h,
        3.0 * t,
        1.5 * t,
        (150.0 + 3.0 * t - 4.0 * t, 100.0 + 1.5 * t, 22.0, 15.0),
    )
}

#[test]
fn moving_detector_finds_the_object_not_the_panning_background() {
    let (w, h) = (240, 160);
    for cue in [MotionCue::Flow, MotionCue::Background] {
        let mut det = MovingCameraDetector::new(MovingConfig {
            cue,
            ..MovingConfig::default()
        })
        .unwrap();
        let mut judge = CameraJudge::new();
        let mut hits = 0;
        let frames = 14;
        for t in 0..frames {
            let (img, gt) = panning_frame(t, w, h);
            let f = Frame::rgb(&img, w, h).unwrap();
            judge.observe(&f);
            let dets = det.detect(&f).unwrap();
            if t < 6 {
                continue; // the background model is still learning its history
            }
            let best = dets
                .iter()
                .filter_map(|d| d.mask.as_ref())
                .map(|m| m.iou(&gt))
                .fold(0.0, f64::max);
            if best >= 0.5 {
                hits += 1;
            }
            // Nothing large on the background: every detection overlaps the object.
            for d in &dets {
                let m = d.mask.as_ref().unwrap();
                let outside = m.area() - m.intersection(&gt);
                assert!(
                    outside as f64 <= 0.5 * gt.area() as f64,
                    "{cue:?}, frame {t}: a detection with {outside} px off the object"
                );
            }
        }
        assert!(
            hits >= 6,
            "{cue:?}: object found in {hits} of {} frames",
            frames - 6
        );
        assert_eq!(judge.moving(), Some(true));
        assert_eq!(
            det.resets(),
            0,
            "{cue:?}: the pan is an easy motion to follow"
        );
    }
}

#[test]
fn the_flow_cue_finds_the_object_from_the_second_frame() {
    // The flow needs one earlier frame and no history: the object is found from frame 2 on,
    // where the background model has not learnt the scene yet.
    let (w, h) = (240, 160);
    let mut flow = MovingCameraDetector::new(MovingConfig::default()).unwrap();
    let mut model = MovingCameraDetector::new(MovingConfig {
        cue: MotionCue::Background,
        ..MovingConfig::default()
    })
    .unwrap();
    assert_eq!(flow.warmup(), (0, 1));
    for t in 0..3 {
        let (img, gt) = panning_frame(t, w, h);
        let f = Frame::rgb(&img, w, h).unwrap();
        let best = |dets: Vec<shapetrack::Detection>| {
            dets.iter()
                .filter_map(|d| d.mask.as_ref())
                .map(|m| m.iou(&gt))
                .fold(0.0, f64::max)
        };
        let (a, b) = (
            best(flow.detect(&f).unwrap()),
            best(model.detect(&f).unwrap()),
        );
        if t == 0 {
            assert_eq!(a, 0.0, "nothing on the first frame");
        } else {
            assert!(a >= 0.7, "frame {t}: the flow cue's IoU {a}");
            assert_eq!(
                b, 0.0,
                "frame {t}: the background model is still warming up"
            );
        }
    }
    assert_eq!(flow.warmup(), (1, 1));
}

/// A fine high-contrast texture (detail at 4–6 px), different everywhere.
fn fine_texture(x: f64, y: f64) -> [u8; 3] {
    let a = (x * 1.1).sin() * (y * 0.9).cos() + 0.5 * ((x + y) * 0.7).sin();
    let b = ((x - 0.5 * y) * 0.8).sin() + 0.3 * (x * 0.05).cos();
    let v = |t: f64| (128.0 + 80.0 * t).clamp(0.0, 255.0) as u8;
    [v(a), v(b), v(0.5 * (a - b))]
}

/// Share of the working frame that the detector called foreground last.
fn foreground_share(det: &MovingCameraDetector) -> f64 {
    let (fg, w, h) = det.foreground();
    fg.iter().filter(|&&v| v != 0).count() as f64 / (w * h).max(1) as f64
}

#[test]
fn a_fine_texture_under_a_sub_pixel_pan_is_not_foreground() {
    // The warped background model is resampled (bilinearly) at every frame, which blurs fine
    // detail, and a sub-pixel pan lands between pixels: on fine texture both leave
    // differences above the threshold along every edge. The background cue's tolerance
    // allows for them; the flow cue must not see motion there either.
    let (w, h) = (240, 160);
    let run = |cue: MotionCue, tolerance: u32| {
        let cfg = MovingConfig {
            cue,
            tolerance,
            refine: None,
            ..MovingConfig::default()
        };
        let mut det = MovingCameraDetector::new(cfg).unwrap();
        let (mut worst, mut dets): (f64, usize) = (0.0, 0);
        for t in 0..14 {
            let mut img = vec![0u8; (w * h * 3) as usize];
            let (ox, oy) = (2.37 * t as f64, 1.13 * t as f64);
            for y in 0..h {
                for x in 0..w {
                    let i = (y * w + x) as usize * 3;
                    let c = fine_texture(x as f64 + ox, y as f64 + oy);
                    img[i..i + 3].copy_from_slice(&c);
                }
            }
            let n = det.detect(&Frame::rgb(&img, w, h).unwrap()).unwrap().len();
            if t >= 5 {
                worst = worst.max(foreground_share(&det));
                dets += n;
            }
        }
        (worst, dets, det.resets())
    };
    // The flow cue has no model to resample: it compares flow with the camera's motion.
    let (flow, dets, resets) = run(MotionCue::Flow, 0);
    assert_eq!(resets, 0);
    assert_eq!(dets, 0, "flow cue: detections on a still background");
    assert!(flow < 0.005, "flow cue: {:.1} % foreground", 100.0 * flow);
    let (with, dets, resets) = run(MotionCue::Background, MovingConfig::default().tolerance);
    assert_eq!(resets, 0);
    assert_eq!(dets, 0, "detections on a still background");
    assert!(
        with < 0.005,
        "{:.1} % of the frame foreground",
        100.0 * with
    );
    let (without, _, _) = run(MotionCue::Background, 0);
    assert!(
        without > 5.0 * with.max(0.002),
        "without the tolerance {:.1} % (with {:.1} %): the test no longer shows what it guards",
        100.0 * without,
        100.0 * with
    );
}

#[test]
fn the_ghost_of_the_first_frames_object_is_cleared() {
    // The camera follows the object (it stays put in the image while the textured world pans
    // by), so the first frames' model holds the object at a spot of the world that it leaves
    // for good: the uncovered background there differs from the model (a "ghost") until the
    // steady-colour rule replaces it.
    let (w, h) = (240, 160);
    // A background-model effect: the flow cue keeps no model of the first frames.
    let run = |ghost_frames: u32| {
        let mut det = MovingCameraDetector::new(MovingConfig {
            cue: MotionCue::Background,
            ghost_frames,
            ..MovingConfig::default()
        })
        .unwrap();
        let (mut off, mut hits) = (0usize, 0usize);
        for t in 0..32u32 {
            let (ox, oy) = (3.0 * t as f64, 1.0 * t as f64);
            let (img, gt) = render(w, h, ox, oy, (120.0 + ox, 80.0 + oy, 22.0, 15.0));
            let dets = det.detect(&Frame::rgb(&img, w, h).unwrap()).unwrap();
            // By frame 26 every pixel of the first frames' spot has been uncovered for 8
            // frames or more.
            if t < 26 {
                continue;
            }
            for m in dets.iter().filter_map(|d| d.mask.as_ref()) {
                // Mostly elsewhere than the object: the ghost's own blob.
                off += ((m.intersection(&gt) as f64) < 0.2 * m.area() as f64) as usize;
                hits += (m.iou(&gt) >= 0.5) as usize;
            }
        }
        (off, hits, det.resets())
    };
    let (off, hits, resets) = run(MovingConfig::default().ghost_frames);
    assert_eq!(resets, 0);
    assert_eq!(
        off, 0,
        "detections off the object (the ghost) in the last 6 frames"
    );
    assert!(
        hits >= 5,
        "the object itself found in {hits} of the last 6 frames"
    );
    let (off_without, _, _) = run(0);
    assert!(
        off_without >= 3,
        "without ghost removal {off_without} off-object detections: the test no longer shows what it guards"
    );
}

#[test]
fn frames_of_any_size_are_detected_without_panicking() {
    // Thin, tiny and odd frames reach every stage of both cues (a flow too small for one
    // patch, a camera fit with no grid samples, a working frame of one pixel).
    for (w, h) in [(1u32, 1u32), (3, 2), (7, 200), (300, 5), (17, 13), (61, 47)] {
        for cue in [MotionCue::Flow, MotionCue::Background] {
            let mut det = MovingCameraDetector::new(MovingConfig {
                cue,
                ..MovingConfig::default()
            })
            .unwrap();
            for t in 0..4 {
                let (img, _) = render(
                    w,
                    h,
                    2.0 * t as f64,
                    0.0,
                    (w as f64 / 2.0, h as f64 / 2.0, 3.0, 2.0),
                );
                let dets = det.detect(&Frame::rgb(&img, w, h).unwrap()).unwrap();
                for d in &dets {
                    let m = d.mask.as_ref().expect("a mask");
                    assert!(
                        m.x() >= 0 && m.y() >= 0,
                        "{w}x{h} {cue:?}: mask off the frame"
                    );
                    assert!(m.x() as u32 + m.width() <= w && m.y() as u32 + m.height() <= h);
                }
            }
        }
    }
}

#[test]
fn a_cut_resets_the_moving_detector_without_spraying_detections() {
    let (w, h) = (200, 140);
    let mut det = MovingCameraDetector::new(MovingConfig::default()).unwrap();
    for t in 0..6 {
        let (img, _) = panning_frame(t, w, h);
        det.detect(&Frame::rgb(&img, w, h).unwrap()).unwrap();
    }
    // A cut: a different place of the world, far away.
    let (img, _) = render(w, h, 5000.0, 3000.0, (0.0, 0.0, 1.0, 1.0));
    let dets = det.detect(&Frame::rgb(&img, w, h).unwrap()).unwrap();
    assert!(dets.is_empty(), "{} detections after a cut", dets.len());
    assert!(det.resets() >= 1);
}

#[test]
fn a_static_camera_is_judged_static() {
    let (w, h) = (160, 120);
    let mut judge = CameraJudge::new();
    for t in 0..5 {
        let (img, _) = render(w, h, 0.0, 0.0, (40.0 + 3.0 * t as f64, 60.0, 12.0, 9.0));
        judge.observe(&Frame::rgb(&img, w, h).unwrap());
    }
    assert_eq!(judge.moving(), Some(false));
}

// ---------------------------------------------------------------------------------------------
// The CLI

fn scratch(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn detect(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_shapetrack"))
        .arg("detect")
        .args(args)
        .output()
        .unwrap()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A folder of `n` panning PNG frames.
fn png_folder(name: &str, n: u32) -> PathBuf {
    let d = scratch(name);
    let frames = d.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    let (w, h) = (120, 90);
    for t in 0..n {
        let (img, _) = render(
            w,
            h,
            2.0 * t as f64,
            0.0,
            (60.0 + 2.0 * t as f64 - 3.0 * t as f64, 45.0, 20.0, 14.0),
        );
        image::save_buffer(
            frames.join(format!("{:03}.png", t + 1)),
            &img,
            w,
            h,
            image::ExtendedColorType::Rgb8,
        )
        .unwrap();
    }
    d
}

fn assert_clean_failure(out: &std::process::Output, what: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{what}: succeeded");
    assert!(!err.contains("panicked"), "{what}: panicked: {err}");
    assert!(err.contains("error"), "{what}: no error message: {err}");
}

#[test]
fn cli_refines_boxes_into_mots_that_reads_back() {
    let d = png_folder("detect_cli_refine", 3);
    let boxes = d.join("boxes.txt");
    std::fs::write(
        &boxes,
        "1,-1,35,27,50,36,0.9,-1,-1,-1\n2,-1,33,27,50,36,0.8,-1,-1,-1\n3,-1,31,27,50,36,0.7,-1,-1,-1\n",
    )
    .unwrap();
    let out_path = d.join("masks.txt");
    for detector in ["refine", "auto"] {
        let out = detect(&[
            "--frames",
            s(&d.join("frames")),
            "--detector",
            detector,
            "--boxes",
            s(&boxes),
            "--out",
            s(&out_path),
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let text = read_text(&out_path).unwrap();
        let recs = parse_mots(&text, "masks.txt").unwrap();
        assert_eq!(recs.len(), 3, "{text}");
        for (k, r) in recs.iter().enumerate() {
            assert_eq!(r.frame, k as u32 + 1);
            let m = r.mask.as_ref().unwrap();
            assert_eq!((m.width, m.height), (120, 90));
            // A mask, not the filled box: smaller than the box's 50×36.
            assert!(m.area() > 0 && m.area() < 50 * 36, "area {}", m.area());
        }
    }
}

#[test]
fn cli_detectors_without_boxes_write_valid_mots() {
    let d = png_folder("detect_cli_auto", 8);
    for detector in ["auto", "moving", "background"] {
        let out_path = d.join(format!("{detector}.txt"));
        let out = detect(&[
            "--frames",
            s(&d.join("frames")),
            "--detector",
            detector,
            "--out",
            s(&out_path),
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let recs = parse_mots(&read_text(&out_path).unwrap(), "out").unwrap();
        assert!(recs.iter().all(|r| (1..=8).contains(&r.frame)));
    }
}

#[test]
fn cli_bad_inputs_fail_cleanly() {
    let d = png_folder("detect_cli_bad", 2);
    let frames = d.join("frames");
    let out_path = d.join("out.txt");
    let empty = d.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let out = detect(&["--frames", s(&empty), "--out", s(&out_path)]);
    assert_clean_failure(&out, "empty folder");
    assert!(String::from_utf8_lossy(&out.stderr).contains("no .jpg or .png"));

    let out = detect(&["--frames", s(&frames)]);
    assert_clean_failure(&out, "missing --out");

    let bad = d.join("bad.txt");
    std::fs::write(&bad, "1,-1,oops,2,3,4,1\n").unwrap();
    let out = detect(&[
        "--frames",
        s(&frames),
        "--boxes",
        s(&bad),
        "--out",
        s(&out_path),
    ]);
    assert_clean_failure(&out, "bad boxes file");
    assert!(String::from_utf8_lossy(&out.stderr).contains("bad.txt:1:3"));

    let out = detect(&[
        "--frames",
        s(&frames),
        "--detector",
        "refine",
        "--out",
        s(&out_path),
    ]);
    assert_clean_failure(&out, "refine without boxes");

    let broken = d.join("broken");
    std::fs::create_dir_all(&broken).unwrap();
    std::fs::write(broken.join("001.png"), b"not a png at all").unwrap();
    let out = detect(&["--frames", s(&broken), "--out", s(&out_path)]);
    assert_clean_failure(&out, "unreadable image");
    assert!(String::from_utf8_lossy(&out.stderr).contains("001.png"));

    let out = detect(&["--frames", s(&d.join("missing")), "--out", s(&out_path)]);
    assert_clean_failure(&out, "missing folder");
    assert!(!out_path.exists(), "nothing written on failure");
}

#[test]
fn a_detector_is_chosen_by_kind_and_boxes() {
    use shapetrack::segment::{ChoiceError, VideoDetector};
    type D = VideoDetector;
    let boxes = || Some(vec![Vec::new(), Vec::new()]);
    for (name, kind) in VideoDetectorKind::ALL {
        assert_eq!(VideoDetectorKind::parse(name), Some(kind));
        // The name the CLI takes (clap's, from the variant) is the one Python parses.
        let cli = clap::ValueEnum::to_possible_value(&kind).unwrap();
        assert_eq!(cli.get_name(), name);
        assert_eq!(
            kind.wants_model(),
            matches!(name, "auto" | "refine"),
            "{name}"
        );
    }
    assert_eq!(VideoDetectorKind::parse("Auto"), None);
    // With boxes, every refining kind (the automatic ones too) refines them.
    for kind in [
        VideoDetectorKind::Auto,
        VideoDetectorKind::AutoMotion,
        VideoDetectorKind::Refine,
        VideoDetectorKind::RefineColour,
    ] {
        assert_eq!(D::choose(kind, boxes()).unwrap().name(), "refine");
    }
    assert!(matches!(
        D::choose(VideoDetectorKind::Refine, None),
        Err(ChoiceError::RefineWithoutBoxes)
    ));
    assert!(matches!(
        D::choose(VideoDetectorKind::Background, boxes()),
        Err(ChoiceError::BoxesNotUsed)
    ));
    assert_eq!(
        D::choose(VideoDetectorKind::AutoMotion, None)
            .unwrap()
            .name(),
        "auto (judging the camera)"
    );
    assert_eq!(
        D::choose(VideoDetectorKind::Moving, None).unwrap().name(),
        "moving"
    );
}
