//! CVAT for video 1.1 XML: a hand-made fixture, round trips, malformed files.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::io::cvat::{parse_cvat, write_cvat, CvatMeta};
use shapetrack::io::{IoError, Record, Rle};
use shapetrack::BBox;
use std::collections::BTreeMap;

fn fixture() -> String {
    std::fs::read_to_string(format!(
        "{}/tests/data/formats/cvat_video_1_1.xml",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap()
}

fn key(rs: &[Record], frame: u32, id: i64) -> &Record {
    rs.iter().find(|r| r.frame == frame && r.id == id).unwrap()
}

/// The hand-made file decodes to the records worked out by hand: keyframes, a listed
/// interpolated box, outside gaps, a sparse gap filled by linear interpolation, the object
/// persisting to the end of the task, a polygon and a CVAT mask.
#[test]
fn hand_made_fixture_imports_as_computed_by_hand() {
    let a = parse_cvat(&fixture(), "cvat.xml", None).unwrap();
    assert_eq!(
        a.meta,
        CvatMeta {
            name: "hand made".into(),
            size: 8,
            width: 20,
            height: 12
        }
    );
    assert_eq!(
        a.labels,
        vec!["car".to_string(), "person & bike".to_string()]
    );
    let rs = &a.records;
    let frames: Vec<(u32, i64)> = rs.iter().map(|r| (r.frame, r.id)).collect();
    assert_eq!(
        frames,
        vec![
            (1, 0),
            (2, 0),
            (2, 1),
            (4, 2),
            (5, 0),
            (6, 0),
            (7, 0),
            (8, 0)
        ]
    );
    let car = |f| key(rs, f, 0);
    assert_eq!(car(1).bbox, BBox::new(1.0, 2.0, 4.0, 4.0));
    assert!(!car(1).flags.interpolated);
    assert_eq!(car(2).bbox, BBox::new(2.0, 2.0, 4.0, 4.0));
    assert!(car(2).flags.interpolated);
    assert_eq!(car(5).bbox, BBox::new(4.0, 4.0, 4.0, 4.0));
    assert!(!car(5).flags.interpolated);
    // CVAT frame 5 lies halfway between the keyframes at 4 and 6.
    assert_eq!(car(6).bbox, BBox::new(6.0, 4.0, 4.0, 5.0));
    assert!(car(6).flags.interpolated);
    assert_eq!(car(7).bbox, BBox::new(8.0, 4.0, 4.0, 6.0));
    // After its last keyframe the car stays to the task's end (frame 8), interpolated.
    assert_eq!(car(8).bbox, BBox::new(8.0, 4.0, 4.0, 6.0));
    assert!(car(8).flags.interpolated);
    assert!(rs
        .iter()
        .filter(|r| r.id == 0)
        .all(|r| r.class == 0 && r.mask.is_none()));

    let poly = key(rs, 2, 1);
    assert_eq!(poly.class, 1);
    assert!(poly.flags.occluded);
    assert_eq!(poly.bbox, BBox::new(2.0, 2.0, 4.0, 3.0));
    let m = poly.mask.as_ref().unwrap();
    assert_eq!((m.width, m.height, m.area()), (20, 12, 12));
    assert_eq!(m.to_mask().bbox(), BBox::new(2.0, 2.0, 4.0, 3.0));

    let mask = key(rs, 4, 2);
    let mut full = vec![0u8; 20 * 12];
    for (x, y) in [(11, 4), (12, 4), (10, 5), (11, 5)] {
        full[y * 20 + x] = 1;
    }
    assert_eq!(mask.mask, Some(Rle::encode(20, 12, &full).unwrap()));
    assert_eq!(mask.bbox, BBox::new(10.0, 4.0, 3.0, 2.0));

    // With a label map, classes come from it.
    let map: BTreeMap<i32, String> =
        [(5, "car".to_string()), (9, "person & bike".to_string())].into();
    let b = parse_cvat(&fixture(), "cvat.xml", Some(&map)).unwrap();
    assert_eq!(key(&b.records, 4, 2).class, 9);
    assert_eq!(key(&b.records, 1, 0).class, 5);
}

fn masked(frame: u32, id: i64, class: i32, x0: u32, y0: u32) -> Record {
    let (w, h) = (16u32, 10u32);
    let mut bitmap = vec![0u8; (w * h) as usize];
    for (dx, dy) in [(0, 0), (1, 0), (1, 1), (2, 2), (0, 2)] {
        bitmap[((y0 + dy) * w + x0 + dx) as usize] = 1;
    }
    let rle = Rle::encode(w, h, &bitmap).unwrap();
    let mut r = Record::from_box(frame, id, rle.to_mask().bbox());
    r.mask = Some(rle);
    r.class = class;
    r
}

/// Boxes and masks, several tracks, gaps (outside), an id absent from the first frames, the
/// last frame of the task, interpolated and occluded flags all survive write → read.
#[test]
fn roundtrip_tracks() {
    let meta = CvatMeta {
        name: "rt <&>".into(),
        size: 6,
        width: 16,
        height: 10,
    };
    let labels: BTreeMap<i32, String> = [(0, "a".into()), (1, "b \"q\"".into())].into();
    let mut recs = vec![
        Record::from_box(1, 3, BBox::new(0.5, 1.25, 3.0, 2.0)),
        Record::from_box(2, 3, BBox::new(1.5, 1.25, 3.0, 2.0)),
        // gap at frame 3, back at 4
        Record::from_box(4, 3, BBox::new(2.0, 2.0, 3.0, 2.0)),
        masked(3, 7, 1, 4, 4),
        masked(4, 7, 1, 5, 4),
        masked(6, 7, 1, 13, 7),
    ];
    recs[1].flags.interpolated = true;
    recs[2].flags.occluded = true;
    recs[4].flags.interpolated = true;
    for r in recs.iter_mut().take(3) {
        r.class = 0;
    }
    let xml = write_cvat(&recs, &meta, &labels).unwrap();
    let back = parse_cvat(&xml, "rt.xml", Some(&labels)).unwrap();
    assert_eq!(back.meta, meta);
    recs.sort_by_key(|r| (r.frame, r.id));
    assert_eq!(back.records, recs);
    // Without a map the classes are label indices, which here are the same.
    let back2 = parse_cvat(&xml, "rt.xml", None).unwrap();
    assert_eq!(back2.records, recs);
    assert_eq!(back2.labels, vec!["a".to_string(), "b \"q\"".to_string()]);
    // Outside shapes: after frame 2 (cvat 2), after frame 4 (cvat 4) for id 3, after 4 for id 7;
    // none after frame 6, the task's last.
    assert_eq!(xml.matches("outside=\"1\"").count(), 3);
    // An empty track list is fine.
    let empty = write_cvat(&[], &meta, &labels).unwrap();
    assert!(parse_cvat(&empty, "e.xml", None)
        .unwrap()
        .records
        .is_empty());
}

#[test]
fn writer_rejects_inconsistent_records() {
    let meta = CvatMeta {
        name: String::new(),
        size: 3,
        width: 16,
        height: 10,
    };
    let labels: BTreeMap<i32, String> = [(0, "a".into())].into();
    let mut r = Record::from_box(4, 1, BBox::new(0.0, 0.0, 1.0, 1.0));
    r.class = 0;
    assert!(matches!(
        write_cvat(&[r.clone()], &meta, &labels),
        Err(IoError::Invalid { .. })
    ));
    r.frame = 1;
    r.class = 5;
    assert!(write_cvat(&[r.clone()], &meta, &labels).is_err());
    r.class = 0;
    assert!(write_cvat(&[r.clone(), r], &meta, &labels).is_err());
}

fn xml_err(text: &str) -> (usize, String) {
    match parse_cvat(text, "bad.xml", None) {
        Err(IoError::Xml {
            file,
            line,
            message,
            ..
        }) => {
            assert_eq!(file, "bad.xml");
            (line, message)
        }
        other => panic!("expected an XML error, got {other:?}"),
    }
}

#[test]
fn malformed_files_give_positioned_errors() {
    let head = "<annotations>\n<meta><task><size>5</size><original_size><width>8</width><height>6</height></original_size></task></meta>\n<track id=\"1\" label=\"a\">\n";
    let doc = |shape: &str| format!("{head}{shape}\n</track>\n</annotations>\n");
    // Truncated document.
    let t = fixture();
    let (l, m) = xml_err(&t[..t.len() / 2]);
    assert!(l > 30 && m.contains("malformed"), "{l} {m}");
    let (l, m) = xml_err(&t[..t.rfind("</track>").unwrap()]);
    assert!(l > 90 && m.contains("ends inside <track>"), "{l} {m}");
    // Mismatched closing tag.
    let (l, m) = xml_err("<annotations>\n<track id=\"1\" label=\"a\">\n</trak>\n</annotations>");
    assert_eq!(l, 3, "{m}");
    // Missing attribute, bad numbers, bad flags.
    assert_eq!(
        xml_err(&doc("<box frame=\"0\" xtl=\"1\" ytl=\"1\" xbr=\"2\"/>")).0,
        4
    );
    let (l, m) = xml_err(&doc(
        "<box frame=\"0\" xtl=\"1\" ytl=\"x\" xbr=\"2\" ybr=\"3\"/>",
    ));
    assert_eq!(l, 4);
    assert!(m.contains("ytl"), "{m}");
    assert_eq!(
        xml_err(&doc(
            "<box frame=\"-1\" xtl=\"1\" ytl=\"1\" xbr=\"2\" ybr=\"3\"/>"
        ))
        .0,
        4
    );
    assert_eq!(
        xml_err(&doc(
            "<box frame=\"0\" outside=\"maybe\" xtl=\"1\" ytl=\"1\" xbr=\"2\" ybr=\"3\"/>"
        ))
        .0,
        4
    );
    assert_eq!(
        xml_err(&doc(
            "<box frame=\"0\" xtl=\"3\" ytl=\"1\" xbr=\"2\" ybr=\"3\"/>"
        ))
        .0,
        4
    );
    // Frame beyond the task.
    assert_eq!(
        xml_err(&doc(
            "<box frame=\"5\" xtl=\"1\" ytl=\"1\" xbr=\"2\" ybr=\"3\"/>"
        ))
        .0,
        4
    );
    // Mask whose runs do not fill its box, or that leaves the frame.
    assert_eq!(
        xml_err(&doc(
            "<mask frame=\"0\" rle=\"1, 2\" left=\"0\" top=\"0\" width=\"2\" height=\"2\"/>"
        ))
        .0,
        4
    );
    assert_eq!(
        xml_err(&doc(
            "<mask frame=\"0\" rle=\"1, 8\" left=\"7\" top=\"0\" width=\"3\" height=\"3\"/>"
        ))
        .0,
        4
    );
    // Polygon with a bad point.
    assert_eq!(
        xml_err(&doc("<polygon frame=\"0\" points=\"1,1;2;3,3\"/>")).0,
        4
    );
    // Unsupported shape.
    let (_, m) = xml_err(&doc("<polyline frame=\"0\" points=\"1,1;2,2\"/>"));
    assert!(m.contains("not supported"), "{m}");
    // Two shapes in one frame.
    let two = "<box frame=\"1\" xtl=\"1\" ytl=\"1\" xbr=\"2\" ybr=\"3\"/>\n<box frame=\"1\" xtl=\"1\" ytl=\"1\" xbr=\"2\" ybr=\"3\"/>";
    assert_eq!(xml_err(&doc(two)).0, 5);
    // Wrong root, CVAT for images, polygons without a frame size.
    assert_eq!(xml_err("<?xml version=\"1.0\"?>\n<foo/>").0, 2);
    assert!(xml_err("<annotations><image id=\"0\"/></annotations>")
        .1
        .contains("images"));
    assert!(xml_err("<annotations><track id=\"1\" label=\"a\"><polygon frame=\"0\" points=\"1,1;2,2;3,1\"/></track></annotations>").1.contains("original_size"));
    // Not XML at all / unknown entity.
    assert!(parse_cvat("<<<", "bad.xml", None).is_err());
    assert!(
        xml_err("<annotations><version>&bogus;</version></annotations>")
            .1
            .contains("entity")
    );
}
