//! The robustness grid: datasets × detector models × trackers, all on the same detections,
//! scored by the same metrics (ours, equal to TrackEval's; `scripts/grid.py` also runs
//! TrackEval and the peer trackers on the files `shapetrack grid prepare` writes).
//!
//! - [`detector`]: detector models that turn ground truth into detections (score calibrations,
//!   misses, jitter, false positives, duplicates, split boxes, mask noise, dropped frames).
//! - [`datasets`]: MOT15, SportsMOT, the BDD100K samples and synthetic scenes.
//! - This module: the [`Cell`]s (a dataset under a detector model), running this crate's
//!   tracker on a cell in process ([`track`]), and scoring ([`score`]).
//!
//! A cell's detections are a pure function of (dataset, model, sequence): the model's seed
//! is derived from their names ([`cell_seed`]), so every tracker, every run and every tool sees
//! the same detections.

pub mod datasets;
pub mod detector;

use std::collections::BTreeMap;

use thiserror::Error;

use crate::eval::{evaluate, EvalConfig, EvalError, MotResults, SequenceInput};
use crate::frame::TrackedShape;
use crate::io::{IoError, Record};
use crate::synth::{Scene, SynthConfig, SynthError};
use crate::track::offline::{OfflineConfig, OfflineError, OfflineTracker};
use crate::track::{detections_by_frame, to_records, Config, TrackError, Tracker};
pub use datasets::{Dataset, GridSequence};
pub use detector::{DetectorModel, GtSequence};

/// Errors of the grid.
#[derive(Debug, Error)]
pub enum GridError {
    /// A data file could not be read.
    #[error(transparent)]
    Io(#[from] IoError),
    /// A data file is not what the grid expects.
    #[error("{file}: {message}")]
    Data {
        /// The file.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// A synthetic scene's settings are invalid.
    #[error("synthetic scene: {0}")]
    Synth(#[from] SynthError),
    /// The online tracker failed.
    #[error("tracker: {0}")]
    Track(#[from] TrackError),
    /// The offline pass failed.
    #[error("offline pass: {0}")]
    Offline(#[from] OfflineError),
    /// Evaluation failed.
    #[error("evaluation: {0}")]
    Eval(#[from] EvalError),
    /// No detector model has this name.
    #[error("unknown detector model {0:?} (known: real, {1})")]
    UnknownModel(String, String),
    /// No dataset has this name.
    #[error("unknown dataset {0:?}")]
    UnknownDataset(String),
    /// A cell asks for real detections from a dataset without any.
    #[error("{0} has no real detections")]
    NoRealDetections(String),
    /// A frame could not be made from the synthetic scene.
    #[error("frame: {0}")]
    Frame(#[from] crate::frame::FrameError),
}

/// A dataset under a detector model: `model` is `real` (the dataset's own detections) or a
/// [`detector::profiles`] name.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Cell {
    /// Dataset name.
    pub dataset: String,
    /// Detector model name.
    pub model: String,
}

impl Cell {
    /// A cell.
    pub fn new(dataset: &str, model: &str) -> Self {
        Self {
            dataset: dataset.to_string(),
            model: model.to_string(),
        }
    }

    /// `dataset/model`.
    pub fn name(&self) -> String {
        format!("{}/{}", self.dataset, self.model)
    }

    /// Whether the cell's detections are masks.
    pub fn masks(&self) -> bool {
        self.model.starts_with("masks") || self.dataset == "bdd-masks"
    }
}

impl std::fmt::Display for Cell {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.dataset, self.model)
    }
}

/// The box-detector profiles (the mask ones apply to datasets with mask ground truth).
pub fn box_models() -> Vec<String> {
    detector::profiles()
        .into_iter()
        .filter(|p| p.masks.is_none())
        .map(|p| p.name)
        .collect()
}

/// The mask-detector profiles.
pub fn mask_models() -> Vec<String> {
    detector::profiles()
        .into_iter()
        .filter(|p| p.masks.is_some())
        .map(|p| p.name)
        .collect()
}

/// 64-bit FNV-1a of a string: stable across platforms and releases.
fn fnv(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

/// The seed of a detector model on one sequence of a dataset.
pub fn cell_seed(dataset: &str, model: &str, sequence: &str) -> u64 {
    fnv(&format!("{dataset}/{model}/{sequence}"))
}

/// The detections of `seq` (of dataset `dataset`) under detector model `model`.
pub fn detections(
    dataset: &str,
    seq: &GridSequence,
    model: &str,
) -> Result<Vec<Record>, GridError> {
    if model == "real" {
        return seq
            .real_dets
            .clone()
            .ok_or_else(|| GridError::NoRealDetections(dataset.to_string()));
    }
    let m = detector::profile(model).ok_or_else(|| {
        let known: Vec<String> = detector::profiles().into_iter().map(|p| p.name).collect();
        GridError::UnknownModel(model.to_string(), known.join(", "))
    })?;
    let gt = GtSequence::from_records(&seq.gt, seq.num_frames, seq.width, seq.height);
    Ok(m.apply(&gt, cell_seed(dataset, model, &seq.name)))
}

/// Online (frame by frame) or offline (whole sequence: re-linking and gap filling too).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Mode {
    /// The online tracker alone.
    Online,
    /// The offline tracker (online pass, re-linker, gap filling).
    Offline,
}

/// What this crate's tracker is given.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Input {
    /// Boxes only (masks dropped, no frames): the peers' input.
    Boxes,
    /// Mask detections, with the frames when the dataset has them (synthetic scenes).
    Masks,
}

/// How this crate's tracker runs on a cell.
#[derive(Debug, Clone, PartialEq)]
pub struct Tracking {
    /// Online or offline.
    pub mode: Mode,
    /// Boxes or masks.
    pub input: Input,
    /// The offline settings; their `online` part is the online tracker's.
    pub config: OfflineConfig,
}

impl Tracking {
    /// The library's defaults: [`Config::default`] for boxes, [`Config::masks`] for masks.
    pub fn defaults(mode: Mode, input: Input) -> Self {
        let online = match input {
            Input::Boxes => Config::default(),
            Input::Masks => Config::masks(),
        };
        Self {
            mode,
            input,
            config: OfflineConfig {
                online,
                ..OfflineConfig::default()
            },
        }
    }

    /// A short label: `online`, `offline`, `masks-online`, `masks-offline`.
    pub fn label(&self) -> &'static str {
        match (self.input, self.mode) {
            (Input::Boxes, Mode::Online) => "online",
            (Input::Boxes, Mode::Offline) => "offline",
            (Input::Masks, Mode::Online) => "masks-online",
            (Input::Masks, Mode::Offline) => "masks-offline",
        }
    }
}

/// Runs this crate's tracker on one sequence's detections; returns its output as records
/// (boxes, frames 1-based).
pub fn track(
    seq: &GridSequence,
    dets: &[Record],
    tracking: &Tracking,
) -> Result<Vec<Record>, GridError> {
    let masks = tracking.input == Input::Masks;
    let input: Vec<Record> = dets
        .iter()
        .map(|r| Record {
            mask: if masks { r.mask.clone() } else { None },
            ..r.clone()
        })
        .collect();
    let per_frame = detections_by_frame(&input, 1, seq.num_frames);
    let mut online_config = tracking.config.online.clone();
    if online_config.frame_rate.is_none() {
        online_config.frame_rate = Some(seq.fps);
    }
    let (w, h) = (seq.width, seq.height);
    let mut scene = match (&seq.synth, masks) {
        (Some(cfg), true) => Some(Scene::new(cfg.clone())?),
        _ => None,
    };
    let shapes = match tracking.mode {
        Mode::Online => {
            let mut t = Tracker::new(online_config)?.with_image_size(w, h);
            let mut out = Vec::new();
            for dets in &per_frame {
                out.extend(with_frame(&mut scene, |frame| t.update(frame, dets))??);
            }
            out
        }
        Mode::Offline => {
            let config = OfflineConfig {
                online: online_config,
                ..tracking.config.clone()
            };
            let mut t = OfflineTracker::new(config, seq.fps)?.with_image_size(w, h);
            for dets in &per_frame {
                with_frame(&mut scene, |frame| t.push_frame(frame, dets).map(|_| ()))??;
            }
            t.finish(|_| {})?.shapes
        }
    };
    let boxes: Vec<TrackedShape> = shapes
        .into_iter()
        .map(|s| TrackedShape { mask: None, ..s })
        .collect();
    Ok(to_records(&boxes, 1, Some((w, h))))
}

/// Calls `f` with the scene's next frame (or without a frame when there is no scene).
fn with_frame<T>(
    scene: &mut Option<Scene>,
    f: impl FnOnce(Option<&crate::Frame<'_>>) -> T,
) -> Result<T, GridError> {
    match scene {
        Some(s) => match s.frame() {
            Some(sf) => {
                let frame = sf.frame()?;
                Ok(f(Some(&frame)))
            }
            None => Ok(f(None)),
        },
        None => Ok(f(None)),
    }
}

/// The evaluation the grid uses: box IoU at 0.5 (HOTA over its α range), no class
/// preprocessing (MOT15's), ground-truth rows with a zero "consider" flag dropped.
pub fn eval_config() -> EvalConfig {
    EvalConfig::for_benchmark("MOT15", false)
}

/// The ground truth of `seq` as the evaluation reads it (boxes; masks dropped).
pub fn gt_boxes(seq: &GridSequence) -> Vec<Record> {
    seq.gt
        .iter()
        .map(|r| Record {
            mask: None,
            ..r.clone()
        })
        .collect()
}

/// Scores the results of a cell's sequences (`(sequence, results)` pairs) combined.
pub fn score(results: &[(&GridSequence, Vec<Record>)]) -> Result<MotResults, GridError> {
    let inputs: Vec<SequenceInput> = results
        .iter()
        .map(|(seq, res)| SequenceInput::new(&seq.name, seq.num_frames, gt_boxes(seq), res.clone()))
        .collect();
    Ok(evaluate(&inputs, &eval_config())?)
}

/// The datasets of the standard grid, by name.
pub const DATASETS: [&str; 5] = ["mot15", "sportsmot", "bdd", "bdd-masks", "synth"];

/// Loads the named datasets (`synth` loads every synthetic family) from `shared`.
pub fn load(names: &[&str], shared: &std::path::Path) -> Result<Vec<Dataset>, GridError> {
    let mut out = Vec::new();
    for &n in names {
        match n {
            "mot15" => out.push(datasets::mot15(shared)?),
            "sportsmot" => out.push(datasets::sportsmot(shared)?),
            "bdd" => out.push(datasets::bdd(shared)?),
            "bdd-masks" => out.push(datasets::bdd_masks(shared)?),
            "synth" => {
                for (family, configs) in synthetic_families() {
                    out.push(datasets::synthetic(&family, &configs)?);
                }
            }
            other => return Err(GridError::UnknownDataset(other.to_string())),
        }
    }
    Ok(out)
}

/// Seeds of the synthetic scenes of each family.
pub const SYNTH_SEEDS: [u64; 3] = [101, 102, 103];

/// The synthetic scenario families ([`crate::synth::Family`]) and their scenes.
pub fn synthetic_families() -> BTreeMap<String, Vec<SynthConfig>> {
    crate::synth::Family::ALL
        .into_iter()
        .map(|f| {
            let scenes = SYNTH_SEEDS
                .iter()
                .map(|&s| SynthConfig::family(f, s))
                .collect();
            (f.name().to_string(), scenes)
        })
        .collect()
}

/// The standard grid's cells over `datasets`: real detections where a dataset has them,
/// box profiles on box datasets, mask profiles on synthetic ones.
pub fn cells(datasets: &[Dataset]) -> Vec<Cell> {
    let mut out = Vec::new();
    for d in datasets {
        let real = d.sequences.iter().all(|s| s.real_dets.is_some());
        if real {
            out.push(Cell::new(&d.name, "real"));
        }
        if d.name.starts_with("synth-") {
            for m in mask_models() {
                out.push(Cell::new(&d.name, &m));
            }
        } else if d.name != "bdd-masks" {
            for m in box_models() {
                out.push(Cell::new(&d.name, &m));
            }
        }
    }
    out
}

/// One tracker's detections and results on a cell, cached so a config evaluation does not
/// regenerate detections.
#[derive(Debug, Clone)]
pub struct CellData<'a> {
    /// The cell.
    pub cell: Cell,
    /// Its sequences with their detections.
    pub sequences: Vec<(&'a GridSequence, Vec<Record>)>,
}

/// The detections of every cell in `cells`, over the sequences of `datasets`.
pub fn cell_data<'a>(
    datasets: &'a [Dataset],
    cells: &[Cell],
) -> Result<Vec<CellData<'a>>, GridError> {
    let mut out = Vec::new();
    for c in cells {
        let d = datasets
            .iter()
            .find(|d| d.name == c.dataset)
            .ok_or_else(|| GridError::UnknownDataset(c.dataset.clone()))?;
        let mut sequences = Vec::new();
        for s in &d.sequences {
            sequences.push((s, detections(&d.name, s, &c.model)?));
        }
        out.push(CellData {
            cell: c.clone(),
            sequences,
        });
    }
    Ok(out)
}

/// Runs `tracking` on every sequence of a cell and scores the results.
pub fn run_cell(data: &CellData<'_>, tracking: &Tracking) -> Result<MotResults, GridError> {
    let mut results = Vec::new();
    for (seq, dets) in &data.sequences {
        results.push((*seq, track(seq, dets, tracking)?));
    }
    score(&results)
}

#[cfg(test)]
mod tests;
