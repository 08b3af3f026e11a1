//! Detector models: how a simulated detector turns a sequence's ground truth into detections.
//!
//! The robustness grid runs every tracker on the same detections; for datasets that ship only
//! ground truth (SportsMOT, the synthetic scenes) or to vary a real dataset's detector, the
//! detections come from a [`DetectorModel`] applied to the ground truth. Each model combines
//! the behaviours real detectors show, so that defaults chosen across models do not fit one
//! detector's quirks:
//!
//! - **score calibration** ([`ScoreModel`]): high and narrow like MOT15's Faster R-CNN, wide,
//!   constant 1.0 like a detector thresholded in the browser, or low like an
//!   objectness × class product; true positives score lower when occluded or small, false
//!   positives draw from a lower, overlapping distribution, and an object's score drifts
//!   smoothly from frame to frame (a first-order autoregressive latent) as real scores do;
//! - **misses** ([`MissModel`]): at random, in bursts (a two-state Markov chain per object,
//!   since real misses come in runs), more often for occluded objects (visibility from the
//!   ground truth when it has a real one, else estimated from the boxes in front) and for
//!   small ones (relative to the sequence's median height); a fully hidden object (visibility
//!   0 in the ground truth) is never detected;
//! - **box jitter** proportional to the box size;
//! - **false positives** ([`FalsePositives`]) near objects (beside one, IoU with it below
//!   ~0.3) and far from them (sizes drawn from the sequence's own objects), some of them
//!   persisting for several frames like static clutter;
//! - **duplicated** boxes (a second box on one object) and **split** boxes (one object reported
//!   as two partial boxes);
//! - for masks ([`MaskNoise`]): eroded, dilated and ragged outlines, split masks, merged masks
//!   of touching objects; and **dropped frames** (no detections at all).
//!
//! Every random choice comes from a stream seeded by (seed, frame, purpose), so a model is
//! deterministic and changing one rate leaves the other behaviours' draws unchanged. The named
//! [`profiles`] are the grid's detector models: fixed test conditions, documented with the
//! real-world behaviour each imitates, never tuned to the tracker.

use std::collections::BTreeMap;

use rand::Rng;
use serde::{Deserialize, Serialize};

use crate::frame::{BBox, Mask};
use crate::io::{Record, RecordFlags, Rle};
use crate::synth::math::{normal, stream, uniform};
use crate::synth::noise::split;

mod catalogue;
mod mask_noise;
mod visibility;

pub use catalogue::{profile, profiles};
use mask_noise::merge_touching;
pub use visibility::estimate_visibility;

/// How detection scores are calibrated (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ScoreModel {
    /// Like MOT15's published Faster R-CNN detections (cut at 0.5): true positives mostly
    /// 0.97–1.0 with a tail down to 0.5 (longer for occluded ones); false positives
    /// `1 − 0.5·v^1.6` (median ≈ 0.83). MOT15's measured quantiles: true positives p10 0.85,
    /// median 0.98; false positives p25 0.70, median 0.86.
    HighNarrow,
    /// True positives spread over 0.3–1.0, false positives over 0.1–0.7.
    Wide,
    /// Every detection, false positives included, scores this (a detector thresholded before
    /// the tracker sees it, as in the browser).
    Constant(f64),
    /// True positives 0.1–0.55, false positives 0.02–0.35 (an objectness × class product).
    Low,
}

/// Which objects the detector misses.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MissModel {
    /// Long-run fraction of frames an object is missed at random.
    pub random: f64,
    /// Mean length (frames) of a run of random misses; 1 = independent frames.
    pub burst: f64,
    /// Miss probability of a fully hidden object, falling linearly to 0 at 70 % visibility.
    pub occlusion: f64,
    /// Miss probability of a vanishingly small object, falling linearly to 0 at
    /// `small_below` times the sequence's median object height.
    pub small: f64,
    /// See `small`.
    pub small_below: f64,
}

impl Default for MissModel {
    fn default() -> Self {
        Self {
            random: 0.0,
            burst: 1.0,
            occlusion: 0.0,
            small: 0.0,
            small_below: 0.5,
        }
    }
}

/// False positives per frame.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FalsePositives {
    /// Mean number of new false positives far from every object (Poisson).
    pub far: f64,
    /// Mean number of new false positives beside an object (Poisson).
    pub near: f64,
    /// Probability that a false positive recurs in the next frame at nearly the same place.
    pub persist: f64,
}

/// Noise of mask detections (applies when the ground truth has masks).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MaskNoise {
    /// Probability that a mask is eroded or dilated (even odds) by 1..=`morph_max` pixels.
    pub morph: f64,
    /// Largest erosion or dilation radius.
    pub morph_max: u32,
    /// Probability that a mask's outline is ragged: pixels within 2 px of it flipped at random
    /// (60 % of those inside kept, 25 % of those outside added).
    pub ragged: f64,
    /// Probability that a mask is cut in two across its long axis (two detections).
    pub split: f64,
    /// Probability that two touching objects are reported as one mask.
    pub merge: f64,
}

/// A simulated detector (module docs). Rates are per object per frame unless said otherwise.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DetectorModel {
    /// Name (the grid's column label).
    pub name: String,
    /// Score calibration.
    pub scores: ScoreModel,
    /// Misses.
    pub misses: MissModel,
    /// Standard deviation of each box edge, as a fraction of the box's width or height.
    pub jitter: f64,
    /// False positives.
    pub false_positives: FalsePositives,
    /// Probability that an object gets a second, duplicated box.
    pub duplicate: f64,
    /// Probability that an object's box is reported as two partial boxes.
    pub split: f64,
    /// Mask noise; `None`: masks are reported exactly (before misses and merging).
    pub masks: Option<MaskNoise>,
    /// Probability that a whole frame has no detections.
    pub drop_frame: f64,
}

/// One ground-truth object in one frame, as a detector model sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct GtObject {
    /// Track id.
    pub id: i64,
    /// Box.
    pub bbox: BBox,
    /// Visible pixels, when the ground truth has masks.
    pub mask: Option<Mask>,
    /// Visible fraction, when the ground truth has a real one.
    pub visibility: Option<f64>,
}

/// A sequence's ground truth, frame by frame (`frames[k]` is frame `k + 1`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct GtSequence {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Objects per frame.
    pub frames: Vec<Vec<GtObject>>,
}

impl GtSequence {
    /// Ground-truth records grouped by frame (frames `1..=num_frames`; others dropped).
    pub fn from_records(records: &[Record], num_frames: u32, width: u32, height: u32) -> Self {
        let mut frames = vec![Vec::new(); num_frames as usize];
        for r in records {
            if r.frame == 0 || r.frame > num_frames {
                continue;
            }
            frames[r.frame as usize - 1].push(GtObject {
                id: r.id,
                bbox: r.bbox,
                mask: r.mask_bitmap(),
                visibility: (r.visibility >= 0.0).then_some(r.visibility),
            });
        }
        Self {
            width,
            height,
            frames,
        }
    }
}

// Purposes of the per-frame random streams.
const MISS: u64 = 0x6d69_7373;
const SCORE: u64 = 0x7363_6f72;
const JITTER: u64 = 0x6a69_7474;
const EXTRA: u64 = 0x6578_7472;
const FP: u64 = 0x6670_6670;
const MASK: u64 = 0x6d61_736b;
const DROP: u64 = 0x6472_6f70;

/// How much an object's latent score keeps from one frame to the next (AR(1) coefficient):
/// real detectors score an object similarly in consecutive frames.
const SCORE_MEMORY: f64 = 0.8;

/// Standard normal CDF (Abramowitz–Stegun 7.1.26, error < 1.5e-7).
fn phi(x: f64) -> f64 {
    let z = x.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * z);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erf = 1.0 - poly * (-z * z).exp();
    if x >= 0.0 {
        0.5 * (1.0 + erf)
    } else {
        0.5 * (1.0 - erf)
    }
}

/// A Poisson draw with mean `lambda` (Knuth; the means here are small).
fn poisson<R: Rng>(rng: &mut R, lambda: f64) -> u32 {
    if lambda.is_nan() || lambda <= 0.0 {
        return 0;
    }
    let l = (-lambda.min(30.0)).exp();
    let (mut k, mut p) = (0u32, 1.0);
    loop {
        p *= rng.gen::<f64>();
        if p <= l || k >= 200 {
            return k;
        }
        k += 1;
    }
}

fn frame_seed(seed: u64, frame: u32) -> u64 {
    seed ^ (frame as u64).wrapping_mul(0xD6E8_FEB8_6659_FD93)
}

/// A detection in the making: box, score, mask, and the object it came from (`None` for false
/// positives), `whole` unless it is one of two parts of a split.
struct Det {
    bbox: BBox,
    score: f64,
    mask: Option<Mask>,
    owner: Option<usize>,
    whole: bool,
}

impl Det {
    fn of(bbox: BBox, score: f64, mask: Option<Mask>, owner: Option<usize>, whole: bool) -> Self {
        Self {
            bbox,
            score,
            mask,
            owner,
            whole,
        }
    }
}

/// A false positive carried to the next frame.
#[derive(Debug, Clone, Copy)]
struct Clutter {
    bbox: BBox,
    score: f64,
}

impl DetectorModel {
    /// A model with no noise at all (exact boxes, score 1).
    pub fn exact(name: &str) -> Self {
        Self {
            name: name.to_string(),
            scores: ScoreModel::Constant(1.0),
            misses: MissModel::default(),
            jitter: 0.0,
            false_positives: FalsePositives::default(),
            duplicate: 0.0,
            split: 0.0,
            masks: None,
            drop_frame: 0.0,
        }
    }

    /// A true positive's score from its latent `q` in `[0, 1]` (higher = more confident),
    /// its visibility and relative size, and a uniform `u`.
    fn tp_score(&self, q: f64, vis: f64, small: f64, u: f64) -> f64 {
        // Occlusion and smallness make the detector less sure.
        let q = q * (0.6 + 0.4 * vis) * (1.0 - 0.3 * small);
        match self.scores {
            ScoreModel::HighNarrow => {
                let tail = 0.15 + 0.5 * (1.0 - vis) + 0.2 * small;
                if u < tail {
                    0.5 + 0.45 * q
                } else {
                    0.97 + 0.03 * q
                }
            }
            ScoreModel::Wide => 0.3 + 0.7 * q,
            ScoreModel::Constant(c) => c,
            ScoreModel::Low => 0.1 + 0.45 * q,
        }
    }

    /// A false positive's score from a uniform `v`.
    fn fp_score(&self, v: f64) -> f64 {
        match self.scores {
            ScoreModel::HighNarrow => 1.0 - 0.5 * v.powf(1.6),
            ScoreModel::Wide => 0.1 + 0.6 * (1.0 - v.powf(1.3)),
            ScoreModel::Constant(c) => c,
            ScoreModel::Low => 0.02 + 0.33 * (1.0 - v.powf(1.5)),
        }
    }

    /// The detections of the whole sequence `gt`, as records (id −1, class −1), seeded by
    /// `seed`.
    pub fn apply(&self, gt: &GtSequence, seed: u64) -> Vec<Record> {
        let (w, h) = (gt.width.max(1), gt.height.max(1));
        let mut heights: Vec<f64> = gt
            .frames
            .iter()
            .flatten()
            .map(|o| o.bbox.h)
            .filter(|h| *h > 0.0)
            .collect();
        heights.sort_by(f64::total_cmp);
        let median_h = heights.get(heights.len() / 2).copied().unwrap_or(1.0);
        let sizes: Vec<(f64, f64)> = gt
            .frames
            .iter()
            .flatten()
            .filter(|o| o.bbox.w > 0.0 && o.bbox.h > 0.0)
            .map(|o| (o.bbox.w, o.bbox.h))
            .collect();
        // Per-object state: in a burst of misses; latent score.
        let mut burst: BTreeMap<i64, bool> = BTreeMap::new();
        let mut latent: BTreeMap<i64, f64> = BTreeMap::new();
        let mut clutter: Vec<Clutter> = Vec::new();
        let mut out = Vec::new();
        let m = &self.misses;
        let r = m.random.clamp(0.0, 0.999);
        let b = m.burst.max(1.0);
        // Two-state chain with stationary miss rate r and mean run length b.
        let (stay, enter) = (1.0 - 1.0 / b, r / (b * (1.0 - r)));
        for (k, objects) in gt.frames.iter().enumerate() {
            let frame = k as u32 + 1;
            let fs = frame_seed(seed, frame);
            let (mut miss_rng, mut score_rng) = (stream(fs, MISS), stream(fs, SCORE));
            let (mut jit_rng, mut extra_rng) = (stream(fs, JITTER), stream(fs, EXTRA));
            let (mut fp_rng, mut mask_rng) = (stream(fs, FP), stream(fs, MASK));
            let dropped = stream(fs, DROP).gen::<f64>() < self.drop_frame;
            let boxes: Vec<BBox> = objects.iter().map(|o| o.bbox).collect();
            let estimated = estimate_visibility(&boxes);
            let mut dets: Vec<Det> = Vec::new();
            for (i, o) in objects.iter().enumerate() {
                // Draw everything first so each object consumes the same number of values.
                let u: [f64; 3] = [miss_rng.gen(), miss_rng.gen(), miss_rng.gen()];
                let (u_burst, u_occ, u_small) = (u[0], u[1], u[2]);
                let (n_score, u_tail) = (normal(&mut score_rng), score_rng.gen::<f64>());
                let jit = [
                    normal(&mut jit_rng),
                    normal(&mut jit_rng),
                    normal(&mut jit_rng),
                    normal(&mut jit_rng),
                ];
                let extra: [f64; 6] = [
                    extra_rng.gen(),
                    extra_rng.gen(),
                    extra_rng.gen(),
                    extra_rng.gen(),
                    extra_rng.gen(),
                    extra_rng.gen(),
                ];
                let in_burst = burst.entry(o.id).or_insert(false);
                *in_burst = if *in_burst {
                    u_burst < stay
                } else {
                    u_burst < enter
                };
                let missed_random = *in_burst;
                let z = latent.entry(o.id).or_insert(n_score);
                *z = SCORE_MEMORY * *z + (1.0 - SCORE_MEMORY * SCORE_MEMORY).sqrt() * n_score;
                let q = phi(*z);
                // A fully hidden object (ground truth with visibility 0: amodal annotations
                // keep hidden people) shows the detector nothing.
                let hidden = o.visibility.is_some_and(|v| v <= 0.0);
                if dropped || hidden || !(o.bbox.w > 0.0 && o.bbox.h > 0.0) {
                    continue;
                }
                let vis = o
                    .visibility
                    .unwrap_or_else(|| estimated.get(i).copied().unwrap_or(1.0))
                    .clamp(0.0, 1.0);
                let small_at = m.small_below * median_h;
                let small = if small_at > 0.0 {
                    ((small_at - o.bbox.h) / small_at).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let p_occ = m.occlusion * ((0.7 - vis) / 0.7).clamp(0.0, 1.0);
                if missed_random || u_occ < p_occ || u_small < m.small * small {
                    continue;
                }
                let score = self.tp_score(q, vis, small, u_tail);
                let mask = o
                    .mask
                    .as_ref()
                    .map(|mk| self.noisy_mask(mk, &mut mask_rng, w, h));
                if let Some(mk) = mask {
                    // Mask detections report their mask's tight box.
                    match self
                        .masks
                        .filter(|n| extra[4] < n.split)
                        .and_then(|_| split(&mk, 16))
                    {
                        Some((a, c)) => {
                            for part in [a, c] {
                                dets.push(Det::of(
                                    part.bbox(),
                                    score * 0.8,
                                    Some(part),
                                    Some(i),
                                    false,
                                ));
                            }
                        }
                        None if !mk.is_empty() => {
                            dets.push(Det::of(mk.bbox(), score, Some(mk), Some(i), true))
                        }
                        None => {}
                    }
                    continue;
                }
                let bb = o.bbox;
                let (sx, sy) = (self.jitter * bb.w, self.jitter * bb.h);
                let (x1, y1) = (bb.x + sx * jit[0], bb.y + sy * jit[1]);
                let (x2, y2) = (bb.x2() + sx * jit[2], bb.y2() + sy * jit[3]);
                let jb = BBox::new(x1, y1, (x2 - x1).max(1.0), (y2 - y1).max(1.0));
                if extra[0] < self.split {
                    // Two partial boxes, each 60 % of the object along its long side.
                    let (p, q2) = if jb.h >= jb.w {
                        (
                            BBox::new(jb.x, jb.y, jb.w, 0.6 * jb.h),
                            BBox::new(jb.x, jb.y + 0.4 * jb.h, jb.w, 0.6 * jb.h),
                        )
                    } else {
                        (
                            BBox::new(jb.x, jb.y, 0.6 * jb.w, jb.h),
                            BBox::new(jb.x + 0.4 * jb.w, jb.y, 0.6 * jb.w, jb.h),
                        )
                    };
                    let f = 0.6 + 0.3 * extra[1];
                    dets.push(Det::of(p, score * f, None, Some(i), false));
                    dets.push(Det::of(q2, score * f, None, Some(i), false));
                } else {
                    dets.push(Det::of(jb, score, None, Some(i), true));
                }
                if extra[2] < self.duplicate {
                    // A second box on the same object: shifted and grown (IoU ~0.5–0.8).
                    let s = 1.1 + 0.25 * extra[3];
                    let c = jb.center();
                    let d = BBox::from_center(
                        crate::frame::Point::new(
                            c.x + 0.08 * jb.w * (2.0 * extra[5] - 1.0),
                            c.y + 0.08 * jb.h * (2.0 * extra[1] - 1.0),
                        ),
                        jb.w * s,
                        jb.h * s,
                    );
                    dets.push(Det::of(
                        d,
                        score * (0.5 + 0.45 * extra[3]),
                        None,
                        Some(i),
                        false,
                    ));
                }
            }
            if let Some(n) = self.masks.filter(|n| n.merge > 0.0) {
                merge_touching(objects, &mut dets, &mut mask_rng, n.merge);
            }
            // False positives: survivors of the last frame's clutter, then new ones.
            let fpc = self.false_positives;
            let mut next = Vec::new();
            for c in &clutter {
                let (u, a, bb) = (
                    fp_rng.gen::<f64>(),
                    normal(&mut fp_rng),
                    normal(&mut fp_rng),
                );
                if u < fpc.persist {
                    let m = BBox::new(
                        c.bbox.x + 0.03 * c.bbox.w * a,
                        c.bbox.y + 0.03 * c.bbox.h * bb,
                        c.bbox.w,
                        c.bbox.h,
                    );
                    next.push(Clutter {
                        bbox: m,
                        score: c.score,
                    });
                }
            }
            for _ in 0..poisson(&mut fp_rng, fpc.far) {
                let Some(&(bw, bh)) =
                    sizes.get((fp_rng.gen::<f64>() * sizes.len() as f64) as usize)
                else {
                    break;
                };
                let (bw, bh) = (bw.min(w as f64), bh.min(h as f64));
                for _ in 0..5 {
                    let c = BBox::new(
                        uniform(&mut fp_rng, 0.0, w as f64 - bw),
                        uniform(&mut fp_rng, 0.0, h as f64 - bh),
                        bw,
                        bh,
                    );
                    if boxes.iter().all(|g| g.iou(&c) <= 0.1) {
                        let score = self.fp_score(fp_rng.gen());
                        next.push(Clutter { bbox: c, score });
                        break;
                    }
                }
            }
            for _ in 0..poisson(&mut fp_rng, fpc.near) {
                if objects.is_empty() {
                    break;
                }
                let o = &objects[((fp_rng.gen::<f64>() * objects.len() as f64) as usize)
                    .min(objects.len() - 1)];
                let bb = o.bbox;
                let side = if fp_rng.gen::<f64>() < 0.5 { -1.0 } else { 1.0 };
                let s = uniform(&mut fp_rng, 0.8, 1.2);
                let c = BBox::new(
                    bb.x + side * uniform(&mut fp_rng, 0.6, 1.0) * bb.w,
                    bb.y + uniform(&mut fp_rng, -0.3, 0.3) * bb.h,
                    bb.w * s,
                    bb.h * s,
                );
                let score = self.fp_score(fp_rng.gen());
                next.push(Clutter { bbox: c, score });
            }
            clutter = next;
            if dropped {
                continue;
            }
            for c in &clutter {
                let mask = self.masks.map(|_| Mask::from_bbox(&c.bbox));
                dets.push(Det::of(c.bbox, c.score, mask, None, false));
            }
            for det in dets {
                let mask = det
                    .mask
                    .map(|mk| mk.clipped(w, h))
                    .filter(|mk| !mk.is_empty());
                if let Some(mk) = &mask {
                    let rle = Rle::from_mask(mk, w, h);
                    out.push(record(frame, mk.bbox(), det.score, Some(rle)));
                } else if det.bbox.w > 0.0 && det.bbox.h > 0.0 {
                    out.push(record(frame, det.bbox, det.score, None));
                }
            }
        }
        out
    }
}

fn record(frame: u32, bbox: BBox, score: f64, mask: Option<Rle>) -> Record {
    Record {
        frame,
        id: -1,
        bbox,
        score,
        class: -1,
        visibility: -1.0,
        mask,
        flags: RecordFlags::default(),
    }
}

#[cfg(test)]
mod tests;
