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

use crate::features::sift::{detect_and_compute, match_descriptors, SiftError, SiftFeatures};
use crate::frame::{Frame, TrackedShape};
use image::imageops::{self, FilterType};
use image::{GrayImage, Luma};
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
        let ((x0, y0, w, h), gray) = frame.gray_crop(&shape.bbox)?;
        let mask = shape.mask.as_ref().map(|m| {
            GrayImage::from_fn(w, h, |x, y| {
                Luma([u8::from(m.get((x0 + x) as i32, (y0 + y) as i32)) * 255])
            })
        });
        let size = (shape.bbox.w.max(0.0) * shape.bbox.h.max(0.0)).sqrt();
        let longest = w.max(h);
        if longest <= max_side.max(1) {
            return Some(Snapshot { gray, mask, size });
        }
        let s = f64::from(max_side.max(1)) / f64::from(longest);
        let nw = ((f64::from(w) * s).round() as u32).max(1);
        let nh = ((f64::from(h) * s).round() as u32).max(1);
        Some(Snapshot {
            gray: imageops::resize(&gray, nw, nh, FilterType::Triangle),
            mask: mask.map(|m| imageops::resize(&m, nw, nh, FilterType::Nearest)),
            size,
        })
    }

    /// SIFT keypoints and descriptors of the crop (inside the mask, when there is one).
    pub fn features(&self, cfg: &AppearanceConfig) -> Result<SiftFeatures, SiftError> {
        detect_and_compute(&self.gray, self.mask.as_ref(), &cfg.sift)
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.gray.as_raw().len() + self.mask.as_ref().map_or(0, |m| m.as_raw().len())
    }
}

/// The first and last snapshot of every track seen so far.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Snapshots {
    first: BTreeMap<u64, Snapshot>,
    last: BTreeMap<u64, Snapshot>,
    /// Per track: frames recorded, recent size.
    seen: BTreeMap<u64, (u32, f64)>,
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
        let Some(s) = Snapshot::take(frame, shape, max_side) else {
            return;
        };
        if first_wanted {
            self.first.insert(shape.id, s.clone());
        }
        if last_wanted {
            self.last.insert(shape.id, s);
        }
    }

    /// Sets a track's first snapshot (replacing any).
    pub fn set_first(&mut self, id: u64, s: Snapshot) {
        self.first.insert(id, s);
    }

    /// Sets a track's last snapshot (replacing any).
    pub fn set_last(&mut self, id: u64, s: Snapshot) {
        self.last.insert(id, s);
    }

    /// The first snapshot of track `id`.
    pub fn first(&self, id: u64) -> Option<&Snapshot> {
        self.first.get(&id)
    }

    /// The last snapshot of track `id`.
    pub fn last(&self, id: u64) -> Option<&Snapshot> {
        self.last.get(&id)
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
        self.first
            .values()
            .chain(self.last.values())
            .map(Snapshot::bytes)
            .sum()
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
        Self::get(&mut self.last, self.snapshots.last(slave), slave, self.cfg)?;
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
