use super::*;

/// CRC-32 (ISO-HDLC), as PNG chunks carry it.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xffff_ffffu32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xedb8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
    out.extend_from_slice(&(data.len() as u32).to_be_bytes());
    let mut body = kind.to_vec();
    body.extend_from_slice(data);
    out.extend_from_slice(&body);
    out.extend_from_slice(&crc32(&body).to_be_bytes());
}

/// A PNG whose header says `w × h` (8-bit grey) and whose data is a few bytes: what a bomb
/// looks like to a reader that trusts the header.
fn png_claiming(w: u32, h: u32) -> Vec<u8> {
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&w.to_be_bytes());
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[8, 0, 0, 0, 0]);
    chunk(&mut out, b"IHDR", &ihdr);
    // zlib: an empty stored block, far too little for the rows it claims.
    chunk(
        &mut out,
        b"IDAT",
        &[0x78, 0x01, 0x01, 0x00, 0x00, 0xff, 0xff, 0, 0, 0, 1],
    );
    chunk(&mut out, b"IEND", &[]);
    out
}

fn small_png(w: u32, h: u32) -> Vec<u8> {
    let img = image::GrayImage::from_fn(w, h, |x, y| image::Luma([((x + y) % 2 * 255) as u8]));
    let mut bytes = Vec::new();
    img.write_to(&mut Cursor::new(&mut bytes), ImageFormat::Png)
        .unwrap();
    bytes
}

#[test]
fn a_header_over_the_cap_is_refused_before_any_pixel_is_decoded() {
    let bomb = png_claiming(20_000, 20_000);
    assert!(bomb.len() < 100, "a few bytes claim 400 M pixels");
    let e = decode_image(&bomb, Some(ImageFormat::Png), "bomb.png", None).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("20000x20000") && msg.contains("refused before decoding"),
        "{msg}"
    );
    // The same from a file, the format guessed from the content.
    let path = std::env::temp_dir().join(format!("shapetrack-bomb-{}.png", std::process::id()));
    std::fs::write(&path, &bomb).unwrap();
    let msg = read_image(&path, None).unwrap_err().to_string();
    std::fs::remove_file(&path).unwrap();
    assert!(msg.contains("refused before decoding"), "{msg}");
    // One side over the cap is enough.
    let msg = decode_image(&png_claiming(70_000, 1), None, "wide.png", None)
        .unwrap_err()
        .to_string();
    assert!(msg.contains("70000x1"), "{msg}");
}

#[test]
fn an_image_of_another_size_than_its_frame_is_refused_and_a_good_one_decodes() {
    let png = small_png(4, 3);
    let e = decode_image(&png, None, "m.png", Some((5, 3))).unwrap_err();
    assert!(e.to_string().contains("4x3, not the frame's 5x3"), "{e}");
    let img = decode_image(&png, Some(ImageFormat::Png), "m.png", Some((4, 3))).unwrap();
    assert_eq!((img.width(), img.height()), (4, 3));
    assert_eq!(img.to_luma8().as_raw()[1], 255);
}
