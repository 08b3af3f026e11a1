//! `shapetrack eval`: CLEAR, Identity and HOTA over a TrackEval-layout folder, as TrackEval.
//!
//! `shapetrack eval --gt GT_ROOT --tracker RESULTS_ROOT --benchmark NAME [--split train]
//! [--seq S ...] [--masks] [--json FILE]`; other tools rely on exactly these flags.

use shapetrack::eval::{evaluate, EvalConfig, MotSummary, Preprocessing, Similarity, Summary};
use shapetrack::io::layout::{discover, load_sequence, results_file, Format};
use std::fmt::Write as _;
use std::path::PathBuf;

/// Preprocessing choice on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum PreprocArg {
    /// From the benchmark name (MOT15 → mot15, MOT20 → mot20, MOTS/--masks → mots, else mot17).
    Auto,
    /// Score every row as given.
    None,
    /// Drop zero-marked gt rows only.
    Mot15,
    /// MOT16/17 distractor removal, pedestrian-only gt, zero-marked rows dropped.
    Mot17,
    /// As mot17 with non-MOT vehicles as distractors.
    Mot20,
    /// MOTSChallenge: class filter, class-10 ignore regions.
    Mots,
}

/// Arguments of `shapetrack eval`.
#[derive(clap::Args)]
pub struct Args {
    /// Ground-truth root: GT_ROOT/<BENCH>-<split>/<seq>/{gt/gt.txt,seqinfo.ini} or flat
    /// GT_ROOT/<seq>/...; sequences from GT_ROOT/seqmaps/<BENCH>-<split>.txt when present.
    #[arg(long, value_name = "GT_ROOT")]
    gt: PathBuf,
    /// Folder of results files, one RESULTS_ROOT/<seq>.txt per sequence.
    #[arg(long, value_name = "RESULTS_ROOT")]
    tracker: PathBuf,
    /// Benchmark name (MOT15, MOT16, MOT17, MOT20, MOTS, ...); picks the default preprocessing.
    #[arg(long, value_name = "NAME")]
    benchmark: String,
    /// Split folder suffix.
    #[arg(long, default_value = "train")]
    split: String,
    /// Evaluate only these sequences (repeatable).
    #[arg(long = "seq", value_name = "S", num_args = 1..)]
    seqs: Vec<String>,
    /// MOTS txt files (RLE masks) and mask IoU.
    #[arg(long)]
    masks: bool,
    /// Write per-sequence and combined figures as JSON.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Preprocessing (default: from the benchmark name, as TrackEval).
    #[arg(long, value_enum, default_value_t = PreprocArg::Auto)]
    preproc: PreprocArg,
    /// Class to evaluate with MOTS preprocessing (2 = pedestrian).
    #[arg(long = "class", value_name = "ID")]
    class: Option<i32>,
    /// Similarity a CLEAR/Identity match needs.
    #[arg(long, default_value_t = 0.5)]
    threshold: f64,
    /// Score a sequence without a results file as an empty tracker instead of failing.
    #[arg(long)]
    allow_missing_results: bool,
}

fn config(args: &Args) -> Result<EvalConfig, Box<dyn std::error::Error>> {
    let mut cfg = EvalConfig::for_benchmark(&args.benchmark, args.masks);
    let mots_class = args.class.unwrap_or(shapetrack::eval::MOTS_PEDESTRIAN);
    cfg.preprocessing = match args.preproc {
        PreprocArg::Auto => match cfg.preprocessing {
            Preprocessing::Mots { .. } => Preprocessing::Mots { class: mots_class },
            p => p,
        },
        PreprocArg::None => Preprocessing::None,
        PreprocArg::Mot15 => Preprocessing::Mot15,
        PreprocArg::Mot17 => Preprocessing::Mot17,
        PreprocArg::Mot20 => Preprocessing::Mot20,
        PreprocArg::Mots => Preprocessing::Mots { class: mots_class },
    };
    if matches!(cfg.preprocessing, Preprocessing::Mots { .. }) && !args.masks {
        return Err("MOTS preprocessing needs mask files: add --masks".into());
    }
    cfg.similarity = if args.masks {
        Similarity::MaskIou
    } else {
        Similarity::BoxIou
    };
    if !(args.threshold > 0.0 && args.threshold <= 1.0) {
        return Err(format!("--threshold {} must be in (0, 1]", args.threshold).into());
    }
    cfg.threshold = args.threshold;
    Ok(cfg)
}

/// Runs the subcommand.
pub fn run(args: Args) -> crate::CliResult {
    let cfg = config(&args)?;
    let mut layout = discover(&args.gt, &args.benchmark, &args.split)?;
    if !args.seqs.is_empty() {
        layout.select(&args.seqs)?;
    }
    let format = if args.masks {
        Format::Mots
    } else {
        Format::Mot
    };
    if let Some(json) = &args.json {
        // Never over a file this run reads (ground truth, seqinfo, results).
        let read: Vec<PathBuf> = layout
            .sequences
            .iter()
            .flat_map(|e| {
                [
                    e.gt_file.clone(),
                    e.seqinfo_file.clone(),
                    results_file(&args.tracker, &e.name),
                ]
            })
            .collect();
        crate::outputs::refuse_overwrite("--json", json, read.iter().map(PathBuf::as_path))?;
    }
    let inputs = layout
        .sequences
        .iter()
        .map(|e| load_sequence(e, &args.tracker, format, args.allow_missing_results))
        .collect::<Result<Vec<_>, _>>()?;
    let results = evaluate(&inputs, &cfg)?;
    let summary = results.summary();
    print!("{}", table(&summary));
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&summary)?;
        shapetrack::io::write_text(path, &(text + "\n"))?;
    }
    Ok(())
}

const COLUMNS: [&str; 16] = [
    "HOTA", "DetA", "AssA", "LocA", "MOTA", "MOTP", "IDF1", "IDP", "IDR", "IDSW", "FP", "FN",
    "Frag", "MT", "PT", "ML",
];

fn row(out: &mut String, name: &str, s: &Summary) {
    let floats = [
        s.hota, s.det_a, s.ass_a, s.loc_a, s.mota, s.motp, s.idf1, s.idp, s.idr,
    ];
    let ints = [s.idsw, s.fp, s.fn_, s.frag, s.mt, s.pt, s.ml];
    let _ = write!(out, "{name:<24}");
    for v in floats {
        let _ = write!(out, "{v:>9.3}");
    }
    for v in ints {
        let _ = write!(out, "{v:>8}");
    }
    out.push('\n');
}

/// TrackEval-style summary: one row per sequence (sorted) and a COMBINED row.
fn table(s: &MotSummary) -> String {
    let mut out = String::new();
    let _ = write!(out, "{:<24}", "Sequence");
    for (k, c) in COLUMNS.iter().enumerate() {
        let w = if k < 9 { 9 } else { 8 };
        let _ = write!(out, "{c:>w$}");
    }
    out.push('\n');
    for (name, r) in &s.sequences {
        row(&mut out, name, r);
    }
    row(&mut out, "COMBINED", &s.combined);
    out
}
