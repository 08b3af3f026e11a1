use super::*;
use crate::frame::Detection;

/// A frame with a bright square on a dark ground.
fn square_frame(w: u32, h: u32, x0: u32, y0: u32, side: u32) -> Vec<u8> {
    let mut v = vec![20u8; (w * h * 3) as usize];
    for y in y0..y0 + side {
        for x in x0..x0 + side {
            let i = ((y * w + x) * 3) as usize;
            v[i..i + 3].copy_from_slice(&[230, 200, 40]);
        }
    }
    v
}

/// A stand-in network: the probability is the input's brightness (first channel above its
/// mean), so a test can know which pixels a mask should hold.
struct Bright;

impl Net for Bright {
    fn run(&mut self, input: &[f32]) -> Result<Vec<f32>, SegmentError> {
        let Some(side) = side_of(input.len(), 3) else {
            return Err(SegmentError::TensorLength {
                what: "input",
                len: input.len(),
                expected: INPUT_LEN,
            });
        };
        Ok(input[..output_len(side)]
            .iter()
            .map(|&v| if v > 0.5 { 0.9 } else { 0.05 })
            .collect())
    }
}

/// [`Bright`], remembering the side of every input it ran on.
struct Sides(Vec<u32>);

impl Net for Sides {
    fn run(&mut self, input: &[f32]) -> Result<Vec<f32>, SegmentError> {
        let out = Bright.run(input)?;
        self.0.push(side_of(input.len(), 3).unwrap_or(0));
        Ok(out)
    }
}

#[test]
fn a_box_runs_at_the_settings_side_and_the_whole_frame_at_the_models() {
    let (w, h) = (240u32, 160u32);
    let px = square_frame(w, h, 20, 30, 40);
    let f = Frame::rgb(&px, w, h).unwrap();
    let cfg = SegmentConfig::default().for_boxes();
    assert_eq!(cfg.side, BOX_SIDE);
    let dets = vec![Detection::from_box(BBox::new(15.0, 25.0, 50.0, 50.0), 0.9)];
    let mut job = Job::new(w, h, dets.clone(), WholeFrame::Proposals, &cfg).unwrap();
    assert_eq!(job.pending_side(), Some(SIDE as u32));
    let mut net = Sides(Vec::new());
    job.run(&f, &mut net).unwrap();
    assert_eq!(net.0, vec![SIDE as u32, BOX_SIDE]);
    assert_eq!(job.pending_side(), None);
    // The box's outline at 256 is the object's, as at 320.
    let truth = Mask::from_bbox(&BBox::new(20.0, 30.0, 40.0, 40.0));
    let m = job.finish().detections[0].mask.clone().expect("a mask");
    assert!(m.iou(&truth) > 0.9, "IoU {}", m.iou(&truth));
    // A tensor of the other side is refused by the job, naming the length it expects.
    let mut job = Job::new(w, h, dets, WholeFrame::Off, &cfg).unwrap();
    assert_eq!(
        job.input(&f, &mut vec![0.0; INPUT_LEN]),
        Err(SegmentError::TensorLength {
            what: "the input buffer",
            len: INPUT_LEN,
            expected: input_len(BOX_SIDE),
        })
    );
    assert_eq!(
        job.supply(&vec![0.0; OUTPUT_LEN]),
        Err(SegmentError::TensorLength {
            what: "the network's output",
            len: OUTPUT_LEN,
            expected: output_len(BOX_SIDE),
        })
    );
    // Sides the network does not run at are refused in the settings.
    for side in [0, 96, 100, 300, 352, 640] {
        let bad = SegmentConfig {
            side,
            ..SegmentConfig::default()
        };
        assert!(
            matches!(
                bad.validate(),
                Err(SegmentError::InvalidConfig { field: "side", .. })
            ),
            "{side}"
        );
    }
}

#[test]
fn the_input_is_normalised_channels_first() {
    let (w, h) = (64u32, 48u32);
    let px = square_frame(w, h, 0, 0, 0);
    let f = Frame::rgb(&px, w, h).unwrap();
    let mut out = vec![0f32; INPUT_LEN];
    input_tensor(&f, &Crop::whole(w, h), &mut out).unwrap();
    // A flat frame: every value is (1 − mean) / std of its channel (divided by its own max).
    for c in 0..3 {
        let want = (1.0 - MEAN[c]) / STD[c];
        for v in &out[c * OUTPUT_LEN..(c + 1) * OUTPUT_LEN] {
            assert!((v - want).abs() < 1e-4, "channel {c}: {v} vs {want}");
        }
    }
    assert!(input_tensor(&f, &Crop::whole(w, h), &mut [0f32; 7]).is_err());
    let outside = Crop {
        x: 60,
        y: 0,
        w: 10,
        h: 10,
    };
    assert!(input_tensor(&f, &outside, &mut out).is_err());
}

#[test]
fn a_box_becomes_the_bright_object_inside_it() {
    let (w, h) = (200u32, 150u32);
    let px = square_frame(w, h, 60, 40, 50);
    let f = Frame::rgb(&px, w, h).unwrap();
    let cfg = SegmentConfig::default();
    let m = segment_box(&f, &BBox::new(55.0, 35.0, 60.0, 60.0), &cfg, &mut Bright)
        .unwrap()
        .expect("a mask");
    let truth = Mask::from_bbox(&BBox::new(60.0, 40.0, 50.0, 50.0));
    assert!(m.iou(&truth) > 0.9, "IoU {}", m.iou(&truth));
}

#[test]
fn the_whole_frame_proposes_what_no_detection_covers() {
    let (w, h) = (240u32, 160u32);
    let mut px = square_frame(w, h, 20, 30, 40);
    // A second object.
    for y in 90..130u32 {
        for x in 150..200u32 {
            let i = ((y * w + x) * 3) as usize;
            px[i..i + 3].copy_from_slice(&[240, 240, 240]);
        }
    }
    let f = Frame::rgb(&px, w, h).unwrap();
    let cfg = SegmentConfig::default();
    // A detection over the first object only.
    let dets = vec![Detection::from_box(BBox::new(15.0, 25.0, 50.0, 50.0), 0.9)];
    let mut job = Job::new(w, h, dets, WholeFrame::Proposals, &cfg).unwrap();
    assert_eq!(job.remaining(), 2, "the whole frame, then the box");
    job.run(&f, &mut Bright).unwrap();
    let out = job.finish();
    assert_eq!(
        out.detections.len(),
        2,
        "{:?}",
        out.detections.iter().map(|d| d.bbox).collect::<Vec<_>>()
    );
    assert!(out.learned.iter().all(|&l| l));
    let second = Mask::from_bbox(&BBox::new(150.0, 90.0, 50.0, 40.0));
    let m = out.detections[1].mask.as_ref().unwrap();
    assert!(m.iou(&second) > 0.85, "IoU {}", m.iou(&second));
}

#[test]
fn bad_outputs_and_calls_are_errors_not_panics() {
    let cfg = SegmentConfig::default();
    let dets = vec![Detection::from_box(BBox::new(5.0, 5.0, 20.0, 20.0), 1.0)];
    let mut job = Job::new(50, 40, dets, WholeFrame::Off, &cfg).unwrap();
    assert!(matches!(
        job.supply(&[0.0; 10]),
        Err(SegmentError::TensorLength { .. })
    ));
    let mut nan = vec![0.5f32; OUTPUT_LEN];
    nan[17] = f32::NAN;
    assert_eq!(job.supply(&nan), Err(SegmentError::NonFinite { index: 17 }));
    job.supply(&vec![0.0; OUTPUT_LEN]).unwrap();
    assert_eq!(
        job.supply(&vec![0.0; OUTPUT_LEN]),
        Err(SegmentError::NothingPending)
    );
    let px = vec![0u8; 30 * 30 * 3];
    let other = Frame::rgb(&px, 30, 30).unwrap();
    assert!(matches!(
        job.input(&other, &mut vec![0.0; INPUT_LEN]),
        Err(SegmentError::FrameSize { .. })
    ));
    // A flat output finds nothing: the detection keeps its box and is not marked learned.
    let out = job.finish();
    assert_eq!(out.learned, vec![false]);
    assert!(out.detections[0].mask.is_none());
    let bad = SegmentConfig {
        threshold: 1.5,
        ..SegmentConfig::default()
    };
    assert!(Job::new(50, 40, vec![], WholeFrame::Off, &bad).is_err());
}

#[test]
fn crops_grow_by_the_margin_and_stay_in_the_frame() {
    let c = Crop::around(&BBox::new(10.0, 10.0, 20.0, 40.0), 100, 100, 0.25, 0).unwrap();
    assert_eq!((c.x, c.y, c.w, c.h), (5, 0, 30, 60));
    let tiny = Crop::around(&BBox::new(50.0, 50.0, 2.0, 2.0), 100, 100, 0.25, 48).unwrap();
    assert_eq!((tiny.w, tiny.h), (48, 48));
    assert!(Crop::around(&BBox::new(0.0, 0.0, f64::NAN, 1.0), 100, 100, 0.25, 0).is_none());
}

#[test]
fn only_the_best_boxes_up_to_max_crops_are_segmented() {
    let cfg = SegmentConfig {
        max_crops: 2,
        ..SegmentConfig::default()
    };
    let dets: Vec<Detection> = [0.2, 0.9, 0.5, 0.7]
        .iter()
        .enumerate()
        .map(|(i, &s)| Detection::from_box(BBox::new(10.0 + 30.0 * i as f64, 10.0, 20.0, 20.0), s))
        .collect();
    let job = Job::new(200, 100, dets, WholeFrame::Off, &cfg).unwrap();
    assert_eq!(job.remaining(), 2);
    // The two best (0.9 at index 1, 0.7 at index 3), in the detections' order.
    assert_eq!(
        job.pending().unwrap().x,
        Crop::around(&BBox::new(40.0, 10.0, 20.0, 20.0), 200, 100, 0.25, 48)
            .unwrap()
            .x
    );
}
