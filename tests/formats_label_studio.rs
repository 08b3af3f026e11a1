//! Label Studio video JSON: records round-trip through the writer and reader (boxes, ids,
//! classes, gaps, filled frames), keyframes expand as Label Studio shows them, and bad files
//! get typed errors at the right place, never a panic.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use std::collections::BTreeMap;

use shapetrack::io::label_studio::{parse_label_studio, write_label_studio, LabelStudioMeta};
use shapetrack::io::{IoError, Record};
use shapetrack::BBox;

const SIZE: (u32, u32) = (640, 480);

fn meta(frames: u32) -> LabelStudioMeta {
    LabelStudioMeta {
        video: "/data/upload/1/clip.mp4".to_string(),
        width: SIZE.0,
        height: SIZE.1,
        frames,
        fps: 25.0,
    }
}

fn names() -> BTreeMap<i32, String> {
    BTreeMap::from([(0, "car".to_string()), (1, "person".to_string())])
}

fn rec(frame: u32, id: i64, class: i32, b: (f64, f64, f64, f64)) -> Record {
    let mut r = Record::from_box(frame, id, BBox::new(b.0, b.1, b.2, b.3));
    r.class = class;
    r
}

/// Track 3 (car): frames 1–4, a gap at 5–6, frames 7–8. Track 5 (person): frames 2–6 with
/// frames 3–5 filled linearly (flagged interpolated). Track 9 (no class): frame 10 only, the
/// video's last frame.
fn tracks() -> Vec<Record> {
    let mut v = Vec::new();
    for f in [1, 2, 3, 4, 7, 8] {
        let d = f as f64;
        v.push(rec(f, 3, 0, (10.0 + 3.0 * d, 20.0, 30.0 + d, 40.0)));
    }
    for f in 2..=6 {
        // Linear from (100, 100, 50, 60) at frame 2 to (140, 120, 70, 60) at frame 6.
        let t = (f - 2) as f64 / 4.0;
        let mut r = rec(
            f,
            5,
            1,
            (100.0 + 40.0 * t, 100.0 + 20.0 * t, 50.0 + 20.0 * t, 60.0),
        );
        r.flags.interpolated = (3..=5).contains(&f);
        v.push(r);
    }
    v.push(rec(10, 9, -1, (0.0, 0.0, 640.0, 480.0)));
    v.sort_by_key(|r| (r.frame, r.id));
    v
}

fn assert_same(a: &[Record], b: &[Record]) {
    assert_eq!(a.len(), b.len(), "{a:#?}\n{b:#?}");
    for (x, y) in a.iter().zip(b) {
        assert_eq!(
            (x.frame, x.id, x.class, x.flags),
            (y.frame, y.id, y.class, y.flags),
            "{x:?} vs {y:?}"
        );
        for (p, q) in [
            (x.bbox.x, y.bbox.x),
            (x.bbox.y, y.bbox.y),
            (x.bbox.w, y.bbox.w),
            (x.bbox.h, y.bbox.h),
        ] {
            assert!((p - q).abs() < 1e-9, "{x:?} vs {y:?}");
        }
    }
}

#[test]
fn records_round_trip() {
    let recs = tracks();
    let text = write_label_studio(&recs, &meta(10), &names()).unwrap();
    let back = parse_label_studio(&text, "ls.json", SIZE, Some(&names())).unwrap();
    assert_same(&recs, &back.records);
    assert_eq!(back.frames, 10);
    assert_eq!(back.tasks, 1);
    assert_eq!(back.video.as_deref(), Some("/data/upload/1/clip.mp4"));
    // Without a label map: classes are label indices in order of first appearance.
    let plain = parse_label_studio(&text, "ls.json", SIZE, None).unwrap();
    assert_eq!(plain.labels, ["car", "person"]);
    assert_same(&recs, &plain.records);
}

#[test]
fn the_written_file_has_label_studio_keyframes() {
    let text = write_label_studio(&tracks(), &meta(10), &names()).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let results = v[0]["annotations"][0]["result"].as_array().unwrap();
    assert_eq!(results.len(), 3);
    let by_id = |id: &str| {
        results
            .iter()
            .find(|r| r["id"] == id)
            .unwrap_or_else(|| panic!("no region {id}"))
    };
    let car = by_id("3");
    assert_eq!(car["type"], "videorectangle");
    assert_eq!(car["value"]["labels"], serde_json::json!(["car"]));
    assert_eq!(car["value"]["framesCount"], 10);
    let seq = car["value"]["sequence"].as_array().unwrap();
    let frames: Vec<(u64, bool)> = seq
        .iter()
        .map(|k| {
            (
                k["frame"].as_u64().unwrap(),
                k["enabled"].as_bool().unwrap(),
            )
        })
        .collect();
    // The gap after frame 4 and the track's end after frame 8 are disabled keyframes.
    assert_eq!(
        frames,
        [
            (1, true),
            (2, true),
            (3, true),
            (4, false),
            (7, true),
            (8, false)
        ]
    );
    // Percent of the frame size.
    assert!((seq[0]["x"].as_f64().unwrap() - 13.0 / 640.0 * 100.0).abs() < 1e-12);
    assert!((seq[0]["height"].as_f64().unwrap() - 40.0 / 480.0 * 100.0).abs() < 1e-12);
    // Filled frames 3–5 of the person are left to Label Studio's interpolation.
    let person = by_id("5")["value"]["sequence"].as_array().unwrap();
    let frames: Vec<u64> = person
        .iter()
        .map(|k| k["frame"].as_u64().unwrap())
        .collect();
    assert_eq!(frames, [2, 6]);
    assert_eq!(by_id("9")["value"]["labels"], serde_json::json!([]));
}

/// A Label Studio export as its UI writes it: random region ids, sparse keyframes, a labels
/// result, a rotated box, a cancelled annotation before the real one.
const EXPORT: &str = r#"[
  {"id": 12, "data": {"video": "clip.mp4"}, "annotations": [
    {"id": 1, "was_cancelled": true, "result": []},
    {"id": 2, "result": [
      {"id": "aB3x", "type": "videorectangle", "from_name": "box", "to_name": "video",
       "origin": "manual",
       "value": {"framesCount": 8, "duration": 0.32, "labels": ["car"], "sequence": [
         {"frame": 1, "enabled": true, "x": 10, "y": 10, "width": 10, "height": 10, "rotation": 0, "time": 0},
         {"frame": 5, "enabled": false, "x": 30, "y": 10, "width": 10, "height": 20, "rotation": 0, "time": 0.16},
         {"frame": 7, "enabled": true, "x": 50, "y": 50, "width": 10, "height": 10, "rotation": 0, "time": 0.24}
       ]}},
      {"id": "zz9", "type": "videorectangle", "from_name": "box", "to_name": "video",
       "value": {"framesCount": 8, "sequence": [
         {"frame": 2, "enabled": false, "x": 50, "y": 50, "width": 10, "height": 10, "rotation": 90}
       ]}},
      {"id": "zz9", "type": "labels", "from_name": "videoLabels", "to_name": "video",
       "value": {"labels": ["person"]}},
      {"id": "c1", "type": "choices", "value": {"choices": ["day"]}}
    ]}
  ]}
]"#;

#[test]
fn keyframes_expand_as_label_studio_shows_them() {
    let a = parse_label_studio(EXPORT, "export.json", (100, 200), None).unwrap();
    assert_eq!(a.labels, ["car", "person"]);
    assert_eq!(a.frames, 8);
    let car: Vec<&Record> = a.records.iter().filter(|r| r.id == 1).collect();
    let frames: Vec<(u32, bool)> = car
        .iter()
        .map(|r| (r.frame, r.flags.interpolated))
        .collect();
    // 1 key, 2–4 interpolated, 5 key (disabled: hidden 6), 7 key, 8 held to framesCount.
    assert_eq!(
        frames,
        [
            (1, false),
            (2, true),
            (3, true),
            (4, true),
            (5, false),
            (7, false),
            (8, true)
        ]
    );
    assert_eq!(car[0].bbox, BBox::new(10.0, 20.0, 10.0, 20.0));
    // Halfway between x 10 % and 30 %, height 10 % and 20 % of 200 px.
    assert_eq!(car[2].bbox, BBox::new(20.0, 20.0, 10.0, 30.0));
    assert_eq!(car[6].bbox, car[5].bbox);
    assert!(car.iter().all(|r| r.class == 0));
    // The second region: its label from the labels result; rotated 90° about its top-left
    // corner, its bounds extend to the left of it.
    let p: Vec<&Record> = a.records.iter().filter(|r| r.id == 2).collect();
    assert_eq!(p.len(), 1);
    assert_eq!(p[0].class, 1);
    let b = p[0].bbox;
    assert!(
        (b.x - 30.0).abs() < 1e-9 && (b.y - 100.0).abs() < 1e-9,
        "{b:?}"
    );
    assert!(
        (b.w - 20.0).abs() < 1e-9 && (b.h - 10.0).abs() < 1e-9,
        "{b:?}"
    );
}

#[test]
fn one_task_object_and_empty_files_read() {
    let task = r#"{"data": {"video": "v.mp4"}, "annotations": [{"result": []}]}"#;
    let a = parse_label_studio(task, "t", SIZE, None).unwrap();
    assert!(a.records.is_empty());
    assert_eq!(a.tasks, 1);
    let a = parse_label_studio("[]", "t", SIZE, None).unwrap();
    assert_eq!((a.tasks, a.records.len()), (0, 0));
}

/// The line and column of a JSON error, and its message.
fn at(e: IoError) -> (usize, usize, String) {
    match e {
        IoError::Json {
            line,
            column,
            message,
            ..
        } => (line, column, message),
        other => panic!("expected a JSON error, got {other:?}"),
    }
}

fn one_key(key: &str) -> String {
    format!(
        "[{{\"data\": {{}}, \"annotations\": [{{\"result\": [\n{{\"id\": \"a\", \"type\": \"videorectangle\", \"value\": {{\"sequence\": [\n{key}\n]}}}}]}}]}}]"
    )
}

#[test]
fn bad_files_give_typed_errors_at_the_bad_value() {
    // Malformed JSON: serde's position.
    let (line, _, _) =
        at(parse_label_studio("[{\"data\": \n,]", "m.json", SIZE, None).unwrap_err());
    assert_eq!(line, 2);
    let bad = [
        (r#"{"frame": 1, "x": 1, "y": 1, "width": 1}"#, "height"),
        (
            r#"{"frame": 0, "x": 1, "y": 1, "width": 1, "height": 1}"#,
            "frame",
        ),
        (
            r#"{"frame": 1.5, "x": 1, "y": 1, "width": 1, "height": 1}"#,
            "frame",
        ),
        (
            r#"{"frame": 1, "x": "1", "y": 1, "width": 1, "height": 1}"#,
            "x",
        ),
        (
            r#"{"frame": 1, "x": 1e999, "y": 1, "width": 1, "height": 1}"#,
            "x",
        ),
        (
            r#"{"frame": 1, "x": 1, "y": 1, "width": -1, "height": 1}"#,
            "width",
        ),
        (
            r#"{"frame": 1, "x": 1, "y": 1, "width": 1, "height": -0.5}"#,
            "height",
        ),
        (
            r#"{"frame": 1, "x": 1, "y": 1, "width": 1, "height": 1, "enabled": 1}"#,
            "enabled",
        ),
        (
            r#"{"frame": 1, "x": 1, "y": 1, "width": 1, "height": 1, "rotation": null}"#,
            "rotation",
        ),
        (r#"[1, 2]"#, "keyframe"),
    ];
    for (key, word) in bad {
        let (line, column, message) =
            at(parse_label_studio(&one_key(key), "k.json", SIZE, None).unwrap_err());
        assert_eq!(line, 3, "{key}: {message}");
        assert!(column >= 1, "{key}");
        assert!(message.contains(word), "{key}: {message}");
    }
    let two = one_key(
        "{\"frame\": 2, \"x\": 1, \"y\": 1, \"width\": 1, \"height\": 1},\n{\"frame\": 2, \"x\": 1, \"y\": 1, \"width\": 1, \"height\": 1}",
    );
    let (line, _, message) = at(parse_label_studio(&two, "k.json", SIZE, None).unwrap_err());
    assert_eq!(line, 4);
    assert!(message.contains("two keyframes"), "{message}");
    // Structure: no annotations, no sequence, no id, a duplicate region id.
    for (text, word) in [
        (r#"[{"data": {}}]"#, "annotations"),
        (r#"[{"annotations": [{}]}]"#, "result"),
        (
            r#"[{"annotations": [{"result": [{"id": "a", "type": "videorectangle", "value": {}}]}]}]"#,
            "sequence",
        ),
        (
            r#"[{"annotations": [{"result": [{"type": "videorectangle", "value": {"sequence": []}}]}]}]"#,
            "id",
        ),
        (
            r#"[{"annotations": [{"result": [{"id": "a", "type": "videorectangle", "value": {"sequence": []}}, {"id": "a", "type": "videorectangle", "value": {"sequence": []}}]}]}]"#,
            "two regions",
        ),
        (r#"{"annotations": 3}"#, "not a list"),
        ("3", "task"),
    ] {
        let (_, _, message) = at(parse_label_studio(text, "s.json", SIZE, None).unwrap_err());
        assert!(message.contains(word), "{text}: {message}");
    }
    // A label the label map does not have.
    let text = write_label_studio(&tracks(), &meta(10), &names()).unwrap();
    let only_car = BTreeMap::from([(0, "car".to_string())]);
    let (_, _, message) =
        at(parse_label_studio(&text, "l.json", SIZE, Some(&only_car)).unwrap_err());
    assert!(message.contains("person"), "{message}");
}

#[test]
fn the_frame_size_is_required() {
    for size in [(0, 0), (640, 0), (1 << 20, 1)] {
        assert!(matches!(
            parse_label_studio("[]", "t", size, None),
            Err(IoError::Invalid { .. })
        ));
        let m = LabelStudioMeta {
            width: size.0,
            height: size.1,
            ..meta(10)
        };
        assert!(matches!(
            write_label_studio(&tracks(), &m, &names()),
            Err(IoError::Invalid { .. })
        ));
    }
}

#[test]
fn unwritable_records_are_errors() {
    let check = |recs: Vec<Record>, m: LabelStudioMeta, word: &str| match write_label_studio(
        &recs,
        &m,
        &names(),
    ) {
        Err(IoError::Invalid { message, .. }) => assert!(message.contains(word), "{message}"),
        other => panic!("{other:?}"),
    };
    check(tracks(), meta(9), "outside");
    check(
        tracks(),
        LabelStudioMeta {
            fps: 0.0,
            ..meta(10)
        },
        "frame rate",
    );
    let mut r = tracks();
    let id = r[0].id;
    r.iter_mut()
        .filter(|x| x.id == id)
        .for_each(|x| x.class = 7);
    check(r, meta(10), "no label name");
    let mut r = tracks();
    r[0].class = 1 - r[0].class.max(0);
    check(r, meta(10), "classes");
    let mut r = tracks();
    r[1].bbox.h = -1.0;
    check(r, meta(10), "negative");
    let mut r = tracks();
    r[0].id = -1;
    check(r, meta(10), "unlinked");
    let mut r = tracks();
    let dup = r[0].clone();
    r.push(dup);
    check(r, meta(10), "twice");
}

#[test]
fn keyframes_far_apart_are_bounded() {
    let text = r#"[{"annotations": [{"result": [{"id": "a", "type": "videorectangle", "value": {"framesCount": 1048576, "sequence": [
      {"frame": 1, "enabled": true, "x": 1, "y": 1, "width": 1, "height": 1}]}}]}]}]"#;
    let (_, _, message) = at(parse_label_studio(text, "far.json", SIZE, None).unwrap_err());
    assert!(message.contains("split"), "{message}");
}

#[test]
fn garbage_never_panics() {
    for text in [
        "",
        "null",
        "{}",
        "[null]",
        "[{\"annotations\": null}]",
        "[{\"annotations\": [{\"result\": [null]}]}]",
        "[{\"annotations\": [{\"result\": [{\"type\": 3}]}]}]",
        "[{\"annotations\": [{\"result\": [{\"id\": {}, \"type\": \"videorectangle\", \"value\": {}}]}]}]",
        "[{\"annotations\": [{\"result\": [{\"id\": 1, \"type\": \"videorectangle\", \"value\": {\"sequence\": [{\"frame\": 4294967295, \"x\": 0, \"y\": 0, \"width\": 0, \"height\": 0}]}}]}]}]",
    ] {
        let _ = parse_label_studio(text, "g", SIZE, None);
    }
}
