//! The CLI's detectors over frames (`detect --detector auto|refine|background|moving|
//! auto-motion|refine-colour [--model PATH|none] [--segment JSON]`) and its follower: the
//! library's [`VideoDetector`] and `follow_sequence_with_net`, with the learned segmentation
//! (U²-Net-p through tract) when its model is installed, as in the CLI.

use crate::{busy, in_pool, value_error};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use shapetrack::segment::{
    segment_settings, ChoiceError, Learned, Net, VideoDetector, VideoDetectorKind, AUTO_WHOLE_FRAME,
};
use shapetrack::{BBox, Detection, Frame, Mask};
use std::sync::Mutex;

/// The network a detector owns: `Send`, so a call can release the GIL.
type SendNet = dyn Net + Send;

/// The learned model as `model` names it (the CLI's `--model`): `None` the installed one
/// (`$SHAPETRACK_U2NETP`, the checkout's node_modules), else the weights-free path with the
/// reason returned as a warning; `"none"` the weights-free path; a path that file or an error.
fn load_net(model: Option<&str>) -> Result<(Option<Box<SendNet>>, Option<String>), String> {
    use shapetrack::segment::TractNet;
    match model {
        Some("none") => Ok((None, None)),
        Some(p) => TractNet::load(Some(std::path::Path::new(p)))
            .map(|n| (Some(Box::new(n) as Box<SendNet>), None))
            .map_err(|e| format!("model: {e}")),
        None => match TractNet::load(None) {
            Ok(n) => Ok((Some(Box::new(n)), None)),
            Err(e) => Ok((None, Some(format!("{e}; using the weights-free path")))),
        },
    }
}

/// A detector as the CLI's `detect` builds it from its flags, and the warning the caller
/// should show (the model was wanted but is not installed).
fn build(
    kind: &str,
    boxes: Option<Vec<Vec<Detection>>>,
    model: Option<&str>,
    segment: Option<&str>,
) -> Result<(VideoDetector<SendNet>, Option<String>), String> {
    let k = VideoDetectorKind::parse(kind).ok_or_else(|| {
        let names: Vec<&str> = VideoDetectorKind::ALL.iter().map(|(n, _)| *n).collect();
        format!("detector: {kind:?} is not one of {}", names.join(", "))
    })?;
    let given = boxes.is_some();
    let base = VideoDetector::choose(k, boxes);
    // Checked whether or not a model runs, as the CLI does: a typo in `segment` must not pass
    // unnoticed because this run happens not to use the model.
    let cfg = segment_settings(segment, given).map_err(|e| format!("segment: {e}"))?;
    let mut det = base.map_err(|e| match e {
        ChoiceError::RefineWithoutBoxes => format!("detector: {kind:?} needs boxes"),
        ChoiceError::BoxesNotUsed => {
            format!("boxes: only the detectors refine and auto take boxes, not {kind:?}")
        }
        ChoiceError::Detector(e) => e.to_string(),
    })?;
    let mut warning = None;
    if k.wants_model() {
        let (net, w) = load_net(model)?;
        warning = w;
        if let Some(net) = net {
            det = det.learned(Learned {
                net,
                cfg,
                whole: AUTO_WHOLE_FRAME,
            });
        }
    }
    Ok((det, warning))
}

/// Per-frame boxes (x, y, w, h; score 1, class -1) as the detector takes them: index = frame
/// number, 1-based.
fn boxes_of(boxes: Vec<Vec<[f64; 4]>>) -> Result<Vec<Vec<Detection>>, String> {
    let mut out = vec![Vec::new()];
    for (k, frame) in boxes.into_iter().enumerate() {
        if frame.len() > shapetrack::io::limits::MAX_BOXES_PER_FRAME {
            return Err(format!(
                "boxes[{k}]: {} boxes, more than the {} a frame takes",
                frame.len(),
                shapetrack::io::limits::MAX_BOXES_PER_FRAME
            ));
        }
        let mut v = Vec::with_capacity(frame.len());
        for (i, [x, y, w, h]) in frame.into_iter().enumerate() {
            if ![x, y, w, h].iter().all(|v| v.is_finite()) || w <= 0.0 || h <= 0.0 {
                return Err(format!(
                    "boxes[{k}][{i}]: ({x}, {y}, {w}, {h}) is not a box (finite x, y and positive w, h)"
                ));
            }
            v.push(Detection::from_box(BBox::new(x, y, w, h), 1.0));
        }
        out.push(v);
    }
    Ok(out)
}

/// A detector over a video's frames, in order (`shapetrack.detect` wraps it).
#[pyclass(module = "shapetrack._native")]
pub struct NativeDetector {
    inner: Mutex<(VideoDetector<SendNet>, u32)>,
    warning: Option<String>,
}

#[pymethods]
impl NativeDetector {
    /// `kind`: the CLI's `--detector` values. `boxes`: per frame, a list of (x, y, w, h)
    /// (refine, auto). `model`: a model file, `"none"`, or `None` for the installed one.
    /// `segment`: the learned segmentation's settings as JSON.
    #[new]
    #[pyo3(signature = (kind, boxes=None, model=None, segment=None))]
    fn new(
        py: Python<'_>,
        kind: &str,
        boxes: Option<Vec<Vec<[f64; 4]>>>,
        model: Option<&str>,
        segment: Option<&str>,
    ) -> PyResult<Self> {
        let boxes = boxes.map(boxes_of).transpose().map_err(value_error)?;
        let (det, warning) = py
            .allow_threads(|| build(kind, boxes, model, segment))
            .map_err(value_error)?;
        Ok(Self {
            inner: Mutex::new((det, 0)),
            warning,
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
        let (r, n) = &mut *guard;
        let dets = py
            .allow_threads(|| {
                in_pool(|| -> Result<Vec<Detection>, String> {
                    let f = Frame::rgb(frame, width, height).map_err(|e| format!("frame: {e}"))?;
                    let dets = r.detect(*n + 1, &f).map_err(|e| e.to_string())?;
                    *n += 1;
                    Ok(dets)
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

    /// The detector running now (auto says what it chose once it has, and whether the
    /// learned segmentation is on).
    #[getter]
    fn name(&self) -> PyResult<String> {
        Ok(self
            .inner
            .try_lock()
            .map_err(|_| busy("detector"))?
            .0
            .name())
    }

    /// Why the learned segmentation is off although the detector wanted it (its model is not
    /// installed), or `None`.
    #[getter]
    fn warning(&self) -> Option<String> {
        self.warning.clone()
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

/// `shapetrack detect --frames DIR [--detector KIND] [--boxes B.txt] [--model M|none]
/// [--segment JSON] --out OUT`: every frame of the folder through the same detector the CLI
/// builds, masks written as MOTS txt (id -1) atomically, the same bytes. Returns the number of
/// frames and of masks, the detector's name and the warning the CLI would print (the model
/// wanted but not installed), if any.
#[pyfunction]
#[pyo3(signature = (frames, out, detector="auto", boxes=None, model=None, segment=None))]
pub fn detect_files(
    py: Python<'_>,
    frames: std::path::PathBuf,
    out: std::path::PathBuf,
    detector: &str,
    boxes: Option<std::path::PathBuf>,
    model: Option<&str>,
    segment: Option<&str>,
) -> PyResult<(usize, usize, String, Option<String>)> {
    use shapetrack::io::motchallenge::read_boxes;
    py.allow_threads(|| {
        in_pool(
            || -> Result<(usize, usize, String, Option<String>), String> {
                let s = |e: &dyn std::fmt::Display| e.to_string();
                let files = shapetrack::io::image_files(&frames).map_err(|e| s(&e))?;
                if files.is_empty() {
                    return Err(format!("{}: no .jpg/.png frames", frames.display()));
                }
                let boxes = boxes
                    .as_deref()
                    .map(|p| read_boxes(p, files.len()))
                    .transpose()
                    .map_err(|e| s(&e))?;
                let (mut r, warning) = build(detector, boxes, model, segment)?;
                let masks = r.detect_files(&files, &out).map_err(|e| s(&e))?;
                Ok((files.len(), masks, r.name(), warning))
            },
        )
    })
    .map_err(value_error)
}

/// Follows one target from a mask at frame `init` (0-based) through `n` frames (RGB bytes
/// n×h×w×3), forward to the end and backward to the start, without a detector: the library's
/// `follow::follow_sequence_with_net`, as `shapetrack follow --detector none [--model M|none]`
/// runs it. `config` is a `FollowConfig` as JSON (missing fields default); `model` as in
/// [`NativeDetector`]. Returns `mask` u8 n×h×w, `confidence` f64 n, `lost` u8 n (bytes) and
/// `warning` (the model wanted but not installed, or `None`).
#[allow(clippy::too_many_arguments)]
#[pyfunction]
#[pyo3(signature = (frames, n, height, width, mask, init, config=None, model=None))]
pub fn follow_frames<'py>(
    py: Python<'py>,
    frames: &[u8],
    n: usize,
    height: u32,
    width: u32,
    mask: &[u8],
    init: usize,
    config: Option<&str>,
    model: Option<&str>,
) -> PyResult<Bound<'py, PyDict>> {
    use shapetrack::follow::{follow_sequence_with_net, mask_from_bitmap, FollowConfig};
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
    let (steps, warning) = py
        .allow_threads(|| {
            in_pool(
                || -> Result<(Vec<shapetrack::follow::FollowStep>, Option<String>), String> {
                    let (mut net, warning) = load_net(model)?;
                    let views = frames
                        .chunks_exact(pixels * 3)
                        .map(|b| Frame::rgb(b, width, height))
                        .collect::<Result<Vec<_>, _>>()
                        .map_err(|e| format!("frames: {e}"))?;
                    let net = net.as_deref_mut().map(|n| n as &mut dyn Net);
                    follow_sequence_with_net(&views, init, &start, None, &cfg, net)
                        .map(|s| (s, warning))
                        .map_err(|e| e.to_string())
                },
            )
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
    d.set_item("warning", warning)?;
    Ok(d)
}
