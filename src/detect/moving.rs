//! Moving-object detection for footage from a moving camera: what moves against the
//! camera's own motion, found by dense optical flow (the default cue) or by
//! camera-motion-compensated background subtraction (the thesis' eq. 1–2 on a warped model).
//!
//! Per frame, on a grey copy area-averaged down to at most [`MovingConfig::work_side`] pixels
//! on its longer side:
//!
//! 1. **Camera motion from sparse matches** ([`CameraMotion`]): a global shift from an
//!    exhaustive block match at half the working size over the frame's outer band (a camera
//!    that follows an object keeps it central, and its near-zero image motion must not win),
//!    then corner points of the previous frame (the strongest Shi–Tomasi response per grid
//!    cell) matched by patch SSD around the shifted position, and an affine fit by RANSAC
//!    ([`ransac`]).
//!
//! With the **flow cue** ([`MotionCue::Flow`], the default):
//!
//! 2. **Dense flow** from the current frame back to the previous one ([`DenseFlow`], DIS with
//!    its variational refinement), started from step 1's motion: each patch tries it beside
//!    its coarse-to-fine estimate, which on fine repetitive texture (fences, façades) would
//!    otherwise settle a period off.
//! 3. **The camera's motion from the flow**: an affine fit by RANSAC to the flow on a grid
//!    of pixels; the moving objects are its outliers. Too few or too small a share of inliers
//!    (a cut, a blur, a scene without texture) or a zoom beyond ±20 %: nothing is reported
//!    this frame, and the next is compared with this one.
//! 4. **Residual motion**: a pixel moves when its flow differs from the camera's by more
//!    than `max(min_residual, residual_factor × median)` working pixels, the median over
//!    the frame (flow noise and the parallax an affine motion leaves, which differ from video
//!    to video). Pixels the camera brought into view (their earlier position off the previous
//!    frame, or within half a patch of its border) have no measured flow and never move. More
//!    than [`MovingConfig::max_foreground`] of the frame moving: a failed compensation,
//!    nothing reported. No history is needed: detections start at the second frame, and the
//!    flat interior of a moving object moves with its edges (the flow's smoothness carries it
//!    there), which the background cue's per-pixel test cannot see.
//!
//! With the **background cue** ([`MotionCue::Background`]):
//!
//! 2. **Failure check.** Too few or too small a share of inliers (a cut, fast motion, a scene
//!    without texture), a large residual, or a frame that still differs from the warped
//!    previous one almost everywhere: the model is re-initialised from this frame and nothing
//!    is reported until it has learnt again ([`MovingConfig::min_age`] frames). Better a few
//!    frames without detections than a frame full of them.
//! 3. **Warp** the background model `B` (and each pixel's age, the frames of history behind
//!    it) into the current frame; pixels that come into view start with age 0.
//! 4. **Detect and learn** with the thesis' eq. 1–2: foreground where `|Z − B| > threshold` on
//!    pixels with history, allowing for a registration error of [`MovingConfig::tolerance`]
//!    pixels (the model is resampled at every warp and an affine motion misses parallax: on
//!    an edge that alone exceeds the threshold; on the 8 DAVIS moving-camera sequences mean J
//!    0.34 → 0.41); `B ← (1 − a)·B + a·Z` with `a = max(alpha, 1/(age + 1))` (the
//!    mean of the frames seen so far while the history is short: eq. 1), background pixels
//!    only, except that foreground pixels learn slowly. A foreground pixel that keeps one
//!    steady colour for [`MovingConfig::ghost_frames`] frames takes it as its background:
//!    that is the scene uncovered where the model still holds an object that has moved on (a
//!    "ghost", above all of the first frames' objects), which would otherwise stay
//!    foreground for `1/foreground_alpha` frames and join the object's blob.
//! 5. If more than [`MovingConfig::max_foreground`] of the pixels with history are foreground,
//!    the compensation has failed (parallax, a zoom the affine model missed): re-initialise
//!    as in step 2, report nothing.
//!
//! Then, with either cue:
//!
//! 6. **Blobs → boxes → masks.** Opening and closing, connected components, small blobs
//!    dropped; each remaining blob's box (scaled to the frame, grown by
//!    [`MovingConfig::box_margin`]) is refined into a mask by [`refine_box_hinted`], the
//!    blob's own pixels as the [`Hint`] its colour models start from. The coarse foreground
//!    finds *where* something moves; the refinement finds its outline.
//!
//! Measured on the 8 DAVIS 2016 moving-camera sequences (`tests/data/detect/README.md`): mean
//! J 0.673 with the flow cue against 0.478 with the background cue as it was before it
//! (0.494 with the hint), at half the off-object masks per frame.

use super::components::{Components, Connectivity};
use super::flow::{DenseFlow, FlowConfig, FlowField};
use super::morphology::Morphology;
use super::refine::{refine_box_hinted, Hint, RefineConfig};
use super::{DetectError, Detector};
use crate::features::transform::{ransac, RansacConfig, Transform, TransformKind};
use crate::frame::{BBox, Detection, Frame, Mask, Point};
use serde::{Deserialize, Serialize};

/// Settings of the [`MovingCameraDetector`].
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MovingConfig {
    /// Longer side of the working copy in pixels (854×480 works at 214×120). Default `240`.
    pub work_side: u32,
    /// Background cue: grey-level difference (working copy) above which a pixel is
    /// foreground. Default `18`.
    pub threshold: f32,
    /// Background cue: learning rate `α` of eq. 2 once a pixel has history. Default `0.1`.
    pub alpha: f32,
    /// Background cue: learning rate of foreground pixels (lets ghosts of the first frames
    /// fade). Default `0.02`.
    pub foreground_alpha: f32,
    /// Background cue: frames of history a pixel needs before it can be foreground. Default
    /// `3`.
    pub min_age: u32,
    /// Fewest RANSAC inliers for a camera motion to be trusted. Default `12`.
    pub min_inliers: usize,
    /// Smallest inlier share of the matches for a camera motion to be trusted. Default `0.2`:
    /// an object that fills half the frame holds half the matches (at 0.35 soapbox lost a
    /// third of its frames to re-initialisations); a cut or a blurred frame gives a few
    /// chance inliers in a hundred.
    pub min_inlier_ratio: f64,
    /// Largest share of the pixels (with history, for the background cue) that may be
    /// foreground. Default `0.5`.
    pub max_foreground: f64,
    /// Blobs smaller than this share of the working frame are dropped. Default `0.002`.
    pub min_blob: f64,
    /// Most blobs refined per frame, largest first (the per-frame cost bound). Default `4`.
    pub max_blobs: usize,
    /// A blob's box grows by this fraction of its size on each side before refinement.
    /// Default `0.1`.
    pub box_margin: f64,
    /// Radius of the closing that joins the pieces of one object (working pixels). Default `2`.
    pub close_radius: u32,
    /// Refinement settings; `None` reports the coarse blobs themselves (upscaled). Default:
    /// [`RefineConfig`]'s defaults. Each blob's own pixels are the refinement's [`Hint`], so
    /// its colour models start from the object rather than from the whole, loose box. (Before
    /// the hint, the texture feature was off here: from the blobs' boxes alone it cost mean J
    /// 0.478 → 0.471 on the 8 DAVIS moving-camera sequences; with the flow cue's blobs as
    /// hints it gains, see `tests/data/detect/README.md`.)
    pub refine: Option<RefineConfig>,
    /// Background cue: registration error allowed, in working pixels: a pixel is foreground only
    /// when no model pixel within this radius is within the threshold of it, or no frame
    /// pixel within it is within the threshold of the model's pixel (see step 4). Default `1`.
    pub tolerance: u32,
    /// Background cue, ghost removal: frames a foreground pixel must keep one steady colour (within the
    /// threshold) before that colour replaces its model (0 = never). A model that still holds
    /// an object that has moved on (the first frames' object, above all) otherwise shows the
    /// object's "ghost" for as long as foreground pixels take to learn (`1/foreground_alpha`
    /// frames) and joins it to the object's blob. Default `8` (a third of a second at 24 fps):
    /// mean J on the 8 DAVIS moving-camera sequences 0.407 → 0.461, car-shadow 0.289 → 0.568;
    /// 4 frames swallow slow objects' flat interiors (0.339), 16 leave ghosts longer (0.425).
    pub ghost_frames: u32,
    /// What tells a moving pixel from the camera's motion. Default [`MotionCue::Flow`].
    pub cue: MotionCue,
    /// The dense flow's settings ([`MotionCue::Flow`]).
    pub flow: FlowConfig,
    /// [`MotionCue::Flow`]: a pixel moves when its flow differs from the camera's by more
    /// than `max(min_residual, residual_factor × the frame's median difference)` working
    /// pixels. Default `0.5` (2 frame pixels at 854×480).
    pub min_residual: f32,
    /// See [`min_residual`](Self::min_residual): the median difference is the flow's noise
    /// and the parallax the affine camera motion leaves, which differ from video to video.
    /// Default `4`.
    pub residual_factor: f32,
}

/// The cue that finds what moves against the camera ([`MovingConfig::cue`]).
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MotionCue {
    /// Dense optical flow ([`DenseFlow`]) between consecutive frames against the camera's
    /// affine motion fitted to it: a pixel moves when its flow is not the camera's. Needs no
    /// history (it reports from the second frame), and the interior of a flat-coloured
    /// object moves with its edges (the flow's smoothness carries it). On the 8 DAVIS
    /// moving-camera sequences mean J 0.673 (the background cue: 0.494), with fewer masks off
    /// the object (`tests/data/detect/README.md`).
    #[default]
    Flow,
    /// The background model warped with the camera motion, and the thesis' eq. 1–2 against
    /// it (steps 3–5 of the module docs): a pixel moves when its grey level is not the
    /// model's.
    Background,
}

impl Default for MovingConfig {
    fn default() -> Self {
        Self {
            work_side: 240,
            threshold: 18.0,
            alpha: 0.1,
            foreground_alpha: 0.02,
            min_age: 3,
            min_inliers: 12,
            min_inlier_ratio: 0.2,
            max_foreground: 0.5,
            min_blob: 0.002,
            max_blobs: 4,
            box_margin: 0.1,
            close_radius: 2,
            refine: Some(RefineConfig::default()),
            tolerance: 1,
            ghost_frames: 8,
            cue: MotionCue::Flow,
            flow: FlowConfig::default(),
            min_residual: 0.5,
            residual_factor: 4.0,
        }
    }
}

impl MovingConfig {
    /// Checks every setting.
    pub fn validate(&self) -> Result<(), DetectError> {
        let bad = |field: &'static str, value: f64, reason: &'static str| {
            Err(DetectError::InvalidConfig {
                field,
                value,
                reason,
            })
        };
        if !(32..=2048).contains(&self.work_side) {
            return bad("work_side", self.work_side as f64, "must be in 32..=2048");
        }
        if !(self.threshold.is_finite() && (0.0..255.0).contains(&self.threshold)) {
            return bad("threshold", self.threshold as f64, "must be in [0, 255)");
        }
        if self.ghost_frames > 255 {
            return bad(
                "ghost_frames",
                self.ghost_frames as f64,
                "must be at most 255",
            );
        }
        if self.tolerance > 8 {
            return bad("tolerance", self.tolerance as f64, "must be at most 8");
        }
        let unit = |v: f32| v.is_finite() && (0.0..=1.0).contains(&v);
        if !unit(self.alpha) || self.alpha == 0.0 {
            return bad("alpha", self.alpha as f64, "must be in (0, 1]");
        }
        if !unit(self.foreground_alpha) {
            return bad(
                "foreground_alpha",
                self.foreground_alpha as f64,
                "must be in [0, 1]",
            );
        }
        if self.min_age > 255 {
            return bad("min_age", self.min_age as f64, "must be at most 255");
        }
        if self.min_inliers < 3 {
            return bad("min_inliers", self.min_inliers as f64, "must be at least 3");
        }
        for (f, v) in [
            ("min_inlier_ratio", self.min_inlier_ratio),
            ("max_foreground", self.max_foreground),
            ("min_blob", self.min_blob),
            ("box_margin", self.box_margin),
        ] {
            if !(v.is_finite() && (0.0..=1.0).contains(&v)) {
                return bad(f, v, "must be in [0, 1]");
            }
        }
        if self.close_radius > 16 {
            return bad(
                "close_radius",
                self.close_radius as f64,
                "must be at most 16",
            );
        }
        if let Some(r) = &self.refine {
            r.validate()?;
        }
        if let Err((field, value, reason)) = self.flow.check() {
            return bad(field, value, reason);
        }
        for (f, v) in [
            ("min_residual", self.min_residual),
            ("residual_factor", self.residual_factor),
        ] {
            if !(v.is_finite() && (0.0..=100.0).contains(&v)) {
                return bad(f, v as f64, "must be in [0, 100]");
            }
        }
        Ok(())
    }
}

/// A grey image at working resolution.
#[derive(Debug, Clone, Default)]
struct Gray {
    w: usize,
    h: usize,
    v: Vec<f32>,
}

impl Gray {
    fn at(&self, x: usize, y: usize) -> f32 {
        self.v[y * self.w + x]
    }

    /// Bilinear sample; `None` outside.
    fn sample(&self, x: f64, y: f64) -> Option<f32> {
        if !(x >= 0.0 && y >= 0.0 && x <= (self.w - 1) as f64 && y <= (self.h - 1) as f64) {
            return None;
        }
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(self.w - 1), (y0 + 1).min(self.h - 1));
        let (tx, ty) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
        let a = self.at(x0, y0) * (1.0 - tx) + self.at(x1, y0) * tx;
        let b = self.at(x0, y1) * (1.0 - tx) + self.at(x1, y1) * tx;
        Some(a * (1.0 - ty) + b * ty)
    }

    /// Area-averaged by an integer factor.
    fn shrink(&self, f: usize) -> Gray {
        let (w, h) = ((self.w / f).max(1), (self.h / f).max(1));
        let mut v = vec![0f32; w * h];
        let k = 1.0 / (f * f) as f32;
        for y in 0..h {
            for x in 0..w {
                let mut s = 0.0;
                for yy in y * f..(y * f + f).min(self.h) {
                    for xx in x * f..(x * f + f).min(self.w) {
                        s += self.at(xx, yy);
                    }
                }
                v[y * w + x] = s * k;
            }
        }
        Gray { w, h, v }
    }
}

/// The frame's grey levels area-averaged down by `scale` (BT.601 luma).
fn downscale(frame: &Frame, scale: usize) -> Gray {
    let (fw, fh) = (frame.width() as usize, frame.height() as usize);
    let (w, h) = ((fw / scale).max(1), (fh / scale).max(1));
    let mut v = vec![0f32; w * h];
    let c = frame.format().channels();
    let data = frame.data();
    let k = 1.0 / (scale * scale) as f32;
    for y in 0..h {
        for yy in y * scale..(y * scale + scale).min(fh) {
            let row = &data[yy * frame.stride()..yy * frame.stride() + fw * c];
            for x in 0..w {
                let mut s = 0.0;
                for xx in x * scale..(x * scale + scale).min(fw) {
                    let p = &row[xx * c..xx * c + 3];
                    s += 0.299 * p[0] as f32 + 0.587 * p[1] as f32 + 0.114 * p[2] as f32;
                }
                v[y * w + x] += s * k;
            }
        }
    }
    Gray { w, h, v }
}

/// A camera motion between two working frames and how much to trust it.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraMotion {
    /// Maps previous-frame to current-frame working coordinates.
    pub transform: Transform,
    /// Matches tried.
    pub matches: usize,
    /// RANSAC inliers.
    pub inliers: usize,
    /// Largest displacement of a working-frame corner under `transform`, in working pixels.
    pub displacement: f64,
}

/// Grid step (working pixels) of the flow samples the camera motion is fitted to: ~1,600
/// samples on 213×120.
const FLOW_GRID: usize = 4;

/// `[a, b, c, d, e, f]` of an affine (or simpler) transform: `(x, y)` ↦ `(a·x + b·y + c,
/// d·x + e·y + f)`.
fn affine_coefficients(t: &Transform) -> [f64; 6] {
    let o = t.apply(Point::new(0.0, 0.0));
    let ex = t.apply(Point::new(1.0, 0.0));
    let ey = t.apply(Point::new(0.0, 1.0));
    [ex.x - o.x, ey.x - o.x, o.x, ex.y - o.y, ey.y - o.y, o.y]
}

/// Histogram bins per working pixel of residual, for [`median_residual`].
const RESIDUAL_BINS_PER_PX: f32 = 64.0;
/// Residuals past this many working pixels share the histogram's last bin.
const RESIDUAL_RANGE_PX: f32 = 16.0;

/// The median of `r` (non-negative residuals) to 1/64 of a working pixel, from a histogram:
/// a linear pass (a selection would reorder a copy), and medians above 16 px mean a failed
/// compensation anyway.
fn median_residual(r: &[f32], bins: &mut Vec<u32>) -> f32 {
    let n = (RESIDUAL_BINS_PER_PX * RESIDUAL_RANGE_PX) as usize;
    bins.clear();
    bins.resize(n + 1, 0);
    for &v in r {
        // `as usize` saturates: NaN → 0, beyond the range → the last bin.
        let b = ((v * RESIDUAL_BINS_PER_PX) as usize).min(n);
        bins[b] += 1;
    }
    let half = r.len().div_ceil(2) as u64;
    let mut seen = 0u64;
    for (b, &c) in bins.iter().enumerate() {
        seen += c as u64;
        if seen >= half {
            return (b as f32 + 0.5) / RESIDUAL_BINS_PER_PX;
        }
    }
    RESIDUAL_RANGE_PX
}

/// Patch radius of the point matcher (7×7 patches).
const PATCH: isize = 3;
/// Local search radius around the globally shifted position (working pixels).
const LOCAL: isize = 3;
/// Global shift search radius at half the working size (±12 → ±24 working pixels).
const GLOBAL: isize = 12;
/// Grid cell of the corner picker (working pixels): ~100 points on 214×120.
const CELL: usize = 16;

/// Normalised distance of `(x, y)` from the centre of a `w × h` frame: 0 at the centre, 1 on
/// the border (the larger of the two axes' ratios).
fn periphery(x: f64, y: f64, w: usize, h: usize) -> f64 {
    let (cx, cy) = (0.5 * w as f64, 0.5 * h as f64);
    ((x - cx).abs() / cx).max((y - cy).abs() / cy).min(1.0)
}

/// Pixels at least this far out ([`periphery`]) decide the global shift: the camera motion is
/// the motion of the frame's surroundings. A camera that follows an object keeps it near the
/// centre, where its own motion (near zero in the image) would otherwise win the match.
const PERIPHERY_BAND: f64 = 0.5;

/// Sum of absolute differences of `a` shifted by `(dx, dy)` against `b` over the outer band of
/// the central region (a mean, so shifts that see different overlaps compare fairly).
fn global_shift(a: &Gray, b: &Gray) -> (isize, isize) {
    let m = GLOBAL as usize;
    if a.w <= 2 * m + 4 || a.h <= 2 * m + 4 {
        return (0, 0);
    }
    let band: Vec<Vec<bool>> = (m..a.h - m)
        .map(|y| {
            (m..a.w - m)
                .map(|x| periphery(x as f64, y as f64, a.w, a.h) >= PERIPHERY_BAND)
                .collect()
        })
        .collect();
    let mut best = ((0, 0), f32::INFINITY);
    for dy in -GLOBAL..=GLOBAL {
        for dx in -GLOBAL..=GLOBAL {
            let mut s = 0.0;
            for (j, y) in (m..a.h - m).enumerate() {
                let yb = (y as isize + dy) as usize;
                for (i, x) in (m..a.w - m).enumerate() {
                    if band[j][i] {
                        s += (a.at(x, y) - b.at((x as isize + dx) as usize, yb)).abs();
                    }
                }
            }
            // A slight preference for small shifts breaks ties on flat frames.
            let s = s * (1.0 + 0.002 * (dx.abs() + dy.abs()) as f32);
            if s < best.1 {
                best = ((dx, dy), s);
            }
        }
    }
    best.0
}

/// Corner points of `g`: the strongest Shi–Tomasi response of each grid cell, when strong.
fn corners(g: &Gray) -> Vec<(usize, usize)> {
    let b = (PATCH + LOCAL + 2) as usize;
    let mut out = Vec::new();
    if g.w <= 2 * b || g.h <= 2 * b {
        return out;
    }
    let mut cy = b;
    while cy < g.h - b {
        let mut cx = b;
        while cx < g.w - b {
            let mut best = (0usize, 0usize, 0f32);
            for y in cy..(cy + CELL).min(g.h - b) {
                for x in cx..(cx + CELL).min(g.w - b) {
                    let (mut sxx, mut syy, mut sxy) = (0f32, 0f32, 0f32);
                    for yy in y - 2..=y + 2 {
                        for xx in x - 2..=x + 2 {
                            let gx = g.at(xx + 1, yy) - g.at(xx - 1, yy);
                            let gy = g.at(xx, yy + 1) - g.at(xx, yy - 1);
                            sxx += gx * gx;
                            syy += gy * gy;
                            sxy += gx * gy;
                        }
                    }
                    let tr = 0.5 * (sxx + syy);
                    let det = ((0.5 * (sxx - syy)).powi(2) + sxy * sxy).sqrt();
                    let lmin = tr - det;
                    if lmin > best.2 {
                        best = (x, y, lmin);
                    }
                }
            }
            // Minimum eigenvalue of the 5×5 structure tensor: ~25·(4 grey levels)² means a
            // real corner, not JPEG noise on a flat wall.
            if best.2 > 400.0 {
                out.push((best.0, best.1));
            }
            cx += CELL;
        }
        cy += CELL;
    }
    out
}

fn ssd(a: &Gray, ax: usize, ay: usize, b: &Gray, bx: usize, by: usize) -> f32 {
    let mut s = 0.0;
    for dy in -PATCH..=PATCH {
        for dx in -PATCH..=PATCH {
            let d = a.at((ax as isize + dx) as usize, (ay as isize + dy) as usize)
                - b.at((bx as isize + dx) as usize, (by as isize + dy) as usize);
            s += d * d;
        }
    }
    s
}

/// Largest displacement under `t` of a corner of a `w × h` frame ([`CameraMotion`]'s).
fn corner_displacement(t: &Transform, w: usize, h: usize) -> f64 {
    let (w, h) = (w as f64, h as f64);
    [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)]
        .iter()
        .map(|&(x, y)| {
            let p = Point::new(x, y);
            t.apply(p).dist(p)
        })
        .fold(0.0, f64::max)
}

/// Estimates the camera motion from `prev` to `cur` (working frames of equal size).
fn estimate_motion(prev: &Gray, cur: &Gray, seed: u64) -> Option<CameraMotion> {
    let (gx, gy) = global_shift(&prev.shrink(2), &cur.shrink(2));
    let (gx, gy) = (2 * gx, 2 * gy);
    let mut matches = Vec::new();
    let lo = PATCH + 1;
    for (x, y) in corners(prev) {
        let (px, py) = (x as isize + gx, y as isize + gy);
        let mut best = (0isize, 0isize, f32::INFINITY);
        let mut costs = [[f32::INFINITY; (2 * LOCAL + 1) as usize]; (2 * LOCAL + 1) as usize];
        for dy in -LOCAL..=LOCAL {
            for dx in -LOCAL..=LOCAL {
                let (qx, qy) = (px + dx, py + dy);
                if qx < lo || qy < lo || qx >= cur.w as isize - lo || qy >= cur.h as isize - lo {
                    continue;
                }
                let c = ssd(prev, x, y, cur, qx as usize, qy as usize);
                costs[(dy + LOCAL) as usize][(dx + LOCAL) as usize] = c;
                if c < best.2 {
                    best = (dx, dy, c);
                }
            }
        }
        if !best.2.is_finite() {
            continue;
        }
        // Sub-pixel: a parabola through the best cost and its neighbours, per axis.
        let sub = |m: f32, c: f32, p: f32| {
            let den = m - 2.0 * c + p;
            if m.is_finite() && p.is_finite() && den > 1e-6 {
                (0.5 * (m - p) / den).clamp(-0.5, 0.5)
            } else {
                0.0
            }
        };
        let (bi, bj) = ((best.0 + LOCAL) as usize, (best.1 + LOCAL) as usize);
        let at = |i: isize, j: isize| {
            if i < 0 || j < 0 || i > 2 * LOCAL || j > 2 * LOCAL {
                f32::INFINITY
            } else {
                costs[j as usize][i as usize]
            }
        };
        let sx = sub(
            at(bi as isize - 1, bj as isize),
            best.2,
            at(bi as isize + 1, bj as isize),
        );
        let sy = sub(
            at(bi as isize, bj as isize - 1),
            best.2,
            at(bi as isize, bj as isize + 1),
        );
        let q = Point::new(
            (px + best.0) as f64 + sx as f64,
            (py + best.1) as f64 + sy as f64,
        );
        matches.push((Point::new(x as f64, y as f64), q));
    }
    if matches.len() < 3 {
        return None;
    }
    let fit = ransac(
        TransformKind::Affine,
        &matches,
        &RansacConfig {
            threshold: 1.0,
            max_iterations: 300,
            seed,
            ..RansacConfig::default()
        },
    )
    .ok()?;
    let t = fit.transform;
    Some(CameraMotion {
        transform: t,
        matches: matches.len(),
        inliers: fit.inliers.len(),
        displacement: corner_displacement(&t, prev.w, prev.h),
    })
}

/// Camera-motion-compensated background subtraction (see the module docs).
#[derive(Debug, Clone)]
pub struct MovingCameraDetector {
    cfg: MovingConfig,
    size: Option<(u32, u32)>,
    scale: usize,
    prev: Option<Gray>,
    bg: Vec<f32>,
    age: Vec<u8>,
    /// Candidate background per pixel: the steady colour a foreground pixel has shown, and
    /// for how many frames in a row (0 = none).
    cand: Vec<f32>,
    cand_age: Vec<u8>,
    fg: Vec<u8>,
    last_motion: Option<CameraMotion>,
    resets: u64,
    frames: u64,
    /// Frames in the model since it last started learning (the first frame, a reset or a
    /// re-initialisation counts 1).
    history: u32,
    morph: Morphology,
    comps: Components,
    flow: DenseFlow,
    field: FlowField,
    /// Per working pixel, how far its flow is from the camera's (working pixels).
    residual: Vec<f32>,
    /// The residuals' histogram (for their median) and one blob's hint bitmap.
    bins: Vec<u32>,
    hint: Vec<u8>,
}

impl MovingCameraDetector {
    /// A detector with validated settings; buffers are sized on the first frame.
    pub fn new(cfg: MovingConfig) -> Result<Self, DetectError> {
        cfg.validate()?;
        Ok(Self {
            flow: DenseFlow::new(cfg.flow.clone()),
            field: FlowField::default(),
            residual: Vec::new(),
            bins: Vec::new(),
            hint: Vec::new(),
            cfg,
            size: None,
            scale: 1,
            prev: None,
            bg: Vec::new(),
            age: Vec::new(),
            cand: Vec::new(),
            cand_age: Vec::new(),
            fg: Vec::new(),
            last_motion: None,
            resets: 0,
            frames: 0,
            history: 0,
            morph: Morphology::new(),
            comps: Components::new(),
        })
    }

    /// The camera motion found for the last frame (`None` on the first frame and after a
    /// failed estimate).
    pub fn last_motion(&self) -> Option<&CameraMotion> {
        self.last_motion.as_ref()
    }

    /// How often the model was re-initialised because the compensation failed.
    pub fn resets(&self) -> u64 {
        self.resets
    }

    /// The working scale: one working pixel covers `scale × scale` frame pixels.
    pub fn scale(&self) -> usize {
        self.scale
    }

    /// The foreground bitmap of the last frame at working resolution (0/1) and its size.
    pub fn foreground(&self) -> (&[u8], usize, usize) {
        let (w, h) = self.prev.as_ref().map_or((0, 0), |g| (g.w, g.h));
        (&self.fg, w, h)
    }

    /// How far the model has learnt: `(frames of history, frames needed)`. Nothing is
    /// detected until the first equals the second, after the first frame and again after
    /// each re-initialisation (a cut, a motion the estimate could not follow). The flow cue
    /// needs one earlier frame (1); the background cue `min_age` frames of history.
    pub fn warmup(&self) -> (u32, u32) {
        // The background model needs `min_age` frames of history; the flow one earlier frame.
        let needed = match self.cfg.cue {
            MotionCue::Flow => 1,
            MotionCue::Background => self.cfg.min_age.max(1),
        };
        (self.history.min(needed), needed)
    }

    /// Forgets everything, including the frame size.
    pub fn reset(&mut self) {
        self.size = None;
        self.prev = None;
        self.last_motion = None;
        self.history = 0;
    }

    fn reinit(&mut self, cur: &Gray) {
        self.history = 1;
        self.bg.clear();
        self.bg.extend_from_slice(&cur.v);
        self.age.clear();
        self.age.resize(cur.v.len(), 1);
        self.cand.clear();
        self.cand.resize(cur.v.len(), 0.0);
        self.cand_age.clear();
        self.cand_age.resize(cur.v.len(), 0);
        self.fg.clear();
        self.fg.resize(cur.v.len(), 0);
    }

    /// [`MotionCue::Flow`]: the working foreground of `cur` from the dense flow to the
    /// previous frame; `false` when nothing may be reported.
    fn update_flow(&mut self, cur: &Gray) -> bool {
        let Some(prev) = self.prev.take() else {
            self.history = 1;
            return false;
        };
        self.frames += 1;
        let (w, h) = (cur.w, cur.h);
        // The camera motion from sparse corner matches first (a global shift over the frame's
        // outer band, then matches around it): the flow starts from it, so that on fine
        // repetitive texture its coarse-to-fine search does not settle a period off.
        let guess = estimate_motion(&prev, cur, self.frames)
            .filter(|m| m.inliers >= self.cfg.min_inliers)
            .and_then(|m| m.transform.inverse().ok())
            .map(|t| affine_coefficients(&t));
        // Flow from the current frame back to the previous one: the residual is then defined
        // on the current frame's pixels, whose mask is wanted.
        self.flow
            .compute_guided(&cur.v, &prev.v, w, h, guess, &mut self.field);
        let (fu, fv) = (&self.field.u, &self.field.v);
        // The camera's motion: an affine fit to the flow on a grid of pixels, by RANSAC. The
        // moving objects are the outliers (a minority of the frame, or the fit fails below).
        let mut matches = Vec::with_capacity((w / FLOW_GRID + 1) * (h / FLOW_GRID + 1));
        for y in (FLOW_GRID / 2..h).step_by(FLOW_GRID) {
            for x in (FLOW_GRID / 2..w).step_by(FLOW_GRID) {
                let i = y * w + x;
                let p = Point::new(x as f64, y as f64);
                matches.push((p, Point::new(p.x + fu[i] as f64, p.y + fv[i] as f64)));
            }
        }
        let fit = (matches.len() >= 3)
            .then(|| {
                ransac(
                    TransformKind::Affine,
                    &matches,
                    &RansacConfig {
                        threshold: 1.0,
                        max_iterations: 300,
                        seed: self.frames,
                        ..RansacConfig::default()
                    },
                )
                .ok()
            })
            .flatten();
        let trusted = fit.as_ref().is_some_and(|f| {
            f.inliers.len() >= self.cfg.min_inliers
                && f.inliers.len() as f64 >= self.cfg.min_inlier_ratio * matches.len() as f64
                && (f.transform.scale() - 1.0).abs() < 0.2
        });
        // `CameraMotion` maps previous to current coordinates: the inverse of the fit.
        let motion = fit
            .as_ref()
            .filter(|_| trusted)
            .and_then(|f| Some((f, f.transform.inverse().ok()?)));
        self.last_motion = motion.as_ref().map(|(f, inv)| CameraMotion {
            transform: *inv,
            matches: matches.len(),
            inliers: f.inliers.len(),
            displacement: corner_displacement(inv, w, h),
        });
        let Some((fit, _)) = motion else {
            // A cut, a blur, a frame the affine motion cannot explain: nothing this frame,
            // and the next frame is compared with this one.
            self.resets += 1;
            self.history = 1;
            return false;
        };
        let t = &fit.transform;
        let m = (self.cfg.flow.patch_size / 2) as f64;
        self.residual.clear();
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let c = t.apply(Point::new(x as f64, y as f64));
                // A pixel the camera brought into view has no earlier self to move from: its
                // flow is the search's guess, not a measurement; nor has one whose patch
                // reached past the previous frame's border (half a patch in from it).
                let seen =
                    c.x >= m && c.y >= m && c.x <= w as f64 - 1.0 - m && c.y <= h as f64 - 1.0 - m;
                let (dx, dy) = (x as f64 + fu[i] as f64 - c.x, y as f64 + fv[i] as f64 - c.y);
                // `sqrt`, not `hypot`: IEEE-exact, so native and wasm builds agree bit for bit.
                self.residual.push(if seen {
                    (dx * dx + dy * dy).sqrt() as f32
                } else {
                    0.0
                });
            }
        }
        // The threshold adapts to the video: its median residual is flow noise plus the
        // parallax an affine motion leaves, which a moving object must exceed by a margin.
        let thr = self
            .cfg
            .min_residual
            .max(self.cfg.residual_factor * median_residual(&self.residual, &mut self.bins));
        self.fg.clear();
        self.fg
            .extend(self.residual.iter().map(|&r| (r > thr) as u8));
        let moving = self.fg.iter().filter(|&&b| b != 0).count();
        self.history = self.history.saturating_add(1);
        // Most of the frame "moving" is a failed compensation (a zoom, strong parallax).
        if moving as f64 > self.cfg.max_foreground * (w * h) as f64 {
            self.resets += 1;
            return false;
        }
        true
    }

    /// Steps 1–5: the working foreground of `cur`; `false` when nothing may be reported.
    fn update_model(&mut self, cur: &Gray) -> bool {
        if self.cfg.cue == MotionCue::Flow {
            return self.update_flow(cur);
        }
        let Some(prev) = self.prev.take() else {
            self.reinit(cur);
            return false;
        };
        self.frames += 1;
        let motion = estimate_motion(&prev, cur, self.frames);
        let trusted = motion.as_ref().is_some_and(|m| {
            m.inliers >= self.cfg.min_inliers
                && m.inliers as f64 >= self.cfg.min_inlier_ratio * m.matches as f64
                && (m.transform.scale() - 1.0).abs() < 0.2
        });
        self.last_motion = motion.filter(|_| trusted);
        let Some(inv) = self
            .last_motion
            .as_ref()
            .and_then(|m| m.transform.inverse().ok())
        else {
            self.resets += 1;
            self.reinit(cur);
            return false;
        };
        // Step 3: warp model and ages into the current frame.
        let (w, h) = (cur.w, cur.h);
        let old = Gray {
            w,
            h,
            v: std::mem::take(&mut self.bg),
        };
        let old_age = std::mem::take(&mut self.age);
        let old_cand = Gray {
            w,
            h,
            v: std::mem::take(&mut self.cand),
        };
        let old_cand_age = std::mem::take(&mut self.cand_age);
        let mut bg = vec![0f32; w * h];
        let mut age = vec![0u8; w * h];
        let mut cand = vec![0f32; w * h];
        let mut cand_age = vec![0u8; w * h];
        for y in 0..h {
            for x in 0..w {
                let q = inv.apply(Point::new(x as f64, y as f64));
                let i = y * w + x;
                if let Some(v) = old.sample(q.x, q.y) {
                    bg[i] = v;
                    let (qx, qy) = (q.x.round() as usize, q.y.round() as usize);
                    let o = qy.min(h - 1) * w + qx.min(w - 1);
                    age[i] = old_age[o];
                    cand_age[i] = old_cand_age[o];
                    cand[i] = old_cand.sample(q.x, q.y).unwrap_or(v);
                } else {
                    bg[i] = cur.v[i];
                }
            }
        }
        // Step 4: classify and learn.
        let (t, min_age) = (self.cfg.threshold, self.cfg.min_age.max(1) as u8);
        let ghost = self.cfg.ghost_frames.min(255) as u8;
        let mut with_history = 0usize;
        let mut fg_count = 0usize;
        self.fg.clear();
        self.fg.resize(w * h, 0);
        // The warped model is resampled every frame and the affine fit misses parallax, so
        // it sits up to about a working pixel off the frame: on an edge that alone makes a
        // difference of gradient × offset, which is not motion.
        let r = self.cfg.tolerance as usize;
        // Smallest difference between `a`'s pixel `i` and `b` within the tolerance radius.
        let near = |a: &[f32], b: &[f32], i: usize| {
            let (x, y) = (i % w, i / w);
            let mut d = f32::INFINITY;
            for yy in y.saturating_sub(r)..(y + r + 1).min(h) {
                for xx in x.saturating_sub(r)..(x + r + 1).min(w) {
                    d = d.min((a[i] - b[yy * w + xx]).abs());
                }
            }
            d
        };
        for i in 0..w * h {
            let z = cur.v[i];
            // A misregistration explains a difference when the frame's pixel is found in
            // the model nearby and the model's pixel in the frame nearby. An object's flat
            // colour over a textured background (or the texture it uncovers, where the model
            // still holds the object) passes only one of the two.
            let grown = age[i] >= min_age;
            // Pixels without history cannot be foreground: skip their neighbourhood search.
            let mut f = grown && near(&cur.v, &bg, i).max(near(&bg, &cur.v, i)) > t;
            // Ghosts: where the model still holds an object that has left (the first
            // frames, or an object that stood still), the frame shows the uncovered
            // background, which is steady in the scene. A foreground pixel that keeps one
            // colour for `ghost_frames` frames has that colour taken as its background.
            if f && ghost > 0 {
                if cand_age[i] > 0 && (z - cand[i]).abs() <= t {
                    cand_age[i] = cand_age[i].saturating_add(1);
                    cand[i] += (z - cand[i]) / cand_age[i] as f32;
                } else {
                    cand[i] = z;
                    cand_age[i] = 1;
                }
                if cand_age[i] >= ghost {
                    bg[i] = cand[i];
                    cand_age[i] = 0;
                    f = false;
                }
            } else {
                cand_age[i] = 0;
            }
            with_history += grown as usize;
            fg_count += f as usize;
            self.fg[i] = f as u8;
            let a = if f {
                self.cfg.foreground_alpha
            } else {
                self.cfg.alpha.max(1.0 / (age[i] as f32 + 1.0))
            };
            bg[i] += a * (z - bg[i]);
            age[i] = age[i].saturating_add(1);
        }
        self.bg = bg;
        self.age = age;
        self.cand = cand;
        self.cand_age = cand_age;
        self.history = self.history.saturating_add(1);
        // Step 5: a foreground over most of the frame is a failed compensation.
        if with_history > 0 && fg_count as f64 > self.cfg.max_foreground * with_history as f64 {
            self.resets += 1;
            self.reinit(cur);
            return false;
        }
        with_history > 0
    }
}

impl Detector for MovingCameraDetector {
    fn detect(&mut self, frame: &Frame) -> Result<Vec<Detection>, DetectError> {
        let (fw, fh) = (frame.width(), frame.height());
        match self.size {
            Some((ew, eh)) if (ew, eh) != (fw, fh) => {
                return Err(DetectError::SizeChanged {
                    expected_width: ew,
                    expected_height: eh,
                    width: fw,
                    height: fh,
                })
            }
            Some(_) => {}
            None => {
                self.size = Some((fw, fh));
                self.scale = (fw.max(fh) as usize).div_ceil(self.cfg.work_side as usize);
                self.scale = self.scale.max(1);
                self.prev = None;
            }
        }
        let cur = downscale(frame, self.scale);
        let ok = self.update_model(&cur);
        let (w, h) = (cur.w, cur.h);
        self.prev = Some(cur);
        if !ok {
            return Ok(Vec::new());
        }
        // Step 6: blobs → boxes → masks.
        self.morph.open(&mut self.fg, w, h, 1);
        self.morph.close(&mut self.fg, w, h, self.cfg.close_radius);
        let blobs = self
            .comps
            .label(&self.fg, w as u32, h as u32, Connectivity::Eight)?
            .to_vec();
        let min_area = (self.cfg.min_blob * (w * h) as f64).max(4.0);
        let mut order: Vec<usize> = (0..blobs.len())
            .filter(|&i| blobs[i].area as f64 >= min_area)
            .collect();
        order.sort_by(|&a, &b| blobs[b].area.cmp(&blobs[a].area));
        order.truncate(self.cfg.max_blobs);
        let s = self.scale as f64;
        let mut out = Vec::new();
        for i in order {
            let b = blobs[i].bbox();
            let score = (blobs[i].area as f64 / (b.w * b.h).max(1.0)).clamp(1e-3, 1.0);
            let (mx, my) = (b.w * s * self.cfg.box_margin, b.h * s * self.cfg.box_margin);
            let fb = BBox::from_xyxy(
                (b.x * s - mx).max(0.0),
                (b.y * s - my).max(0.0),
                ((b.x + b.w) * s + mx).min(fw as f64),
                ((b.y + b.h) * s + my).min(fh as f64),
            );
            let mask = match &self.cfg.refine {
                Some(r) => {
                    // The blob's own pixels tell the refinement where the object is.
                    self.hint.clear();
                    self.hint.resize(w * h, 0);
                    for run in self.comps.runs(i) {
                        let row = run.y as usize * w;
                        self.hint[row + run.x0 as usize..row + run.x1 as usize].fill(1);
                    }
                    let hint = Hint {
                        bits: &self.hint,
                        width: w,
                        height: h,
                        scale: s,
                    };
                    refine_box_hinted(frame, &fb, r, Some(hint))?
                }
                None => self.comps.mask(i).map(|m| upscale(&m, self.scale, fw, fh)),
            };
            if let Some(m) = mask.filter(|m| !m.is_empty()) {
                out.push(Detection::from_mask(m, score));
            }
        }
        Ok(out)
    }
}

/// A working-resolution mask blown up to frame pixels.
fn upscale(m: &Mask, s: usize, fw: u32, fh: u32) -> Mask {
    let (w, h) = (m.width() as usize * s, m.height() as usize * s);
    let mut data = vec![0u8; w * h];
    for y in 0..h {
        for x in 0..w {
            data[y * w + x] = m.get(m.x() + (x / s) as i32, m.y() + (y / s) as i32) as u8;
        }
    }
    Mask::new(m.x() * s as i32, m.y() * s as i32, w as u32, h as u32, data)
        .map(|m| m.clipped(fw, fh))
        .unwrap_or_else(|_| Mask::empty())
}

/// Whether a camera moves, judged from the motion between consecutive frames: the median
/// corner displacement, in frame pixels per frame, over the frames given. A static camera
/// measures well under a pixel (JPEG noise, a flickering light); a hand-held one several.
#[derive(Debug, Clone, Default)]
pub struct CameraJudge {
    prev: Option<Gray>,
    scale: usize,
    displacements: Vec<f64>,
}

/// Median displacement (frame pixels per frame) above which the camera counts as moving.
pub const MOVING_CAMERA_PX: f64 = 1.0;

impl CameraJudge {
    /// A judge with no frames yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Looks at the next frame. Frames of another size than the first are ignored.
    pub fn observe(&mut self, frame: &Frame) {
        if self.prev.is_none() {
            self.scale = (frame.width().max(frame.height()) as usize)
                .div_ceil(240)
                .max(1);
        }
        let cur = downscale(frame, self.scale);
        if let Some(p) = &self.prev {
            if (p.w, p.h) != (cur.w, cur.h) {
                return;
            }
            let d = estimate_motion(p, &cur, 1)
                .filter(|m| m.inliers >= 8)
                // An unreliable estimate says "something moves": a static camera gives clean
                // matches on its texture.
                .map_or(f64::INFINITY, |m| m.displacement * self.scale as f64);
            self.displacements.push(d);
        }
        self.prev = Some(cur);
    }

    /// Frame pairs measured so far.
    pub fn pairs(&self) -> usize {
        self.displacements.len()
    }

    /// Whether the camera moves (`None` before the first pair).
    pub fn moving(&self) -> Option<bool> {
        if self.displacements.is_empty() {
            return None;
        }
        let mut d = self.displacements.clone();
        d.sort_by(f64::total_cmp);
        Some(d[d.len() / 2] > MOVING_CAMERA_PX)
    }
}
