//! The `shapetrack` command-line tool: track, detect, evaluate, generate synthetic scenes,
//! benchmark.
//!
//! Each subcommand lives in its own module with its `Args` and `run`; flags other tools rely on
//! are listed in the README and must not change.

mod bench;
mod detect;
mod detect_eval;
mod eval;
mod eval_vot;
mod follow;
// The grid needs the native-only `shapetrack::grid` (and rayon). The CLI is a native tool,
// but `wasm-pack test` builds every target for wasm32, so the rest compiles there too.
#[cfg(not(target_arch = "wasm32"))]
mod grid;
mod netcache;
mod outputs;
mod synth;
mod track;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Result type of every subcommand: errors are printed, never panicked.
pub type CliResult = Result<(), Box<dyn std::error::Error>>;

#[derive(Parser)]
#[command(
    name = "shapetrack",
    version,
    about = "Multi-object shape tracker: track, evaluate, synthesise, benchmark"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Track detections (MOTChallenge det.txt boxes or MOTS masks) and write results.
    Track(track::Args),
    /// Evaluate MOTChallenge-layout results: CLEAR, Identity and HOTA, as TrackEval.
    Eval(eval::Args),
    /// Evaluate VOT short-term results: accuracy, robustness, EAO.
    EvalVot(eval_vot::Args),
    /// Follow one target given by a binary PNG mask at one frame, forward and backward;
    /// write MOTS txt.
    Follow(follow::Args),
    /// Run the follower under the VOT anchor and reset protocols; write region files for
    /// `eval-vot`.
    Vot(follow::VotArgs),
    /// Write a deterministic synthetic sequence in MOTChallenge layout.
    Synth(synth::Args),
    /// Run a detector over a folder of frames and write its masks as MOTS txt.
    Detect(detect::Args),
    /// Mask quality (J) and speed of each detector on DAVIS-layout sequences.
    DetectEval(detect_eval::Args),
    /// Measure speed (frames per second) of the tracker and its stages.
    Bench(bench::Args),
    /// The robustness grid: datasets × detector models × trackers.
    #[cfg(not(target_arch = "wasm32"))]
    Grid(grid::Args),
}

#[cfg(target_arch = "wasm32")]
fn main() -> ExitCode {
    run()
}

#[cfg(not(target_arch = "wasm32"))]
fn main() -> ExitCode {
    // One thread, as in the browser (ARCHITECTURE.md: single-threaded per worker), and the
    // command runs *on* that pool's thread: linfa's k-means calls rayon for every small
    // per-pair clustering, and from outside the pool each call is a hand-off to a worker and
    // back (profiled on 50 masks a frame: ~12 % of the time in futex waits and context
    // switches). Run inside the pool, rayon executes those calls inline. Same output.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .stack_size(8 << 20)
        .build();
    match pool {
        Ok(p) => p.install(run),
        Err(_) => run(),
    }
}

fn run() -> ExitCode {
    let cli = Cli::parse();
    let res = match cli.cmd {
        Cmd::Track(a) => track::run(a),
        Cmd::Eval(a) => eval::run(a),
        Cmd::EvalVot(a) => eval_vot::run(a),
        Cmd::Follow(a) => follow::run(a),
        Cmd::Vot(a) => follow::run_vot(a),
        Cmd::Synth(a) => synth::run(a),
        Cmd::Detect(a) => detect::run(a),
        Cmd::DetectEval(a) => detect_eval::run(a),
        Cmd::Bench(a) => bench::run(a),
        #[cfg(not(target_arch = "wasm32"))]
        Cmd::Grid(a) => grid::run(a),
    };
    match res {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            let mut src = e.source();
            while let Some(s) = src {
                eprintln!("  caused by: {s}");
                src = s.source();
            }
            ExitCode::FAILURE
        }
    }
}
