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

mod camera;
mod config;

use super::components::{Components, Connectivity};
use super::flow::{DenseFlow, FlowField};
use super::morphology::Morphology;
use super::refine::{refine_box_hinted, Hint};
use super::{DetectError, Detector};
use crate::features::transform::{ransac, RansacConfig, Transform, TransformKind};
use crate::frame::{BBox, Detection, Frame, Mask, Point};

use camera::{corner_displacement, downscale, estimate_motion, Gray};
pub use camera::{CameraJudge, CameraMotion, MOVING_CAMERA_PX};
pub use config::{MotionCue, MovingConfig};

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
