//! The detection file of `shapetrack track`: MOT, MOTS or Scalabel told apart by content, a
//! text file checked in a first pass, then read one frame's records at a time.

use crate::io::limits::image_size_ok;
use crate::io::motchallenge::{parse_mot_line, parse_mots_line, MotReadOptions};
use crate::io::scalabel::{self, parse_scalabel, split_videos, Categories};
use crate::io::{strip_bom, IoError, Record, Rle};
use std::path::{Path, PathBuf};

/// Whether a detection file is MOTS, from its first non-blank line: six whitespace-separated
/// fields, no comma, and a sixth that is an RLE mask of the height and width in the fourth and
/// fifth. A small mask's RLE may be all digits (`538` is a 4×4 mask's runs 5, 3, 8), so a
/// sixth field that reads as a number is decoded rather than taken for a box height: a MOT
/// box line's height almost never decodes to runs covering exactly its "height × width".
pub(crate) fn is_mots(text: &str) -> bool {
    let Some(line) = text
        .lines()
        .map(|l| strip_bom(l).trim())
        .find(|l| !l.is_empty())
    else {
        return false;
    };
    let f: Vec<&str> = line.split_whitespace().collect();
    if line.contains(',') || f.len() != 6 {
        return false;
    }
    if f[5].parse::<f64>().is_err() {
        return true;
    }
    match (f[3].parse::<u32>(), f[4].parse::<u32>()) {
        (Ok(h), Ok(w)) => {
            image_size_ok(u64::from(w), u64::from(h)) && Rle::from_compressed(f[5], h, w).is_ok()
        }
        _ => false,
    }
}

/// Whether a detection file is JSON (Scalabel): its first non-blank character (after a
/// byte-order mark) opens a list or an object.
pub(crate) fn is_json(text: &str) -> bool {
    matches!(strip_bom(text).trim_start().chars().next(), Some('[' | '{'))
}

/// The detections of one video of a Scalabel file (`video`, or the file's only one), its name
/// and the category table its classes refer to.
pub(crate) fn scalabel_detections(
    text: &str,
    file: &str,
    video: Option<&str>,
) -> Result<(String, Vec<Record>, Categories), super::RunError> {
    let mut videos = split_videos(parse_scalabel(text, file)?);
    let name = match video {
        Some(v) => v.to_string(),
        None if videos.len() == 1 => videos.keys().next().cloned().unwrap_or_default(),
        None => {
            let names: Vec<&String> = videos.keys().collect();
            return Err(format!(
                "{file} holds {} videos ({names:?}): choose one with --video",
                videos.len()
            )
            .into());
        }
    };
    let frames = videos
        .remove(&name)
        .ok_or_else(|| format!("{file}: no video named {name:?}"))?;
    let mut cats = Categories::default();
    let mut records =
        scalabel::to_records(&frames, &mut scalabel::IdMap::default(), &mut cats, false);
    // Detections carry no identity; the tracker gives them one.
    for r in &mut records {
        r.id = -1;
    }
    Ok((name, records, cats))
}

/// What a first pass over a MOT/MOTS text file found, without keeping its records.
pub(crate) struct Scan {
    /// Whether frame numbers never decrease from line to line (then the tracker reads the
    /// file again line by line while it runs, and memory stays flat over any length).
    pub(crate) sorted: bool,
    pub(crate) records: usize,
    pub(crate) first_frame: Option<u32>,
    pub(crate) last_frame: u32,
    /// The image size of the first mask (MOTS).
    pub(crate) mask_size: Option<(u32, u32)>,
}

pub(crate) fn open_lines(path: &Path) -> Result<Lines, IoError> {
    let f = std::fs::File::open(path).map_err(|source| IoError::Io {
        file: path.display().to_string(),
        source,
    })?;
    Ok(Lines {
        reader: std::io::BufReader::new(f),
        buf: Vec::new(),
        line: 0,
    })
}

/// The lines of a text detection file (without their `\n` or `\r\n`), as `BufRead::lines`
/// gives them but bounded: a line longer than `limits::MAX_LINE_BYTES` (a device, a binary
/// file) or ending in a carriage return alone (classic Mac line endings: the whole file would
/// read as one line, every record past the first silently dropped) is an error naming it.
pub(crate) struct Lines {
    reader: std::io::BufReader<std::fs::File>,
    buf: Vec<u8>,
    line: usize,
}

impl Iterator for Lines {
    type Item = std::io::Result<String>;

    fn next(&mut self) -> Option<Self::Item> {
        use std::io::{BufRead as _, Read as _};
        let cap = crate::io::limits::MAX_LINE_BYTES;
        let bad = |msg: String| std::io::Error::new(std::io::ErrorKind::InvalidData, msg);
        self.buf.clear();
        match (&mut self.reader)
            .take(cap + 1)
            .read_until(b'\n', &mut self.buf)
        {
            Ok(0) => return None,
            Ok(_) => {}
            Err(e) => return Some(Err(e)),
        }
        self.line += 1;
        if self.buf.len() as u64 > cap {
            return Some(Err(bad(format!(
                "line {} is longer than {} MiB: not a text detection file",
                self.line,
                cap >> 20
            ))));
        }
        if self.buf.last() == Some(&b'\n') {
            self.buf.pop();
            if self.buf.last() == Some(&b'\r') {
                self.buf.pop();
            }
        }
        if self.buf.contains(&b'\r') {
            return Some(Err(bad(format!(
                "line {} ends in a carriage return alone (classic Mac line endings): save the \
                 file with LF or CRLF line endings",
                self.line
            ))));
        }
        Some(
            String::from_utf8(std::mem::take(&mut self.buf))
                .map_err(|_| bad(format!("line {} is not UTF-8 text", self.line))),
        )
    }
}

/// Reads line `ln` of a text detection file (I/O errors name the file).
pub(crate) fn line_of(
    line: Option<std::io::Result<String>>,
    path: &Path,
) -> Result<Option<String>, IoError> {
    line.transpose().map_err(|source| IoError::Io {
        file: path.display().to_string(),
        source,
    })
}

fn parse_line(raw: &str, file: &str, ln: usize, mots: bool) -> Result<Option<Record>, IoError> {
    // The first line may start with a byte-order mark (these lines do not pass `read_text`).
    let raw = if ln == 1 { strip_bom(raw) } else { raw };
    if mots {
        parse_mots_line(raw, file, ln)
    } else {
        parse_mot_line(raw, file, ln, MotReadOptions::default())
    }
}

/// Checks every line of a MOT/MOTS file (so a bad line fails before anything is written) and
/// notes what the run needs to know up front.
pub(crate) fn scan(
    path: &Path,
    mots: bool,
    image_size: Option<(u32, u32)>,
) -> Result<Scan, IoError> {
    let file = path.display().to_string();
    let mut lines = open_lines(path)?;
    let mut scan = Scan {
        sorted: true,
        records: 0,
        first_frame: None,
        last_frame: 0,
        mask_size: None,
    };
    let mut prev = 0u32;
    let mut ln = 0usize;
    while let Some(raw) = line_of(lines.next(), path)? {
        ln += 1;
        let Some(r) = parse_line(&raw, &file, ln, mots)? else {
            continue;
        };
        // Without a seqinfo the first mask gives the frame's size, and every other mask must
        // have it too (a mask of another size would be tracked on a frame it does not fit).
        check_mask_size(
            &r,
            image_size.or(scan.mask_size),
            image_size.is_some(),
            &file,
            ln,
        )?;
        if scan.records > 0 && r.frame < prev {
            scan.sorted = false;
        }
        prev = r.frame;
        scan.records += 1;
        scan.first_frame = Some(scan.first_frame.map_or(r.frame, |f| f.min(r.frame)));
        scan.last_frame = scan.last_frame.max(r.frame);
        if scan.mask_size.is_none() {
            scan.mask_size = r.mask.as_ref().map(|m| (m.width, m.height));
        }
    }
    Ok(scan)
}

/// A mask must be of the frame it belongs to: `size`, the seqinfo's when `from_seqinfo`,
/// else the first mask's.
pub(crate) fn check_mask_size(
    r: &Record,
    size: Option<(u32, u32)>,
    from_seqinfo: bool,
    file: &str,
    line: usize,
) -> Result<(), IoError> {
    if let (Some(m), Some((w, h))) = (&r.mask, size) {
        if (m.width, m.height) != (w, h) {
            let source = if from_seqinfo {
                "seqinfo"
            } else {
                "the file's first mask"
            };
            return Err(IoError::Invalid {
                file: file.to_string(),
                line,
                message: format!(
                    "a {}x{} mask in a {w}x{h} video ({source}): masks must be of the frame's size",
                    m.width, m.height
                ),
            });
        }
    }
    Ok(())
}

/// The detections, one frame's records at a time, in frame order.
pub(crate) enum Groups {
    /// Held in memory, sorted by frame (Scalabel JSON, or a text file not sorted by frame).
    Loaded { records: Vec<Record>, at: usize },
    /// A text file sorted by frame, read line by line.
    Stream {
        lines: Lines,
        path: PathBuf,
        mots: bool,
        ln: usize,
        pending: Option<Record>,
    },
}

impl Groups {
    pub(crate) fn loaded(mut records: Vec<Record>) -> Self {
        records.sort_by_key(|r| r.frame);
        Groups::Loaded { records, at: 0 }
    }

    /// The next frame's number and records.
    pub(crate) fn next_group(&mut self) -> Result<Option<(u32, Vec<Record>)>, IoError> {
        match self {
            Groups::Loaded { records, at } => {
                let Some(first) = records.get(*at) else {
                    return Ok(None);
                };
                let frame = first.frame;
                let end = records[*at..]
                    .iter()
                    .position(|r| r.frame != frame)
                    .map_or(records.len(), |k| *at + k);
                let group = records[*at..end].to_vec();
                *at = end;
                Ok(Some((frame, group)))
            }
            Groups::Stream {
                lines,
                path,
                mots,
                ln,
                pending,
            } => {
                let file = path.display().to_string();
                let mut group: Vec<Record> = pending.take().into_iter().collect();
                while let Some(raw) = line_of(lines.next(), path)? {
                    *ln += 1;
                    let Some(r) = parse_line(&raw, &file, *ln, *mots)? else {
                        continue;
                    };
                    match group.first() {
                        Some(g) if g.frame != r.frame => {
                            *pending = Some(r);
                            break;
                        }
                        _ => group.push(r),
                    }
                }
                Ok(group.first().map(|g| g.frame).map(|f| (f, group)))
            }
        }
    }
}
