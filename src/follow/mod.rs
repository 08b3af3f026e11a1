//! Following one user-given target through frames, forward or backward, with or without a
//! detector (issue 12).
//!
//! Per frame, [`Follower::step`] runs these phases:
//!
//! 1. **predict**: the search region is the last mask's box moved by the last motion and grown
//!    (more while the target is lost);
//! 2. **match**: SIFT keypoints of the search region (bounded by [`FollowConfig::max_side`])
//!    against the target model's keypoints (those inside the mask at the last confident frame);
//! 3. **fit**: a similarity transform by RANSAC, model frame → this frame, or the predicted
//!    translation when too few matches agree, or when the fit's keypoints move with the
//!    background after the target had moved against it (a second fit, of the last frame's
//!    keypoints, gives the background's motion; see [`FollowConfig::background_lock`]);
//! 4. **warp**: the model mask moved by it;
//! 5. **refine**: pixels within a band around the warped outline relabelled by the colour model
//!    (target vs surrounding-background histograms) with the warped shape as a prior;
//! 6. **detections**: when a detection agrees with the result (mask IoU ≥
//!    [`FollowConfig::detection_iou`]), its mask is taken instead — a detector's outline is
//!    sharper than a warped one — but only its pixels within a band of the followed outline
//!    that the colour model does not hold background (a loose detection's shadow stays out);
//! 7. **judge**: a confidence from the RANSAC consensus and how far colour had to move the
//!    outline; low confidence marks the frame lost (the model is then not updated) and
//!    [`FollowConfig::max_lost`] lost frames in a row stop the follower.
//!
//! Everything is single-threaded and allocation-bounded by the crop sizes, so it runs the same
//! in wasm. [`interpolate`] morphs one keyframe mask into another along matched outlines.

mod colour;
mod config;
pub mod interpolate;
mod sequence;
mod warp;

pub use config::{FollowConfig, FollowError};
pub use interpolate::{interpolate_masks, InterpolateError};
pub use sequence::{follow_sequence, follow_sequence_with_net, mask_from_bitmap};
use warp::within_reach;
pub use warp::{rasterize_polygon, warp_mask};

use serde::{Deserialize, Serialize};

use crate::features::sift::{self, Keypoint, MatchConfig, SiftFeatures};
use crate::features::transform::{
    ransac, RansacConfig, RansacFit, Transform, TransformKind, Translation,
};
use crate::frame::{BBox, Detection, Frame, Mask, Point};
use crate::segment::{input_tensor, Crop, Net, Saliency};
use colour::{ColourModel, RefineParams, Ring};

/// The follower's result for one frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FollowStep {
    /// The target's mask in this frame (empty once stopped).
    pub mask: Mask,
    /// Confidence in `[0, 1]`.
    pub confidence: f64,
    /// The target was not found confidently in this frame (the mask is a prediction).
    pub lost: bool,
    /// The follower has given up (too many lost frames in a row); it outputs nothing more.
    pub stopped: bool,
    /// RANSAC inliers of the fitted transform (0 when none was fitted).
    pub inliers: usize,
    /// A detection's mask was taken for this frame.
    pub from_detection: bool,
    /// The learned segmentation's mask was taken for this frame.
    #[serde(default)]
    pub from_learned: bool,
}

/// What the follower knows of the target at its last confident frame.
#[derive(Debug, Clone)]
struct Model {
    mask: Mask,
    feats: SiftFeatures,
}

/// Follows one target from a mask given at one frame; feed it frames in the direction of
/// travel (forward or backward), one [`step`](Follower::step) per frame.
#[derive(Debug, Clone)]
pub struct Follower {
    cfg: FollowConfig,
    width: u32,
    height: u32,
    model: Model,
    colour: ColourModel,
    last: Mask,
    velocity: Point,
    lost_run: usize,
    stopped: bool,
    /// The last frame's keypoints of the search region (for the background's motion; kept
    /// only with [`FollowConfig::background_lock`]).
    background: SiftFeatures,
    /// The target's recent motion against the background, in pixels per frame (smoothed).
    relative: f64,
    /// The model (keypoints and mask) was taken from the last frame.
    model_fresh: bool,
}

fn sqrt_area(m: &Mask) -> f64 {
    (m.area() as f64).sqrt()
}

impl Follower {
    /// Starts from `mask` on `frame`. Errors: empty mask, mask outside the frame, bad config.
    pub fn new(frame: &Frame<'_>, mask: &Mask, cfg: FollowConfig) -> Result<Follower, FollowError> {
        cfg.validate()?;
        let (w, h) = (frame.width(), frame.height());
        let mask = mask.tight();
        if mask.is_empty() {
            return Err(FollowError::EmptyMask);
        }
        if mask.x() < 0
            || mask.y() < 0
            || mask.x() as i64 + mask.width() as i64 > w as i64
            || mask.y() as i64 + mask.height() as i64 > h as i64
        {
            return Err(FollowError::MaskOutside {
                width: w,
                height: h,
            });
        }
        let feats = model_features(frame, &mask, &cfg)?;
        let colour = ColourModel::learn(frame, &mask, &ring(&mask, &cfg), cfg.max_side);
        Ok(Follower {
            width: w,
            height: h,
            model: Model {
                mask: mask.clone(),
                feats,
            },
            colour,
            last: mask,
            velocity: Point::default(),
            lost_run: 0,
            stopped: false,
            background: SiftFeatures::default(),
            relative: 0.0,
            model_fresh: true,
            cfg,
        })
    }

    /// Starts from a full-frame bitmap (`mask_w × mask_h` bytes, non-zero = target), which
    /// must have the frame's size.
    pub fn from_bitmap(
        frame: &Frame<'_>,
        mask_w: u32,
        mask_h: u32,
        bitmap: &[u8],
        cfg: FollowConfig,
    ) -> Result<Follower, FollowError> {
        let mask = mask_from_bitmap(frame.width(), frame.height(), mask_w, mask_h, bitmap)?;
        Follower::new(frame, &mask, cfg)
    }

    /// Whether the follower has stopped.
    pub fn stopped(&self) -> bool {
        self.stopped
    }

    /// Its settings.
    pub fn config(&self) -> &FollowConfig {
        &self.cfg
    }

    /// Follows the target into the next frame (in the direction of travel). `detections` may
    /// be empty (no detector).
    pub fn step(
        &mut self,
        frame: &Frame<'_>,
        detections: &[Detection],
    ) -> Result<FollowStep, FollowError> {
        self.step_learned(frame, detections, None)
    }

    /// Where the target is expected in the next frame: the last outline's box moved by the
    /// last motion.
    fn predicted_box(&self) -> BBox {
        self.last
            .bbox()
            .translated(self.velocity.x, self.velocity.y)
    }

    /// The crop the learned segmentation should see for the next frame: the predicted box
    /// grown by the segmentation's margin, more while the target is lost. `None` once
    /// stopped.
    pub fn learned_crop(&self) -> Option<Crop> {
        if self.stopped {
            return None;
        }
        let b = self.predicted_box();
        let grow = 1.0 + 0.5 * self.lost_run as f64;
        Crop::around(
            &b,
            self.width,
            self.height,
            self.cfg.segment.margin * grow,
            self.cfg.segment.min_crop,
        )
    }

    /// [`Follower::step`] with the learned segmentation run by `net` on
    /// [`Follower::learned_crop`] (the synchronous case of [`Follower::step_learned`]).
    pub fn step_with_net(
        &mut self,
        frame: &Frame<'_>,
        detections: &[Detection],
        net: &mut dyn Net,
    ) -> Result<FollowStep, FollowError> {
        let sal = match self.learned_crop() {
            Some(crop) if (frame.width(), frame.height()) == (self.width, self.height) => {
                let mut input = vec![0f32; crate::segment::input_len(self.cfg.segment.side)];
                input_tensor(frame, &crop, &mut input)?;
                let out = net.run(&input)?;
                Some(Saliency::new(crop, &out, self.cfg.segment.stretch)?)
            }
            _ => None,
        };
        self.step_learned(frame, detections, sal.as_ref())
    }

    /// [`Follower::step`] with the learned segmentation's map of [`Follower::learned_crop`]
    /// for this frame (`None`: without).
    pub fn step_learned(
        &mut self,
        frame: &Frame<'_>,
        detections: &[Detection],
        learned: Option<&Saliency>,
    ) -> Result<FollowStep, FollowError> {
        if frame.width() != self.width || frame.height() != self.height {
            return Err(FollowError::FrameSize {
                index: 0,
                got_width: frame.width(),
                got_height: frame.height(),
                width: self.width,
                height: self.height,
            });
        }
        if self.stopped {
            return Ok(FollowStep {
                mask: Mask::empty(),
                confidence: 0.0,
                lost: true,
                stopped: true,
                inliers: 0,
                from_detection: false,
                from_learned: false,
            });
        }
        if let Some(sal) = learned {
            let c = sal.crop();
            if c.x as u64 + c.w as u64 > self.width as u64
                || c.y as u64 + c.h as u64 > self.height as u64
            {
                return Err(FollowError::InvalidConfig {
                    field: "learned",
                    reason: "the learned map's crop lies outside the frame",
                });
            }
        }
        let cfg = &self.cfg;

        // Predict: the search region.
        let last_box = self.last.bbox();
        let grow = 1.0 + 0.5 * self.lost_run as f64;
        let margin = cfg.search_margin * last_box.w.max(last_box.h) * grow
            + 8.0
            + self.velocity.x.abs().max(self.velocity.y.abs());
        let region = last_box
            .translated(self.velocity.x, self.velocity.y)
            .expanded(margin);
        let region = clip_box(&region, self.width, self.height);

        // Match and fit: model frame → this frame.
        let feats = match region {
            Some(r) => sift::detect_in_region(frame, &r, None, &cfg.sift())?,
            None => SiftFeatures::default(),
        };
        let downscale = region.map_or(1.0, |r| (r.w.max(r.h) / cfg.max_side as f64).max(1.0));
        let fit = self.fit(&feats, downscale);
        // A fit on the background: the target had moved against the background, and now the
        // fit's keypoints move with it (an occluder or the scene behind, taken into the model
        // while it crossed the outline, outvotes the target's own keypoints).
        let mut locked = false;
        // Twice the inlier threshold: slower relative motion is within the fits' noise.
        let floor = 2.0 * cfg.ransac_threshold * downscale;
        let moving = self.relative > floor;
        // The background's fit is needed only where a lock can be found or the relative
        // motion updated.
        let judged = match (cfg.background_lock, &fit) {
            (Some(share), Some(f)) if moving || self.model_fresh => Some((share, f)),
            _ => None,
        };
        if let Some((share, (t, inl))) = judged {
            if let Some((bg, on_bg)) = self.background_motion(&feats, downscale) {
                let on = inl.iter().filter(|(_, j)| on_bg[*j]).count() as f64;
                if moving && on >= share * inl.len() as f64 {
                    // Decays, so a target that has really stopped against the background is
                    // taken up again (after ~7 frames per halving of its speed).
                    self.relative *= 0.9;
                    locked = true;
                    // The model's keypoints that moved with the background are not the
                    // target's.
                    let drop: Vec<usize> = inl
                        .iter()
                        .filter(|(_, j)| on_bg[*j])
                        .map(|(i, _)| *i)
                        .collect();
                    self.model.feats = without(&self.model.feats, &drop);
                } else if self.model_fresh {
                    // Both fits map the last frame then: compare where they take its centre.
                    if let Some(cm) = self.model.mask.centroid() {
                        let d = t.apply(cm).dist2(bg.apply(cm)).sqrt();
                        self.relative = 0.7 * self.relative + 0.3 * d;
                    }
                }
            }
        }
        let fit = if locked { None } else { fit };

        // Warp.
        let (warped, inliers) = match &fit {
            Some((t, n)) => (
                warp_mask(&self.model.mask, t, self.width, self.height),
                n.len(),
            ),
            None => {
                let t = Transform::Translation(Translation {
                    dx: self.velocity.x,
                    dy: self.velocity.y,
                });
                (warp_mask(&self.last, &t, self.width, self.height), 0)
            }
        };

        // Refine by colour.
        let refined = if warped.is_empty() {
            warped.clone()
        } else {
            colour::refine(
                frame,
                &warped,
                &self.colour,
                &RefineParams {
                    band: band_px(&warped, cfg),
                    prior_weight: cfg.prior_weight,
                    max_side: cfg.max_side,
                    max_area_change: cfg.max_area_change,
                },
            )
        };
        // Colour that swallows or erases the target is a colour-model failure, not a shape
        // change: keep the warped mask then.
        let ratio = refined.area() as f64 / warped.area().max(1) as f64;
        let (mut mask, agreement) = if refined.is_empty() || !(0.5..=2.0).contains(&ratio) {
            (warped.clone(), 0.0)
        } else {
            let a = refined.iou(&warped);
            (refined, a)
        };

        let geo = (inliers as f64 / cfg.full_inliers as f64).min(1.0);
        let mut confidence = 0.5 * geo + 0.5 * agreement;
        if locked {
            // The fit found the background: the target is not where it says.
            confidence = confidence.min(0.99 * cfg.lost_confidence);
        }

        // The learned outline wins where it agrees with the followed one; where the follower
        // has lost its object, it re-anchors on a learned region near the prediction.
        let mut from_learned = false;
        // The follower's own estimate, kept for its state when a learned outline only shapes
        // the output (`learned_carry_iou`).
        let mut own_estimate: Option<(Mask, f64)> = None;
        if let Some(sal) =
            learned.filter(|_| cfg.learned_below >= 1.0 || confidence < cfg.learned_below)
        {
            let predicted = self.last.translated(
                self.velocity.x.round() as i32,
                self.velocity.y.round() as i32,
            );
            let cut = match cfg.learned_box_slack {
                Some(s) if !mask.is_empty() => {
                    let b = mask.bbox();
                    b.expanded(s * b.w.max(b.h))
                }
                _ => sal.crop().bbox(),
            };
            if let Some(region) = sal.mask(&cut, cfg.segment.threshold, cfg.segment.keep_fraction) {
                let own = agreeing_parts(&region, &mask);
                let iou = own.iou(&mask);
                let trusted = !mask.is_empty() && confidence >= cfg.lost_confidence;
                let kept = own.area() as f64 / mask.area().max(1) as f64;
                let added =
                    (own.area() - own.intersection(&mask)) as f64 / mask.area().max(1) as f64;
                if !own.is_empty()
                    && iou >= cfg.learned_iou
                    && kept >= 1.0 - cfg.learned_max_shrink
                    && added <= cfg.learned_max_growth
                {
                    let previous = std::mem::replace(&mut mask, own);
                    // The follower goes on from its own estimate unless the two agree
                    // closely, or its own estimate is unsure (its fit found almost nothing:
                    // it is only the last outline moved by the last motion).
                    if iou < cfg.learned_carry_iou && confidence >= cfg.learned_carry_below {
                        own_estimate = Some((previous, confidence));
                    }
                    confidence = confidence.max(iou);
                    from_learned = true;
                } else if !trusted {
                    let near = agreeing_parts(&region, &predicted);
                    let iou = near.iou(&predicted);
                    let ratio = near.area() as f64 / predicted.area().max(1) as f64;
                    if !near.is_empty() && iou >= cfg.reanchor_iou && (0.5..=2.0).contains(&ratio) {
                        mask = near;
                        confidence = confidence.max(cfg.lost_confidence).max(iou);
                        from_learned = true;
                    }
                }
            }
        }

        // Detections that agree win, within reach of the followed outline and where they do
        // not look like the background.
        let mut from_detection = false;
        if let Some((iou, det)) = detections
            .iter()
            .filter_map(|d| d.mask.as_ref().map(|m| (m.iou(&mask), m)))
            .max_by(|a, b| a.0.total_cmp(&b.0))
        {
            if iou >= cfg.detection_iou {
                let reach = (DETECTION_REACH_BANDS * band_px(&mask, cfg)).ceil() as u32;
                let near = within_reach(&det.clipped(self.width, self.height), &mask, reach);
                let taken = self.colour.vet(frame, &near, &mask, DETECTION_MIN_LLR);
                if !taken.is_empty() {
                    mask = taken;
                    confidence = confidence.max(iou);
                    from_detection = true;
                }
            }
        }

        // The output; the follower's state below goes on from its own estimate when a learned
        // outline is not carried.
        let output = mask;
        let (mask, from_learned_state) = match &own_estimate {
            Some((own, c)) if !from_detection => {
                confidence = *c;
                (own, false)
            }
            _ => (&output, from_learned),
        };
        // What the next frame warps: the colour-refined outline only when configured, since
        // refinement errors compound when fed back (see `carry_refined`).
        let carried = if from_detection || from_learned_state || cfg.carry_refined {
            mask.clone()
        } else {
            warped
        };

        // Judge and update.
        let lost = mask.is_empty() || confidence < cfg.lost_confidence;
        if let (Some(c0), Some(c1)) = (self.last.centroid(), mask.centroid()) {
            // Smoothed so one bad frame does not throw the next search region off.
            let v = c1 - c0;
            self.velocity = self.velocity * 0.5 + v * 0.5;
        }
        let mut renewed = false;
        if lost {
            self.lost_run += 1;
            if self.lost_run > cfg.max_lost {
                self.stopped = true;
            }
        } else {
            self.lost_run = 0;
            let new_feats = select_inside(&feats, &carried);
            // A textureless view keeps the older model: with no keypoints the next frame
            // could not be matched at all.
            if new_feats.len() >= cfg.min_inliers || new_feats.len() >= self.model.feats.len() {
                self.model = Model {
                    mask: carried.clone(),
                    feats: new_feats,
                };
                renewed = true;
            }
            let ring = ring(mask, cfg);
            self.colour
                .update(frame, mask, &ring, cfg.max_side, cfg.colour_rate);
        }
        if !carried.is_empty() {
            self.last = carried;
        }
        if cfg.background_lock.is_some() {
            self.background = feats;
            self.model_fresh = renewed;
        }
        Ok(FollowStep {
            mask: if self.stopped { Mask::empty() } else { output },
            confidence,
            lost,
            stopped: self.stopped,
            inliers,
            from_detection,
            from_learned,
        })
    }

    /// The background's motion from the last frame's search region to this one's, and which
    /// of `feats` move with it; `None` when it cannot be fitted.
    fn background_motion(
        &self,
        feats: &SiftFeatures,
        downscale: f64,
    ) -> Option<(Transform, Vec<bool>)> {
        let (matches, bg) = robust_fit(&self.background, feats, &self.cfg, downscale)?;
        let mut on = vec![false; feats.len()];
        for &k in &bg.inliers {
            on[matches[k].train] = true;
        }
        Some((bg.transform, on))
    }

    /// RANSAC similarity from the model's keypoints to this frame's, if enough agree and
    /// the scale change is plausible: the transform and its inliers' (model, frame) keypoint
    /// indices.
    fn fit(
        &self,
        feats: &SiftFeatures,
        downscale: f64,
    ) -> Option<(Transform, Vec<(usize, usize)>)> {
        let cfg = &self.cfg;
        let (matches, fit) = robust_fit(&self.model.feats, feats, cfg, downscale)?;
        let s = fit.transform.scale();
        let steps = (self.lost_run + 1) as f64;
        let max = cfg.max_scale_change.powf(steps.min(3.0));
        if !(s.is_finite() && s <= max && s >= 1.0 / max) {
            return None;
        }
        let inliers = fit
            .inliers
            .iter()
            .map(|&i| (matches[i].query, matches[i].train))
            .collect();
        Some((fit.transform, inliers))
    }
}

/// Keypoints `from` matched to `to` and a RANSAC similarity fitted to the matches, if at
/// least [`FollowConfig::min_inliers`] agree (`downscale`: the search region's, which scales
/// the inlier threshold to frame pixels).
fn robust_fit(
    from: &SiftFeatures,
    to: &SiftFeatures,
    cfg: &FollowConfig,
    downscale: f64,
) -> Option<(Vec<sift::SiftMatch>, RansacFit)> {
    let matches = sift::match_descriptors(
        from,
        to,
        &MatchConfig {
            ratio: cfg.match_ratio,
            cross_check: false,
        },
    );
    if matches.len() < cfg.min_inliers {
        return None;
    }
    let pairs: Vec<(Point, Point)> = matches
        .iter()
        .map(|m| {
            let a = from.keypoints[m.query];
            let b = to.keypoints[m.train];
            (
                Point::new(a.x as f64, a.y as f64),
                Point::new(b.x as f64, b.y as f64),
            )
        })
        .collect();
    let rc = RansacConfig {
        threshold: cfg.ransac_threshold * downscale,
        max_iterations: 300,
        seed: cfg.seed,
        ..RansacConfig::default()
    };
    let fit = ransac(TransformKind::Similarity, &pairs, &rc).ok()?;
    (fit.inliers.len() >= cfg.min_inliers).then_some((matches, fit))
}

/// The connected parts of `region` that lie mostly on `mask` (over half of their own pixels,
/// or over a tenth of the mask's): the learned object the followed outline is on, without the
/// other salient things the crop holds.
fn agreeing_parts(region: &Mask, mask: &Mask) -> Mask {
    use crate::detect::components::{Components, Connectivity};
    let mut comps = Components::new();
    let Ok(blobs) = comps.label(
        region.data(),
        region.width(),
        region.height(),
        Connectivity::Eight,
    ) else {
        return Mask::empty();
    };
    let n = blobs.len();
    let (w, h) = (region.width() as usize, region.height() as usize);
    let mut bits = vec![0u8; w * h];
    for i in 0..n {
        let Some(part) = comps.mask(i) else { continue };
        let part = part.translated(region.x(), region.y());
        let on = part.intersection(mask) as f64;
        if on > 0.5 * part.area() as f64 || on > 0.1 * mask.area() as f64 {
            for r in comps.runs(i) {
                let row = r.y as usize * w;
                bits[row + r.x0 as usize..row + r.x1 as usize].fill(1);
            }
        }
    }
    match Mask::new(
        region.x(),
        region.y(),
        region.width(),
        region.height(),
        bits,
    ) {
        Ok(m) if !m.is_empty() => m.tight(),
        _ => Mask::empty(),
    }
}

/// Half-width of the band around the warped outline that colour may relabel, in frame pixels.
fn band_px(mask: &Mask, cfg: &FollowConfig) -> f64 {
    (cfg.band * sqrt_area(mask)).clamp(2.0, 60.0)
}

/// How far, in bands, a detection's outline may lie outside the followed one and still be
/// taken (see [`FollowConfig::detection_iou`]).
///
/// Why: a detection that agrees closely overall can still carry a wrong part — the
/// moving-camera detector's masks are loose by a few pixels and take in shadows and
/// background that moved with the object. Taken whole, they cost car-roundabout 0.04 J on
/// DAVIS-moving, and `--detector auto` scored below the follower alone (mean J 0.621 against
/// 0.624). Cut to the pixels within one band of the followed mask, a detection may move the
/// outline as far as colour refinement may in a frame; its sharper outline is kept where the
/// two agree. The measured sweep is in tests/data/follow/README.md.
const DETECTION_REACH_BANDS: f64 = 1.0;

/// A detection's pixels outside the followed mask are taken only where the colour model's
/// log-likelihood ratio (target : surroundings) exceeds this.
///
/// Why: the reach alone bounds a frame's step, not the drift. A detection that is loose the
/// same way in every frame (a shadow under the object) is taken a band further each frame,
/// since what is taken is carried; in a generated scene the shadow was wholly taken within six
/// frames (IoU 0.82 with the target). Pixels the colour model holds clearly background (a
/// ratio under 1/e) stay out; the bound is loose so that a detector's outline still corrects a
/// follower that lags a growing object (the colour model is blurred at the edge). On
/// DAVIS-moving with `--detector auto` a bound of −2, −1 or −0.5 scored alike, 0 and 1 less
/// (tests/data/follow/README.md).
const DETECTION_MIN_LLR: f32 = -1.0;

/// How many bands next to the outline the colour model's background leaves out.
///
/// Why: the pixels along an object's edge mix its colours with the surroundings' (edge blur,
/// JPEG's half-resolution chroma, a followed outline a pixel or two off). Learnt as
/// background, they made the band's edge pixels look like background, the outline retreated
/// a little every frame, and the next frame learnt the object's own edge as background: the
/// followed mask shrank steadily (soapbox, dog, bus on DAVIS-moving: a quarter to a half of
/// the object's area lost in 60–100 frames). Two bands (4 px at the default band) cover that
/// mix; the band's decisions are then made by colours learnt away from the edge. Mean J on
/// the eight DAVIS-moving sequences 0.605 → 0.624 (one band 0.622, three 0.617; see
/// tests/data/follow/README.md).
const GUARD_BANDS: f64 = 2.0;

/// The background ring around a mask that the colour model learns from: it starts
/// [`GUARD_BANDS`] bands outside the outline and is as wide as two bands, at least 8 px, so
/// the surroundings the band can reach are represented.
fn ring(mask: &Mask, cfg: &FollowConfig) -> Ring {
    let band = band_px(mask, cfg);
    Ring {
        guard: GUARD_BANDS * band,
        width: (2.0 * cfg.band * sqrt_area(mask)).max(8.0),
    }
}

/// The frame's SIFT features inside `mask` (searched over the mask's box plus a small margin,
/// so keypoints near the outline see their neighbourhood).
fn model_features(
    frame: &Frame<'_>,
    mask: &Mask,
    cfg: &FollowConfig,
) -> Result<SiftFeatures, FollowError> {
    let b = mask.bbox();
    let Some(region) = clip_box(&b.expanded(8.0), frame.width(), frame.height()) else {
        return Ok(SiftFeatures::default());
    };
    Ok(sift::detect_in_region(
        frame,
        &region,
        Some(mask),
        &cfg.sift(),
    )?)
}

fn select_inside(feats: &SiftFeatures, mask: &Mask) -> SiftFeatures {
    select(feats, |_, k| {
        mask.get(k.x.floor() as i32, k.y.floor() as i32)
    })
}

/// `feats` without the keypoints at indices `drop`.
fn without(feats: &SiftFeatures, drop: &[usize]) -> SiftFeatures {
    let mut keep = vec![true; feats.len()];
    for &i in drop {
        keep[i] = false;
    }
    select(feats, |i, _| keep[i])
}

/// The keypoints of `feats` (with their descriptors) that `keep(index, keypoint)` accepts.
fn select(feats: &SiftFeatures, keep: impl Fn(usize, &Keypoint) -> bool) -> SiftFeatures {
    let mut out = SiftFeatures::default();
    for (i, (k, d)) in feats.keypoints.iter().zip(&feats.descriptors).enumerate() {
        if keep(i, k) {
            out.keypoints.push(*k);
            out.descriptors.push(*d);
        }
    }
    out
}

fn clip_box(b: &BBox, w: u32, h: u32) -> Option<BBox> {
    let x0 = b.x.max(0.0);
    let y0 = b.y.max(0.0);
    let x1 = b.x2().min(w as f64);
    let y1 = b.y2().min(h as f64);
    (x1 - x0 >= 1.0 && y1 - y0 >= 1.0).then(|| BBox::from_xyxy(x0, y0, x1, y1))
}
