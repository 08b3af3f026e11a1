//! A whole sequence from files to a results file: what `shapetrack track` runs, and the
//! Python package's batch runs too (one code path, so their outputs are equal bit for bit).
//! The online tracker over a detection file, and with `offline`, then the offline pass
//! (Kalman trajectory re-linker and gap filling).
//!
//! Detections come from a MOTChallenge `det.txt` (comma-separated numbers, boxes) or a MOTS
//! txt (space-separated, six fields, the sixth an RLE mask), told apart by the first line.
//! Frames, when given, are decoded lazily one at a time from the image folder (offline, only
//! each track's first and last appearance is kept, as a small crop).
//!
//! MOT and MOTS text cannot say a shape was filled in; `--format coco` (COCO-video JSON, with
//! its per-frame `interpolated` list) and `--format cvat` (CVAT XML, `keyframe="0"`) can.

mod input;
mod output;

use crate::frame::{Detection, Frame, Mask, TrackedShape};
use crate::io::motchallenge::{parse_mot, parse_mots, write_mot, write_mots, SeqInfo};
use crate::io::scalabel::{self, write_scalabel, Categories};
use crate::io::{
    image_files, read_text, strip_bom, write_text, AtomicFile, IoError, PackedRle, Record, Rle,
};
use crate::track::offline::{OfflineConfig, OfflineTracker, Phase, RleHistory};
use crate::track::usable::RunData;
use crate::track::{detections_by_frame, to_records, Config, Preset, Tracker};
use input::{
    check_mask_size, is_json, is_mots, line_of, open_lines, scalabel_detections, scan, Groups,
};
use output::{boxes_as_masks, coco, cvat, task_name, OutCtx, Sink, Tally, WRITE_CHUNK};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Output file formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
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

/// What one run reads and writes: the flags of `shapetrack track`, as fields.
#[derive(Debug, Clone, Default)]
pub struct Options {
    /// Detections: MOTChallenge det.txt (boxes), MOTS txt (masks) or Scalabel JSON (boxes or
    /// RLE masks with scores, e.g. BDD100K predictions), told apart by content.
    pub det: PathBuf,
    /// With Scalabel detections holding several videos: the one to track.
    pub video: Option<String>,
    /// Image folder (MOTChallenge `img1/`), for appearance features; optional in box mode.
    pub frames: Option<PathBuf>,
    /// `seqinfo.ini` (frame count, fps, image size). `None`: two levels above `det`, if
    /// present (see [`seqinfo_beside`]).
    pub seqinfo: Option<PathBuf>,
    /// Frames per second (overrides seqinfo; default 30): the offline re-linker's Δt = 1/fps.
    pub fps: Option<f64>,
    /// Run the offline pass (Kalman trajectory re-linker, gap filling) after the online one.
    pub offline: bool,
    /// Offline configuration file (JSON `{"online": …, "relink": …, "fill": …,
    /// "appearance": …}`); its `online` part merges over `config`.
    pub offline_config: Option<PathBuf>,
    /// Also write the joins the re-linker made (JSON), offline only.
    pub joins: Option<PathBuf>,
    /// Output file, written atomically (a temporary file renamed into place).
    pub out: PathBuf,
    /// Output format (`None`: from the extension: `.json` COCO-video, `.xml` CVAT, else MOT;
    /// or MOTS for mask input when `mots_for_masks`).
    pub format: Option<Format>,
    /// With `format: None`, mask input is written as MOTS whatever the extension (the batch
    /// runs' rule: masks are never reduced to boxes). The CLI leaves it off.
    pub mots_for_masks: bool,
    /// Tracker configuration file (JSON; missing fields take the preset's values, and a
    /// `"preset"` field in it replaces `preset`).
    pub config: Option<PathBuf>,
    /// Settings preset the configuration starts from (`None`: `masks` for MOTS masks,
    /// `default` for boxes).
    pub preset: Option<Preset>,
}

/// What a run did: the counts `shapetrack track` prints.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Frames of the sequence.
    pub frames: u32,
    /// Detection records read.
    pub detections: usize,
    /// Distinct track ids written.
    pub tracks: usize,
    /// Shapes written.
    pub shapes: usize,
    /// Shapes not taken from a detection (coasted online, filled offline).
    pub interpolated: usize,
    /// Offline only: joins made, shapes filled, coasted shapes dropped.
    pub offline: Option<(usize, usize, usize)>,
    /// Time inside the tracker (reading and writing files excluded).
    pub core: Duration,
    /// Whether the detections were masks.
    pub masks: bool,
    /// The frame rate used.
    pub fps: f64,
}

/// The error of a run: the message names the file, line or field at fault. `Send` and `Sync`
/// so a run can go on another thread (the Python package releases the GIL around it).
pub type RunError = Box<dyn std::error::Error + Send + Sync>;

/// The `seqinfo.ini` a run reads when none is given: two levels above the detection file
/// (`SEQ/det/det.txt` → `SEQ/seqinfo.ini`), when it exists.
pub fn seqinfo_beside(det: &Path) -> Option<PathBuf> {
    let p = det.parent()?.parent()?.join("seqinfo.ini");
    p.is_file().then_some(p)
}

/// Whether two paths name the same existing file (under any name: relative, absolute,
/// through a link).
fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}

/// The tracker of the run: online alone, or inside the offline one.
enum Runner {
    Online(Box<Tracker>),
    /// Masks kept as RLE until the offline pass: a long video's bitmaps never sit in memory.
    Offline(Box<OfflineTracker<RleHistory>>),
}

impl Runner {
    fn frame(&self) -> u32 {
        match self {
            Runner::Online(t) => t.frame(),
            Runner::Offline(t) => t.frames(),
        }
    }

    fn skip_idle(&mut self, n: u32) -> u32 {
        match self {
            Runner::Online(t) => t.skip_idle(n),
            Runner::Offline(t) => t.skip_idle(n),
        }
    }

    /// One frame; the online shapes it reported (the offline tracker keeps its own).
    fn update(
        &mut self,
        frame: Option<&Frame<'_>>,
        dets: &[Detection],
    ) -> Result<Vec<TrackedShape>, RunError> {
        Ok(match self {
            Runner::Online(t) => t.update(frame, dets)?,
            Runner::Offline(t) => {
                t.push_frame(frame, dets)?;
                Vec::new()
            }
        })
    }
}

/// Tracks one sequence and writes its results file; `on_phase` hears each offline phase as
/// it starts. Everything is checked before the output is created (an output that is one of
/// the inputs is refused), and the output appears whole or not at all.
pub fn run(args: &Options, on_phase: &mut dyn FnMut(Phase)) -> Result<Summary, RunError> {
    let det_name = args.det.display().to_string();
    // The seqinfo found beside the detections is read as much as one given: it is an input
    // too, and never written over.
    let seqinfo_path = args.seqinfo.clone().or_else(|| seqinfo_beside(&args.det));
    let inputs = [
        Some(&args.det),
        args.config.as_ref(),
        args.offline_config.as_ref(),
        seqinfo_path.as_ref(),
    ];
    for input in inputs.into_iter().flatten() {
        for out in std::iter::once(&args.out).chain(args.joins.as_ref()) {
            if same_file(out, input) {
                return Err(format!(
                    "{} is an input of this run: write the output somewhere else",
                    out.display()
                )
                .into());
            }
        }
    }
    // Told apart by the first non-blank text; JSON is read whole, text files line by line.
    let head = {
        let mut lines = open_lines(&args.det)?;
        let mut head = String::new();
        while let Some(l) = line_of(lines.next(), &args.det)? {
            if !strip_bom(&l).trim().is_empty() {
                head = l;
                break;
            }
        }
        head
    };
    // A JSON file is parsed before anything depends on whether it holds masks: that is read
    // from its records, not guessed from its text (a `"rle": null` is no mask, and a mask
    // tracked as a box would be written as nothing).
    let scalabel_input = if is_json(&head) {
        Some(scalabel_detections(
            &read_text(&args.det)?,
            &det_name,
            args.video.as_deref(),
        )?)
    } else {
        None
    };
    // Scalabel masks are tracked like MOTS masks.
    let mots = match &scalabel_input {
        Some((_, recs, _)) => recs.iter().any(|r| r.mask.is_some()),
        None => is_mots(&head),
    };
    // Masks get the mask preset (appearance, amodal completion, re-identification by colour
    // and SIFT when frames are given); a JSON config fills its missing fields from it too.
    let preset = args
        .preset
        .unwrap_or(if mots { Preset::Masks } else { Preset::Default });
    // A --config file may name its own "preset", which then replaces this one.
    let online_config = match &args.config {
        Some(p) => {
            let bad = |e: serde_json::Error| format!("{}: {e}", p.display());
            let value: serde_json::Value = serde_json::from_str(&read_text(p)?).map_err(bad)?;
            Config::from_settings(preset, &value).map_err(bad)?
        }
        None => preset.config(),
    };
    let mut offline_config = OfflineConfig {
        online: online_config.clone(),
        ..OfflineConfig::default()
    };
    if let Some(p) = &args.offline_config {
        let bad = |e: serde_json::Error| format!("{}: {e}", p.display());
        let value: serde_json::Value = serde_json::from_str(&read_text(p)?).map_err(bad)?;
        let from_file = OfflineConfig::from_value(value.clone()).map_err(bad)?;
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
    // Settings that make tracking impossible are refused here, naming the file they came from
    // as well as the field (the tracker's own check knows only the field).
    // Weights that the run's data cannot feed (mask terms with boxes) are as impossible.
    let data = RunData {
        masks: mots,
        images: args.frames.is_some(),
    };
    if let Some(p) = &args.config {
        online_config
            .validate_for(data)
            .map_err(|e| format!("{}: {e}", p.display()))?;
    }
    if let Some(p) = &args.offline_config {
        let bad = |e: &dyn std::fmt::Display| format!("{}: {e}", p.display());
        offline_config.validate().map_err(|e| bad(&e))?;
        offline_config
            .online
            .validate_for(data)
            .map_err(|e| bad(&e))?;
    }

    let seqinfo = seqinfo_path.as_deref().map(SeqInfo::read).transpose()?;
    let seq_size = seqinfo
        .as_ref()
        .filter(|s| s.im_width > 0 && s.im_height > 0)
        .map(|s| (s.im_width, s.im_height));

    let mut scalabel_video: Option<(String, Categories)> = None;
    let (mut groups, num_records, first_rec, last_rec, mask_size) = match scalabel_input {
        Some((video, recs, cats)) => {
            scalabel_video = Some((video, cats));
            // Every mask of the frame's size: the seqinfo's, or else the first mask's.
            let mask = recs
                .iter()
                .find_map(|r| r.mask.as_ref().map(|m| (m.width, m.height)));
            for r in &recs {
                check_mask_size(r, seq_size.or(mask), seq_size.is_some(), &det_name, 0)?;
            }
            let first = recs.iter().map(|r| r.frame).min();
            let last = recs.iter().map(|r| r.frame).max().unwrap_or(0);
            let n = recs.len();
            (Groups::loaded(recs), n, first, last, mask)
        }
        None => {
            let sc = scan(&args.det, mots, seq_size)?;
            let groups = if sc.sorted {
                Groups::Stream {
                    lines: open_lines(&args.det)?,
                    path: args.det.clone(),
                    mots,
                    ln: 0,
                    pending: None,
                }
            } else {
                let text = read_text(&args.det)?;
                let recs = if mots {
                    parse_mots(&text, &det_name)?
                } else {
                    parse_mot(&text, &det_name)?
                };
                Groups::loaded(recs)
            };
            (
                groups,
                sc.records,
                sc.first_frame,
                sc.last_frame,
                sc.mask_size,
            )
        }
    };

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
    let first_frame = first_rec.unwrap_or(1).min(1);
    let num_frames = match &seqinfo {
        Some(s) => s.seq_length.max(last_rec + 1 - first_frame),
        None => last_rec + 1 - first_frame,
    };
    let image_size = seq_size.or(mask_size);
    let images = args.frames.as_deref().map(image_files).transpose()?;
    if let (Some(imgs), Some(dir)) = (&images, &args.frames) {
        if (imgs.len() as u64) < num_frames as u64 {
            return Err(format!(
                "{} holds {} images (.jpg/.png) but the sequence has {num_frames} frames: \
                 appearance needs one image per frame",
                dir.display(),
                imgs.len()
            )
            .into());
        }
    }

    // Online: the tracker alone. Offline: the same tracker inside the offline one, which keeps
    // appearance snapshots while frames stream through and runs the re-linker at the end.
    let mut runner = if args.offline {
        let online = Tracker::new(offline_config.online.clone())?;
        let t = OfflineTracker::<RleHistory>::with_history(online, offline_config, fps)?;
        Runner::Offline(Box::new(match image_size {
            Some((w, h)) => t.with_image_size(w, h),
            None => t,
        }))
    } else {
        let t = Tracker::new(online_config)?;
        Runner::Online(Box::new(match image_size {
            Some((w, h)) => t.with_image_size(w, h),
            None => t,
        }))
    };

    let format =
        args.format
            .unwrap_or_else(|| match args.out.extension().and_then(|e| e.to_str()) {
                Some("json") => Format::Coco,
                Some("xml") => Format::Cvat,
                _ if mots && args.mots_for_masks => Format::Mots,
                _ => Format::Mot,
            });
    if format == Format::Mots && image_size.is_none() {
        return Err("MOTS output needs the image size: give --seqinfo or mask input".into());
    }
    // Online MOT/MOTS output is written while tracking, so memory stays flat over any length.
    let mut sink = match (args.offline, format) {
        (false, Format::Mot | Format::Mots) => Sink::Stream {
            out: AtomicFile::create(&args.out)?,
            pending: BTreeMap::new(),
            mots: format == Format::Mots,
        },
        _ => Sink::Collect(Vec::new()),
    };
    let mut tally = Tally::default();
    let mut core = Duration::ZERO;
    // Runs the tracker over frames (file numbering) from the runner's next frame up to
    // `frame` (exclusive) that have no detections; with no live track they are skipped.
    let end = first_frame as u64 + num_frames as u64;
    let step = |runner: &mut Runner,
                sink: &mut Sink,
                tally: &mut Tally,
                core: &mut Duration,
                k: u32,
                dets: &[Detection]|
     -> Result<(), RunError> {
        let img = match images.as_ref().and_then(|v| v.get(k as usize)) {
            Some(p) => Some(crate::io::read_rgb(p)?),
            None => None,
        };
        let frame = img
            .as_ref()
            .map(|i| Frame::rgb(i.as_raw(), i.width(), i.height()))
            .transpose()?;
        let t0 = Instant::now();
        let shapes = runner.update(frame.as_ref(), dets)?;
        *core += t0.elapsed();
        tally.add(&shapes);
        let ctx = OutCtx {
            out: &args.out,
            first_frame,
            image_size,
            now: runner.frame(),
        };
        sink.push(shapes, &ctx)?;
        Ok(())
    };
    let empty_until = |runner: &mut Runner,
                       sink: &mut Sink,
                       tally: &mut Tally,
                       core: &mut Duration,
                       stop: u64|
     -> Result<(), RunError> {
        loop {
            // Index (0-based) of the next frame the runner will see.
            let k = runner.frame() as u64;
            let left = stop.saturating_sub(first_frame as u64 + k);
            if left == 0 {
                return Ok(());
            }
            if runner.skip_idle(left.min(u32::MAX as u64) as u32) == 0 {
                step(runner, sink, tally, core, k as u32, &[])?;
            }
        }
    };
    while let Some((fr, recs)) = groups.next_group()? {
        if (fr as u64) < first_frame as u64 + runner.frame() as u64 {
            continue; // cannot happen: groups come in frame order from first_frame
        }
        empty_until(&mut runner, &mut sink, &mut tally, &mut core, fr as u64)?;
        let dets = detections_by_frame(&recs, fr, 1).pop().unwrap_or_default();
        let k = fr - first_frame;
        step(&mut runner, &mut sink, &mut tally, &mut core, k, &dets)?;
    }
    empty_until(&mut runner, &mut sink, &mut tally, &mut core, end)?;

    let mut offline_counts = None;
    let mut shapes = match sink {
        Sink::Stream { .. } => {
            let ctx = OutCtx {
                out: &args.out,
                first_frame,
                image_size,
                now: runner.frame(),
            };
            sink.flush_before(u32::MAX, &ctx)?;
            if let Sink::Stream { out, .. } = sink {
                out.commit()?;
            }
            None
        }
        Sink::Collect(v) => Some(v),
    };
    // The offline result's masks, packed, aligned with `shapes` (see `finish_packed`).
    let mut packed: Option<Vec<Option<PackedRle>>> = None;
    if let Runner::Offline(t) = runner {
        let t0 = Instant::now();
        let mut last_phase = None;
        let (res, masks) = t.finish_packed(|p| {
            // Once per phase, so long runs can show where they are.
            if last_phase != Some(p.phase) && p.phase != Phase::Done {
                on_phase(p.phase);
                last_phase = Some(p.phase);
            }
        })?;
        core += t0.elapsed();
        offline_counts = Some((res.joins.len(), res.filled, res.coasted_dropped));
        if let Some(p) = &args.joins {
            write_text(p, &serde_json::to_string_pretty(&res.joins)?)?;
        }
        tally = Tally::default();
        tally.add(&res.shapes);
        packed = Some(masks);
        shapes = Some(res.shapes);
    }
    if let Some(mut shapes) = shapes {
        let mots = format == Format::Mots;
        // Records of some shapes, their masks unpacked from `packed` when given.
        let records_of =
            |shapes: &mut [TrackedShape], masks: Option<&mut [Option<PackedRle>]>| -> Vec<Record> {
                let Some(masks) = masks else {
                    if mots {
                        boxes_as_masks(shapes);
                    }
                    return to_records(shapes, first_frame, image_size);
                };
                for s in shapes.iter_mut() {
                    s.mask = None;
                }
                let mut records = to_records(shapes, first_frame, image_size);
                for ((r, s), m) in records.iter_mut().zip(shapes.iter()).zip(masks) {
                    r.mask = match m.take() {
                        Some(p) => Some(p.unpack()),
                        // MOTS has no box-only form (see `boxes_as_masks`).
                        None => image_size
                            .filter(|_| mots)
                            .map(|(w, h)| Rle::from_mask(&Mask::from_bbox(&s.bbox), w, h)),
                    };
                }
                records
            };
        match (format, packed) {
            (Format::Mot | Format::Mots, Some(mut packed)) => {
                // The offline result is in (frame, id) order: written a slice at a time, so
                // its masks are never all unpacked at once.
                let mut out = AtomicFile::create(&args.out)?;
                for (sh, ms) in shapes
                    .chunks_mut(WRITE_CHUNK)
                    .zip(packed.chunks_mut(WRITE_CHUNK))
                {
                    let records = records_of(sh, Some(ms));
                    let text = if mots {
                        write_mots(&records)
                    } else {
                        write_mot(&records)
                    };
                    use std::io::Write as _;
                    out.write_all(text.as_bytes())
                        .map_err(|source| IoError::Io {
                            file: args.out.display().to_string(),
                            source,
                        })?;
                }
                out.commit()?;
            }
            (_, mut packed) => {
                let out_records = records_of(&mut shapes, packed.as_deref_mut());
                let body = match format {
                    Format::Mot => write_mot(&out_records),
                    Format::Mots => write_mots(&out_records),
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
            }
        }
    }

    Ok(Summary {
        frames: num_frames,
        detections: num_records,
        tracks: tally.ids.len(),
        shapes: tally.shapes,
        // Shapes not taken from a detection: coasted online over a missed detection, or
        // filled offline. MOT text cannot mark them; the count says how many there are.
        interpolated: tally.interpolated,
        offline: offline_counts,
        core,
        masks: mots,
        fps,
    })
}

#[cfg(test)]
#[path = "from_files_tests.rs"]
mod tests;
