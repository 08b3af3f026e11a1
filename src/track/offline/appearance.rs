//! Appearance snapshots: what the re-linker needs of the frames, kept during the online pass.
//!
//! The thesis compares SIFT keypoints of a slave track with its master. Keeping the whole video
//! in memory for that (a browser tab, a 10-minute 1080p clip) is not an option, and only two
//! appearances per track are ever compared: the slave's **last** and the master's **first**.
//! So while frames stream through the online pass, each reported shape's grey crop (and mask)
//! is stored as its track's last snapshot, and the first one stays as its first snapshot.
//! Crops are downscaled to a bounded side, so memory is `O(tracks)`, not `O(frames)`.
//!
//! A shape entering or leaving an occlusion is seen as a sliver, which has few keypoints and
//! matches nothing. So the "last" snapshot is only replaced by an appearance at least
//! [`RELIABLE`] times the track's recent size (a slowly decaying maximum), and the "first"
//! snapshot, taken in the frame the track is confirmed (the online tracker reports its
//! tentative frames later, when their images are gone), is replaced by any larger appearance
//! during the track's first [`FIRST_WINDOW`] reported frames, while it emerges.
//!
//! SIFT runs only at the end, and only on the snapshots of tracks that are candidates of some
//! join.
//!
//! A track's last snapshot is replaced in almost every frame it is seen, and downscaling a crop
//! (a triangle filter) cost more than the whole online frame (in wasm, at 1920×1080, ~9 of the
//! tracker's ~11 ms per frame). So a new last snapshot is kept as taken, at full size, until the
//! next frame ([`Snapshots::end_frame`]): replaced by then, it is dropped without ever being
//! downscaled; still the last one, it is downscaled then. The result is the same crop, downscaled
//! by the same filter, only fewer times; full-size crops are held only for the shapes of the
//! latest frame.

use crate::features::sift::{detect_and_compute, match_descriptors, SiftError, SiftFeatures};
use crate::frame::{Frame, Mask, TrackedShape};
use image::imageops::{self, FilterType};
use image::GrayImage;
use std::borrow::Cow;
use std::collections::BTreeMap;

use super::config::AppearanceConfig;

/// An appearance replaces the last snapshot only when its size `sqrt(w·h)` is at least this
/// fraction of the track's recent size.
pub const RELIABLE: f64 = 0.8;

/// Reported frames during which a larger appearance replaces the first snapshot.
pub const FIRST_WINDOW: u32 = 10;

/// Per frame, the track's recent size decays by this factor (then grows to any larger
/// appearance), so a track shrinking into the distance keeps updating its last snapshot.
const SIZE_DECAY: f64 = 0.97;

/// One stored appearance: a grey crop of the shape's box and, for mask shapes, its mask on the
/// same grid (255 = foreground).
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    /// Grey crop (BT.601 luma), at most `max_side` on its longer side.
    pub gray: GrayImage,
    /// Mask crop on the same grid, when the shape has a mask.
    pub mask: Option<GrayImage>,
    /// The shape's size `sqrt(w·h)` in the frame, pixels.
    pub size: f64,
}

impl Snapshot {
    /// The crop of `shape` in `frame`, downscaled so its longer side is at most `max_side`.
    /// `None` when the shape's box lies outside the frame.
    pub fn take(frame: &Frame<'_>, shape: &TrackedShape, max_side: u32) -> Option<Snapshot> {
        Some(Self::crop(frame, shape)?.downscaled(max_side))
    }

    /// The crop of `shape` in `frame` at full size. `None` when the shape's box lies outside
    /// the frame.
    fn crop(frame: &Frame<'_>, shape: &TrackedShape) -> Option<Snapshot> {
        let ((x0, y0, w, h), gray) = frame.gray_crop(&shape.bbox)?;
        let mask = shape.mask.as_ref().map(|m| mask_crop(m, (x0, y0, w, h)));
        let size = (shape.bbox.w.max(0.0) * shape.bbox.h.max(0.0)).sqrt();
        Some(Snapshot { gray, mask, size })
    }

    /// This crop downscaled so its longer side is at most `max_side` (unchanged when it
    /// already is).
    fn downscaled(self, max_side: u32) -> Snapshot {
        let (w, h) = self.gray.dimensions();
        let longest = w.max(h);
        if longest <= max_side.max(1) {
            return self;
        }
        let s = f64::from(max_side.max(1)) / f64::from(longest);
        let nw = ((f64::from(w) * s).round() as u32).max(1);
        let nh = ((f64::from(h) * s).round() as u32).max(1);
        Snapshot {
            gray: imageops::resize(&self.gray, nw, nh, FilterType::Triangle),
            mask: self
                .mask
                .map(|m| imageops::resize(&m, nw, nh, FilterType::Nearest)),
            size: self.size,
        }
    }

    /// SIFT keypoints and descriptors of the crop (inside the mask, when there is one).
    pub fn features(&self, cfg: &AppearanceConfig) -> Result<SiftFeatures, SiftError> {
        detect_and_compute(&self.gray, self.mask.as_ref(), &cfg.sift)
    }

    /// A 0×0 crop (a placeholder while an entry is replaced).
    fn empty() -> Snapshot {
        Snapshot {
            gray: GrayImage::new(0, 0),
            mask: None,
            size: 0.0,
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.gray.as_raw().len() + self.mask.as_ref().map_or(0, |m| m.as_raw().len())
    }
}

/// The part of `m` over the pixel rectangle `(x0, y0, w, h)` as a 0/255 image, copied a row
/// span at a time (a look-up per pixel was a third of the crop's time).
fn mask_crop(m: &Mask, (x0, y0, w, h): (u32, u32, u32, u32)) -> GrayImage {
    let (w_, h_) = (w as usize, h as usize);
    let mut out = vec![0u8; w_ * h_];
    let (mx, my, mw) = (i64::from(m.x()), i64::from(m.y()), i64::from(m.width()));
    // The columns of the rectangle the mask covers, in mask coordinates.
    let lx0 = (i64::from(x0) - mx).max(0);
    let lx1 = (i64::from(x0) + i64::from(w) - mx).min(mw);
    if lx1 > lx0 {
        let dst0 = (mx + lx0 - i64::from(x0)) as usize;
        let len = (lx1 - lx0) as usize;
        for (y, row) in out.chunks_exact_mut(w_.max(1)).enumerate() {
            let ly = i64::from(y0) + y as i64 - my;
            if ly < 0 || ly >= i64::from(m.height()) {
                continue;
            }
            let src = (ly * mw + lx0) as usize;
            for (d, &v) in row[dst0..dst0 + len]
                .iter_mut()
                .zip(&m.data()[src..src + len])
            {
                *d = if v != 0 { 255 } else { 0 };
            }
        }
    }
    GrayImage::from_raw(w, h, out).unwrap_or_else(|| GrayImage::new(w, h))
}

/// A track's last snapshot: downscaled, or as taken in the latest frame (module docs).
#[derive(Debug, Clone, PartialEq)]
enum Last {
    Scaled(Snapshot),
    /// Full size, taken in frame `frame` (counted by [`Snapshots::end_frame`]), to be
    /// downscaled to `max_side` unless replaced first.
    Taken {
        snap: Snapshot,
        max_side: u32,
        frame: u64,
    },
}

/// The first and last snapshot of every track seen so far.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Snapshots {
    first: BTreeMap<u64, Snapshot>,
    last: BTreeMap<u64, Last>,
    /// Per track: frames recorded, recent size.
    seen: BTreeMap<u64, (u32, f64)>,
    /// Frames ended so far ([`Snapshots::end_frame`]).
    frame: u64,
}

impl Snapshots {
    /// No snapshots.
    pub fn new() -> Self {
        Self::default()
    }

    /// Records `shape` seen in `frame` (module docs: when it replaces the first or the last
    /// snapshot). Crops are only taken when one of them is replaced.
    pub fn record(&mut self, frame: &Frame<'_>, shape: &TrackedShape, max_side: u32) {
        let size = (shape.bbox.w.max(0.0) * shape.bbox.h.max(0.0)).sqrt();
        let (count, recent) = self.seen.get(&shape.id).copied().unwrap_or((0, 0.0));
        let recent = size.max(recent * SIZE_DECAY);
        self.seen.insert(shape.id, (count + 1, recent));
        let first_wanted = match self.first.get(&shape.id) {
            None => true,
            Some(f) => count < FIRST_WINDOW && size > f.size,
        };
        let last_wanted = size >= RELIABLE * recent || !self.last.contains_key(&shape.id);
        if !(first_wanted || last_wanted) {
            return;
        }
        let Some(s) = Snapshot::crop(frame, shape) else {
            return;
        };
        if first_wanted {
            self.first.insert(shape.id, s.clone().downscaled(max_side));
        }
        if last_wanted {
            // Downscaled at the next frame's end, unless replaced before (module docs).
            let last = Last::Taken {
                snap: s,
                max_side,
                frame: self.frame,
            };
            self.last.insert(shape.id, last);
        }
    }

    /// Ends a frame whose shapes were all [`record`](Self::record)ed: the last snapshots taken
    /// before it and not replaced in it are downscaled now, so full-size crops are held only
    /// for the shapes of the latest frame.
    pub fn end_frame(&mut self) {
        for v in self.last.values_mut() {
            if matches!(v, Last::Taken { frame, .. } if *frame < self.frame) {
                let Last::Taken { snap, max_side, .. } =
                    std::mem::replace(v, Last::Scaled(Snapshot::empty()))
                else {
                    continue;
                };
                *v = Last::Scaled(snap.downscaled(max_side));
            }
        }
        self.frame += 1;
    }

    /// Sets a track's first snapshot (replacing any).
    pub fn set_first(&mut self, id: u64, s: Snapshot) {
        self.first.insert(id, s);
    }

    /// Sets a track's last snapshot (replacing any).
    pub fn set_last(&mut self, id: u64, s: Snapshot) {
        self.last.insert(id, Last::Scaled(s));
    }

    /// The first snapshot of track `id`.
    pub fn first(&self, id: u64) -> Option<&Snapshot> {
        self.first.get(&id)
    }

    /// The last snapshot of track `id` (downscaled here when it was taken in the latest
    /// frame, see [`Snapshots::end_frame`]).
    pub fn last(&self, id: u64) -> Option<Cow<'_, Snapshot>> {
        Some(match self.last.get(&id)? {
            Last::Scaled(s) => Cow::Borrowed(s),
            Last::Taken { snap, max_side, .. } => Cow::Owned(snap.clone().downscaled(*max_side)),
        })
    }

    /// Number of tracks with a snapshot.
    pub fn len(&self) -> usize {
        self.last.len()
    }

    /// Whether no snapshot was taken.
    pub fn is_empty(&self) -> bool {
        self.last.is_empty()
    }

    /// Bytes held by all crops.
    pub fn bytes(&self) -> usize {
        let last = self.last.values().map(|l| match l {
            Last::Scaled(s) | Last::Taken { snap: s, .. } => s,
        });
        self.first.values().chain(last).map(Snapshot::bytes).sum()
    }
}

/// Lazily computed SIFT features of snapshots, so each is detected at most once.
pub(crate) struct FeatureCache<'a> {
    snapshots: &'a Snapshots,
    cfg: &'a AppearanceConfig,
    first: BTreeMap<u64, Option<SiftFeatures>>,
    last: BTreeMap<u64, Option<SiftFeatures>>,
}

impl<'a> FeatureCache<'a> {
    pub(crate) fn new(snapshots: &'a Snapshots, cfg: &'a AppearanceConfig) -> Self {
        Self {
            snapshots,
            cfg,
            first: BTreeMap::new(),
            last: BTreeMap::new(),
        }
    }

    fn get(
        cache: &mut BTreeMap<u64, Option<SiftFeatures>>,
        snap: Option<&Snapshot>,
        id: u64,
        cfg: &AppearanceConfig,
    ) -> Result<(), SiftError> {
        if let std::collections::btree_map::Entry::Vacant(e) = cache.entry(id) {
            e.insert(snap.map(|s| s.features(cfg)).transpose()?);
        }
        Ok(())
    }

    /// SIFT connections (ratio-test matches) from `slave`'s last snapshot to `master`'s first;
    /// `None` when either has no snapshot.
    pub(crate) fn connections(
        &mut self,
        slave: u64,
        master: u64,
    ) -> Result<Option<usize>, SiftError> {
        let last = self.snapshots.last(slave);
        Self::get(&mut self.last, last.as_deref(), slave, self.cfg)?;
        Self::get(
            &mut self.first,
            self.snapshots.first(master),
            master,
            self.cfg,
        )?;
        let (Some(Some(a)), Some(Some(b))) = (self.last.get(&slave), self.first.get(&master))
        else {
            return Ok(None);
        };
        Ok(Some(match_descriptors(a, b, &self.cfg.matching).len()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{Point, TrackState};
    use crate::synth::{Scene, SynthConfig};

    /// Deferred downscaling keeps exactly the snapshots that downscaling every crop when it is
    /// taken keeps (the rules of `record`, written out again here with `Snapshot::take`), and
    /// after each frame only that frame's shapes are held at full size.
    #[test]
    fn deferred_snapshots_are_the_eager_ones() {
        let max_side = 24;
        let mut deferred = Snapshots::new();
        let mut first: BTreeMap<u64, Snapshot> = BTreeMap::new();
        let mut last: BTreeMap<u64, Snapshot> = BTreeMap::new();
        let mut seen: BTreeMap<u64, (u32, f64)> = BTreeMap::new();
        let cfg = SynthConfig {
            frames: 60,
            ..SynthConfig::with_seed(5)
        };
        let mut settled = 0;
        for f in Scene::new(cfg).unwrap() {
            let frame = Frame::rgb(&f.image, f.width, f.height).unwrap();
            // Every other object skips odd frames, so some last snapshots outlive their frame.
            let shown = f.gt.iter().filter(|g| g.id % 2 == 0 || f.index % 2 == 0);
            let mut now = Vec::new();
            for g in shown {
                let shape = TrackedShape {
                    id: g.id,
                    frame: f.index,
                    bbox: g.bbox,
                    mask: Some(g.mask.clone()),
                    centroid: Point::new(0.0, 0.0),
                    state: TrackState::Confirmed,
                    score: 1.0,
                    class: -1,
                    cost: 0.0,
                    det_index: None,
                    interpolated: false,
                };
                deferred.record(&frame, &shape, max_side);
                now.push(g.id);
                let size = (g.bbox.w * g.bbox.h).sqrt();
                let (count, recent) = seen.get(&g.id).copied().unwrap_or((0, 0.0));
                let recent = size.max(recent * SIZE_DECAY);
                seen.insert(g.id, (count + 1, recent));
                let first_wanted = first
                    .get(&g.id)
                    .is_none_or(|s| count < FIRST_WINDOW && size > s.size);
                let last_wanted = size >= RELIABLE * recent || !last.contains_key(&g.id);
                if let (true, Some(s)) = (
                    first_wanted || last_wanted,
                    Snapshot::take(&frame, &shape, max_side),
                ) {
                    if first_wanted {
                        first.insert(g.id, s.clone());
                    }
                    if last_wanted {
                        last.insert(g.id, s);
                    }
                }
            }
            // Read before the frame ends, too: the last snapshots taken in it are downscaled
            // on demand.
            for (id, s) in &last {
                assert_eq!(deferred.last(*id).as_deref(), Some(s), "frame {}", f.index);
            }
            deferred.end_frame();
            for (id, l) in &deferred.last {
                match l {
                    Last::Taken { .. } => assert!(now.contains(id), "{id} kept at full size"),
                    Last::Scaled(_) if now.contains(id) => {}
                    Last::Scaled(_) => settled += 1,
                }
            }
            for (id, s) in &first {
                assert_eq!(deferred.first(*id), Some(s));
            }
            assert_eq!(deferred.len(), last.len());
        }
        assert!(settled > 0, "some snapshots outlived their frame");
        assert!(first.len() > 5);
    }

    /// The row-span mask crop is the per-pixel look-up, for rectangles inside, across and
    /// beyond a mask.
    #[test]
    fn mask_crop_is_the_pixel_lookup() {
        let data: Vec<u8> = (0..35 * 20)
            .map(|i| u8::from(i % 7 < 3 || i % 11 == 0))
            .collect();
        let m = Mask::new(12, -4, 35, 20, data).unwrap();
        for rect in [
            (0, 0, 60, 30),
            (15, 2, 10, 5),
            (40, 10, 20, 20),
            (0, 20, 5, 5),
            (46, 0, 1, 16),
        ] {
            let want = GrayImage::from_fn(rect.2, rect.3, |x, y| {
                image::Luma([u8::from(m.get((rect.0 + x) as i32, (rect.1 + y) as i32)) * 255])
            });
            assert_eq!(mask_crop(&m, rect), want, "{rect:?}");
        }
    }
}
