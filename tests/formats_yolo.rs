//! YOLO-style txt with track ids: records round-trip through the single-file and the
//! per-frame (Ultralytics) forms, Ultralytics' own lines read as documented, and bad input
//! gets typed errors at the right line and field, never a panic.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::io::yolo::{parse_yolo, parse_yolo_frame, write_yolo, write_yolo_frames};
use shapetrack::io::{IoError, Record};
use shapetrack::BBox;

const SIZE: (u32, u32) = (640, 480);

fn rec(frame: u32, id: i64, class: i32, score: f64, b: (f64, f64, f64, f64)) -> Record {
    let mut r = Record::from_box(frame, id, BBox::new(b.0, b.1, b.2, b.3));
    r.class = class;
    r.score = score;
    r
}

/// Two tracks with a gap, an unlinked box, several classes and scores.
fn tracks() -> Vec<Record> {
    vec![
        rec(1, 1, 0, 0.9, (10.0, 20.0, 30.0, 40.0)),
        rec(1, 2, 2, 0.75, (100.5, 200.25, 50.0, 60.0)),
        rec(1, -1, 3, 0.3, (0.0, 0.0, 640.0, 480.0)),
        rec(2, 1, 0, 0.8, (12.0, 22.0, 30.0, 40.0)),
        // Id 2 is missing in frame 2: a gap.
        rec(3, 1, 0, 1.0, (14.0, 24.0, 31.0, 41.0)),
        rec(3, 2, 2, 0.5, (-5.0, 470.0, 20.0, 20.0)),
    ]
}

fn assert_same(a: &[Record], b: &[Record]) {
    assert_eq!(a.len(), b.len(), "{a:?}\n{b:?}");
    for (x, y) in a.iter().zip(b) {
        assert_eq!(
            (x.frame, x.id, x.class),
            (y.frame, y.id, y.class),
            "{x:?} vs {y:?}"
        );
        for (p, q) in [
            (x.bbox.x, y.bbox.x),
            (x.bbox.y, y.bbox.y),
            (x.bbox.w, y.bbox.w),
            (x.bbox.h, y.bbox.h),
            (x.score, y.score),
        ] {
            assert!((p - q).abs() < 1e-9, "{x:?} vs {y:?}");
        }
        assert_eq!(x.flags, y.flags);
    }
}

fn sorted(mut v: Vec<Record>) -> Vec<Record> {
    v.sort_by_key(|r| (r.frame, r.id));
    v
}

#[test]
fn records_round_trip_through_the_single_file_form() {
    let recs = tracks();
    let text = write_yolo(&recs, SIZE).unwrap();
    // One line per record, frame first, normalised centre and size.
    assert_eq!(text.lines().count(), recs.len());
    assert!(
        text.starts_with("1 3 0.5 0.5 1 1 0.3 -1\n"),
        "the unlinked box sorts first: {text}"
    );
    assert!(text.contains("\n1 0 0.0390625 0.0833333333"), "{text}");
    let back = parse_yolo(&text, "t.txt", SIZE).unwrap();
    assert_same(&sorted(recs), &back);
}

#[test]
fn records_round_trip_through_per_frame_files() {
    let recs = tracks();
    let files = write_yolo_frames(&recs, SIZE).unwrap();
    // No file for a frame without boxes; frame 2 has one line.
    assert_eq!(files.keys().copied().collect::<Vec<_>>(), [1, 2, 3]);
    assert_eq!(files[&2].lines().count(), 1);
    let mut back = Vec::new();
    for (frame, text) in &files {
        back.extend(parse_yolo_frame(text, &format!("video_{frame}.txt"), *frame, SIZE).unwrap());
    }
    assert_same(&sorted(recs), &sorted(back));
}

#[test]
fn ultralytics_lines_read_with_and_without_conf_and_id() {
    // class cx cy w h track_id (save_txt), with conf (save_conf), and a plain detection label.
    let text = "0 0.5 0.5 0.25 0.5 7\r\n\n2 0.25 0.25 0.1 0.1 0.66 8\n1 0.5 0.5 1 1\n";
    let r = parse_yolo_frame(text, "v_4.txt", 4, (100, 200)).unwrap();
    assert_eq!(r.len(), 3);
    assert_eq!(
        (r[0].frame, r[0].id, r[0].class, r[0].score),
        (4, 7, 0, 1.0)
    );
    assert_eq!(r[0].bbox, BBox::new(37.5, 50.0, 25.0, 100.0));
    assert_eq!((r[1].id, r[1].class, r[1].score), (8, 2, 0.66));
    assert_eq!((r[2].id, r[2].class), (-1, 1));
    assert_eq!(r[2].bbox, BBox::new(0.0, 0.0, 100.0, 200.0));
    // The same lines with a frame prefix are the single-file form.
    let single: String = text
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| format!("4 {l}\n"))
        .collect();
    let s = parse_yolo(&single, "all.txt", (100, 200)).unwrap();
    assert_same(&sorted(r), &s);
}

#[test]
fn interpolated_frames_are_written_as_plain_lines() {
    // YOLO cannot flag a filled frame: it comes back as an ordinary box (documented).
    let mut recs = tracks();
    recs[3].flags.interpolated = true;
    let back = parse_yolo(&write_yolo(&recs, SIZE).unwrap(), "t", SIZE).unwrap();
    assert!(back.iter().all(|r| !r.flags.interpolated));
    assert_eq!(back.len(), recs.len());
}

#[test]
fn no_class_is_written_as_class_zero() {
    let recs = vec![rec(1, 1, -1, 1.0, (1.0, 2.0, 3.0, 4.0))];
    let back = parse_yolo(&write_yolo(&recs, SIZE).unwrap(), "t", SIZE).unwrap();
    assert_eq!(back[0].class, 0);
}

/// The line and field of a parse error.
fn at(e: IoError) -> (usize, usize) {
    match e {
        IoError::Parse { line, column, .. } => (line, column),
        other => panic!("expected a parse error, got {other:?}"),
    }
}

#[test]
fn bad_lines_give_typed_errors_at_their_field() {
    let good = "1 0 0.5 0.5 0.1 0.1 0.9 3\n";
    let cases: [(&str, (usize, usize)); 10] = [
        ("x 0 0.5 0.5 0.1 0.1 0.9 3", (1, 1)),
        ("0 0 0.5 0.5 0.1 0.1 0.9 3", (1, 1)),
        ("1 -2 0.5 0.5 0.1 0.1 0.9 3", (1, 2)),
        ("1 0 nan 0.5 0.1 0.1 0.9 3", (1, 3)),
        ("1 0 0.5 inf 0.1 0.1 0.9 3", (1, 4)),
        ("1 0 0.5 0.5 -0.1 0.1 0.9 3", (1, 5)),
        ("1 0 0.5 0.5 0.1 -0.1 0.9 3", (1, 6)),
        ("1 0 0.5 0.5 0.1 0.1 NaN 3", (1, 7)),
        ("1 0 0.5 0.5 0.1 0.1 0.9 3.5", (1, 8)),
        ("1 0 0.5 0.5", (1, 2)),
    ];
    for (line, want) in cases {
        let text = format!("{good}{line}\n");
        let e = parse_yolo(&text, "bad.txt", SIZE).unwrap_err();
        let msg = e.to_string();
        assert!(msg.starts_with("bad.txt:2:"), "{line}: {msg}");
        assert_eq!(at(e), (want.0 + 1, want.1), "{line}");
    }
    // Too many fields.
    let e = parse_yolo("1 0 0.5 0.5 0.1 0.1 0.9 3 4\n", "b", SIZE).unwrap_err();
    assert_eq!(at(e), (1, 2));
    // A frame beyond the cap.
    let e = parse_yolo("99999999 0 0.5 0.5 0.1 0.1 3\n", "b", SIZE).unwrap_err();
    assert_eq!(at(e), (1, 1));
    // Per-frame lines are numbered from their first field.
    let e = parse_yolo_frame("0 0.5 0.5 -1 0.1 3\n", "f", 1, SIZE).unwrap_err();
    assert_eq!(at(e), (1, 4));
}

#[test]
fn a_track_twice_in_a_frame_is_an_error() {
    let text = "1 0 0.5 0.5 0.1 0.1 3\n1 0 0.4 0.5 0.1 0.1 3\n";
    match parse_yolo(text, "dup.txt", SIZE).unwrap_err() {
        IoError::Invalid { line, message, .. } => {
            assert_eq!(line, 2);
            assert!(message.contains("twice"), "{message}");
        }
        e => panic!("{e:?}"),
    }
    // Unlinked boxes (-1) may share a frame.
    let text = "1 0 0.5 0.5 0.1 0.1 -1\n1 0 0.4 0.5 0.1 0.1 -1\n";
    assert_eq!(parse_yolo(text, "ok.txt", SIZE).unwrap().len(), 2);
}

#[test]
fn the_image_size_is_required() {
    let recs = tracks();
    for size in [(0, 0), (640, 0), (0, 480), (1 << 20, 10)] {
        for e in [
            write_yolo(&recs, size).unwrap_err(),
            write_yolo_frames(&recs, size).unwrap_err(),
            parse_yolo("1 0 0.5 0.5 0.1 0.1 3\n", "t", size).unwrap_err(),
            parse_yolo_frame("0 0.5 0.5 0.1 0.1 3\n", "t", 1, size).unwrap_err(),
        ] {
            assert!(
                matches!(&e, IoError::Invalid { message, .. } if message.contains("width and height")),
                "{e:?}"
            );
        }
    }
}

#[test]
fn unwritable_records_are_errors() {
    let mut bad = tracks();
    bad[0].bbox.w = f64::NAN;
    assert!(matches!(
        write_yolo(&bad, SIZE),
        Err(IoError::Invalid { .. })
    ));
    let mut bad = tracks();
    bad[0].frame = 0;
    assert!(matches!(
        write_yolo(&bad, SIZE),
        Err(IoError::Invalid { .. })
    ));
}

#[test]
fn garbage_never_panics() {
    for text in [
        "",
        "\n\n",
        "1",
        "1 2 3 4 5 6 7 8 9 10",
        "1 0 1e400 0.5 0.1 0.1 1",
        "4294967296 0 0.5 0.5 0.1 0.1 1",
        "1 0 0.5 0.5 0.1 0.1 99999999999999999999",
        "\u{feff}1 0 0.5 0.5 0.1 0.1 1",
        "1\t0\t0.5\t0.5\t0.1\t0.1\t1",
    ] {
        let _ = parse_yolo(text, "g", SIZE);
        let _ = parse_yolo_frame(text, "g", 1, SIZE);
    }
}
