//! The grid's datasets: real trajectories from `../shared/data` and synthetic scenes, each a
//! list of [`GridSequence`]s with ground truth and, where a real detector was run, its
//! detections.
//!
//! - [`mot15`]: MOT15 train, 11 sequences (`gt/gt.txt`; real detections `det/det.txt`, the
//!   Faster R-CNN boxes published with SORT).
//! - [`sportsmot`]: SportsMOT train, 45 sequences, ground truth only. Its track ids start at
//!   0; they are renumbered from 1 on reading (`id + 1`), so every tool that reads the
//!   ground truth back sees MOTChallenge's 1-based ids.
//! - [`bdd`]: the BDD100K box-tracking sample, one driving video at 5 fps: ground truth from
//!   `track_sample_anns.json`, real detections = the boxes (with their scores) of a real
//!   tracker's output `track_predictions.json`, its ids ignored. Ground-truth boxes flagged
//!   `crowd` are left out (BDD's own evaluation ignores them rather than counting them as
//!   objects); classes are pooled, as the peers are class-agnostic.
//! - [`bdd_masks`]: the BDD100K segmentation-tracking sample: ground-truth instance masks
//!   and a real model's masks (no scores: 1.0), for mask mode without frames.
//! - [`synthetic`]: the generator's scenes with frames, visible-part masks and visibility
//!   (the pedestrian crowd's boxes amodal).

use std::path::{Path, PathBuf};

use super::GridError;
use crate::io::motchallenge::{parse_mot, SeqInfo};
use crate::io::{read_text, scalabel, Record};
use crate::synth::{Scene, SynthConfig};

/// One sequence of a dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct GridSequence {
    /// Name (unique within its dataset).
    pub name: String,
    /// Frames per second.
    pub fps: f64,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Number of frames.
    pub num_frames: u32,
    /// Ground truth (1-based frames and ids; masks when the dataset has them).
    pub gt: Vec<Record>,
    /// A real detector's output, when the dataset ships one.
    pub real_dets: Option<Vec<Record>>,
    /// The synthetic scene the frames come from (regenerated when a tracker needs pixels).
    pub synth: Option<SynthConfig>,
}

/// A named list of sequences.
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    /// Name (`mot15`, `sportsmot`, `bdd`, `bdd-masks`, `synth-<family>`).
    pub name: String,
    /// Its sequences.
    pub sequences: Vec<GridSequence>,
}

/// `../shared` beside the repository, or `$SHAPETRACK_SHARED`, or `/work/shared`.
pub fn shared_dir() -> PathBuf {
    if let Some(p) = std::env::var_os("SHAPETRACK_SHARED") {
        return PathBuf::from(p);
    }
    let beside = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared");
    if beside.is_dir() {
        beside
    } else {
        PathBuf::from("/work/shared")
    }
}

fn io(e: crate::io::IoError) -> GridError {
    GridError::Io(e)
}

fn sequence_dirs(root: &Path) -> Result<Vec<PathBuf>, GridError> {
    let rd = std::fs::read_dir(root).map_err(|source| {
        GridError::Io(crate::io::IoError::Io {
            file: root.display().to_string(),
            source,
        })
    })?;
    let mut dirs: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("seqinfo.ini").is_file())
        .collect();
    dirs.sort();
    Ok(dirs)
}

/// MOTChallenge-layout sequences under `root` (`<seq>/seqinfo.ini`, `<seq>/gt/gt.txt`, and
/// `<seq>/det/det.txt` when `with_dets`); `id_offset` is added to the ground truth's ids.
fn mot_layout(
    name: &str,
    root: &Path,
    with_dets: bool,
    id_offset: i64,
) -> Result<Dataset, GridError> {
    let mut sequences = Vec::new();
    for dir in sequence_dirs(root)? {
        let info = SeqInfo::read(&dir.join("seqinfo.ini")).map_err(io)?;
        let read = |rel: &str| -> Result<Vec<Record>, GridError> {
            let p = dir.join(rel);
            parse_mot(&read_text(&p).map_err(io)?, &p.display().to_string()).map_err(io)
        };
        let mut gt = read("gt/gt.txt")?;
        for r in &mut gt {
            r.id += id_offset;
        }
        let real_dets = if with_dets {
            Some(read("det/det.txt")?)
        } else {
            None
        };
        let seq_name = dir
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        sequences.push(GridSequence {
            name: seq_name,
            fps: info.frame_rate,
            width: info.im_width,
            height: info.im_height,
            num_frames: info.seq_length,
            gt,
            real_dets,
            synth: None,
        });
    }
    Ok(Dataset {
        name: name.to_string(),
        sequences,
    })
}

/// MOT15 train with its real detections.
pub fn mot15(shared: &Path) -> Result<Dataset, GridError> {
    mot_layout("mot15", &shared.join("data/mot15-train"), true, 0)
}

/// SportsMOT train (ground truth only; ids renumbered from 1).
pub fn sportsmot(shared: &Path) -> Result<Dataset, GridError> {
    mot_layout("sportsmot", &shared.join("data/sportsmot-train"), false, 1)
}

/// Records of a Scalabel file, crowd labels left out, classes pooled (the peers are
/// class-agnostic); as detections (`as_detections`) their ids are −1.
fn scalabel_records(path: &Path, as_detections: bool) -> Result<Vec<Record>, GridError> {
    let text = read_text(path).map_err(io)?;
    let frames = scalabel::parse_scalabel(&text, &path.display().to_string()).map_err(io)?;
    let mut ids = scalabel::IdMap::default();
    let mut categories = scalabel::Categories::default();
    let mut out = scalabel::to_records(&frames, &mut ids, &mut categories, true);
    for r in &mut out {
        r.class = -1;
        if as_detections {
            r.id = -1;
        }
    }
    Ok(out)
}

fn bdd_sequence(name: &str, gt: Vec<Record>, dets: Vec<Record>) -> Result<GridSequence, GridError> {
    let num_frames = gt.iter().chain(&dets).map(|r| r.frame).max().unwrap_or(0);
    Ok(GridSequence {
        name: name.to_string(),
        // BDD100K's tracking annotations are at 5 frames per second.
        fps: 5.0,
        width: 1280,
        height: 720,
        num_frames,
        gt,
        real_dets: Some(dets),
        synth: None,
    })
}

/// The BDD100K box-tracking sample (module docs).
pub fn bdd(shared: &Path) -> Result<Dataset, GridError> {
    let dir = shared.join("data/bdd100k-sample/box_track");
    let gt = scalabel_records(&dir.join("track_sample_anns.json"), false)?;
    let dets = scalabel_records(&dir.join("track_predictions.json"), true)?;
    Ok(Dataset {
        name: "bdd".into(),
        sequences: vec![bdd_sequence("b1c66a42-6f7d68ca", gt, dets)?],
    })
}

/// The BDD100K segmentation-tracking sample: masks, no frames (module docs).
pub fn bdd_masks(shared: &Path) -> Result<Dataset, GridError> {
    let dir = shared.join("data/bdd100k-sample/seg_track");
    let gt = scalabel_records(&dir.join("seg_track_sample.json"), false)?;
    let dets = scalabel_records(&dir.join("seg_track_preds.json"), true)?;
    Ok(Dataset {
        name: "bdd-masks".into(),
        sequences: vec![bdd_sequence("b1c66a42-6f7d68ca", gt, dets)?],
    })
}

/// Synthetic sequences `name-s<seed>` of the scenes `configs`. Ground truth: the visible
/// parts' boxes and masks, with their visibility; for a crowd of pedestrians
/// ([`SynthConfig::crowd`]) the amodal boxes instead, hidden people included, as the
/// MOTChallenge pedestrian benchmarks annotate (masks still the visible pixels: the
/// detector models segment what they see).
pub fn synthetic(name: &str, configs: &[SynthConfig]) -> Result<Dataset, GridError> {
    let mut sequences = Vec::new();
    for cfg in configs {
        let mut scene = Scene::new(cfg.clone()).map_err(GridError::Synth)?;
        let mut gt = Vec::new();
        while let Some(f) = scene.frame() {
            if cfg.crowd.is_some() {
                gt.extend(f.amodal_gt_records());
            } else {
                gt.extend(f.gt_records());
            }
        }
        sequences.push(GridSequence {
            name: format!("{name}-s{}", cfg.seed),
            fps: cfg.fps,
            width: cfg.width,
            height: cfg.height,
            num_frames: cfg.frames,
            gt,
            real_dets: None,
            synth: Some(cfg.clone()),
        });
    }
    Ok(Dataset {
        name: format!("synth-{name}"),
        sequences,
    })
}
