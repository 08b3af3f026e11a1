//! `shapetrack track`: run the online tracker over a detection file and write the tracks;
//! with `--offline`, then the offline pass (Kalman trajectory re-linker and gap filling).
//!
//! The run itself is the library's [`shapetrack::track::from_files`] (the Python package's
//! batch calls the same code, so their outputs are equal bit for bit); this module is its
//! flags and its summary line.
//!
//! MOT and MOTS text cannot say a shape was filled in; `--format coco` (COCO-video JSON, with
//! its per-frame `interpolated` list) and `--format cvat` (CVAT XML, `keyframe="0"`) can.

use shapetrack::track::from_files::{self, Format, Options};
use shapetrack::track::Preset;
use std::path::PathBuf;

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
    /// Tracker configuration (JSON; missing fields take the preset's values, and a
    /// `"preset"` field in it replaces `--preset`).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Settings preset the configuration starts from (default: `masks` for MOTS masks,
    /// `default` for boxes).
    #[arg(long, value_enum)]
    pub preset: Option<Preset>,
}

/// Runs the subcommand.
pub fn run(args: Args) -> crate::CliResult {
    // Never write over an input: a typo in --out must not destroy the detections.
    if let Some(joins) = &args.joins {
        crate::outputs::refuse_same_output("--out", &args.out, "--joins", joins)?;
    }
    let opts = Options {
        det: args.det,
        video: args.video,
        frames: args.frames,
        seqinfo: args.seqinfo,
        fps: args.fps,
        offline: args.offline,
        offline_config: args.offline_config,
        joins: args.joins,
        out: args.out,
        format: args.format,
        mots_for_masks: false,
        config: args.config,
        preset: args.preset,
    };
    // One line per offline phase on stderr, so long runs show where they are.
    let mut on_phase = |p| eprintln!("offline: {p:?}");
    let s = from_files::run(&opts, &mut on_phase).map_err(|e| e as Box<dyn std::error::Error>)?;
    let mut summary = String::new();
    if let Some((joins, filled, dropped)) = s.offline {
        summary = format!(" joins={joins} filled={filled} coasted_dropped={dropped}");
    }
    summary.push_str(&format!(" interpolated={}", s.interpolated));
    if let Some(kb) = crate::outputs::peak_memory_kb() {
        summary.push_str(&format!(" peak_mem_kb={kb}"));
    }
    let secs = s.core.as_secs_f64();
    println!(
        "{}: frames={} detections={} tracks={} shapes={}{} core_fps={:.0} ({} mode, {}, fps {})",
        opts.det.display(),
        s.frames,
        s.detections,
        s.tracks,
        s.shapes,
        summary,
        if secs > 0.0 {
            s.frames as f64 / secs
        } else {
            f64::INFINITY
        },
        if s.masks { "mask" } else { "box" },
        if opts.offline { "offline" } else { "online" },
        s.fps
    );
    Ok(())
}
