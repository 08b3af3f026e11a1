//! [`BoxRefiner`]: a detector that turns boxes from another source into masks with
//! [`refine_box`].

use super::{refine_box, RefineConfig};
use crate::detect::{DetectError, Detector};
use crate::frame::{Detection, Frame, Mask};

/// A detector that turns boxes from another source (files, a box detector) into masks.
/// Boxes are handed in per frame with [`BoxRefiner::set_boxes`]; a box that cannot be refined
/// is passed on as a filled box so no detection is lost.
#[derive(Debug, Clone, Default)]
pub struct BoxRefiner {
    cfg: RefineConfig,
    boxes: Vec<Detection>,
}

impl BoxRefiner {
    /// A refiner with validated settings.
    pub fn new(cfg: RefineConfig) -> Result<Self, DetectError> {
        cfg.validate()?;
        Ok(Self {
            cfg,
            boxes: Vec::new(),
        })
    }

    /// The boxes of the next frame to refine (their score and class are kept).
    pub fn set_boxes(&mut self, boxes: Vec<Detection>) {
        self.boxes = boxes;
    }

    /// Refines the box-only detections of `dets` in place, the highest scores first (equal
    /// scores: in order) and at most `max` of them (all when `None`: a caller bounds a frame's
    /// cost with it). Each refined box takes the mask found inside it, and its box becomes the
    /// mask's. A box the refinement finds nothing in, or one past `max`, takes its filled box
    /// (clipped to the frame) as its mask, so no detection is lost. Detections that came with
    /// a mask keep it. Returns how many boxes were refined.
    pub fn refine_all(
        &self,
        frame: &Frame,
        dets: &mut [Detection],
        max: Option<usize>,
    ) -> Result<usize, DetectError> {
        // The `max` highest scores by repeated scans rather than a sort: `max` is a handful,
        // a frame holds at most a few hundred boxes, and a sort by a closure costs the browser
        // module 7 KB.
        let mut chosen = vec![false; dets.len()];
        for _ in 0..max.unwrap_or(usize::MAX).min(dets.len()) {
            let mut best: Option<(usize, f64)> = None;
            for (i, d) in dets.iter().enumerate() {
                let free = d.mask.is_none() && !chosen.get(i).copied().unwrap_or(true);
                if free && best.is_none_or(|(_, s)| d.score > s) {
                    best = Some((i, d.score));
                }
            }
            match best.and_then(|(i, _)| chosen.get_mut(i)) {
                Some(c) => *c = true,
                None => break,
            }
        }
        let mut refined = 0;
        for (d, &pick) in dets.iter_mut().zip(&chosen) {
            if d.mask.is_some() {
                continue;
            }
            let found = if pick {
                refine_box(frame, &d.bbox, &self.cfg)?
            } else {
                None
            };
            refined += usize::from(found.is_some());
            // Clipped before it is rasterised: a box of any size costs at most the frame.
            let m = found
                .unwrap_or_else(|| Mask::from_bbox(&d.bbox.clipped(frame.width(), frame.height())));
            if !m.is_empty() {
                d.bbox = m.bbox();
                d.mask = Some(m);
            }
        }
        Ok(refined)
    }
}

impl Detector for BoxRefiner {
    fn detect(&mut self, frame: &Frame) -> Result<Vec<Detection>, DetectError> {
        let mut dets = std::mem::take(&mut self.boxes);
        self.refine_all(frame, &mut dets, None)?;
        Ok(dets)
    }
}
