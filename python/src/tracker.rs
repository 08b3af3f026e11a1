//! `Tracker` and `OfflineTracker`: the core's online and offline trackers, one frame per call.

use crate::{busy, in_pool, value_error};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use shapetrack::track::offline::{OfflineConfig, OfflineTracker, Progress};
use shapetrack::track::{Config, Preset, TrackError, Tracker};
use shapetrack::{BBox, Detection, Frame, Mask, TrackedShape};
use std::sync::Mutex;

/// The online config of a settings object (JSON text): an optional `"preset"` and any fields
/// over it, as `--config` files and the JS `Tracker` take them. `None`: the default preset.
pub(crate) fn online_config(json: Option<&str>) -> PyResult<Config> {
    let Some(text) = json else {
        return Ok(Preset::Default.config());
    };
    let bad = |e: serde_json::Error| value_error(format!("config: {e}"));
    let v: serde_json::Value = serde_json::from_str(text).map_err(bad)?;
    let c = Config::from_settings(Preset::Default, &v).map_err(bad)?;
    c.validate()
        .map_err(|e| value_error(format!("config: {e}")))?;
    Ok(c)
}

/// The offline config of a settings object: `{"online": {…, "preset": …}, "relink": …,
/// "fill": …, "appearance": …}`, every part optional, as the CLI's `--offline-config` (whose
/// `online` part merges over the preset).
fn offline_config(json: Option<&str>) -> PyResult<OfflineConfig> {
    let Some(text) = json else {
        return Ok(OfflineConfig::default());
    };
    let bad = |e: serde_json::Error| value_error(format!("config: {e}"));
    let mut v: serde_json::Value = serde_json::from_str(text).map_err(bad)?;
    let online = match v.as_object_mut().and_then(|m| m.remove("online")) {
        Some(section) => Config::from_settings(Preset::Default, &section)
            .map_err(|e| value_error(format!("config: online: {e}")))?,
        None => Preset::Default.config(),
    };
    let rest = OfflineConfig::from_value(v).map_err(bad)?;
    let c = OfflineConfig { online, ..rest };
    c.validate()
        .map_err(|e| value_error(format!("config: {e}")))?;
    Ok(c)
}

/// The core's error with the Python argument it concerns in front (`boxes[3]: detection 3:
/// bbox.w is -1, expected a size ≥ 0`): the caller passed arrays, not detections.
fn track_error(e: TrackError) -> String {
    match &e {
        TrackError::InvalidDetection { index, field, .. } => {
            let arg = if *field == "score" { "scores" } else { "boxes" };
            format!("{arg}[{index}]: {e}")
        }
        _ => e.to_string(),
    }
}

/// One frame's input as the Python layer sends it: `n` detections, little arrays as native
/// byte order bytes (boxes `f64` n×4 x,y,w,h; scores `f64` n; classes `i32` n; masks `u8`
/// n×h×w; frame `u8` h×w×3).
pub(crate) struct Input<'a> {
    pub n: usize,
    pub boxes: &'a [u8],
    pub scores: &'a [u8],
    pub classes: Option<&'a [u8]>,
    pub masks: Option<&'a [u8]>,
    pub frame: Option<&'a [u8]>,
    pub height: u32,
    pub width: u32,
}

fn f64s(b: &[u8]) -> impl Iterator<Item = f64> + '_ {
    b.chunks_exact(8).map(|c| {
        let mut a = [0u8; 8];
        a.copy_from_slice(c);
        f64::from_ne_bytes(a)
    })
}

fn i32s(b: &[u8]) -> impl Iterator<Item = i32> + '_ {
    b.chunks_exact(4).map(|c| {
        let mut a = [0u8; 4];
        a.copy_from_slice(c);
        i32::from_ne_bytes(a)
    })
}

/// Checks a buffer's length against what its field should hold, naming the field.
fn check_len(field: &str, b: &[u8], want: usize) -> PyResult<()> {
    if b.len() != want {
        return Err(value_error(format!(
            "{field}: {} bytes, expected {want}",
            b.len()
        )));
    }
    Ok(())
}

impl Input<'_> {
    /// The core's detections. With masks, each detection is its mask (its box the mask's own,
    /// as when MOTS input is read); without, its box.
    pub(crate) fn detections(&self) -> PyResult<Vec<Detection>> {
        let n = self.n;
        let pixels = self.height as usize * self.width as usize;
        check_len("boxes", self.boxes, n * 32)?;
        check_len("scores", self.scores, n * 8)?;
        if let Some(c) = self.classes {
            check_len("classes", c, n * 4)?;
        }
        if let Some(m) = self.masks {
            check_len("masks", m, n * pixels)?;
        }
        if let Some(f) = self.frame {
            check_len("frame", f, pixels * 3)?;
        }
        let boxes: Vec<f64> = f64s(self.boxes).collect();
        let scores: Vec<f64> = f64s(self.scores).collect();
        let classes: Vec<i32> = match self.classes {
            Some(c) => i32s(c).collect(),
            None => vec![-1; n],
        };
        let mut out = Vec::with_capacity(n);
        for i in 0..n {
            let b = &boxes[4 * i..4 * i + 4];
            let (score, class) = (scores[i], classes[i]);
            let det = match self.masks {
                Some(m) => {
                    let full = &m[i * pixels..(i + 1) * pixels];
                    let mask = Mask::from_full(self.width, self.height, full)
                        .map_err(|e| value_error(format!("masks[{i}]: {e}")))?;
                    Detection::from_mask(mask, score)
                }
                None => Detection::from_box(BBox::new(b[0], b[1], b[2], b[3]), score),
            };
            out.push(Detection { class, ..det });
        }
        Ok(out)
    }
}

/// Tracked shapes as a dict of bytes (the Python layer makes arrays of them): `tracker_id`
/// u64, `frame` u32, `xywh` f64 n×4, `score` f64, `class_id` i32, `detection_index` i64 (-1
/// when filled in), `interpolated` u8, and `mask` u8 n×h×w when `size` is known and some
/// shape has a mask (`None` otherwise).
pub(crate) fn shapes_dict<'py>(
    py: Python<'py>,
    shapes: &[TrackedShape],
    size: Option<(u32, u32)>,
) -> PyResult<Bound<'py, PyDict>> {
    let mut ids = Vec::with_capacity(shapes.len() * 8);
    let mut frames = Vec::with_capacity(shapes.len() * 4);
    let mut xywh = Vec::with_capacity(shapes.len() * 32);
    let mut scores = Vec::with_capacity(shapes.len() * 8);
    let mut classes = Vec::with_capacity(shapes.len() * 4);
    let mut det = Vec::with_capacity(shapes.len() * 8);
    let mut interp = Vec::with_capacity(shapes.len());
    for s in shapes {
        ids.extend(s.id.to_ne_bytes());
        frames.extend(s.frame.to_ne_bytes());
        for v in [s.bbox.x, s.bbox.y, s.bbox.w, s.bbox.h] {
            xywh.extend(v.to_ne_bytes());
        }
        scores.extend(s.score.to_ne_bytes());
        classes.extend(s.class.to_ne_bytes());
        let d = s.det_index.map_or(-1, |i| i as i64);
        det.extend(d.to_ne_bytes());
        interp.push(u8::from(s.interpolated));
    }
    let d = PyDict::new(py);
    d.set_item("tracker_id", PyBytes::new(py, &ids))?;
    d.set_item("frame", PyBytes::new(py, &frames))?;
    d.set_item("xywh", PyBytes::new(py, &xywh))?;
    d.set_item("score", PyBytes::new(py, &scores))?;
    d.set_item("class_id", PyBytes::new(py, &classes))?;
    d.set_item("detection_index", PyBytes::new(py, &det))?;
    d.set_item("interpolated", PyBytes::new(py, &interp))?;
    let masks = match size {
        Some((w, h)) if shapes.iter().any(|s| s.mask.is_some()) => {
            let mut m = Vec::with_capacity(shapes.len() * (w * h) as usize);
            for s in shapes {
                match &s.mask {
                    Some(mask) => m.extend(mask.to_full(w, h)),
                    // A box-only shape among masks: its box, filled (as MOTS writes it).
                    None => m.extend(Mask::from_bbox(&s.bbox).to_full(w, h)),
                }
            }
            Some(PyBytes::new(py, &m))
        }
        _ => None,
    };
    d.set_item("mask", masks)?;
    d.set_item("height", size.map(|s| s.1))?;
    d.set_item("width", size.map(|s| s.0))?;
    Ok(d)
}

/// The image size an input gives, when it has masks or a frame.
fn input_size(inp: &Input<'_>) -> Option<(u32, u32)> {
    (inp.masks.is_some() || inp.frame.is_some()).then_some((inp.width, inp.height))
}

/// The online tracker (`shapetrack.Tracker` wraps it).
#[pyclass(module = "shapetrack._native")]
pub struct NativeTracker {
    inner: Mutex<Tracker>,
    size: Mutex<Option<(u32, u32)>>,
}

#[pymethods]
impl NativeTracker {
    #[new]
    #[pyo3(signature = (config=None))]
    fn new(config: Option<&str>) -> PyResult<Self> {
        let t = Tracker::new(online_config(config)?).map_err(value_error)?;
        Ok(Self {
            inner: Mutex::new(t),
            size: Mutex::new(None),
        })
    }

    /// One frame; the shapes the tracker reports (this frame's, and the earlier frames of a
    /// track confirmed now).
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (n, boxes, scores, classes, masks, frame, height, width))]
    fn update<'py>(
        &self,
        py: Python<'py>,
        n: usize,
        boxes: &[u8],
        scores: &[u8],
        classes: Option<&[u8]>,
        masks: Option<&[u8]>,
        frame: Option<&[u8]>,
        height: u32,
        width: u32,
    ) -> PyResult<Bound<'py, PyDict>> {
        let inp = Input {
            n,
            boxes,
            scores,
            classes,
            masks,
            frame,
            height,
            width,
        };
        let dets = inp.detections()?;
        let mut guard = self.inner.try_lock().map_err(|_| busy("Tracker"))?;
        let t: &mut Tracker = &mut guard;
        let shapes = py
            .allow_threads(|| {
                in_pool(|| -> Result<Vec<TrackedShape>, String> {
                    let f = frame
                        .map(|b| Frame::rgb(b, width, height))
                        .transpose()
                        .map_err(|e| format!("frame: {e}"))?;
                    t.update(f.as_ref(), &dets).map_err(track_error)
                })
            })
            .map_err(value_error)?;
        let mut size = self.size.try_lock().map_err(|_| busy("Tracker"))?;
        if let Some(s) = input_size(&inp) {
            *size = Some(s);
        }
        shapes_dict(py, &shapes, *size)
    }

    /// Frames seen so far.
    #[getter]
    fn frame(&self) -> PyResult<u32> {
        Ok(self.inner.try_lock().map_err(|_| busy("Tracker"))?.frame())
    }
}

/// The offline tracker (`shapetrack.OfflineTracker` wraps it): frames pushed one at a time,
/// the re-linker and gap filling at `finish`.
#[pyclass(module = "shapetrack._native")]
pub struct NativeOfflineTracker {
    /// `None` once finished.
    inner: Mutex<Option<OfflineTracker>>,
    size: Mutex<Option<(u32, u32)>>,
}

#[pymethods]
impl NativeOfflineTracker {
    #[new]
    #[pyo3(signature = (config=None, fps=30.0))]
    fn new(config: Option<&str>, fps: f64) -> PyResult<Self> {
        if !(fps.is_finite() && fps > 0.0) {
            return Err(value_error(format!("fps: {fps} is not a positive number")));
        }
        let mut cfg = offline_config(config)?;
        if cfg.online.frame_rate.is_none() {
            cfg.online.frame_rate = Some(fps);
        }
        let t = OfflineTracker::new(cfg, fps).map_err(value_error)?;
        Ok(Self {
            inner: Mutex::new(Some(t)),
            size: Mutex::new(None),
        })
    }

    /// One frame into the online pass.
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (n, boxes, scores, classes, masks, frame, height, width))]
    fn push(
        &self,
        py: Python<'_>,
        n: usize,
        boxes: &[u8],
        scores: &[u8],
        classes: Option<&[u8]>,
        masks: Option<&[u8]>,
        frame: Option<&[u8]>,
        height: u32,
        width: u32,
    ) -> PyResult<()> {
        let inp = Input {
            n,
            boxes,
            scores,
            classes,
            masks,
            frame,
            height,
            width,
        };
        let dets = inp.detections()?;
        let mut guard = self.inner.try_lock().map_err(|_| busy("OfflineTracker"))?;
        let t = guard
            .as_mut()
            .ok_or_else(|| value_error("OfflineTracker: already finished"))?;
        py.allow_threads(|| {
            in_pool(|| -> Result<(), String> {
                let f = frame
                    .map(|b| Frame::rgb(b, width, height))
                    .transpose()
                    .map_err(|e| format!("frame: {e}"))?;
                t.push_frame(f.as_ref(), &dets)
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            })
        })
        .map_err(value_error)?;
        if let Some(s) = input_size(&inp) {
            *self.size.try_lock().map_err(|_| busy("OfflineTracker"))? = Some(s);
        }
        Ok(())
    }

    /// The offline pass; `progress(phase, fraction)` hears how far it is (called with the
    /// GIL taken back for the call). Returns every shape of the sequence, by (frame, id).
    #[pyo3(signature = (progress=None))]
    fn finish<'py>(
        &self,
        py: Python<'py>,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let t = self
            .inner
            .try_lock()
            .map_err(|_| busy("OfflineTracker"))?
            .take()
            .ok_or_else(|| value_error("OfflineTracker: already finished"))?;
        // The first error the callback raised: the pass goes on, the error is raised after.
        let mut cb_error: Option<PyErr> = None;
        let result = py.allow_threads(|| {
            in_pool(|| {
                t.finish(|p: Progress| {
                    let Some(cb) = &progress else { return };
                    if cb_error.is_some() {
                        return;
                    }
                    Python::with_gil(|py| {
                        let phase = format!("{:?}", p.phase).to_lowercase();
                        if let Err(e) = cb.call1(py, (phase, p.fraction)) {
                            cb_error = Some(e);
                        }
                    });
                })
                .map_err(|e| e.to_string())
            })
        });
        if let Some(e) = cb_error {
            return Err(e);
        }
        let res = result.map_err(value_error)?;
        let size = *self.size.try_lock().map_err(|_| busy("OfflineTracker"))?;
        let d = shapes_dict(py, &res.shapes, size)?;
        d.set_item("joins", res.joins.len())?;
        d.set_item("filled", res.filled)?;
        Ok(d)
    }

    /// Frames pushed so far.
    #[getter]
    fn frames(&self) -> PyResult<u32> {
        let g = self.inner.try_lock().map_err(|_| busy("OfflineTracker"))?;
        Ok(g.as_ref().map_or(0, |t| t.frames()))
    }
}
