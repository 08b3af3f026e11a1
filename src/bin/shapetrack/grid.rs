//! `shapetrack grid`: the robustness grid (datasets × detector models × trackers; see
//! `shapetrack::grid` and `tests/data/quality/README.md`).
//!
//! ```text
//! shapetrack grid eval    [--datasets D,..] [--cells GLOB,..] [--config C.json] [--offline-config O.json]
//!                         [--mode online|offline|both] [--input boxes|masks|both] [--json F]
//! shapetrack grid prepare --out DIR [--datasets ..] [--cells ..]
//! shapetrack grid run     --dir DIR --name NAME [--mode ..] [--input ..] [--config ..] [--cells ..]
//! shapetrack grid score   --dir DIR [--json F]
//! ```
//!
//! `eval` runs this crate's tracker in process (nothing written; what tuning uses); `prepare`
//! writes each cell in TrackEval's layout (`DIR/<dataset>__<model>/gt/MOT15-train/<seq>/…`,
//! one ground-truth root per cell, so TrackEval runs with BENCHMARK MOT15) with the cell's
//! detections (`DIR/<cell>/det/<seq>.txt`, MOTChallenge det.txt, the tight boxes of mask
//! detections); `run` writes this crate's results beside them
//! (`DIR/<cell>/trackers/MOT15-train/NAME/data/<seq>.txt`), `score` scores every tracker
//! folder there. `scripts/grid.py` runs the peers and TrackEval on the same files.

use shapetrack::eval::{MotResults, Summary};
use shapetrack::grid::{self, Cell, CellData, Dataset, Input, Mode, Tracking};
use shapetrack::io::layout::parse_mot_as_trackeval;
use shapetrack::io::motchallenge::write_mot;
use shapetrack::io::{read_text, write_text, Record};
use shapetrack::track::offline::OfflineConfig;
use shapetrack::track::Config;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What to run.
#[derive(clap::Subcommand)]
pub enum Command {
    /// Run this crate's tracker on the cells in process and print (or write) the scores.
    Eval(EvalArgs),
    /// Write each cell's ground truth and detections in TrackEval's layout.
    Prepare(PrepareArgs),
    /// Run this crate's tracker on prepared cells and write its results beside them.
    Run(RunArgs),
    /// Score every tracker's results in prepared cells.
    Score(ScoreArgs),
}

/// Arguments of `shapetrack grid`.
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    cmd: Command,
}

/// Which cells.
#[derive(clap::Args, Clone)]
pub struct Select {
    /// Datasets (comma-separated): mot15, sportsmot, bdd, bdd-masks, synth.
    #[arg(long, value_delimiter = ',', default_values_t = grid::DATASETS.map(String::from))]
    datasets: Vec<String>,
    /// Only cells whose `dataset/model` name matches one of these patterns (`*` matches
    /// anything; comma-separated), e.g. `mot15/*,*/wide`.
    #[arg(long, value_delimiter = ',')]
    cells: Vec<String>,
    /// The shared data folder (default: ../shared beside the repository, or
    /// $SHAPETRACK_SHARED).
    #[arg(long)]
    shared: Option<PathBuf>,
}

/// Online, offline or both.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ModeArg {
    /// The online tracker.
    Online,
    /// The offline tracker.
    Offline,
    /// Both.
    Both,
}

/// Boxes, masks or both.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum InputArg {
    /// Boxes (every cell).
    Boxes,
    /// Masks (mask cells only).
    Masks,
    /// Boxes everywhere, masks too in mask cells.
    Both,
}

/// How this crate's tracker runs.
#[derive(clap::Args, Clone)]
pub struct TrackerArgs {
    /// Online, offline or both.
    #[arg(long, value_enum, default_value_t = ModeArg::Both)]
    mode: ModeArg,
    /// Boxes, masks or both.
    #[arg(long, value_enum, default_value_t = InputArg::Both)]
    input: InputArg,
    /// Online config (JSON) over the preset of the input (boxes: the defaults; masks: the
    /// mask preset).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Offline config (JSON `{"relink": …, "fill": …}`; its `online` part merges over the
    /// online config).
    #[arg(long)]
    offline_config: Option<PathBuf>,
}

/// Arguments of `grid eval`.
#[derive(clap::Args)]
pub struct EvalArgs {
    #[command(flatten)]
    select: Select,
    #[command(flatten)]
    tracker: TrackerArgs,
    /// Write the scores as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Evaluate many online configs in one process (datasets and detections loaded once): a
    /// JSON-lines file of `{"label": …, "online": {…}, "offline": {…}}` (either part may be
    /// absent), each applied over the preset (and over `--config`); one result line per config
    /// is appended to `--results`.
    #[arg(long, requires = "results")]
    configs: Option<PathBuf>,
    /// Where `--configs` results go (JSON lines, appended).
    #[arg(long)]
    results: Option<PathBuf>,
}

/// Arguments of `grid prepare`.
#[derive(clap::Args)]
pub struct PrepareArgs {
    #[command(flatten)]
    select: Select,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
}

/// Arguments of `grid run`.
#[derive(clap::Args)]
pub struct RunArgs {
    #[command(flatten)]
    select: Select,
    #[command(flatten)]
    tracker: TrackerArgs,
    /// The prepared folder.
    #[arg(long)]
    dir: PathBuf,
    /// Tracker name prefix: results go to `<name>-<online|offline|masks-online|masks-offline>`.
    #[arg(long, default_value = "ours")]
    name: String,
}

/// Arguments of `grid score`.
#[derive(clap::Args)]
pub struct ScoreArgs {
    #[command(flatten)]
    select: Select,
    /// The prepared folder.
    #[arg(long)]
    dir: PathBuf,
    /// Write the scores as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
}

/// Runs the subcommand.
pub fn run(args: Args) -> crate::CliResult {
    match args.cmd {
        Command::Eval(a) => eval(a),
        Command::Prepare(a) => prepare(a),
        Command::Run(a) => run_prepared(a),
        Command::Score(a) => score(a),
    }
}

/// `*`-only glob match.
fn glob(pattern: &str, name: &str) -> bool {
    let parts: Vec<&str> = pattern.split('*').collect();
    if parts.len() == 1 {
        return pattern == name;
    }
    let mut rest = name;
    for (i, p) in parts.iter().enumerate() {
        if i == 0 {
            match rest.strip_prefix(p) {
                Some(r) => rest = r,
                None => return false,
            }
        } else if i == parts.len() - 1 {
            return rest.ends_with(p);
        } else {
            match rest.find(p) {
                Some(k) => rest = &rest[k + p.len()..],
                None => return false,
            }
        }
    }
    true
}

fn load(select: &Select) -> Result<(Vec<Dataset>, Vec<Cell>), Box<dyn std::error::Error>> {
    let shared = select
        .shared
        .clone()
        .unwrap_or_else(grid::datasets::shared_dir);
    let names: Vec<&str> = select.datasets.iter().map(String::as_str).collect();
    let datasets = grid::load(&names, &shared)?;
    let cells = grid::cells(&datasets)
        .into_iter()
        .filter(|c| select.cells.is_empty() || select.cells.iter().any(|p| glob(p, &c.name())))
        .collect();
    Ok((datasets, cells))
}

/// The trackings `args` asks for on `cell`.
fn trackings(args: &TrackerArgs, cell: &Cell) -> Result<Vec<Tracking>, Box<dyn std::error::Error>> {
    let modes: &[Mode] = match args.mode {
        ModeArg::Online => &[Mode::Online],
        ModeArg::Offline => &[Mode::Offline],
        ModeArg::Both => &[Mode::Online, Mode::Offline],
    };
    let inputs: Vec<Input> = match args.input {
        InputArg::Boxes => vec![Input::Boxes],
        InputArg::Masks if cell.masks() => vec![Input::Masks],
        InputArg::Masks => vec![],
        InputArg::Both if cell.masks() => vec![Input::Boxes, Input::Masks],
        InputArg::Both => vec![Input::Boxes],
    };
    let mut out = Vec::new();
    for &input in &inputs {
        for &mode in modes {
            let mut t = Tracking::defaults(mode, input);
            if let Some(p) = &args.config {
                t.config.online = t
                    .config
                    .online
                    .overlay_json(&read_text(p)?)
                    .map_err(|e| format!("{}: {e}", p.display()))?;
            }
            if let Some(p) = &args.offline_config {
                let bad = |e: serde_json::Error| format!("{}: {e}", p.display());
                let v: serde_json::Value = serde_json::from_str(&read_text(p)?).map_err(bad)?;
                let online: Config = match v.get("online") {
                    Some(o) => t.config.online.overlay(o).map_err(bad)?,
                    None => t.config.online.clone(),
                };
                let parsed: OfflineConfig = serde_json::from_value(v).map_err(bad)?;
                t.config = OfflineConfig { online, ..parsed };
            }
            out.push(t);
        }
    }
    Ok(out)
}

/// The figures the grid reports.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
struct Row {
    #[serde(rename = "HOTA")]
    hota: f64,
    #[serde(rename = "DetA")]
    det_a: f64,
    #[serde(rename = "AssA")]
    ass_a: f64,
    /// Localisation, detection recall and precision: where a DetA difference comes from.
    #[serde(rename = "LocA", default)]
    loc_a: f64,
    #[serde(rename = "DetRe", default)]
    det_re: f64,
    #[serde(rename = "DetPr", default)]
    det_pr: f64,
    #[serde(rename = "CLR_Re", default)]
    clr_re: f64,
    #[serde(rename = "CLR_Pr", default)]
    clr_pr: f64,
    #[serde(rename = "IDF1")]
    idf1: f64,
    #[serde(rename = "MOTA")]
    mota: f64,
    #[serde(rename = "IDSW")]
    idsw: u64,
}

impl From<&Summary> for Row {
    fn from(s: &Summary) -> Self {
        Row {
            hota: s.hota,
            det_a: s.det_a,
            ass_a: s.ass_a,
            loc_a: s.loc_a,
            det_re: s.det_re,
            det_pr: s.det_pr,
            clr_re: s.clr_re,
            clr_pr: s.clr_pr,
            idf1: s.idf1,
            mota: s.mota,
            idsw: s.idsw,
        }
    }
}

fn row(r: &MotResults) -> Row {
    Row::from(&r.summary().combined)
}

/// One config line of `grid eval --configs`.
#[derive(serde::Deserialize)]
struct ConfigLine {
    label: String,
    #[serde(default)]
    online: Option<serde_json::Value>,
    #[serde(default)]
    offline: Option<serde_json::Value>,
}

fn eval_many(
    data: &[CellData<'_>],
    args: &EvalArgs,
    configs: &Path,
    results: &Path,
) -> crate::CliResult {
    use std::io::Write as _;
    let text = read_text(configs)?;
    let mut out = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(results)
        .map_err(|e| format!("{}: {e}", results.display()))?;
    for (k, line) in text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
    {
        let bad = |e: serde_json::Error| format!("{}:{}: {e}", configs.display(), k + 1);
        let c: ConfigLine = serde_json::from_str(line).map_err(bad)?;
        let t0 = std::time::Instant::now();
        let mut cells: BTreeMap<String, BTreeMap<String, Row>> = BTreeMap::new();
        for d in data {
            for mut t in trackings(&args.tracker, &d.cell)? {
                if let Some(o) = &c.online {
                    t.config.online = t.config.online.overlay(o).map_err(bad)?;
                }
                if let Some(o) = &c.offline {
                    let online = t.config.online.clone();
                    let mut v = serde_json::to_value(&t.config).map_err(bad)?;
                    shapetrack::settings::merge(&mut v, o);
                    t.config = serde_json::from_value(v).map_err(bad)?;
                    t.config.online = online;
                }
                let r = row(&grid::run_cell(d, &t)?);
                cells
                    .entry(d.cell.name())
                    .or_default()
                    .insert(t.label().to_string(), r);
            }
        }
        let rec = serde_json::json!({
            "label": c.label,
            "online": c.online,
            "offline": c.offline,
            "seconds": t0.elapsed().as_secs_f64(),
            "cells": cells,
        });
        writeln!(out, "{rec}").map_err(|e| format!("{}: {e}", results.display()))?;
        out.flush()
            .map_err(|e| format!("{}: {e}", results.display()))?;
        let hota: Vec<f64> = cells
            .values()
            .flat_map(|m| m.values().map(|r| r.hota))
            .collect();
        println!(
            "{:40} mean HOTA {:.3} over {} runs ({:.1} s)",
            c.label,
            hota.iter().sum::<f64>() / hota.len().max(1) as f64,
            hota.len(),
            t0.elapsed().as_secs_f64()
        );
    }
    Ok(())
}

fn eval(args: EvalArgs) -> crate::CliResult {
    let (datasets, cells) = load(&args.select)?;
    let data = grid::cell_data(&datasets, &cells)?;
    if let (Some(c), Some(r)) = (&args.configs, &args.results) {
        return eval_many(&data, &args, c, r);
    }
    let mut all: BTreeMap<String, BTreeMap<String, Row>> = BTreeMap::new();
    let t0 = std::time::Instant::now();
    for d in &data {
        for t in trackings(&args.tracker, &d.cell)? {
            let r = row(&grid::run_cell(d, &t)?);
            println!(
                "{:28} {:14} HOTA {:6.2} IDF1 {:6.2} MOTA {:7.2} IDSW {:5}",
                d.cell.name(),
                t.label(),
                r.hota,
                r.idf1,
                r.mota,
                r.idsw
            );
            all.entry(d.cell.name())
                .or_default()
                .insert(t.label().to_string(), r);
        }
    }
    // Means over cells, per tracking.
    let mut means: BTreeMap<String, (f64, f64, usize)> = BTreeMap::new();
    for rows in all.values() {
        for (k, r) in rows {
            let m = means.entry(k.clone()).or_default();
            m.0 += r.hota;
            m.1 += r.idf1;
            m.2 += 1;
        }
    }
    for (k, (h, i, n)) in &means {
        println!(
            "mean over {n} cells, {k}: HOTA {:.3} IDF1 {:.3}",
            h / *n as f64,
            i / *n as f64
        );
    }
    eprintln!("({:.1} s)", t0.elapsed().as_secs_f64());
    if let Some(p) = &args.json {
        write_text(p, &serde_json::to_string_pretty(&all)?)?;
    }
    Ok(())
}

/// A cell's folder name.
fn cell_dir(root: &Path, cell: &Cell) -> PathBuf {
    root.join(format!("{}__{}", cell.dataset, cell.model))
}

fn seqinfo(seq: &grid::GridSequence) -> String {
    format!(
        "[Sequence]\nname={}\nimDir=img1\nframeRate={}\nseqLength={}\nimWidth={}\nimHeight={}\nimExt=.jpg\n",
        seq.name, seq.fps, seq.num_frames, seq.width, seq.height
    )
}

fn mkdir(p: &Path) -> Result<(), Box<dyn std::error::Error>> {
    std::fs::create_dir_all(p).map_err(|e| format!("{}: {e}", p.display()).into())
}

fn prepare(args: PrepareArgs) -> crate::CliResult {
    let (datasets, cells) = load(&args.select)?;
    let data = grid::cell_data(&datasets, &cells)?;
    for d in &data {
        let dir = cell_dir(&args.out, &d.cell);
        let gt_root = dir.join("gt");
        mkdir(&gt_root.join("seqmaps"))?;
        mkdir(&dir.join("det"))?;
        let mut seqmap = String::from("name\n");
        for (seq, dets) in &d.sequences {
            let sdir = gt_root.join("MOT15-train").join(&seq.name);
            mkdir(&sdir.join("gt"))?;
            write_text(&sdir.join("seqinfo.ini"), &seqinfo(seq))?;
            write_text(&sdir.join("gt/gt.txt"), &write_mot(&grid::gt_boxes(seq)))?;
            let boxes: Vec<Record> = dets
                .iter()
                .map(|r| Record {
                    mask: None,
                    ..r.clone()
                })
                .collect();
            write_text(
                &dir.join("det").join(format!("{}.txt", seq.name)),
                &write_mot(&boxes),
            )?;
            seqmap.push_str(&seq.name);
            seqmap.push('\n');
        }
        write_text(&gt_root.join("seqmaps/MOT15-train.txt"), &seqmap)?;
        println!("{}: {} sequences", dir.display(), d.sequences.len());
    }
    Ok(())
}

fn run_prepared(args: RunArgs) -> crate::CliResult {
    let (datasets, cells) = load(&args.select)?;
    let data: Vec<CellData<'_>> = grid::cell_data(&datasets, &cells)?;
    for d in &data {
        let dir = cell_dir(&args.dir, &d.cell);
        for t in trackings(&args.tracker, &d.cell)? {
            let name = format!("{}-{}", args.name, t.label());
            let out = dir.join("trackers/MOT15-train").join(&name).join("data");
            mkdir(&out)?;
            let t0 = std::time::Instant::now();
            let mut frames = 0u64;
            for (seq, dets) in &d.sequences {
                let res = grid::track(seq, dets, &t)?;
                write_text(&out.join(format!("{}.txt", seq.name)), &write_mot(&res))?;
                frames += seq.num_frames as u64;
            }
            let secs = t0.elapsed().as_secs_f64();
            write_text(
                &out.with_file_name("timing.txt"),
                &format!("frames={frames} seconds={secs:.4}\n"),
            )?;
            println!("{} {name}: {frames} frames in {secs:.6} s", d.cell.name());
        }
    }
    Ok(())
}

fn score(args: ScoreArgs) -> crate::CliResult {
    let (datasets, cells) = load(&args.select)?;
    let mut all: BTreeMap<String, BTreeMap<String, Row>> = BTreeMap::new();
    for c in &cells {
        let d = datasets
            .iter()
            .find(|d| d.name == c.dataset)
            .ok_or("dataset")?;
        let root = cell_dir(&args.dir, c).join("trackers/MOT15-train");
        let Ok(rd) = std::fs::read_dir(&root) else {
            continue;
        };
        let mut names: Vec<String> = rd
            .filter_map(|e| e.ok())
            .filter(|e| e.path().is_dir())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        for name in names {
            let mut results = Vec::new();
            for seq in &d.sequences {
                let p = root
                    .join(&name)
                    .join("data")
                    .join(format!("{}.txt", seq.name));
                let recs = if p.is_file() {
                    parse_mot_as_trackeval(&read_text(&p)?, &p.display().to_string())?
                } else {
                    Vec::new()
                };
                results.push((seq, recs));
            }
            let r = row(&grid::score(&results)?);
            println!(
                "{:28} {:22} HOTA {:6.2} IDF1 {:6.2} MOTA {:7.2} IDSW {:5}",
                c.name(),
                name,
                r.hota,
                r.idf1,
                r.mota,
                r.idsw
            );
            all.entry(c.name()).or_default().insert(name, r);
        }
    }
    if let Some(p) = &args.json {
        write_text(p, &serde_json::to_string_pretty(&all)?)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::glob;

    #[test]
    fn globs() {
        assert!(glob("mot15/*", "mot15/wide"));
        assert!(glob("*/wide", "sportsmot/wide"));
        assert!(!glob("*/wide", "sportsmot/low"));
        assert!(glob("*", "x"));
        assert!(glob("synth-*/masks-*", "synth-crowd/masks-clean"));
        assert!(glob("a", "a") && !glob("a", "ab"));
    }
}
