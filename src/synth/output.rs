//! What a scene produces per frame: the rendered image with its ground truth and detections
//! ([`SynthFrame`], [`GtObject`]), and their conversion to records.

use super::ShapeKind;
use crate::frame::{BBox, Detection, Frame, FrameError, Mask};
use crate::io::{Record, RecordFlags, Rle};
use serde::{Deserialize, Serialize};

/// One object's ground truth in one frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GtObject {
    /// Object id (1-based, never reused within a scene).
    pub id: u64,
    /// Outline family.
    pub kind: ShapeKind,
    /// Visible pixels (never empty; disjoint from every other object's in the frame).
    pub mask: Mask,
    /// Tight box of `mask`.
    pub bbox: BBox,
    /// Visible pixels over the full silhouette's pixels, in `(0, 1]`.
    pub visibility: f64,
    /// Pixels of the full silhouette (unclipped, unoccluded).
    pub full_area: u64,
    /// The colours the object's texture uses.
    pub palette: Vec<[u8; 3]>,
}

/// One object's whole silhouette in one frame, hidden or not: the amodal ground truth.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Silhouette {
    /// Object id.
    pub id: u64,
    /// Box of the whole silhouette (occluded parts included), clipped to the frame.
    pub bbox: BBox,
    /// Visible pixels over the full silhouette's pixels, in `[0, 1]` (0: fully hidden).
    pub visibility: f64,
}

/// One rendered frame with its ground truth and detections.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthFrame {
    /// Frame number, 1-based.
    pub index: u32,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// RGB8 pixels, row-major, `3·width` bytes per row.
    pub image: Vec<u8>,
    /// Ground truth of the visible objects, by increasing id.
    pub gt: Vec<GtObject>,
    /// Every object with part of its silhouette inside the frame, visible or fully hidden,
    /// by increasing id: the amodal ground truth.
    pub silhouettes: Vec<Silhouette>,
    /// Noisy mask detections (each with its mask's tight box), object detections first (by id)
    /// then false positives.
    pub detections: Vec<Detection>,
    /// For each detection, the id of the object it came from (`None` for false positives).
    pub detection_sources: Vec<Option<u64>>,
    /// Box-only variant of `detections` (same order, same scores): jittered boxes, no masks.
    pub box_detections: Vec<Detection>,
}

impl SynthFrame {
    /// A borrowed RGB view of the image.
    pub fn frame(&self) -> Result<Frame<'_>, FrameError> {
        Frame::rgb(&self.image, self.width, self.height)
    }

    /// Ground truth as records: class 1, score 1 ("consider"), visibility, mask as RLE.
    pub fn gt_records(&self) -> Vec<Record> {
        self.gt
            .iter()
            .map(|g| Record {
                frame: self.index,
                id: g.id as i64,
                bbox: g.bbox,
                score: 1.0,
                class: 1,
                visibility: g.visibility,
                mask: Some(Rle::from_mask(&g.mask, self.width, self.height)),
                flags: RecordFlags::default(),
            })
            .collect()
    }

    /// Amodal ground truth as records, as the MOTChallenge pedestrian benchmarks annotate:
    /// one per [`Silhouette`] (fully hidden objects included, visibility 0), the box of the
    /// whole silhouette, class 1, score 1, and the **visible** pixels as the mask when there
    /// are any (what a segmenter could report; the evaluation scores boxes).
    pub fn amodal_gt_records(&self) -> Vec<Record> {
        self.silhouettes
            .iter()
            .map(|s| {
                let mask = visible_in(&self.gt, s.id)
                    .map(|g| Rle::from_mask(&g.mask, self.width, self.height));
                Record {
                    frame: self.index,
                    id: s.id as i64,
                    bbox: s.bbox,
                    score: 1.0,
                    class: 1,
                    visibility: s.visibility,
                    mask,
                    flags: RecordFlags::default(),
                }
            })
            .collect()
    }

    /// Mask detections as records: id -1, class -1, the detection's score, mask as RLE.
    pub fn detection_records(&self) -> Vec<Record> {
        self.detections
            .iter()
            .map(|d| Record {
                frame: self.index,
                id: -1,
                bbox: d.bbox,
                score: d.score,
                class: -1,
                visibility: -1.0,
                mask: d
                    .mask
                    .as_ref()
                    .map(|m| Rle::from_mask(m, self.width, self.height)),
                flags: RecordFlags::default(),
            })
            .collect()
    }

    /// Box-only detections as records: id -1, class -1, the score, no mask.
    pub fn box_detection_records(&self) -> Vec<Record> {
        self.box_detections
            .iter()
            .map(|d| Record {
                frame: self.index,
                id: -1,
                bbox: d.bbox,
                score: d.score,
                class: -1,
                visibility: -1.0,
                mask: None,
                flags: RecordFlags::default(),
            })
            .collect()
    }
}

/// Object `id`'s entry in `gt` (by increasing id), if it is there.
pub(super) fn visible_in(gt: &[GtObject], id: u64) -> Option<&GtObject> {
    gt.binary_search_by_key(&id, |g| g.id).ok().map(|k| &gt[k])
}
