//! The offline pass's output and work budgets (issue 65, class 2): wide fill settings over a
//! tiny input are refused with a typed error instead of allocating what the settings claim,
//! and the re-linker's dense join solve stays small on crowded short tracklets.
// A native suite (`cargo test`); for wasm32 it compiles to nothing.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::frame::{BBox, Point, TrackState, TrackedShape};
use shapetrack::track::offline::{relink, OfflineConfig, OfflineError, SequenceInfo};

/// A box-mode shape of track `id` centred on `c` (20×40 px).
fn shape(id: u64, frame: u32, c: Point) -> TrackedShape {
    let bbox = BBox::from_center(c, 20.0, 40.0);
    TrackedShape {
        id,
        frame,
        bbox,
        mask: None,
        centroid: bbox.center(),
        state: TrackState::Confirmed,
        score: 0.9,
        class: -1,
        cost: 0.0,
        det_index: Some(0),
        interpolated: false,
    }
}

/// Two shapes per track, 600,000 frames apart, and a fill setting that says "fill any gap":
/// the fill would invent 1.2 million shapes from eight input shapes. Refused, naming the cap.
#[test]
fn wide_fill_settings_over_a_tiny_input_are_refused() {
    let mut shapes = Vec::new();
    for id in 1..=4u64 {
        let c = Point::new(50.0 * id as f64, 100.0);
        shapes.push(shape(id, 1, c));
        shapes.push(shape(id, 300_001, c));
    }
    let mut config = OfflineConfig::default();
    config.fill.max_gap = u32::MAX;
    let r = relink(shapes, None, &config, &SequenceInfo::new(25.0), &mut |_| {});
    match r {
        Err(OfflineError::FillBudget { cap, .. }) => assert!(cap < 1_200_000, "cap {cap}"),
        other => panic!(
            "expected the fill budget's error, got {:?}",
            other.map(|r| r.filled)
        ),
    }
}

/// The same settings where the gaps are short: the fill is made as before (the budget follows
/// the input, and a default-sized fill can never reach it).
#[test]
fn wide_fill_settings_over_short_gaps_still_fill() {
    let mut shapes = Vec::new();
    for f in [1u32, 20, 40] {
        shapes.push(shape(1, f, Point::new(f64::from(f), 50.0)));
    }
    let mut config = OfflineConfig::default();
    config.fill.max_gap = u32::MAX;
    let r = relink(shapes, None, &config, &SequenceInfo::new(25.0), &mut |_| {}).unwrap();
    assert_eq!(r.filled, 18 + 19);
}
