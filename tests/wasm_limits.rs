//! Issue 65, class 3: the wasm objects never trap and never end poisoned. Sizes are checked
//! when an object is built (a frame buffer or a tracker's image size the detectors and the
//! RLE writer cannot hold is an `Error` there), the tracker's kept history is bounded with an
//! `Error` once full that changes nothing, and a frame the tracker refused binds it to
//! nothing. Run in wasm by wasm-bindgen-test (see tests/wasm_bindings.rs).
#![cfg(target_arch = "wasm32")]

use serde::Serialize;
use shapetrack::wasm::*;
use tsify::Ts;
use wasm_bindgen::{JsCast, JsValue};
use wasm_bindgen_test::*;

fn js<T: Serialize>(v: &T) -> JsValue {
    v.serialize(&serde_wasm_bindgen::Serializer::json_compatible())
        .unwrap()
}

fn settings<T: JsCast>(v: &serde_json::Value) -> T {
    js(v).unchecked_into()
}

/// The message of a JS `Error`; fails the test for anything else.
fn error_message(e: JsValue) -> String {
    let err: js_sys::Error = e.dyn_into().expect("a JS Error object");
    String::from(err.message())
}

fn records(v: Ts<Records>) -> Vec<RecordJs> {
    serde_wasm_bindgen::from_value(JsValue::from(v)).unwrap()
}

/// `n` boxes side by side, as a JS detector hands them in.
fn boxes(n: usize, x0: f64) -> Detections {
    let boxes: Vec<_> = (0..n)
        .map(|i| {
            serde_json::json!({
                "bbox": { "x": x0 + 40.0 * i as f64, "y": 20.0, "w": 30.0, "h": 40.0 },
                "score": 0.9,
            })
        })
        .collect();
    Detections::from_lists(Ts::new_unchecked(js(
        &serde_json::json!({ "boxes": boxes }),
    )))
    .unwrap()
}

#[wasm_bindgen_test]
fn a_frame_buffer_beyond_the_image_caps_is_refused_when_built() {
    // 16384 x 16384 was accepted (1 GiB): the background detector then sat within a few MB of
    // wasm32's 4 GiB. The pixel cap is the readers' (io::limits): 2^26, 8192 x 8192; a side
    // stays within a browser canvas' 16384.
    for (w, h) in [
        (16384.0, 16384.0),
        (8193.0, 8192.0),
        (16384.0, 4097.0),
        (16385.0, 1.0),
        (0.0, 8.0),
    ] {
        let msg = error_message(FrameBuffer::new(w, h).err().unwrap());
        assert!(
            msg.contains("frame size") && msg.contains("67108864"),
            "{w}x{h}: {msg}"
        );
    }
    // Long frames within the caps stay valid.
    let long = FrameBuffer::new(16384.0, 16.0).unwrap();
    assert_eq!(long.len(), 16384 * 16 * 4);
}

#[wasm_bindgen_test]
fn an_offline_image_size_beyond_the_caps_is_refused_when_the_tracker_is_built() {
    // 0 x 0 encoded every mask as empty and 4294967295 x 4294967295 wrapped the run counts,
    // both without a word.
    for (w, h) in [
        (0.0, 0.0),
        (4294967295.0, 4294967295.0),
        (100000.0, 100000.0),
    ] {
        let opts = serde_json::json!({ "fps": 25, "width": w, "height": h });
        let msg = error_message(Tracker::new(None, Some(settings(&opts))).err().unwrap());
        assert!(msg.contains("frame size"), "{w}x{h}: {msg}");
    }
    let opts = serde_json::json!({ "fps": 25, "width": 640, "height": 480 });
    assert!(Tracker::new(None, Some(settings(&opts))).is_ok());
}

#[wasm_bindgen_test]
fn a_full_history_refuses_the_next_frame_and_keeps_everything() {
    let opts = serde_json::json!({ "fps": 25, "width": 640, "height": 480 });
    let mut t = Tracker::new(None, Some(settings(&opts)))
        .unwrap()
        .with_history_cap(20);
    assert_eq!(t.max_kept_shapes(), 20);
    // Two objects a frame: full after 10 frames.
    let mut n = 0;
    let msg = loop {
        n += 1;
        assert!(n < 100, "the cap never refused a frame");
        match t.update_detections(f64::from(n), &boxes(2, 10.0 + f64::from(n))) {
            Ok(_) => {}
            Err(e) => break error_message(e),
        }
    };
    assert!(msg.contains("at most 20 shapes"), "{msg}");
    assert!(t.kept_shapes() >= 20);
    // Nothing changed: the frame was not tracked, every kept shape is there, and the offline
    // pass runs over them.
    assert_eq!(t.frame(), n - 1);
    let kept = records(t.tracks().unwrap());
    assert_eq!(kept.len() as u32, t.kept_shapes());
    assert_eq!(kept.iter().map(|r| r.frame).max(), Some(n - 1));
    let again = t.update_detections(f64::from(n), &boxes(2, 10.0)).err();
    assert!(error_message(again.unwrap()).contains("at most 20 shapes"));
    assert!(t.finish(None).is_ok());
    // The default cap.
    let t = Tracker::new(None, None).unwrap();
    assert_eq!(t.max_kept_shapes() as usize, MAX_KEPT_SHAPES);
    assert_eq!(t.kept_shapes(), 0);
}

#[wasm_bindgen_test]
fn a_refused_first_frame_does_not_bind_the_tracker_to_its_size() {
    let mut t = Tracker::new(None, None).unwrap();
    let big = FrameBuffer::new(64.0, 48.0).unwrap();
    // More detections than the tracker takes in one frame: the core refuses the frame.
    let msg = error_message(t.update(1.0, &big, &boxes(2001, 0.0)).err().unwrap());
    assert!(msg.contains("2000"), "{msg}");
    assert_eq!(t.frame(), 0);
    // The first frame that is tracked sets the size (it was the refused frame's: "frame size
    // changed from (64, 48) to (32, 32)" on every later frame).
    let small = FrameBuffer::new(32.0, 32.0).unwrap();
    t.update(1.0, &small, &boxes(0, 0.0)).unwrap();
    assert_eq!(t.frame(), 1);
    let msg = error_message(t.update(2.0, &big, &boxes(0, 0.0)).err().unwrap());
    assert!(msg.contains("frame size changed"), "{msg}");
}
