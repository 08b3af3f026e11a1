//! Scalabel JSON (BDD100K): the four sample files round-trip, convert to records with the
//! documented conventions, records round-trip through the writer, and bad input gets typed
//! errors at the right place, never a panic.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::io::scalabel::{
    from_records, parse_scalabel, split_videos, to_records, write_scalabel, Categories, IdMap,
};
use shapetrack::io::{read_text, IoError};
use shapetrack::BBox;
use std::collections::BTreeSet;
use std::path::PathBuf;

fn sample(rel: &str) -> (String, String) {
    let shared = std::env::var_os("SHAPETRACK_SHARED")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared"));
    let p = shared.join("data/bdd100k-sample").join(rel);
    (read_text(&p).unwrap(), p.display().to_string())
}

const FILES: [&str; 4] = [
    "box_track/track_sample_anns.json",
    "box_track/track_predictions.json",
    "seg_track/seg_track_sample.json",
    "seg_track/seg_track_preds.json",
];

#[test]
fn the_bdd100k_samples_round_trip() {
    for f in FILES {
        let (text, name) = sample(f);
        let frames = parse_scalabel(&text, &name).unwrap();
        let written = write_scalabel(&frames).unwrap();
        let a: serde_json::Value = serde_json::from_str(&text).unwrap();
        let b: serde_json::Value = serde_json::from_str(&written).unwrap();
        assert_eq!(a, b, "{f}");
        // And once more through the reader: the same frames.
        assert_eq!(parse_scalabel(&written, "again").unwrap(), frames, "{f}");
    }
}

#[test]
fn samples_have_their_documented_contents() {
    let count = |f: &str| {
        let (text, name) = sample(f);
        let frames = parse_scalabel(&text, &name).unwrap();
        let labels: usize = frames.iter().map(|f| f.labels.len()).sum();
        let ids: BTreeSet<String> = frames
            .iter()
            .flat_map(|f| f.labels.iter().map(|l| l.id.clone()))
            .collect();
        (frames.len(), labels, ids.len(), frames)
    };
    let (n, _, ids, frames) = count(FILES[0]);
    assert_eq!((n, ids), (202, 144));
    assert_eq!(split_videos(frames).len(), 1);
    let (n, boxes, _, frames) = count(FILES[1]);
    assert_eq!((n, boxes), (202, 2301));
    assert!(frames
        .iter()
        .flat_map(|f| &f.labels)
        .all(|l| l.score.is_some_and(|s| (0.0..=1.0).contains(&s))));
    let (n, _, ids, frames) = count(FILES[2]);
    assert_eq!((n, ids), (100, 90));
    assert!(frames
        .iter()
        .flat_map(|f| &f.labels)
        .all(|l| l.rle.is_some()));
    let (n, masks, _, _) = count(FILES[3]);
    assert_eq!((n, masks), (100, 1567));
}

#[test]
fn labels_convert_with_inclusive_boxes_dense_ids_and_bdd_classes() {
    let (text, name) = sample(FILES[0]);
    let frames = parse_scalabel(&text, &name).unwrap();
    let (mut ids, mut cats) = (IdMap::default(), Categories::default());
    let recs = to_records(&frames, &mut ids, &mut cats, false);
    // The first label: a-00122062, a car, x1 0, y1 346.55…, x2 75.41…, y2 407.45…
    let r = &recs[0];
    assert_eq!((r.frame, r.id, r.class), (1, 1, 3));
    assert_eq!(ids.name(1), Some("a-00122062"));
    assert!((r.bbox.w - (75.41276162779963 + 1.0)).abs() < 1e-12);
    assert!((r.bbox.y - 346.55482900742646).abs() < 1e-12);
    assert!((r.bbox.h - (407.4496307987563 - 346.55482900742646 + 1.0)).abs() < 1e-12);
    assert!(r.flags.occluded == frames[0].labels[0].occluded);
    assert_eq!(ids.len(), 144);
    assert_eq!(r.score, 1.0);
    // Crowd labels can be left out.
    let crowd = frames
        .iter()
        .flat_map(|f| &f.labels)
        .filter(|l| l.crowd)
        .count();
    let without = to_records(
        &frames,
        &mut IdMap::default(),
        &mut Categories::default(),
        true,
    );
    assert_eq!(without.len(), recs.len() - crowd);
    // Masks: the box is the mask's tight box.
    let (text, name) = sample(FILES[3]);
    let frames = parse_scalabel(&text, &name).unwrap();
    let recs = to_records(
        &frames,
        &mut IdMap::default(),
        &mut Categories::default(),
        false,
    );
    assert_eq!(recs.len(), 1567);
    for r in recs.iter().take(50) {
        assert_eq!(r.bbox, r.mask_bitmap().unwrap().bbox());
    }
}

#[test]
fn records_round_trip_through_the_writer() {
    let (text, name) = sample(FILES[2]);
    let frames = parse_scalabel(&text, &name).unwrap();
    let (mut ids, mut cats) = (IdMap::default(), Categories::default());
    let recs = to_records(&frames, &mut ids, &mut cats, false);
    let out = from_records(&recs, "b1c66a42-6f7d68ca", 100, Some(&ids), &cats);
    assert_eq!(out.len(), 100);
    let text2 = write_scalabel(&out).unwrap();
    let back = parse_scalabel(&text2, "written").unwrap();
    let (mut ids2, mut cats2) = (IdMap::default(), cats.clone());
    let recs2 = to_records(&back, &mut ids2, &mut cats2, false);
    assert_eq!(recs2.len(), recs.len());
    let mut a = recs.clone();
    let mut b = recs2.clone();
    a.sort_by_key(|r| (r.frame, ids.name(r.id).unwrap().to_string()));
    b.sort_by_key(|r| (r.frame, ids2.name(r.id).unwrap().to_string()));
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(ids.name(x.id), ids2.name(y.id));
        assert_eq!((x.frame, x.class, &x.mask), (y.frame, y.class, &y.mask));
        assert!((x.bbox.x - y.bbox.x).abs() < 1e-9 && (x.bbox.w - y.bbox.w).abs() < 1e-9);
    }
    // Boxes without masks: x2 = x + w − 1 and back.
    let b = BBox::new(10.5, 20.0, 30.0, 40.0);
    let rec = shapetrack::io::Record::from_box(3, 7, b);
    let out = write_scalabel(&from_records(&[rec], "v", 3, None, &cats)).unwrap();
    assert!(
        out.contains("\"x2\":39.5") && out.contains("\"y2\":59.0"),
        "{out}"
    );
    let back = parse_scalabel(&out, "w").unwrap();
    assert_eq!(back.len(), 3);
    assert_eq!(back[2].labels[0].bbox, Some(b));
    assert_eq!(back[2].labels[0].id, "7");
    assert!(back[0].labels.is_empty());
}

fn err(text: &str) -> IoError {
    parse_scalabel(text, "bad.json").unwrap_err()
}

fn at(e: &IoError) -> (usize, usize, String) {
    match e {
        IoError::Json {
            line,
            column,
            message,
            ..
        } => (*line, *column, message.clone()),
        other => panic!("not a JSON error: {other:?}"),
    }
}

#[test]
fn bad_input_gets_typed_errors_at_the_offending_value() {
    // Not JSON.
    let (l, _, _) = at(&err("[{\"frameIndex\": 0,\n \"labels\": [}]"));
    assert_eq!(l, 2);
    // Not a list of frames.
    assert!(at(&err("42")).2.contains("list of frames"));
    assert!(at(&err("{\"config\": {}}")).2.contains("frames"));
    // A frame without frameIndex, on line 2.
    let (l, c, m) = at(&err("[\n  {\"labels\": []}\n]"));
    assert_eq!((l, c), (2, 3));
    assert!(m.contains("frameIndex"), "{m}");
    assert!(at(&err("[{\"frameIndex\": -1}]")).2.contains("frameIndex"));
    // A label without id, on line 3.
    let (l, _, m) = at(&err(
        "[{\"frameIndex\": 0, \"labels\": [\n {\"id\": \"a\"},\n {\"category\": \"car\"}]}]",
    ));
    assert_eq!(l, 3);
    assert!(m.contains("id"), "{m}");
    // Boxes: a missing coordinate, an inverted box.
    let frame = |label: &str| format!("[{{\"frameIndex\": 0, \"labels\": [{label}]}}]");
    let m = at(&err(&frame(
        r#"{"id": "a", "box2d": {"x1": 0, "y1": 0, "x2": 5}}"#,
    )))
    .2;
    assert!(m.contains("box2d.y2"), "{m}");
    let m = at(&err(&frame(
        r#"{"id": "a", "box2d": {"x1": 9, "y1": 0, "x2": 5, "y2": 4}}"#,
    )))
    .2;
    assert!(m.contains("x2 < x1"), "{m}");
    // Two labels with one id.
    let m = at(&err(&frame(r#"{"id": "a"}, {"id": "a"}"#))).2;
    assert!(m.contains("two labels"), "{m}");
    // RLE: malformed counts, and a size that disagrees with the file's other masks.
    let e = err(&frame(
        r#"{"id": "a", "rle": {"counts": "~~~~", "size": [4, 4]}}"#,
    ));
    assert!(matches!(e, IoError::Rle { .. }), "{e:?}");
    let two = r#"[{"frameIndex": 0, "labels": [{"id": "a", "rle": {"counts": "04", "size": [2, 2]}}]},
 {"frameIndex": 1, "labels": [{"id": "a", "rle": {"counts": "09", "size": [3, 3]}}]}]"#;
    let (l, _, m) = at(&err(two));
    assert_eq!(l, 2);
    assert!(m.contains("differs"), "{m}");
    // Empty and null label lists are fine.
    let ok = parse_scalabel(
        r#"[{"frameIndex": 0, "labels": null}, {"frameIndex": 1}]"#,
        "x",
    )
    .unwrap();
    assert!(ok.iter().all(|f| f.labels.is_empty()));
    let again = write_scalabel(&ok).unwrap();
    assert_eq!(
        serde_json::from_str::<serde_json::Value>(&again).unwrap(),
        serde_json::json!([{"frameIndex": 0, "labels": null}, {"frameIndex": 1}])
    );
}

#[test]
fn truncated_and_garbled_files_never_panic() {
    let (text, _) = sample(FILES[1]);
    let text = &text[..20_000.min(text.len())];
    let mut errors = 0;
    for cut in (1..text.len()).step_by(97) {
        if parse_scalabel(&text[..cut], "cut").is_err() {
            errors += 1;
        }
        // Garble one byte into a quote or a brace.
        let mut g = text.as_bytes().to_vec();
        g[cut] = if cut % 2 == 0 { b'"' } else { b'}' };
        let _ = parse_scalabel(&String::from_utf8_lossy(&g), "garbled");
    }
    assert!(errors > 100);
}

#[test]
fn plain_integer_ids_keep_their_value_and_others_are_numbered_after_them() {
    let mut ids = IdMap::default();
    // A tracker's ids, first seen out of order (a later id's earlier views): kept as given.
    assert_eq!(ids.intern("6"), 6);
    assert_eq!(ids.intern("5"), 5);
    assert_eq!(ids.intern("6"), 6);
    // Strings that are not plain positive integers are numbered after the largest so far.
    assert_eq!(ids.intern("a-00122062"), 7);
    assert_eq!(ids.intern("07"), 8);
    assert_eq!(ids.intern("0"), 9);
    assert_eq!(ids.intern("-3"), 10);
    assert_eq!(ids.intern("99999999999999999999"), 11);
    // A plain integer whose value is taken by a numbered string gets the next one.
    assert_eq!(ids.intern("8"), 12);
    assert_eq!(ids.name(8), Some("07"));
    assert_eq!(ids.name(12), Some("8"));
    assert_eq!(ids.name(1), None);
    assert_eq!(ids.len(), 8);
}
