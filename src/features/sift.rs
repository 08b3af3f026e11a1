//! SIFT keypoints and descriptors (Lowe 2004), a port of OpenCV 4.x's `cv::SIFT`.
//!
//! The tracker's shape-context variant and the offline re-linker match SIFT keypoints between
//! two appearances of a shape. [`detect_in_region`] runs on a detection's region of a frame,
//! keeping only keypoints inside its mask ([`detect_and_compute`] does the same on any grey
//! image); [`match_descriptors`] pairs two shapes' features with Lowe's ratio test.
//!
//! Cost grows with the region's area (about 4× per doubling of its side, with OpenCV's default
//! upsampling): for per-frame use, bound it with [`SiftConfig::max_side`] and consider
//! `upsample: false` (about half the time on 128–256 px crops, fewer small-scale keypoints).
//!
//! The pipeline and its constants are OpenCV's float path (`sift.dispatch.cpp` /
//! `sift.simd.hpp` with `DoG_TYPE_SHORT 0`): input optionally upsampled 2× (bilinear), Gaussian
//! scale space with `n_octave_layers + 3` layers per octave (σ = 1.6, input blur assumed 0.5),
//! DoG, 3×3×3 extrema above half the contrast threshold, up to five quadratic refinement steps,
//! contrast (`0.04 / n_octave_layers`) and edge (r = 10) rejection, 36-bin orientation histogram
//! with peaks ≥ 80 % spawning extra keypoints, and the 4×4×8 descriptor with trilinear
//! interpolation, clipping at 0.2 and byte scaling ×512. Gradient angles use OpenCV's
//! `fastAtan2` polynomial so histograms bin alike.
//!
//! Deliberate differences from OpenCV, each for the tracker's sake:
//! - **Coordinates** follow this crate's pixel convention (pixel `(i, j)` covers
//!   `[i, i+1) × [j, j+1)`), and the quarter-pixel shift that OpenCV's half-pixel-centred
//!   upsampling leaves in its keypoints is removed: `x_ours = x_opencv + 0.25` when upsampling,
//!   `x_opencv + 0.5` otherwise.
//! - **Mask before budget**: keypoints outside the mask are dropped before `max_keypoints` keeps
//!   the strongest (OpenCV trims first, so a mask can leave fewer than `nfeatures`).
//! - **Order**: keypoints are sorted by decreasing response (OpenCV's order is unspecified).
//! - **`max_side`**: an optional area downscale of large inputs, with results mapped back.
//!
//! Descriptors are stored as bytes (`[u8; 128]`): OpenCV's float descriptors hold exactly these
//! saturated byte values, so nothing is lost, they take a quarter of the memory, and matching
//! runs on exact integer arithmetic.

mod descriptor;
mod detect;
mod matching;
mod scale_space;

use image::{GrayImage, Luma};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::frame::{BBox, Frame, Mask, PixelFormat};

use descriptor::{calc_descriptor, quantize, DESCR_LEN};
use detect::{find_scale_space_extrema, DetectParams, RawKeypoint};
use scale_space::{area_resize, dog_pyramid, gaussian_pyramid, initial_image, Plane};

/// Errors from SIFT detection.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SiftError {
    /// The image has no pixels.
    #[error("image is empty ({width}x{height})")]
    EmptyImage {
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
    },
    /// The mask's size differs from the image's.
    #[error("mask is {mask_width}x{mask_height} but the image is {width}x{height}")]
    MaskSize {
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
        /// Mask width.
        mask_width: u32,
        /// Mask height.
        mask_height: u32,
    },
    /// A raw pixel buffer does not hold `width * height` values.
    #[error("pixel buffer has {len} values, expected {width}x{height} = {expected}")]
    BufferSize {
        /// Values given.
        len: usize,
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
        /// Values expected.
        expected: usize,
    },
    /// A raw pixel value is NaN or infinite.
    #[error("pixel {index} is not finite ({value})")]
    NonFinitePixel {
        /// Index in the buffer.
        index: usize,
        /// The value found.
        value: f32,
    },
    /// A configuration value is out of range.
    #[error(
        "invalid SIFT config: {field} = {} ({reason})",
        crate::settings::Short::of(.value)
    )]
    InvalidConfig {
        /// Field name in [`SiftConfig`].
        field: &'static str,
        /// The value given.
        value: f64,
        /// What the field accepts.
        reason: &'static str,
    },
}

/// Detector settings. `Default` gives OpenCV's `SIFT::create()` defaults and no size bound;
/// missing fields deserialise to their defaults.
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SiftConfig {
    /// Layers per octave in which extrema are sought (OpenCV `nOctaveLayers`). Default 3;
    /// accepted 1..=8.
    pub n_octave_layers: u32,
    /// Contrast threshold on |D| at the refined extremum, divided by `n_octave_layers`
    /// (intensities scaled to `[0, 1]`). Default 0.04; higher gives fewer keypoints.
    pub contrast_threshold: f32,
    /// Maximum ratio of principal curvatures of kept extrema (edge rejection). Default 10;
    /// lower rejects more edge-like keypoints. Must be > 0.
    pub edge_threshold: f32,
    /// Blur of the first octave's first layer. Default 1.6; accepted (0, 16].
    pub sigma: f32,
    /// Upsample the input 2× before building the pyramid (OpenCV's first octave −1): roughly
    /// four times more keypoints on small crops, at about four times the cost. Default true.
    pub upsample: bool,
    /// Keep only the strongest keypoints by response (OpenCV `nfeatures`). As in OpenCV,
    /// keypoints tied with the last one kept (the other orientations of the same location) are
    /// kept too. `None` (default) keeps all.
    pub max_keypoints: Option<usize>,
    /// If the image's longer side exceeds this, area-downscale it so the longer side equals
    /// `max_side` before detection; keypoints are mapped back to input coordinates. Bounds the
    /// cost on large crops. `None` (default) never downscales; must be ≥ 1.
    pub max_side: Option<u32>,
}

impl Default for SiftConfig {
    fn default() -> Self {
        SiftConfig {
            n_octave_layers: 3,
            contrast_threshold: 0.04,
            edge_threshold: 10.0,
            sigma: 1.6,
            upsample: true,
            max_keypoints: None,
            max_side: None,
        }
    }
}

impl SiftConfig {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), SiftError> {
        let bad = |field, value: f64, reason| {
            Err(SiftError::InvalidConfig {
                field,
                value,
                reason,
            })
        };
        if !(1..=8).contains(&self.n_octave_layers) {
            return bad(
                "n_octave_layers",
                f64::from(self.n_octave_layers),
                "must be in 1..=8",
            );
        }
        let ct = self.contrast_threshold;
        if !(ct.is_finite() && ct >= 0.0) {
            return bad(
                "contrast_threshold",
                f64::from(ct),
                "must be finite and >= 0",
            );
        }
        let et = self.edge_threshold;
        if !(et.is_finite() && et > 0.0) {
            return bad("edge_threshold", f64::from(et), "must be finite and > 0");
        }
        let s = self.sigma;
        if !(s.is_finite() && s > 0.0 && s <= 16.0) {
            return bad("sigma", f64::from(s), "must be in (0, 16]");
        }
        if self.max_side == Some(0) {
            return bad("max_side", 0.0, "must be >= 1");
        }
        Ok(())
    }
}

/// A SIFT keypoint in input-image coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Keypoint {
    /// Column of the centre, in pixels (pixel `i` spans `[i, i+1)`).
    pub x: f32,
    /// Row of the centre, in pixels, growing downwards.
    pub y: f32,
    /// Diameter of the meaningful neighbourhood (OpenCV's `KeyPoint::size`): twice the
    /// detection scale σ, in input pixels.
    pub size: f32,
    /// Dominant gradient orientation in degrees, `[0, 360)`, measured from +x towards +y
    /// (clockwise on screen), as OpenCV's `KeyPoint::angle`.
    pub angle: f32,
    /// Contrast |D| of the refined DoG extremum (intensities in `[0, 1]`); larger is stronger.
    pub response: f32,
    /// Octave it was found in: −1 is the 2× upsampled image, 0 the input, 1 half size, …
    /// (relative to the downscaled image when `max_side` applied).
    pub octave: i32,
}

/// Keypoints with one descriptor each (`descriptors[i]` describes `keypoints[i]`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SiftFeatures {
    /// Keypoints, strongest response first.
    pub keypoints: Vec<Keypoint>,
    /// 128-byte descriptors: the unit-norm, 0.2-clipped histogram × 512, saturated to bytes.
    pub descriptors: Vec<[u8; 128]>,
}

impl SiftFeatures {
    /// Number of keypoints.
    pub fn len(&self) -> usize {
        self.keypoints.len()
    }

    /// Whether there are no keypoints.
    pub fn is_empty(&self) -> bool {
        self.keypoints.is_empty()
    }
}

/// Matching settings (missing fields deserialise to their defaults).
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MatchConfig {
    /// Lowe's ratio: a match is kept when its distance is below `ratio` × the distance to the
    /// second nearest train descriptor. Default 0.8 (Lowe 2004). Values ≥ 1 disable the test
    /// except for exact ties; NaN keeps nothing.
    pub ratio: f32,
    /// Also require the query to be the nearest neighbour of its train descriptor (mutual
    /// nearest neighbours). Default false.
    pub cross_check: bool,
}

impl Default for MatchConfig {
    fn default() -> Self {
        MatchConfig {
            ratio: 0.8,
            cross_check: false,
        }
    }
}

/// A match between descriptor `query` of the first set and `train` of the second.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SiftMatch {
    /// Index in the query (first) set.
    pub query: usize,
    /// Index in the train (second) set.
    pub train: usize,
    /// L2 distance between the byte descriptors (same scale as OpenCV's `DMatch::distance`).
    pub distance: f32,
}

/// Detects SIFT keypoints in a grey image and computes their descriptors.
///
/// `mask`, if given, must have the image's size; a keypoint is kept when the mask pixel under its
/// centre is non-zero. Images too small to hold a keypoint (e.g. 1×1) give an empty result; an
/// image with no pixels is an error.
pub fn detect_and_compute(
    img: &GrayImage,
    mask: Option<&GrayImage>,
    cfg: &SiftConfig,
) -> Result<SiftFeatures, SiftError> {
    let (w, h) = img.dimensions();
    let plane = Plane {
        w: w as usize,
        h: h as usize,
        data: img.as_raw().iter().map(|&v| f32::from(v)).collect(),
    };
    run(plane, w, h, mask, cfg)
}

/// [`detect_and_compute`] on a row-major `f32` grey buffer with values on the 0–255 scale
/// (thresholds are OpenCV's, which assume 8-bit intensities).
pub fn detect_and_compute_f32(
    pixels: &[f32],
    width: u32,
    height: u32,
    mask: Option<&GrayImage>,
    cfg: &SiftConfig,
) -> Result<SiftFeatures, SiftError> {
    let expected = (width as usize).saturating_mul(height as usize);
    if pixels.len() != expected {
        return Err(SiftError::BufferSize {
            len: pixels.len(),
            width,
            height,
            expected,
        });
    }
    if let Some((index, &value)) = pixels.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(SiftError::NonFinitePixel { index, value });
    }
    let plane = Plane {
        w: width as usize,
        h: height as usize,
        data: pixels.to_vec(),
    };
    run(plane, width, height, mask, cfg)
}

/// SIFT features of one region of a frame, in frame coordinates: what the tracker computes per
/// detection. The frame is cropped to `region` (clipped to the frame) and converted to grey
/// (BT.601); with `mask`, only keypoints on its foreground pixels are kept. `cfg.max_side`
/// bounds the cost of large regions. A region outside the frame gives no features.
pub fn detect_in_region(
    frame: &Frame<'_>,
    region: &BBox,
    mask: Option<&Mask>,
    cfg: &SiftConfig,
) -> Result<SiftFeatures, SiftError> {
    match RegionCrop::new(frame, region, mask) {
        Some(crop) => crop.detect(cfg),
        None => Ok(SiftFeatures::default()),
    }
}

/// The input of [`detect_in_region`] cut out of the frame: the region's pixels (clipped to the
/// frame) and, when a mask was given, the mask. It lets the keypoints be computed after the
/// frame is gone, and only if they are ever needed (the tracker keeps one per described view,
/// and most views are never compared by SIFT). The pixels are copied as they are (row
/// copies); the grey conversion, which costs more, waits for [`RegionCrop::detect`].
#[derive(Debug, Clone, PartialEq)]
pub struct RegionCrop {
    /// The clipped rectangle `(x0, y0, w, h)` in the frame.
    rect: crate::frame::PixelRect,
    /// Its pixels in the frame's layout, rows packed.
    pixels: Vec<u8>,
    /// The frame's layout.
    format: PixelFormat,
    /// The mask, in frame coordinates.
    mask: Option<Mask>,
}

impl RegionCrop {
    /// Cuts `region` (clipped to the frame) out of `frame`, with `mask`; `None` when the region
    /// lies outside the frame.
    pub fn new(frame: &Frame<'_>, region: &BBox, mask: Option<&Mask>) -> Option<Self> {
        let (rect, pixels) = frame.crop(region)?;
        Some(Self {
            rect,
            pixels,
            format: frame.format(),
            mask: mask.cloned(),
        })
    }

    /// The SIFT features of the crop, in frame coordinates (as [`detect_in_region`]).
    pub fn detect(&self, cfg: &SiftConfig) -> Result<SiftFeatures, SiftError> {
        let (x0, y0, w, h) = self.rect;
        let stride = w as usize * self.format.channels();
        let Some(gray) = Frame::new(&self.pixels, w, h, stride, self.format)
            .ok()
            .and_then(|f| f.gray_crop(&BBox::new(0.0, 0.0, w as f64, h as f64)))
            .map(|(_, g)| g)
        else {
            return Err(SiftError::EmptyImage {
                width: w,
                height: h,
            });
        };
        let mask_crop = self.mask.as_ref().map(|m| {
            GrayImage::from_fn(w, h, |x, y| {
                Luma([u8::from(m.get((x0 + x) as i32, (y0 + y) as i32)) * 255])
            })
        });
        let mut feats = detect_and_compute(&gray, mask_crop.as_ref(), cfg)?;
        for k in &mut feats.keypoints {
            k.x += x0 as f32;
            k.y += y0 as f32;
        }
        Ok(feats)
    }
}

/// Matches descriptors of `query` against `train` (brute-force L2, ratio test, optional cross
/// check). Results are ordered by query index.
pub fn match_descriptors(
    query: &SiftFeatures,
    train: &SiftFeatures,
    cfg: &MatchConfig,
) -> Vec<SiftMatch> {
    matching::match_sets(&query.descriptors, &train.descriptors, cfg)
}

/// [`match_descriptors`] on bare descriptor slices.
pub fn match_descriptor_sets(
    query: &[[u8; 128]],
    train: &[[u8; 128]],
    cfg: &MatchConfig,
) -> Vec<SiftMatch> {
    matching::match_sets(query, train, cfg)
}

/// Shared driver: validates, quantises the descriptors.
fn run(
    input: Plane,
    w: u32,
    h: u32,
    mask: Option<&GrayImage>,
    cfg: &SiftConfig,
) -> Result<SiftFeatures, SiftError> {
    let (keypoints, float_desc) = detect_float(input, w, h, mask, cfg)?;
    Ok(SiftFeatures {
        keypoints,
        descriptors: float_desc.iter().map(quantize).collect(),
    })
}

/// The whole pipeline on a plane of the input's size `w × h`, with unit-norm float descriptors.
fn detect_float(
    input: Plane,
    w: u32,
    h: u32,
    mask: Option<&GrayImage>,
    cfg: &SiftConfig,
) -> Result<(Vec<Keypoint>, Vec<[f32; DESCR_LEN]>), SiftError> {
    cfg.validate()?;
    if w == 0 || h == 0 {
        return Err(SiftError::EmptyImage {
            width: w,
            height: h,
        });
    }
    if let Some(m) = mask {
        if m.dimensions() != (w, h) {
            return Err(SiftError::MaskSize {
                width: w,
                height: h,
                mask_width: m.width(),
                mask_height: m.height(),
            });
        }
    }

    // Optional downscale; (sx, sy) map work-plane pixels back to input pixels.
    let (work, sx, sy) = match cfg.max_side {
        Some(ms) if w.max(h) > ms => {
            let s = f64::from(ms) / f64::from(w.max(h));
            let nw = ((f64::from(w) * s).round() as usize).clamp(1, ms as usize);
            let nh = ((f64::from(h) * s).round() as usize).clamp(1, ms as usize);
            let p = area_resize(&input, nw, nh);
            (p, w as f32 / nw as f32, h as f32 / nh as f32)
        }
        _ => (input, 1.0, 1.0),
    };

    let first_octave: i32 = if cfg.upsample { -1 } else { 0 };
    let n_layers = cfg.n_octave_layers as usize;
    let base = initial_image(&work, cfg.upsample, cfg.sigma);
    let min_side = base.w.min(base.h) as f64;
    // OpenCV's octave count; its last octave is only ~4 px wide, too small for any extremum
    // (5 px border), but it is kept so the pyramids are OpenCV's.
    let n_octaves = ((min_side.log2() - 2.0).round_ties_even() as i64 - i64::from(first_octave))
        .max(0) as usize;
    if n_octaves == 0 {
        return Ok((Vec::new(), Vec::new()));
    }
    let gpyr = gaussian_pyramid(base, n_octaves, n_layers, f64::from(cfg.sigma));
    let dog = dog_pyramid(&gpyr, n_layers);

    // Octave coordinates -> input coordinates (crate pixel convention, see the module docs).
    let base_scale = if cfg.upsample { 0.5f32 } else { 1.0 };
    let base_shift = if cfg.upsample { 0.25f32 } else { 0.5 };
    let to_input = move |octave: usize, x_oct: f32, y_oct: f32| {
        let f = (1u32 << octave) as f32 * base_scale;
        ((x_oct * f + base_shift) * sx, (y_oct * f + base_shift) * sy)
    };
    let inside_mask = |octave: usize, x_oct: f32, y_oct: f32| match mask {
        None => true,
        Some(m) => {
            let (x, y) = to_input(octave, x_oct, y_oct);
            x >= 0.0
                && y >= 0.0
                && (x as u32) < w
                && (y as u32) < h
                && m.get_pixel(x as u32, y as u32).0[0] != 0
        }
    };
    let params = DetectParams {
        n_layers,
        contrast_threshold: cfg.contrast_threshold,
        edge_threshold: cfg.edge_threshold,
        sigma: cfg.sigma,
    };
    let mut raw = find_scale_space_extrema(&gpyr, &dog, &params, inside_mask);

    // Strongest first; exact duplicates (two start pixels refining to the same extremum) are
    // adjacent after this sort and removed, as OpenCV's removeDuplicatedSorted.
    raw.sort_by(|a, b| {
        b.response
            .total_cmp(&a.response)
            .then(a.y_oct.total_cmp(&b.y_oct))
            .then(a.x_oct.total_cmp(&b.x_oct))
            .then(a.octave.cmp(&b.octave))
            .then(a.size_base.total_cmp(&b.size_base))
            .then(a.angle.total_cmp(&b.angle))
    });
    raw.dedup_by(|a, b| same_keypoint(a, b));
    if let Some(n) = cfg.max_keypoints {
        retain_best(&mut raw, n);
    }

    let size_scale = 0.5 * (sx + sy);
    let mut keypoints = Vec::with_capacity(raw.len());
    let mut descriptors = Vec::with_capacity(raw.len());
    let mut scratch = descriptor::DescriptorScratch::default();
    for k in &raw {
        let Some(img) = gpyr.get(k.octave * (n_layers + 3) + k.layer) else {
            continue;
        };
        // The descriptor works in the gradients' y-up frame, hence 360 - angle (as OpenCV).
        let mut ori = 360.0 - k.angle;
        if (ori - 360.0).abs() < f32::EPSILON {
            ori = 0.0;
        }
        descriptors.push(calc_descriptor(
            img,
            k.x_oct,
            k.y_oct,
            ori,
            k.scale_oct,
            &mut scratch,
        ));
        let (x, y) = to_input(k.octave, k.x_oct, k.y_oct);
        keypoints.push(Keypoint {
            x,
            y,
            size: k.size_base * base_scale * size_scale,
            angle: k.angle,
            response: k.response,
            octave: k.octave as i32 + first_octave,
        });
    }
    Ok((keypoints, descriptors))
}

/// Same location, scale and orientation (bit-exact), i.e. one extremum found twice.
fn same_keypoint(a: &RawKeypoint, b: &RawKeypoint) -> bool {
    a.octave == b.octave
        && a.x_oct == b.x_oct
        && a.y_oct == b.y_oct
        && a.size_base == b.size_base
        && a.angle == b.angle
}

/// OpenCV's `KeyPointsFilter::retainBest` on a list sorted by decreasing response: keeps the
/// first `n` and any further keypoints tied with the `n`-th.
fn retain_best(kps: &mut Vec<RawKeypoint>, n: usize) {
    if kps.len() <= n {
        return;
    }
    if n == 0 {
        kps.clear();
        return;
    }
    let cut = kps[n - 1].response;
    let end = n + kps[n..].iter().take_while(|k| k.response >= cut).count();
    kps.truncate(end);
}

#[cfg(test)]
mod tests;
