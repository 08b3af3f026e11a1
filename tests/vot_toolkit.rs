//! Our VOT metrics against the official VOT toolkit (vot-toolkit 0.9.0) on the real "bag"
//! sequence: the reference numbers and result files were produced by
//! `tests/data/vot/make_toolkit_fixture.py` (see its doc for the trackers).
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::eval::vot::{
    anchor_frames, anchors_every, evaluate_anchor_sequence, evaluate_reset_sequence,
    run_anchor_protocol, run_reset_protocol, summarize_anchor, summarize_reset, AnchorParams,
    OverlapMethod, ResetParams,
};
use shapetrack::io::vot::{parse_anchor_values, read_regions, Direction, Region};
use shapetrack::{BBox, Point};
use std::path::PathBuf;

fn data() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/vot")
}

fn gt() -> Vec<Region> {
    read_regions(
        &PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data/vot-bag/groundtruth.txt"),
    )
    .unwrap()
}

#[derive(serde::Deserialize)]
struct AnchorRef {
    accuracy: f64,
    robustness: f64,
    eao: f64,
    accuracy_weight: f64,
}

#[derive(serde::Deserialize)]
struct ResetRef {
    accuracy: f64,
    failures: f64,
    robustness: f64,
    eao: f64,
}

#[derive(serde::Deserialize)]
struct TrackerRef {
    anchor: AnchorRef,
    reset: ResetRef,
}

#[derive(serde::Deserialize)]
struct Reference {
    trackers: std::collections::BTreeMap<String, TrackerRef>,
}

fn reference() -> Reference {
    serde_json::from_str(&std::fs::read_to_string(data().join("toolkit_reference.json")).unwrap())
        .unwrap()
}

const SIZE: Option<(u32, u32)> = Some((480, 360));

/// Multistart (VOT2020) A, R and EAO equal the toolkit's for all three trackers.
#[test]
fn anchor_protocol_matches_toolkit() {
    let gt = gt();
    assert_eq!(gt.len(), 196);
    let anchors = parse_anchor_values(
        &std::fs::read_to_string(data().join("bag_anchor.value")).unwrap(),
        "a",
    )
    .unwrap();
    assert_eq!(anchors, anchors_every(196, 50));
    let params = AnchorParams::toolkit(SIZE);
    for (name, want) in reference().trackers {
        let runs: Vec<Vec<Region>> = anchors
            .iter()
            .map(|a| {
                read_regions(
                    &data().join(format!("results/{name}/baseline/bag_{:08}.txt", a.frame)),
                )
                .unwrap()
            })
            .collect();
        let seq = evaluate_anchor_sequence(&gt, &anchors, &runs, &params).unwrap();
        let s = summarize_anchor(std::slice::from_ref(&seq), &params).unwrap();
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert!(
            close(s.accuracy, want.anchor.accuracy),
            "{name}: A {} vs {}",
            s.accuracy,
            want.anchor.accuracy
        );
        assert!(
            close(s.robustness, want.anchor.robustness),
            "{name}: R {} vs {}",
            s.robustness,
            want.anchor.robustness
        );
        assert!(
            close(s.eao, want.anchor.eao),
            "{name}: EAO {} vs {}",
            s.eao,
            want.anchor.eao
        );
        assert_eq!(seq.accuracy_weight, want.anchor.accuracy_weight, "{name}");
    }
}

/// Reset-protocol (VOT2019 supervised) A, failures, robustness and EAO equal the toolkit's.
#[test]
fn reset_protocol_matches_toolkit() {
    let gt = gt();
    let params = ResetParams {
        bounds: SIZE,
        method: OverlapMethod::Toolkit,
        ..ResetParams::default()
    };
    for (name, want) in reference().trackers {
        let traj = read_regions(&data().join(format!("results/{name}/reset/bag_001.txt"))).unwrap();
        let seq = evaluate_reset_sequence(&gt, &traj, &params).unwrap();
        let s = summarize_reset(&[seq], &params).unwrap();
        assert!(
            (s.accuracy - want.reset.accuracy).abs() < 1e-12,
            "{name}: A {}",
            s.accuracy
        );
        assert_eq!(s.failures, want.reset.failures, "{name}");
        assert!(
            (s.reliability - want.reset.robustness).abs() < 1e-12,
            "{name}"
        );
        // The toolkit accumulates the reset EAO curve in float32.
        let eao = s.eao.unwrap();
        assert!(
            (eao - want.reset.eao).abs() < 1e-6,
            "{name}: EAO {eao} vs {}",
            want.reset.eao
        );
    }
}

fn shift(r: &Region, dx: f64) -> Region {
    match r {
        Region::Polygon(p) => {
            Region::Polygon(p.iter().map(|q| Point::new(q.x + dx, q.y)).collect())
        }
        other => other.clone(),
    }
}

fn tracker_line(name: &str, gt: &[Region], start: usize, frame: usize) -> Region {
    match name {
        "perfect" => gt[frame].clone(),
        "shifted" if (60..=75).contains(&frame) => shift(&gt[frame], 200.0),
        "shifted" => gt[frame].clone(),
        _ => Region::Rectangle(gt[start].bbox()),
    }
}

/// The protocol drivers, fed the same synthetic trackers, produce the toolkit's trajectories.
#[test]
fn drivers_reproduce_the_fixture_trajectories() {
    let gt = gt();
    let anchors = anchors_every(196, 50);
    let reset = ResetParams {
        bounds: SIZE,
        method: OverlapMethod::Toolkit,
        ..ResetParams::default()
    };
    for name in ["perfect", "shifted", "constant"] {
        let runs = run_anchor_protocol(196, &gt, &anchors, |start, init, dir| {
            assert_eq!(init, &gt[start]);
            let a = anchors
                .iter()
                .find(|a| a.frame == start && a.direction == dir)
                .unwrap();
            anchor_frames(a, 196)[1..]
                .iter()
                .map(|&f| tracker_line(name, &gt, start, f))
                .collect()
        })
        .unwrap();
        for (a, run) in anchors.iter().zip(&runs) {
            let want = read_regions(
                &data().join(format!("results/{name}/baseline/bag_{:08}.txt", a.frame)),
            )
            .unwrap();
            assert_eq!(run.len(), want.len());
            for (x, y) in run.iter().zip(&want) {
                let same = match (x, y) {
                    (Region::Rectangle(p), Region::Rectangle(q)) => bbox_close(p, q),
                    (Region::Polygon(p), Region::Polygon(q)) => p
                        .iter()
                        .zip(q)
                        .all(|(u, v)| (u.x - v.x).abs() < 1e-9 && (u.y - v.y).abs() < 1e-9),
                    (p, q) => p == q,
                };
                assert!(same, "{name} anchor {}: {x:?} vs {y:?}", a.frame);
            }
        }
        let traj = run_reset_protocol(&gt, &reset, |start, _| {
            (start + 1..196)
                .map(|f| tracker_line(name, &gt, start, f))
                .collect()
        });
        let want = read_regions(&data().join(format!("results/{name}/reset/bag_001.txt"))).unwrap();
        let codes = |t: &[Region]| t.iter().map(|r| r.special()).collect::<Vec<_>>();
        assert_eq!(codes(&traj), codes(&want), "{name}");
    }
}

fn bbox_close(a: &BBox, b: &BBox) -> bool {
    [(a.x, b.x), (a.y, b.y), (a.w, b.w), (a.h, b.h)]
        .iter()
        .all(|(u, v)| (u - v).abs() < 1e-9)
}

#[test]
fn backward_anchor_runs_visit_frames_in_reverse() {
    let a = anchors_every(196, 50);
    assert_eq!(a[3].direction, Direction::Backward);
    let f = anchor_frames(&a[3], 196);
    assert_eq!(
        (f[0], f[1], *f.last().unwrap(), f.len()),
        (150, 149, 0, 151)
    );
}
