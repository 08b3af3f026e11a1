//! TrackEval's MOTChallenge folder layout.
//!
//! Ground truth: `GT_ROOT/<BENCH>-<split>/<seq>/{gt/gt.txt,seqinfo.ini}` with the sequence list
//! in `GT_ROOT/seqmaps/<BENCH>-<split>.txt` (a `name` header, then one sequence per line).
//! Results: `RESULTS_ROOT/<seq>.txt`. When `GT_ROOT/<BENCH>-<split>` does not exist the layout is
//! taken as flat (`GT_ROOT/<seq>/...`), and without a seqmap every sub-folder that has
//! `gt/gt.txt` is a sequence, in name order.

use super::motchallenge::{parse_mot_with, parse_mots, MotReadOptions, SeqInfo};
use super::sequence::{Origin, SequenceInput};
use super::{read_text, IoError, Record};
use std::path::{Path, PathBuf};

/// One ground-truth sequence found on disk.
#[derive(Debug, Clone, PartialEq)]
pub struct SeqEntry {
    /// Sequence name (its folder name).
    pub name: String,
    /// `.../<seq>/gt/gt.txt`.
    pub gt_file: PathBuf,
    /// `.../<seq>/seqinfo.ini`.
    pub seqinfo_file: PathBuf,
    /// `seqLength` from `seqinfo.ini`.
    pub num_frames: u32,
    /// `imWidth` × `imHeight` from `seqinfo.ini`, when it gives them: every MOTS mask of the
    /// sequence must be of this size.
    pub image_size: Option<(u32, u32)>,
}

/// The ground-truth sequences of one benchmark split.
#[derive(Debug, Clone, PartialEq)]
pub struct GtLayout {
    /// Folder holding the sequence folders (`GT_ROOT/<BENCH>-<split>` or `GT_ROOT`).
    pub dir: PathBuf,
    /// The seqmap used, if any.
    pub seqmap: Option<PathBuf>,
    /// Sequences in seqmap (or name) order.
    pub sequences: Vec<SeqEntry>,
}

fn invalid(file: &Path, line: usize, message: impl Into<String>) -> IoError {
    IoError::Invalid {
        file: file.display().to_string(),
        line,
        message: message.into(),
    }
}

/// Sequence names of a seqmap text (TrackEval: skip the first line and empty names; the name
/// is the first comma-separated field).
pub fn parse_seqmap(text: &str) -> Vec<String> {
    text.lines()
        .skip(1)
        .filter_map(|l| {
            let name = l
                .trim_end_matches('\r')
                .split(',')
                .next()
                .unwrap_or("")
                .trim();
            (!name.is_empty()).then(|| name.to_string())
        })
        .collect()
}

/// Finds the sequences of `benchmark`-`split` under `gt_root`, reading each `seqinfo.ini`.
/// A missing folder, `gt/gt.txt` or `seqinfo.ini` (or key in it) is an error naming the file.
pub fn discover(gt_root: &Path, benchmark: &str, split: &str) -> Result<GtLayout, IoError> {
    let set = format!("{benchmark}-{split}");
    let split_dir = gt_root.join(&set);
    let dir = if split_dir.is_dir() {
        split_dir
    } else {
        gt_root.to_path_buf()
    };
    if !dir.is_dir() {
        return Err(invalid(&dir, 0, "ground-truth folder not found"));
    }
    let seqmap_file = gt_root.join("seqmaps").join(format!("{set}.txt"));
    let (names, seqmap) = if seqmap_file.is_file() {
        (parse_seqmap(&read_text(&seqmap_file)?), Some(seqmap_file))
    } else {
        let rd = std::fs::read_dir(&dir).map_err(|source| IoError::Io {
            file: dir.display().to_string(),
            source,
        })?;
        let mut names: Vec<String> = rd
            .filter_map(Result::ok)
            .filter(|e| e.path().join("gt").join("gt.txt").is_file())
            .filter_map(|e| e.file_name().to_str().map(str::to_string))
            .collect();
        names.sort();
        (names, None)
    };
    if names.is_empty() {
        return Err(invalid(
            seqmap.as_deref().unwrap_or(&dir),
            0,
            "no sequences found (no seqmap entries and no <seq>/gt/gt.txt)",
        ));
    }
    let mut sequences = Vec::with_capacity(names.len());
    for name in names {
        let seq_dir = dir.join(&name);
        let seqinfo_file = seq_dir.join("seqinfo.ini");
        let gt_file = seq_dir.join("gt").join("gt.txt");
        if !seqinfo_file.is_file() {
            return Err(invalid(&seqinfo_file, 0, "seqinfo.ini not found"));
        }
        let info = SeqInfo::read(&seqinfo_file)?;
        if !gt_file.is_file() {
            return Err(invalid(&gt_file, 0, "ground-truth file not found"));
        }
        sequences.push(SeqEntry {
            name,
            gt_file,
            seqinfo_file,
            num_frames: info.seq_length,
            image_size: (info.im_width > 0 && info.im_height > 0)
                .then_some((info.im_width, info.im_height)),
        });
    }
    Ok(GtLayout {
        dir,
        seqmap,
        sequences,
    })
}

impl GtLayout {
    /// Keeps only the named sequences, in the given order; an unknown name is an error.
    pub fn select(&mut self, names: &[String]) -> Result<(), IoError> {
        let mut out = Vec::with_capacity(names.len());
        for n in names {
            match self.sequences.iter().find(|s| &s.name == n) {
                Some(s) => out.push(s.clone()),
                None => {
                    return Err(invalid(
                        &self.dir.join(n),
                        0,
                        format!("sequence {n} is not in the ground truth"),
                    ))
                }
            }
        }
        self.sequences = out;
        Ok(())
    }
}

/// The results file of `seq`: `RESULTS_ROOT/<seq>.txt`.
pub fn results_file(results_root: &Path, seq: &str) -> PathBuf {
    results_root.join(format!("{seq}.txt"))
}

/// 1-based line numbers of the non-blank lines: the line of each record the readers return.
pub fn record_lines(text: &str) -> Vec<usize> {
    text.lines()
        .enumerate()
        .filter(|(_, l)| !l.trim_end_matches('\r').trim().is_empty())
        .map(|(i, _)| i + 1)
        .collect()
}

/// Parses MOTChallenge txt as TrackEval reads it. Unlike
/// [`parse_mot`](super::motchallenge::parse_mot) it accepts negative box sizes (real trackers
/// write them; TrackEval scores such a box with IoU 0) and frame 0 (so that evaluation can report
/// it as an invalid timestep, as TrackEval does). Missing confidence is 1, class and
/// visibility -1.
pub fn parse_mot_as_trackeval(text: &str, file: &str) -> Result<Vec<Record>, IoError> {
    let opts = MotReadOptions {
        allow_negative_size: true,
        allow_frame_zero: true,
    };
    parse_mot_with(text, file, opts)
}

/// Which file format to read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// MOTChallenge txt (boxes).
    Mot,
    /// MOTS txt (RLE masks).
    Mots,
}

/// Reads a gt or results file with the line of each record. Box gt lines need 8 fields
/// (`frame,id,x,y,w,h,conf,class`), as TrackEval requires.
pub fn read_records(
    path: &Path,
    format: Format,
    is_gt: bool,
) -> Result<(Vec<Record>, Origin), IoError> {
    let text = read_text(path)?;
    let file = path.display().to_string();
    let records = match format {
        Format::Mot => parse_mot_as_trackeval(&text, &file)?,
        Format::Mots => parse_mots(&text, &file)?,
    };
    let lines = record_lines(&text);
    if is_gt && format == Format::Mot {
        for (i, raw) in text.lines().enumerate() {
            let line = raw.trim_end_matches('\r').trim();
            if line.is_empty() {
                continue;
            }
            let mut fields: Vec<&str> = if line.contains(',') {
                line.split(',').map(str::trim).collect()
            } else {
                line.split_whitespace().collect()
            };
            while fields.last().is_some_and(|f| f.is_empty()) {
                fields.pop();
            }
            if fields.len() < 8 {
                return Err(IoError::parse(
                    &file,
                    i + 1,
                    fields.len() + 1,
                    "8 fields for ground truth: frame,id,x,y,w,h,conf,class",
                    line,
                ));
            }
        }
    }
    Ok((records, Origin { file, lines }))
}

/// Loads one sequence: its gt and `RESULTS_ROOT/<seq>.txt`. A missing results file is an error
/// naming it (as in TrackEval) unless `allow_missing_results`, which scores it as empty.
pub fn load_sequence(
    entry: &SeqEntry,
    results_root: &Path,
    format: Format,
    allow_missing_results: bool,
) -> Result<SequenceInput, IoError> {
    let (gt, gt_origin) = read_records(&entry.gt_file, format, true)?;
    check_mask_sizes(&gt, &gt_origin, entry)?;
    let res_file = results_file(results_root, &entry.name);
    let (results, results_origin) = if res_file.is_file() {
        let (results, origin) = read_records(&res_file, format, false)?;
        check_mask_sizes(&results, &origin, entry)?;
        (results, origin)
    } else if allow_missing_results {
        (
            Vec::new(),
            Origin {
                file: res_file.display().to_string(),
                lines: Vec::new(),
            },
        )
    } else {
        return Err(invalid(
            &res_file,
            0,
            format!("results file for sequence {} not found", entry.name),
        ));
    };
    Ok(SequenceInput {
        name: entry.name.clone(),
        num_frames: entry.num_frames,
        gt,
        results,
        gt_origin: Some(gt_origin),
        results_origin: Some(results_origin),
    })
}

/// Every mask of `records` is of the sequence's size (its seqinfo's `imWidth` × `imHeight`),
/// refused naming the file and line otherwise: TrackEval would score masks of another size
/// against each other without a word, though they cannot be of this video.
fn check_mask_sizes(records: &[Record], origin: &Origin, entry: &SeqEntry) -> Result<(), IoError> {
    let Some((w, h)) = entry.image_size else {
        return Ok(());
    };
    for (k, r) in records.iter().enumerate() {
        if let Some(m) = r.mask.as_ref().filter(|m| (m.width, m.height) != (w, h)) {
            return Err(IoError::Invalid {
                file: origin.file.clone(),
                line: origin.lines.get(k).copied().unwrap_or(0),
                message: format!(
                    "a {}x{} mask in sequence {}, whose frames are {w}x{h} ({}): masks must be \
                     of the frame's size",
                    m.width,
                    m.height,
                    entry.name,
                    entry.seqinfo_file.display()
                ),
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seqmap_and_lines() {
        assert_eq!(
            parse_seqmap("name\nA\n\nB,extra\r\n"),
            vec!["A".to_string(), "B".to_string()]
        );
        assert_eq!(record_lines("1\n\n  \r\n2\n"), vec![1, 4]);
    }
}
