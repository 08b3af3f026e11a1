//! Image files (frames, PNG masks) decoded only after their header passed the caps.
//!
//! A PNG of a few hundred kilobytes can declare 20000 × 20000 pixels; decoded naively it asks
//! for gigabytes before a single pixel is read (in wasm, a trap). Every image the readers and
//! the CLI take goes through here: the decoder reads the header, the size is checked against
//! [`super::limits`] (and against the frame's size when the image must match one), and only
//! then are the pixels decoded. The decoding itself is the `image` crate's.

use super::limits::{image_size_ok, MAX_PIXELS, MAX_SIDE};
use super::IoError;
use image::{DynamicImage, ImageDecoder, ImageFormat, ImageReader};
use std::io::{BufRead, Cursor, Seek};
use std::path::Path;

fn err(file: &str, message: impl Into<String>) -> IoError {
    IoError::Image {
        file: file.to_string(),
        message: message.into(),
    }
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
    DynamicImage::from_decoder(decoder).map_err(|e| err(file, e.to_string()))
}

/// Reads an image file (format from its content), its size checked before decoding; with
/// `expect`, it must be exactly that size.
pub fn read_image(path: &Path, expect: Option<(u32, u32)>) -> Result<DynamicImage, IoError> {
    let file = path.display().to_string();
    let reader = ImageReader::open(path)
        .map_err(|e| err(&file, e.to_string()))?
        .with_guessed_format()
        .map_err(|e| err(&file, e.to_string()))?;
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
    decode_checked(reader, file, expect)
}

#[cfg(test)]
#[path = "image_file_tests.rs"]
mod tests;
