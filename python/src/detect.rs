//! The weights-free detectors over frames: the CLI's `detect --detector background|moving|
//! auto-motion` (the learned segmentation is the CLI's and the page's only; see
//! docs/python.md).

use crate::{busy, in_pool, value_error};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use shapetrack::detect::{
    BackgroundConfig, BackgroundSubtractor, CameraJudge, DetectError, Detector,
    MovingCameraDetector, MovingConfig,
};
use shapetrack::{Detection, Frame, Mask};
use std::sync::Mutex;

/// Frames `auto` watches before choosing (the CLI's `detect::JUDGE_FRAMES`).
const JUDGE_FRAMES: usize = 5;

/// A detector run frame by frame, as the CLI's `detect` runs it.
enum Runner {
    /// Still deciding (auto): both detectors learn; the moving one reports.
    Judging {
        judge: CameraJudge,
        background: Box<BackgroundSubtractor>,
        moving: Box<MovingCameraDetector>,
    },
    /// Static camera.
    Background(Box<BackgroundSubtractor>),
    /// Moving camera.
    Moving(Box<MovingCameraDetector>),
}

fn background() -> Result<Box<BackgroundSubtractor>, DetectError> {
    BackgroundSubtractor::new(BackgroundConfig::default()).map(Box::new)
}

fn moving() -> Result<Box<MovingCameraDetector>, DetectError> {
    MovingCameraDetector::new(MovingConfig::default()).map(Box::new)
}

impl Runner {
    fn detect(&mut self, frame: &Frame) -> Result<Vec<Detection>, DetectError> {
        match self {
            Runner::Background(d) => d.detect(frame),
            Runner::Moving(d) => d.detect(frame),
            Runner::Judging {
                judge,
                background: bg,
                moving: mv,
            } => {
                judge.observe(frame);
                bg.detect(frame)?;
                let out = mv.detect(frame)?;
                if judge.pairs() + 1 >= JUDGE_FRAMES {
                    let next = if judge.moving() == Some(false) {
                        Runner::Background(std::mem::replace(bg, background()?))
                    } else {
                        Runner::Moving(std::mem::replace(mv, moving()?))
                    };
                    *self = next;
                }
                Ok(out)
            }
        }
    }

    fn name(&self) -> &'static str {
        match self {
            Runner::Judging { .. } => "auto (judging the camera)",
            Runner::Background(_) => "background",
            Runner::Moving(_) => "moving",
        }
    }
}

/// A detector over a video's frames, in order (`shapetrack.detect` wraps it).
#[pyclass(module = "shapetrack._native")]
pub struct NativeDetector {
    inner: Mutex<Runner>,
}

#[pymethods]
impl NativeDetector {
    /// `kind`: `auto` (= `auto-motion`: background or moving, chosen from the first frames),
    /// `background` or `moving`.
    #[new]
    fn new(kind: &str) -> PyResult<Self> {
        let r = match kind {
            "auto" | "auto-motion" => Runner::Judging {
                judge: CameraJudge::new(),
                background: background().map_err(value_error)?,
                moving: moving().map_err(value_error)?,
            },
            "background" => Runner::Background(background().map_err(value_error)?),
            "moving" => Runner::Moving(moving().map_err(value_error)?),
            other => {
                return Err(value_error(format!(
                    "detector: {other:?} is not one of auto, auto-motion, background, moving"
                )))
            }
        };
        Ok(Self {
            inner: Mutex::new(r),
        })
    }

    /// The next frame's detections: `xywh` f64 n×4, `score` f64, `class_id` i32, `mask` u8
    /// n×h×w (bytes).
    fn detect<'py>(
        &self,
        py: Python<'py>,
        frame: &[u8],
        height: u32,
        width: u32,
    ) -> PyResult<Bound<'py, PyDict>> {
        let mut guard = self.inner.try_lock().map_err(|_| busy("detector"))?;
        let r: &mut Runner = &mut guard;
        let dets = py
            .allow_threads(|| {
                in_pool(|| -> Result<Vec<Detection>, String> {
                    let f = Frame::rgb(frame, width, height).map_err(|e| format!("frame: {e}"))?;
                    r.detect(&f).map_err(|e| e.to_string())
                })
            })
            .map_err(value_error)?;
        let d = PyDict::new(py);
        let mut xywh = Vec::with_capacity(dets.len() * 32);
        let mut scores = Vec::with_capacity(dets.len() * 8);
        let mut classes = Vec::with_capacity(dets.len() * 4);
        let mut masks = Vec::with_capacity(dets.len() * (width * height) as usize);
        for det in &dets {
            for v in [det.bbox.x, det.bbox.y, det.bbox.w, det.bbox.h] {
                xywh.extend(v.to_ne_bytes());
            }
            scores.extend(det.score.to_ne_bytes());
            classes.extend(det.class.to_ne_bytes());
            let m = match &det.mask {
                Some(m) => m.to_full(width, height),
                None => Mask::from_bbox(&det.bbox).to_full(width, height),
            };
            masks.extend(m);
        }
        d.set_item("xywh", PyBytes::new(py, &xywh))?;
        d.set_item("score", PyBytes::new(py, &scores))?;
        d.set_item("class_id", PyBytes::new(py, &classes))?;
        d.set_item("mask", PyBytes::new(py, &masks))?;
        Ok(d)
    }

    /// The detector running now (auto says what it chose once it has).
    #[getter]
    fn name(&self) -> PyResult<&'static str> {
        Ok(self.inner.try_lock().map_err(|_| busy("detector"))?.name())
    }
}

/// The frames of a folder (`.jpg`/`.jpeg`/`.png`, in natural order: `2.png` before `10.png`),
/// as the CLI reads them.
#[pyfunction]
pub fn image_files(dir: std::path::PathBuf) -> PyResult<Vec<std::path::PathBuf>> {
    shapetrack::io::image_files(&dir).map_err(value_error)
}

/// One image file as RGB bytes (h×w×3) with its height and width; the CLI's decoder and its
/// size caps (read from the header before decoding).
#[pyfunction]
pub fn read_frame(py: Python<'_>, path: std::path::PathBuf) -> PyResult<(Py<PyBytes>, u32, u32)> {
    let img = py
        .allow_threads(|| shapetrack::io::read_rgb(&path).map_err(|e| e.to_string()))
        .map_err(value_error)?;
    let (w, h) = img.dimensions();
    Ok((PyBytes::new(py, img.as_raw()).unbind(), h, w))
}

/// `shapetrack detect --frames DIR --detector KIND --model none --out OUT`: every frame of the
/// folder through the detector, masks written as MOTS txt (id -1) atomically. Returns the
/// number of frames and of masks.
#[pyfunction]
#[pyo3(signature = (frames, out, detector="auto"))]
pub fn detect_files(
    py: Python<'_>,
    frames: std::path::PathBuf,
    out: std::path::PathBuf,
    detector: &str,
) -> PyResult<(usize, usize)> {
    use shapetrack::io::motchallenge::write_mots;
    use shapetrack::io::{AtomicFile, IoError, Record, Rle};
    use std::io::Write as _;
    let runner = NativeDetector::new(detector)?;
    let mut r = runner.inner.into_inner().map_err(|_| busy("detector"))?;
    py.allow_threads(|| {
        in_pool(|| -> Result<(usize, usize), String> {
            let s = |e: &dyn std::fmt::Display| e.to_string();
            let files = shapetrack::io::image_files(&frames).map_err(|e| s(&e))?;
            if files.is_empty() {
                return Err(format!("{}: no .jpg/.png frames", frames.display()));
            }
            let mut file = AtomicFile::create(&out).map_err(|e| s(&e))?;
            let mut masks = 0usize;
            let mut first: Option<(u32, u32)> = None;
            for (i, path) in files.iter().enumerate() {
                let n = i as u32 + 1;
                let img = shapetrack::io::read_rgb(path).map_err(|e| s(&e))?;
                let (w, h) = img.dimensions();
                let (fw, fh) = *first.get_or_insert((w, h));
                if (w, h) != (fw, fh) {
                    return Err(format!(
                        "{}: frame is {w}x{h}, the first frame was {fw}x{fh}",
                        path.display()
                    ));
                }
                let frame = Frame::rgb(img.as_raw(), w, h).map_err(|e| s(&e))?;
                let dets = r.detect(&frame).map_err(|e| format!("frame {n}: {e}"))?;
                let recs: Vec<Record> = dets
                    .iter()
                    .filter_map(|d| {
                        let m = d.mask.as_ref()?;
                        let mut rec = Record::from_box(n, -1, d.bbox);
                        rec.score = d.score;
                        rec.class = d.class;
                        rec.mask = Some(Rle::from_mask(m, w, h));
                        Some(rec)
                    })
                    .collect();
                masks += recs.len();
                file.write_all(write_mots(&recs).as_bytes())
                    .map_err(|source| {
                        s(&IoError::Io {
                            file: out.display().to_string(),
                            source,
                        })
                    })?;
            }
            file.commit().map_err(|e| s(&e))?;
            Ok((files.len(), masks))
        })
    })
    .map_err(value_error)
}

/// Follows one target from a mask at frame `init` (0-based) through `n` frames (RGB bytes
/// n×h×w×3), forward to the end and backward to the start, without a detector: the library's
/// `follow::follow_sequence`. `config` is a `FollowConfig` as JSON (missing fields default).
/// Returns `mask` u8 n×h×w, `confidence` f64 n and `lost` u8 n (bytes).
#[allow(clippy::too_many_arguments)]
#[pyfunction]
#[pyo3(signature = (frames, n, height, width, mask, init, config=None))]
pub fn follow_frames<'py>(
    py: Python<'py>,
    frames: &[u8],
    n: usize,
    height: u32,
    width: u32,
    mask: &[u8],
    init: usize,
    config: Option<&str>,
) -> PyResult<Bound<'py, PyDict>> {
    use shapetrack::follow::{follow_sequence, mask_from_bitmap, FollowConfig};
    let pixels = height as usize * width as usize;
    if frames.len() != n * pixels * 3 {
        return Err(value_error(format!(
            "frames: {} bytes, expected {n}×{height}×{width}×3",
            frames.len()
        )));
    }
    let cfg: FollowConfig = match config {
        Some(j) => serde_json::from_str(j).map_err(|e| value_error(format!("config: {e}")))?,
        None => FollowConfig::default(),
    };
    cfg.validate()
        .map_err(|e| value_error(format!("config: {e}")))?;
    let start = mask_from_bitmap(width, height, width, height, mask)
        .map_err(|e| value_error(format!("mask: {e}")))?;
    let steps = py
        .allow_threads(|| {
            in_pool(|| -> Result<Vec<shapetrack::follow::FollowStep>, String> {
                let views = frames
                    .chunks_exact(pixels * 3)
                    .map(|b| Frame::rgb(b, width, height))
                    .collect::<Result<Vec<_>, _>>()
                    .map_err(|e| format!("frames: {e}"))?;
                follow_sequence(&views, init, &start, None, &cfg).map_err(|e| e.to_string())
            })
        })
        .map_err(value_error)?;
    let mut masks = Vec::with_capacity(n * pixels);
    let mut conf = Vec::with_capacity(n * 8);
    let mut lost = Vec::with_capacity(n);
    for s in &steps {
        masks.extend(s.mask.to_full(width, height));
        conf.extend(s.confidence.to_ne_bytes());
        lost.push(u8::from(s.lost));
    }
    let d = PyDict::new(py);
    d.set_item("mask", PyBytes::new(py, &masks))?;
    d.set_item("confidence", PyBytes::new(py, &conf))?;
    d.set_item("lost", PyBytes::new(py, &lost))?;
    Ok(d)
}
