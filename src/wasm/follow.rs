//! Following one shape the user gave (`Follower`: the core's `follow::Follower`, frame by
//! frame in either direction) and shape-aware interpolation between two keyframe masks
//! (`interpolateMasks`). Masks cross the boundary as compressed RLE of the whole frame.

use super::*;
use crate::follow::{interpolate_masks, Follower as CoreFollower};
use crate::io::Rle;
use serde::{Deserialize, Serialize};
use tsify::{Ts, Tsify};
use wasm_bindgen::prelude::*;

/// The follower's result for one frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Tsify)]
pub struct FollowStepJs {
    /// The target's mask in this frame; absent once the follower has stopped.
    pub mask: Option<RleJs>,
    /// The mask's box; absent with the mask.
    pub bbox: Option<BoxJs>,
    /// Confidence in `[0, 1]`.
    pub confidence: f64,
    /// Not found confidently here: the mask is a prediction.
    pub lost: bool,
    /// The follower gave up (too many lost frames in a row) and reports nothing more.
    pub stopped: bool,
    /// A detection's mask was taken for this frame.
    pub from_detection: bool,
    /// The learned segmentation's mask was taken for this frame.
    pub from_learned: bool,
}

/// Follows one target from the mask given on a first frame. Feed it the frames in the
/// direction of travel (forward or backward), one `step` per frame; start a second follower
/// on the same first frame for the other direction.
#[wasm_bindgen]
pub struct Follower {
    inner: CoreFollower,
    width: u32,
    height: u32,
    /// The crop `learnedInput` prepared, which `stepLearned`'s output belongs to.
    crop: Option<crate::segment::Crop>,
}

#[wasm_bindgen]
impl Follower {
    /// Starts from `mask` (RLE of the whole frame, the buffer's size) on the frame in `buf`.
    /// An empty mask, a mask of another size or bad settings are errors.
    #[wasm_bindgen(constructor)]
    pub fn new(
        buf: &FrameBuffer,
        mask: Ts<RleJs>,
        options: Option<FollowSettings>,
    ) -> Result<Follower, JsValue> {
        let rle = rust(mask)?.to_rle()?;
        let (width, height) = (buf.width(), buf.height());
        if (rle.width, rle.height) != (width, height) {
            return Err(js_error(BindingError::Invalid(format!(
                "the mask is {}x{}, the frame {width}x{height}",
                rle.width, rle.height
            ))));
        }
        let cfg = settings::follow_config(options.as_ref())?;
        let frame = buf.frame()?;
        let inner = CoreFollower::new(&frame, &rle.to_mask(), cfg).map_err(js_error)?;
        Ok(Follower {
            inner,
            width,
            height,
            crop: None,
        })
    }

    /// The learned segmentation's input for the next frame (in `buf`): the crop around where
    /// the target is expected, as a `Float32Array` for the network; `undefined` once stopped.
    /// Run the network on it and hand the output to `stepLearned` with the same frame.
    #[wasm_bindgen(js_name = learnedInput)]
    pub fn learned_input(&mut self, buf: &FrameBuffer) -> Result<Option<Vec<f32>>, JsValue> {
        let frame = buf.frame()?;
        self.crop = None;
        let Some(crop) = self.inner.learned_crop() else {
            return Ok(None);
        };
        let side = self.inner.config().segment.side;
        let mut out = vec![0f32; crate::segment::input_len(side)];
        crate::segment::input_tensor(&frame, &crop, &mut out).map_err(js_error)?;
        self.crop = Some(crop);
        Ok(Some(out))
    }

    /// As `stepWith` (detections optional), with the network's output for the input
    /// `learnedInput` gave for this frame.
    #[wasm_bindgen(js_name = stepLearned)]
    pub fn step_learned(
        &mut self,
        buf: &FrameBuffer,
        output: &[f32],
        detections: Option<Detections>,
    ) -> Result<Ts<FollowStepJs>, JsValue> {
        let crop = self.crop.take().ok_or_else(|| {
            js_error(BindingError::Invalid(
                "stepLearned needs the output for this frame's learnedInput".into(),
            ))
        })?;
        let segment = &self.inner.config().segment;
        let expected = crate::segment::output_len(segment.side);
        if output.len() != expected {
            return Err(js_error(crate::segment::SegmentError::TensorLength {
                what: "the network's output",
                len: output.len(),
                expected,
            }));
        }
        let sal = crate::segment::Saliency::new(crop, output, segment.stretch).map_err(js_error)?;
        let dets = detections.map(|d| d.inner).unwrap_or_default();
        let frame = buf.frame()?;
        let s = self
            .inner
            .step_learned(&frame, &dets, Some(&sal))
            .map_err(js_error)?;
        self.report(s)
    }

    /// Follows the target into the frame in `buf` (the next one in the direction of travel),
    /// from the pixels alone.
    pub fn step(&mut self, buf: &FrameBuffer) -> Result<Ts<FollowStepJs>, JsValue> {
        self.advance(buf, &[])
    }

    /// As `step`, preferring a detection whose mask agrees with the followed one.
    #[wasm_bindgen(js_name = stepWith)]
    pub fn step_with(
        &mut self,
        buf: &FrameBuffer,
        detections: &Detections,
    ) -> Result<Ts<FollowStepJs>, JsValue> {
        self.advance(buf, &detections.inner)
    }

    /// Whether the follower has stopped.
    #[wasm_bindgen(getter)]
    pub fn stopped(&self) -> bool {
        self.inner.stopped()
    }
}

impl Follower {
    fn advance(
        &mut self,
        buf: &FrameBuffer,
        dets: &[crate::frame::Detection],
    ) -> Result<Ts<FollowStepJs>, JsValue> {
        let frame = buf.frame()?;
        self.crop = None;
        let s = self.inner.step(&frame, dets).map_err(js_error)?;
        self.report(s)
    }

    fn report(&self, s: crate::follow::FollowStep) -> Result<Ts<FollowStepJs>, JsValue> {
        let has = !s.stopped && !s.mask.is_empty();
        let rle = has.then(|| Rle::from_mask(&s.mask, self.width, self.height));
        ts(&FollowStepJs {
            bbox: rle.as_ref().map(|r| r.bbox().into()),
            mask: rle.as_ref().map(RleJs::from),
            confidence: s.confidence,
            lost: s.lost,
            stopped: s.stopped,
            from_detection: s.from_detection,
            from_learned: s.from_learned,
        })
    }
}

/// The mask at `t ∈ [0, 1]` between keyframe masks `a` (t = 0) and `b` (t = 1) of one frame
/// size: their outlines matched point to point (shape context) and moved linearly, not a box
/// blend.
#[wasm_bindgen(js_name = interpolateMasks)]
pub fn interpolate_masks_js(a: Ts<RleJs>, b: Ts<RleJs>, t: f64) -> Result<Ts<RleJs>, JsValue> {
    let (a, b) = (rust(a)?.to_rle()?, rust(b)?.to_rle()?);
    if (a.width, a.height) != (b.width, b.height) {
        return Err(js_error(BindingError::Invalid(format!(
            "keyframe masks of different sizes: {}x{} and {}x{}",
            a.width, a.height, b.width, b.height
        ))));
    }
    let m =
        interpolate_masks(&a.to_mask(), &b.to_mask(), t, a.width, a.height).map_err(js_error)?;
    ts(&RleJs::from(&Rle::from_mask(&m, a.width, a.height)))
}
