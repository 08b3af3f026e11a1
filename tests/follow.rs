//! Following a user-given shape (issue 12): the core follower on a generated sequence, shape-
//! aware interpolation against a box lerp, the `follow` CLI's MOTS output and its errors.
//! Everything is generated here (small frames), so each test takes a few seconds in debug.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::follow::{
    follow_sequence, interpolate_masks, rasterize_polygon, FollowConfig, FollowError, Follower,
};
use shapetrack::frame::{BBox, Detection, Frame, Mask, Point};
use shapetrack::io::motchallenge::parse_mots;
use shapetrack::segment::{Crop, Saliency, OUTPUT_LEN, SIDE};
use std::path::{Path, PathBuf};
use std::process::Command;

const W: u32 = 160;
const H: u32 = 120;

/// A repeatable value in [0, 1) for integer cell coordinates (a hash, not an RNG, so any
/// pixel can be rendered independently).
fn hash(x: i64, y: i64, salt: u64) -> f64 {
    let mut h = (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
        ^ salt.wrapping_mul(0x1656_67B1_9E37_79F9);
    h ^= h >> 31;
    h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    h ^= h >> 29;
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// The target's pose in frame `i`: centre and angle (radians).
fn pose(i: usize) -> (Point, f64) {
    let t = i as f64;
    (Point::new(45.0 + 3.0 * t, 55.0 + 1.2 * t), 0.05 * t)
}

/// Half sizes of the target rectangle.
const HW: f64 = 22.0;
const HH: f64 = 14.0;

/// Object coordinates of frame pixel centre `(x, y)` in frame `i`.
fn to_object(x: f64, y: f64, i: usize) -> Point {
    let (c, a) = pose(i);
    let (dx, dy) = (x - c.x, y - c.y);
    Point::new(a.cos() * dx + a.sin() * dy, -a.sin() * dx + a.cos() * dy)
}

/// Frame `i`: a reddish, blotchy rectangle (texture fixed to the object, so it moves and
/// turns with it) over a blue-green blotchy background that stays put.
fn render(i: usize) -> (Vec<u8>, Mask) {
    let mut rgb = Vec::with_capacity((W * H * 3) as usize);
    let mut truth = vec![0u8; (W * H) as usize];
    for y in 0..H {
        for x in 0..W {
            let o = to_object(x as f64 + 0.5, y as f64 + 0.5, i);
            let inside = o.x.abs() < HW && o.y.abs() < HH;
            let px = if inside {
                truth[(y * W + x) as usize] = 1;
                let v = hash((o.x / 4.0).floor() as i64, (o.y / 4.0).floor() as i64, 7);
                [
                    (150.0 + 100.0 * v) as u8,
                    (40.0 + 120.0 * v) as u8,
                    (30.0 + 60.0 * v) as u8,
                ]
            } else {
                let v = hash((x / 5) as i64, (y / 5) as i64, 3);
                [
                    (20.0 + 60.0 * v) as u8,
                    (70.0 + 120.0 * v) as u8,
                    (90.0 + 130.0 * v) as u8,
                ]
            };
            rgb.extend_from_slice(&px);
        }
    }
    (rgb, Mask::from_full(W, H, &truth).unwrap())
}

#[test]
fn follower_keeps_a_moving_turning_shape_that_copying_loses() {
    let n = 16;
    let scenes: Vec<(Vec<u8>, Mask)> = (0..n).map(render).collect();
    let frames: Vec<Frame> = scenes
        .iter()
        .map(|(rgb, _)| Frame::rgb(rgb, W, H).unwrap())
        .collect();
    // Start in the middle so both directions are exercised.
    let init = 5;
    let steps = follow_sequence(
        &frames,
        init,
        &scenes[init].1,
        None,
        &FollowConfig::default(),
    )
    .unwrap();
    assert_eq!(steps.len(), n);
    let ious: Vec<f64> = steps
        .iter()
        .zip(&scenes)
        .map(|(s, (_, t))| s.mask.iou(t))
        .collect();
    let copy: Vec<f64> = scenes.iter().map(|(_, t)| scenes[init].1.iou(t)).collect();
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let worst = ious.iter().copied().fold(1.0, f64::min);
    assert!(
        worst >= 0.7 && mean(&ious) >= 0.8,
        "follower IoU per frame {ious:.3?}"
    );
    // Copying the first mask: about half overlap on average, none at the far ends.
    let copy_worst = copy.iter().copied().fold(1.0, f64::min);
    assert!(
        mean(&copy) < 0.55 && copy_worst < 0.2 && mean(&ious) > mean(&copy) + 0.25,
        "copy baseline {copy:.3?}, follower {ious:.3?}"
    );
    for s in &steps {
        assert!(!s.lost && !s.stopped && (0.0..=1.0).contains(&s.confidence));
    }
}

/// Follows the generated target from frame 0 with `detections` per frame; returns each
/// frame's (IoU with the truth, whether a detection's mask was taken).
fn follow_with(detections: &[Vec<Detection>], cfg: &FollowConfig) -> Vec<(f64, bool)> {
    let scenes: Vec<(Vec<u8>, Mask)> = (0..detections.len()).map(render).collect();
    let frames: Vec<Frame> = scenes
        .iter()
        .map(|(rgb, _)| Frame::rgb(rgb, W, H).unwrap())
        .collect();
    let steps = follow_sequence(&frames, 0, &scenes[0].1, Some(detections), cfg).unwrap();
    steps
        .iter()
        .zip(&scenes)
        .skip(1)
        .map(|(s, (_, t))| (s.mask.iou(t), s.from_detection))
        .collect()
}

#[test]
fn detections_replace_the_followed_mask_only_when_they_agree_closely() {
    let n = 10;
    let truth: Vec<Mask> = (0..n).map(|i| render(i).1).collect();
    // A detector that finds the target exactly: its outline is taken in every frame.
    let exact: Vec<Vec<Detection>> = truth
        .iter()
        .map(|t| vec![Detection::from_mask(t.clone(), 0.9)])
        .collect();
    let got = follow_with(&exact, &FollowConfig::default());
    assert!(got.iter().all(|&(iou, det)| det && iou > 0.99), "{got:.3?}");
    // A detector whose mask is 10 px off (IoU about 0.63 with the target: a shadow or a
    // neighbour merged in): never taken, and the follower is not dragged along with it. Taken
    // at IoU 0.5, such masks led the follower off the target on DAVIS (mean J 0.60 → 0.47).
    let off: Vec<Vec<Detection>> = truth
        .iter()
        .map(|t| vec![Detection::from_mask(t.translated(10, 0), 0.9)])
        .collect();
    let iou_off = truth[1].iou(&truth[1].translated(10, 0));
    assert!((0.55..0.7).contains(&iou_off), "{iou_off}");
    let got = follow_with(&off, &FollowConfig::default());
    assert!(
        got.iter().all(|&(iou, det)| !det && iou >= 0.7),
        "{got:.3?}"
    );
    // At a looser threshold the same detections are taken.
    let loose = FollowConfig {
        detection_iou: 0.5,
        ..FollowConfig::default()
    };
    assert!(follow_with(&off, &loose).iter().any(|&(_, det)| det));
}

#[test]
fn a_loose_detection_is_taken_only_near_the_followed_outline() {
    let n = 10;
    let truth: Vec<Mask> = (0..n).map(|i| render(i).1).collect();
    // A detector that takes in a shadow: the target and the same shape 6 px below it. It
    // agrees closely overall (IoU about 0.82 with the target, above the 0.8 at which a
    // detection is taken) but its lower 6 px are background.
    let shadowed: Vec<Vec<Detection>> = truth
        .iter()
        .map(|t| {
            let (x0, y0) = (t.x(), t.y());
            let (w, h) = (t.width(), t.height() + 6);
            let data = (0..h as i32)
                .flat_map(|y| (0..w as i32).map(move |x| (x0 + x, y0 + y)))
                .map(|(x, y)| u8::from(t.get(x, y) || t.get(x, y - 6)))
                .collect();
            vec![Detection::from_mask(
                Mask::new(x0, y0, w, h, data).unwrap(),
                0.9,
            )]
        })
        .collect();
    let iou_det = truth[1].iou(shadowed[1][0].mask.as_ref().unwrap());
    assert!((0.8..0.86).contains(&iou_det), "{iou_det}");
    // Taken (on most frames: the first ones' followed mask can be a little off the 0.8), but
    // not the shadow: within a band of the followed outline, and not where the colour model
    // sees background. Taken whole, the result scores the detection's own 0.82; cut to the
    // band alone, the shadow is taken a band further each frame (0.82 by frame 6).
    let got = follow_with(&shadowed, &FollowConfig::default());
    assert!(
        got.iter().filter(|g| g.1).count() >= got.len() / 2,
        "{got:.3?}"
    );
    assert!(got.iter().all(|&(iou, _)| iou >= 0.9), "{got:.3?}");
}

#[test]
fn follower_rejects_bad_input_with_typed_errors() {
    let (rgb, truth) = render(0);
    let f = Frame::rgb(&rgb, W, H).unwrap();
    let frames = [f];
    let cfg = FollowConfig::default();
    assert_eq!(
        follow_sequence(&frames, 0, &Mask::empty(), None, &cfg).unwrap_err(),
        FollowError::EmptyMask
    );
    assert!(matches!(
        follow_sequence(&frames, 3, &truth, None, &cfg),
        Err(FollowError::FrameOutOfRange { frame: 3, len: 1 })
    ));
    assert_eq!(
        follow_sequence(&[], 0, &truth, None, &cfg).unwrap_err(),
        FollowError::NoFrames
    );
    let outside = truth.translated(W as i32, 0);
    assert!(matches!(
        follow_sequence(&frames, 0, &outside, None, &cfg),
        Err(FollowError::MaskOutside { .. })
    ));
    assert!(matches!(
        shapetrack::follow::mask_from_bitmap(W, H, W - 1, H, &vec![1; ((W - 1) * H) as usize]),
        Err(FollowError::MaskSize { .. })
    ));
    let small = vec![0u8; 30 * 20 * 3];
    let other = Frame::rgb(&small, 30, 20).unwrap();
    assert!(matches!(
        follow_sequence(&[frames[0], other], 0, &truth, None, &cfg),
        Err(FollowError::FrameSize { index: 1, .. })
    ));
}

/// An L shape at `centre`, `scale`, turned by `angle`.
fn l_shape(centre: Point, scale: f64, angle: f64) -> Vec<Point> {
    let pts = [
        (-1.0, -1.0),
        (0.0, -1.0),
        (0.0, 0.5),
        (1.2, 0.5),
        (1.2, 1.0),
        (-1.0, 1.0),
    ];
    pts.iter()
        .map(|&(x, y)| {
            let (x, y) = (x * scale, y * scale);
            Point::new(
                centre.x + angle.cos() * x - angle.sin() * y,
                centre.y + angle.sin() * x + angle.cos() * y,
            )
        })
        .collect()
}

#[test]
fn interpolated_midpoint_beats_a_box_lerp() {
    let (w, h) = (200, 160);
    let a = rasterize_polygon(&l_shape(Point::new(50.0, 60.0), 20.0, 0.0), w, h);
    let b = rasterize_polygon(&l_shape(Point::new(140.0, 90.0), 30.0, 0.4), w, h);
    let truth = rasterize_polygon(&l_shape(Point::new(95.0, 75.0), 25.0, 0.2), w, h);
    let mid = interpolate_masks(&a, &b, 0.5, w, h).unwrap();
    let (ba, bb) = (a.bbox(), b.bbox());
    let lerp = BBox::from_xyxy(
        0.5 * (ba.x + bb.x),
        0.5 * (ba.y + bb.y),
        0.5 * (ba.x2() + bb.x2()),
        0.5 * (ba.y2() + bb.y2()),
    );
    let boxed = Mask::from_bbox(&lerp);
    let (ours, theirs) = (mid.iou(&truth), boxed.iou(&truth));
    assert!(ours >= 0.85, "interpolated IoU {ours:.3}");
    assert!(
        ours > theirs + 0.1,
        "ours {ours:.3} vs box lerp {theirs:.3}"
    );
    // The ends are the keyframes themselves; bad positions and empty keyframes are errors.
    assert_eq!(interpolate_masks(&a, &b, 0.0, w, h).unwrap(), a.tight());
    assert!(interpolate_masks(&a, &b, 1.5, w, h).is_err());
    assert!(interpolate_masks(&Mask::empty(), &b, 0.5, w, h).is_err());
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("shapetrack-follow-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write_png_gray(path: &Path, w: u32, h: u32, data: Vec<u8>) {
    image::GrayImage::from_raw(w, h, data)
        .unwrap()
        .save(path)
        .unwrap();
}

fn follow_cli(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_shapetrack"))
        .arg("follow")
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn cli_writes_mots_that_reads_back_and_refuses_bad_input() {
    let dir = scratch("cli");
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    let n = 6;
    let mut truth = Vec::new();
    for i in 0..n {
        let (rgb, t) = render(i);
        image::RgbImage::from_raw(W, H, rgb)
            .unwrap()
            .save(frames.join(format!("{:03}.png", i + 1)))
            .unwrap();
        truth.push(t);
    }
    let init = dir.join("init.png");
    write_png_gray(
        &init,
        W,
        H,
        truth[2].to_full(W, H).iter().map(|v| v * 255).collect(),
    );
    let out = dir.join("track.txt");
    let s = |p: &Path| p.to_str().unwrap().to_owned();
    let (fr, ini, o) = (s(&frames), s(&init), s(&out));
    let res = follow_cli(&[
        "--frames",
        &fr,
        "--init",
        &ini,
        "--init-frame",
        "3",
        "--out",
        &o,
    ]);
    assert!(
        res.status.success(),
        "{}",
        String::from_utf8_lossy(&res.stderr)
    );
    let recs = parse_mots(&std::fs::read_to_string(&out).unwrap(), "track.txt").unwrap();
    assert_eq!(recs.len(), n);
    for (k, r) in recs.iter().enumerate() {
        assert_eq!((r.frame, r.id), (k as u32 + 1, 1));
        let m = r.mask_bitmap().unwrap();
        assert!(
            m.iou(&truth[k]) > 0.6,
            "frame {} IoU {}",
            k + 1,
            m.iou(&truth[k])
        );
    }

    // Bad input: a clear error, a failure exit, no panic.
    let empty = dir.join("empty.png");
    write_png_gray(&empty, W, H, vec![0; (W * H) as usize]);
    let wrong = dir.join("wrong.png");
    write_png_gray(&wrong, W / 2, H, vec![255; (W / 2 * H) as usize]);
    let no_frames = dir.join("none");
    std::fs::create_dir_all(&no_frames).unwrap();
    let (em, wr, nf) = (s(&empty), s(&wrong), s(&no_frames));
    let cases: [(&[&str], &str); 5] = [
        (&["--frames", &fr, "--init", &em, "--out", &o], "empty"),
        (&["--frames", &fr, "--init", &wr, "--out", &o], "80x120"),
        (
            &[
                "--frames",
                &fr,
                "--init",
                &ini,
                "--init-frame",
                "0",
                "--out",
                &o,
            ],
            "out of range",
        ),
        (
            &[
                "--frames",
                &fr,
                "--init",
                &ini,
                "--init-frame",
                "7",
                "--out",
                &o,
            ],
            "out of range",
        ),
        (
            &["--frames", &nf, "--init", &ini, "--out", &o],
            "no .jpg or .png",
        ),
    ];
    for (args, expect) in cases {
        let res = follow_cli(args);
        let err = String::from_utf8_lossy(&res.stderr);
        assert!(!res.status.success(), "{args:?} succeeded");
        assert!(err.contains(expect), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
    // A 16-bit initial mask whose target is id 1 (as instance maps store it) keeps every
    // pixel: written back unchanged at its own frame.
    let init16 = dir.join("init16.png");
    let full = truth[2].to_full(W, H);
    image::ImageBuffer::<image::Luma<u16>, _>::from_raw(
        W,
        H,
        full.iter().map(|&v| u16::from(v)).collect::<Vec<_>>(),
    )
    .unwrap()
    .save(&init16)
    .unwrap();
    let out16 = dir.join("track16.txt");
    let res = follow_cli(&[
        "--frames",
        &fr,
        "--init",
        &s(&init16),
        "--init-frame",
        "3",
        "--out",
        &s(&out16),
        "--model",
        "none",
    ]);
    assert!(
        res.status.success(),
        "{}",
        String::from_utf8_lossy(&res.stderr)
    );
    let recs = parse_mots(&std::fs::read_to_string(&out16).unwrap(), "track16.txt").unwrap();
    let at_init = recs
        .iter()
        .find(|r| r.frame == 3)
        .unwrap()
        .mask_bitmap()
        .unwrap();
    assert_eq!(
        at_init.area(),
        truth[2].area(),
        "every pixel of the 16-bit mask kept"
    );
    // --out over a file the run reads (the initial mask, a frame) is refused, the file kept.
    let frame3 = frames.join("003.png");
    for target in [&init, &frame3] {
        let before = std::fs::read(target).unwrap();
        let t = s(target);
        let res = follow_cli(&[
            "--frames",
            &fr,
            "--init",
            &ini,
            "--init-frame",
            "3",
            "--out",
            &t,
        ]);
        let err = String::from_utf8_lossy(&res.stderr);
        assert!(!res.status.success(), "--out {t} succeeded");
        assert!(err.contains("is an input of this run"), "{err}");
        assert_eq!(std::fs::read(target).unwrap(), before, "{t} changed");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A stand-in for the segmentation network that sees `shown`: its map is 1 on the crop's
/// pixels inside `shown` and 0 elsewhere (the real network is tested in tests/segment_model.rs).
fn oracle_map(crop: &Crop, shown: &Mask) -> Vec<f32> {
    let mut out = vec![0f32; OUTPUT_LEN];
    for v in 0..SIDE {
        for u in 0..SIDE {
            let x = crop.x as f64 + (u as f64 + 0.5) * crop.w as f64 / SIDE as f64;
            let y = crop.y as f64 + (v as f64 + 0.5) * crop.h as f64 / SIDE as f64;
            if shown.get(x.floor() as i32, y.floor() as i32) {
                out[v * SIDE + u] = 1.0;
            }
        }
    }
    out
}

/// Follows the generated target through `n` frames with the learned map of `shown(i)` in each;
/// returns each frame's (IoU with the truth, whether the learned outline was taken).
fn follow_learned(n: usize, cfg: &FollowConfig, shown: impl Fn(&Mask) -> Mask) -> Vec<(f64, bool)> {
    let scenes: Vec<(Vec<u8>, Mask)> = (0..n).map(render).collect();
    let first = Frame::rgb(&scenes[0].0, W, H).unwrap();
    let mut f = Follower::new(&first, &scenes[0].1, cfg.clone()).unwrap();
    scenes[1..]
        .iter()
        .map(|(rgb, truth)| {
            let frame = Frame::rgb(rgb, W, H).unwrap();
            let crop = f.learned_crop().expect("a running follower has a crop");
            let sal = Saliency::new(crop, &oracle_map(&crop, &shown(truth)), true).unwrap();
            let s = f.step_learned(&frame, &[], Some(&sal)).unwrap();
            (s.mask.iou(truth), s.from_learned)
        })
        .collect()
}

#[test]
fn the_learned_outline_is_taken_where_it_agrees_and_only_while_the_follower_is_unsure() {
    let always = FollowConfig {
        learned_below: 1.0,
        learned_box_slack: None,
        learned_carry_iou: 0.0,
        ..FollowConfig::default()
    };
    // Consulted on every frame, a map of the object itself is taken and holds the object.
    let got = follow_learned(10, &always, Mask::clone);
    assert!(got.iter().all(|&(iou, l)| l && iou > 0.95), "{got:.3?}");
    // The net is consulted only while the follower's confidence is below `learned_below`
    // (by default 1: on every frame); at 0 never, and the follower's own outline stands.
    let got = follow_learned(10, &FollowConfig::default(), Mask::clone);
    assert!(got.iter().all(|&(iou, l)| l && iou > 0.95), "{got:.3?}");
    let never = FollowConfig {
        learned_below: 0.0,
        ..FollowConfig::default()
    };
    let got = follow_learned(10, &never, Mask::clone);
    assert!(got.iter().all(|&(iou, l)| !l && iou > 0.8), "{got:.3?}");
    // A map of the object's left half (a crop that showed the network a part as the whole)
    // would lose half the outline: refused (`learned_max_shrink`), the outline is kept.
    let half = |t: &Mask| {
        let b = t.bbox();
        let keep = Mask::from_bbox(&BBox { w: b.w * 0.5, ..b });
        let bits: Vec<u8> = (0..H as i32)
            .flat_map(|y| (0..W as i32).map(move |x| (x, y)))
            .map(|(x, y)| u8::from(t.get(x, y) && keep.get(x, y)))
            .collect();
        Mask::from_full(W, H, &bits).unwrap()
    };
    let got = follow_learned(10, &always, half);
    assert!(got.iter().all(|&(iou, l)| !l && iou > 0.8), "{got:.3?}");
}

#[test]
fn a_learned_outline_that_takes_in_a_neighbour_is_refused_past_the_growth_bound() {
    // The network outlines the object and a neighbour touching it as one salient region (a
    // horse and its rider, a flock).
    let bounded = FollowConfig {
        learned_below: 1.0,
        learned_box_slack: None,
        learned_carry_iou: 0.0,
        learned_max_growth: 0.2,
        ..FollowConfig::default()
    };
    let got = follow_learned(10, &bounded, with_neighbour);
    assert!(got.iter().all(|&(iou, l)| !l && iou > 0.8), "{got:.3?}");
    // Without the bound (its default: only `learned_iou` limits growth) it is taken and the
    // followed outline grows onto the neighbour.
    let unbounded = FollowConfig {
        learned_max_growth: 1.0,
        ..bounded
    };
    let got = follow_learned(10, &unbounded, with_neighbour);
    assert!(got.iter().any(|&(iou, l)| l && iou < 0.8), "{got:.3?}");
}

/// The network's outline of the object with a neighbour touching it on the right (half the
/// object's box more), as one salient region.
fn with_neighbour(t: &Mask) -> Mask {
    let b = t.bbox();
    let n = Mask::from_bbox(&BBox {
        x: b.x + b.w - 1.0,
        w: b.w * 0.5,
        ..b
    });
    let bits: Vec<u8> = (0..H as i32)
        .flat_map(|y| (0..W as i32).map(move |x| (x, y)))
        .map(|(x, y)| u8::from(t.get(x, y) || n.get(x, y)))
        .collect();
    Mask::from_full(W, H, &bits).unwrap()
}

#[test]
fn a_learned_map_cut_to_the_followed_box_keeps_a_touching_neighbour_out() {
    // Cut to the follower's own box (+5 %) and not carried, the map's outline is taken on
    // every frame and the neighbour stays out: only the slack's strip of it is ever shown.
    // Never carried, not even while the follower is unsure (`learned_carry_below`, which
    // would carry the strip on this scene's frames of low confidence: the price it pays for
    // textureless objects, an_unsure_follower_carries_the_learned_outline).
    let cut = FollowConfig {
        learned_below: 1.0,
        learned_box_slack: Some(0.05),
        learned_carry_iou: 1.0,
        learned_carry_below: 0.0,
        ..FollowConfig::default()
    };
    let got = follow_learned(10, &cut, with_neighbour);
    assert!(got.iter().all(|&(iou, l)| l && iou > 0.88), "{got:.3?}");
    // Carried, the strip becomes the next frame's estimate and its box grows into the
    // neighbour a strip at a time.
    let carried = FollowConfig {
        learned_carry_iou: 0.0,
        ..cut.clone()
    };
    let got = follow_learned(10, &carried, with_neighbour);
    let last = got.last().unwrap().0;
    assert!(last < 0.8, "{got:.3?}");
    // Cut to the whole crop around the prediction (no box slack), as much of the neighbour as
    // the crop shows is taken on every frame, even without carrying it.
    let crop = FollowConfig {
        learned_box_slack: None,
        ..cut
    };
    let got = follow_learned(10, &crop, with_neighbour);
    assert!(got.iter().all(|&(iou, _)| iou < 0.86), "{got:.3?}");
    assert!(got.last().unwrap().0 < 0.75, "{got:.3?}");
}

#[test]
fn learned_cut_and_carry_settings_are_checked() {
    let frame_rgb = render(0);
    let frame = Frame::rgb(&frame_rgb.0, W, H).unwrap();
    for (cfg, field) in [
        (
            FollowConfig {
                learned_box_slack: Some(-0.1),
                ..FollowConfig::default()
            },
            "learned_box_slack",
        ),
        (
            FollowConfig {
                learned_box_slack: Some(f64::NAN),
                ..FollowConfig::default()
            },
            "learned_box_slack",
        ),
        (
            FollowConfig {
                learned_carry_iou: 1.5,
                ..FollowConfig::default()
            },
            "learned_carry_iou",
        ),
        (
            FollowConfig {
                learned_carry_below: f64::NAN,
                ..FollowConfig::default()
            },
            "learned_carry_below",
        ),
    ] {
        match Follower::new(&frame, &frame_rgb.1, cfg) {
            Err(FollowError::InvalidConfig { field: f, .. }) => assert_eq!(f, field),
            other => panic!("{field}: {other:?}"),
        }
    }
}

/// Frame `i` of a textureless scene: a flat grey box, barely darker than the flat grey ground,
/// speeding up to the right (a plastic bag in the wind: nothing for SIFT to match, nothing for
/// the colour model to tell apart).
fn render_flat(i: usize) -> (Vec<u8>, Mask) {
    let t = i as f64;
    let (cx, cy) = (40.0 + 0.3 * t * t, 60.0);
    let mut rgb = Vec::with_capacity((W * H * 3) as usize);
    let mut truth = vec![0u8; (W * H) as usize];
    for y in 0..H {
        for x in 0..W {
            let inside = (x as f64 + 0.5 - cx).abs() < HW && (y as f64 + 0.5 - cy).abs() < HH;
            if inside {
                truth[(y * W + x) as usize] = 1;
            }
            let v = if inside { 120 } else { 126 };
            rgb.extend_from_slice(&[v, v, v]);
        }
    }
    (rgb, Mask::from_full(W, H, &truth).unwrap())
}

#[test]
fn an_unsure_follower_carries_the_learned_outline() {
    // Nothing to match, nothing the colour model tells apart: the follower's own estimate is
    // its last outline moved by its last motion, which lags an object speeding up. Carried
    // while the follower is unsure (the default), the network's outline keeps its state on
    // the object; not carried, the state lags until the map, cut to the lagging box, no
    // longer shows the object.
    let follow = |cfg: &FollowConfig| -> Vec<f64> {
        let scenes: Vec<(Vec<u8>, Mask)> = (0..12).map(render_flat).collect();
        let first = Frame::rgb(&scenes[0].0, W, H).unwrap();
        let mut f = Follower::new(&first, &scenes[0].1, cfg.clone()).unwrap();
        scenes[1..]
            .iter()
            .map(|(rgb, truth)| {
                let frame = Frame::rgb(rgb, W, H).unwrap();
                let crop = f.learned_crop().expect("a running follower has a crop");
                let sal = Saliency::new(crop, &oracle_map(&crop, truth), true).unwrap();
                f.step_learned(&frame, &[], Some(&sal))
                    .unwrap()
                    .mask
                    .iou(truth)
            })
            .collect()
    };
    let carried = follow(&FollowConfig::default());
    let kept = follow(&FollowConfig {
        learned_carry_below: 0.0,
        ..FollowConfig::default()
    });
    assert!(carried.iter().all(|&iou| iou > 0.9), "{carried:.3?}");
    assert!(kept.last().unwrap() < &0.5, "{kept:.3?}");
}

/// Frame size of the panning shot.
const PW: u32 = 320;
const PH: u32 = 160;

/// Frame `i` of a panning shot: the camera pans right (the blotchy blue-green scene slides
/// left 2 px a frame), the textured target moves right 3 px a frame in the picture (5 px
/// against the scene), and passes behind a textured grey pole that stands in the scene (it
/// slides with it). Returns the frame and the target's visible part.
fn render_pan(i: usize) -> (Vec<u8>, Mask) {
    const PAN: f64 = 4.0;
    let t = i as f64;
    let (cx, cy) = (40.0 + 6.0 * t, 80.0);
    let pole = 200.0 - PAN * t;
    let mut rgb = Vec::with_capacity((PW * PH * 3) as usize);
    let mut truth = vec![0u8; (PW * PH) as usize];
    for y in 0..PH {
        for x in 0..PW {
            let (fx, fy) = (x as f64 + 0.5, y as f64 + 0.5);
            // Scene coordinates: what stands in the scene is drawn there.
            let sx = fx + PAN * t;
            let px = if (fx - pole).abs() < 20.0 {
                let v = hash((sx / 3.0).floor() as i64, (fy / 3.0).floor() as i64, 11);
                [
                    (120.0 + 130.0 * v) as u8,
                    (20.0 + 200.0 * v) as u8,
                    (10.0 + 80.0 * v) as u8,
                ]
            } else if (fx - cx).abs() < 30.0 && (fy - cy).abs() < 20.0 {
                truth[(y * PW + x) as usize] = 1;
                let (ox, oy) = ((fx - cx + 30.0) / 3.0, (fy - cy + 20.0) / 3.0);
                let v = hash(ox.floor() as i64, oy.floor() as i64, 7);
                [
                    (120.0 + 130.0 * v) as u8,
                    (20.0 + 200.0 * v) as u8,
                    (10.0 + 80.0 * v) as u8,
                ]
            } else {
                let v = hash((sx / 5.0).floor() as i64, (fy / 5.0).floor() as i64, 3);
                [
                    (20.0 + 60.0 * v) as u8,
                    (70.0 + 120.0 * v) as u8,
                    (90.0 + 130.0 * v) as u8,
                ]
            };
            rgb.extend_from_slice(&px);
        }
    }
    (rgb, Mask::from_full(PW, PH, &truth).unwrap())
}

#[test]
fn a_follower_that_finds_the_background_lets_it_go() {
    // Behind the pole the target's keypoints vanish and the pole's, taken into the model
    // while it crossed the outline, win the fit: from then on the fit moves as the scene
    // does. A target that had moved against the scene does not do that: the frame is lost,
    // the pole's keypoints leave the model, and the target is taken up where it comes out.
    let follow = |cfg: &FollowConfig| -> Vec<f64> {
        let scenes: Vec<(Vec<u8>, Mask)> = (0..31).map(render_pan).collect();
        let first = Frame::rgb(&scenes[0].0, PW, PH).unwrap();
        let mut f = Follower::new(&first, &scenes[0].1, cfg.clone()).unwrap();
        scenes[1..]
            .iter()
            .map(|(rgb, truth)| {
                let frame = Frame::rgb(rgb, PW, PH).unwrap();
                f.step(&frame, &[]).unwrap().mask.iou(truth)
            })
            .collect()
    };
    let on = follow(&FollowConfig::default());
    let off = follow(&FollowConfig {
        background_lock: None,
        ..FollowConfig::default()
    });
    // Measured: from frame 25 on, IoU 0.63–0.79 with the check, 0.13 down to 0 without.
    assert!(on[24..].iter().all(|&iou| iou > 0.55), "{on:.3?}");
    assert!(off[24..].iter().all(|&iou| iou < 0.2), "{off:.3?}");
}
