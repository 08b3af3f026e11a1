//! COCO-video / YouTube-VIS JSON: pycocotools cross-check, round trips, malformed input.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::io::coco_video::{
    parse_coco_video, parse_coco_video_results, write_coco_video, write_coco_video_results,
    Category, VideoInfo,
};
use shapetrack::io::{IoError, Record, Rle};
use shapetrack::BBox;

fn fixture(name: &str) -> String {
    let p = format!("{}/tests/data/formats/{name}", env!("CARGO_MANIFEST_DIR"));
    std::fs::read_to_string(&p).unwrap()
}

#[derive(serde::Deserialize)]
struct Expected {
    video_id: i64,
    id: i64,
    frame: u32,
    counts: String,
    bbox: [f64; 4],
    area: u64,
}

/// Every mask of the fixture (compressed strings, uncompressed counts, single and multiple
/// polygons, some outside the image) decodes to exactly what pycocotools decodes.
#[test]
fn pycocotools_fixture_decodes_identically() {
    let data = parse_coco_video(&fixture("coco_video_pycocotools.json"), "fixture").unwrap();
    let expected: Vec<Expected> =
        serde_json::from_str(&fixture("coco_video_pycocotools_expected.json")).unwrap();
    let total: usize = data.videos.iter().map(|v| v.records.len()).sum();
    assert_eq!(total, expected.len());
    for e in &expected {
        let v = data
            .videos
            .iter()
            .find(|v| v.video.id == e.video_id)
            .unwrap();
        let r = v
            .records
            .iter()
            .find(|r| r.id == e.id && r.frame == e.frame)
            .unwrap();
        let m = r.mask.as_ref().unwrap();
        let want = Rle::from_compressed(&e.counts, v.video.height, v.video.width).unwrap();
        assert_eq!(
            m, &want,
            "video {} ann {} frame {}",
            e.video_id, e.id, e.frame
        );
        assert_eq!(m.to_compressed(), e.counts);
        assert_eq!(m.area(), e.area);
        assert_eq!(
            r.bbox,
            BBox::new(e.bbox[0], e.bbox[1], e.bbox[2], e.bbox[3])
        );
    }
    assert_eq!(data.categories.len(), 2);
    assert_eq!(data.videos[1].video.file_names.len(), 3);
}

fn video(id: i64, w: u32, h: u32, len: u32) -> VideoInfo {
    VideoInfo {
        id,
        width: w,
        height: h,
        length: len,
        file_names: (0..len).map(|i| format!("v{id}/{i:05}.jpg")).collect(),
    }
}

fn masked(frame: u32, id: i64, class: i32, w: u32, h: u32, x0: u32, y0: u32) -> Record {
    let mut bitmap = vec![0u8; (w * h) as usize];
    for y in y0..(y0 + 3).min(h) {
        for x in x0..(x0 + 2).min(w) {
            bitmap[(y * w + x) as usize] = 1;
        }
    }
    let rle = Rle::encode(w, h, &bitmap).unwrap();
    let mut r = Record::from_box(frame, id, rle.to_mask().bbox());
    r.mask = Some(rle);
    r.class = class;
    r
}

/// Two videos, mask and box tracks, an empty frame, interpolated/occluded flags and per-frame
/// scores all survive write → read.
#[test]
fn roundtrip_two_videos() {
    let (v1, v2) = (video(10, 9, 7, 5), video(11, 12, 4, 3));
    let mut r1 = vec![
        masked(1, 1, 3, 9, 7, 1, 1),
        masked(2, 1, 3, 9, 7, 2, 1),
        // frame 3 empty, id 1 back in frame 4, interpolated
        masked(4, 1, 3, 9, 7, 4, 2),
        masked(5, 2, 4, 9, 7, 6, 3),
    ];
    r1[2].flags.interpolated = true;
    r1[3].flags.occluded = true;
    r1[3].score = 0.25;
    let mut r2 = vec![Record::from_box(2, 1, BBox::new(0.5, 1.0, 3.25, 2.0))];
    r2[0].class = 4;
    let cats = vec![
        Category {
            id: 3,
            name: "car".into(),
        },
        Category {
            id: 4,
            name: "person".into(),
        },
    ];
    let text = write_coco_video(&[(v1.clone(), &r1), (v2.clone(), &r2)], &cats).unwrap();
    let back = parse_coco_video(&text, "rt").unwrap();
    assert_eq!(back.videos[0].video, v1);
    assert_eq!(back.videos[1].video, v2);
    assert_eq!(back.videos[0].records, r1);
    assert_eq!(back.videos[1].records, r2);
    assert_eq!(back.categories, cats);
    // Writing the parsed data again gives the same text.
    assert_eq!(back.to_json().unwrap(), text);
}

#[test]
fn roundtrip_results_form() {
    let v = video(5, 9, 7, 4);
    let mut recs = vec![masked(1, 1, 2, 9, 7, 0, 0), masked(3, 1, 2, 9, 7, 1, 1)];
    recs[0].score = 0.5;
    recs[1].score = 0.5;
    let text = write_coco_video_results(&[(v.clone(), &recs)]).unwrap();
    assert!(text.starts_with('['));
    let back = parse_coco_video_results(&text, "res", &[v]).unwrap();
    assert_eq!(back[&5], recs);
}

#[test]
fn writer_rejects_inconsistent_records() {
    let v = video(1, 9, 7, 2);
    let r = vec![masked(3, 1, 1, 9, 7, 0, 0)];
    assert!(matches!(
        write_coco_video(&[(v.clone(), &r)], &[]),
        Err(IoError::Invalid { .. })
    ));
    let r = vec![masked(1, 1, 1, 5, 5, 0, 0)];
    assert!(write_coco_video(&[(v.clone(), &r)], &[]).is_err());
    let r = vec![masked(1, 1, 1, 9, 7, 0, 0), masked(2, 1, 2, 9, 7, 0, 0)];
    assert!(write_coco_video(&[(v, &r)], &[]).is_err());
}

fn json_err(text: &str) -> (usize, usize, String) {
    match parse_coco_video(text, "bad.json") {
        Err(IoError::Json {
            file,
            line,
            column,
            message,
        }) => {
            assert_eq!(file, "bad.json");
            (line, column, message)
        }
        Err(IoError::Rle { file, line, .. }) => {
            assert_eq!(file, "bad.json");
            (line, 0, "rle".into())
        }
        other => panic!("expected an error, got {other:?}"),
    }
}

#[test]
fn malformed_files_give_positioned_errors() {
    let head =
        "{\"videos\":[{\"id\":1,\"width\":4,\"height\":3,\"length\":2}],\n\"annotations\":[\n";
    // Truncated document.
    assert_eq!(json_err("{\"videos\":[").0, 1);
    // Wrong type: width is a string.
    let (l, _, m) = json_err("{\"videos\":[\n{\"id\":1,\"width\":\"4\",\"height\":3}]}");
    assert_eq!(l, 2, "{m}");
    assert!(m.contains("invalid type"), "{m}");
    // Missing key.
    let (l, _, m) = json_err("{\"videos\":[\n{\"id\":1,\"height\":3}]}");
    assert_eq!(l, 2);
    assert!(m.contains("width"), "{m}");
    // RLE that does not cover the video.
    let t = format!("{head}{{\"id\":1,\"video_id\":1,\"category_id\":1,\"segmentations\":[\n{{\"size\":[3,4],\"counts\":[1,2]}}]}}]}}");
    let (l, _, m) = json_err(&t);
    assert_eq!(l, 4, "{m}");
    // RLE of another size.
    let t = format!("{head}{{\"id\":1,\"video_id\":1,\"category_id\":1,\"segmentations\":[\n{{\"size\":[4,4],\"counts\":\"<\"}}]}}]}}");
    assert_eq!(json_err(&t).0, 4);
    // Bad compressed string.
    let t = format!("{head}{{\"id\":1,\"video_id\":1,\"category_id\":1,\"segmentations\":[\n{{\"size\":[3,4],\"counts\":\"!!\"}}]}}]}}");
    assert_eq!(json_err(&t).0, 4);
    // Too many frames.
    let t = format!(
        "{head}{{\"id\":1,\"video_id\":1,\"category_id\":1,\"bboxes\":[null,null,[1,1,1,1]]}}]}}"
    );
    assert_eq!(json_err(&t).0, 3);
    // Negative box size.
    let t =
        format!("{head}{{\"id\":1,\"video_id\":1,\"category_id\":1,\"bboxes\":[[1,1,-1,1]]}}]}}");
    assert_eq!(json_err(&t).0, 3);
    // Polygon with too few coordinates.
    let t = format!(
        "{head}{{\"id\":1,\"video_id\":1,\"category_id\":1,\"segmentations\":[\n[[1,1,2,2]]]}}]}}"
    );
    assert_eq!(json_err(&t).0, 4);
    // Duplicate annotation id.
    let t = format!("{head}{{\"id\":1,\"video_id\":1,\"category_id\":1}},\n{{\"id\":1,\"video_id\":1,\"category_id\":1}}]}}");
    assert_eq!(json_err(&t).0, 4);
    // Zero-size video.
    assert_eq!(
        json_err("{\"videos\":[{\"id\":1,\"width\":0,\"height\":3}]}").0,
        1
    );
}
