//! The synthetic scene (the embedded demo), rendered in wasm.

use super::*;
use crate::frame::Detection;
use crate::io::Record;
use crate::synth::{Scene, ScenePreset};
use tsify::Ts;
use wasm_bindgen::prelude::*;

/// Frames between two saved scene states: stepping back replays at most this many frames.
pub(super) const CHECKPOINT_EVERY: u32 = 100;

/// A deterministic synthetic sequence with ground truth, rendered in wasm straight into a
/// [`FrameBuffer`]: the demo needs nothing downloaded.
#[wasm_bindgen]
pub struct SynthScene {
    /// Positioned at the next frame to render in order.
    scene: Scene,
    /// Scene states before frames 1, 1+N, 1+2N, ... for random access (display scrubbing).
    checkpoints: Vec<Scene>,
}

#[wasm_bindgen]
impl SynthScene {
    /// The named scene.
    #[wasm_bindgen(constructor)]
    pub fn new(preset: Ts<ScenePreset>) -> Result<SynthScene, JsValue> {
        let cfg = rust(preset)?.config(0);
        let scene = Scene::new(cfg).map_err(js_error)?;
        Ok(SynthScene {
            checkpoints: vec![scene.clone()],
            scene,
        })
    }

    /// The named scene at another frame size (`width`, `height` in 16..=8192): its shapes,
    /// speeds and occluders scaled with the frame, so only the pixel count changes (the app's
    /// bench page measures the tracker at a chosen resolution with it).
    pub fn sized(preset: Ts<ScenePreset>, width: f64, height: f64) -> Result<SynthScene, JsValue> {
        let (w, h) = (whole_u32("width", width)?, whole_u32("height", height)?);
        let cfg = rust(preset)?.config(0).scaled_to(w, h);
        let scene = Scene::new(cfg).map_err(js_error)?;
        Ok(SynthScene {
            checkpoints: vec![scene.clone()],
            scene,
        })
    }

    /// Frame width.
    #[wasm_bindgen(getter)]
    pub fn width(&self) -> u32 {
        self.scene.config().width
    }

    /// Frame height.
    #[wasm_bindgen(getter)]
    pub fn height(&self) -> u32 {
        self.scene.config().height
    }

    /// Number of frames.
    #[wasm_bindgen(getter)]
    pub fn frames(&self) -> u32 {
        self.scene.config().frames
    }

    /// Frame rate.
    #[wasm_bindgen(getter)]
    pub fn fps(&self) -> f64 {
        self.scene.config().fps
    }

    /// Renders frame `n` (1-based) as RGBA into `buf`, with its ground truth and the scene's
    /// own (noisy) detections. In-order frames cost one render; others replay from the nearest
    /// saved state.
    pub fn render(&mut self, n: f64, buf: &mut FrameBuffer) -> Result<SceneFrame, JsValue> {
        let n = whole_u32("n", n)?;
        let (w, h, frames) = (self.width(), self.height(), self.frames());
        if n < 1 || n > frames {
            return Err(js_error(BindingError::FrameRange { frame: n, frames }));
        }
        if (buf.width(), buf.height()) != (w, h) {
            return Err(js_error(BindingError::SizeChanged {
                expected: (w, h),
                got: (buf.width(), buf.height()),
            }));
        }
        if self.scene.next_index() != n {
            let k = ((n - 1) / CHECKPOINT_EVERY) as usize;
            // Checkpoints exist for every block already reached in order; beyond, start from
            // the last one.
            let cp = k.min(self.checkpoints.len().saturating_sub(1));
            if let Some(s) = self.checkpoints.get(cp) {
                if self.scene.next_index() > n || s.next_index() > self.scene.next_index() {
                    self.scene = s.clone();
                }
            }
        }
        let mut frame = None;
        while self.scene.next_index() <= n {
            let next = self.scene.next_index();
            if (next - 1) % CHECKPOINT_EVERY == 0 {
                let k = ((next - 1) / CHECKPOINT_EVERY) as usize;
                if k == self.checkpoints.len() {
                    self.checkpoints.push(self.scene.clone());
                }
            }
            frame = self.scene.frame();
            if frame.is_none() {
                break;
            }
        }
        let Some(f) = frame.filter(|f| f.index == n) else {
            return Err(js_error(BindingError::FrameRange { frame: n, frames }));
        };
        for (dst, src) in buf
            .bytes_mut()
            .chunks_exact_mut(4)
            .zip(f.image.chunks_exact(3))
        {
            dst[..3].copy_from_slice(src);
            dst[3] = 255;
        }
        Ok(SceneFrame {
            index: f.index,
            gt: f.gt_records(),
            detections: f.detections,
        })
    }
}

/// One rendered synthetic frame's ground truth and detections (the pixels are in the buffer).
#[wasm_bindgen]
pub struct SceneFrame {
    index: u32,
    gt: Vec<Record>,
    detections: Vec<Detection>,
}

#[wasm_bindgen]
impl SceneFrame {
    /// Frame number (1-based).
    #[wasm_bindgen(getter)]
    pub fn index(&self) -> u32 {
        self.index
    }

    /// Ground truth of the visible objects, as records with masks.
    #[wasm_bindgen(js_name = groundTruth)]
    pub fn ground_truth(&self) -> Result<Ts<Records>, JsValue> {
        ts(&from_core_records(&self.gt))
    }

    /// The scene's own noisy mask detections (misses, jitter, false positives).
    pub fn detections(&self) -> Detections {
        Detections {
            inner: self.detections.clone(),
        }
    }
}
