//! 16-bit PNG instance maps and DAVIS 8-bit binary masks.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::io::png_masks::{
    decode_png_masks, encode_png_masks, read_png_mask_dir, read_png_masks, write_png_mask_dir,
    EightBit,
};
use shapetrack::io::{IoError, Record, Rle};
use shapetrack::BBox;
use std::path::PathBuf;

fn davis_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/davis-car-shadow/DAVIS/Annotations/480p/car-shadow")
}

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("shapetrack-formats-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn rect_record(frame: u32, id: i64, w: u32, h: u32, rect: (u32, u32, u32, u32)) -> Record {
    let (x0, y0, rw, rh) = rect;
    let mut bitmap = vec![0u8; (w * h) as usize];
    for y in y0..y0 + rh {
        for x in x0..x0 + rw {
            bitmap[(y * w + x) as usize] = 1;
        }
    }
    let rle = Rle::encode(w, h, &bitmap).unwrap();
    let mut r = Record::from_box(frame, id, rle.to_mask().bbox());
    r.mask = Some(rle);
    r
}

/// The DAVIS car-shadow annotations (8-bit, 0/255) read as one object per frame whose mask is
/// exactly the non-zero pixels, and the 40 frames share one size.
#[test]
fn davis_binary_masks() {
    let seq = read_png_mask_dir(&davis_dir(), EightBit::Binary { id: 7 }).unwrap();
    assert_eq!((seq.width, seq.height, seq.num_frames), (854, 480, 40));
    assert_eq!(seq.records.len(), 40);
    // Check frame 1 against a direct pixel count.
    let img = image::open(davis_dir().join("00000.png"))
        .unwrap()
        .to_luma8();
    let on: Vec<(u32, u32)> = img
        .enumerate_pixels()
        .filter(|p| p.2 .0[0] != 0)
        .map(|p| (p.0, p.1))
        .collect();
    let r = &seq.records[0];
    assert_eq!((r.frame, r.id), (1, 7));
    let m = r.mask.as_ref().unwrap();
    assert_eq!(m.area(), on.len() as u64);
    let x0 = on.iter().map(|p| p.0).min().unwrap() as f64;
    let x1 = on.iter().map(|p| p.0).max().unwrap() as f64;
    let y0 = on.iter().map(|p| p.1).min().unwrap() as f64;
    let y1 = on.iter().map(|p| p.1).max().unwrap() as f64;
    assert_eq!(r.bbox, BBox::new(x0, y0, x1 - x0 + 1.0, y1 - y0 + 1.0));
    // Written back as a 16-bit id map it reads back identically.
    let png = encode_png_masks(&seq.records[..1], 854, 480).unwrap();
    let back = decode_png_masks(&png, 1, "mem", EightBit::Ids).unwrap();
    assert_eq!(back.records, seq.records[..1]);
}

/// Several ids, an empty frame and a box-only record survive write → read through a folder.
#[test]
fn roundtrip_folder_with_empty_frame() {
    let (w, h) = (13u32, 9u32);
    let mut recs = vec![
        rect_record(1, 1, w, h, (0, 0, 3, 2)),
        rect_record(1, 300, w, h, (5, 4, 4, 5)),
        rect_record(3, 65535, w, h, (12, 8, 1, 1)),
    ];
    let dir = tmp_dir("rt");
    write_png_mask_dir(&dir, &recs, w, h, 3).unwrap();
    let seq = read_png_mask_dir(&dir, EightBit::Ids).unwrap();
    assert_eq!((seq.width, seq.height, seq.num_frames), (w, h, 3));
    recs.sort_by_key(|r| (r.frame, r.id));
    assert_eq!(seq.records, recs);
    // A box record is painted as the pixels whose centres are inside it.
    let boxed = Record::from_box(1, 2, BBox::new(1.0, 1.0, 2.0, 3.0));
    let png = encode_png_masks(&[boxed], w, h).unwrap();
    let f = decode_png_masks(&png, 1, "mem", EightBit::Ids).unwrap();
    assert_eq!(f.records[0].bbox, BBox::new(1.0, 1.0, 2.0, 3.0));
    assert_eq!(f.records[0].mask.as_ref().unwrap().area(), 6);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn overlapping_masks_keep_the_lower_id() {
    let (w, h) = (6u32, 6u32);
    let a = rect_record(1, 2, w, h, (0, 0, 4, 4));
    let b = rect_record(1, 1, w, h, (2, 2, 4, 4));
    let png = encode_png_masks(&[a, b.clone()], w, h).unwrap();
    let f = decode_png_masks(&png, 1, "mem", EightBit::Ids).unwrap();
    assert_eq!(f.records[0], b);
    assert_eq!(f.records[1].mask.as_ref().unwrap().area(), 16 - 4);
}

#[test]
fn wrong_inputs_are_typed_errors() {
    // Not a PNG.
    assert!(matches!(
        decode_png_masks(b"not a png", 1, "x.png", EightBit::Ids),
        Err(IoError::Image { ref file, .. }) if file == "x.png"
    ));
    // A colour PNG.
    let rgb = image::RgbImage::new(3, 2);
    let mut bytes = std::io::Cursor::new(Vec::new());
    rgb.write_to(&mut bytes, image::ImageFormat::Png).unwrap();
    match decode_png_masks(bytes.get_ref(), 1, "rgb.png", EightBit::Ids) {
        Err(IoError::Image { message, .. }) => assert!(message.contains("greyscale"), "{message}"),
        other => panic!("{other:?}"),
    }
    // Truncated PNG.
    let png = encode_png_masks(&[rect_record(1, 1, 5, 5, (1, 1, 2, 2))], 5, 5).unwrap();
    assert!(decode_png_masks(&png[..png.len() / 2], 1, "t.png", EightBit::Ids).is_err());
    // Ids that do not fit, masks of the wrong size.
    assert!(encode_png_masks(&[rect_record(1, 70000, 5, 5, (1, 1, 2, 2))], 5, 5).is_err());
    assert!(encode_png_masks(&[rect_record(1, 0, 5, 5, (1, 1, 2, 2))], 5, 5).is_err());
    assert!(encode_png_masks(&[rect_record(1, 1, 5, 5, (1, 1, 2, 2))], 6, 5).is_err());
    // Frames of different sizes in one folder.
    let dir = tmp_dir("sizes");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("00000.png"), encode_png_masks(&[], 5, 5).unwrap()).unwrap();
    std::fs::write(dir.join("00001.png"), encode_png_masks(&[], 6, 5).unwrap()).unwrap();
    match read_png_mask_dir(&dir, EightBit::Ids) {
        Err(IoError::Invalid { file, .. }) => assert!(file.ends_with("00001.png")),
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        read_png_masks(&dir.join("missing.png"), 1, EightBit::Ids),
        Err(IoError::Io { .. })
    ));
    let _ = std::fs::remove_dir_all(&dir);
}
