//! Where an [`OfflineTracker`](super::OfflineTracker) keeps the online output until the offline
//! pass: the shapes as they are ([`Vec<TrackedShape>`], masks as bitmaps, the default), or with
//! their masks packed as COCO RLE strings ([`RleHistory`]).
//!
//! A mask bitmap is the size of its box; its packed RLE is about a byte per run. What keeps a
//! long video's output in memory (the browser app, the CLI's `--offline`) keeps packed RLE: the
//! offline pass decodes only the masks a fill carries (the ends of runs of frames) and reads
//! every shape's area from its RLE, so it decides as it does over bitmaps, and the result's
//! masks are matched back to the packed ones ([`KeptMasks`]) without decoding them.

use super::OfflineResult;
use crate::frame::TrackedShape;
use crate::io::{PackedRle, Rle};
use std::collections::{HashMap, HashSet};

/// The online output as the offline stages read it: the shapes, and each shape's mask area
/// (pixels; `None` for a box). The area is kept apart from the mask because a compact store
/// carries the bitmaps of the ends of each track's runs of frames only (the fill carries those
/// along a gap), while the fill's hide test reads the areas of shapes near a gap's ends.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct OfflineInput {
    pub(super) shapes: Vec<TrackedShape>,
    pub(super) mask_areas: Vec<Option<u64>>,
}

impl OfflineInput {
    /// The shapes as they are, areas from their masks.
    pub fn from_shapes(shapes: Vec<TrackedShape>) -> Self {
        let mask_areas = shapes
            .iter()
            .map(|s| s.mask.as_ref().map(|m| m.area()))
            .collect();
        Self { shapes, mask_areas }
    }

    /// Adds one shape whose mask (absent from `shape` or not) has `mask_area` pixels.
    pub fn push(&mut self, shape: TrackedShape, mask_area: Option<u64>) {
        self.shapes.push(shape);
        self.mask_areas.push(mask_area);
    }

    /// The shapes.
    pub fn shapes(&self) -> &[TrackedShape] {
        &self.shapes
    }

    /// The mask areas, one per shape.
    pub fn mask_areas(&self) -> &[Option<u64>] {
        &self.mask_areas
    }
}

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
    fn offline_input(&self) -> OfflineInput;
    /// The same, consuming the store (no copy where it holds the shapes as they are).
    fn into_offline_input(self) -> OfflineInput {
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

    fn offline_input(&self) -> OfflineInput {
        OfflineInput::from_shapes(self.clone())
    }

    fn into_offline_input(self) -> OfflineInput {
        OfflineInput::from_shapes(self)
    }
}

/// One kept shape: the shape without its mask bitmap, and the mask as packed RLE of the
/// whole image.
#[derive(Debug, Clone, PartialEq)]
pub struct RleShape {
    /// The shape; its `mask` is `None` (the mask is in `packed`).
    pub shape: TrackedShape,
    /// The shape's mask, when it has one.
    pub packed: Option<PackedRle>,
}

impl RleShape {
    /// Keeps `shape` with its mask encoded for a `width × height` image.
    pub fn new(mut shape: TrackedShape, width: u32, height: u32) -> Self {
        let packed = shape
            .mask
            .take()
            .map(|m| PackedRle::new(&Rle::from_mask(&m, width, height)));
        Self { shape, packed }
    }

    /// The mask as RLE, when the shape has one.
    pub fn rle(&self) -> Option<Rle> {
        self.packed.as_ref().map(PackedRle::unpack)
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

    /// Masks are decoded only for observed shapes at the end of a run of consecutive observed
    /// frames of their track: gap filling carries the mask of a gap's end along the path, so
    /// the whole video's masks never sit in memory as bitmaps at once. Every shape's mask area
    /// comes from its RLE (the fill's hide test), so the offline pass decides as it does over
    /// the bitmaps.
    fn offline_input(&self) -> OfflineInput {
        let mut input = OfflineInput::default();
        for (k, end) in self.shapes.iter().zip(self.run_ends()) {
            let (s, area) = input_shape(k.shape.clone(), k.packed.as_ref(), end);
            input.push(s, area);
        }
        input
    }

    fn into_offline_input(self) -> OfflineInput {
        self.into_parts().0
    }
}

/// A kept shape as the offline pass reads it: its mask decoded when it ends a run of frames
/// (`end`, see `RleHistory::run_ends`), and its mask area either way.
fn input_shape(
    mut shape: TrackedShape,
    packed: Option<&PackedRle>,
    end: bool,
) -> (TrackedShape, Option<u64>) {
    if end {
        shape.mask = packed.map(|p| p.unpack().to_mask());
    }
    (shape, packed.map(PackedRle::area))
}

/// The masks of an [`RleHistory`] set apart by [`RleHistory::into_parts`], to be matched to
/// the offline result's shapes without decoding them.
#[derive(Debug, Clone, Default)]
pub struct KeptMasks {
    /// Observed shapes' masks by (frame, detection index): unique within a frame.
    observed: HashMap<(u32, usize), PackedRle>,
    /// Coasted shapes' masks by (online id, frame), with their boxes.
    coasted: HashMap<(u64, u32), Vec<(crate::frame::BBox, PackedRle)>>,
}

impl KeptMasks {
    /// The mask of each shape of `result` (the offline pass over the history these masks
    /// came from), aligned with `result.shapes`: an observed shape takes the mask kept for its
    /// detection, a coasted one the mask kept for its online identity (re-identified through
    /// the joins), frame and box, a filled one its own bitmap, packed for an image of
    /// `image_size`. `None` for shapes without a mask.
    pub fn resolve(
        mut self,
        result: &OfflineResult,
        image_size: Option<(u32, u32)>,
    ) -> Vec<Option<PackedRle>> {
        let map = result.id_map();
        let mut coasted: HashMap<(u64, u32), Vec<(crate::frame::BBox, PackedRle)>> = HashMap::new();
        for ((id, f), v) in self.coasted.drain() {
            let root = map.get(&id).copied().unwrap_or(id);
            coasted.entry((root, f)).or_default().extend(v);
        }
        let (w, h) = image_size.unwrap_or((0, 0));
        result
            .shapes
            .iter()
            .map(|s| {
                let kept = match (s.interpolated, s.det_index) {
                    (false, Some(d)) => self.observed.remove(&(s.frame, d)),
                    _ => coasted.get_mut(&(s.id, s.frame)).and_then(|v| {
                        let i = v.iter().position(|(b, _)| *b == s.bbox)?;
                        Some(v.swap_remove(i).1)
                    }),
                };
                kept.or_else(|| {
                    s.mask
                        .as_ref()
                        .map(|m| PackedRle::new(&Rle::from_mask(m, w, h)))
                })
            })
            .collect()
    }
}

impl RleHistory {
    /// Splits the history into the offline pass's input (see [`History::offline_input`],
    /// built without copying the shapes) and the masks, kept packed for writing the result.
    pub fn into_parts(self) -> (OfflineInput, KeptMasks) {
        let ends = self.run_ends();
        let mut input = OfflineInput::default();
        let mut kept = KeptMasks::default();
        for (k, end) in self.shapes.into_iter().zip(ends) {
            let RleShape { shape, packed } = k;
            let (shape, area) = input_shape(shape, packed.as_ref(), end);
            if let Some(p) = packed {
                match (shape.interpolated, shape.det_index) {
                    (false, Some(d)) => {
                        kept.observed.entry((shape.frame, d)).or_insert(p);
                    }
                    _ => kept
                        .coasted
                        .entry((shape.id, shape.frame))
                        .or_default()
                        .push((shape.bbox, p)),
                }
            }
            input.push(shape, area);
        }
        (input, kept)
    }

    /// For each kept shape, whether its mask is decoded for the offline pass: observed shapes
    /// at the end of a run of consecutive observed frames of their track (gap filling carries
    /// the mask of a gap's end along the path). Coasted shapes (interpolated) are not
    /// observations: an observed shape beside one still ends a run.
    fn run_ends(&self) -> Vec<bool> {
        let observed: HashSet<(u64, u32)> = self
            .shapes
            .iter()
            .filter(|k| !k.shape.interpolated)
            .map(|k| (k.shape.id, k.shape.frame))
            .collect();
        self.shapes
            .iter()
            .map(|k| {
                let (id, f) = (k.shape.id, k.shape.frame);
                !k.shape.interpolated
                    && (f <= 1
                        || !observed.contains(&(id, f - 1))
                        || !observed.contains(&(id, f.saturating_add(1))))
            })
            .collect()
    }

    /// Applies an offline result to the online output a front end has already shown, in
    /// place: ids become the joined identities', the online pass's coasted shapes stay (they
    /// were shown) except where an observation of the joined identity covers their frame,
    /// and the shapes the pass filled in are added where nothing was shown. Returns the added
    /// shapes (masks encoded for `image_size`); the history ends sorted by (frame, id).
    /// Observed shapes take the pass's boxes (smoothed over their track, [`super::smooth`]).
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
        // Observed shapes take the offline pass's boxes (smoothed over their whole track).
        // `result.shapes` is sorted by (frame, id).
        let observed = |s: &&crate::frame::TrackedShape| !s.interpolated;
        let boxes: Vec<_> = result.shapes.iter().filter(observed).collect();
        for k in self.shapes.iter_mut().filter(|k| !k.shape.interpolated) {
            let key = (k.shape.frame, k.shape.id);
            if let Ok(i) = boxes.binary_search_by_key(&key, |s| (s.frame, s.id)) {
                let b = boxes[i].bbox;
                k.shape.bbox = b;
                if k.packed.is_none() {
                    k.shape.centroid = b.center();
                }
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
