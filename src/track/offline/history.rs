//! Where an [`OfflineTracker`](super::OfflineTracker) keeps the online output until the offline
//! pass: the shapes as they are ([`Vec<TrackedShape>`], masks as bitmaps, the default), or with
//! their masks as COCO RLE ([`RleHistory`]).
//!
//! A mask bitmap is the size of its box; its RLE is a few hundred bytes. A front end that keeps
//! a long video's output in memory (the browser app) keeps RLE, and the offline pass decodes
//! only the masks it reads.

use super::OfflineResult;
use crate::frame::TrackedShape;
use crate::io::Rle;
use std::collections::HashSet;

/// A store for the online pass's shapes.
pub trait History: Default {
    /// What is kept per shape.
    type Item;
    /// Keeps one shape the online pass reported. `image_size` is the frame size when known
    /// (an RLE covers the whole image).
    fn push(&mut self, shape: TrackedShape, image_size: Option<(u32, u32)>);
    /// Everything kept, in the order pushed.
    fn items(&self) -> &[Self::Item];
    /// The shapes the offline stages read.
    fn offline_input(&self) -> Vec<TrackedShape>;
    /// The same, consuming the store (no copy where it holds the shapes as they are).
    fn into_offline_input(self) -> Vec<TrackedShape> {
        self.offline_input()
    }
}

impl History for Vec<TrackedShape> {
    type Item = TrackedShape;

    fn push(&mut self, shape: TrackedShape, _: Option<(u32, u32)>) {
        Vec::push(self, shape);
    }

    fn items(&self) -> &[TrackedShape] {
        self
    }

    fn offline_input(&self) -> Vec<TrackedShape> {
        self.clone()
    }

    fn into_offline_input(self) -> Vec<TrackedShape> {
        self
    }
}

/// One kept shape: the shape without its mask bitmap, and the mask as RLE of the whole image.
#[derive(Debug, Clone, PartialEq)]
pub struct RleShape {
    /// The shape; its `mask` is `None` (the mask is in `rle`).
    pub shape: TrackedShape,
    /// The shape's mask, when it has one.
    pub rle: Option<Rle>,
}

impl RleShape {
    /// Keeps `shape` with its mask encoded for a `width × height` image.
    pub fn new(mut shape: TrackedShape, width: u32, height: u32) -> Self {
        let rle = shape.mask.take().map(|m| Rle::from_mask(&m, width, height));
        Self { shape, rle }
    }
}

/// The online output with masks as RLE (see the module docs).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RleHistory {
    shapes: Vec<RleShape>,
}

impl History for RleHistory {
    type Item = RleShape;

    /// Without an image size, masks are encoded for a 0 × 0 image (empty): give the size first.
    fn push(&mut self, shape: TrackedShape, image_size: Option<(u32, u32)>) {
        let (w, h) = image_size.unwrap_or((0, 0));
        self.shapes.push(RleShape::new(shape, w, h));
    }

    fn items(&self) -> &[RleShape] {
        &self.shapes
    }

    /// Masks are decoded only for shapes at the end of a run of consecutive frames of their
    /// track: gap filling carries the mask of a gap's end along the path, so the whole video's
    /// masks never sit in memory as bitmaps at once. The fill's hide check also reads the
    /// mask areas of shapes near a gap's ends; without them it sees fewer hides than over
    /// bitmaps, and fills such gaps (what the browser has always done).
    fn offline_input(&self) -> Vec<TrackedShape> {
        let present: HashSet<(u64, u32)> = self
            .shapes
            .iter()
            .map(|k| (k.shape.id, k.shape.frame))
            .collect();
        self.shapes
            .iter()
            .map(|k| {
                let (id, f) = (k.shape.id, k.shape.frame);
                let end = f <= 1
                    || !present.contains(&(id, f - 1))
                    || !present.contains(&(id, f.saturating_add(1)));
                let mut s = k.shape.clone();
                if end {
                    s.mask = k.rle.as_ref().map(Rle::to_mask);
                }
                s
            })
            .collect()
    }
}

impl RleHistory {
    /// Applies an offline result to the online output a front end has already shown, in
    /// place: ids become the joined identities', the online pass's coasted shapes stay (they
    /// were shown) except where an observation of the joined identity covers their frame,
    /// and the shapes the pass filled in are added where nothing was shown. Returns the added
    /// shapes (masks encoded for `image_size`); the history ends sorted by (frame, id).
    ///
    /// This differs from [`OfflineResult::shapes`], which also drops coasted shapes a fill
    /// replaces or that trail an identity's last observation: a page does not take back what
    /// it showed.
    pub fn apply(
        &mut self,
        result: &OfflineResult,
        image_size: Option<(u32, u32)>,
    ) -> Vec<RleShape> {
        let map = result.id_map();
        let (w, h) = image_size.unwrap_or((0, 0));
        for k in &mut self.shapes {
            if let Some(&root) = map.get(&k.shape.id) {
                k.shape.id = root;
            }
        }
        // A join may be made over a slave's coasted tail (the pass ignores coasted shapes):
        // where that tail now meets the master's observed shape, the observation stays.
        let observed: HashSet<(u64, u32)> = self
            .shapes
            .iter()
            .filter(|k| !k.shape.interpolated)
            .map(|k| (k.shape.id, k.shape.frame))
            .collect();
        self.shapes
            .retain(|k| !(k.shape.interpolated && observed.contains(&(k.shape.id, k.shape.frame))));
        // Only the gaps the offline pass filled where nothing was shown are new.
        let present: HashSet<(u64, u32)> = self
            .shapes
            .iter()
            .map(|k| (k.shape.id, k.shape.frame))
            .collect();
        let added: Vec<RleShape> = result
            .shapes
            .iter()
            .filter(|s| s.interpolated && !present.contains(&(s.id, s.frame)))
            .map(|s| RleShape::new(s.clone(), w, h))
            .collect();
        self.shapes.extend(added.iter().cloned());
        self.shapes.sort_by_key(|k| (k.shape.frame, k.shape.id));
        added
    }
}
