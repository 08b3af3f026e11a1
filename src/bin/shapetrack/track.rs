//! `shapetrack track`: run the online tracker over a detection file and write the tracks.
//!
//! Detections come from a MOTChallenge `det.txt` (comma-separated numbers, boxes) or a MOTS
//! txt (space-separated, six fields, the sixth an RLE mask), told apart by the first line.
//! Frames, when given, are decoded lazily one at a time from the image folder.

use shapetrack::frame::{Frame, Mask, TrackedShape};
use shapetrack::io::motchallenge::{parse_mot, parse_mots, write_mot, write_mots, SeqInfo};
use shapetrack::io::{read_text, write_text, IoError};
use shapetrack::track::{detections_by_frame, to_records, Config, Tracker};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Output file formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// MOTChallenge txt: `frame,id,x,y,w,h,conf,-1,-1,-1`.
    Mot,
    /// MOTS txt: `frame id class height width rle`.
    Mots,
}

/// Arguments of `shapetrack track`.
#[derive(clap::Args)]
pub struct Args {
    /// Detections: MOTChallenge det.txt (boxes) or MOTS txt (masks).
    #[arg(long)]
    pub det: PathBuf,
    /// Image folder (MOTChallenge `img1/`), for appearance features; optional in box mode.
    #[arg(long)]
    pub frames: Option<PathBuf>,
    /// `seqinfo.ini` (frame count, fps, image size). Default: two levels above --det, if present.
    #[arg(long)]
    pub seqinfo: Option<PathBuf>,
    /// Frames per second (overrides seqinfo; default 30). Used by the offline re-linker.
    #[arg(long)]
    pub fps: Option<f64>,
    /// Run the offline pass (Kalman trajectory re-linker) after the online one.
    #[arg(long)]
    pub offline: bool,
    /// Output file.
    #[arg(long)]
    pub out: PathBuf,
    /// Output format (default: MOT for `.txt`).
    #[arg(long, value_enum)]
    pub format: Option<Format>,
    /// Tracker configuration (JSON; missing fields take their defaults).
    #[arg(long)]
    pub config: Option<PathBuf>,
}

/// Whether a detection file is MOTS: its first line has six whitespace-separated fields, no
/// comma, and a sixth field that is not a number (an RLE string).
fn is_mots(text: &str) -> bool {
    let Some(line) = text.lines().map(str::trim).find(|l| !l.is_empty()) else {
        return false;
    };
    let f: Vec<&str> = line.split_whitespace().collect();
    !line.contains(',') && f.len() == 6 && f[5].parse::<f64>().is_err()
}

/// The image files of a folder, sorted by name (MOTChallenge names them by frame number).
fn list_images(dir: &Path) -> Result<Vec<PathBuf>, IoError> {
    let rd = std::fs::read_dir(dir).map_err(|source| IoError::Io {
        file: dir.display().to_string(),
        source,
    })?;
    let mut files: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| matches!(e.to_ascii_lowercase().as_str(), "jpg" | "jpeg" | "png"))
        })
        .collect();
    files.sort();
    Ok(files)
}

fn load_rgb(path: &Path) -> Result<image::RgbImage, IoError> {
    image::open(path)
        .map(|i| i.to_rgb8())
        .map_err(|e| IoError::Image {
            file: path.display().to_string(),
            message: e.to_string(),
        })
}

/// Runs the subcommand.
pub fn run(args: Args) -> crate::CliResult {
    if args.offline {
        return Err(
            "the offline pass (--offline, Kalman trajectory re-linker) is not available \
                    yet; run without --offline for online tracking"
                .into(),
        );
    }
    let config = match &args.config {
        Some(p) => {
            Config::from_json(&read_text(p)?).map_err(|e| format!("{}: {e}", p.display()))?
        }
        None => Config::default(),
    };
    let det_name = args.det.display().to_string();
    let text = read_text(&args.det)?;
    let mots = is_mots(&text);
    let records = if mots {
        parse_mots(&text, &det_name)?
    } else {
        parse_mot(&text, &det_name)?
    };

    let seqinfo_path = args.seqinfo.clone().or_else(|| {
        let p = args.det.parent()?.parent()?.join("seqinfo.ini");
        p.is_file().then_some(p)
    });
    let seqinfo = seqinfo_path.as_deref().map(SeqInfo::read).transpose()?;
    let fps = args
        .fps
        .or(seqinfo.as_ref().map(|s| s.frame_rate))
        .unwrap_or(30.0);
    if !(fps.is_finite() && fps > 0.0) {
        return Err(format!("--fps must be a positive number, got {fps}").into());
    }

    // MOTS files may number frames from 0 (KITTI-MOTS); the tracker counts from 1.
    let first_frame = records.iter().map(|r| r.frame).min().unwrap_or(1).min(1);
    let last_frame = records.iter().map(|r| r.frame).max().unwrap_or(0);
    let num_frames = match &seqinfo {
        Some(s) => s.seq_length.max(last_frame + 1 - first_frame),
        None => last_frame + 1 - first_frame,
    };
    let per_frame = detections_by_frame(&records, first_frame, num_frames);

    let image_size = seqinfo
        .as_ref()
        .map(|s| (s.im_width, s.im_height))
        .or_else(|| {
            records
                .iter()
                .find_map(|r| r.mask.as_ref().map(|m| (m.width, m.height)))
        });
    let images = args.frames.as_deref().map(list_images).transpose()?;

    let mut tracker = Tracker::new(config)?;
    let mut shapes: Vec<TrackedShape> = Vec::new();
    let mut core = Duration::ZERO;
    for (k, dets) in per_frame.iter().enumerate() {
        let img = match images.as_ref().and_then(|v| v.get(k)) {
            Some(p) => Some(load_rgb(p)?),
            None => None,
        };
        let frame = img
            .as_ref()
            .map(|i| Frame::rgb(i.as_raw(), i.width(), i.height()))
            .transpose()?;
        let t0 = Instant::now();
        let out = tracker.update(frame.as_ref(), dets)?;
        core += t0.elapsed();
        shapes.extend(out);
    }

    let format = args.format.unwrap_or(Format::Mot);
    if format == Format::Mots {
        for s in &mut shapes {
            if s.mask.is_none() {
                // Boxes are the degenerate case of masks: write the box as a filled mask.
                s.mask = Some(Mask::from_bbox(&s.bbox));
            }
        }
    }
    let out_records = to_records(&shapes, first_frame, image_size);
    let body = match format {
        Format::Mot => write_mot(&out_records),
        Format::Mots => {
            if image_size.is_none() {
                return Err(
                    "MOTS output needs the image size: give --seqinfo or mask input".into(),
                );
            }
            write_mots(&out_records)
        }
    };
    write_text(&args.out, &body)?;

    let ids: std::collections::HashSet<u64> = shapes.iter().map(|s| s.id).collect();
    let secs = core.as_secs_f64();
    println!(
        "{}: frames={} detections={} tracks={} shapes={} core_fps={:.0} ({} mode, fps {})",
        args.det.display(),
        num_frames,
        records.len(),
        ids.len(),
        shapes.len(),
        if secs > 0.0 {
            num_frames as f64 / secs
        } else {
            f64::INFINITY
        },
        if mots { "mask" } else { "box" },
        fps
    );
    Ok(())
}
