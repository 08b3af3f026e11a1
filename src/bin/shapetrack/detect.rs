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

use clap::ValueEnum;
use shapetrack::detect::{
    BackgroundConfig, BackgroundSubtractor, BoxRefiner, CameraJudge, DetectError, Detector,
    MovingCameraDetector, MovingConfig, RefineConfig,
};
use shapetrack::io::limits::MAX_BOXES_PER_FRAME;
use shapetrack::io::motchallenge::{parse_mot_line, write_mots, MotReadOptions};
use shapetrack::io::{image_files, read_rgb, read_text, AtomicFile, IoError, Record, Rle};
use shapetrack::segment::{Job, Net, SegmentConfig, WholeFrame};
use shapetrack::{Detection, Frame};
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// Which detector runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Kind {
    /// `refine` when boxes are given; otherwise `background` or `moving`, chosen from how much
    /// the camera moves over the first frames, then (with the model) each blob and each
    /// salient region of the whole frame segmented by the learned model.
    Auto,
    /// The thesis' adaptive background subtractor (static camera).
    Background,
    /// Camera-motion-compensated background subtraction with box refinement (moving camera).
    Moving,
    /// Refines the `--boxes` into masks: the learned model (when installed), the colour
    /// refinement for a box it finds nothing in.
    Refine,
    /// `auto` without the learned model: motion blobs only.
    AutoMotion,
    /// `refine` without the learned model: GrabCut-like colour + edge segmentation.
    RefineColour,
}

impl Kind {
    /// The weights-free kind this one falls back to, and whether it would use the model.
    pub fn plain(self) -> (Kind, bool) {
        match self {
            Kind::Auto => (Kind::Auto, true),
            Kind::Refine => (Kind::Refine, true),
            Kind::AutoMotion => (Kind::Auto, false),
            Kind::RefineColour => (Kind::Refine, false),
            k => (k, false),
        }
    }
}

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

/// The learned stage of a detector: the network and its settings.
pub struct Learned {
    /// The network.
    pub net: Box<dyn Net>,
    /// Its settings.
    pub cfg: SegmentConfig,
    /// Whole-frame pass of the automatic detector (boxes never get one).
    pub whole: WholeFrame,
}

/// The learned segmentation's settings: `--segment`'s JSON over the defaults, a crop around a
/// given box at [`shapetrack::segment::BOX_SIDE`] (as in the page) unless the JSON sets `side`.
pub fn segment_settings(
    json: Option<&str>,
    boxes: bool,
) -> Result<SegmentConfig, Box<dyn std::error::Error>> {
    let base = if boxes {
        SegmentConfig::default().for_boxes()
    } else {
        SegmentConfig::default()
    };
    let cfg = match json {
        Some(j) => {
            let v = serde_json::from_str(j).map_err(|e| format!("--segment: {e}"))?;
            shapetrack::settings::overlay(&base, &v).map_err(|e| format!("--segment: {e}"))?
        }
        None => base,
    };
    cfg.validate().map_err(|e| format!("--segment: {e}"))?;
    Ok(cfg)
}

/// Frames the auto choice watches before deciding between a static and a moving camera.
pub const JUDGE_FRAMES: usize = 5;

/// The automatic detector's whole-frame pass with the learned model (chosen on the 21 DAVIS
/// clips, `tests/data/detect/README.md`).
pub const AUTO_WHOLE_FRAME: WholeFrame = WholeFrame::Proposals;

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
    /// Frames of different sizes in one folder.
    #[error("{file}: frame is {width}x{height}, the first frame was {first_width}x{first_height}")]
    SizeChanged {
        /// The frame.
        file: String,
        /// Its width.
        width: u32,
        /// Its height.
        height: u32,
        /// The first frame's width.
        first_width: u32,
        /// The first frame's height.
        first_height: u32,
    },
    /// `--out` is one of the inputs.
    #[error("--out {0} would overwrite an input")]
    OutIsInput(String),
    /// A detector failed on a frame.
    #[error("frame {frame}: {source}")]
    Detect {
        /// 1-based frame number.
        frame: u32,
        /// The detector's error.
        #[source]
        source: DetectError,
    },
}

/// A detector chosen by [`Kind`], run frame by frame.
pub enum Runner {
    /// Still deciding (auto without boxes): both detectors learn; the moving one reports.
    Judging {
        judge: CameraJudge,
        background: Box<BackgroundSubtractor>,
        moving: Box<MovingCameraDetector>,
    },
    /// Static camera.
    Background(Box<BackgroundSubtractor>),
    /// Moving camera.
    Moving(Box<MovingCameraDetector>),
    /// Box refinement; the boxes of every frame, index = frame number.
    Refine(BoxRefiner, Vec<Vec<Detection>>),
    /// A weights-free detector whose detections (or boxes) the learned model segments.
    Learned(Box<Runner>, Box<Learned>),
}

impl Runner {
    /// The detector for `kind`; `boxes` are the per-frame boxes (refine, auto).
    pub fn new(
        kind: Kind,
        boxes: Option<Vec<Vec<Detection>>>,
    ) -> Result<Runner, Box<dyn std::error::Error>> {
        let bg = || BackgroundSubtractor::new(BackgroundConfig::default()).map(Box::new);
        let mv = || MovingCameraDetector::new(MovingConfig::default()).map(Box::new);
        let kind = kind.plain().0;
        Ok(match (kind, boxes) {
            (Kind::Refine | Kind::Auto | Kind::RefineColour | Kind::AutoMotion, Some(b)) => {
                Runner::Refine(BoxRefiner::new(RefineConfig::default())?, b)
            }
            (Kind::Refine | Kind::RefineColour, None) => {
                return Err(DetectCliError::RefineWithoutBoxes.into())
            }
            (_, Some(_)) => return Err(DetectCliError::BoxesNotUsed.into()),
            (Kind::Background, None) => Runner::Background(bg()?),
            (Kind::Moving, None) => Runner::Moving(mv()?),
            (Kind::Auto | Kind::AutoMotion, None) => Runner::Judging {
                judge: CameraJudge::new(),
                background: bg()?,
                moving: mv()?,
            },
        })
    }

    /// `self` with the learned stage on top.
    pub fn learned(self, learned: Learned) -> Runner {
        Runner::Learned(Box::new(self), Box::new(learned))
    }

    /// Lets the detector learn from frame `n` without asking for its detections (the learned
    /// stage does not run): an evaluation that scores every Nth frame keeps a background
    /// model as current as a full run would.
    pub fn observe(&mut self, n: u32, frame: &Frame) -> Result<(), DetectError> {
        match self {
            Runner::Learned(base, _) => base.observe(n, frame),
            Runner::Refine(..) => Ok(()),
            _ => self.detect(n, frame).map(|_| ()),
        }
    }

    /// The name of the detector running now (auto says what it chose once it has).
    pub fn name(&self) -> String {
        match self {
            Runner::Judging { .. } => "auto (judging the camera)".into(),
            Runner::Background(_) => "background".into(),
            Runner::Moving(_) => "moving".into(),
            Runner::Refine(..) => "refine".into(),
            Runner::Learned(base, _) => format!("{} + learned segmentation", base.name()),
        }
    }

    /// The detections of frame `n` (1-based).
    pub fn detect(&mut self, n: u32, frame: &Frame) -> Result<Vec<Detection>, DetectError> {
        match self {
            Runner::Learned(base, learned) => {
                let Learned { net, cfg, whole } = &mut **learned;
                let seg = |e: shapetrack::segment::SegmentError| DetectError::Refine {
                    reason: format!("learned segmentation: {e}"),
                };
                if let Runner::Refine(r, boxes) = &mut **base {
                    // Boxes: the model first; the colour refinement for those it finds
                    // nothing in (they are still box-only).
                    let b = boxes.get(n as usize).cloned().unwrap_or_default();
                    let mut job = Job::new(frame.width(), frame.height(), b, WholeFrame::Off, cfg)
                        .map_err(seg)?;
                    job.run(frame, net.as_mut()).map_err(seg)?;
                    let mut dets = job.finish().detections;
                    r.refine_all(frame, &mut dets, None)?;
                    return Ok(dets);
                }
                let dets = base.detect(n, frame)?;
                let mut job =
                    Job::new(frame.width(), frame.height(), dets, *whole, cfg).map_err(seg)?;
                job.run(frame, net.as_mut()).map_err(seg)?;
                Ok(job.finish().detections)
            }
            Runner::Background(d) => d.detect(frame),
            Runner::Moving(d) => d.detect(frame),
            Runner::Refine(r, boxes) => {
                let b = boxes.get(n as usize).cloned().unwrap_or_default();
                r.set_boxes(b);
                r.detect(frame)
            }
            Runner::Judging {
                judge,
                background,
                moving,
            } => {
                judge.observe(frame);
                background.detect(frame)?;
                let out = moving.detect(frame)?;
                if judge.pairs() + 1 >= JUDGE_FRAMES {
                    let next = if judge.moving() == Some(false) {
                        Runner::Background(std::mem::replace(
                            background,
                            Box::new(BackgroundSubtractor::new(BackgroundConfig::default())?),
                        ))
                    } else {
                        Runner::Moving(std::mem::replace(
                            moving,
                            Box::new(MovingCameraDetector::new(MovingConfig::default())?),
                        ))
                    };
                    *self = next;
                }
                Ok(out)
            }
        }
    }
}

/// Reads MOTChallenge boxes into per-frame detections (index = frame number). A box for a
/// frame the folder does not have (beyond its `frames` frames) is an error naming its line:
/// it would never be refined, and the output would lose it without a word. A frame of more
/// than [`MAX_BOXES_PER_FRAME`] boxes (the tracker's cap) is an error naming the first line
/// over it: the refiner's work per frame would follow the file's claim.
pub fn read_boxes(path: &Path, frames: usize) -> Result<Vec<Vec<Detection>>, IoError> {
    let file = path.display().to_string();
    let text = read_text(path)?;
    let mut out = vec![Vec::new(); frames + 1];
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let Some(r) = parse_mot_line(raw, &file, line, MotReadOptions::default())? else {
            continue;
        };
        let Some(v) = out.get_mut(r.frame as usize) else {
            return Err(IoError::Invalid {
                file,
                line,
                message: format!(
                    "a box for frame {}, but the frame folder holds {frames} frames",
                    r.frame
                ),
            });
        };
        if v.len() == MAX_BOXES_PER_FRAME {
            return Err(IoError::Invalid {
                file,
                line,
                message: format!(
                    "frame {} holds more than {MAX_BOXES_PER_FRAME} boxes, the most per \
                     frame the tracker and the refiner take (src/io/limits.rs)",
                    r.frame
                ),
            });
        }
        let mut d = Detection::from_box(r.bbox, r.score);
        d.class = r.class;
        v.push(d);
    }
    Ok(out)
}

/// MOTS records of one frame's detections (id -1: detections carry no identity).
pub fn records(n: u32, dets: &[Detection], w: u32, h: u32) -> Vec<Record> {
    dets.iter()
        .filter_map(|d| {
            let m = d.mask.as_ref()?;
            let mut r = Record::from_box(n, -1, d.bbox);
            r.score = d.score;
            r.class = d.class;
            r.mask = Some(Rle::from_mask(m, w, h));
            Some(r)
        })
        .collect()
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
    let (kind, wants_model) = args.detector.plain();
    // Checked whether or not a model runs: a typo in --segment must not pass unnoticed
    // just because this run happens not to use the model.
    let cfg = segment_settings(args.segment.as_deref(), boxes.is_some())?;
    let mut runner = Runner::new(kind, boxes)?;
    if wants_model {
        if let Some(net) = ModelChoice::from_flag(args.model.as_deref()).load("detect")? {
            runner = runner.learned(Learned {
                net,
                cfg,
                whole: AUTO_WHOLE_FRAME,
            });
        }
    }
    // Written frame by frame, like `track`: a long folder's masks are never all held. The
    // file is atomic, so a failure midway still leaves any old output untouched.
    let mut out = AtomicFile::create(&args.out)?;
    let mut masks = 0usize;
    let mut first: Option<(u32, u32)> = None;
    for (i, path) in files.iter().enumerate() {
        let n = i as u32 + 1;
        let img = read_rgb(path)?;
        let (w, h) = img.dimensions();
        let (fw, fh) = *first.get_or_insert((w, h));
        if (w, h) != (fw, fh) {
            return Err(DetectCliError::SizeChanged {
                file: path.display().to_string(),
                width: w,
                height: h,
                first_width: fw,
                first_height: fh,
            }
            .into());
        }
        let frame = Frame::rgb(img.as_raw(), w, h)?;
        let dets = runner
            .detect(n, &frame)
            .map_err(|source| DetectCliError::Detect { frame: n, source })?;
        let recs = records(n, &dets, w, h);
        masks += recs.len();
        out.write_all(write_mots(&recs).as_bytes())
            .map_err(|source| IoError::Io {
                file: args.out.display().to_string(),
                source,
            })?;
    }
    out.commit()?;
    eprintln!(
        "detect: {} frames, {masks} masks, detector {}",
        files.len(),
        runner.name()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::read_boxes;
    use shapetrack::io::limits::MAX_BOXES_PER_FRAME;

    /// `--boxes` takes at most the tracker's boxes per frame: the refiner's work per frame
    /// follows the file's claim otherwise. The error names the file and the first line over.
    #[test]
    fn boxes_beyond_the_per_frame_cap_are_refused_with_their_line() {
        let dir = std::env::temp_dir().join(format!("st-boxes-cap-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("boxes.txt");
        let mut text = String::from("1,-1,5,5,10,10,0.9,-1,-1,-1\n");
        for k in 0..=MAX_BOXES_PER_FRAME {
            text.push_str(&format!("2,-1,{k},5,10,10,0.9,-1,-1,-1\n"));
        }
        std::fs::write(&path, &text).unwrap();
        let e = read_boxes(&path, 3).unwrap_err().to_string();
        let line = MAX_BOXES_PER_FRAME + 2;
        assert!(e.contains(&format!("boxes.txt:{line}:")), "{e}");
        assert!(e.contains("frame 2"), "{e}");
        // At the cap it is read.
        let at_cap: String = text
            .lines()
            .take(line - 1)
            .map(|l| format!("{l}\n"))
            .collect();
        std::fs::write(&path, at_cap).unwrap();
        assert_eq!(read_boxes(&path, 3).unwrap()[2].len(), MAX_BOXES_PER_FRAME);
        std::fs::remove_dir_all(&dir).ok();
    }
}
