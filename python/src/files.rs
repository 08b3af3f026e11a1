//! Whole sequences from files: `track_files` is `shapetrack track` (the same library function,
//! so the output is the CLI's bit for bit) and `evaluate` is `shapetrack eval --json`.

use crate::{in_pool, value_error};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use shapetrack::eval::{evaluate as eval_mot, EvalConfig, Preprocessing, Similarity};
use shapetrack::io::layout::{discover, load_sequence, Format as LayoutFormat};
use shapetrack::track::from_files::{self, Format, Options};
use shapetrack::track::offline::Phase;
use shapetrack::track::Preset;
use std::path::PathBuf;

/// A preset by name, as the CLI's `--preset` and a settings object's `"preset"` spell it.
fn preset(name: &str) -> PyResult<Preset> {
    serde_json::from_value(serde_json::Value::String(name.to_string()))
        .map_err(|e| value_error(format!("preset: {e}")))
}

/// Checks a settings object (JSON text) as `Tracker(config)` would, without tracking:
/// the batch checks its `--config` once, before any task starts.
#[pyfunction]
pub fn check_config(config: &str) -> PyResult<()> {
    crate::tracker::online_config(Some(config)).map(|_| ())
}

/// Tracks one sequence from its files and writes `out` atomically (`shapetrack track`).
/// Returns the run's counts: `frames`, `detections`, `tracks`, `shapes`, `interpolated`,
/// `masks`, `fps`, `core_seconds`, and offline `joins`, `filled`.
#[allow(clippy::too_many_arguments)]
#[pyfunction]
#[pyo3(signature = (det, out, frames=None, seqinfo=None, offline=false, preset_name=None, config=None, fps=None, mots_for_masks=true))]
pub fn track_files<'py>(
    py: Python<'py>,
    det: PathBuf,
    out: PathBuf,
    frames: Option<PathBuf>,
    seqinfo: Option<PathBuf>,
    offline: bool,
    preset_name: Option<&str>,
    config: Option<PathBuf>,
    fps: Option<f64>,
    mots_for_masks: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let opts = Options {
        det,
        frames,
        seqinfo,
        fps,
        offline,
        out,
        format: None::<Format>,
        mots_for_masks,
        config,
        preset: preset_name.map(preset).transpose()?,
        ..Options::default()
    };
    let s = py
        .allow_threads(|| {
            in_pool(|| from_files::run(&opts, &mut |_: Phase| {}).map_err(|e| e.to_string()))
        })
        .map_err(value_error)?;
    let d = PyDict::new(py);
    d.set_item("frames", s.frames)?;
    d.set_item("detections", s.detections)?;
    d.set_item("tracks", s.tracks)?;
    d.set_item("shapes", s.shapes)?;
    d.set_item("interpolated", s.interpolated)?;
    d.set_item("masks", s.masks)?;
    d.set_item("fps", s.fps)?;
    d.set_item("core_seconds", s.core.as_secs_f64())?;
    if let Some((joins, filled, dropped)) = s.offline {
        d.set_item("joins", joins)?;
        d.set_item("filled", filled)?;
        d.set_item("coasted_dropped", dropped)?;
    }
    Ok(d)
}

/// CLEAR, Identity and HOTA over a TrackEval-layout ground truth and a folder of results,
/// as `shapetrack eval --gt GT --tracker RESULTS --benchmark B [--split S] [--seq …]
/// [--masks] --json`: the same JSON text (per-sequence rows and the combined row).
#[allow(clippy::too_many_arguments)]
#[pyfunction]
#[pyo3(signature = (gt, results, benchmark="MOT15", split="train", seqs=None, masks=false, threshold=0.5, allow_missing_results=false))]
pub fn evaluate(
    py: Python<'_>,
    gt: PathBuf,
    results: PathBuf,
    benchmark: &str,
    split: &str,
    seqs: Option<Vec<String>>,
    masks: bool,
    threshold: f64,
    allow_missing_results: bool,
) -> PyResult<String> {
    // The CLI's `eval` settings with `--preproc auto` (src/bin/shapetrack/eval.rs).
    let mut cfg = EvalConfig::for_benchmark(benchmark, masks);
    if let Preprocessing::Mots { .. } = cfg.preprocessing {
        cfg.preprocessing = Preprocessing::Mots {
            class: shapetrack::eval::MOTS_PEDESTRIAN,
        };
    }
    cfg.similarity = if masks {
        Similarity::MaskIou
    } else {
        Similarity::BoxIou
    };
    if !(threshold > 0.0 && threshold <= 1.0) {
        return Err(value_error(format!(
            "threshold: {threshold} must be in (0, 1]"
        )));
    }
    cfg.threshold = threshold;
    let format = if masks {
        LayoutFormat::Mots
    } else {
        LayoutFormat::Mot
    };
    let benchmark = benchmark.to_string();
    let split = split.to_string();
    py.allow_threads(|| {
        in_pool(|| -> Result<String, String> {
            let e = |e: &dyn std::fmt::Display| e.to_string();
            let mut layout = discover(&gt, &benchmark, &split).map_err(|x| e(&x))?;
            if let Some(s) = &seqs {
                layout.select(s).map_err(|x| e(&x))?;
            }
            let inputs = layout
                .sequences
                .iter()
                .map(|s| load_sequence(s, &results, format, allow_missing_results))
                .collect::<Result<Vec<_>, _>>()
                .map_err(|x| e(&x))?;
            let res = eval_mot(&inputs, &cfg).map_err(|x| e(&x))?;
            serde_json::to_string_pretty(&res.summary()).map_err(|x| e(&x))
        })
    })
    .map_err(value_error)
}
