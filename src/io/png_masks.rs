//! Instance masks as one PNG per frame: 16-bit greyscale where the pixel value is the object id
//! (0 = background), as MOTS/KITTI-style instance maps; and 8-bit greyscale either as DAVIS
//! 2016 binary masks (0 / non-zero, one object whose id the caller gives) or as 8-bit id maps.
//! A paletted PNG (DAVIS 2017, VOT) is read by its palette indices, as an 8-bit map.
//!
//! Reading gives one [`Record`] per id present in the frame, with its mask ([`Rle`]) and tight
//! box. Writing paints the records of one frame into a 16-bit map; the format cannot express
//! overlap, so records are painted in ascending id order and a pixel keeps the first id that
//! claimed it. Records without a mask are painted as their box (pixel centres inside it).

use super::image_file::{decode_mask_image, MaskImage};
use super::{IoError, Record, RecordFlags, Rle};
use crate::frame::Mask;
use image::{DynamicImage, ImageBuffer, ImageFormat, Luma};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// How 8-bit greyscale PNGs are read (16-bit PNGs are always id maps).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EightBit {
    /// A binary mask (DAVIS 2016: 0 background, 255 object): every non-zero pixel belongs to
    /// the one object `id`.
    Binary {
        /// Id given to the object.
        id: i64,
    },
    /// Pixel values are object ids (0 = background).
    Ids,
}

impl Default for EightBit {
    fn default() -> Self {
        EightBit::Binary { id: 1 }
    }
}

/// One decoded instance map: its size and the records it holds (sorted by id).
#[derive(Debug, Clone, PartialEq)]
pub struct PngMaskFrame {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// One record per object present.
    pub records: Vec<Record>,
}

fn image_err(file: &str, message: impl Into<String>) -> IoError {
    IoError::Image {
        file: file.to_string(),
        message: message.into(),
    }
}

/// Splits a row-major id map into one column-major RLE per non-zero id, in one pass.
fn rles_from_ids<T: Copy + Into<u32>>(width: u32, height: u32, ids: &[T]) -> BTreeMap<u32, Rle> {
    // Per id: the runs so far and the end (column-major position) of its last foreground run.
    let mut runs: BTreeMap<u32, (Vec<u32>, u64)> = BTreeMap::new();
    let (w, h) = (width as usize, height as usize);
    for x in 0..w {
        for y in 0..h {
            let id: u32 = ids[y * w + x].into();
            if id == 0 {
                continue;
            }
            let p = (x * h + y) as u64;
            let (counts, end) = runs.entry(id).or_insert_with(|| (Vec::new(), 0));
            if !counts.is_empty() && *end == p {
                if let Some(last) = counts.last_mut() {
                    *last += 1;
                }
            } else {
                counts.push((p - *end) as u32);
                counts.push(1);
            }
            *end = p + 1;
        }
    }
    let total = width as u64 * height as u64;
    runs.into_iter()
        .map(|(id, (mut counts, end))| {
            if end < total {
                counts.push((total - end) as u32);
            }
            (
                id,
                Rle {
                    height,
                    width,
                    counts,
                },
            )
        })
        .collect()
}

fn record_of(frame: u32, id: i64, rle: Rle) -> Record {
    Record {
        frame,
        id,
        bbox: rle.bbox(),
        score: 1.0,
        class: -1,
        visibility: -1.0,
        mask: Some(rle),
        flags: RecordFlags::default(),
    }
}

/// Decodes one PNG instance map held in memory. `frame` is the records' frame number and
/// `file` names the image in errors. Only 8- and 16-bit greyscale PNGs and paletted PNGs (read
/// by index, as an 8-bit map) are accepted.
pub fn decode_png_masks(
    bytes: &[u8],
    frame: u32,
    file: &str,
    eight_bit: EightBit,
) -> Result<PngMaskFrame, IoError> {
    let img =
        decode_mask_image(bytes, Some(ImageFormat::Png), file, None).map_err(|e| match e {
            IoError::Image { message, .. } => {
                image_err(file, format!("not a readable PNG: {message}"))
            }
            other => other,
        })?;
    let (width, height) = img.dimensions();
    // A paletted PNG's indices are read as an 8-bit map: DAVIS and VOT write index k for
    // object k, whatever colour their palette gives it.
    let eight = matches!(
        img,
        MaskImage::Indexed(_) | MaskImage::Plain(DynamicImage::ImageLuma8(_))
    );
    let rles = match &img {
        MaskImage::Plain(DynamicImage::ImageLuma16(buf)) => {
            rles_from_ids(width, height, buf.as_raw())
        }
        MaskImage::Indexed(buf) | MaskImage::Plain(DynamicImage::ImageLuma8(buf)) => {
            match eight_bit {
                EightBit::Ids => rles_from_ids(width, height, buf.as_raw()),
                EightBit::Binary { .. } => {
                    let bin: Vec<u8> = buf.as_raw().iter().map(|&v| (v != 0) as u8).collect();
                    rles_from_ids(width, height, &bin)
                }
            }
        }
        MaskImage::Plain(other) => {
            return Err(image_err(
                file,
                format!(
                    "expected an 8- or 16-bit greyscale or a paletted PNG, found {:?}",
                    other.color()
                ),
            ))
        }
    };
    let records = rles
        .into_iter()
        .map(|(id, rle)| {
            let id = match (eight, eight_bit) {
                (true, EightBit::Binary { id }) => id,
                _ => id as i64,
            };
            record_of(frame, id, rle)
        })
        .collect();
    Ok(PngMaskFrame {
        width,
        height,
        records,
    })
}

/// Reads one PNG instance map from disk (see [`decode_png_masks`]).
pub fn read_png_masks(
    path: &Path,
    frame: u32,
    eight_bit: EightBit,
) -> Result<PngMaskFrame, IoError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| IoError::Io {
        file: file.clone(),
        source,
    })?;
    decode_png_masks(&bytes, frame, &file, eight_bit)
}

/// A folder of PNG instance maps read as a sequence.
#[derive(Debug, Clone, PartialEq)]
pub struct PngMaskSequence {
    /// Image width (the same in every frame).
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Number of frames (PNG files).
    pub num_frames: u32,
    /// All records, sorted by frame then id.
    pub records: Vec<Record>,
}

/// The `*.png` files of a folder in name order, numbers by value (`2.png` before `10.png`,
/// as with frame folders: see [`super::natural_cmp`]).
pub fn png_files(dir: &Path) -> Result<Vec<PathBuf>, IoError> {
    let io = |source| IoError::Io {
        file: dir.display().to_string(),
        source,
    };
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(io)? {
        let p = entry.map_err(io)?.path();
        if p.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
            files.push(p);
        }
    }
    files.sort_by(|a, b| super::natural_cmp(&a.to_string_lossy(), &b.to_string_lossy()));
    Ok(files)
}

/// Reads every `*.png` of `dir` in name order as frames 1, 2, …; all must have the same size.
pub fn read_png_mask_dir(dir: &Path, eight_bit: EightBit) -> Result<PngMaskSequence, IoError> {
    let files = png_files(dir)?;
    let mut size: Option<(u32, u32, PathBuf)> = None;
    let mut records = Vec::new();
    for (i, path) in files.iter().enumerate() {
        let f = read_png_masks(path, i as u32 + 1, eight_bit)?;
        match &size {
            Some((w, h, first)) if (*w, *h) != (f.width, f.height) => {
                return Err(IoError::Invalid {
                    file: path.display().to_string(),
                    line: 0,
                    message: format!(
                        "image is {}x{} but {} is {w}x{h}",
                        f.width,
                        f.height,
                        first.display()
                    ),
                });
            }
            Some(_) => {}
            None => size = Some((f.width, f.height, path.clone())),
        }
        records.extend(f.records);
    }
    let (width, height) = size.map_or((0, 0), |(w, h, _)| (w, h));
    Ok(PngMaskSequence {
        width,
        height,
        num_frames: files.len() as u32,
        records,
    })
}

/// Paints the records of one frame into a 16-bit id map of `width × height` and encodes it as
/// PNG. Ids must be in `1..=65535`; masks must have the image's size.
pub fn encode_png_masks(records: &[Record], width: u32, height: u32) -> Result<Vec<u8>, IoError> {
    let refs: Vec<&Record> = records.iter().collect();
    encode_refs(&refs, width, height)
}

fn encode_refs(records: &[&Record], width: u32, height: u32) -> Result<Vec<u8>, IoError> {
    let out_name = "<png mask output>";
    if width == 0 || height == 0 {
        return Err(image_err(
            out_name,
            format!("image size {width}x{height} is empty"),
        ));
    }
    let mut ids = vec![0u16; width as usize * height as usize];
    let mut rs: Vec<&Record> = records.to_vec();
    rs.sort_by_key(|r| r.id);
    for r in rs {
        let id = u16::try_from(r.id)
            .ok()
            .filter(|&v| v != 0)
            .ok_or_else(|| {
                image_err(
                    out_name,
                    format!("id {} does not fit a 16-bit id map (1..=65535)", r.id),
                )
            })?;
        let mask = match &r.mask {
            Some(m) => {
                if (m.width, m.height) != (width, height) {
                    return Err(image_err(
                        out_name,
                        format!(
                            "mask of id {} is {}x{} but the image is {width}x{height}",
                            r.id, m.width, m.height
                        ),
                    ));
                }
                m.decode()
            }
            None => Mask::from_bbox(&r.bbox).to_full(width, height),
        };
        for (dst, &m) in ids.iter_mut().zip(&mask) {
            if m != 0 && *dst == 0 {
                *dst = id;
            }
        }
    }
    let buf: ImageBuffer<Luma<u16>, Vec<u16>> = ImageBuffer::from_raw(width, height, ids)
        .ok_or_else(|| image_err(out_name, "id map has the wrong length"))?;
    let mut out = std::io::Cursor::new(Vec::new());
    DynamicImage::ImageLuma16(buf)
        .write_to(&mut out, ImageFormat::Png)
        .map_err(|e| image_err(out_name, e.to_string()))?;
    Ok(out.into_inner())
}

/// Writes frames `1..=num_frames` as `dir/<frame - 1, 5 digits>.png` (DAVIS naming: 00000.png
/// is frame 1), empty frames included. Records outside that range are an error.
pub fn write_png_mask_dir(
    dir: &Path,
    records: &[Record],
    width: u32,
    height: u32,
    num_frames: u32,
) -> Result<(), IoError> {
    if let Some(r) = records.iter().find(|r| r.frame < 1 || r.frame > num_frames) {
        return Err(IoError::Invalid {
            file: dir.display().to_string(),
            line: 0,
            message: format!(
                "record of id {} is in frame {} outside 1..={num_frames}",
                r.id, r.frame
            ),
        });
    }
    std::fs::create_dir_all(dir).map_err(|source| IoError::Io {
        file: dir.display().to_string(),
        source,
    })?;
    let frames = super::by_frame(records, num_frames);
    for (f, recs) in frames.iter().enumerate().skip(1) {
        let png = encode_refs(recs, width, height)?;
        let path = dir.join(format!("{:05}.png", f - 1));
        std::fs::write(&path, png).map_err(|source| IoError::Io {
            file: path.display().to_string(),
            source,
        })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_pass_rles_equal_per_id_encoding() {
        let (w, h) = (7u32, 5u32);
        let ids: Vec<u16> = (0..35).map(|i| ((i * 7 + 3) % 4) as u16).collect();
        let rles = rles_from_ids(w, h, &ids);
        for id in 1..4u16 {
            let bin: Vec<u8> = ids.iter().map(|&v| (v == id) as u8).collect();
            assert_eq!(
                rles[&(id as u32)],
                Rle::encode(w, h, &bin).unwrap(),
                "id {id}"
            );
        }
        assert!(!rles.contains_key(&0));
    }

    #[test]
    fn png_files_are_in_frame_order() {
        let dir = std::env::temp_dir().join(format!("shapetrack-png-order-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for n in ["1.png", "10.png", "12.png", "2.png", "notes.txt"] {
            std::fs::write(dir.join(n), b"").unwrap();
        }
        let names: Vec<String> = png_files(&dir)
            .unwrap()
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(names, ["1.png", "2.png", "10.png", "12.png"]);
    }
}
