//! `shapetrack eval-vot`: VOT short-term accuracy, robustness and EAO of stored results.

use shapetrack::eval::vot::{
    anchors_every, evaluate_reset_sequence, summarize_anchor, summarize_reset, AnchorParams,
    AnchorScorer, OverlapMethod, ResetParams,
};
use shapetrack::io::vot::{parse_anchor_values, read_regions, region_lines, Anchor, Region};
use shapetrack::io::{read_text, IoError};
use std::path::{Path, PathBuf};

/// Evaluation protocol.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Protocol {
    /// VOT2020 anchors (multi-start): A, R, EAO.
    Anchor,
    /// VOT2016–2019 reset-based (supervised): A, failures, reliability, EAO.
    Reset,
}

/// Arguments of `shapetrack eval-vot`.
#[derive(clap::Args)]
#[command(after_help = "RESULT LAYOUT (the VOT toolkit's):
  anchor protocol: --tracker DIR holding one file per anchor, <seq>_<frame>.txt with the
    0-based anchor frame in 8 digits (e.g. bag_00000050.txt), or DIR/<seq>/ holding them.
    Each file lists the run in run order (backward anchors from the anchor down to frame 0):
    `1` at the anchor, then one region per frame.
  reset protocol: --tracker FILE, or DIR holding <seq>_001.txt (or DIR/<seq>/<seq>_001.txt):
    one line per frame, `1` at initialisations, `2` at failures, `0` for skipped frames.
  Regions: `x,y,w,h`, `x1,y1,...,xn,yn`, or `m<x>,<y>,<w>,<h>,<runs>` (VOT masks).
  Anchors: --anchors FILE, else <seq dir>/anchor.value, else every --anchor-spacing frames.
  Image size (for clipping): --size WxH, else the first image of the sequence folder.")]
pub struct Args {
    /// Ground truth: a groundtruth.txt or a sequence folder holding one.
    #[arg(long)]
    gt: PathBuf,
    /// Tracker results: a folder (anchor or reset layout) or a reset trajectory file.
    #[arg(long)]
    tracker: PathBuf,
    /// Evaluation protocol.
    #[arg(long, value_enum, default_value = "anchor")]
    protocol: Protocol,
    /// Write the scores (and per-anchor details) as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Print per-anchor (or per-failure) details.
    #[arg(long)]
    verbose: bool,
    /// Reproduce the VOT toolkit exactly (raster overlap; the anchor frame counts as 0). This is
    /// the default, so that scores compare with published VOT numbers; the flag is kept for
    /// scripts that say it explicitly.
    #[arg(long, conflicts_with = "exact")]
    toolkit: bool,
    /// Use exact polygon overlap and count each anchor frame as overlap 1 (the tracker was given
    /// the ground truth there) instead of the toolkit's semantics: a perfect tracker then scores
    /// A = R = 1.
    #[arg(long)]
    exact: bool,
    /// Anchor file (`anchor.value` format: >0 forward, <0 backward).
    #[arg(long)]
    anchors: Option<PathBuf>,
    /// Anchor spacing when no anchor file exists.
    #[arg(long, default_value_t = 50)]
    anchor_spacing: usize,
    /// Image size WxH for clipping regions to the image.
    #[arg(long)]
    size: Option<String>,
    /// Do not clip regions to the image.
    #[arg(long)]
    unbounded: bool,
    /// Sequence name used in result file names (default: the sequence folder's name).
    #[arg(long)]
    sequence: Option<String>,
}

/// The size of the sequence's first image, and that image (a file the run reads).
fn image_size(dir: &Path) -> Option<((u32, u32), PathBuf)> {
    let imgs = shapetrack::io::image_files(dir).ok()?;
    let first = imgs.into_iter().next()?;
    Some((image::image_dimensions(&first).ok()?, first))
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("--size {s:?}: expected WxH"))?;
    let p = |v: &str| {
        v.trim()
            .parse::<u32>()
            .ok()
            .filter(|&n| n > 0)
            .ok_or_else(|| format!("--size {s:?}: expected WxH with positive whole numbers"))
    };
    let (w, h) = (p(w)?, p(h)?);
    // The size clips every region; one beyond the readers' image cap is no real video.
    if !shapetrack::io::limits::image_size_ok(w.into(), h.into()) {
        return Err(format!(
            "--size {s:?}: beyond the image cap (sides up to {}, at most {} pixels; \
             src/io/limits.rs)",
            shapetrack::io::limits::MAX_SIDE,
            shapetrack::io::limits::MAX_PIXELS
        ));
    }
    Ok((w, h))
}

/// The first existing path among candidates.
fn first_existing(c: &[PathBuf]) -> Option<PathBuf> {
    c.iter().find(|p| p.exists()).cloned()
}

/// The error for line `line` of a result file that runs past the frames it may cover.
fn beyond(path: &Path, line: usize, what: &str, frames: usize) -> IoError {
    IoError::Invalid {
        file: path.display().to_string(),
        line,
        message: format!(
            "more lines than frames: {what} has {frames} frames, so this line and any after \
             it would be ignored"
        ),
    }
}

/// Scores the run file of anchor `a` a region at a time. A file with more regions than the
/// run has frames is refused at its first extra line (they would be ignored).
fn score_run(scorer: &mut AnchorScorer<'_>, a: &Anchor, path: &Path) -> crate::CliResult {
    let len = scorer.run_length(a)?;
    let file = path.display().to_string();
    let text = read_text(path)?;
    let what = format!("the run of the anchor at frame {}", a.frame);
    let mut bad: Option<IoError> = None;
    let regions = region_lines(&text, &file)
        .enumerate()
        .map_while(|(i, r)| match r {
            Ok(_) if i >= len => {
                bad = Some(beyond(path, i + 1, &what, len));
                None
            }
            Ok(r) => Some(r),
            Err(e) => {
                bad = Some(e);
                None
            }
        });
    let scored = scorer.add(a, regions);
    if let Some(e) = bad {
        return Err(e.into());
    }
    scored.map_err(|e| format!("{file}: {e}"))?;
    Ok(())
}

/// Runs the subcommand.
pub fn run(args: Args) -> crate::CliResult {
    let (gt_file, seq_dir) = if args.gt.is_dir() {
        (args.gt.join("groundtruth.txt"), args.gt.clone())
    } else {
        let dir = args.gt.parent().map(Path::to_path_buf).unwrap_or_default();
        (args.gt.clone(), dir)
    };
    let gt = read_regions(&gt_file)?;
    // Every file this run reads, so that --json never lands on one of them.
    let mut read = vec![gt_file.clone()];
    if gt.is_empty() {
        return Err(format!("{}: no frames", gt_file.display()).into());
    }
    let seq = match &args.sequence {
        Some(s) => s.clone(),
        None => seq_dir
            .canonicalize()
            .ok()
            .and_then(|d| d.file_name().map(|n| n.to_string_lossy().into_owned()))
            .unwrap_or_else(|| "sequence".into()),
    };
    let size = match &args.size {
        Some(s) => Some(parse_size(s)?),
        None => image_size(&seq_dir).map(|(size, first)| {
            read.push(first);
            size
        }),
    };
    let bounds = if args.unbounded { None } else { size };
    let toolkit = !args.exact || args.toolkit;
    let method = if toolkit {
        OverlapMethod::Toolkit
    } else {
        OverlapMethod::Exact
    };
    let report = match args.protocol {
        Protocol::Anchor => {
            let anchors: Vec<Anchor> = match args.anchors.clone().or_else(|| {
                let p = seq_dir.join("anchor.value");
                p.exists().then_some(p)
            }) {
                Some(p) => {
                    let a = parse_anchor_values(
                        &shapetrack::io::read_text(&p)?,
                        &p.display().to_string(),
                    )?;
                    read.push(p);
                    a
                }
                None => anchors_every(gt.len(), args.anchor_spacing),
            };
            let params = if toolkit {
                AnchorParams::toolkit(bounds)
            } else {
                AnchorParams {
                    bounds,
                    ..AnchorParams::default()
                }
            };
            // Each run file is scored as it is read and dropped: memory follows one run's
            // text, not every anchor's masks at once.
            let mut scorer = AnchorScorer::new(&gt, &params);
            for a in &anchors {
                let name = format!("{seq}_{:08}.txt", a.frame);
                let path = first_existing(&[
                    args.tracker.join(&name),
                    args.tracker.join(&seq).join(&name),
                ])
                .ok_or_else(|| format!("no result file {name} in {}", args.tracker.display()))?;
                score_run(&mut scorer, a, &path)?;
                read.push(path);
            }
            let s = scorer.finish()?;
            let sum = summarize_anchor(std::slice::from_ref(&s), &params)?;
            println!(
                "sequence {seq}: {} frames, {} anchors, bounds {:?}, overlap {:?}",
                gt.len(),
                anchors.len(),
                bounds,
                method
            );
            println!("A    {:.4}", sum.accuracy);
            println!("R    {:.4}", sum.robustness);
            println!(
                "EAO  {:.4}  (defined lengths only: {})",
                sum.eao,
                sum.eao_defined.map_or("n/a".into(), |v| format!("{v:.4}"))
            );
            if args.verbose {
                println!("anchor  dir       frames  N^F  failed  accuracy");
                for r in &s.runs {
                    println!(
                        "{:6}  {:8}  {:6}  {:4}  {:6}  {:.4}",
                        r.anchor.frame,
                        format!("{:?}", r.anchor.direction).to_lowercase(),
                        r.length,
                        r.progress,
                        r.failed,
                        r.accuracy
                    );
                }
            }
            let runs_json: Vec<serde_json::Value> = s
                .runs
                .iter()
                .map(|r| {
                    serde_json::json!({"anchor": r.anchor.frame, "direction": r.anchor.direction,
                        "length": r.length, "progress": r.progress, "failed": r.failed, "accuracy": r.accuracy})
                })
                .collect();
            serde_json::json!({"protocol": "anchor", "sequence": seq, "params": params,
                "accuracy": sum.accuracy, "robustness": sum.robustness, "eao": sum.eao,
                "eao_defined": sum.eao_defined, "eao_curve": sum.eao_curve, "anchors": runs_json})
        }
        Protocol::Reset => {
            let params = ResetParams {
                bounds,
                method,
                ..ResetParams::default()
            };
            let path = if args.tracker.is_dir() {
                let name = format!("{seq}_001.txt");
                first_existing(&[
                    args.tracker.join(&name),
                    args.tracker.join(&seq).join(&name),
                ])
                .ok_or_else(|| format!("no result file {name} in {}", args.tracker.display()))?
            } else {
                args.tracker.clone()
            };
            let traj: Vec<Region> = read_regions(&path)?;
            if traj.len() > gt.len() {
                return Err(beyond(&path, gt.len() + 1, "the sequence", gt.len()).into());
            }
            read.push(path);
            let s = evaluate_reset_sequence(&gt, &traj, &params)?;
            let sum = summarize_reset(std::slice::from_ref(&s), &params)?;
            println!(
                "sequence {seq}: {} frames, bounds {:?}, overlap {:?}",
                gt.len(),
                bounds,
                method
            );
            println!("A            {:.4}", sum.accuracy);
            println!("failures     {}", s.failures);
            println!(
                "reliability  {:.4}  (exp(-{}·F/L))",
                sum.reliability, params.sensitivity
            );
            println!(
                "EAO          {}",
                sum.eao.map_or(
                    "n/a (sequence shorter than the EAO range)".into(),
                    |v| format!("{v:.4}")
                )
            );
            if args.verbose {
                println!(
                    "failure frames (1-based): {:?}",
                    s.failure_frames.iter().map(|f| f + 1).collect::<Vec<_>>()
                );
            }
            serde_json::json!({"protocol": "reset", "sequence": seq, "params": params,
                "accuracy": sum.accuracy, "failures": s.failures, "failure_frames": s.failure_frames,
                "reliability": sum.reliability, "eao": sum.eao})
        }
    };
    if let Some(p) = &args.json {
        crate::outputs::refuse_overwrite("--json", p, read.iter().map(PathBuf::as_path))?;
        shapetrack::io::write_text(p, &serde_json::to_string_pretty(&report)?)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::parse_size;

    #[test]
    fn size_must_be_positive() {
        assert_eq!(parse_size("640x480"), Ok((640, 480)));
        assert!(parse_size("0x0").is_err());
        assert!(parse_size("640x").is_err());
    }

    /// A size beyond the readers' image cap is refused: it is a claim, not an image.
    #[test]
    fn size_beyond_the_image_cap_is_refused() {
        let e = parse_size("100000x100000").unwrap_err();
        assert!(e.contains("--size") && e.contains("cap"), "{e}");
        assert!(parse_size("8192x8192").is_ok());
    }
}
