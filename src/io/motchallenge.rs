//! MOTChallenge text files (`gt.txt`, `det.txt`, results), MOTS text files and `seqinfo.ini`.
//!
//! MOTChallenge lines are `frame,id,x,y,w,h,conf,c8,c9,c10`: for gt files of MOT16 and later
//! `c8` is the class and `c9` the visibility; in MOT15 they are world coordinates (-1). Like
//! TrackEval we accept commas or whitespace as separators, CRLF, blank lines and extra fields.
//! MOTS lines are `frame id class height width rle` with a pycocotools-compressed RLE.

use super::limits::{
    id_ok, image_size_ok, ID_EXPECTED, MAX_BOXES_PER_FRAME, MAX_FRAME, MAX_PIXELS, MAX_SIDE,
};
use super::{IoError, Record, RecordFlags, Rle};
use crate::frame::BBox;
use std::fmt::Write as _;

/// Splits a MOTChallenge line into fields: comma-separated, or whitespace-separated when the line
/// has no comma (both occur in the wild). Empty trailing fields are dropped.
fn fields(line: &str) -> Vec<&str> {
    let mut v: Vec<&str> = if line.contains(',') {
        line.split(',').map(str::trim).collect()
    } else {
        line.split_whitespace().collect()
    };
    while v.last().is_some_and(|s| s.is_empty()) {
        v.pop();
    }
    v
}

fn num(file: &str, line: usize, col: usize, s: &str, what: &str) -> Result<f64, IoError> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(IoError::parse(
            file,
            line,
            col,
            format!("{what} (a finite number)"),
            s,
        )),
    }
}

fn int(file: &str, line: usize, col: usize, s: &str, what: &str) -> Result<i64, IoError> {
    if let Ok(v) = s.parse::<i64>() {
        return Ok(v);
    }
    // Some tools write integral values as floats ("1.0"); accept those, nothing else.
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v.fract() == 0.0 && v.abs() < 9.0e15 => Ok(v as i64),
        _ => Err(IoError::parse(
            file,
            line,
            col,
            format!("{what} (an integer)"),
            s,
        )),
    }
}

/// The track id of field 2, within ±2⁵³ (see [`super::limits::MAX_ID`]).
fn track_id(file: &str, line: usize, s: &str) -> Result<i64, IoError> {
    let id = match s.parse::<i64>() {
        Ok(id) => id,
        // An integer too long for i64 is still an id, only too large: say so.
        Err(_) if is_digits(s.strip_prefix(['-', '+']).unwrap_or(s)) => i64::MAX,
        Err(_) => int(file, line, 2, s, "track id")?,
    };
    if !id_ok(id) {
        return Err(IoError::parse(file, line, 2, ID_EXPECTED, s));
    }
    Ok(id)
}

fn is_digits(s: &str) -> bool {
    !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit())
}

/// How strictly [`parse_mot_with`] checks values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MotReadOptions {
    /// Accept negative box sizes. Real trackers write them and TrackEval scores such a box with
    /// IoU 0, so the evaluator must read them; the tracker's inputs must not have them.
    pub allow_negative_size: bool,
    /// Accept frame 0, so that evaluation can report it as an invalid timestep as TrackEval does.
    pub allow_frame_zero: bool,
}

/// Parses a MOTChallenge txt file (gt, det or results). `file` names it in errors.
///
/// Needs at least 6 fields per line; missing confidence defaults to 1, missing class and
/// visibility to -1. Frames must be ≥ 1 and sizes non-negative.
pub fn parse_mot(text: &str, file: &str) -> Result<Vec<Record>, IoError> {
    parse_mot_with(text, file, MotReadOptions::default())
}

/// [`parse_mot`] with the strictness of `opts`. The class column is truncated to an integer
/// (TrackEval reads it with `astype(int)`).
pub fn parse_mot_with(
    text: &str,
    file: &str,
    opts: MotReadOptions,
) -> Result<Vec<Record>, IoError> {
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        if let Some(r) = parse_mot_line(raw, file, i + 1, opts)? {
            out.push(r);
        }
    }
    Ok(out)
}

/// One line of a MOTChallenge txt file (`ln` is its 1-based number, for errors): `None` for a
/// blank line. What [`parse_mot_with`] does per line, for readers that stream.
pub fn parse_mot_line(
    raw: &str,
    file: &str,
    ln: usize,
    opts: MotReadOptions,
) -> Result<Option<Record>, IoError> {
    let line = raw.trim_end_matches('\r').trim();
    if line.is_empty() {
        return Ok(None);
    }
    let f = fields(line);
    if f.len() < 6 {
        return Err(IoError::parse(
            file,
            ln,
            f.len() + 1,
            "at least 6 fields: frame,id,x,y,w,h[,conf,...]",
            line,
        ));
    }
    let frame = int(file, ln, 1, f[0], "frame number")?;
    let first = if opts.allow_frame_zero { 0 } else { 1 };
    if frame < first || frame > MAX_FRAME as i64 {
        return Err(IoError::parse(
            file,
            ln,
            1,
            format!("frame number in {first}..={MAX_FRAME} (the readers' cap)"),
            f[0],
        ));
    }
    let id = track_id(file, ln, f[1])?;
    let x = num(file, ln, 3, f[2], "box left")?;
    let y = num(file, ln, 4, f[3], "box top")?;
    let w = num(file, ln, 5, f[4], "box width")?;
    let h = num(file, ln, 6, f[5], "box height")?;
    if w < 0.0 && !opts.allow_negative_size {
        return Err(IoError::parse(file, ln, 5, "box width ≥ 0", f[4]));
    }
    if h < 0.0 && !opts.allow_negative_size {
        return Err(IoError::parse(file, ln, 6, "box height ≥ 0", f[5]));
    }
    let score = match f.get(6) {
        Some(s) => num(file, ln, 7, s, "confidence")?,
        None => 1.0,
    };
    let class = match f.get(7) {
        Some(s) => num(file, ln, 8, s, "class")? as i32,
        None => -1,
    };
    let visibility = match f.get(8) {
        Some(s) => num(file, ln, 9, s, "visibility")?,
        None => -1.0,
    };
    Ok(Some(Record {
        frame: frame as u32,
        id,
        bbox: BBox::new(x, y, w, h),
        score,
        class,
        visibility,
        mask: None,
        flags: RecordFlags::default(),
    }))
}

/// Reads MOTChallenge boxes into per-frame detections (index = frame number, 1-based; index 0
/// stays empty): the boxes `shapetrack detect --boxes` refines into masks. A box for a frame
/// the video does not have (beyond its `frames` frames) is an error naming its line: it would
/// never be refined, and the output would lose it without a word. A frame of more than
/// [`MAX_BOXES_PER_FRAME`] boxes (the tracker's cap) is an error naming the first line over
/// it: the refiner's work per frame would follow the file's claim.
pub fn read_boxes(
    path: &std::path::Path,
    frames: usize,
) -> Result<Vec<Vec<crate::frame::Detection>>, IoError> {
    let file = path.display().to_string();
    let text = super::read_text(path)?;
    let mut out = vec![Vec::new(); frames + 1];
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let Some(r) = parse_mot_line(raw, &file, line, MotReadOptions::default())? else {
            continue;
        };
        let Some(v) = out.get_mut(r.frame as usize) else {
            return Err(IoError::Invalid {
                file,
                line,
                message: format!(
                    "a box for frame {}, but the frame folder holds {frames} frames",
                    r.frame
                ),
            });
        };
        if v.len() == MAX_BOXES_PER_FRAME {
            return Err(IoError::Invalid {
                file,
                line,
                message: format!(
                    "frame {} holds more than {MAX_BOXES_PER_FRAME} boxes, the most per \
                     frame the tracker and the refiner take (src/io/limits.rs)",
                    r.frame
                ),
            });
        }
        let mut d = crate::frame::Detection::from_box(r.bbox, r.score);
        d.class = r.class;
        v.push(d);
    }
    Ok(out)
}

/// Writes records as MOTChallenge txt, `frame,id,x,y,w,h,conf,-1,-1,-1` per line, sorted by
/// frame then id. Numbers use the shortest text that reads back to the same `f64`.
pub fn write_mot(records: &[Record]) -> String {
    let mut rs: Vec<&Record> = records.iter().collect();
    rs.sort_by_key(|r| (r.frame, r.id));
    let mut s = String::with_capacity(rs.len() * 48);
    for r in rs {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},-1",
            r.frame,
            r.id,
            r.bbox.x,
            r.bbox.y,
            r.bbox.w,
            r.bbox.h,
            r.score,
            if r.class == -1 {
                "-1".to_string()
            } else {
                r.class.to_string()
            },
            r.visibility
        );
    }
    s
}

/// Parses a MOTS txt file: `frame id class height width rle` per line (space-separated).
pub fn parse_mots(text: &str, file: &str) -> Result<Vec<Record>, IoError> {
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        if let Some(r) = parse_mots_line(raw, file, i + 1)? {
            out.push(r);
        }
    }
    Ok(out)
}

/// One line of a MOTS txt file (`ln` is its 1-based number, for errors): `None` for a blank
/// line. What [`parse_mots`] does per line, for readers that stream.
pub fn parse_mots_line(raw: &str, file: &str, ln: usize) -> Result<Option<Record>, IoError> {
    let line = raw.trim_end_matches('\r').trim();
    if line.is_empty() {
        return Ok(None);
    }
    let f: Vec<&str> = line.split_whitespace().collect();
    if f.len() < 6 {
        return Err(IoError::parse(
            file,
            ln,
            f.len() + 1,
            "6 fields: frame id class height width rle",
            line,
        ));
    }
    let frame = int(file, ln, 1, f[0], "frame number")?;
    if !(0..=MAX_FRAME as i64).contains(&frame) {
        return Err(IoError::parse(
            file,
            ln,
            1,
            format!("frame number in 0..={MAX_FRAME} (the readers' cap)"),
            f[0],
        ));
    }
    let id = track_id(file, ln, f[1])?;
    let class = int(file, ln, 3, f[2], "class id")? as i32;
    let h = int(file, ln, 4, f[3], "image height")?;
    let w = int(file, ln, 5, f[4], "image width")?;
    if !(1..=1 << 16).contains(&h) {
        return Err(IoError::parse(
            file,
            ln,
            4,
            "image height in 1..=65536",
            f[3],
        ));
    }
    if !(1..=1 << 16).contains(&w) {
        return Err(IoError::parse(
            file,
            ln,
            5,
            "image width in 1..=65536",
            f[4],
        ));
    }
    if !image_size_ok(w as u64, h as u64) {
        return Err(IoError::parse(
            file,
            ln,
            4,
            format!("image of at most {MAX_PIXELS} pixels (the readers' cap)"),
            &format!("{h} {w}"),
        ));
    }
    let rle = Rle::from_compressed(f[5], h as u32, w as u32).map_err(|source| IoError::Rle {
        file: file.to_string(),
        line: ln,
        source,
    })?;
    let bbox = rle.bbox();
    // MOTS frames are 0-based in KITTI-MOTS but 1-based in MOTS20; keep what the file says
    // (frame 0 is stored as 0 and callers that need 1-based frames shift it).
    Ok(Some(Record {
        frame: frame as u32,
        id,
        bbox,
        score: 1.0,
        class,
        visibility: -1.0,
        mask: Some(rle),
        flags: RecordFlags::default(),
    }))
}

/// MOTS records of one frame's detections with masks (frame `n`, id -1: detections carry no
/// identity; box-only detections are left out): the lines `shapetrack detect` writes.
pub fn detection_records(
    n: u32,
    dets: &[crate::frame::Detection],
    width: u32,
    height: u32,
) -> Vec<Record> {
    dets.iter()
        .filter_map(|d| {
            let m = d.mask.as_ref()?;
            let mut r = Record::from_box(n, -1, d.bbox);
            r.score = d.score;
            r.class = d.class;
            r.mask = Some(Rle::from_mask(m, width, height));
            Some(r)
        })
        .collect()
}

/// Writes records that carry masks as MOTS txt, sorted by frame then id. Records without a
/// mask are skipped (MOTS has no box-only form).
pub fn write_mots(records: &[Record]) -> String {
    let mut rs: Vec<&Record> = records.iter().filter(|r| r.mask.is_some()).collect();
    rs.sort_by_key(|r| (r.frame, r.id));
    let mut s = String::new();
    for r in rs {
        if let Some(m) = &r.mask {
            let _ = writeln!(
                s,
                "{} {} {} {} {} {}",
                r.frame,
                r.id,
                r.class,
                m.height,
                m.width,
                m.to_compressed()
            );
        }
    }
    s
}

/// The `[Sequence]` section of a MOTChallenge `seqinfo.ini`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SeqInfo {
    /// Sequence name.
    pub name: String,
    /// Image folder, relative to the sequence folder.
    pub im_dir: String,
    /// Frames per second.
    pub frame_rate: f64,
    /// Number of frames.
    pub seq_length: u32,
    /// Image width.
    pub im_width: u32,
    /// Image height.
    pub im_height: u32,
    /// Image file extension, with the dot.
    pub im_ext: String,
}

impl SeqInfo {
    /// Parses `seqinfo.ini` text; keys are case-insensitive, unknown keys ignored.
    pub fn parse(text: &str, file: &str) -> Result<SeqInfo, IoError> {
        let mut get = std::collections::HashMap::new();
        for (i, raw) in text.lines().enumerate() {
            let line = raw.trim();
            if line.is_empty()
                || line.starts_with('[')
                || line.starts_with(';')
                || line.starts_with('#')
            {
                continue;
            }
            let Some((k, v)) = line.split_once('=') else {
                return Err(IoError::parse(file, i + 1, 1, "key=value", line));
            };
            get.insert(k.trim().to_ascii_lowercase(), (i + 1, v.trim().to_string()));
        }
        let req = |k: &str| -> Result<(usize, String), IoError> {
            get.get(&k.to_ascii_lowercase())
                .cloned()
                .ok_or_else(|| IoError::Invalid {
                    file: file.to_string(),
                    line: 0,
                    message: format!("missing key {k}"),
                })
        };
        let parse_u32 = |k: &str| -> Result<u32, IoError> {
            let (ln, v) = req(k)?;
            v.parse::<u32>().map_err(|_| {
                IoError::parse(file, ln, k.len() + 2, format!("{k} as a whole number"), &v)
            })
        };
        // Counts a few bytes can declare but that decide what is allocated: capped.
        let capped = |k: &str, max: u32| -> Result<u32, IoError> {
            let v = parse_u32(k)?;
            if v > max {
                let (ln, text) = req(k)?;
                return Err(IoError::parse(
                    file,
                    ln,
                    k.len() + 2,
                    format!("{k} ≤ {max} (the readers' cap)"),
                    &text,
                ));
            }
            Ok(v)
        };
        // The image size is optional, but when given it must be one.
        let (im_width, im_height) = match (
            get.contains_key("imwidth"),
            get.contains_key("imheight"),
        ) {
            (false, false) => (0, 0),
            _ => {
                let (w, h) = (parse_u32("imWidth")?, parse_u32("imHeight")?);
                if !image_size_ok(w as u64, h as u64) {
                    let (ln, text) = req("imWidth")?;
                    return Err(IoError::parse(
                        file,
                        ln,
                        9,
                        format!(
                            "imWidth × imHeight ≥ 1 × 1, sides ≤ {MAX_SIDE}, at most {MAX_PIXELS} pixels"
                        ),
                        &format!("{text} × {h}"),
                    ));
                }
                (w, h)
            }
        };
        let (fr_ln, fr) = req("frameRate")?;
        let frame_rate = fr
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() && *v > 0.0)
            .ok_or_else(|| IoError::parse(file, fr_ln, 11, "frameRate > 0", &fr))?;
        Ok(SeqInfo {
            name: req("name").map(|v| v.1).unwrap_or_default(),
            im_dir: req("imDir").map(|v| v.1).unwrap_or_else(|_| "img1".into()),
            frame_rate,
            seq_length: capped("seqLength", MAX_FRAME)?,
            im_width,
            im_height,
            im_ext: req("imExt").map(|v| v.1).unwrap_or_else(|_| ".jpg".into()),
        })
    }

    /// Reads and parses a `seqinfo.ini` file.
    pub fn read(path: &std::path::Path) -> Result<SeqInfo, IoError> {
        SeqInfo::parse(&super::read_text(path)?, &path.display().to_string())
    }

    /// The file's text.
    pub fn to_ini(&self) -> String {
        format!(
            "[Sequence]\nname={}\nimDir={}\nframeRate={}\nseqLength={}\nimWidth={}\nimHeight={}\nimExt={}\n",
            self.name, self.im_dir, self.frame_rate, self.seq_length, self.im_width, self.im_height, self.im_ext
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_lenient_lines_and_roundtrips() {
        let text = "1,2,10.5,20,30,40,0.9,-1,-1,-1,extra\r\n\n2 3 1 2 3 4\n";
        let r = parse_mot(text, "t.txt").unwrap();
        assert_eq!(r.len(), 2);
        assert_eq!(r[0].bbox, BBox::new(10.5, 20.0, 30.0, 40.0));
        assert_eq!(r[1].score, 1.0);
        let back = parse_mot(&write_mot(&r), "w.txt").unwrap();
        assert_eq!(back, r);
    }

    #[test]
    fn errors_name_line_and_column() {
        let e = parse_mot("1,1,0,0,1,1,1\n1,x,0,0,1,1,1\n", "bad.txt").unwrap_err();
        match e {
            IoError::Parse {
                file, line, column, ..
            } => assert_eq!((file.as_str(), line, column), ("bad.txt", 2, 2)),
            other => panic!("unexpected {other:?}"),
        }
        assert!(matches!(
            parse_mot("1,1,0,0\n", "f"),
            Err(IoError::Parse {
                line: 1,
                column: 5,
                ..
            })
        ));
        assert!(matches!(
            parse_mot("0,1,0,0,1,1\n", "f"),
            Err(IoError::Parse { column: 1, .. })
        ));
        assert!(matches!(
            parse_mot("1,1,0,0,-1,1\n", "f"),
            Err(IoError::Parse { column: 5, .. })
        ));
        assert!(matches!(
            parse_mot("1,1,0,0,nan,1\n", "f"),
            Err(IoError::Parse { column: 5, .. })
        ));
    }

    #[test]
    fn mots_roundtrip() {
        let text = "1 2001 2 4 3 125ON\n2 2001 2 4 3 <\n";
        let r = parse_mots(text, "m.txt").unwrap();
        assert_eq!(r.len(), 2);
        assert_eq!(r[0].mask.as_ref().unwrap().area(), 3);
        assert_eq!(write_mots(&r), text);
        assert!(matches!(
            parse_mots("1 1 2 4 3 12\n", "m"),
            Err(IoError::Rle { line: 1, .. })
        ));
    }

    #[test]
    fn seqinfo_roundtrip() {
        let s = SeqInfo {
            name: "A".into(),
            im_dir: "img1".into(),
            frame_rate: 25.0,
            seq_length: 10,
            im_width: 640,
            im_height: 480,
            im_ext: ".png".into(),
        };
        assert_eq!(SeqInfo::parse(&s.to_ini(), "s").unwrap(), s);
        assert!(SeqInfo::parse("[Sequence]\nframeRate=x\nseqLength=3\n", "s").is_err());
    }

    /// `--boxes` takes at most the tracker's boxes per frame: the refiner's work per frame
    /// follows the file's claim otherwise. The error names the file and the first line over.
    #[test]
    fn boxes_beyond_the_per_frame_cap_are_refused_with_their_line() {
        let dir = std::env::temp_dir().join(format!("st-boxes-cap-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("boxes.txt");
        let mut text = String::from("1,-1,5,5,10,10,0.9,-1,-1,-1\n");
        for k in 0..=MAX_BOXES_PER_FRAME {
            text.push_str(&format!("2,-1,{k},5,10,10,0.9,-1,-1,-1\n"));
        }
        std::fs::write(&path, &text).unwrap();
        let e = read_boxes(&path, 3).unwrap_err().to_string();
        let line = MAX_BOXES_PER_FRAME + 2;
        assert!(e.contains(&format!("boxes.txt:{line}:")), "{e}");
        assert!(e.contains("frame 2"), "{e}");
        // At the cap it is read.
        let at_cap: String = text
            .lines()
            .take(line - 1)
            .map(|l| format!("{l}\n"))
            .collect();
        std::fs::write(&path, at_cap).unwrap();
        assert_eq!(read_boxes(&path, 3).unwrap()[2].len(), MAX_BOXES_PER_FRAME);
        // A box beyond the video's frames names its line too.
        std::fs::write(&path, "4,-1,5,5,10,10,0.9,-1,-1,-1\n").unwrap();
        let e = read_boxes(&path, 3).unwrap_err().to_string();
        assert!(e.contains("boxes.txt:1:") && e.contains("frame 4"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
