//! Detections: lists handed in by detectors written in JS, the background detector, the
//! moving-camera detector, the judge that tells the two kinds of footage apart, and the
//! refinement that turns a box detector's boxes into masks.

use super::region::Region;
use super::*;
use crate::detect::{
    BackgroundSubtractor, BoxRefiner as CoreRefiner, CameraJudge as CoreJudge, DetectError,
    Detector, MovingCameraDetector,
};
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

    /// Appends the detections of `other` that this list does not already hold: one of
    /// `other`'s is left out when at least `covered` (in `[0, 1]`) of its pixels lie on a
    /// single detection of this list (a detection without a mask counts as its filled box).
    /// Returns how many were appended. For combining two detectors' output: a class
    /// detector's objects (this list) with the moving objects it does not know (`other`).
    #[wasm_bindgen(js_name = addUncovered)]
    pub fn add_uncovered(&mut self, other: &Detections, covered: f64) -> Result<u32, JsValue> {
        if !(covered.is_finite() && (0.0..=1.0).contains(&covered)) {
            return Err(js_error(BindingError::Invalid(format!(
                "addUncovered: covered must be in [0, 1], not {covered}"
            ))));
        }
        let own: Vec<Region> = self.inner.iter().map(Region::of).collect();
        let uncovered: Vec<Detection> = other
            .inner
            .iter()
            .filter(|d| {
                let r = Region::of(d);
                let area = r.area();
                !(area > 0.0 && own.iter().any(|o| o.overlap(&r) >= covered * area))
            })
            .cloned()
            .collect();
        let added = u32::try_from(uncovered.len()).unwrap_or(u32::MAX);
        self.inner.extend(uncovered);
        Ok(added)
    }

    /// Leaves out the detections that are parts of another: one whose class is among
    /// `classes` is dropped when at least `share` (in `(0, 1]`) of its pixels lie on a single
    /// other detection (its mask, or its box without one) of at least `ratio` (≥ 1) times its
    /// area (and strictly more). Returns how many were dropped. An object detector reports
    /// what a person wears (shoes) beside the person, and a moving blob covers a person the
    /// detector only saw the shoes of: each would become a track of its own on the same
    /// object. Only the classes that are parts can go: a car inside a larger blob is a car the
    /// blob wrongly took in with its surroundings, not a part of it.
    #[wasm_bindgen(js_name = dropParts)]
    pub fn drop_parts(&mut self, classes: &[i32], share: f64, ratio: f64) -> Result<u32, JsValue> {
        if !(share.is_finite() && share > 0.0 && share <= 1.0) {
            return Err(js_error(BindingError::Invalid(format!(
                "dropParts: share must be in (0, 1], not {share}"
            ))));
        }
        if !(ratio.is_finite() && ratio >= 1.0) {
            return Err(js_error(BindingError::Invalid(format!(
                "dropParts: ratio must be a number ≥ 1, not {ratio}"
            ))));
        }
        let regions: Vec<Region> = self.inner.iter().map(Region::of).collect();
        let areas: Vec<f64> = regions.iter().map(Region::area).collect();
        let part: Vec<bool> = (0..regions.len())
            .map(|i| {
                let a = areas[i];
                a > 0.0
                    && classes.contains(&self.inner[i].class)
                    && (0..regions.len()).any(|j| {
                        j != i
                            && areas[j] > a
                            && areas[j] >= ratio * a
                            && self.inner[i].bbox.intersection_area(&self.inner[j].bbox) > 0.0
                            && regions[i].overlap(&regions[j]) >= share * a
                    })
            })
            .collect();
        drop(regions);
        let dropped = part.iter().filter(|&&p| p).count();
        let mut k = 0;
        self.inner.retain(|_| {
            k += 1;
            !part[k - 1]
        });
        Ok(u32::try_from(dropped).unwrap_or(u32::MAX))
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

// ------------------------------------------------------------------------------------------
// Moving-camera detector

/// Moving objects seen by a moving camera: the camera's motion between frames is estimated
/// and what moves against it is found, by dense optical flow (the default) or by a
/// compensated background model (`cue: "background"`); moving blobs are refined into masks
/// (see the core's `MovingCameraDetector`). No model weights.
///
/// The flow needs one earlier frame, the background model `min_age` frames of history,
/// before anything can be foreground, after the first frame and again after each
/// re-initialisation (a cut, a jump the motion estimate could not follow): `learning`,
/// `warmupSeen` and `warmupFrames` say where it is, so a page can explain frames without
/// detections.
#[wasm_bindgen]
pub struct MovingDetector {
    inner: MovingCameraDetector,
}

#[wasm_bindgen]
impl MovingDetector {
    /// A detector with the core's defaults, or the settings given (`MovingConfig`'s fields;
    /// missing ones keep their defaults, unknown ones are errors).
    #[wasm_bindgen(constructor)]
    pub fn new(config: Option<MovingSettings>) -> Result<MovingDetector, JsValue> {
        let cfg = settings::moving_config(config.as_ref())?;
        Ok(MovingDetector {
            inner: MovingCameraDetector::new(cfg).map_err(js_error)?,
        })
    }

    /// Detects the moving objects of the frame in `buf` (frames must come in order, all of
    /// the size of the first: another size is an error until `reset`).
    pub fn detect(&mut self, buf: &FrameBuffer) -> Result<Detections, JsValue> {
        let frame = buf.frame()?;
        let inner = self.inner.detect(&frame).map_err(js_error)?;
        Ok(Detections { inner })
    }

    /// Forgets the model and the frame size (e.g. after a cut or a size change).
    pub fn reset(&mut self) {
        self.inner.reset();
    }

    /// Frames of history the model holds, up to `warmupFrames` (detections can start on the
    /// frame after it reaches that).
    #[wasm_bindgen(getter, js_name = warmupSeen)]
    pub fn warmup_seen(&self) -> u32 {
        self.inner.warmup().0
    }

    /// Frames of history the model needs before it detects (1 for the flow cue: one earlier
    /// frame; `min_age` for the background cue).
    #[wasm_bindgen(getter, js_name = warmupFrames)]
    pub fn warmup_frames(&self) -> u32 {
        self.inner.warmup().1
    }

    /// Whether the model is still learning (nothing is detected meanwhile).
    #[wasm_bindgen(getter)]
    pub fn learning(&self) -> bool {
        let (seen, needed) = self.inner.warmup();
        seen < needed
    }

    /// How often the model started over because the camera's motion could not be followed.
    #[wasm_bindgen(getter)]
    pub fn resets(&self) -> u32 {
        u32::try_from(self.inner.resets()).unwrap_or(u32::MAX)
    }

    /// How far the camera moved between the last two frames: the largest displacement of a
    /// frame corner, in frame pixels; `undefined` when it was not estimated (first frame, a
    /// failed estimate).
    #[wasm_bindgen(getter, js_name = cameraShift)]
    pub fn camera_shift(&self) -> Option<f64> {
        let scale = self.inner.scale() as f64;
        self.inner.last_motion().map(|m| m.displacement * scale)
    }
}

// ------------------------------------------------------------------------------------------
// Box → mask refinement

/// Turns a box detector's boxes (SSD, boxes from a file) into masks of the objects inside
/// them: the core's `refine_box`, a GrabCut-like colour segmentation of each box against a
/// ring of background around it, on a working crop of at most `max_side` pixels a side (the
/// bound on each box's cost). No model weights.
#[wasm_bindgen]
pub struct BoxRefiner {
    inner: CoreRefiner,
}

#[wasm_bindgen]
impl BoxRefiner {
    /// A refiner with the core's defaults, or the settings given (`RefineConfig`'s fields;
    /// missing ones keep their defaults, unknown or out-of-range ones are errors).
    #[wasm_bindgen(constructor)]
    pub fn new(config: Option<RefineSettings>) -> Result<BoxRefiner, JsValue> {
        let cfg = settings::refine_config(config.as_ref())?;
        Ok(BoxRefiner {
            inner: CoreRefiner::new(cfg).map_err(js_error)?,
        })
    }

    /// Refines the box-only detections of `dets` in the frame in `buf`, in place, the
    /// highest scores first and at most `max` of them (all when `undefined`: a page bounds a
    /// frame's cost with it). Each refined box takes the mask found inside it, and its box
    /// becomes the mask's. A box the refinement finds nothing in, or one past `max`, takes
    /// its filled box (clipped to the frame) as its mask: every detection leaves with a mask,
    /// and none is dropped. Detections that came with a mask keep it. Returns how many boxes
    /// were refined.
    pub fn refine(
        &self,
        buf: &FrameBuffer,
        dets: &mut Detections,
        max: Option<u32>,
    ) -> Result<u32, JsValue> {
        let frame = buf.frame()?;
        let refined = self
            .inner
            .refine_all(&frame, &mut dets.inner, max.map(|m| m as usize))
            .map_err(js_error)?;
        Ok(u32::try_from(refined).unwrap_or(u32::MAX))
    }
}

// ------------------------------------------------------------------------------------------
// Camera judge

/// Tells a static camera from a moving one, from the motion between the first frames (the
/// median corner displacement against `MOVING_CAMERA_PX` frame pixels per frame): which of
/// the two background detectors fits the footage.
#[wasm_bindgen]
pub struct CameraJudge {
    inner: CoreJudge,
    /// Size of the first frame: the core ignores frames of another size; the binding says so.
    size: Option<(u32, u32)>,
}

#[wasm_bindgen]
impl CameraJudge {
    /// A judge with no frames yet.
    #[wasm_bindgen(constructor)]
    #[allow(clippy::new_without_default)] // a JS class: `new CameraJudge()` is its API
    pub fn new() -> CameraJudge {
        CameraJudge {
            inner: CoreJudge::new(),
            size: None,
        }
    }

    /// Looks at the next frame. A frame of another size than the first is an error (and is
    /// not looked at).
    pub fn observe(&mut self, buf: &FrameBuffer) -> Result<(), JsValue> {
        let frame = buf.frame()?;
        let (w, h) = (frame.width(), frame.height());
        let (ew, eh) = *self.size.get_or_insert((w, h));
        if (ew, eh) != (w, h) {
            return Err(js_error(DetectError::SizeChanged {
                expected_width: ew,
                expected_height: eh,
                width: w,
                height: h,
            }));
        }
        self.inner.observe(&frame);
        Ok(())
    }

    /// Frame pairs measured so far (one less than the frames observed).
    #[wasm_bindgen(getter)]
    pub fn pairs(&self) -> u32 {
        u32::try_from(self.inner.pairs()).unwrap_or(u32::MAX)
    }

    /// Whether the camera moves: `undefined` before two frames have been observed.
    #[wasm_bindgen(getter)]
    pub fn moving(&self) -> Option<bool> {
        self.inner.moving()
    }
}
