//! `eval` bounds the boxes of one frame (issue 65, class 2): every frame's similarity matrix
//! is ground truth × tracker boxes and its matching cubic in them, so a file claiming more
//! boxes in one frame than the cap gets an error naming the record, not a huge matrix.
// A native suite (`cargo test`); for wasm32 it compiles to nothing.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::eval::{prepare, EvalConfig, SequenceInput};
use shapetrack::frame::BBox;
use shapetrack::io::limits::MAX_BOXES_PER_FRAME;
use shapetrack::io::Record;

fn boxes(n: usize, frame: u32) -> Vec<Record> {
    (0..n)
        .map(|k| Record::from_box(frame, k as i64 + 1, BBox::new(k as f64, 0.0, 10.0, 10.0)))
        .collect()
}

#[test]
fn a_frame_beyond_the_box_cap_is_refused_naming_the_record() {
    for (gt, tr) in [(MAX_BOXES_PER_FRAME + 1, 1), (1, MAX_BOXES_PER_FRAME + 1)] {
        let input = SequenceInput::new("crowd", 3, boxes(gt, 2), boxes(tr, 2));
        let e = prepare(&input, &EvalConfig::unfiltered())
            .unwrap_err()
            .to_string();
        assert!(e.contains("frame 2") && e.contains("boxes"), "{e}");
        assert!(
            e.contains(&format!("record {}", MAX_BOXES_PER_FRAME + 1)),
            "{e}"
        );
    }
}

#[test]
fn a_frame_at_the_box_cap_is_evaluated() {
    let input = SequenceInput::new("crowd", 1, boxes(50, 1), boxes(50, 1));
    assert!(prepare(&input, &EvalConfig::unfiltered()).is_ok());
}
