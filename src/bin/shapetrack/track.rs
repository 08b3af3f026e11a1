//! `shapetrack track`: run the online tracker over a detection file and write the tracks;
//! with `--offline`, then the offline pass (Kalman trajectory re-linker and gap filling).
//!
//! Detections come from a MOTChallenge `det.txt` (comma-separated numbers, boxes) or a MOTS
//! txt (space-separated, six fields, the sixth an RLE mask), told apart by the first line.
//! Frames, when given, are decoded lazily one at a time from the image folder (offline, only
//! each track's first and last appearance is kept, as a small crop).
//!
//! MOT and MOTS text cannot say a shape was filled in; `--format coco` (COCO-video JSON, with
//! its per-frame `interpolated` list) and `--format cvat` (CVAT XML, `keyframe="0"`) can.

use shapetrack::frame::{Frame, Mask, TrackedShape};
use shapetrack::io::coco_video::{write_coco_video, Category, VideoInfo};
use shapetrack::io::cvat::{write_cvat, CvatMeta};
use shapetrack::io::motchallenge::{parse_mot, parse_mots, write_mot, write_mots, SeqInfo};
use shapetrack::io::scalabel::{self, parse_scalabel, split_videos, write_scalabel, Categories};
use shapetrack::io::{read_text, write_text, IoError, Record};
use shapetrack::track::offline::{OfflineConfig, OfflineTracker, Phase};
use shapetrack::track::{detections_by_frame, to_records, Config, Tracker};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Tracker settings presets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Preset {
    /// `Config::default()`: tuned on MOTChallenge boxes.
    Default,
    /// `Config::masks()`: instance masks with frames (appearance, re-identification by colour
    /// and SIFT, amodal completion, fragment merging, coasting).
    Masks,
}

/// Output file formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// Scalabel JSON (BDD100K): a list of frames with labels (ids as strings, scores kept).
    Scalabel,
    /// MOTChallenge txt: `frame,id,x,y,w,h,conf,-1,-1,-1`.
    Mot,
    /// MOTS txt: `frame id class height width rle`.
    Mots,
    /// COCO-video JSON (one annotation per track, with per-frame `interpolated` flags).
    Coco,
    /// CVAT for video 1.1 XML (filled-in shapes are written with `keyframe="0"`).
    Cvat,
}

/// Arguments of `shapetrack track`.
#[derive(clap::Args)]
pub struct Args {
    /// Detections: MOTChallenge det.txt (boxes), MOTS txt (masks) or Scalabel JSON (boxes or
    /// RLE masks with scores, e.g. BDD100K predictions), told apart by content.
    #[arg(long)]
    pub det: PathBuf,
    /// With Scalabel detections holding several videos: the one to track.
    #[arg(long)]
    pub video: Option<String>,
    /// Image folder (MOTChallenge `img1/`), for appearance features; optional in box mode.
    #[arg(long)]
    pub frames: Option<PathBuf>,
    /// `seqinfo.ini` (frame count, fps, image size). Default: two levels above --det, if present.
    #[arg(long)]
    pub seqinfo: Option<PathBuf>,
    /// Frames per second (overrides seqinfo; default 30): the offline re-linker's Δt = 1/fps.
    #[arg(long)]
    pub fps: Option<f64>,
    /// Run the offline pass (Kalman trajectory re-linker, gap filling) after the online one.
    #[arg(long)]
    pub offline: bool,
    /// Offline configuration (JSON `{"online": …, "relink": …, "fill": …, "appearance": …}`;
    /// missing fields take their defaults). Its `online` part merges over `--config` (or over
    /// the preset for the input when `--config` is not given).
    #[arg(long, requires = "offline")]
    pub offline_config: Option<PathBuf>,
    /// Also write the joins the re-linker made (JSON list of `{slave, master, slave_last,
    /// master_first, cost, connections}`, online ids and frames).
    #[arg(long, requires = "offline")]
    pub joins: Option<PathBuf>,
    /// Output file.
    #[arg(long)]
    pub out: PathBuf,
    /// Output format (default: from the extension: `.json` COCO-video, `.xml` CVAT, else MOT).
    #[arg(long, value_enum)]
    pub format: Option<Format>,
    /// Tracker configuration (JSON; missing fields take the preset's values).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Settings preset the configuration starts from (default: `masks` for MOTS masks,
    /// `default` for boxes).
    #[arg(long, value_enum)]
    pub preset: Option<Preset>,
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

/// Whether a detection file is JSON (Scalabel): its first non-blank character opens a list or
/// an object.
fn is_json(text: &str) -> bool {
    matches!(text.trim_start().chars().next(), Some('[' | '{'))
}

/// The detections of one video of a Scalabel file (`video`, or the file's only one), its name
/// and the category table its classes refer to.
fn scalabel_detections(
    text: &str,
    file: &str,
    video: Option<&str>,
) -> Result<(String, Vec<Record>, Categories), Box<dyn std::error::Error>> {
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
    let det_name = args.det.display().to_string();
    let text = read_text(&args.det)?;
    let scalabel_input = is_json(&text);
    // Scalabel masks are tracked like MOTS masks.
    let mots = if scalabel_input {
        text.contains("\"rle\"") && text.contains("\"counts\"")
    } else {
        is_mots(&text)
    };
    // Masks get the mask preset (appearance, amodal completion, re-identification by colour
    // and SIFT when frames are given); a JSON config fills its missing fields from it too.
    let preset = args
        .preset
        .unwrap_or(if mots { Preset::Masks } else { Preset::Default });
    let base = match preset {
        Preset::Masks => Config::masks(),
        Preset::Default => Config::default(),
    };
    let online_config = match &args.config {
        Some(p) => base
            .overlay_json(&read_text(p)?)
            .map_err(|e| format!("{}: {e}", p.display()))?,
        None => base,
    };
    let mut offline_config = OfflineConfig {
        online: online_config.clone(),
        ..OfflineConfig::default()
    };
    if let Some(p) = &args.offline_config {
        let bad = |e: serde_json::Error| format!("{}: {e}", p.display());
        let value: serde_json::Value = serde_json::from_str(&read_text(p)?).map_err(bad)?;
        let from_file: OfflineConfig = serde_json::from_value(value.clone()).map_err(bad)?;
        // The file's `online` section, when present, merges over --config (or the preset);
        // without one, the online pass is the one --config (or the preset) describes.
        let online = match value.get("online") {
            Some(section) => online_config.overlay(section).map_err(bad)?,
            None => online_config.clone(),
        };
        offline_config = OfflineConfig {
            online,
            ..from_file
        };
    }
    let mut scalabel_video: Option<(String, Categories)> = None;
    let records = if scalabel_input {
        let (video, recs, cats) = scalabel_detections(&text, &det_name, args.video.as_deref())?;
        scalabel_video = Some((video, cats));
        recs
    } else if mots {
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
    // The online tracker scales its time-measuring frame counts to the video's rate, unless
    // the config says otherwise.
    let known_fps = args.fps.or(seqinfo.as_ref().map(|s| s.frame_rate));
    let mut online_config = online_config;
    if online_config.frame_rate.is_none() {
        online_config.frame_rate = known_fps;
    }
    if offline_config.online.frame_rate.is_none() {
        offline_config.online.frame_rate = known_fps;
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

    // Online: the tracker alone. Offline: the same tracker inside the offline one, which keeps
    // appearance snapshots while frames stream through and runs the re-linker at the end.
    let mut online = if args.offline {
        None
    } else {
        let t = Tracker::new(online_config)?;
        Some(match image_size {
            Some((w, h)) => t.with_image_size(w, h),
            None => t,
        })
    };
    let mut offline = if args.offline {
        let t = OfflineTracker::new(offline_config, fps)?;
        Some(match image_size {
            Some((w, h)) => t.with_image_size(w, h),
            None => t,
        })
    } else {
        None
    };
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
        if let Some(t) = online.as_mut() {
            shapes.extend(t.update(frame.as_ref(), dets)?);
        } else if let Some(t) = offline.as_mut() {
            t.push_frame(frame.as_ref(), dets)?;
        }
        core += t0.elapsed();
    }
    let mut summary = String::new();
    if let Some(t) = offline {
        let t0 = Instant::now();
        let mut last_phase = None;
        let res = t.finish(|p| {
            // One line per phase on stderr, so long runs show where they are.
            if last_phase != Some(p.phase) && p.phase != Phase::Done {
                eprintln!("offline: {:?}", p.phase);
                last_phase = Some(p.phase);
            }
        })?;
        core += t0.elapsed();
        summary = format!(" joins={} filled={}", res.joins.len(), res.filled);
        if let Some(p) = &args.joins {
            write_text(p, &serde_json::to_string_pretty(&res.joins)?)?;
        }
        shapes = res.shapes;
    }
    // Shapes not taken from a detection: coasted online over a missed detection, or filled
    // offline. MOT text cannot mark them; the count says how many there are.
    let interpolated = shapes.iter().filter(|s| s.interpolated).count();
    summary.push_str(&format!(" interpolated={interpolated}"));

    let format =
        args.format
            .unwrap_or_else(|| match args.out.extension().and_then(|e| e.to_str()) {
                Some("json") => Format::Coco,
                Some("xml") => Format::Cvat,
                _ => Format::Mot,
            });
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
        Format::Coco => coco(&out_records, num_frames, image_size)?,
        Format::Cvat => cvat(&out_records, num_frames, image_size, &args.det)?,
        Format::Scalabel => {
            let (video, cats) = scalabel_video
                .clone()
                .unwrap_or_else(|| (task_name(&args.det), Categories::default()));
            write_scalabel(&scalabel::from_records(
                &out_records,
                &video,
                num_frames,
                None,
                &cats,
            ))?
        }
    };
    write_text(&args.out, &body)?;

    let ids: std::collections::HashSet<u64> = shapes.iter().map(|s| s.id).collect();
    let secs = core.as_secs_f64();
    println!(
        "{}: frames={} detections={} tracks={} shapes={}{} core_fps={:.0} ({} mode, {}, fps {})",
        args.det.display(),
        num_frames,
        records.len(),
        ids.len(),
        shapes.len(),
        summary,
        if secs > 0.0 {
            num_frames as f64 / secs
        } else {
            f64::INFINITY
        },
        if mots { "mask" } else { "box" },
        if args.offline { "offline" } else { "online" },
        fps
    );
    Ok(())
}

/// A label name per class present (`object` for the unknown class -1).
fn class_names(records: &[Record]) -> BTreeMap<i32, String> {
    records
        .iter()
        .map(|r| {
            let name = if r.class < 0 {
                "object".to_string()
            } else {
                format!("class{}", r.class)
            };
            (r.class, name)
        })
        .collect()
}

fn task_name(det: &Path) -> String {
    det.parent()
        .and_then(Path::parent)
        .and_then(Path::file_name)
        .or_else(|| det.file_stem())
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "sequence".to_string())
}

/// COCO-video (ground-truth form, so every track keeps its id) of one video.
fn coco(
    records: &[Record],
    num_frames: u32,
    image_size: Option<(u32, u32)>,
) -> Result<String, IoError> {
    let (width, height) = image_size.unwrap_or((0, 0));
    let video = VideoInfo {
        id: 1,
        width,
        height,
        length: num_frames,
        file_names: Vec::new(),
    };
    let categories: Vec<Category> = class_names(records)
        .into_iter()
        .map(|(id, name)| Category { id, name })
        .collect();
    write_coco_video(&[(video, records)], &categories)
}

/// CVAT for video 1.1 XML of one task.
fn cvat(
    records: &[Record],
    num_frames: u32,
    image_size: Option<(u32, u32)>,
    det: &Path,
) -> Result<String, IoError> {
    let (width, height) = image_size.unwrap_or((0, 0));
    let meta = CvatMeta {
        name: task_name(det),
        size: num_frames,
        width,
        height,
    };
    write_cvat(records, &meta, &class_names(records))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_config_overrides_only_its_fields() {
        let base = Config::masks();
        let c = base
            .overlay_json(r#"{"max_lost": 7, "terms": {"iou": {"weight": 2.0}}}"#)
            .unwrap();
        assert_eq!(c.max_lost, 7);
        assert_eq!(c.terms.iou.weight, 2.0);
        assert_eq!(c.terms.ioa, base.terms.ioa);
        assert_eq!(c.coast_frames, base.coast_frames);
        assert!(base.overlay_json(r#"{"max_lots": 7}"#).is_err());
        assert!(base.overlay_json("not json").is_err());
    }
}
