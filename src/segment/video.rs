//! A detector chosen at run time and run over a video's frames in order, with the learned
//! segmentation optionally on top: what `shapetrack detect` runs, and the Python package's
//! `detect` with it (one implementation, so the two give the same masks bit for bit).

use super::{Job, Net, SegmentConfig, SegmentError, WholeFrame};
use crate::detect::{
    BackgroundConfig, BackgroundSubtractor, BoxRefiner, CameraJudge, DetectError, Detector,
    MovingCameraDetector, MovingConfig, RefineConfig,
};
use crate::frame::{Detection, Frame, FrameError};
use crate::io::IoError;
use std::path::{Path, PathBuf};

/// Frames the automatic choice watches before deciding between a static and a moving camera.
pub const JUDGE_FRAMES: usize = 5;

/// The automatic detector's whole-frame pass with the learned model (chosen on the 21 DAVIS
/// clips, `tests/data/detect/README.md`): salient regions no motion blob covers are segmented
/// too, so objects that stand still get masks.
pub const AUTO_WHOLE_FRAME: WholeFrame = WholeFrame::Proposals;

/// The learned segmentation's settings as `shapetrack detect --segment JSON` gives them: the
/// JSON's fields over the defaults, a crop around a given box (`boxes`) at
/// [`super::BOX_SIDE`] (as in the page) unless the JSON sets `side`. Checked; the error is the
/// JSON's or the setting's message.
pub fn segment_settings(json: Option<&str>, boxes: bool) -> Result<SegmentConfig, String> {
    let base = if boxes {
        SegmentConfig::default().for_boxes()
    } else {
        SegmentConfig::default()
    };
    let cfg = match json {
        Some(j) => {
            let v = serde_json::from_str(j).map_err(|e| e.to_string())?;
            crate::settings::overlay(&base, &v).map_err(|e| e.to_string())?
        }
        None => base,
    };
    cfg.validate().map_err(|e| e.to_string())?;
    Ok(cfg)
}

/// Which detector runs over a video: the values of `shapetrack detect --detector` and of the
/// Python package's `detector=` (one mapping, so the two build the same detector). The doc
/// comments are the CLI's help.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum VideoDetectorKind {
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

impl VideoDetectorKind {
    /// Every kind with its name (the CLI's value; for callers without the `cli` feature).
    pub const ALL: [(&'static str, VideoDetectorKind); 6] = [
        ("auto", VideoDetectorKind::Auto),
        ("refine", VideoDetectorKind::Refine),
        ("background", VideoDetectorKind::Background),
        ("moving", VideoDetectorKind::Moving),
        ("auto-motion", VideoDetectorKind::AutoMotion),
        ("refine-colour", VideoDetectorKind::RefineColour),
    ];

    /// The kind named `name` (as in [`Self::ALL`]).
    pub fn parse(name: &str) -> Option<Self> {
        Self::ALL.iter().find(|(n, _)| *n == name).map(|&(_, k)| k)
    }

    /// Whether this kind puts the learned model on top when it is installed.
    pub fn wants_model(self) -> bool {
        matches!(self, VideoDetectorKind::Auto | VideoDetectorKind::Refine)
    }
}

/// Why [`VideoDetector::choose`] could not build a detector.
#[derive(Debug, thiserror::Error)]
pub enum ChoiceError {
    /// Refinement without boxes.
    #[error("refinement needs boxes")]
    RefineWithoutBoxes,
    /// Boxes given to a detector that finds its own objects.
    #[error("only the detectors refine and auto take boxes")]
    BoxesNotUsed,
    /// The detector's own settings.
    #[error(transparent)]
    Detector(#[from] DetectError),
}

/// Why [`VideoDetector::detect_files`] stopped; the output file is then left as it was.
#[derive(Debug, thiserror::Error)]
pub enum DetectFilesError {
    /// Reading a frame or writing the output.
    #[error(transparent)]
    Io(#[from] IoError),
    /// A frame's pixels.
    #[error(transparent)]
    Frame(#[from] FrameError),
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
    /// The detector failed on a frame.
    #[error("frame {frame}: {source}")]
    Detect {
        /// 1-based frame number.
        frame: u32,
        /// The detector's error.
        #[source]
        source: DetectError,
    },
}

/// The learned stage of a [`VideoDetector`]: the network and its settings. `N` is the
/// network's type (`dyn Net`, or `dyn Net + Send` where the detector crosses threads).
pub struct Learned<N: Net + ?Sized = dyn Net> {
    /// The network.
    pub net: Box<N>,
    /// Its settings.
    pub cfg: SegmentConfig,
    /// Whole-frame pass (boxes given by the caller never get one).
    pub whole: WholeFrame,
}

/// A weights-free detector, or one of them with the learned segmentation on top.
pub enum VideoDetector<N: Net + ?Sized = dyn Net> {
    /// Still deciding (the automatic detector's first [`JUDGE_FRAMES`] frames): both
    /// detectors learn; the moving one reports.
    Judging {
        /// Watches how much the camera moves.
        judge: CameraJudge,
        /// The static-camera detector, learning its background meanwhile.
        background: Box<BackgroundSubtractor>,
        /// The moving-camera detector, whose detections are reported meanwhile.
        moving: Box<MovingCameraDetector>,
    },
    /// Static camera: the thesis' adaptive background subtractor.
    Background(Box<BackgroundSubtractor>),
    /// Moving camera: motion-compensated background subtraction with box refinement.
    Moving(Box<MovingCameraDetector>),
    /// Box refinement; the boxes of every frame, index = frame number (1-based; 0 unused).
    Refine(BoxRefiner, Vec<Vec<Detection>>),
    /// A weights-free detector whose detections (or given boxes) the learned model segments.
    Learned(Box<VideoDetector<N>>, Box<Learned<N>>),
}

fn background() -> Result<Box<BackgroundSubtractor>, DetectError> {
    BackgroundSubtractor::new(BackgroundConfig::default()).map(Box::new)
}

fn moving() -> Result<Box<MovingCameraDetector>, DetectError> {
    MovingCameraDetector::new(MovingConfig::default()).map(Box::new)
}

fn segment_error(e: SegmentError) -> DetectError {
    DetectError::Refine {
        reason: format!("learned segmentation: {e}"),
    }
}

impl<N: Net + ?Sized> VideoDetector<N> {
    /// The automatic detector: background subtraction or the moving-camera detector, chosen
    /// from how much the camera moves over the first [`JUDGE_FRAMES`] frames.
    pub fn auto() -> Result<Self, DetectError> {
        Ok(VideoDetector::Judging {
            judge: CameraJudge::new(),
            background: background()?,
            moving: moving()?,
        })
    }

    /// The static-camera background subtractor.
    pub fn background() -> Result<Self, DetectError> {
        Ok(VideoDetector::Background(background()?))
    }

    /// The moving-camera detector.
    pub fn moving() -> Result<Self, DetectError> {
        Ok(VideoDetector::Moving(moving()?))
    }

    /// Refinement of given boxes into masks; `boxes[n]` holds frame `n`'s (1-based).
    pub fn refine(boxes: Vec<Vec<Detection>>) -> Result<Self, DetectError> {
        Ok(VideoDetector::Refine(
            BoxRefiner::new(RefineConfig::default())?,
            boxes,
        ))
    }

    /// The weights-free detector of `kind` (the learned stage is added by the caller, which
    /// owns the model: see [`VideoDetectorKind::wants_model`]). `boxes[n]` are frame `n`'s
    /// boxes to refine; with boxes, `Auto` refines them too.
    pub fn choose(
        kind: VideoDetectorKind,
        boxes: Option<Vec<Vec<Detection>>>,
    ) -> Result<Self, ChoiceError> {
        use VideoDetectorKind as K;
        Ok(match (kind, boxes) {
            (K::Refine | K::Auto | K::RefineColour | K::AutoMotion, Some(b)) => Self::refine(b)?,
            (K::Refine | K::RefineColour, None) => return Err(ChoiceError::RefineWithoutBoxes),
            (K::Background | K::Moving, Some(_)) => return Err(ChoiceError::BoxesNotUsed),
            (K::Background, None) => Self::background()?,
            (K::Moving, None) => Self::moving()?,
            (K::Auto | K::AutoMotion, None) => Self::auto()?,
        })
    }

    /// Runs the detector over `files` (frame `k + 1` is `files[k]`) and writes the masks as
    /// MOTS txt (id -1) to `out`, frame by frame so a long folder's masks are never all held;
    /// the file is atomic, so a failure midway leaves any old output untouched. Returns the
    /// number of masks written. What `shapetrack detect` and the Python package's
    /// `detect_files` run, so the two write the same bytes.
    pub fn detect_files(
        &mut self,
        files: &[PathBuf],
        out: &Path,
    ) -> Result<usize, DetectFilesError> {
        use crate::io::motchallenge::{detection_records, write_mots};
        use std::io::Write as _;
        let mut file = crate::io::AtomicFile::create(out)?;
        let mut masks = 0usize;
        let mut first: Option<(u32, u32)> = None;
        for (i, path) in files.iter().enumerate() {
            let n = i as u32 + 1;
            let img = crate::io::read_rgb(path)?;
            let (w, h) = img.dimensions();
            let (fw, fh) = *first.get_or_insert((w, h));
            if (w, h) != (fw, fh) {
                return Err(DetectFilesError::SizeChanged {
                    file: path.display().to_string(),
                    width: w,
                    height: h,
                    first_width: fw,
                    first_height: fh,
                });
            }
            let frame = Frame::rgb(img.as_raw(), w, h)?;
            let dets = self
                .detect(n, &frame)
                .map_err(|source| DetectFilesError::Detect { frame: n, source })?;
            let recs = detection_records(n, &dets, w, h);
            masks += recs.len();
            file.write_all(write_mots(&recs).as_bytes())
                .map_err(|source| IoError::Io {
                    file: out.display().to_string(),
                    source,
                })?;
        }
        file.commit()?;
        Ok(masks)
    }

    /// `self` with the learned stage on top.
    pub fn learned(self, learned: Learned<N>) -> Self {
        VideoDetector::Learned(Box::new(self), Box::new(learned))
    }

    /// Lets the detector learn from frame `n` without asking for its detections (the learned
    /// stage does not run): an evaluation that scores every Nth frame keeps a background
    /// model as current as a full run would.
    pub fn observe(&mut self, n: u32, frame: &Frame) -> Result<(), DetectError> {
        match self {
            VideoDetector::Learned(base, _) => base.observe(n, frame),
            VideoDetector::Refine(..) => Ok(()),
            _ => self.detect(n, frame).map(|_| ()),
        }
    }

    /// The name of the detector running now (the automatic one says what it chose once it
    /// has).
    pub fn name(&self) -> String {
        match self {
            VideoDetector::Judging { .. } => "auto (judging the camera)".into(),
            VideoDetector::Background(_) => "background".into(),
            VideoDetector::Moving(_) => "moving".into(),
            VideoDetector::Refine(..) => "refine".into(),
            VideoDetector::Learned(base, _) => format!("{} + learned segmentation", base.name()),
        }
    }

    /// The detections of frame `n` (1-based; it picks the frame's boxes for refinement).
    pub fn detect(&mut self, n: u32, frame: &Frame) -> Result<Vec<Detection>, DetectError> {
        match self {
            VideoDetector::Learned(base, learned) => {
                let Learned { net, cfg, whole } = &mut **learned;
                if let VideoDetector::Refine(r, boxes) = &mut **base {
                    // Boxes: the model first; the colour refinement for those it finds
                    // nothing in (they are still box-only).
                    let b = boxes.get(n as usize).cloned().unwrap_or_default();
                    let mut job = Job::new(frame.width(), frame.height(), b, WholeFrame::Off, cfg)
                        .map_err(segment_error)?;
                    job.run(frame, &mut **net).map_err(segment_error)?;
                    let mut dets = job.finish().detections;
                    r.refine_all(frame, &mut dets, None)?;
                    return Ok(dets);
                }
                let dets = base.detect(n, frame)?;
                let mut job = Job::new(frame.width(), frame.height(), dets, *whole, cfg)
                    .map_err(segment_error)?;
                job.run(frame, &mut **net).map_err(segment_error)?;
                Ok(job.finish().detections)
            }
            VideoDetector::Background(d) => d.detect(frame),
            VideoDetector::Moving(d) => d.detect(frame),
            VideoDetector::Refine(r, boxes) => {
                let b = boxes.get(n as usize).cloned().unwrap_or_default();
                r.set_boxes(b);
                r.detect(frame)
            }
            VideoDetector::Judging {
                judge,
                background: bg,
                moving: mv,
            } => {
                judge.observe(frame);
                bg.detect(frame)?;
                let out = mv.detect(frame)?;
                if judge.pairs() + 1 >= JUDGE_FRAMES {
                    // The chosen detector keeps what it learned; the other is dropped.
                    let next = if judge.moving() == Some(false) {
                        VideoDetector::Background(std::mem::replace(bg, background()?))
                    } else {
                        VideoDetector::Moving(std::mem::replace(mv, moving()?))
                    };
                    *self = next;
                }
                Ok(out)
            }
        }
    }
}
