//! Random bytes and mutated valid files fed to every reader: Ok or a typed error, never a panic.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use proptest::prelude::*;
use shapetrack::io::coco_video::{parse_coco_video, parse_coco_video_results};
use shapetrack::io::cvat::parse_cvat;
use shapetrack::io::png_masks::{decode_png_masks, encode_png_masks, EightBit};
use shapetrack::io::vot::{parse_anchor_values, parse_regions};
use shapetrack::io::{Record, Rle};

fn fixture(name: &str) -> String {
    std::fs::read_to_string(format!(
        "{}/tests/data/formats/{name}",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap()
}

fn all_text_readers(s: &str) {
    let _ = parse_coco_video(s, "f");
    let _ = parse_coco_video_results(s, "f", &[]);
    let _ = parse_cvat(s, "f", None);
    let _ = parse_regions(s, "f");
    let _ = parse_anchor_values(s, "f");
}

/// Deletes, duplicates or replaces a byte range of a valid document.
fn mutate(doc: &str, at: usize, len: usize, what: u8, insert: &str) -> String {
    let b = doc.as_bytes();
    let at = at % b.len().max(1);
    let end = (at + len).min(b.len());
    let mut out: Vec<u8> = b[..at].to_vec();
    match what % 3 {
        0 => {}
        1 => out.extend_from_slice(&b[at..end]),
        _ => out.extend_from_slice(insert.as_bytes()),
    }
    out.extend_from_slice(&b[if what % 3 == 1 { at } else { end }..]);
    String::from_utf8_lossy(&out).into_owned()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, rng_seed: proptest::test_runner::RngSeed::Fixed(11), failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn random_strings_never_panic(s in "\\PC{0,300}") {
        all_text_readers(&s);
    }

    #[test]
    fn structured_noise_never_panics(s in "[\\[\\]{}<>/=\",:;.0-9a-z \\n&#-]{0,400}") {
        all_text_readers(&s);
    }

    #[test]
    fn mutated_coco_never_panics(at in 0usize..10_000, len in 0usize..40, what in 0u8..3, ins in "[\\[\\]{}\",:0-9a-z-]{0,12}") {
        let doc = mutate(&fixture("coco_video_pycocotools.json"), at, len, what, &ins);
        let _ = parse_coco_video(&doc, "m");
    }

    #[test]
    fn mutated_cvat_never_panics(at in 0usize..10_000, len in 0usize..40, what in 0u8..3, ins in "[<>/=\" 0-9a-z;,&]{0,12}") {
        let doc = mutate(&fixture("cvat_video_1_1.xml"), at, len, what, &ins);
        let _ = parse_cvat(&doc, "m", None);
    }

    #[test]
    fn mutated_vot_lines_never_panic(at in 0usize..200, len in 0usize..10, what in 0u8..3, ins in "[m0-9,.n a-]{0,10}") {
        let doc = mutate("1\n10.5,20,30,40\n1,2,3,4,5,6,7,8\nm2,3,3,2,1,4,1\nnan,nan,nan,nan\n", at, len, what, &ins);
        let _ = parse_regions(&doc, "m");
    }

    #[test]
    fn random_and_corrupted_pngs_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..200), at in 0usize..400, v in any::<u8>()) {
        for mode in [EightBit::Ids, EightBit::Binary { id: 3 }] {
            let _ = decode_png_masks(&bytes, 1, "r.png", mode);
        }
        let mut bitmap = vec![0u8; 6 * 4];
        bitmap[5] = 1;
        let mut r = Record::from_box(1, 9, Default::default());
        r.mask = Some(Rle::encode(6, 4, &bitmap).unwrap());
        let mut png = encode_png_masks(&[r], 6, 4).unwrap();
        let i = at % png.len();
        png[i] = v;
        let _ = decode_png_masks(&png, 1, "c.png", EightBit::Ids);
        png.truncate(i);
        let _ = decode_png_masks(&png, 1, "t.png", EightBit::Ids);
    }
}

/// Sizes that would make a reader allocate gigabytes (or loop for billions of frames) are
/// errors; degenerate regions do not panic the overlap code.
#[test]
fn hostile_sizes_are_errors() {
    assert!(parse_regions("m0,0,65536,65536,0\n", "h").is_err());
    let coco = "{\"videos\":[{\"id\":1,\"width\":65536,\"height\":65536,\"length\":1}]}";
    assert!(parse_coco_video(coco, "h").is_err());
    let cvat = "<annotations><meta><task><size>4000000000</size></task></meta></annotations>";
    assert!(parse_cvat(cvat, "h", None).is_err());
    let cvat = "<annotations><track id=\"1\" label=\"a\"><box frame=\"0\" xtl=\"0\" ytl=\"0\" xbr=\"1\" ybr=\"1\"/><box frame=\"4294967295\" xtl=\"0\" ytl=\"0\" xbr=\"1\" ybr=\"1\"/></track></annotations>";
    assert!(parse_cvat(cvat, "h", None).is_err());
    use shapetrack::eval::vot::{overlap, OverlapMethod};
    use shapetrack::io::vot::Region;
    let empty = Region::Polygon(vec![]);
    let tiny = Region::Polygon(vec![shapetrack::Point::new(f64::NAN, 1.0); 4]);
    let huge = Region::Rectangle(shapetrack::BBox::new(-1e11, -1e11, 2e11, 2e11));
    for m in [OverlapMethod::Exact, OverlapMethod::Toolkit] {
        for a in [&empty, &tiny, &huge] {
            for b in [&empty, &tiny, &huge] {
                let o = overlap(a, b, None, m);
                assert!((0.0..=1.0).contains(&o), "{a:?} {b:?} {o}");
            }
        }
    }
}
