//! The wasm entry points' Rust side under mutated input, in wasm (wasm-bindgen-test, Node):
//! settings objects, RLE objects, detection lists and annotation text, each mutated from a
//! valid seed. A panic here is a trap that would kill the page's tracker, so the test passing
//! means every input came back as a value or a JS `Error`. `tests/fuzz_parsers.rs` does the
//! same natively for the readers behind `parseAnnotations`, with many more executions.
#![cfg(target_arch = "wasm32")]

use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use shapetrack::wasm::*;
use tsify::Ts;
use wasm_bindgen::{JsCast, JsValue};
use wasm_bindgen_test::*;

fn ts<T: tsify::Tsify>(v: JsValue) -> Ts<T> {
    Ts::new_unchecked(v)
}

const TOKENS: &[&str] = &[
    "0",
    "-1",
    "1e300",
    "4294967296",
    "65536",
    "1.5",
    "null",
    "[]",
    "{}",
    "\"x\"",
    "true",
    "[1,2]",
    "{\"a\":{\"b\":{}}}",
];

/// A few edits of `seed`: bytes flipped or dropped, numbers and tokens swapped in.
fn mutate(rng: &mut Xoshiro256PlusPlus, seed: &str) -> String {
    let mut out = seed.as_bytes().to_vec();
    for _ in 0..1 + rng.gen_range(0..3) {
        let n = out.len();
        if n == 0 {
            break;
        }
        let at = rng.gen_range(0..n);
        match rng.gen_range(0..4) {
            0 => out[at] ^= 1 << rng.gen_range(0..7),
            1 => {
                out.remove(at);
            }
            2 => {
                // Replace the number starting at or after `at`.
                if let Some(s) = (at..n).find(|&i| out[i].is_ascii_digit()) {
                    let e = (s..n)
                        .find(|&i| !(out[i].is_ascii_digit() || out[i] == b'.'))
                        .unwrap_or(n);
                    let t = TOKENS[rng.gen_range(0..TOKENS.len())];
                    out.splice(s..e, t.bytes());
                }
            }
            _ => {
                let t = TOKENS[rng.gen_range(0..TOKENS.len())];
                out.splice(at..at, t.bytes());
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// A JS value from JSON text, when it parses.
fn json(text: &str) -> Option<JsValue> {
    js_sys::JSON::parse(text).ok()
}

/// Executions per entry point and seed kind (a few seconds in wasm).
const ITERS: usize = 20_000;

#[wasm_bindgen_test]
fn mutated_settings_never_trap() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
    let tracker = r#"{"preset":"masks","max_lost":30,"motion":{"std_measurement":0.1},"terms":{"iou":{"weight":1}}}"#;
    let offline = r#"{"fps":25,"width":64,"height":48,"relink":{},"fill":{"max_gap_seconds":2}}"#;
    let background = r#"{"alpha":0.05,"threshold":25,"min_area":20,"connectivity":4,"update":{"selective":{"foreground_alpha":0.01}},"shadow":{}}"#;
    for _ in 0..ITERS {
        if let Some(v) = json(&mutate(&mut rng, tracker)) {
            let _ = Tracker::new(Some(v.unchecked_into()), None);
        }
        if let Some(v) = json(&mutate(&mut rng, offline)) {
            let _ = Tracker::new(None, Some(v.unchecked_into()));
        }
        if let Some(v) = json(&mutate(&mut rng, background)) {
            let _ = BackgroundDetector::new(Some(v.unchecked_into()));
        }
    }
    // Still a working module.
    assert!(Tracker::new(None, None).is_ok());
}

#[wasm_bindgen_test]
fn mutated_masks_and_detections_never_trap() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(2);
    let rle = r#"{"size":[6,8],"counts":"d025O?"}"#;
    let lists = r#"{"masks":[{"x":1,"y":2,"width":2,"height":2,"data":[1,1,0,1],"score":0.9,"class":1}],"boxes":[{"bbox":{"x":0,"y":0,"w":4,"h":5},"score":0.5,"class":-1}]}"#;
    for _ in 0..ITERS {
        if let Some(v) = json(&mutate(&mut rng, rle)) {
            let _ = decode_mask(ts(v));
        }
        if let Some(v) = json(&mutate(&mut rng, lists)) {
            if let Ok(d) = Detections::from_lists(ts(v)) {
                let mut t = Tracker::new(None, None).unwrap();
                let _ = t.update_detections(1.0, &d);
            }
        }
    }
}

#[wasm_bindgen_test]
fn mutated_annotation_text_never_traps() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
    let seeds = [
        ("mot", "1,1,10,20,30,40,1,-1,-1,-1\n2,1,12,20,30,40,1,-1,-1,-1\n"),
        ("mots", "1 1 1 6 8 d025O?\n"),
        (
            "cvat",
            "<annotations><version>1.1</version><meta><task><size>3</size><original_size><width>8</width><height>6</height></original_size></task></meta><track id=\"0\" label=\"a\"><box frame=\"0\" keyframe=\"1\" outside=\"0\" occluded=\"0\" xtl=\"1\" ytl=\"1\" xbr=\"5\" ybr=\"5\"/><box frame=\"2\" keyframe=\"1\" outside=\"0\" occluded=\"0\" xtl=\"2\" ytl=\"1\" xbr=\"6\" ybr=\"5\"/></track></annotations>",
        ),
        (
            "coco-video",
            r#"{"videos":[{"id":1,"width":8,"height":6,"length":2}],"annotations":[{"id":1,"video_id":1,"category_id":1,"bboxes":[[1,1,3,3],null],"areas":[9,null],"segmentations":[null,null]}],"categories":[{"id":1,"name":"a"}]}"#,
        ),
        (
            "scalabel",
            r#"[{"name":"a-1.jpg","videoName":"a","frameIndex":0,"labels":[{"id":"1","category":"car","box2d":{"x1":1,"y1":1,"x2":4,"y2":4}}]}]"#,
        ),
        (
            "label-studio",
            r#"[{"data":{"video":"v"},"annotations":[{"result":[{"id":"1","type":"videorectangle","value":{"framesCount":3,"labels":["a"],"sequence":[{"frame":1,"enabled":true,"x":10,"y":10,"width":20,"height":20},{"frame":3,"enabled":false,"x":20,"y":10,"width":20,"height":20}]}}]}]}]"#,
        ),
        ("yolo", "1 0 0.5 0.5 0.25 0.5 0.9 7\n2 0 0.5 0.5 0.25 0.5 0.9 7\n"),
    ];
    for k in 0..ITERS {
        let (format, seed) = seeds[k % seeds.len()];
        let text = mutate(&mut rng, seed);
        // The frame size Label Studio and YOLO need (the others ignore it).
        let meta = json(r#"{"width": 8, "height": 6}"#).map(ts);
        let _ = parse_annotations(
            ts(JsValue::from_str(format)),
            JsValue::from_str(&text),
            JsValue::from_str("f"),
            meta,
        );
    }
}
