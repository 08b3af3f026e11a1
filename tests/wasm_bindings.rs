//! The browser bindings, run in wasm by wasm-bindgen-test (under Node):
//!
//! `CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUNNER=wasm-bindgen-test-runner cargo test
//!  --target wasm32-unknown-unknown --no-default-features --test wasm_bindings`
//!
//! They call the exported functions the way the generated JS glue does (typed JS values in,
//! typed JS values out) and check the JS-visible results, including that failures arrive as JS
//! `Error` objects with the core's message.
#![cfg(target_arch = "wasm32")]

use serde::Serialize;
use shapetrack::wasm::*;
use tsify::Ts;
use wasm_bindgen::{JsCast, JsValue};
use wasm_bindgen_test::*;

/// A JS value built from a Rust value the way a JS caller would pass it.
fn js<T: Serialize>(v: &T) -> JsValue {
    v.serialize(&serde_wasm_bindgen::Serializer::json_compatible())
        .unwrap()
}

fn ts<T: tsify::Tsify>(v: JsValue) -> Ts<T> {
    Ts::new_unchecked(v)
}

/// The message of a JS `Error`; fails the test for anything else.
fn error_message(e: JsValue) -> String {
    let err: js_sys::Error = e.dyn_into().expect("a JS Error object");
    String::from(err.message())
}

fn records_of(v: Ts<Records>) -> Vec<RecordJs> {
    serde_wasm_bindgen::from_value(JsValue::from(v)).unwrap()
}

const MOT: &str =
    "1,1,10,20,30,40,1,-1,-1,-1\n1,2,100,20,30,40,0.5,-1,-1,-1\n2,1,12,21,30,40,1,-1,-1,-1\n";

#[wasm_bindgen_test]
fn frame_buffer_is_rgba_in_wasm_memory() {
    let buf = FrameBuffer::new(64, 48).unwrap();
    assert_eq!(buf.len(), 64 * 48 * 4);
    assert_eq!((buf.width(), buf.height()), (64, 48));
    // The pointer must lie inside linear memory so JS can build a view on it.
    let mem: js_sys::WebAssembly::Memory = wasm_bindgen::memory().dyn_into().unwrap();
    let size = mem
        .buffer()
        .dyn_into::<js_sys::ArrayBuffer>()
        .unwrap()
        .byte_length() as usize;
    assert!(buf.ptr() as usize + buf.len() <= size);
}

#[wasm_bindgen_test]
fn frame_buffer_rejects_bad_sizes_with_an_error() {
    for (w, h) in [(0, 10), (10, 0), (20000, 10)] {
        let msg = error_message(FrameBuffer::new(w, h).err().unwrap());
        assert!(msg.contains(&format!("{w}x{h}")), "{msg}");
    }
}

#[wasm_bindgen_test]
fn mot_text_round_trips_through_records() {
    let recs = parse_records(ts(JsValue::from_str("mot")), MOT, "a.txt").unwrap();
    let v = records_of(recs);
    assert_eq!(v.len(), 3);
    assert_eq!(
        (v[1].frame, v[1].id, v[1].bbox.x, v[1].score),
        (1, 2, 100.0, 0.5)
    );
    let text = write_records(ts(JsValue::from_str("mot")), ts(js(&v))).unwrap();
    assert_eq!(text, MOT);
}

#[wasm_bindgen_test]
fn records_from_js_take_defaults_for_missing_fields() {
    let row =
        serde_json::json!([{ "frame": 3, "id": 7, "bbox": { "x": 1, "y": 2, "w": 3, "h": 4 } }]);
    let text = write_records(ts(JsValue::from_str("mot")), ts(js(&row))).unwrap();
    assert_eq!(text, "3,7,1,2,3,4,1,-1,-1,-1\n");
}

#[wasm_bindgen_test]
fn parse_errors_name_file_line_and_column() {
    let msg = error_message(
        parse_records(
            ts(JsValue::from_str("mot")),
            "1,1,10,20,30,40\n2,x,1,1,1,1\n",
            "gt.txt",
        )
        .err()
        .unwrap(),
    );
    assert!(msg.starts_with("gt.txt:2:2:"), "{msg}");
}

#[wasm_bindgen_test]
fn bad_js_values_are_errors_not_traps() {
    let msg = error_message(
        write_records(ts(JsValue::from_str("mot")), ts(JsValue::from_f64(3.0)))
            .err()
            .unwrap(),
    );
    assert!(msg.contains("Records"), "{msg}");
    let msg = error_message(
        parse_records(ts(JsValue::from_str("yaml")), "", "x")
            .err()
            .unwrap(),
    );
    assert!(msg.contains("yaml"), "{msg}");
    // A negative box size is a core FrameError, surfaced with its message.
    let row =
        serde_json::json!([{ "frame": 1, "id": 1, "bbox": { "x": 0, "y": 0, "w": -3, "h": 4 } }]);
    let msg = error_message(
        write_records(ts(JsValue::from_str("mot")), ts(js(&row)))
            .err()
            .unwrap(),
    );
    assert!(msg.contains("negative size"), "{msg}");
}

#[wasm_bindgen_test]
fn masks_round_trip_between_bitmaps_and_rle() {
    let (w, h) = (8u32, 6u32);
    let mut full = vec![0u8; (w * h) as usize];
    for (x, y) in [(2, 1), (3, 1), (3, 2), (5, 4)] {
        full[y * w as usize + x] = 1;
    }
    let rle = encode_mask(w, h, &full).unwrap();
    let rle_v: RleJs = serde_wasm_bindgen::from_value(JsValue::from(rle.clone())).unwrap();
    assert_eq!(rle_v.size, [h, w]);
    let bm = decode_mask(rle).unwrap();
    let bm_js = JsValue::from(bm);
    // `data` must reach JS as a Uint8Array, not an array of numbers.
    let data = js_sys::Reflect::get(&bm_js, &"data".into()).unwrap();
    let data: js_sys::Uint8Array = data.dyn_into().expect("Uint8Array");
    let x = js_sys::Reflect::get(&bm_js, &"x".into())
        .unwrap()
        .as_f64()
        .unwrap();
    let width = js_sys::Reflect::get(&bm_js, &"width".into())
        .unwrap()
        .as_f64()
        .unwrap();
    assert_eq!((x, width), (2.0, 4.0));
    assert_eq!(data.to_vec().iter().map(|&v| v as u32).sum::<u32>(), 4);
    let msg = error_message(encode_mask(w, h, &full[1..]).err().unwrap());
    assert!(msg.contains("expected 8x6"), "{msg}");
}

#[wasm_bindgen_test]
fn mots_text_round_trips_byte_exact() {
    let (w, h) = (8u32, 6u32);
    let mut full = vec![0u8; (w * h) as usize];
    for i in [9, 10, 17, 18, 30] {
        full[i] = 1;
    }
    let rle: RleJs =
        serde_wasm_bindgen::from_value(JsValue::from(encode_mask(w, h, &full).unwrap())).unwrap();
    let line = format!("1 5 2 {h} {w} {}\n", rle.counts);
    let recs = parse_records(ts(JsValue::from_str("mots")), &line, "m.txt").unwrap();
    let v = records_of(recs.clone());
    // The box is derived from the mask: columns 1..=6, rows 1..=3.
    assert_eq!(
        (v[0].bbox.x, v[0].bbox.y, v[0].bbox.w, v[0].bbox.h),
        (1.0, 1.0, 6.0, 3.0)
    );
    let text = write_records(ts(JsValue::from_str("mots")), ts(JsValue::from(recs))).unwrap();
    assert_eq!(text, line);
}
