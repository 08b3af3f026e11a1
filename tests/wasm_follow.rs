//! Following a given shape and interpolating keyframe masks through the browser bindings, run
//! in wasm by wasm-bindgen-test (under Node):
//!
//! `CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUNNER=wasm-bindgen-test-runner cargo test
//!  --target wasm32-unknown-unknown --no-default-features --test wasm_follow`
//!
//! The synthetic scene provides frames and the true mask of each object: the follower starts
//! from one object's true mask and must stay on it; bad input (an empty mask, a mask of another
//! size, a position outside [0, 1]) is a JS `Error`, never a trap.
#![cfg(target_arch = "wasm32")]

use serde::Serialize;
use shapetrack::io::Rle;
use shapetrack::wasm::*;
use tsify::Ts;
use wasm_bindgen::{JsCast, JsValue};
use wasm_bindgen_test::*;

fn error_message(e: JsValue) -> String {
    let err: js_sys::Error = e.dyn_into().expect("a JS Error object");
    String::from(err.message())
}

fn rle_js(v: &RleJs) -> Ts<RleJs> {
    Ts::new_unchecked(
        serde::Serialize::serialize(v, &serde_wasm_bindgen::Serializer::json_compatible()).unwrap(),
    )
}

fn rle(v: &RleJs) -> Rle {
    Rle::from_compressed(&v.counts, v.size[0], v.size[1]).unwrap()
}

/// The true masks of frame `n` by object id.
fn truth(f: &SceneFrame) -> std::collections::BTreeMap<i64, RleJs> {
    let recs: Vec<RecordJs> =
        serde_wasm_bindgen::from_value(JsValue::from(f.ground_truth().unwrap())).unwrap();
    recs.into_iter()
        .filter_map(|r| r.mask.map(|m| (r.id, m)))
        .collect()
}

#[wasm_bindgen_test]
fn follows_a_scene_object_from_its_first_mask() {
    let mut scene = SynthScene::new(Ts::new_unchecked(JsValue::from_str("default"))).unwrap();
    let mut buf = FrameBuffer::new(f64::from(scene.width()), f64::from(scene.height())).unwrap();
    let first = scene.render(1.0, &mut buf).unwrap();
    // The largest object of frame 1.
    let (id, mask) = truth(&first)
        .into_iter()
        .max_by_key(|(_, m)| rle(m).area())
        .expect("the scene has objects");
    let mut follower = Follower::new(&buf, rle_js(&mask), None).unwrap();
    let (mut good, mut seen) = (0, 0);
    for n in 2..=30 {
        let f = scene.render(f64::from(n), &mut buf).unwrap();
        let step: FollowStepJs =
            serde_wasm_bindgen::from_value(JsValue::from(follower.step(&buf).unwrap())).unwrap();
        let Some(gt) = truth(&f).remove(&id) else {
            continue;
        };
        seen += 1;
        if step
            .mask
            .as_ref()
            .is_some_and(|m| rle(m).iou(&rle(&gt)) >= 0.5)
        {
            good += 1;
        }
    }
    assert!(seen >= 20, "the object stays in view: {seen}");
    assert!(
        good * 10 >= seen * 8,
        "mask IoU ≥ 0.5 on {good} of {seen} frames"
    );
}

#[wasm_bindgen_test]
fn bad_follow_input_is_an_error_not_a_trap() {
    let buf = FrameBuffer::new(64.0, 48.0).unwrap();
    let empty = RleJs::from(&Rle::empty(64, 48));
    let msg = error_message(Follower::new(&buf, rle_js(&empty), None).err().unwrap());
    assert!(msg.to_lowercase().contains("empty"), "{msg}");
    let other = RleJs::from(&Rle::empty(32, 32));
    let msg = error_message(Follower::new(&buf, rle_js(&other), None).err().unwrap());
    assert!(msg.contains("32x32") && msg.contains("64x48"), "{msg}");
    let bad = Ts::new_unchecked(JsValue::from_str("not a mask"));
    assert!(Follower::new(&buf, bad, None).is_err());
    // A frame of another size than the first one.
    let mut bits = vec![0u8; 64 * 48];
    for y in 10..30 {
        for x in 10..30 {
            bits[y * 64 + x] = 1;
        }
    }
    let square = RleJs::from(&Rle::encode(64, 48, &bits).unwrap());
    // Settings are the core's FollowConfig fields; a bad or unknown one is an error naming it.
    for (bad, field) in [
        (serde_json::json!({ "max_side": "big" }), "max_side"),
        (serde_json::json!({ "max_sides": 100 }), "max_sides"),
    ] {
        let v = bad
            .serialize(&serde_wasm_bindgen::Serializer::json_compatible())
            .unwrap();
        let msg = error_message(
            Follower::new(&buf, rle_js(&square), Some(v.unchecked_into()))
                .err()
                .unwrap(),
        );
        assert!(msg.contains(field), "{bad}: {msg}");
    }
    let ok = serde_json::json!({ "max_side": 160 })
        .serialize(&serde_wasm_bindgen::Serializer::json_compatible())
        .unwrap();
    assert!(Follower::new(&buf, rle_js(&square), Some(ok.unchecked_into())).is_ok());
    let mut f = Follower::new(&buf, rle_js(&square), None).unwrap();
    let small = FrameBuffer::new(32.0, 32.0).unwrap();
    assert!(
        f.step(&small).is_err(),
        "a frame of another size is refused"
    );
    assert!(f.step(&buf).is_ok(), "and the follower still works");
}

/// A `w × h` frame's RLE with a filled axis-aligned rectangle.
fn rect(w: u32, h: u32, x0: u32, y0: u32, rw: u32, rh: u32) -> RleJs {
    let mut bits = vec![0u8; (w * h) as usize];
    for y in y0..y0 + rh {
        for x in x0..x0 + rw {
            bits[(y * w + x) as usize] = 1;
        }
    }
    RleJs::from(&Rle::encode(w, h, &bits).unwrap())
}

#[wasm_bindgen_test]
fn interpolation_between_keyframes_moves_the_shape_and_checks_its_input() {
    // A square moving from (10, 10) to (50, 30) and growing from 20 to 28 px: half way it is
    // a 24 px square at (30, 20).
    let a = rect(96, 64, 10, 10, 20, 20);
    let b = rect(96, 64, 50, 30, 28, 28);
    let want = rect(96, 64, 30, 20, 24, 24);
    let m = interpolate_masks_js(rle_js(&a), rle_js(&b), 0.5).unwrap();
    let m: RleJs = serde_wasm_bindgen::from_value(JsValue::from(m)).unwrap();
    let iou = rle(&m).iou(&rle(&want));
    assert!(iou >= 0.8, "midpoint IoU {iou:.2}");
    assert!(
        rle(&a).iou(&rle(&want)) < 0.2,
        "neither keyframe is already the answer"
    );
    let end = interpolate_masks_js(rle_js(&a), rle_js(&b), 1.0).unwrap();
    let end: RleJs = serde_wasm_bindgen::from_value(JsValue::from(end)).unwrap();
    assert!(
        rle(&end).iou(&rle(&b)) >= 0.9,
        "t = 1 is the second keyframe"
    );

    let msg = error_message(
        interpolate_masks_js(rle_js(&a), rle_js(&b), 1.5)
            .err()
            .unwrap(),
    );
    assert!(msg.contains("1.5"), "{msg}");
    let msg = error_message(
        interpolate_masks_js(rle_js(&a), rle_js(&b), f64::NAN)
            .err()
            .unwrap(),
    );
    assert!(msg.contains("NaN"), "{msg}");
    let empty = RleJs::from(&Rle::empty(96, 64));
    let msg = error_message(
        interpolate_masks_js(rle_js(&empty), rle_js(&b), 0.5)
            .err()
            .unwrap(),
    );
    assert!(msg.contains("empty"), "{msg}");
    let other = RleJs::from(&Rle::empty(8, 8));
    let msg = error_message(
        interpolate_masks_js(rle_js(&a), rle_js(&other), 0.5)
            .err()
            .unwrap(),
    );
    assert!(msg.contains("different sizes"), "{msg}");
}
