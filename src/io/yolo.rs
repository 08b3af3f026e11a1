//! YOLO-style txt with track ids: what Ultralytics' `yolo track … save_txt=True` writes, and
//! the single-file form this crate uses to keep a whole sequence in one file.
//!
//! YOLO keeps one txt per image, so a sequence is a folder of files and the frame lives only in
//! the file name. Ultralytics' tracking output has one line per object,
//! `class cx cy w h [conf] track_id` (`conf` with `save_conf=True`; `track_id` −1 for an
//! unlinked box), with the centre and size normalised by the image width and height. Two
//! forms are read and written:
//!
//! - **per-frame** ([`parse_yolo_frame`], [`write_yolo_frames`]): one file's lines exactly as
//!   Ultralytics writes them; the caller supplies the frame number (from the file name), since
//!   the text does not hold it;
//! - **single-file** ([`parse_yolo`], [`write_yolo`]): every line prefixed with its 1-based
//!   frame, `frame class cx cy w h [conf] track_id`, so one file carries the sequence (what the
//!   app imports and exports). Stripping the first field gives the per-frame line back.
//!
//! Both readers accept lines with and without `conf` (without: score 1), and a line without a
//! track id (`class cx cy w h`, plain YOLO detection labels) as id −1. The writers always write
//! `conf`, with enough digits to read back the same value. Fields are separated by whitespace;
//! blank lines and CRLF line ends are accepted.
//!
//! **Normalised coordinates** make the image size part of the format: readers take it to turn
//! fractions back into pixels and writers to turn pixels into fractions, and both refuse to
//! work without a valid size (`(0, 0)` is an error, not a silent identity). Boxes outside the
//! image (fractions beyond `[0, 1]`) are kept, as a tracker's predictions may leave the frame.
//!
//! **Classes** are YOLO's 0-based indices. YOLO has no "no class": records of class −1 are
//! written as class 0.
//!
//! **Interpolated frames cannot be flagged**: a YOLO line has no field for it, and adding one
//! would break every YOLO tool that reads the file. Filled frames are written as ordinary
//! lines and read back with `flags.interpolated = false`; keep a CVAT, Scalabel or MOT copy
//! when the flag matters.
//!
//! **Errors** are [`IoError::Parse`] with the line and field (1-based) of the bad value:
//! a wrong field count, a non-integer frame / class / id, a non-finite number, a negative
//! width or height, a frame outside `1..=`[`MAX_FRAME`], a track id twice in one frame;
//! a missing or absurd image size is [`IoError::Invalid`].

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;

use super::limits::{id_ok, image_size_ok, ID_EXPECTED, MAX_FRAME, MAX_RECORDS};
use super::{IoError, Record};
use crate::frame::BBox;

fn check_size(file: &str, size: (u32, u32)) -> Result<(f64, f64), IoError> {
    if image_size_ok(size.0 as u64, size.1 as u64) {
        Ok((size.0 as f64, size.1 as f64))
    } else {
        Err(IoError::Invalid {
            file: file.to_string(),
            line: 0,
            message: format!(
                "YOLO coordinates are fractions of the image size: a valid image width and \
                 height are needed, got {} × {}",
                size.0, size.1
            ),
        })
    }
}

/// Reads the object fields of one line (everything after the frame in the single-file form).
/// `first` is the 1-based field number of `fields[0]`, for error columns.
fn parse_object(
    file: &str,
    line: usize,
    first: usize,
    fields: &[&str],
    frame: u32,
    (w_img, h_img): (f64, f64),
) -> Result<Record, IoError> {
    if !(5..=7).contains(&fields.len()) {
        return Err(IoError::parse(
            file,
            line,
            first,
            "class cx cy w h [conf] track_id",
            &fields.join(" "),
        ));
    }
    let class: i32 = fields[0]
        .parse()
        .ok()
        .filter(|c| *c >= 0)
        .ok_or_else(|| IoError::parse(file, line, first, "a class index ≥ 0", fields[0]))?;
    let mut nums = [0.0f64; 4];
    for (k, n) in nums.iter_mut().enumerate() {
        let s = fields[1 + k];
        let v: f64 = s
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| IoError::parse(file, line, first + 1 + k, "a finite number", s))?;
        if k >= 2 && v < 0.0 {
            return Err(IoError::parse(
                file,
                line,
                first + 1 + k,
                "a width or height ≥ 0",
                s,
            ));
        }
        *n = v;
    }
    let (score, id) = match fields.len() {
        5 => (1.0, -1),
        n => {
            let id_s = fields[n - 1];
            let id: i64 = id_s.parse().ok().filter(|i| *i >= -1).ok_or_else(|| {
                IoError::parse(file, line, first + n - 1, "a track id (integer ≥ −1)", id_s)
            })?;
            if !id_ok(id) {
                return Err(IoError::parse(file, line, first + n - 1, ID_EXPECTED, id_s));
            }
            let score = if n == 7 {
                let s = fields[5];
                s.parse()
                    .ok()
                    .filter(|v: &f64| v.is_finite())
                    .ok_or_else(|| {
                        IoError::parse(file, line, first + 5, "a finite confidence", s)
                    })?
            } else {
                1.0
            };
            (score, id)
        }
    };
    let [cx, cy, w, h] = nums;
    let (w, h) = (w * w_img, h * h_img);
    let bbox = BBox::checked(cx * w_img - w / 2.0, cy * h_img - h / 2.0, w, h)
        .map_err(|e| IoError::parse(file, line, first + 1, "a box in the image", &e.to_string()))?;
    let mut r = Record::from_box(frame, id, bbox);
    r.score = score;
    r.class = class;
    Ok(r)
}

/// Non-blank lines with their 1-based numbers.
fn lines(text: &str) -> impl Iterator<Item = (usize, Vec<&str>)> {
    text.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.split_whitespace().collect::<Vec<_>>()))
        .filter(|(_, f)| !f.is_empty())
}

/// Rejects a track id (other than −1) seen twice in one frame.
fn check_unique(
    file: &str,
    line: usize,
    seen: &mut BTreeSet<(u32, i64)>,
    r: &Record,
) -> Result<(), IoError> {
    if r.id >= 0 && !seen.insert((r.frame, r.id)) {
        return Err(IoError::Invalid {
            file: file.to_string(),
            line,
            message: format!("track id {} twice in frame {}", r.id, r.frame),
        });
    }
    Ok(())
}

/// Reads one per-frame file as Ultralytics writes it (`class cx cy w h [conf] track_id`),
/// giving its records frame `frame`. `size` is the image (width, height).
pub fn parse_yolo_frame(
    text: &str,
    file: &str,
    frame: u32,
    size: (u32, u32),
) -> Result<Vec<Record>, IoError> {
    let img = check_size(file, size)?;
    if !(1..=MAX_FRAME).contains(&frame) {
        return Err(IoError::Invalid {
            file: file.to_string(),
            line: 0,
            message: format!("frame {frame} is outside 1..={MAX_FRAME}"),
        });
    }
    let mut seen = BTreeSet::new();
    let mut out = Vec::new();
    for (line, fields) in lines(text) {
        let r = parse_object(file, line, 1, &fields, frame, img)?;
        check_unique(file, line, &mut seen, &r)?;
        out.push(r);
    }
    Ok(out)
}

/// Reads the single-file form (`frame class cx cy w h [conf] track_id` per line). `size` is
/// the image (width, height). Records come back sorted by frame, then id.
pub fn parse_yolo(text: &str, file: &str, size: (u32, u32)) -> Result<Vec<Record>, IoError> {
    let img = check_size(file, size)?;
    let mut seen = BTreeSet::new();
    let mut out = Vec::new();
    for (line, fields) in lines(text) {
        let frame: u32 = fields[0]
            .parse()
            .ok()
            .filter(|f| (1..=MAX_FRAME).contains(f))
            .ok_or_else(|| {
                IoError::parse(
                    file,
                    line,
                    1,
                    format!("a frame number in 1..={MAX_FRAME}"),
                    fields[0],
                )
            })?;
        let r = parse_object(file, line, 2, &fields[1..], frame, img)?;
        check_unique(file, line, &mut seen, &r)?;
        out.push(r);
        if out.len() as u64 > MAX_RECORDS {
            return Err(IoError::Invalid {
                file: file.to_string(),
                line,
                message: format!("more than {MAX_RECORDS} boxes; split the file"),
            });
        }
    }
    out.sort_by_key(|r| (r.frame, r.id));
    Ok(out)
}

/// One record's per-frame line, without a newline.
fn object_line(out: &mut String, r: &Record, (w_img, h_img): (f64, f64)) {
    let b = &r.bbox;
    let _ = write!(
        out,
        "{} {} {} {} {} {} {}",
        r.class.max(0),
        (b.x + b.w / 2.0) / w_img,
        (b.y + b.h / 2.0) / h_img,
        b.w / w_img,
        b.h / h_img,
        r.score,
        r.id.max(-1)
    );
}

fn check_records(records: &[Record]) -> Result<(), IoError> {
    for r in records {
        let b = &r.bbox;
        if BBox::checked(b.x, b.y, b.w, b.h).is_err() || !r.score.is_finite() || r.frame < 1 {
            return Err(IoError::Invalid {
                file: "<yolo output>".to_string(),
                line: 0,
                message: format!(
                    "record of id {} in frame {} has a non-finite or negative box, a \
                     non-finite score or frame 0",
                    r.id, r.frame
                ),
            });
        }
    }
    Ok(())
}

/// Writes records in the single-file form, sorted by frame then id. `size` is the image
/// (width, height); without a valid one this is an error.
pub fn write_yolo(records: &[Record], size: (u32, u32)) -> Result<String, IoError> {
    let img = check_size("<yolo output>", size)?;
    check_records(records)?;
    let mut sorted: Vec<&Record> = records.iter().collect();
    sorted.sort_by_key(|r| (r.frame, r.id));
    let mut out = String::new();
    for r in sorted {
        let _ = write!(out, "{} ", r.frame);
        object_line(&mut out, r, img);
        out.push('\n');
    }
    Ok(out)
}

/// Writes records as Ultralytics' per-frame files: frame → that file's text (frames without
/// records have no entry; Ultralytics writes no file for them either).
pub fn write_yolo_frames(
    records: &[Record],
    size: (u32, u32),
) -> Result<BTreeMap<u32, String>, IoError> {
    let img = check_size("<yolo output>", size)?;
    check_records(records)?;
    let mut sorted: Vec<&Record> = records.iter().collect();
    sorted.sort_by_key(|r| (r.frame, r.id));
    let mut out: BTreeMap<u32, String> = BTreeMap::new();
    for r in sorted {
        let text = out.entry(r.frame).or_default();
        object_line(text, r, img);
        text.push('\n');
    }
    Ok(out)
}
