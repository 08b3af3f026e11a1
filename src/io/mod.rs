//! File formats in and out: MOTChallenge txt, MOTS txt (COCO RLE), 16-bit PNG instance masks,
//! COCO-video / YouTube-VIS JSON, CVAT-for-video XML, VOT `groundtruth.txt`, Scalabel JSON
//! (BDD100K), Label Studio video JSON, YOLO-style txt with track ids.
//!
//! Every reader turns text into [`Record`]s (one object in one frame) and reports problems as an
//! [`IoError`] naming the file, the line (1-based), the column (1-based field or character) and
//! what was expected. Readers are strict except where MOTChallenge itself is lenient: trailing
//! fields, CRLF line ends, blank lines, comma or whitespace separators.

pub mod coco_video;
pub mod cvat;
pub mod image_file;
pub mod label_studio;
pub mod layout;
pub mod limits;
pub mod motchallenge;
pub mod png_masks;
pub mod rle;
pub mod scalabel;
pub mod sequence;
pub mod vot;
pub mod yolo;

use crate::frame::{BBox, Mask, TrackedShape};
pub use rle::{PackedRle, Rle, RleError};
use serde::{Deserialize, Serialize};
use serde_json::value::RawValue;
use std::collections::BTreeMap;
use thiserror::Error;

/// Errors reading or writing annotation and result files.
#[derive(Debug, Error)]
pub enum IoError {
    /// The file could not be read or written.
    #[error("{file}: {source}")]
    Io {
        /// Path of the file.
        file: String,
        /// Underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A value in a text file is malformed.
    #[error("{file}:{line}:{column}: expected {expected}, found {found:?}")]
    Parse {
        /// Path (or a name for in-memory text).
        file: String,
        /// 1-based line number.
        line: usize,
        /// 1-based column (field number for delimited files, character for others).
        column: usize,
        /// What the reader expected there.
        expected: String,
        /// The text found (possibly shortened).
        found: String,
    },
    /// An RLE mask string is malformed.
    #[error("{file}:{line}: bad RLE mask: {source}")]
    Rle {
        /// Path of the file.
        file: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong with it.
        #[source]
        source: RleError,
    },
    /// A JSON document is malformed or does not have the expected structure.
    #[error("{file}:{line}:{column}: {message}")]
    Json {
        /// Path of the file.
        file: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// An XML document is malformed or does not have the expected structure.
    #[error("{file}:{line}:{column}: {message}")]
    Xml {
        /// Path of the file.
        file: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// An image file could not be decoded or has the wrong pixel type.
    #[error("{file}: {message}")]
    Image {
        /// Path of the file.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// The data is well-formed but inconsistent (e.g. a duplicate id in one frame).
    #[error("{file}:{line}: {message}")]
    Invalid {
        /// Path of the file.
        file: String,
        /// 1-based line (0 when not tied to a line).
        line: usize,
        /// What is wrong.
        message: String,
    },
}

impl IoError {
    /// A parse error; `found` is shortened to keep messages readable.
    pub fn parse(
        file: &str,
        line: usize,
        column: usize,
        expected: impl Into<String>,
        found: &str,
    ) -> IoError {
        let found: String = if found.chars().count() > 40 {
            found.chars().take(40).chain("…".chars()).collect()
        } else {
            found.to_string()
        };
        IoError::Parse {
            file: file.to_string(),
            line,
            column,
            expected: expected.into(),
            found,
        }
    }
}

/// Reads a whole text file, naming the file in the error. A leading UTF-8 byte-order mark
/// is dropped: editors on Windows write one, and left in place it would be part of the first
/// field (a MOT frame number that fails to parse, a JSON file taken for text).
pub fn read_text(path: &std::path::Path) -> Result<String, IoError> {
    use std::io::Read as _;
    let io = |source| IoError::Io {
        file: path.display().to_string(),
        source,
    };
    // At most one byte past the cap is read (a device's length says nothing: /dev/zero's is 0).
    let mut text = String::new();
    std::fs::File::open(path)
        .map_err(io)?
        .take(limits::MAX_TEXT_BYTES + 1)
        .read_to_string(&mut text)
        .map_err(io)?;
    if text.len() as u64 > limits::MAX_TEXT_BYTES {
        return Err(IoError::Invalid {
            file: path.display().to_string(),
            line: 1,
            message: format!(
                "longer than {} MiB: not a text file this project reads",
                limits::MAX_TEXT_BYTES >> 20
            ),
        });
    }
    lone_carriage_returns(path, &text)?;
    if text.starts_with(BOM) {
        text.drain(..BOM.len_utf8());
    }
    Ok(text)
}

/// Refuses text whose lines end in a carriage return alone (classic Mac OS): read by lines
/// that end in `\n`, the whole file would be one line and every field past the first
/// record's silently ignored. `\r\n` (Windows) is fine.
pub fn lone_carriage_returns(path: &std::path::Path, text: &str) -> Result<(), IoError> {
    let bytes = text.as_bytes();
    match bytes
        .iter()
        .enumerate()
        .find(|&(i, &b)| b == b'\r' && bytes.get(i + 1) != Some(&b'\n'))
    {
        Some((i, _)) => Err(IoError::Invalid {
            file: path.display().to_string(),
            line: line_col(text, i).0,
            message: "a line ends in a carriage return alone (classic Mac line endings): \
                      save the file with LF or CRLF line endings"
                .into(),
        }),
        None => Ok(()),
    }
}

/// The UTF-8 byte-order mark (U+FEFF) some editors put at the start of a text file.
pub const BOM: char = '\u{feff}';

/// `line` without a leading byte-order mark: for readers that take a file line by line rather
/// than through [`read_text`] (its first line may start with one).
pub fn strip_bom(line: &str) -> &str {
    line.strip_prefix(BOM).unwrap_or(line)
}

/// The 1-based line and column (in characters) of byte `offset` of `text`, for error messages.
/// Offsets past the end (or inside a multi-byte character) are clamped to a valid position.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let mut end = offset.min(text.len());
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    let before = &text[..end];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    (line, before[line_start..].chars().count() + 1)
}

/// A JSON syntax error of `file` at serde's position, its message without serde's own
/// "at line … column …" (the error carries them).
pub(crate) fn json_err(file: &str, e: serde_json::Error) -> IoError {
    IoError::Json {
        file: file.to_string(),
        line: e.line().max(1),
        column: e.column().max(1),
        message: serde_message(&e),
    }
}

/// serde's message without its own "at line … column …" (the error carries the position).
pub(crate) fn serde_message(e: &serde_json::Error) -> String {
    let text = e.to_string();
    text.split(" at line ").next().unwrap_or("").to_string()
}

/// A JSON document being read, for error positions: raw values borrowed from `text` tell
/// where they are in it.
pub(crate) struct JsonCtx<'t> {
    pub(crate) file: &'t str,
    pub(crate) text: &'t str,
}

impl JsonCtx<'_> {
    /// An error at `raw`'s position.
    pub(crate) fn err_at(&self, raw: &RawValue, message: impl Into<String>) -> IoError {
        let offset = (raw.get().as_ptr() as usize).wrapping_sub(self.text.as_ptr() as usize);
        let (line, column) = line_col(self.text, offset);
        IoError::Json {
            file: self.file.to_string(),
            line,
            column,
            message: message.into(),
        }
    }

    /// `raw` as an object (an error naming `what` otherwise).
    pub(crate) fn object<'a>(
        &self,
        raw: &'a RawValue,
        what: &str,
    ) -> Result<BTreeMap<String, &'a RawValue>, IoError> {
        serde_json::from_str(raw.get())
            .map_err(|_| self.err_at(raw, format!("{what} is not an object")))
    }

    /// `raw` as a list (an error naming `what` otherwise).
    pub(crate) fn list<'a>(
        &self,
        raw: &'a RawValue,
        what: &str,
    ) -> Result<Vec<&'a RawValue>, IoError> {
        serde_json::from_str(raw.get())
            .map_err(|_| self.err_at(raw, format!("{what} is not a list")))
    }

    /// A finite number (JSON has no NaN, but `1e999` parses as infinity).
    pub(crate) fn number(&self, raw: &RawValue, what: &str) -> Result<f64, IoError> {
        serde_json::from_str::<f64>(raw.get())
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| self.err_at(raw, format!("{what} must be a finite number")))
    }
}

/// The image files (`.jpg`, `.jpeg`, `.png`) of a frame folder in natural order (`2.png`
/// before `10.png`; zero-padded names such as MOTChallenge's sort the same either way).
pub fn image_files(dir: &std::path::Path) -> Result<Vec<std::path::PathBuf>, IoError> {
    let rd = std::fs::read_dir(dir).map_err(|source| IoError::Io {
        file: dir.display().to_string(),
        source,
    })?;
    let mut files: Vec<std::path::PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| matches!(e.to_ascii_lowercase().as_str(), "jpg" | "jpeg" | "png"))
        })
        .collect();
    files.sort_by(|a, b| natural_cmp(&a.to_string_lossy(), &b.to_string_lossy()));
    Ok(files)
}

/// Reads an image file (PNG or JPEG) as RGB8; a file that cannot be read or decoded is an
/// error naming it. What the commands that take a frame folder read each frame with.
/// Its size is checked against the caps before it is decoded ([`image_file`]).
pub fn read_rgb(path: &std::path::Path) -> Result<image::RgbImage, IoError> {
    image_file::read_image(path, None).map(|i| i.to_rgb8())
}

/// Compares names as people number files: runs of digits by value, the rest by character.
pub fn natural_cmp(a: &str, b: &str) -> std::cmp::Ordering {
    use std::cmp::Ordering;
    fn chunks(s: &str) -> Vec<(bool, &str)> {
        let mut out = Vec::new();
        let mut start = 0;
        let mut digit = None;
        for (i, c) in s.char_indices() {
            let d = c.is_ascii_digit();
            if digit.is_some_and(|p| p != d) {
                out.push((digit.unwrap_or(false), &s[start..i]));
                start = i;
            }
            digit = Some(d);
        }
        if start < s.len() {
            out.push((digit.unwrap_or(false), &s[start..]));
        }
        out
    }
    let (ca, cb) = (chunks(a), chunks(b));
    for ((da, x), (db, y)) in ca.iter().zip(cb.iter()) {
        let o = if *da && *db {
            let (tx, ty) = (x.trim_start_matches('0'), y.trim_start_matches('0'));
            tx.len()
                .cmp(&ty.len())
                .then_with(|| tx.cmp(ty))
                .then_with(|| x.len().cmp(&y.len()))
        } else {
            x.cmp(y)
        };
        if o != Ordering::Equal {
            return o;
        }
    }
    ca.len().cmp(&cb.len())
}

/// Writes a whole text file, naming the file in the error.
///
/// The text goes to a temporary file beside `path` that is renamed over it once complete, so
/// a failed write (disk full, a killed process) leaves the old file as it was.
pub fn write_text(path: &std::path::Path, text: &str) -> Result<(), IoError> {
    use std::io::Write as _;
    let mut f = AtomicFile::create(path)?;
    f.write_all(text.as_bytes()).map_err(|source| IoError::Io {
        file: path.display().to_string(),
        source,
    })?;
    f.commit()
}

/// A file written in full or not at all: writes go to a temporary file beside the target
/// (same folder, so the rename stays on one file system), [`AtomicFile::commit`] renames it
/// into place, and dropping it uncommitted deletes the temporary file. An existing file at the
/// target keeps its contents until the commit.
#[derive(Debug)]
pub struct AtomicFile {
    target: std::path::PathBuf,
    temp: std::path::PathBuf,
    out: Option<std::io::BufWriter<std::fs::File>>,
}

impl AtomicFile {
    /// Opens a temporary file for `target`.
    pub fn create(target: &std::path::Path) -> Result<Self, IoError> {
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .ok_or_else(|| IoError::Invalid {
                file: target.display().to_string(),
                line: 0,
                message: "not a file name".to_string(),
            })?;
        // Unique per process and per call: two writers never share a temporary file.
        static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let k = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        #[cfg(not(target_arch = "wasm32"))]
        let pid = std::process::id();
        #[cfg(target_arch = "wasm32")]
        let pid = 0;
        let temp = target.with_file_name(format!(".{name}.{pid}.{k}.partial"));
        let f = std::fs::File::create(&temp).map_err(|source| IoError::Io {
            file: temp.display().to_string(),
            source,
        })?;
        Ok(Self {
            target: target.to_path_buf(),
            temp,
            out: Some(std::io::BufWriter::new(f)),
        })
    }

    /// Flushes, syncs and renames the temporary file over the target.
    pub fn commit(mut self) -> Result<(), IoError> {
        let err = |source| IoError::Io {
            file: self.target.display().to_string(),
            source,
        };
        let Some(out) = self.out.take() else {
            return Ok(());
        };
        {
            // Closed before the rename (some systems refuse to rename an open file).
            let f = out.into_inner().map_err(|e| err(e.into_error()))?;
            f.sync_all().map_err(err)?;
        }
        std::fs::rename(&self.temp, &self.target).map_err(err)
    }
}

impl std::io::Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self.out.as_mut() {
            Some(o) => o.write(buf),
            None => Err(std::io::Error::other("file already committed")),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        match self.out.as_mut() {
            Some(o) => o.flush(),
            None => Ok(()),
        }
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.out.take().is_some() {
            // Not committed: the target keeps its old contents; the partial file goes.
            let _ = std::fs::remove_file(&self.temp);
        }
    }
}

/// Per-record flags that only some formats can express.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct RecordFlags {
    /// Filled in by interpolation (offline gap filling, or a CVAT non-keyframe).
    pub interpolated: bool,
    /// Marked occluded by an annotator.
    pub occluded: bool,
}

/// One object in one frame, the common currency of every format.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Record {
    /// 1-based frame number.
    pub frame: u32,
    /// Track id (-1 for unlinked detections).
    pub id: i64,
    /// Bounding box.
    pub bbox: BBox,
    /// Confidence (results, detections) or the "consider" flag (MOTChallenge gt: 0 = ignore).
    pub score: f64,
    /// Class label (MOTChallenge gt column 8, MOTS class; -1 when absent).
    pub class: i32,
    /// Visibility ratio (MOTChallenge gt column 9; -1 when absent).
    pub visibility: f64,
    /// Instance mask, for mask formats.
    pub mask: Option<Rle>,
    /// Format-specific flags.
    pub flags: RecordFlags,
}

impl Record {
    /// A box record with default score 1, no class, no visibility, no mask.
    pub fn from_box(frame: u32, id: i64, bbox: BBox) -> Record {
        Record {
            frame,
            id,
            bbox,
            score: 1.0,
            class: -1,
            visibility: -1.0,
            mask: None,
            flags: RecordFlags::default(),
        }
    }

    /// The record of a tracked shape; `img` (width, height) is needed to encode a mask.
    pub fn from_tracked(s: &TrackedShape, img: Option<(u32, u32)>) -> Record {
        let mask = match (&s.mask, img) {
            (Some(m), Some((w, h))) => Some(Rle::from_mask(m, w, h)),
            _ => None,
        };
        Record {
            frame: s.frame,
            id: s.id as i64,
            bbox: s.bbox,
            score: s.score,
            class: s.class,
            visibility: -1.0,
            mask,
            flags: RecordFlags {
                interpolated: s.interpolated,
                occluded: false,
            },
        }
    }

    /// The record's mask as a bitmap, when it has one.
    pub fn mask_bitmap(&self) -> Option<Mask> {
        self.mask.as_ref().map(Rle::to_mask)
    }
}

/// Groups records by frame: `out[f]` holds the records of frame `f` (index 0 unused), for
/// frames `1..=num_frames` (records beyond are dropped by the caller's choice of `num_frames`).
pub fn by_frame(records: &[Record], num_frames: u32) -> Vec<Vec<&Record>> {
    let mut out = vec![Vec::new(); num_frames as usize + 1];
    for r in records {
        if r.frame >= 1 && r.frame <= num_frames {
            out[r.frame as usize].push(r);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_files_sort_as_people_number_them() {
        let mut names = vec![
            "12.png",
            "2.png",
            "10.png",
            "1.png",
            "frame_002.jpg",
            "frame_10.jpg",
        ];
        names.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(
            names,
            [
                "1.png",
                "2.png",
                "10.png",
                "12.png",
                "frame_002.jpg",
                "frame_10.jpg"
            ]
        );
        let mut padded = vec!["000010.jpg", "000002.jpg", "000001.jpg"];
        padded.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(padded, ["000001.jpg", "000002.jpg", "000010.jpg"]);
    }
}
