//! `shapetrack detect`: runs a detector over a folder of frames and writes MOTS txt.
//!
//! ```text
//! shapetrack detect --frames DIR [--detector auto|refine|background|moving|auto-motion|refine-colour]
//!                   [--boxes BOXES.txt] [--model PATH|none] --out MASKS.txt
//! ```
//!
//! `auto` and `refine` are the best available: with the learned segmentation's model
//! installed (`npm ci`; see `shapetrack::segment`), every mask comes from it — `refine`
//! segments each box, `auto` each moving blob and each salient region of the whole frame (so
//! objects that stand still are found too). `--model none` (or the detector values
//! `auto-motion` and `refine-colour`) keeps the weights-free path: motion blobs and the
//! GrabCut-like colour refinement. Without the model and without `--model`, `auto` and
//! `refine` warn and take the weights-free path.
//!
//! Frames are the folder's `.jpg`/`.jpeg`/`.png` files in name order, numbered from 1. Each
//! detection becomes one line `frame id class height width rle` with id `-1` (detections carry
//! no identity, as in `synth`'s `det_mots.txt`) and the box's class, `-1` when unknown.
//! `--boxes` (MOTChallenge txt) gives the boxes to refine into masks. Other scripts rely on
//! exactly these flags.

use shapetrack::io::image_files;
use shapetrack::io::motchallenge::read_boxes;
use shapetrack::segment::{
    ChoiceError, Learned, Net, SegmentConfig, VideoDetector, VideoDetectorKind, AUTO_WHOLE_FRAME,
};
use shapetrack::Detection;
use std::path::PathBuf;

/// Which detector runs (the library's kinds, which the Python package parses too).
pub type Kind = VideoDetectorKind;

/// Arguments of `shapetrack detect`.
#[derive(clap::Args)]
pub struct Args {
    /// Folder of frames (.jpg/.png), sorted by file name, numbered from 1.
    #[arg(long)]
    frames: PathBuf,
    /// Detector.
    #[arg(long, value_enum, default_value_t = Kind::Auto)]
    detector: Kind,
    /// MOTChallenge boxes (frame,id,x,y,w,h,score,...) to refine into masks.
    #[arg(long)]
    boxes: Option<PathBuf>,
    /// MOTS txt output (frame id class height width rle).
    #[arg(long)]
    out: PathBuf,
    /// The learned segmentation's model file (u2netp.onnx; found in the checkout's
    /// node_modules when absent), or `none` for the weights-free path.
    #[arg(long)]
    model: Option<String>,
    /// Learned segmentation settings as JSON over the defaults (e.g. `{"margin": 0.5}`).
    #[arg(long)]
    segment: Option<String>,
}

/// How `--model` was given.
pub enum ModelChoice {
    /// Not given: the checkout's model if installed, else the weights-free path with a warning.
    Default,
    /// `--model none`.
    Off,
    /// `--model PATH`: that file or an error.
    Path(PathBuf),
}

impl ModelChoice {
    /// From the flag's value.
    pub fn from_flag(v: Option<&str>) -> ModelChoice {
        match v {
            None => ModelChoice::Default,
            Some("none") => ModelChoice::Off,
            Some(p) => ModelChoice::Path(PathBuf::from(p)),
        }
    }

    /// The network, or `None` for the weights-free path (`what` names the command in the
    /// warning printed when the model is missing).
    #[cfg(not(target_arch = "wasm32"))]
    pub fn load(&self, what: &str) -> Result<Option<Box<dyn Net>>, Box<dyn std::error::Error>> {
        use shapetrack::segment::TractNet;
        match self {
            ModelChoice::Off => Ok(None),
            ModelChoice::Path(p) => Ok(Some(Box::new(TractNet::load(Some(p))?))),
            ModelChoice::Default => match TractNet::load(None) {
                Ok(n) => Ok(Some(Box::new(n))),
                Err(e) => {
                    eprintln!("{what}: warning: {e}\n{what}: using the weights-free path");
                    Ok(None)
                }
            },
        }
    }

    /// The CLI compiled for wasm32 (only so `wasm-pack test` builds every target) has no
    /// native network: the weights-free path, or an error when a model file is named.
    #[cfg(target_arch = "wasm32")]
    pub fn load(&self, _what: &str) -> Result<Option<Box<dyn Net>>, Box<dyn std::error::Error>> {
        match self {
            ModelChoice::Path(p) => Err(format!(
                "{}: the learned segmentation runs natively only",
                p.display()
            )
            .into()),
            _ => Ok(None),
        }
    }
}

/// The learned segmentation's settings from `--segment` (the library's
/// [`shapetrack::segment::segment_settings`], the flag named in its error).
pub fn segment_settings(
    json: Option<&str>,
    boxes: bool,
) -> Result<SegmentConfig, Box<dyn std::error::Error>> {
    Ok(
        shapetrack::segment::segment_settings(json, boxes)
            .map_err(|e| format!("--segment: {e}"))?,
    )
}

/// Errors of the detect command that are not I/O or detector errors.
#[derive(Debug, thiserror::Error)]
pub enum DetectCliError {
    /// The frame folder has no image.
    #[error("{dir}: no .jpg or .png frames in this folder")]
    NoFrames {
        /// The folder.
        dir: String,
    },
    /// `--detector refine` without `--boxes`.
    #[error("--detector refine needs --boxes BOXES.txt")]
    RefineWithoutBoxes,
    /// `--boxes` with a detector that finds its own objects.
    #[error("--boxes can only be used with --detector refine or auto")]
    BoxesNotUsed,
    /// `--out` is one of the inputs.
    #[error("--out {0} would overwrite an input")]
    OutIsInput(String),
}

/// A detector chosen by [`Kind`], run frame by frame (the library's, shared with the Python
/// package).
pub type Runner = VideoDetector;

/// The weights-free detector for `kind` (the library's [`VideoDetector::choose`], with the
/// CLI's wording); `boxes` are the per-frame boxes (refine, auto).
pub fn runner(
    kind: Kind,
    boxes: Option<Vec<Vec<Detection>>>,
) -> Result<Runner, Box<dyn std::error::Error>> {
    Runner::choose(kind, boxes).map_err(|e| match e {
        ChoiceError::RefineWithoutBoxes => DetectCliError::RefineWithoutBoxes.into(),
        ChoiceError::BoxesNotUsed => DetectCliError::BoxesNotUsed.into(),
        ChoiceError::Detector(e) => e.into(),
    })
}

pub fn run(args: Args) -> crate::CliResult {
    let files = image_files(&args.frames)?;
    if files.is_empty() {
        return Err(DetectCliError::NoFrames {
            dir: args.frames.display().to_string(),
        }
        .into());
    }
    let same = crate::outputs::same_file;
    if files.iter().any(|f| same(f, &args.out))
        || args.boxes.as_deref().is_some_and(|b| same(b, &args.out))
    {
        return Err(DetectCliError::OutIsInput(args.out.display().to_string()).into());
    }
    let boxes = args
        .boxes
        .as_deref()
        .map(|p| read_boxes(p, files.len()))
        .transpose()?;
    // Checked whether or not a model runs: a typo in --segment must not pass unnoticed
    // just because this run happens not to use the model.
    let cfg = segment_settings(args.segment.as_deref(), boxes.is_some())?;
    let mut runner = runner(args.detector, boxes)?;
    if args.detector.wants_model() {
        if let Some(net) = ModelChoice::from_flag(args.model.as_deref()).load("detect")? {
            runner = runner.learned(Learned {
                net,
                cfg,
                whole: AUTO_WHOLE_FRAME,
            });
        }
    }
    let masks = runner.detect_files(&files, &args.out)?;
    eprintln!(
        "detect: {} frames, {masks} masks, detector {}",
        files.len(),
        runner.name()
    );
    Ok(())
}
