//! Image files (frames, PNG masks) decoded only after their header passed the caps.
//!
//! A PNG of a few hundred kilobytes can declare 20000 × 20000 pixels; decoded naively it asks
//! for gigabytes before a single pixel is read (in wasm, a trap). Every image the readers and
//! the CLI take goes through here: the decoder reads the header, the size is checked against
//! [`super::limits`] (and against the frame's size when the image must match one), and only
//! then are the pixels decoded. The decoding itself is the `image` crate's.
//!
//! Two things the `image` crate does quietly are caught here. A JPEG cut short (a copy that
//! stopped midway) decodes without error, its missing rows grey: a JPEG must reach its
//! end-of-image marker ([`jpeg_complete`]). And a paletted PNG is expanded to the palette's
//! colours, while a mask written that way (DAVIS, VOT) means its palette *index*: 0 the
//! background, k object k, whatever colour the palette gives k (black, or the background's).
//! Masks are therefore read by [`read_mask_image`] / [`decode_mask_image`], which give a
//! paletted PNG's indices.

use super::limits::{image_size_ok, MAX_PIXELS, MAX_SIDE};
use super::IoError;
use image::{DynamicImage, ImageDecoder, ImageFormat, ImageReader};
use std::io::{BufRead, BufReader, Cursor, Read, Seek};
use std::path::Path;

fn err(file: &str, message: impl Into<String>) -> IoError {
    IoError::Image {
        file: file.to_string(),
        message: message.into(),
    }
}

/// A header's size `w × h` against the caps and, with `expect`, the frame's size: checked
/// before any pixel is decoded.
fn check_size(file: &str, w: u32, h: u32, expect: Option<(u32, u32)>) -> Result<(), IoError> {
    if !image_size_ok(u64::from(w), u64::from(h)) {
        return Err(err(
            file,
            format!(
                "the image says it is {w}x{h}: over the cap of {MAX_PIXELS} pixels (sides \
                 ≤ {MAX_SIDE}), refused before decoding"
            ),
        ));
    }
    if let Some((ew, eh)) = expect {
        if (w, h) != (ew, eh) {
            return Err(err(
                file,
                format!("the image is {w}x{h}, not the frame's {ew}x{eh}"),
            ));
        }
    }
    Ok(())
}

/// The header's size checked, then the pixels decoded.
fn decode_checked<R: BufRead + Seek>(
    reader: ImageReader<R>,
    file: &str,
    expect: Option<(u32, u32)>,
) -> Result<DynamicImage, IoError> {
    let decoder = reader
        .into_decoder()
        .map_err(|e| err(file, e.to_string()))?;
    let (w, h) = decoder.dimensions();
    check_size(file, w, h, expect)?;
    DynamicImage::from_decoder(decoder).map_err(|e| err(file, e.to_string()))
}

/// The error for a JPEG that ends before its end-of-image marker.
fn truncated(file: &str) -> IoError {
    err(
        file,
        "truncated JPEG: the data ends before its end-of-image marker (FF D9), so the decoder \
         would fill the missing rows grey",
    )
}

/// Whether a JPEG stream reaches its end-of-image marker (`FF D9`). The segments before a scan
/// are skipped by their lengths (an EXIF thumbnail's own `FF D9` lies inside one); a scan's
/// entropy-coded data is read to the next marker (`FF 00` is a stuffed byte, `FF D0`–`FF D7`
/// restart markers). Bytes after the marker are not read. A stream that does not start with
/// `FF D8` is left to the decoder (`true`).
pub fn jpeg_complete(bytes: impl Iterator<Item = u8>) -> bool {
    let mut b = bytes.peekable();
    if b.next() != Some(0xFF) || b.next() != Some(0xD8) {
        return true;
    }
    // The marker after an `FF` (fill `FF`s skipped).
    fn marker(b: &mut impl Iterator<Item = u8>) -> Option<u8> {
        loop {
            match b.next()? {
                0xFF => continue,
                m => return Some(m),
            }
        }
    }
    loop {
        // Find the next `FF`: in a scan, past its data; elsewhere past stray bytes.
        loop {
            match b.next() {
                None => return false,
                Some(0xFF) => break,
                Some(_) => {}
            }
        }
        let Some(m) = marker(&mut b) else {
            return false;
        };
        match m {
            0xD9 => return true,
            // A stuffed 0xFF or a restart marker inside a scan; no length either way.
            0x00 | 0xD0..=0xD7 | 0x01 => {}
            // A segment (a scan's header too, its data then read up to the next marker).
            _ => {
                let (Some(hi), Some(lo)) = (b.next(), b.next()) else {
                    return false;
                };
                let len = ((usize::from(hi) << 8) | usize::from(lo)).saturating_sub(2);
                if b.by_ref().take(len).count() < len {
                    return false;
                }
            }
        }
    }
}

/// Refuses a JPEG `file` whose `bytes` do not reach the end-of-image marker.
fn check_jpeg(
    format: Option<ImageFormat>,
    bytes: impl Iterator<Item = u8>,
    file: &str,
) -> Result<(), IoError> {
    if format == Some(ImageFormat::Jpeg) && !jpeg_complete(bytes) {
        return Err(truncated(file));
    }
    Ok(())
}

/// Reads an image file (format from its content), its size checked before decoding; with
/// `expect`, it must be exactly that size. A JPEG must be complete ([`jpeg_complete`]).
pub fn read_image(path: &Path, expect: Option<(u32, u32)>) -> Result<DynamicImage, IoError> {
    let file = path.display().to_string();
    let reader = ImageReader::open(path)
        .map_err(|e| err(&file, e.to_string()))?
        .with_guessed_format()
        .map_err(|e| err(&file, e.to_string()))?;
    if reader.format() == Some(ImageFormat::Jpeg) {
        // A second pass over the file (read from the page cache): the marker walk streams.
        let f = std::fs::File::open(path).map_err(|e| err(&file, e.to_string()))?;
        let mut failed = false;
        let bytes = BufReader::new(f).bytes().map_while(|r| {
            failed |= r.is_err();
            r.ok()
        });
        check_jpeg(Some(ImageFormat::Jpeg), bytes, &file)?;
        if failed {
            return Err(err(&file, "read error while checking the JPEG"));
        }
    }
    decode_checked(reader, &file, expect)
}

/// Decodes an image held in memory (`format`, or guessed from its content), its size checked
/// before decoding; `file` names it in errors.
pub fn decode_image(
    bytes: &[u8],
    format: Option<ImageFormat>,
    file: &str,
    expect: Option<(u32, u32)>,
) -> Result<DynamicImage, IoError> {
    let reader = match format {
        Some(f) => ImageReader::with_format(Cursor::new(bytes), f),
        None => ImageReader::new(Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| err(file, e.to_string()))?,
    };
    check_jpeg(reader.format(), bytes.iter().copied(), file)?;
    decode_checked(reader, file, expect)
}

/// A mask image's pixels as the file means them.
#[derive(Debug, Clone)]
pub enum MaskImage {
    /// A paletted PNG: each pixel's palette index (0 = background, k = object k), whatever
    /// colour the palette gives it.
    Indexed(image::GrayImage),
    /// Any other image, decoded as [`read_image`] does.
    Plain(DynamicImage),
}

impl MaskImage {
    /// Image width and height.
    pub fn dimensions(&self) -> (u32, u32) {
        match self {
            MaskImage::Indexed(i) => i.dimensions(),
            MaskImage::Plain(i) => (i.width(), i.height()),
        }
    }

    /// One flag per pixel (row-major): 1 where the mask holds an object. A paletted PNG's
    /// index ≠ 0; otherwise `plain`, given the image decoded (callers differ: any non-zero
    /// channel, or grey above half).
    pub fn object_bits(&self, plain: impl Fn(&DynamicImage) -> Vec<u8>) -> Vec<u8> {
        match self {
            MaskImage::Indexed(i) => i.as_raw().iter().map(|&v| u8::from(v != 0)).collect(),
            MaskImage::Plain(i) => plain(i),
        }
    }
}

/// A paletted PNG's indices, or `None` when `r` holds another kind of PNG (or no PNG: the
/// caller decodes it as an image and reports what is wrong). The size is checked against the
/// caps (and `expect`) before the pixels are decoded.
fn png_indices<R: BufRead + Seek>(
    r: R,
    file: &str,
    expect: Option<(u32, u32)>,
) -> Result<Option<image::GrayImage>, IoError> {
    let mut dec = png::Decoder::new_with_limits(
        r,
        png::Limits {
            bytes: (2 * MAX_PIXELS) as usize,
        },
    );
    // No expansion: the indices themselves, packed 1, 2, 4 or 8 bits a pixel.
    dec.set_transformations(png::Transformations::IDENTITY);
    let Ok(mut reader) = dec.read_info() else {
        return Ok(None);
    };
    let info = reader.info();
    if info.color_type != png::ColorType::Indexed {
        return Ok(None);
    }
    let (w, h, depth) = (info.width, info.height, info.bit_depth as usize);
    check_size(file, w, h, expect)?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| err(file, "image too large"))?;
    let mut buf = vec![0u8; size];
    let out = reader
        .next_frame(&mut buf)
        .map_err(|e| err(file, format!("not a readable PNG: {e}")))?;
    let mask = (1u16 << depth) - 1;
    let mut idx = Vec::with_capacity(w as usize * h as usize);
    for row in buf.chunks(out.line_size).take(h as usize) {
        for x in 0..w as usize {
            let bit = x * depth;
            let shift = 8 - depth - bit % 8;
            idx.push(((u16::from(row[bit / 8]) >> shift) & mask) as u8);
        }
    }
    Ok(image::GrayImage::from_raw(w, h, idx))
}

/// Reads a mask image: a paletted PNG by its indices, anything else as [`read_image`] does.
pub fn read_mask_image(path: &Path, expect: Option<(u32, u32)>) -> Result<MaskImage, IoError> {
    let file = path.display().to_string();
    let f = std::fs::File::open(path).map_err(|e| err(&file, e.to_string()))?;
    if let Some(i) = png_indices(BufReader::new(f), &file, expect)? {
        return Ok(MaskImage::Indexed(i));
    }
    read_image(path, expect).map(MaskImage::Plain)
}

/// [`read_mask_image`] for bytes held in memory (see [`decode_image`]).
pub fn decode_mask_image(
    bytes: &[u8],
    format: Option<ImageFormat>,
    file: &str,
    expect: Option<(u32, u32)>,
) -> Result<MaskImage, IoError> {
    if matches!(format, None | Some(ImageFormat::Png)) {
        if let Some(i) = png_indices(Cursor::new(bytes), file, expect)? {
            return Ok(MaskImage::Indexed(i));
        }
    }
    decode_image(bytes, format, file, expect).map(MaskImage::Plain)
}

#[cfg(test)]
#[path = "image_file_tests.rs"]
mod tests;
