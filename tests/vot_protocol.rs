//! VOT protocols checked against hand computations (bag ground truth and synthetic sequences).
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::eval::vot::{
    anchor_frames, anchors_every, evaluate_anchor_sequence, evaluate_reset_sequence,
    run_anchor_protocol, run_reset_protocol, summarize_anchor, summarize_reset, AnchorParams,
    ResetParams, VotError,
};
use shapetrack::io::vot::{read_regions, Direction, Region};
use shapetrack::{BBox, Point};
use std::path::PathBuf;

fn bag() -> Vec<Region> {
    read_regions(
        &PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data/vot-bag/groundtruth.txt"),
    )
    .unwrap()
}

fn shifted(r: &Region, dx: f64) -> Region {
    match r {
        Region::Polygon(p) => {
            Region::Polygon(p.iter().map(|q| Point::new(q.x + dx, q.y)).collect())
        }
        other => other.clone(),
    }
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-12
}

/// A tracker that returns the ground truth scores A = 1, R = 1 and an EAO curve of 1 at every
/// length some run reaches (1..=195 on bag); the toolkit-style EAO counts the undefined
/// lengths 196..754 as 0, giving 81/640.
#[test]
fn perfect_tracker_on_bag() {
    let gt = bag();
    let anchors = anchors_every(gt.len(), 50);
    let params = AnchorParams {
        bounds: Some((480, 360)),
        ..AnchorParams::default()
    };
    let runs = run_anchor_protocol(gt.len(), &gt, &anchors, |start, _, dir| {
        let a = anchors
            .iter()
            .find(|a| a.frame == start && a.direction == dir)
            .unwrap();
        anchor_frames(a, gt.len())[1..]
            .iter()
            .map(|&f| gt[f].clone())
            .collect()
    })
    .unwrap();
    let seq = evaluate_anchor_sequence(&gt, &anchors, &runs, &params).unwrap();
    assert!(seq.runs.iter().all(|r| !r.failed && r.accuracy == 1.0));
    let s = summarize_anchor(&[seq], &params).unwrap();
    assert_eq!((s.accuracy, s.robustness), (1.0, 1.0));
    for (j, v) in s.eao_curve.iter().enumerate().skip(1) {
        if j < 196 {
            assert!(close(v.unwrap(), 1.0), "curve[{j}] = {v:?}");
        } else {
            assert_eq!(*v, None, "curve[{j}]");
        }
    }
    assert_eq!(s.eao_defined, Some(1.0));
    assert!(close(s.eao, 81.0 / 640.0));
}

/// Ground truth moved 200 px right in frames 60..=75: overlap 0 there, so each run fails at
/// the first shifted frame it meets (10 frames below θφ = 0.1 ⇒ failure dated at the first):
/// anchor 0 → 60, anchor 50 → 10, anchor 100 (backward) → 25, anchor 150 (backward) → 75.
#[test]
fn shifted_tracker_fails_where_computed_by_hand() {
    let gt = bag();
    let anchors = anchors_every(gt.len(), 50);
    let params = AnchorParams {
        bounds: Some((480, 360)),
        ..AnchorParams::default()
    };
    let runs = run_anchor_protocol(gt.len(), &gt, &anchors, |start, _, dir| {
        let a = anchors
            .iter()
            .find(|a| a.frame == start && a.direction == dir)
            .unwrap();
        anchor_frames(a, gt.len())[1..]
            .iter()
            .map(|&f| {
                if (60..=75).contains(&f) {
                    shifted(&gt[f], 200.0)
                } else {
                    gt[f].clone()
                }
            })
            .collect()
    })
    .unwrap();
    let seq = evaluate_anchor_sequence(&gt, &anchors, &runs, &params).unwrap();
    let progress: Vec<usize> = seq.runs.iter().map(|r| r.progress).collect();
    assert_eq!(progress, vec![60, 10, 25, 75]);
    let lengths: Vec<usize> = seq.runs.iter().map(|r| r.length).collect();
    assert_eq!(lengths, vec![196, 146, 101, 151]);
    assert!(seq.runs.iter().all(|r| r.failed));
    let s = summarize_anchor(&[seq], &params).unwrap();
    assert_eq!(s.accuracy, 1.0);
    assert!(close(s.robustness, 170.0 / 594.0));
    // EAO curve by hand: a run of length L failing at p contributes min(j, p−1)/j while j < L
    // and (p−1)/(j−1) after (the toolkit's divisor).
    let runs = [(196usize, 60usize), (146, 10), (101, 25), (151, 75)];
    let phi = |j: usize| {
        runs.iter()
            .map(|&(l, p)| {
                if j < l {
                    (p - 1).min(j) as f64 / j as f64
                } else {
                    (p - 1) as f64 / (j - 1) as f64
                }
            })
            .sum::<f64>()
            / 4.0
    };
    assert!(close(s.eao_curve[100].unwrap(), 166.0 / 400.0));
    assert!(close(
        s.eao_curve[160].unwrap(),
        (59.0 / 160.0 + 107.0 / 159.0) / 4.0
    ));
    let eao: f64 = (115..755).map(phi).sum::<f64>() / 640.0;
    assert!(close(s.eao, eao), "{} vs {eao}", s.eao);
    assert_eq!(s.eao_defined, Some(s.eao));
}

/// 30 frames of a 10×10 box moving 1 px right per frame; the tracker keeps the initial box, so
/// d frames from the anchor the overlap is (10 − d)/(10 + d) (0 from d = 10). It is ≤ 0.1 from
/// d = 9, so every run fails at N^F = 9.
fn moving_box() -> Vec<Region> {
    (0..30)
        .map(|f| Region::Rectangle(BBox::new(f as f64, 0.0, 10.0, 10.0)))
        .collect()
}

fn ov(d: usize) -> f64 {
    if d >= 10 {
        0.0
    } else {
        (10.0 - d as f64) / (10.0 + d as f64)
    }
}

#[test]
fn constant_tracker_anchor_scores_by_hand() {
    let gt = moving_box();
    let anchors = anchors_every(30, 10);
    assert_eq!(
        anchors
            .iter()
            .map(|a| (a.frame, a.direction))
            .collect::<Vec<_>>(),
        vec![
            (0, Direction::Forward),
            (10, Direction::Forward),
            (20, Direction::Backward)
        ]
    );
    let params = AnchorParams {
        eao_low: 2,
        eao_high: 12,
        ..AnchorParams::default()
    };
    let runs = run_anchor_protocol(30, &gt, &anchors, |start, init, dir| {
        let a = anchors
            .iter()
            .find(|a| a.frame == start && a.direction == dir)
            .unwrap();
        vec![init.clone(); anchor_frames(a, 30).len() - 1]
    })
    .unwrap();
    let seq = evaluate_anchor_sequence(&gt, &anchors, &runs, &params).unwrap();
    for r in &seq.runs {
        assert_eq!(r.progress, 9);
        for (d, &o) in r.overlaps.iter().enumerate() {
            assert!(close(o, ov(d)), "d={d}: {o}");
        }
    }
    let s = summarize_anchor(&[seq], &params).unwrap();
    let a: f64 = (0..9).map(ov).sum::<f64>() / 9.0;
    assert!(close(s.accuracy, a));
    assert!(close(s.robustness, 27.0 / 71.0));
    // Curve (all runs longer than 11 frames): mean of overlaps 1..=j, zeroed from d = 9.
    let phi = |j: usize| {
        (1..=j)
            .map(|d| if d < 9 { ov(d) } else { 0.0 })
            .sum::<f64>()
            / j as f64
    };
    for j in 1..12 {
        assert!(close(s.eao_curve[j].unwrap(), phi(j)), "j={j}");
    }
    assert!(close(s.eao, (2..12).map(phi).sum::<f64>() / 10.0));
}

#[test]
fn constant_tracker_reset_scores_by_hand() {
    let gt = moving_box();
    let params = ResetParams {
        burnin: 3,
        eao_low: 1,
        eao_high: 8,
        ..ResetParams::default()
    };
    let traj = run_reset_protocol(&gt, &params, |start, init| {
        vec![init.clone(); 30 - start - 1]
    });
    // Fails when the overlap reaches 0 (d = 10): at frames 10 and 25; re-initialised 5 later.
    let codes: Vec<Option<i32>> = traj.iter().map(Region::special).collect();
    for (f, c) in codes.iter().enumerate() {
        let want = match f {
            0 | 15 => Some(1),
            10 | 25 => Some(2),
            11..=14 | 26..=29 => Some(0),
            _ => None,
        };
        assert_eq!(*c, want, "frame {f}");
    }
    let seq = evaluate_reset_sequence(&gt, &traj, &params).unwrap();
    assert_eq!(
        (seq.failures, seq.failure_frames.clone()),
        (2, vec![10, 25])
    );
    // Accuracy frames: d = 3..=9 after each initialisation (burn-in 3).
    assert_eq!(seq.accuracy_frames, 14);
    assert!(close(seq.accuracy, (3..10).map(ov).sum::<f64>() / 7.0));
    let s = summarize_reset(&[seq], &params).unwrap();
    assert_eq!(s.failures, 2.0);
    assert!(close(s.reliability, (-30.0f64 * 2.0 / 30.0).exp()));
    // EAO runs: two failed runs of 10 frames (overlaps of d = 0..9, the init frame being a
    // special code, overlap 0), padded with zeros; curve[j] = mean(o_1..o_j).
    let phi = |j: usize| {
        (1..=j)
            .map(|d| if d < 10 { ov(d) } else { 0.0 })
            .sum::<f64>()
            / j as f64
    };
    assert!(close(s.eao.unwrap(), (1..=8).map(phi).sum::<f64>() / 8.0));

    let perfect = run_reset_protocol(&gt, &params, |start, _| gt[start + 1..].to_vec());
    let p = evaluate_reset_sequence(&gt, &perfect, &params).unwrap();
    assert_eq!((p.failures, p.accuracy), (0, 1.0));
}

#[test]
fn protocol_errors_are_typed() {
    let gt = moving_box();
    let anchors = anchors_every(30, 10);
    let params = AnchorParams::default();
    assert!(matches!(
        run_anchor_protocol(30, &gt, &anchors, |_, _, _| vec![]),
        Err(VotError::LengthMismatch { .. })
    ));
    assert!(matches!(
        run_anchor_protocol(31, &gt, &anchors, |_, _, _| vec![]),
        Err(VotError::LengthMismatch { .. })
    ));
    let bad = [shapetrack::io::vot::Anchor {
        frame: 40,
        direction: Direction::Forward,
    }];
    assert!(matches!(
        evaluate_anchor_sequence(&gt, &bad, &[vec![]], &params),
        Err(VotError::AnchorOutOfRange { .. })
    ));
    assert!(matches!(
        evaluate_anchor_sequence(&gt, &[], &[], &params),
        Err(VotError::Empty)
    ));
    assert!(matches!(
        summarize_anchor(&[], &params),
        Err(VotError::Empty)
    ));
    assert!(evaluate_reset_sequence(&gt, &gt[..3], &ResetParams::default()).is_err());
}
