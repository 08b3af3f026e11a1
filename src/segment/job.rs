//! One frame's learned segmentation as a state machine, so the same decisions run whether the
//! network is called synchronously (the CLI) or from a browser worker that awaits it.

use super::{input_tensor, Crop, Net, Saliency, SegmentConfig, SegmentError};
use crate::frame::{BBox, Detection, Frame, Mask};
use serde::{Deserialize, Serialize};

/// What a job does with the whole frame, beside the detections' boxes.
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WholeFrame {
    /// Only the detections' boxes are segmented.
    #[default]
    Off,
    /// The whole frame goes through the network first; each salient region no detection
    /// covers becomes a new box, segmented like the others (objects that do not move, which
    /// a motion cue cannot see).
    Proposals,
    /// As `Proposals`, but the whole frame's salient regions are taken as masks directly,
    /// without a second, closer look (one network run less per region).
    Masks,
}

/// What the network is run on next, and for whom.
#[derive(Debug, Clone, Copy)]
enum Target {
    /// The box of detection `i`.
    Detection(usize),
    /// The whole frame.
    Whole,
}

/// One frame's segmentation: detections in, the same detections with learned masks out.
///
/// ```text
/// let mut job = Job::new(w, h, detections, WholeFrame::Off, &cfg)?;
/// while job.pending().is_some() {
///     job.input(&frame, &mut input)?;     // the next crop's tensor
///     let output = network(&input);       // however the caller runs it
///     job.supply(&output)?;
/// }
/// let Outcome { detections, learned } = job.finish();
/// ```
#[derive(Debug, Clone)]
pub struct Job {
    cfg: SegmentConfig,
    width: u32,
    height: u32,
    dets: Vec<Detection>,
    learned: Vec<bool>,
    queue: Vec<(Crop, Target)>,
    next: usize,
    /// Crops still allowed (`max_crops` minus those queued).
    budget: usize,
    whole: WholeFrame,
}

/// A finished job's detections.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// The detections in their order, each with its learned mask where the network found its
    /// object (and its box the mask's), then the regions the whole frame proposed.
    pub detections: Vec<Detection>,
    /// Per detection: whether its mask is the network's.
    pub learned: Vec<bool>,
}

/// Mask IoU above which two of a job's masks are one object: the later one is dropped (a
/// motion blob and the salient region around the same animal).
const SAME_OBJECT: f64 = 0.7;

/// Share of a salient region's box inside a detection's box above which the detection
/// covers it already (the region is not proposed again).
const COVERED: f64 = 0.5;

impl Job {
    /// A job for a `width × height` frame's `detections` (boxes, or masks to redo).
    pub fn new(
        width: u32,
        height: u32,
        detections: Vec<Detection>,
        whole: WholeFrame,
        cfg: &SegmentConfig,
    ) -> Result<Job, SegmentError> {
        cfg.validate()?;
        if width == 0 || height == 0 {
            return Err(SegmentError::FrameSize {
                width,
                height,
                expected_width: width.max(1),
                expected_height: height.max(1),
            });
        }
        let mut job = Job {
            cfg: cfg.clone(),
            width,
            height,
            learned: vec![false; detections.len()],
            dets: detections,
            queue: Vec::new(),
            next: 0,
            budget: cfg.max_crops,
            whole,
        };
        if whole != WholeFrame::Off {
            job.queue.push((Crop::whole(width, height), Target::Whole));
        }
        // The highest scores first, by repeated scans (a handful of picks; a sort by a
        // closure costs the browser module several KB).
        let mut chosen = vec![false; job.dets.len()];
        let mut picks = Vec::new();
        while job.budget > 0 {
            let mut best: Option<(usize, f64)> = None;
            for (i, d) in job.dets.iter().enumerate() {
                if !chosen[i] && job.eligible(&d.bbox) && best.is_none_or(|(_, s)| d.score > s) {
                    best = Some((i, d.score));
                }
            }
            let Some((i, _)) = best else { break };
            chosen[i] = true;
            picks.push(i);
            job.budget -= 1;
        }
        // Segmented in the detections' own order (deterministic whatever the scores).
        picks.sort_unstable();
        for i in picks {
            if let Some(crop) = job.crop_for(&job.dets[i].bbox) {
                job.queue.push((crop, Target::Detection(i)));
            }
        }
        Ok(job)
    }

    fn eligible(&self, b: &BBox) -> bool {
        b.is_valid() && b.clipped(self.width, self.height).area() >= self.cfg.min_area.max(1.0)
    }

    fn crop_for(&self, b: &BBox) -> Option<Crop> {
        Crop::around(
            &b.clipped(self.width, self.height),
            self.width,
            self.height,
            self.cfg.margin,
            self.cfg.min_crop,
        )
    }

    /// The crop the network should see next; `None` when the job is done.
    pub fn pending(&self) -> Option<Crop> {
        self.queue.get(self.next).map(|(c, _)| *c)
    }

    /// The side the pending crop runs at: the whole frame at [`super::SIDE`], a box's crop at
    /// [`SegmentConfig::side`]; `None` when the job is done.
    pub fn pending_side(&self) -> Option<u32> {
        self.queue.get(self.next).map(|&(_, t)| self.side(t))
    }

    fn side(&self, target: Target) -> u32 {
        match target {
            Target::Whole => super::SIDE as u32,
            Target::Detection(_) => self.cfg.side,
        }
    }

    /// How many network runs are still queued (more may follow a whole-frame pass).
    pub fn remaining(&self) -> usize {
        self.queue.len() - self.next
    }

    /// Writes the pending crop's input tensor into `out`: `3 · side²` values for its
    /// [`Job::pending_side`] ([`super::input_len`]).
    pub fn input(&self, frame: &Frame, out: &mut [f32]) -> Result<(), SegmentError> {
        if (frame.width(), frame.height()) != (self.width, self.height) {
            return Err(SegmentError::FrameSize {
                width: frame.width(),
                height: frame.height(),
                expected_width: self.width,
                expected_height: self.height,
            });
        }
        let (crop, side) = self
            .pending()
            .zip(self.pending_side())
            .ok_or(SegmentError::NothingPending)?;
        let expected = super::input_len(side);
        if out.len() != expected {
            return Err(SegmentError::TensorLength {
                what: "the input buffer",
                len: out.len(),
                expected,
            });
        }
        input_tensor(frame, &crop, out)
    }

    /// Hands over the network's output for the pending crop (`side²` values).
    pub fn supply(&mut self, output: &[f32]) -> Result<(), SegmentError> {
        let (crop, target) = *self
            .queue
            .get(self.next)
            .ok_or(SegmentError::NothingPending)?;
        let expected = super::output_len(self.side(target));
        if output.len() != expected {
            return Err(SegmentError::TensorLength {
                what: "the network's output",
                len: output.len(),
                expected,
            });
        }
        let sal = Saliency::new(crop, output, self.cfg.stretch)?;
        self.next += 1;
        match target {
            Target::Detection(i) => self.take_box(i, &sal),
            Target::Whole => self.take_whole(&sal),
        }
        Ok(())
    }

    fn take_box(&mut self, i: usize, sal: &Saliency) {
        let Some(d) = self.dets.get(i) else { return };
        let b = d.bbox.clipped(self.width, self.height);
        let s = self.cfg.slack;
        let region = BBox::new(
            b.x - s * b.w,
            b.y - s * b.h,
            b.w * (1.0 + 2.0 * s),
            b.h * (1.0 + 2.0 * s),
        );
        if let Some(m) = sal.mask(&region, self.cfg.threshold, self.cfg.keep_fraction) {
            if let Some(d) = self.dets.get_mut(i) {
                d.bbox = m.bbox();
                d.mask = Some(m);
            }
            if let Some(l) = self.learned.get_mut(i) {
                *l = true;
            }
        }
    }

    fn take_whole(&mut self, sal: &Saliency) {
        let all = Crop::whole(self.width, self.height).bbox();
        // Each component on its own: the mask keeps every component big enough, then they
        // are parted again.
        let Some(m) = sal.mask(&all, self.cfg.threshold, self.cfg.keep_fraction) else {
            return;
        };
        for part in split(&m) {
            if (part.area() as f64) < self.cfg.min_area {
                continue;
            }
            let pb = part.bbox();
            let covered = self.dets.iter().any(|d| {
                let a = pb.area();
                a > 0.0 && pb.intersection_area(&d.bbox) / a >= COVERED
            });
            if covered {
                continue;
            }
            let score = sal.mean_over(&part);
            match self.whole {
                WholeFrame::Masks => {
                    self.dets.push(Detection::from_mask(part, score));
                    self.learned.push(true);
                }
                WholeFrame::Proposals | WholeFrame::Off => {
                    let i = self.dets.len();
                    self.dets.push(Detection::from_mask(part, score));
                    self.learned.push(true);
                    if self.budget > 0 {
                        if let Some(crop) = self.crop_for(&pb) {
                            self.budget -= 1;
                            self.queue.push((crop, Target::Detection(i)));
                        }
                    }
                }
            }
        }
    }

    /// Runs every pending crop through `net` (the synchronous case).
    pub fn run<N: Net + ?Sized>(&mut self, frame: &Frame, net: &mut N) -> Result<(), SegmentError> {
        let mut input = Vec::new();
        while let Some(side) = self.pending_side() {
            input.resize(super::input_len(side), 0.0);
            self.input(frame, &mut input)?;
            let out = net.run(&input)?;
            self.supply(&out)?;
        }
        Ok(())
    }

    /// The detections with their learned masks; two masks of one object (IoU ≥ 0.7) are
    /// kept once, the earlier.
    pub fn finish(self) -> Outcome {
        let mut keep = vec![true; self.dets.len()];
        for j in 0..self.dets.len() {
            let Some(mj) = self.dets[j].mask.as_ref() else {
                continue;
            };
            for i in 0..j {
                if !keep[i] {
                    continue;
                }
                if let Some(mi) = self.dets[i].mask.as_ref() {
                    if mi.iou(mj) >= SAME_OBJECT {
                        keep[j] = false;
                        break;
                    }
                }
            }
        }
        let mut detections = Vec::with_capacity(self.dets.len());
        let mut learned = Vec::with_capacity(self.dets.len());
        for ((d, l), k) in self.dets.into_iter().zip(self.learned).zip(keep) {
            if k {
                detections.push(d);
                learned.push(l);
            }
        }
        Outcome {
            detections,
            learned,
        }
    }
}

/// The 8-connected components of a mask, each as its own tight mask.
fn split(m: &Mask) -> Vec<Mask> {
    use crate::detect::components::{Components, Connectivity};
    let mut comps = Components::new();
    let Ok(blobs) = comps.label(m.data(), m.width(), m.height(), Connectivity::Eight) else {
        return vec![m.clone()];
    };
    let n = blobs.len();
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        if let Some(part) = comps.mask(i) {
            out.push(part.translated(m.x(), m.y()).tight());
        }
    }
    out
}
