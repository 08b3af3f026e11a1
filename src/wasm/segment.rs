//! The learned segmentation from JS: the core decides which crops the network sees and turns
//! its outputs into masks (`SegmentJob`, the core's `segment::Job`); JS runs the network
//! (onnxruntime-web, in a worker) between `input` and `supply`. So the page and the CLI make
//! the same decisions; only the network's arithmetic differs (wasm kernels vs tract).

use super::*;
use crate::segment::{Job, WholeFrame, INPUT_LEN, OUTPUT_LEN, SIDE};
use tsify::Ts;
use wasm_bindgen::prelude::*;

/// Side of the network's square input and output as the model declares it (320): the whole
/// frame's, and the default of a box's crop (`SegmentSettings.side`; `segmentBoxSide()` for a
/// box a person drew).
#[wasm_bindgen(js_name = segmentSide)]
pub fn segment_side() -> usize {
    SIDE
}

/// The side a crop around a given box runs at (256, `segment::BOX_SIDE`).
#[wasm_bindgen(js_name = segmentBoxSide)]
pub fn segment_box_side() -> u32 {
    crate::segment::BOX_SIDE
}

/// Values in one input tensor at the model's side (3·320·320).
#[wasm_bindgen(js_name = segmentInputLength)]
pub fn segment_input_length() -> usize {
    INPUT_LEN
}

/// Values in one output map at the model's side (320·320).
#[wasm_bindgen(js_name = segmentOutputLength)]
pub fn segment_output_length() -> usize {
    OUTPUT_LEN
}

/// One frame's learned segmentation:
///
/// ```js
/// const job = new SegmentJob(frame, detections, 'proposals', settings);
/// while (job.remaining > 0) job.supply(await net.run(job.input(frame)));
/// const withMasks = job.finish();   // Detections
/// ```
#[wasm_bindgen]
pub struct SegmentJob {
    job: Option<Job>,
}

#[wasm_bindgen]
impl SegmentJob {
    /// A job for `detections` (copied; boxes or masks to redo) on frames of `buf`'s size.
    /// `whole`: `"off"` (the boxes only), `"proposals"` (the whole frame first, its salient
    /// regions no detection covers added and segmented) or `"masks"`.
    #[wasm_bindgen(constructor)]
    pub fn new(
        buf: &FrameBuffer,
        detections: &Detections,
        whole: Option<Ts<WholeFrame>>,
        settings: Option<SegmentSettings>,
    ) -> Result<SegmentJob, JsValue> {
        let cfg = settings::segment_config(settings.as_ref())?;
        let whole = match whole {
            Some(w) => rust(w)?,
            None => WholeFrame::Off,
        };
        let job = Job::new(
            buf.width(),
            buf.height(),
            detections.inner.clone(),
            whole,
            &cfg,
        )
        .map_err(js_error)?;
        Ok(SegmentJob { job: Some(job) })
    }

    fn job(&self) -> Result<&Job, JsValue> {
        self.job
            .as_ref()
            .ok_or_else(|| js_error(BindingError::Invalid("the job has finished".into())))
    }

    /// Network runs still queued (a whole-frame pass may queue more).
    #[wasm_bindgen(getter)]
    pub fn remaining(&self) -> usize {
        self.job.as_ref().map_or(0, Job::remaining)
    }

    /// The pending crop (frame pixels), or `undefined` when the job is done.
    pub fn pending(&self) -> Result<Option<Ts<BoxJs>>, JsValue> {
        match self.job()?.pending() {
            Some(c) => Ok(Some(ts(&BoxJs::from(c.bbox()))?)),
            None => Ok(None),
        }
    }

    /// The pending crop's input tensor (`Float32Array` of 3·side·side, channels first: the side
    /// is the whole frame's 320 or the settings' `side` for a box) from the frame in `buf`.
    pub fn input(&self, buf: &FrameBuffer) -> Result<Vec<f32>, JsValue> {
        let frame = buf.frame()?;
        let side = self
            .job()?
            .pending_side()
            .ok_or_else(|| js_error(crate::segment::SegmentError::NothingPending))?;
        let mut out = vec![0f32; crate::segment::input_len(side)];
        self.job()?.input(&frame, &mut out).map_err(js_error)?;
        Ok(out)
    }

    /// Hands over the network's first output for the pending crop (side·side probabilities).
    pub fn supply(&mut self, output: &[f32]) -> Result<(), JsValue> {
        let job = self
            .job
            .as_mut()
            .ok_or_else(|| js_error(BindingError::Invalid("the job has finished".into())))?;
        job.supply(output).map_err(js_error)
    }

    /// The detections with their learned masks (each box the network found nothing in keeps
    /// what it came with). The job cannot be used afterwards.
    pub fn finish(&mut self) -> Result<Detections, JsValue> {
        let job = self
            .job
            .take()
            .ok_or_else(|| js_error(BindingError::Invalid("the job has finished".into())))?;
        Ok(Detections {
            inner: job.finish().detections,
        })
    }
}
