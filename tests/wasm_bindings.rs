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

/// A settings object (`TrackerSettings`, `OfflineSettings`, …) as a JS caller passes it.
fn settings<T: JsCast>(v: &serde_json::Value) -> T {
    js(v).unchecked_into()
}

/// The message of a JS `Error`; fails the test for anything else.
fn error_message(e: JsValue) -> String {
    let err: js_sys::Error = e.dyn_into().expect("a JS Error object");
    String::from(err.message())
}

fn records_of(v: Ts<Records>) -> Vec<RecordJs> {
    serde_wasm_bindgen::from_value(JsValue::from(v)).unwrap()
}

/// Parses `text` as `format` and returns the records as plain structs.
fn parse(format: &str, text: &str, name: &str) -> Result<Vec<RecordJs>, JsValue> {
    let a = parse_annotations(
        ts(JsValue::from_str(format)),
        JsValue::from_str(text),
        JsValue::from_str(name),
        None,
    )?;
    let v: serde_json::Value = serde_wasm_bindgen::from_value(JsValue::from(a)).unwrap();
    Ok(serde_json::from_value(v["records"].clone()).unwrap())
}

/// Writes records as `format` with optional sequence info.
fn write<T: Serialize>(
    format: &str,
    records: &T,
    meta: Option<serde_json::Value>,
) -> Result<String, JsValue> {
    write_annotations(
        ts(JsValue::from_str(format)),
        ts(js(records)),
        meta.map(|m| ts(js(&m))),
    )
}

const MOT: &str =
    "1,1,10,20,30,40,1,-1,-1,-1\n1,2,100,20,30,40,0.5,-1,-1,-1\n2,1,12,21,30,40,1,-1,-1,-1\n";

#[wasm_bindgen_test]
fn frame_buffer_is_rgba_in_wasm_memory() {
    let buf = FrameBuffer::new(64.0, 48.0).unwrap();
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
        let msg = error_message(FrameBuffer::new(f64::from(w), f64::from(h)).err().unwrap());
        assert!(msg.contains(&format!("{w}x{h}")), "{msg}");
    }
}

#[wasm_bindgen_test]
fn mot_text_round_trips_through_records() {
    let v = parse("mot", MOT, "a.txt").unwrap();
    assert_eq!(v.len(), 3);
    assert_eq!(
        (v[1].frame, v[1].id, v[1].bbox.x, v[1].score),
        (1, 2, 100.0, 0.5)
    );
    let text = write("mot", &v, None).unwrap();
    assert_eq!(text, MOT);
}

#[wasm_bindgen_test]
fn records_from_js_take_defaults_for_missing_fields() {
    let row =
        serde_json::json!([{ "frame": 3, "id": 7, "bbox": { "x": 1, "y": 2, "w": 3, "h": 4 } }]);
    let text = write("mot", &row, None).unwrap();
    assert_eq!(text, "3,7,1,2,3,4,1,-1,-1,-1\n");
}

#[wasm_bindgen_test]
fn parse_errors_name_file_line_and_column() {
    let msg = error_message(
        parse("mot", "1,1,10,20,30,40\n2,x,1,1,1,1\n", "gt.txt")
            .err()
            .unwrap(),
    );
    assert!(msg.starts_with("gt.txt:2:2:"), "{msg}");
}

#[wasm_bindgen_test]
fn bad_js_values_are_errors_not_traps() {
    let msg = error_message(
        write_annotations(
            ts(JsValue::from_str("mot")),
            ts(JsValue::from_f64(3.0)),
            None,
        )
        .err()
        .unwrap(),
    );
    assert!(msg.contains("Records"), "{msg}");
    let msg = error_message(parse("yaml", "", "x").err().unwrap());
    assert!(msg.contains("yaml"), "{msg}");
    // A negative box size is a core FrameError, surfaced with its message.
    let row =
        serde_json::json!([{ "frame": 1, "id": 1, "bbox": { "x": 0, "y": 0, "w": -3, "h": 4 } }]);
    let msg = error_message(write("mot", &row, None).err().unwrap());
    assert!(msg.contains("negative size"), "{msg}");
}

#[wasm_bindgen_test]
fn masks_round_trip_between_bitmaps_and_rle() {
    let (w, h) = (8u32, 6u32);
    let mut full = vec![0u8; (w * h) as usize];
    for (x, y) in [(2, 1), (3, 1), (3, 2), (5, 4)] {
        full[y * w as usize + x] = 1;
    }
    let rle = encode_mask(f64::from(w), f64::from(h), &full).unwrap();
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
    let msg = error_message(
        encode_mask(f64::from(w), f64::from(h), &full[1..])
            .err()
            .unwrap(),
    );
    assert!(msg.contains("expected 8x6"), "{msg}");
}

#[wasm_bindgen_test]
fn mots_text_round_trips_byte_exact() {
    let (w, h) = (8u32, 6u32);
    let mut full = vec![0u8; (w * h) as usize];
    for i in [9, 10, 17, 18, 30] {
        full[i] = 1;
    }
    let rle: RleJs = serde_wasm_bindgen::from_value(JsValue::from(
        encode_mask(f64::from(w), f64::from(h), &full).unwrap(),
    ))
    .unwrap();
    let line = format!("1 5 2 {h} {w} {}\n", rle.counts);
    let v = parse("mots", &line, "m.txt").unwrap();
    // The box is derived from the mask: columns 1..=6, rows 1..=3.
    assert_eq!(
        (v[0].bbox.x, v[0].bbox.y, v[0].bbox.w, v[0].bbox.h),
        (1.0, 1.0, 6.0, 3.0)
    );
    let text = write("mots", &v, None).unwrap();
    assert_eq!(text, line);
}

/// Two tracks with masks in an 8×6 image over frames 1–3.
fn masked_records() -> Vec<RecordJs> {
    let (w, h) = (8u32, 6u32);
    let mut out = Vec::new();
    for f in 1..=3u32 {
        for (id, x0) in [(1i64, f as usize - 1), (2, 5)] {
            let mut full = vec![0u8; (w * h) as usize];
            for y in 1..3 {
                full[y * w as usize + x0] = 1;
                full[y * w as usize + x0 + 1] = 1;
            }
            let rle: RleJs = serde_wasm_bindgen::from_value(JsValue::from(
                encode_mask(f64::from(w), f64::from(h), &full).unwrap(),
            ))
            .unwrap();
            let row = serde_json::json!({
                "frame": f, "id": id, "class": 1,
                "bbox": { "x": x0, "y": 1, "w": 2, "h": 2 }, "mask": rle,
            });
            out.push(serde_json::from_value(row).unwrap());
        }
    }
    out
}

#[wasm_bindgen_test]
fn coco_video_and_cvat_round_trip_through_the_core() {
    let recs = masked_records();
    let meta = serde_json::json!({ "width": 8, "height": 6, "frames": 3, "name": "t",
        "labels": [{ "class": 1, "name": "car" }] });
    for format in ["coco-video", "cvat"] {
        let text = write(format, &recs, Some(meta.clone())).unwrap();
        let a = parse_annotations(
            ts(JsValue::from_str(format)),
            JsValue::from_str(&text),
            JsValue::from_str("x"),
            None,
        )
        .unwrap();
        let v: serde_json::Value = serde_wasm_bindgen::from_value(JsValue::from(a)).unwrap();
        assert_eq!(
            (v["width"].clone(), v["height"].clone()),
            (8.into(), 6.into()),
            "{format}"
        );
        assert_eq!(v["frames"], 3, "{format}");
        assert!(
            v["labels"]
                .as_array()
                .unwrap()
                .iter()
                .any(|l| l["name"] == "car"),
            "{format}: {v}"
        );
        let back: Vec<RecordJs> = serde_json::from_value(v["records"].clone()).unwrap();
        assert_eq!(back.len(), recs.len(), "{format}");
        for (a, b) in recs.iter().zip(&back) {
            assert_eq!((a.frame, a.id, a.bbox), (b.frame, b.id, b.bbox), "{format}");
            assert_eq!(
                a.mask.as_ref().map(|m| &m.counts),
                b.mask.as_ref().map(|m| &m.counts),
                "{format}"
            );
        }
    }
    // Without the frame size these formats cannot be written.
    let msg = error_message(write("cvat", &recs, None).err().unwrap());
    assert!(msg.contains("width and height"), "{msg}");
}

#[wasm_bindgen_test]
fn scalabel_label_studio_and_yolo_round_trip_through_the_core() {
    // Two tracks over 4 frames: a gap for id 2, a filled frame for id 1.
    let mut recs: Vec<RecordJs> = Vec::new();
    for (frame, id, x, filled) in [
        (1, 1, 0.0, false),
        (2, 1, 4.0, true),
        (3, 1, 8.0, false),
        (1, 2, 40.0, false),
        (3, 2, 44.0, false),
        (4, 2, 48.0, false),
    ] {
        let row = serde_json::json!({
            "frame": frame, "id": id, "score": 1.0, "class": 1, "visibility": -1.0,
            "interpolated": filled, "occluded": false,
            "bbox": { "x": x, "y": 10, "w": 16, "h": 20 },
        });
        recs.push(serde_json::from_value(row).unwrap());
    }
    recs.sort_by_key(|r| (r.frame, r.id));
    let meta = serde_json::json!({ "width": 160, "height": 120, "frames": 4, "name": "t",
        "labels": [{ "class": 1, "name": "car" }] });
    for format in ["scalabel", "label-studio", "yolo"] {
        let text = write(format, &recs, Some(meta.clone())).unwrap();
        let a = parse_annotations(
            ts(JsValue::from_str(format)),
            JsValue::from_str(&text),
            JsValue::from_str("x"),
            Some(ts(js(&serde_json::json!({ "width": 160, "height": 120 })))),
        )
        .unwrap();
        let v: serde_json::Value = serde_wasm_bindgen::from_value(JsValue::from(a)).unwrap();
        let back: Vec<RecordJs> = serde_json::from_value(v["records"].clone()).unwrap();
        assert_eq!(back.len(), recs.len(), "{format}: {text}");
        for (a, b) in recs.iter().zip(&back) {
            assert_eq!((a.frame, a.id), (b.frame, b.id), "{format}");
            for (p, q) in [
                (a.bbox.x, b.bbox.x),
                (a.bbox.y, b.bbox.y),
                (a.bbox.w, b.bbox.w),
                (a.bbox.h, b.bbox.h),
            ] {
                assert!((p - q).abs() < 1e-9, "{format}: {a:?} vs {b:?}");
            }
            // YOLO cannot say a frame was filled; the other two can.
            if format != "yolo" {
                assert_eq!(
                    a.interpolated, b.interpolated,
                    "{format}: frame {}",
                    a.frame
                );
            }
        }
        if format != "yolo" {
            assert!(
                v["labels"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .any(|l| l["name"] == "car"),
                "{format}: {v}"
            );
        }
    }
    // Label Studio and YOLO boxes are relative to the frame: reading needs its size.
    for format in ["label-studio", "yolo"] {
        let text = write(format, &recs, Some(meta.clone())).unwrap();
        let msg = error_message(parse(format, &text, "x").err().unwrap());
        assert!(msg.contains("width and height"), "{format}: {msg}");
    }
}

// ---------------------------------------------------------------------------------------------
// Tracker, detectors, synthetic scene, evaluation

use shapetrack::io::Rle;
use shapetrack::Mask;

fn scene(preset: &str) -> SynthScene {
    SynthScene::new(ts(JsValue::from_str(preset))).unwrap()
}

#[wasm_bindgen_test]
fn every_field_of_the_core_configs_is_a_valid_setting() {
    use shapetrack::track::Config;
    // The settings are the core's own config types (partial JSON over a preset), so the
    // complete serialised configs, every field named, are accepted as they are.
    for cfg in [Config::default(), Config::masks()] {
        let v = serde_json::to_value(&cfg).unwrap();
        assert!(Tracker::new(Some(settings(&v)), None).is_ok(), "{v}");
    }
    let mut offline =
        serde_json::to_value(shapetrack::track::offline::OfflineConfig::default()).unwrap();
    let map = offline.as_object_mut().unwrap();
    map.remove("online");
    map.insert("fps".into(), serde_json::json!(25));
    assert!(
        Tracker::new(None, Some(settings(&offline))).is_ok(),
        "{offline}"
    );
    let bg =
        serde_json::to_value(shapetrack::detect::background::BackgroundConfig::default()).unwrap();
    assert!(BackgroundDetector::new(Some(settings(&bg))).is_ok(), "{bg}");
}

#[wasm_bindgen_test]
fn mask_preset_is_reachable_from_js_and_bad_settings_name_their_field() {
    assert!(Tracker::new(
        Some(settings(&serde_json::json!({ "preset": "masks" }))),
        None
    )
    .is_ok());
    assert!(Tracker::new(
        Some(settings(&serde_json::json!({
            "preset": "masks", "high_score": 0.25, "reid_terms": { "colour": { "gate": 0.4 } }
        }))),
        None
    )
    .is_ok());
    for (bad, field) in [
        (serde_json::json!({ "preset": "mask" }), "preset"),
        (
            serde_json::json!({ "preset": "masks", "appearance": { "lazzy": true } }),
            "lazzy",
        ),
        (
            serde_json::json!({ "shape_variant": "Fourier" }),
            "shape_variant",
        ),
        (
            serde_json::json!({ "terms": { "iou": { "weight": "heavy" } } }),
            "terms.iou.weight",
        ),
        (serde_json::json!({ "min_hits": -1 }), "min_hits"),
        (
            serde_json::json!({ "score_adaptation": { "window": 1.5 } }),
            "score_adaptation.window",
        ),
    ] {
        let msg = error_message(Tracker::new(Some(settings(&bad)), None).err().unwrap());
        assert!(msg.contains(field), "{bad}: {msg}");
    }
}

#[wasm_bindgen_test]
fn partial_tracker_settings_are_accepted() {
    let partial = serde_json::json!({ "max_lost": 60, "terms": { "iou": { "weight": 0.25 } } });
    assert!(Tracker::new(Some(settings(&partial)), None).is_ok());
    // `undefined` means "not given", as in JS; `null` turns an optional setting off.
    let obj =
        js(&serde_json::json!({ "score_adaptation": null, "terms": { "iou": { "gate": null } } }));
    js_sys::Reflect::set(&obj, &"max_lost".into(), &JsValue::UNDEFINED).unwrap();
    assert!(Tracker::new(Some(obj.unchecked_into()), None).is_ok());
    // A value JSON cannot hold is an error, not a trap.
    let obj = js(&serde_json::json!({}));
    js_sys::Reflect::set(&obj, &"max_lost".into(), &js_sys::BigInt::from(3u32).into()).unwrap();
    let msg = error_message(
        Tracker::new(Some(obj.unchecked_into()), None)
            .err()
            .unwrap(),
    );
    assert!(msg.contains("JSON"), "{msg}");
    // Through the JS entry point: a typo is an error, not silently ignored.
    let msg = error_message(
        Tracker::new(Some(settings(&serde_json::json!({ "max_lots": 3 }))), None)
            .err()
            .unwrap(),
    );
    assert!(msg.contains("max_lots"), "{msg}");
    let msg = error_message(
        Tracker::new(Some(settings(&serde_json::json!({ "min_hits": 0 }))), None)
            .err()
            .unwrap(),
    );
    assert!(msg.contains("min_hits"), "{msg}");
}

/// Deterministic pseudo-random masks, some partly or wholly outside the image.
fn masks() -> Vec<Mask> {
    let mut state = 12345u64;
    let mut next = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 33) as u32
    };
    (0..200)
        .map(|_| {
            let (w, h) = (1 + next() % 30, 1 + next() % 30);
            let (x, y) = (next() as i32 % 90 - 20, next() as i32 % 70 - 20);
            let data = (0..w * h).map(|_| (next() % 3 == 0) as u8).collect();
            Mask::new(x, y, w, h, data).unwrap()
        })
        .collect()
}

/// The core's mask codec, which the page uses for every shape of every frame, agrees with the
/// full-bitmap encoding and decoding on wasm too.
#[wasm_bindgen_test]
fn mask_rle_codec_round_trips_on_wasm() {
    for m in masks() {
        let rle = Rle::from_mask(&m, 64, 48);
        let full: Vec<u8> = {
            let mut f = vec![0u8; 64 * 48];
            for (x, y) in m.pixels() {
                if (0..64).contains(&x) && (0..48).contains(&y) {
                    f[y as usize * 64 + x as usize] = 1;
                }
            }
            f
        };
        assert_eq!(rle, Rle::encode(64, 48, &full).unwrap());
        assert_eq!(rle.to_mask(), Mask::from_full(64, 48, &full).unwrap());
    }
}

#[wasm_bindgen_test]
fn synthetic_frames_are_the_same_in_order_and_out_of_order() {
    let mut a = scene("default");
    let mut b = scene("default");
    let (w, h) = (a.width(), a.height());
    let mut buf_a = FrameBuffer::new(f64::from(w), f64::from(h)).unwrap();
    let mut buf_b = FrameBuffer::new(f64::from(w), f64::from(h)).unwrap();
    let mut frames = Vec::new();
    for n in 1..=8 {
        a.render(f64::from(n), &mut buf_a).unwrap();
        frames.push(pixels(&buf_a));
    }
    // Jump ahead, then back: the scene replays to the frame asked for.
    for n in [7, 3, 8, 1] {
        let f = b.render(f64::from(n), &mut buf_b).unwrap();
        assert_eq!(f.index(), n);
        assert!(
            pixels(&buf_b) == frames[n as usize - 1],
            "frame {n} differs"
        );
    }
    let msg = error_message(b.render(0.0, &mut buf_b).err().unwrap());
    assert!(msg.contains("outside 1..=300"), "{msg}");
    // The buffer holds the core's RGB frames, pixel by pixel, opaque.
    let core = shapetrack::synth::Scene::new(shapetrack::synth::ScenePreset::Default.config(0));
    for (f, px) in core.unwrap().zip(&frames) {
        let want: Vec<u8> = f
            .image
            .chunks_exact(3)
            .flat_map(|c| [c[0], c[1], c[2], 255])
            .collect();
        assert!(*px == want, "frame {} differs from the core's", f.index);
    }
}

#[wasm_bindgen_test]
fn a_scene_at_another_size_renders_at_that_size_and_bad_sizes_are_errors() {
    let mut s = SynthScene::sized(ts(JsValue::from_str("demo")), 640.0, 360.0).unwrap();
    assert_eq!((s.width(), s.height(), s.frames()), (640, 360, 600));
    let mut buf = FrameBuffer::new(640.0, 360.0).unwrap();
    let f = s.render(1.0, &mut buf).unwrap();
    // The core's demo at that size, frame for frame.
    let cfg = shapetrack::synth::SynthConfig::demo().scaled_to(640, 360);
    let core = shapetrack::synth::Scene::new(cfg).unwrap().next().unwrap();
    assert_eq!(records_of(f.ground_truth().unwrap()).len(), core.gt.len());
    let rgb: Vec<u8> = pixels(&buf)
        .chunks_exact(4)
        .flat_map(|c| [c[0], c[1], c[2]])
        .collect();
    assert!(rgb == core.image);
    for (w, h, what) in [
        (8.0, 360.0, "size"),
        (640.5, 360.0, "width"),
        (640.0, -1.0, "height"),
    ] {
        let msg = error_message(
            SynthScene::sized(ts(JsValue::from_str("demo")), w, h)
                .err()
                .unwrap(),
        );
        assert!(msg.contains(what), "{w}x{h}: {msg}");
    }
}

/// The frame buffer's bytes, read through wasm memory as JS would.
fn pixels(buf: &FrameBuffer) -> Vec<u8> {
    let mem: js_sys::WebAssembly::Memory = wasm_bindgen::memory().dyn_into().unwrap();
    // Copy on the JS side first: allocating the Vec may grow wasm memory, which detaches a
    // view on it (the reason the app rebuilds its views before every use).
    js_sys::Uint8Array::new_with_byte_offset_and_length(
        &mem.buffer(),
        buf.ptr() as u32,
        buf.len() as u32,
    )
    .slice(0, buf.len() as u32)
    .to_vec()
}

#[wasm_bindgen_test]
fn tracker_keeps_ids_on_the_scene_masks_and_refuses_out_of_order_frames() {
    let mut s = scene("default");
    let mut buf = FrameBuffer::new(f64::from(s.width()), f64::from(s.height())).unwrap();
    let mut tracker = Tracker::new(None, None).unwrap();
    // Track id per gt object over 40 frames, from the scene's own detections.
    let mut seen: std::collections::BTreeMap<i64, std::collections::BTreeSet<i64>> =
        Default::default();
    for n in 1..=40 {
        let f = s.render(f64::from(n), &mut buf).unwrap();
        let shapes: Vec<serde_json::Value> = serde_wasm_bindgen::from_value(JsValue::from(
            tracker.update(f64::from(n), &buf, &f.detections()).unwrap(),
        ))
        .unwrap();
        let gt = records_of(f.ground_truth().unwrap());
        for sh in shapes.iter().filter(|s| s["frame"] == n) {
            let b = &sh["bbox"];
            let (x, y) = (b["x"].as_f64().unwrap(), b["y"].as_f64().unwrap());
            let (w, h) = (b["w"].as_f64().unwrap(), b["h"].as_f64().unwrap());
            let tb = shapetrack::BBox::new(x, y, w, h);
            if let Some(g) = gt.iter().find(|g| {
                shapetrack::BBox::new(g.bbox.x, g.bbox.y, g.bbox.w, g.bbox.h).iou(&tb) > 0.7
            }) {
                seen.entry(g.id)
                    .or_default()
                    .insert(sh["id"].as_i64().unwrap());
            }
            assert!(sh["mask"]["counts"].is_string(), "masks come back as RLE");
        }
    }
    assert_eq!(tracker.frame(), 40);
    // The phases were timed with the host's clock, every frame.
    let p: serde_json::Value =
        serde_wasm_bindgen::from_value(JsValue::from(tracker.phase_times().unwrap())).unwrap();
    assert_eq!(p["frames"], 40, "{p}");
    for phase in ["features", "regions", "costs", "assignment", "update"] {
        let ms = p[phase].as_f64().unwrap();
        assert!(ms.is_finite() && ms >= 0.0, "{phase}: {p}");
    }
    assert!(seen.len() >= 5, "most objects tracked: {seen:?}");
    let stable = seen.values().filter(|ids| ids.len() == 1).count();
    assert!(stable * 10 >= seen.len() * 8, "ids per object: {seen:?}");
    // The whole history comes back as records.
    let all = records_of(tracker.tracks().unwrap());
    assert!(all.iter().all(|r| r.mask.is_some()));
    // Frames go in order.
    let f = s.render(42.0, &mut buf).unwrap();
    let msg = error_message(tracker.update(42.0, &buf, &f.detections()).err().unwrap());
    assert!(msg.contains("expected frame 41, got 42"), "{msg}");
    // A frame of another size is refused.
    let small = FrameBuffer::new(8.0, 8.0).unwrap();
    let msg = error_message(tracker.update(41.0, &small, &f.detections()).err().unwrap());
    assert!(msg.contains("frame size changed"), "{msg}");
}

#[wasm_bindgen_test]
fn update_returns_each_shape_with_the_shape_types_keys_and_the_records_values() {
    let keys = |v: &JsValue| -> Vec<String> {
        js_sys::Object::keys(v.unchecked_ref::<js_sys::Object>())
            .iter()
            .map(|k| k.as_string().unwrap())
            .collect()
    };
    let mut s = scene("default");
    let mut buf = FrameBuffer::new(f64::from(s.width()), f64::from(s.height())).unwrap();
    let mut tracker = Tracker::new(None, None).unwrap();
    let mut returned: Vec<serde_json::Value> = Vec::new();
    for n in 1..=12 {
        let f = s.render(f64::from(n), &mut buf).unwrap();
        let shapes = JsValue::from(tracker.update(f64::from(n), &buf, &f.detections()).unwrap());
        assert!(js_sys::Array::is_array(&shapes));
        for sh in js_sys::Array::from(&shapes).iter() {
            // The keys of `Shape`, in its order (what JSON exports of update's output show).
            let want = [
                "frame",
                "id",
                "bbox",
                "score",
                "class",
                "mask",
                "interpolated",
                "state",
                "centroid",
                "cost",
            ];
            assert_eq!(keys(&sh), want);
            let get = |k: &str| js_sys::Reflect::get(&sh, &k.into()).unwrap();
            assert_eq!(keys(&get("bbox")), ["x", "y", "w", "h"]);
            assert_eq!(keys(&get("centroid")), ["x", "y"]);
            assert_eq!(keys(&get("mask")), ["size", "counts"]);
            returned.push(serde_wasm_bindgen::from_value(sh).unwrap());
        }
    }
    assert!(returned.len() >= 12 * 5, "{} shapes", returned.len());
    // Every value is the one the tracker keeps: the records of the same frame and id.
    let records = records_of(tracker.tracks().unwrap());
    let states = ["tentative", "confirmed", "lost", "removed"];
    let (mut confirmed, mut detected) = (0, 0);
    for sh in &returned {
        let (frame, id) = (sh["frame"].as_u64().unwrap(), sh["id"].as_i64().unwrap());
        let r = records
            .iter()
            .find(|r| u64::from(r.frame) == frame && r.id == id)
            .unwrap_or_else(|| panic!("no record for {sh}"));
        let b = &sh["bbox"];
        let bbox = [&b["x"], &b["y"], &b["w"], &b["h"]].map(|v| v.as_f64().unwrap());
        assert_eq!(bbox, [r.bbox.x, r.bbox.y, r.bbox.w, r.bbox.h], "{sh}");
        assert_eq!(sh["score"].as_f64().unwrap(), r.score, "{sh}");
        assert_eq!(sh["class"].as_i64().unwrap(), i64::from(r.class), "{sh}");
        let m = r.mask.as_ref().unwrap();
        assert_eq!(sh["mask"]["counts"].as_str().unwrap(), m.counts, "{sh}");
        assert_eq!(sh["mask"]["size"], serde_json::json!(m.size), "{sh}");
        assert_eq!(sh["interpolated"], r.interpolated, "{sh}");
        detected += usize::from(sh["interpolated"] == false);
        assert!(states.contains(&sh["state"].as_str().unwrap()), "{sh}");
        confirmed += usize::from(sh["state"] == "confirmed");
        let (cx, cy) = (sh["centroid"]["x"].as_f64(), sh["centroid"]["y"].as_f64());
        assert!(
            cx.is_some_and(|x| x > r.bbox.x && x < r.bbox.x + r.bbox.w),
            "{sh}"
        );
        assert!(
            cy.is_some_and(|y| y > r.bbox.y && y < r.bbox.y + r.bbox.h),
            "{sh}"
        );
        assert!(sh["cost"].as_f64().is_some_and(f64::is_finite), "{sh}");
    }
    assert!(
        confirmed * 2 > returned.len(),
        "mostly confirmed: {confirmed}"
    );
    assert!(detected * 2 > returned.len(), "mostly detected: {detected}");
    // Two shapes' masks differ (each one gets its own part of the counts).
    let first = &returned[0]["mask"]["counts"];
    assert!(returned.iter().any(|sh| &sh["mask"]["counts"] != first));

    // Box detections without pixels: no `mask` key at all (not `undefined`).
    let mut boxes = Tracker::new(None, None).unwrap();
    for n in 1..=3 {
        let x = 10.0 + 2.0 * f64::from(n);
        let lists = serde_json::json!({
            "boxes": [{ "bbox": { "x": x, "y": 20, "w": 30, "h": 40 }, "score": 0.9, "class": 2 }],
        });
        let dets = Detections::from_lists(ts(js(&lists))).unwrap();
        let shapes = JsValue::from(boxes.update_detections(f64::from(n), &dets).unwrap());
        for sh in js_sys::Array::from(&shapes).iter() {
            let want = [
                "frame",
                "id",
                "bbox",
                "score",
                "class",
                "interpolated",
                "state",
                "centroid",
                "cost",
            ];
            assert_eq!(keys(&sh), want);
            let v: serde_json::Value = serde_wasm_bindgen::from_value(sh).unwrap();
            assert_eq!(v["frame"], n);
            assert_eq!(v["class"], 2);
            assert_eq!(v["score"], 0.9);
        }
    }
}

#[wasm_bindgen_test]
fn detections_from_js_lists_are_checked() {
    let ok = serde_json::json!({
        "boxes": [{ "bbox": { "x": 1, "y": 2, "w": 3, "h": 4 }, "score": 0.5 }],
    });
    let d = Detections::from_lists(ts(js(&ok))).unwrap();
    assert_eq!(d.len(), 1);
    let bad = serde_json::json!({ "boxes": [{ "bbox": { "x": 1, "y": 2, "w": -3, "h": 4 } }] });
    let msg = error_message(Detections::from_lists(ts(js(&bad))).err().unwrap());
    assert!(msg.contains("negative size"), "{msg}");
    // A mask is a Uint8Array whose length must match its size.
    let lists = js_sys::Object::new();
    let m = js_sys::Object::new();
    for (k, v) in [("x", 2.0), ("y", 3.0), ("width", 2.0), ("height", 2.0)] {
        js_sys::Reflect::set(&m, &k.into(), &v.into()).unwrap();
    }
    js_sys::Reflect::set(
        &m,
        &"data".into(),
        &js_sys::Uint8Array::from(&[1u8, 1, 0][..]),
    )
    .unwrap();
    js_sys::Reflect::set(&lists, &"masks".into(), &js_sys::Array::of1(&m)).unwrap();
    let msg = error_message(Detections::from_lists(ts(lists.into())).err().unwrap());
    assert!(msg.contains("expected 2x2"), "{msg}");
}

#[wasm_bindgen_test]
fn background_detector_finds_the_moving_shapes() {
    let mut s = scene("default");
    let mut buf = FrameBuffer::new(f64::from(s.width()), f64::from(s.height())).unwrap();
    let mut bg = BackgroundDetector::new(None).unwrap();
    let mut found = 0;
    for n in 1..=40 {
        s.render(f64::from(n), &mut buf).unwrap();
        found = bg.detect(&buf).unwrap().len();
    }
    assert!(found >= 3, "{found} detections after the model settled");
    for (opts, field) in [
        (serde_json::json!({ "connectivity": 6 }), "connectivity"),
        (serde_json::json!({ "alpha": 0 }), "alpha"),
        (serde_json::json!({ "update": "sometimes" }), "update"),
        (
            serde_json::json!({ "shadow": { "max_chrome": 1 } }),
            "max_chrome",
        ),
    ] {
        let msg = error_message(
            BackgroundDetector::new(Some(settings(&opts)))
                .err()
                .unwrap(),
        );
        assert!(msg.contains(field), "{opts}: {msg}");
    }
    let opts = serde_json::json!({ "connectivity": 4, "shadow": {}, "update": "all" });
    assert!(BackgroundDetector::new(Some(settings(&opts))).is_ok());
}

#[wasm_bindgen_test]
fn evaluation_scores_perfect_and_broken_results() {
    let mut s = scene("default");
    let mut buf = FrameBuffer::new(f64::from(s.width()), f64::from(s.height())).unwrap();
    let mut gt = Vec::new();
    for n in 1..=10 {
        gt.extend(records_of(
            s.render(f64::from(n), &mut buf)
                .unwrap()
                .ground_truth()
                .unwrap(),
        ));
    }
    let scores = |res: &Vec<RecordJs>, opts: serde_json::Value| -> serde_json::Value {
        let v = evaluate(ts(js(&gt)), ts(js(res)), 10, Some(settings(&opts))).unwrap();
        serde_wasm_bindgen::from_value(JsValue::from(v)).unwrap()
    };
    let perfect = scores(&gt, serde_json::json!({}));
    assert_eq!(perfect["hota"], 100.0);
    assert_eq!(perfect["mota"], 100.0);
    let masks = scores(&gt, serde_json::json!({ "similarity": "mask" }));
    assert_eq!(masks["idf1"], 100.0);
    // Swap two ids from frame 5 on: identity metrics drop, detection does not.
    let ids: Vec<i64> = gt
        .iter()
        .filter(|r| r.frame == 5)
        .map(|r| r.id)
        .take(2)
        .collect();
    let swapped: Vec<RecordJs> = gt
        .iter()
        .cloned()
        .map(|mut r| {
            if r.frame >= 5 && ids.contains(&r.id) {
                r.id = if r.id == ids[0] { ids[1] } else { ids[0] };
            }
            r
        })
        .collect();
    let sw = scores(&swapped, serde_json::json!({}));
    assert!(sw["mota"].as_f64().unwrap() < 100.0);
    assert_eq!(sw["idsw"], 2);
    assert_eq!(sw["deta"], 100.0);
    let msg = error_message(
        evaluate(
            ts(js(&gt)),
            ts(js(&gt)),
            10,
            Some(settings(&serde_json::json!({ "similarity": "area" }))),
        )
        .err()
        .unwrap(),
    );
    assert!(msg.contains("similarity"), "{msg}");
}

// ------------------------------------------------------------------------------------------
// The offline pass from JS

#[wasm_bindgen_test]
fn offline_options_are_checked() {
    let bad = |opts: serde_json::Value| -> String {
        error_message(Tracker::new(None, Some(settings(&opts))).err().unwrap())
    };
    assert!(bad(serde_json::json!({ "fps": 0 })).contains("fps"));
    assert!(bad(serde_json::json!({})).contains("fps"));
    let msg = bad(serde_json::json!({ "fps": 25, "relink": { "max_slave": 3 } }));
    assert!(msg.contains("max_slave"), "{msg}");
    let msg = bad(serde_json::json!({ "fps": 25, "relink": { "max_size_ratio": 0.5 } }));
    assert!(msg.contains("relink.max_size_ratio"), "{msg}");
    let msg = bad(serde_json::json!({ "fps": 25, "width": 640 }));
    assert!(msg.contains("width/height"), "{msg}");
    let msg = bad(serde_json::json!({ "fps": 25, "width": 640.5, "height": 480 }));
    assert!(msg.contains("width"), "{msg}");
    let msg = bad(serde_json::json!({ "fps": "25" }));
    assert!(msg.contains("fps"), "{msg}");
    let msg = bad(serde_json::json!({ "fps": 25, "fill": { "max_gap": "long" } }));
    assert!(msg.contains("fill.max_gap"), "{msg}");
    let msg = bad(serde_json::json!({ "fps": 25, "online": { "max_lost": 3 } }));
    assert!(msg.contains("online"), "{msg}");
    assert!(Tracker::new(
        None,
        Some(settings(&serde_json::json!({ "fps": 30, "relink": { "solver": "greedy" }, "fill": { "max_gap": 4 } })))
    )
    .is_ok());
    // An online tracker has no offline pass.
    let mut online = Tracker::new(None, None).unwrap();
    assert!(!online.offline());
    let msg = error_message(online.finish(None).err().unwrap());
    assert!(msg.contains("offline options"), "{msg}");
}

/// A JS function that appends its argument to `log` (what a page's progress callback does).
fn recorder(log: &js_sys::Array) -> ProgressCallback {
    let push = js_sys::Function::new_with_args("p", "this.push(p)").bind0(log);
    JsValue::from(push).unchecked_into()
}

/// Ids in a list of records.
fn ids(records: &[RecordJs]) -> std::collections::BTreeSet<i64> {
    records.iter().map(|r| r.id).collect()
}

/// The mask preset reaches the core through JS: on the occlusion scene (eight shapes hidden
/// behind bars again and again) it re-identifies shapes after each hide by colour and SIFT,
/// where the box-mode defaults start new tracks; the identity scores say so too.
#[wasm_bindgen_test]
fn mask_preset_from_js_reidentifies_shapes_after_occlusions() {
    let run = |config: serde_json::Value| {
        let mut s = scene("occlusion");
        let (w, h, frames) = (s.width(), s.height(), s.frames());
        let mut buf = FrameBuffer::new(f64::from(w), f64::from(h)).unwrap();
        let mut tracker = Tracker::new(Some(settings(&config)), None).unwrap();
        let mut gt = Vec::new();
        for n in 1..=frames {
            let f = s.render(f64::from(n), &mut buf).unwrap();
            gt.extend(records_of(f.ground_truth().unwrap()));
            tracker.update(f64::from(n), &buf, &f.detections()).unwrap();
        }
        let res = records_of(tracker.tracks().unwrap());
        let opts = serde_json::json!({ "similarity": "mask" });
        let v = evaluate(ts(js(&gt)), ts(js(&res)), frames, Some(settings(&opts))).unwrap();
        let scores: serde_json::Value = serde_wasm_bindgen::from_value(JsValue::from(v)).unwrap();
        let (idf1, idsw) = (
            scores["idf1"].as_f64().unwrap(),
            scores["idsw"].as_u64().unwrap(),
        );
        (ids(&res).len(), idf1, idsw)
    };
    let (default_ids, default_idf1, default_idsw) = run(serde_json::json!({}));
    let (masks_ids, masks_idf1, masks_idsw) = run(serde_json::json!({ "preset": "masks" }));
    let msg = format!(
        "ids {default_ids} → {masks_ids}, IDF1 {default_idf1:.1} → {masks_idf1:.1}, \
         IDSW {default_idsw} → {masks_idsw}"
    );
    wasm_bindgen_test::console_log!("occlusion scene, box defaults → mask preset: {msg}");
    assert!(masks_ids * 3 <= default_ids * 2, "{msg}");
    assert!(masks_idf1 > default_idf1 + 20.0, "{msg}");
    assert!(masks_idsw < default_idsw, "{msg}");
}

#[wasm_bindgen_test]
fn finish_rejoins_occluded_tracks_and_fills_the_gaps() {
    // Eight shapes bouncing behind two bars (hidden ~10 frames each time), tracked from the
    // scene's own noisy mask detections.
    let mut s = scene("occlusion");
    let (w, h, frames, fps) = (s.width(), s.height(), s.frames(), s.fps());
    let mut buf = FrameBuffer::new(f64::from(w), f64::from(h)).unwrap();
    let opts = serde_json::json!({ "fps": fps });
    let mut tracker = Tracker::new(None, Some(settings(&opts))).unwrap();
    assert!(tracker.offline());
    let mut gt = Vec::new();
    for n in 1..=frames {
        let f = s.render(f64::from(n), &mut buf).unwrap();
        gt.extend(records_of(f.ground_truth().unwrap()));
        tracker.update(f64::from(n), &buf, &f.detections()).unwrap();
    }
    let online = records_of(tracker.tracks().unwrap());
    // Records the online pass coasted over (interpolated) stay as they are; the pass adds
    // only the gaps it fills (`added`).
    let coasted = online.iter().filter(|r| r.interpolated).count();

    let log = js_sys::Array::new();
    let t0 = js_sys::Date::now();
    let out = tracker.finish(Some(recorder(&log))).unwrap();
    let finish_ms = js_sys::Date::now() - t0;
    let out: serde_json::Value = serde_wasm_bindgen::from_value(JsValue::from(out)).unwrap();
    let records: Vec<RecordJs> = serde_json::from_value(out["records"].clone()).unwrap();
    let joins = out["joins"].as_array().unwrap();

    // Joins were made, and each master's id is gone (it carries its slave's identity now).
    assert!(!joins.is_empty(), "no joins");
    let final_ids = ids(&records);
    for j in joins {
        assert!(!final_ids.contains(&j["master"].as_i64().unwrap()), "{j}");
        assert!(j["slave_last"].as_u64().unwrap() < j["master_first"].as_u64().unwrap());
    }
    assert!(
        final_ids.len() < ids(&online).len(),
        "offline ids {} vs online {}",
        final_ids.len(),
        ids(&online).len()
    );
    // Gaps were filled: interpolated records, with masks carried along, inside the frames.
    let filled: Vec<RecordJs> = serde_json::from_value(out["added"].clone()).unwrap();
    assert!(!filled.is_empty(), "nothing filled");
    assert!(filled.iter().all(|r| r.interpolated));
    assert_eq!(out["filled"].as_u64().unwrap() as usize, filled.len());
    assert_eq!(
        records.iter().filter(|r| r.interpolated).count(),
        coasted + filled.len(),
        "no record twice"
    );
    assert!(filled.iter().all(|r| r.mask.is_some()), "filled masks");
    assert!(filled.iter().all(|r| (1..=frames).contains(&r.frame)));
    // Every online record is still there, under its joined id, and nothing else changed.
    assert_eq!(records.len(), online.len() + filled.len());
    let observed: Vec<_> = records.iter().filter(|r| !r.interpolated).collect();
    let mut by_key: std::collections::BTreeMap<(u32, String), usize> = Default::default();
    for r in online.iter().filter(|r| !r.interpolated) {
        *by_key
            .entry((r.frame, r.mask.as_ref().unwrap().counts.clone()))
            .or_default() += 1;
    }
    for r in &observed {
        let k = (r.frame, r.mask.as_ref().unwrap().counts.clone());
        let n = by_key.get_mut(&k).expect("an online record");
        *n -= 1;
    }
    assert!(by_key.values().all(|&n| n == 0));
    // The joins are right, not just fewer ids: identity metrics improve against the truth.
    let score = |res: &Vec<RecordJs>| -> serde_json::Value {
        let v = evaluate(ts(js(&gt)), ts(js(res)), frames, None).unwrap();
        serde_wasm_bindgen::from_value(JsValue::from(v)).unwrap()
    };
    let (on, off) = (score(&online), score(&records));
    assert!(
        off["idsw"].as_u64() < on["idsw"].as_u64() && off["idf1"].as_f64() > on["idf1"].as_f64(),
        "online {on}\noffline {off}"
    );
    assert!(
        off["hota"].as_f64() >= on["hota"].as_f64(),
        "online {on}\noffline {off}"
    );
    console_log!(
        "occlusion scene, {frames} frames: ids {} online -> {} offline ({} joins, {} filled); \
         IDSW {} -> {}, IDF1 {:.2} -> {:.2}, HOTA {:.2} -> {:.2}; finish {finish_ms:.0} ms",
        ids(&online).len(),
        final_ids.len(),
        joins.len(),
        filled.len(),
        on["idsw"],
        off["idsw"],
        on["idf1"].as_f64().unwrap(),
        off["idf1"].as_f64().unwrap(),
        on["hota"].as_f64().unwrap(),
        off["hota"].as_f64().unwrap(),
    );

    // Progress: phases in order, fractions in [0, 1] and growing within a phase, ending at
    // "done" with 1.
    let order = ["candidates", "appearance", "matching", "filling", "done"];
    let reports: Vec<(usize, f64)> = log
        .iter()
        .map(|p| {
            let p: serde_json::Value = serde_wasm_bindgen::from_value(p).unwrap();
            let phase = p["phase"].as_str().unwrap().to_string();
            let rank = order
                .iter()
                .position(|&o| o == phase)
                .expect("a finish phase");
            (rank, p["fraction"].as_f64().unwrap())
        })
        .collect();
    assert!(reports.len() >= 5, "{reports:?}");
    assert!(
        reports
            .windows(2)
            .all(|w| w[0].0 < w[1].0 || (w[0].0 == w[1].0 && w[0].1 <= w[1].1)),
        "{reports:?}"
    );
    assert!(reports.iter().all(|&(_, f)| (0.0..=1.0).contains(&f)));
    assert_eq!(reports.last(), Some(&(4, 1.0)));
    // With frames, the appearance phase ran (snapshots were taken during the online pass).
    assert!(reports.iter().any(|&(r, _)| r == 1), "{reports:?}");
    for rank in [0, 2, 3] {
        assert!(
            reports.iter().any(|&(r, _)| r == rank),
            "no {}: {reports:?}",
            order[rank]
        );
    }

    // The tracker is final: tracks() is the result, no frame and no second finish.
    assert!(tracker.finished());
    assert_eq!(records_of(tracker.tracks().unwrap()), records);
    let f = s.render(1.0, &mut buf).unwrap();
    let msg = error_message(
        tracker
            .update(f64::from(frames + 1), &buf, &f.detections())
            .err()
            .unwrap(),
    );
    assert!(msg.contains("finished"), "{msg}");
    let msg = error_message(tracker.finish(None).err().unwrap());
    assert!(msg.contains("finished"), "{msg}");
}

/// Boxes of one object moving right, hidden in frames 11..=16: two online tracks.
fn broken_track(tracker: &mut Tracker) {
    for n in 1..=30u32 {
        let boxes = if (11..=16).contains(&n) {
            serde_json::json!([])
        } else {
            serde_json::json!([{ "bbox": { "x": 10.0 + 8.0 * n as f64, "y": 50, "w": 30, "h": 60 }, "score": 0.95 }])
        };
        let d = Detections::from_lists(ts(js(&serde_json::json!({ "boxes": boxes })))).unwrap();
        tracker.update_detections(f64::from(n), &d).unwrap();
    }
}

#[wasm_bindgen_test]
fn a_throwing_progress_callback_is_an_error_and_leaves_the_tracker_usable() {
    // The online tracker forgets a lost track after 3 frames, so the gap breaks it.
    let online = serde_json::json!({ "max_lost": 3 });
    let opts = serde_json::json!({ "fps": 25, "width": 640, "height": 480 });
    let mut tracker = Tracker::new(Some(settings(&online)), Some(settings(&opts))).unwrap();
    broken_track(&mut tracker);
    assert_eq!(
        ids(&records_of(tracker.tracks().unwrap())).len(),
        2,
        "the gap breaks the track online"
    );

    let throws = js_sys::Function::new_with_args("p", "throw new Error('stop at ' + p.phase)");
    let e = tracker
        .finish(Some(JsValue::from(throws).unchecked_into()))
        .err()
        .unwrap();
    let msg = error_message(e);
    assert_eq!(msg, "progress callback threw: stop at candidates");
    // A thrown non-Error value is reported too.
    let throws = js_sys::Function::new_with_args("p", "throw 'plain string'");
    let msg = error_message(
        tracker
            .finish(Some(JsValue::from(throws).unchecked_into()))
            .err()
            .unwrap(),
    );
    assert!(msg.contains("plain string"), "{msg}");
    assert!(!tracker.finished());

    // Nothing was lost: without a callback the pass runs and joins the two pieces.
    let out = tracker.finish(None).unwrap();
    let out: serde_json::Value = serde_wasm_bindgen::from_value(JsValue::from(out)).unwrap();
    let records: Vec<RecordJs> = serde_json::from_value(out["records"].clone()).unwrap();
    assert_eq!(ids(&records).len(), 1, "{}", out["joins"]);
    let filled: Vec<u32> = records
        .iter()
        .filter(|r| r.interpolated)
        .map(|r| r.frame)
        .collect();
    assert_eq!(filled, (11..=16).collect::<Vec<_>>());
    // Filled boxes lie on the line between the two ends.
    for r in records.iter().filter(|r| r.interpolated) {
        let want = 10.0 + 8.0 * r.frame as f64;
        assert!(
            (r.bbox.x - want).abs() < 1.0,
            "frame {}: x {} vs {want}",
            r.frame,
            r.bbox.x
        );
    }
}

// ------------------------------------------------------------------------------------------
// Moving-camera detector and camera judge

/// Paints the frame `buf` holds the way JS does (through a view on wasm memory): a blocky
/// grey texture seen from a camera shifted by `pan` pixels to the right, and a white square
/// at `square` (top-left) when given.
fn paint(buf: &FrameBuffer, pan: i32, square: Option<(i32, i32)>) {
    let (w, h) = (buf.width() as i32, buf.height() as i32);
    let mut px = vec![255u8; buf.len()];
    for y in 0..h {
        for x in 0..w {
            let (bx, by) = ((x + pan).div_euclid(8) as u32, y.div_euclid(8) as u32);
            let mut v = (bx.wrapping_mul(73_856_093) ^ by.wrapping_mul(19_349_663)) % 200;
            let inside =
                |(sx, sy): (i32, i32)| (sx..sx + 24).contains(&x) && (sy..sy + 24).contains(&y);
            if square.is_some_and(inside) {
                v = 255;
            }
            let i = 4 * (y * w + x) as usize;
            px[i..i + 3].fill(v as u8);
        }
    }
    write_pixels(buf, &px);
}

/// Copies RGBA bytes into the frame buffer, as JS writes a frame into wasm memory.
fn write_pixels(buf: &FrameBuffer, px: &[u8]) {
    // The view is made after the caller's Vec: allocating may grow (and detach) wasm memory.
    let mem: js_sys::WebAssembly::Memory = wasm_bindgen::memory().dyn_into().unwrap();
    js_sys::Uint8Array::new_with_byte_offset_and_length(
        &mem.buffer(),
        buf.ptr() as u32,
        buf.len() as u32,
    )
    .copy_from(px);
}

#[wasm_bindgen_test]
fn camera_judge_tells_a_still_camera_from_a_panning_one() {
    for (pan_per_frame, moves) in [(0, false), (4, true)] {
        let buf = FrameBuffer::new(160.0, 120.0).unwrap();
        let mut judge = CameraJudge::new();
        assert_eq!(judge.moving(), None, "no pair yet");
        for n in 0..5 {
            paint(&buf, n * pan_per_frame, None);
            judge.observe(&buf).unwrap();
        }
        assert_eq!(judge.pairs(), 4);
        assert_eq!(judge.moving(), Some(moves), "pan {pan_per_frame} px/frame");
    }
    // Another frame size is an error naming both sizes, and is not looked at.
    let mut judge = CameraJudge::new();
    let buf = FrameBuffer::new(160.0, 120.0).unwrap();
    paint(&buf, 0, None);
    judge.observe(&buf).unwrap();
    let other = FrameBuffer::new(80.0, 60.0).unwrap();
    let msg = error_message(judge.observe(&other).err().unwrap());
    assert!(msg.contains("80x60") && msg.contains("160x120"), "{msg}");
    assert_eq!(judge.pairs(), 0);
}

#[wasm_bindgen_test]
fn moving_detector_learns_then_finds_an_object_while_the_camera_pans() {
    // The default flow cue needs one earlier frame; the background cue `min_age` frames.
    let background = settings(&serde_json::json!({ "cue": "background" }));
    for (opts, needed) in [(None, 1u32), (Some(background), 3)] {
        let mut det = MovingDetector::new(opts).unwrap();
        assert_eq!(det.warmup_frames(), needed);
        assert!(det.learning());
        assert_eq!(det.camera_shift(), None);
        let buf = FrameBuffer::new(160.0, 120.0).unwrap();
        let mut found = Vec::new();
        for n in 0..12 {
            // The camera pans 2 px a frame; the square crosses the view at 6 px a frame.
            paint(&buf, 2 * n, Some((20 + 6 * n, 48)));
            found.push(det.detect(&buf).unwrap().len());
            if n == 0 {
                assert_eq!((det.warmup_seen(), det.learning()), (1, needed > 1));
            }
        }
        assert_eq!(det.resets(), 0, "the pan was followed");
        assert!(!det.learning());
        assert_eq!(det.warmup_seen(), needed);
        let shift = det.camera_shift().expect("a motion estimate");
        assert!((shift - 2.0).abs() < 0.5, "camera shift {shift} px");
        assert!(
            found[..needed as usize].iter().all(|&n| n == 0),
            "nothing while learning: {found:?}"
        );
        assert!(
            found[4..].iter().all(|&n| n > 0),
            "the square is found: {found:?}"
        );
    }
    let mut det = MovingDetector::new(None).unwrap();
    let buf = FrameBuffer::new(160.0, 120.0).unwrap();
    paint(&buf, 0, Some((20, 48)));
    det.detect(&buf).unwrap();

    // A frame of another size is an error, not a trap; after `reset` it starts a new model.
    let small = FrameBuffer::new(80.0, 60.0).unwrap();
    let msg = error_message(det.detect(&small).err().unwrap());
    assert!(msg.contains("80x60") && msg.contains("160x120"), "{msg}");
    det.reset();
    assert!(det.learning() && det.warmup_seen() == 0);
    assert_eq!(det.detect(&small).unwrap().len(), 0);
    assert_eq!(det.warmup_seen(), 1);
}

#[wasm_bindgen_test]
fn moving_detector_settings_are_checked_and_name_their_field() {
    for (opts, field) in [
        (serde_json::json!({ "threshold": 300 }), "threshold"),
        (serde_json::json!({ "treshold": 5 }), "treshold"),
        (serde_json::json!({ "min_age": -1 }), "min_age"),
        (serde_json::json!({ "work_side": 8 }), "work_side"),
        (
            serde_json::json!({ "refine": { "max_sid": 40 } }),
            "max_sid",
        ),
        (serde_json::json!({ "refine": [1, 2] }), "refine"),
        (serde_json::json!({ "alpha": "fast" }), "alpha"),
        (serde_json::json!({ "cue": "optical" }), "cue"),
        (
            serde_json::json!({ "flow": { "patch_size": 2 } }),
            "flow.patch_size",
        ),
        (serde_json::json!({ "flow": { "alpha": -1 } }), "flow.alpha"),
        (
            serde_json::json!({ "residual_factor": 1e9 }),
            "residual_factor",
        ),
    ] {
        let msg = error_message(MovingDetector::new(Some(settings(&opts))).err().unwrap());
        assert!(msg.contains(field), "{opts}: {msg}");
    }
    let not_object = MovingDetector::new(Some(settings(&serde_json::json!([1]))));
    assert!(error_message(not_object.err().unwrap()).contains("plain object"));
    for ok in [
        serde_json::json!({}),
        serde_json::json!({ "cue": "background", "refine": null, "min_age": 5 }),
        serde_json::json!({ "cue": "flow", "flow": { "patch_stride": 3 }, "min_residual": 1 }),
        serde_json::json!({ "refine": { "iterations": 1 }, "max_blobs": 2 }),
    ] {
        let det = MovingDetector::new(Some(settings(&ok)));
        assert!(det.is_ok(), "{ok}");
        if ok["min_age"] == 5 {
            assert_eq!(det.unwrap().warmup_frames(), 5);
        }
    }
}

/// A red disc (centre `(80, 60)`, radius 25) on green and blue stripes, 160×120.
fn paint_disc(buf: &FrameBuffer) -> Vec<bool> {
    let (w, h) = (buf.width() as usize, buf.height() as usize);
    let mut px = vec![255u8; buf.len()];
    let mut disc = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let (dx, dy) = (x as f64 + 0.5 - 80.0, y as f64 + 0.5 - 60.0);
            let inside = dx.hypot(dy) < 25.0;
            disc[y * w + x] = inside;
            let c = if inside {
                [200, 40, 30]
            } else if (x / 6 + y / 9) % 2 == 0 {
                [40, 160, 60]
            } else {
                [50, 70, 170]
            };
            let i = 4 * (y * w + x);
            px[i..i + 3].copy_from_slice(&c);
        }
    }
    write_pixels(buf, &px);
    disc
}

/// A detection as `Detections.toList` hands it to JS.
#[derive(serde::Deserialize)]
struct Listed {
    score: f64,
    mask: Option<ListedMask>,
}

#[derive(serde::Deserialize)]
struct ListedMask {
    x: i32,
    y: i32,
    width: u32,
    height: u32,
    #[serde(with = "serde_bytes")]
    data: Vec<u8>,
}

impl ListedMask {
    fn area(&self) -> usize {
        self.data.iter().filter(|&&v| v != 0).count()
    }

    /// IoU with a frame-sized 0/1 image `w` pixels wide.
    fn iou(&self, truth: &[bool], w: usize) -> f64 {
        let mut inter = 0;
        for (k, &v) in self.data.iter().enumerate() {
            let x = self.x + (k % self.width as usize) as i32;
            let y = self.y + (k / self.width as usize) as i32;
            if v != 0 && truth.get(y as usize * w + x as usize) == Some(&true) {
                inter += 1;
            }
        }
        let union = self.area() + truth.iter().filter(|&&v| v).count() - inter;
        inter as f64 / union as f64
    }
}

#[wasm_bindgen_test]
fn box_refiner_turns_boxes_into_the_objects_masks_highest_scores_first() {
    let buf = FrameBuffer::new(160.0, 120.0).unwrap();
    let disc = paint_disc(&buf);
    let lists = serde_json::json!({
        "boxes": [
            // Past the budget of one (the lower score): filled, not refined.
            { "bbox": { "x": 5, "y": 5, "w": 30, "h": 20 }, "score": 0.4 },
            // The disc's box, a little loose, as a detector gives it.
            { "bbox": { "x": 52, "y": 32, "w": 56, "h": 56 }, "score": 0.9 },
        ],
        "masks": [{ "x": 140, "y": 100, "width": 2, "height": 1, "data": [1, 0], "score": 0.7 }],
    });
    let mut dets = Detections::from_lists(ts(js(&lists))).unwrap();
    let refiner = BoxRefiner::new(None).unwrap();
    assert_eq!(refiner.refine(&buf, &mut dets, Some(1)).unwrap(), 1);
    let listed: Vec<Listed> =
        serde_wasm_bindgen::from_value(dets.to_list().unwrap().into()).unwrap();
    let by_score = |s: f64| {
        listed
            .iter()
            .find(|d| d.score == s)
            .and_then(|d| d.mask.as_ref())
            .expect("every detection leaves with a mask")
    };
    let m = by_score(0.9);
    let iou = m.iou(&disc, 160);
    assert!(iou > 0.85, "the disc's outline, IoU {iou}");
    assert!(
        (m.area() as f64) < 0.9 * 56.0 * 56.0,
        "not the filled box: {} px",
        m.area()
    );
    assert_eq!(by_score(0.4).area(), 600, "past the budget: the filled box");
    let kept = by_score(0.7);
    assert_eq!(
        (kept.x, kept.y, kept.width, kept.height, kept.area()),
        (140, 100, 2, 1, 1)
    );

    // Without a budget every box is refined (the stripes' box finds the stripe it holds, or
    // falls back to its filled box; either way it keeps a mask).
    let mut all = Detections::from_lists(ts(js(&lists))).unwrap();
    let n = refiner.refine(&buf, &mut all, None).unwrap();
    assert!((1..=2).contains(&n), "{n} refined");
    let listed: Vec<Listed> =
        serde_wasm_bindgen::from_value(all.to_list().unwrap().into()).unwrap();
    assert!(listed.iter().all(|d| d.mask.is_some()));
    assert_eq!(listed.len(), 3);
}

#[wasm_bindgen_test]
fn box_refiner_settings_are_checked_and_name_their_field() {
    for (opts, field) in [
        (serde_json::json!({ "max_sid": 80 }), "max_sid"),
        (serde_json::json!({ "smoothness": "high" }), "smoothness"),
        (serde_json::json!({ "iterations": 0 }), "iterations"),
    ] {
        let msg = error_message(BoxRefiner::new(Some(settings(&opts))).err().unwrap());
        assert!(msg.contains(field), "{opts}: {msg}");
    }
    assert!(BoxRefiner::new(Some(settings(&serde_json::json!({ "iterations": 1 })))).is_ok());
    let refiner = BoxRefiner::new(None).unwrap();
    let buf = FrameBuffer::new(16.0, 16.0).unwrap();
    let lists =
        serde_json::json!({ "boxes": [{ "bbox": { "x": 100, "y": 100, "w": 5, "h": 5 } }] });
    let mut dets = Detections::from_lists(ts(js(&lists))).unwrap();
    // A box wholly outside the frame: nothing to refine, nothing to fill; kept as a box.
    assert_eq!(refiner.refine(&buf, &mut dets, None).unwrap(), 0);
    assert_eq!(dets.len(), 1);
}

#[wasm_bindgen_test]
fn add_uncovered_appends_only_what_the_list_does_not_hold() {
    // The list: a 10×10 mask at (0, 0) and a 10×10 box at (50, 50).
    let own = serde_json::json!({
        "masks": [{ "x": 0, "y": 0, "width": 10, "height": 10, "data": vec![1u8; 100], "class": 3 }],
        "boxes": [{ "bbox": { "x": 50, "y": 50, "w": 10, "h": 10 } }],
    });
    let other = serde_json::json!({
        "masks": [
            // 60 % of it on the mask: held at 0.5, not at 0.7.
            { "x": 4, "y": 0, "width": 10, "height": 10, "data": vec![1u8; 100], "score": 0.6 },
            // Wholly on the box (a detection without a mask counts as its filled box).
            { "x": 52, "y": 52, "width": 4, "height": 4, "data": vec![1u8; 16], "score": 0.7 },
            // Nowhere near: always appended.
            { "x": 100, "y": 100, "width": 5, "height": 5, "data": vec![1u8; 25], "score": 0.8 },
        ],
    });
    let other = Detections::from_lists(ts(js(&other))).unwrap();
    let scores = |d: &Detections| -> Vec<f64> {
        let l: Vec<Listed> = serde_wasm_bindgen::from_value(d.to_list().unwrap().into()).unwrap();
        l.iter().map(|d| d.score).collect()
    };
    let mut a = Detections::from_lists(ts(js(&own))).unwrap();
    assert_eq!(a.add_uncovered(&other, 0.5).unwrap(), 1);
    assert_eq!(scores(&a), vec![1.0, 1.0, 0.8]);
    let mut b = Detections::from_lists(ts(js(&own))).unwrap();
    assert_eq!(b.add_uncovered(&other, 0.7).unwrap(), 2);
    assert_eq!(scores(&b), vec![1.0, 1.0, 0.6, 0.8]);
    // An empty list takes everything; `other` is left as it was.
    let mut c = Detections::from_lists(ts(js(&serde_json::json!({})))).unwrap();
    assert_eq!(c.add_uncovered(&other, 0.5).unwrap(), 3);
    assert_eq!(other.len(), 3);
    for bad in [-0.1, 1.5, f64::NAN] {
        let msg = error_message(a.add_uncovered(&other, bad).err().unwrap());
        assert!(msg.contains("covered"), "{bad}: {msg}");
    }
}

#[wasm_bindgen_test]
fn drop_parts_leaves_out_parts_lying_on_a_larger_detection_and_nothing_else() {
    // Classes: 4 a person, 19 a shoe (a part), 23 a car (never a part), -1 a moving blob.
    const SHOE: i32 = 19;
    let mask = |x: u32, y: u32, w: u32, h: u32, score: f64, class: i32| {
        serde_json::json!({ "x": x, "y": y, "width": w, "height": h,
            "data": vec![1u8; (w * h) as usize], "score": score, "class": class })
    };
    let shoe_box = |x: f64, y: f64| serde_json::json!({ "bbox": { "x": x, "y": y, "w": 4, "h": 4 }, "score": 0.7, "class": SHOE });
    let scores = |d: &Detections| -> Vec<f64> {
        let l: Vec<Listed> = serde_wasm_bindgen::from_value(d.to_list().unwrap().into()).unwrap();
        l.iter().map(|d| d.score).collect()
    };
    let list = |v: serde_json::Value| Detections::from_lists(ts(js(&v))).unwrap();
    // A person (20x40); a shoe mask on it; a shoe box half on it; a shoe mask a quarter on
    // it; a car mask wholly on it (not a part class); a shoe beside it.
    let mut d = list(serde_json::json!({
        "masks": [mask(0, 0, 20, 40, 0.9, 4), mask(2, 36, 4, 4, 0.8, SHOE),
                  mask(19, 0, 4, 4, 0.6, SHOE), mask(4, 4, 4, 4, 0.5, 23),
                  mask(40, 0, 6, 6, 0.4, SHOE)],
        "boxes": [shoe_box(18.0, 30.0)],
    }));
    assert_eq!(d.drop_parts(&[SHOE], 0.5, 4.0).unwrap(), 2);
    assert_eq!(
        scores(&d),
        vec![0.9, 0.6, 0.5, 0.4],
        "the shoe on it and the half-on box go"
    );
    // No part classes: nothing goes. At 0.8 the box half on the person stays.
    let two = || {
        list(
            serde_json::json!({ "masks": [mask(0, 0, 20, 40, 0.9, 4)], "boxes": [shoe_box(18.0, 30.0)] }),
        )
    };
    assert_eq!(two().drop_parts(&[], 0.5, 4.0).unwrap(), 0);
    assert_eq!(two().drop_parts(&[SHOE], 0.8, 4.0).unwrap(), 0);
    // A blob twice the size of each of two parts under it holds them at ratio 2, not 4.
    let pair = || {
        list(serde_json::json!({ "masks": [mask(0, 0, 20, 20, 0.3, -1),
            mask(0, 0, 10, 20, 0.9, SHOE), mask(10, 0, 10, 20, 0.8, SHOE)] }))
    };
    assert_eq!(pair().drop_parts(&[SHOE], 0.5, 4.0).unwrap(), 0);
    assert_eq!(pair().drop_parts(&[SHOE], 0.5, 2.0).unwrap(), 2);
    // A box holds a part too (a person's box not refined into a mask); two equal masks do
    // not hold each other.
    let mut d = list(serde_json::json!({
        "masks": [mask(2, 2, 4, 4, 0.8, SHOE), mask(30, 0, 8, 8, 0.7, SHOE), mask(30, 0, 8, 8, 0.6, SHOE)],
        "boxes": [{ "bbox": { "x": 0, "y": 0, "w": 20, "h": 20 }, "score": 0.9, "class": 4 }],
    }));
    assert_eq!(d.drop_parts(&[SHOE], 0.5, 1.0).unwrap(), 1);
    assert_eq!(
        scores(&d),
        vec![0.7, 0.6, 0.9],
        "the shoe in the box goes, the equal pair stays"
    );
    for (share, ratio) in [
        (0.0, 4.0),
        (1.5, 4.0),
        (f64::NAN, 4.0),
        (0.5, 0.5),
        (0.5, f64::INFINITY),
    ] {
        let msg = error_message(d.drop_parts(&[SHOE], share, ratio).err().unwrap());
        assert!(msg.contains("dropParts"), "{share} {ratio}: {msg}");
    }
    assert_eq!(d.len(), 3, "a refused call changes nothing");
}

#[wasm_bindgen_test]
fn boxes_of_any_size_are_compared_and_filled_without_rasterising_them_whole() {
    // A JS detector may hand in a box far larger than the frame (a bug, a unit mix-up): it
    // must cost at most the frame, never exhaust wasm memory.
    let huge =
        serde_json::json!({ "bbox": { "x": -1e9, "y": -1e9, "w": 3e9, "h": 3e9 }, "score": 0.5 });
    let buf = FrameBuffer::new(16.0, 16.0).unwrap();
    let mut dets = Detections::from_lists(ts(js(&serde_json::json!({ "boxes": [huge] })))).unwrap();
    // Past the budget: its filled box, clipped to the frame.
    assert_eq!(
        BoxRefiner::new(None)
            .unwrap()
            .refine(&buf, &mut dets, Some(0))
            .unwrap(),
        0
    );
    let listed: Vec<Listed> =
        serde_wasm_bindgen::from_value(dets.to_list().unwrap().into()).unwrap();
    let m = listed[0].mask.as_ref().expect("a mask");
    assert_eq!((m.x, m.y, m.width, m.height, m.area()), (0, 0, 16, 16, 256));

    // A small mask inside a huge box is held by it; a huge box is not held by a small mask.
    let small = serde_json::json!({ "x": 5, "y": 5, "width": 2, "height": 2, "data": [1, 1, 1, 1], "score": 0.9 });
    let mut own = Detections::from_lists(ts(js(&serde_json::json!({ "boxes": [huge] })))).unwrap();
    let other = Detections::from_lists(ts(js(&serde_json::json!({ "masks": [small] })))).unwrap();
    assert_eq!(own.add_uncovered(&other, 0.5).unwrap(), 0);
    let mut own = Detections::from_lists(ts(js(&serde_json::json!({ "masks": [small] })))).unwrap();
    let other = Detections::from_lists(ts(js(&serde_json::json!({ "boxes": [huge] })))).unwrap();
    assert_eq!(own.add_uncovered(&other, 0.5).unwrap(), 1);
    // Two boxes: a 10×10 box half on another.
    let a = serde_json::json!({ "boxes": [{ "bbox": { "x": 0, "y": 0, "w": 10, "h": 10 } }] });
    let b = serde_json::json!({ "boxes": [{ "bbox": { "x": 5, "y": 0, "w": 10, "h": 10 } }] });
    let b = Detections::from_lists(ts(js(&b))).unwrap();
    let mut held = Detections::from_lists(ts(js(&a))).unwrap();
    assert_eq!(held.add_uncovered(&b, 0.5).unwrap(), 0);
    let mut kept = Detections::from_lists(ts(js(&a))).unwrap();
    assert_eq!(kept.add_uncovered(&b, 0.51).unwrap(), 1);
}
