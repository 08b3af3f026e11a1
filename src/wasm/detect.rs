//! Detections: lists handed in by detectors written in JS, and the background detector.

use super::*;
use crate::detect::{BackgroundSubtractor, Detector};
use crate::frame::{BBox, Detection, Mask};
use serde::{Deserialize, Serialize};
use tsify::{Ts, Tsify};
use wasm_bindgen::prelude::*;

/// A mask handed in by a JS detector: `data` holds `width·height` bytes (non-zero = object)
/// for the rectangle whose top-left pixel is `(x, y)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Tsify)]
pub struct MaskInput {
    /// Image x of the left column.
    pub x: i32,
    /// Image y of the top row.
    pub y: i32,
    /// Bitmap width.
    pub width: u32,
    /// Bitmap height.
    pub height: u32,
    /// Row-major bytes.
    #[serde(with = "serde_bytes")]
    #[tsify(type = "Uint8Array")]
    pub data: Vec<u8>,
    /// Detector confidence; defaults to 1.
    #[serde(default = "one")]
    #[tsify(optional)]
    pub score: f64,
    /// Class label; -1 (the default) when unknown.
    #[serde(default = "minus_one_i32")]
    #[tsify(optional)]
    pub class: i32,
}

/// A box handed in by a JS detector.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Tsify)]
pub struct BoxInput {
    /// The box.
    pub bbox: BoxJs,
    /// Detector confidence; defaults to 1.
    #[serde(default = "one")]
    #[tsify(optional)]
    pub score: f64,
    /// Class label; -1 (the default) when unknown.
    #[serde(default = "minus_one_i32")]
    #[tsify(optional)]
    pub class: i32,
}

/// What a detector written in JS returns: masks, boxes, or both.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
pub struct DetectionLists {
    /// Mask detections.
    #[serde(default)]
    #[tsify(optional)]
    pub masks: Vec<MaskInput>,
    /// Box-only detections.
    #[serde(default)]
    #[tsify(optional)]
    pub boxes: Vec<BoxInput>,
}

/// One detection as JS sees it (for drawing detector output).
#[derive(Debug, Clone, PartialEq, Serialize, Tsify)]
pub struct DetectionJs {
    /// Bounding box.
    pub bbox: BoxJs,
    /// Cropped mask, when the detector gave one.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub mask: Option<MaskBitmap>,
    /// Confidence.
    pub score: f64,
    /// Class label (-1 when unknown).
    pub class: i32,
}

impl From<&Detection> for DetectionJs {
    fn from(d: &Detection) -> Self {
        DetectionJs {
            bbox: d.bbox.into(),
            mask: d.mask.as_ref().map(MaskBitmap::from),
            score: d.score,
            class: d.class,
        }
    }
}

/// A list of detections as JS sees it.
#[derive(Debug, Clone, PartialEq, Serialize, Tsify)]
#[serde(transparent)]
pub struct DetectionList(pub Vec<DetectionJs>);

/// One frame's detections, kept in wasm memory: the background detector's output goes to the
/// tracker without crossing into JS. Detectors written in JS build one with `fromLists`.
#[wasm_bindgen]
pub struct Detections {
    pub(super) inner: Vec<Detection>,
}

#[wasm_bindgen]
impl Detections {
    /// Detections from a JS detector's masks and boxes (checked: sizes, finite boxes).
    #[wasm_bindgen(js_name = fromLists)]
    pub fn from_lists(lists: Ts<DetectionLists>) -> Result<Detections, JsValue> {
        let lists = rust(lists)?;
        let mut inner = Vec::with_capacity(lists.masks.len() + lists.boxes.len());
        for m in lists.masks {
            let mask = Mask::new(m.x, m.y, m.width, m.height, m.data).map_err(js_error)?;
            let mut d = Detection::from_mask(mask, m.score);
            d.class = m.class;
            inner.push(d);
        }
        for b in lists.boxes {
            let bbox = BBox::checked(b.bbox.x, b.bbox.y, b.bbox.w, b.bbox.h).map_err(js_error)?;
            let mut d = Detection::from_box(bbox, b.score);
            d.class = b.class;
            inner.push(d);
        }
        Ok(Detections { inner })
    }

    /// Number of detections.
    #[wasm_bindgen(getter)]
    pub fn len(&self) -> usize {
        self.inner.len()
    }

    /// Whether there is no detection.
    #[wasm_bindgen(getter, js_name = isEmpty)]
    pub fn is_empty(&self) -> bool {
        self.inner.is_empty()
    }

    /// The detections as plain JS objects (copies the masks).
    #[wasm_bindgen(js_name = toList)]
    pub fn to_list(&self) -> Result<Ts<DetectionList>, JsValue> {
        ts(&DetectionList(
            self.inner.iter().map(DetectionJs::from).collect(),
        ))
    }
}

// ------------------------------------------------------------------------------------------
// Background detector

/// The adaptive background subtractor (thesis eq. 1–2) with morphology and connected
/// components: one mask per moving object, no model weights.
#[wasm_bindgen]
pub struct BackgroundDetector {
    inner: BackgroundSubtractor,
}

#[wasm_bindgen]
impl BackgroundDetector {
    /// A detector with the core's defaults, or the settings given (`BackgroundConfig`'s
    /// fields; missing ones keep their defaults).
    #[wasm_bindgen(constructor)]
    pub fn new(config: Option<BackgroundSettings>) -> Result<BackgroundDetector, JsValue> {
        let cfg = settings::background_config(config.as_ref())?;
        Ok(BackgroundDetector {
            inner: BackgroundSubtractor::new(cfg).map_err(js_error)?,
        })
    }

    /// Detects the moving objects of the frame in `buf` (frames must come in order).
    pub fn detect(&mut self, buf: &FrameBuffer) -> Result<Detections, JsValue> {
        let frame = buf.frame()?;
        let inner = self.inner.detect(&frame).map_err(js_error)?;
        Ok(Detections { inner })
    }

    /// Forgets the background model (e.g. after a cut or a size change).
    pub fn reset(&mut self) {
        self.inner.reset();
    }

    /// Frames of the initial background learnt so far (detections start once it equals
    /// `warmupFrames`).
    #[wasm_bindgen(getter, js_name = warmupSeen)]
    pub fn warmup_seen(&self) -> u32 {
        self.inner.warmup().0
    }

    /// Frames the initial background takes to learn (`init_frames`).
    #[wasm_bindgen(getter, js_name = warmupFrames)]
    pub fn warmup_frames(&self) -> u32 {
        self.inner.warmup().1
    }
}
