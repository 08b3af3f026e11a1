//! The tracker: online updates, the kept history, and the offline pass at the end.

use super::*;
use crate::frame::{TrackState, TrackedShape};
use crate::io::{Record, Rle};
use crate::track::offline::{self, OfflineConfig, Progress, SequenceInfo, Snapshots};
use crate::track::{Config as TrackConfig, Tracker as CoreTracker};
use serde::Serialize;
use tsify::{Ts, Tsify};
use wasm_bindgen::prelude::*;
use wasm_bindgen::JsCast;

/// One tracked shape as the tracker reports it: a record plus the tracker's own fields.
#[derive(Debug, Clone, PartialEq, Serialize, Tsify)]
pub struct ShapeJs {
    /// 1-based frame number.
    pub frame: u32,
    /// Track id (unique within this tracker, from 1).
    pub id: i64,
    /// Bounding box.
    pub bbox: BoxJs,
    /// Detection score.
    pub score: f64,
    /// Class label (-1 when unknown).
    pub class: i32,
    /// Mask as compressed RLE over the frame, when the detection had one.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub mask: Option<RleJs>,
    /// Filled in by the offline pass rather than detected.
    pub interpolated: bool,
    /// Lifecycle state.
    #[tsify(type = "\"tentative\" | \"confirmed\" | \"lost\" | \"removed\"")]
    pub state: TrackState,
    /// Centroid (mask moments or box centre).
    pub centroid: PointJs,
    /// Matching cost that attached the detection (0 for a new track).
    pub cost: f64,
}

impl ShapeJs {
    fn new(s: &TrackedShape, rle: Option<&Rle>) -> Self {
        ShapeJs {
            frame: s.frame,
            id: s.id as i64,
            bbox: s.bbox.into(),
            score: s.score,
            class: s.class,
            mask: rle.map(RleJs::from),
            interpolated: s.interpolated,
            state: s.state,
            centroid: s.centroid.into(),
            cost: s.cost,
        }
    }
}

/// The shapes one update reports.
#[derive(Debug, Clone, PartialEq, Serialize, Tsify)]
#[serde(transparent)]
pub struct Shapes(pub Vec<ShapeJs>);

/// One reported shape as the tracker keeps it: the shape without its mask bitmap, and the
/// mask as RLE (a few hundred bytes instead of a bitmap the size of the box), so a long video's
/// history stays small.
#[derive(Debug, Clone)]
pub(super) struct Kept {
    shape: TrackedShape,
    rle: Option<Rle>,
}

impl Kept {
    fn record(&self) -> Record {
        let mut r = Record::from_tracked(&self.shape, None);
        r.mask = self.rle.clone();
        r
    }
}

/// What a tracker built with offline options keeps for the offline pass besides its history.
pub(super) struct OfflineState {
    config: OfflineConfig,
    fps: f64,
    /// Image size from the options (box mode); frames override it.
    size: Option<(u32, u32)>,
    /// Each track's first and last appearance, taken while the frames stream past.
    snapshots: Snapshots,
}

/// The tracker. Owns its ids (two trackers on a page never share a counter) and keeps every
/// reported shape, so the whole result can be read back or exported at any time.
///
/// Built with offline options (`new Tracker(config, { fps })`) it also keeps what the offline
/// pass needs, and `finish()` runs that pass (thesis ch. 5: trajectory re-linking across
/// occlusions, then gap filling) over every frame tracked so far.
#[wasm_bindgen]
pub struct Tracker {
    inner: CoreTracker,
    /// Everything reported so far; after `finish`, the offline result.
    history: Vec<Kept>,
    /// Frame size, known from the first frame (masks need it for RLE).
    size: Option<(u32, u32)>,
    /// Present when the tracker was built for the offline pass.
    offline: Option<OfflineState>,
    /// `finish` ran: the history is final and no frame may follow.
    finished: bool,
}

#[wasm_bindgen]
impl Tracker {
    /// A tracker with the core's defaults, or with the given settings over them. With
    /// `offline` options it can run the offline pass at the end (`finish`).
    #[wasm_bindgen(constructor)]
    pub fn new(
        config: Option<Ts<TrackerConfig>>,
        offline: Option<Ts<OfflineOptions>>,
    ) -> Result<Tracker, JsValue> {
        let cfg = match config {
            Some(c) => settings(c)?.to_core()?,
            None => TrackConfig::default(),
        };
        let offline = match offline {
            Some(o) => {
                let o = settings(o)?;
                if !(o.fps.is_finite() && o.fps > 0.0) {
                    return Err(js_error(BindingError::Option {
                        name: "fps",
                        message: format!("{} (must be a finite number > 0)", o.fps),
                    }));
                }
                let size = match (o.width, o.height) {
                    (Some(w), Some(h)) => Some((w, h)),
                    (None, None) => None,
                    _ => {
                        return Err(js_error(BindingError::Option {
                            name: "width/height",
                            message: "give both or neither".to_string(),
                        }))
                    }
                };
                Some(OfflineState {
                    config: o.to_core(cfg.clone())?,
                    fps: o.fps,
                    size,
                    snapshots: Snapshots::new(),
                })
            }
            None => None,
        };
        Ok(Tracker {
            inner: CoreTracker::new(cfg).map_err(js_error)?,
            history: Vec::new(),
            size: None,
            offline,
            finished: false,
        })
    }

    /// Number of frames tracked so far.
    #[wasm_bindgen(getter)]
    pub fn frame(&self) -> u32 {
        self.inner.frame()
    }

    /// Whether this tracker can run the offline pass (it was built with offline options).
    #[wasm_bindgen(getter)]
    pub fn offline(&self) -> bool {
        self.offline.is_some()
    }

    /// Whether the offline pass has run (the result is final; no frame may follow).
    #[wasm_bindgen(getter)]
    pub fn finished(&self) -> bool {
        self.finished
    }

    /// Tracks frame `frame` (1-based; must be the next one) with its pixels and detections.
    /// Returns the online shapes this frame produced.
    pub fn update(
        &mut self,
        frame: f64,
        buf: &FrameBuffer,
        detections: &Detections,
    ) -> Result<Ts<Shapes>, JsValue> {
        let frame = whole_u32("frame", frame)?;
        self.check_next(frame)?;
        self.check_size(buf.width(), buf.height())?;
        let image = buf.frame()?;
        let shapes = self
            .inner
            .update(Some(&image), &detections.inner)
            .map_err(js_error)?;
        if let Some(off) = self.offline.as_mut() {
            if off.config.appearance.enabled {
                // Only shapes seen in this frame: a track confirmed now also reports its
                // tentative frames, whose pixels are gone.
                let now = self.inner.frame();
                for s in shapes.iter().filter(|s| s.frame == now) {
                    off.snapshots
                        .record(&image, s, off.config.appearance.max_side);
                }
            }
        }
        self.report(shapes)
    }

    /// Tracks frame `frame` from detections only (box mode: no pixels, e.g. a `det.txt`).
    #[wasm_bindgen(js_name = updateDetections)]
    pub fn update_detections(
        &mut self,
        frame: f64,
        detections: &Detections,
    ) -> Result<Ts<Shapes>, JsValue> {
        let frame = whole_u32("frame", frame)?;
        self.check_next(frame)?;
        // Shapes are reported as RLE of the whole image: without its size a mask would come
        // back empty (`size: [0, 0]`), so refuse before anything changes.
        if self.image_size().is_none() && detections.inner.iter().any(|d| d.mask.is_some()) {
            return Err(js_error(BindingError::Invalid(
                "mask detections without a frame need the image size: pass width and height \
                 in the tracker's options, or call update with a frame first"
                    .to_string(),
            )));
        }
        let shapes = self
            .inner
            .update(None, &detections.inner)
            .map_err(js_error)?;
        self.report(shapes)
    }

    /// Every shape reported so far, as records (by frame, then id); after `finish`, the
    /// offline result.
    pub fn tracks(&self) -> Result<Ts<Records>, JsValue> {
        let mut recs: Vec<Record> = self.history.iter().map(Kept::record).collect();
        recs.sort_by_key(|r| (r.frame, r.id));
        ts(&from_core_records(&recs))
    }

    /// The offline pass over every frame tracked so far: joins tracks broken by occlusions
    /// (Kalman trajectory re-linking, joins chosen together by min-cost matching) and fills
    /// the gaps with shapes marked interpolated. `progress` is called with each progress
    /// report; if it throws, `finish` throws an `Error` carrying that message, and the tracker
    /// is left as it was (`finish` may be called again). After `finish` the tracker is final:
    /// `tracks()` returns the result and `update` refuses new frames.
    pub fn finish(
        &mut self,
        progress: Option<ProgressCallback>,
    ) -> Result<Ts<OfflineOutput>, JsValue> {
        if self.finished {
            return Err(js_error(BindingError::Finished));
        }
        let Some(off) = self.offline.as_ref() else {
            return Err(js_error(BindingError::NotOffline));
        };
        let callback: Option<js_sys::Function> = progress.map(JsCast::unchecked_into);
        // The core's progress callback cannot fail: the first exception is kept, further
        // reports are dropped, and it is raised once the pass returns.
        let mut thrown: Option<JsValue> = None;
        let mut report = |p: Progress| {
            let Some(f) = callback.as_ref() else { return };
            if thrown.is_some() {
                return;
            }
            let value = match OfflineProgress::from(p).into_ts() {
                Ok(v) => JsValue::from(v),
                Err(e) => {
                    thrown = Some(js_error(e));
                    return;
                }
            };
            if let Err(e) = f.call1(&JsValue::NULL, &value) {
                thrown = Some(e);
            }
        };
        let seq = SequenceInfo {
            fps: off.fps,
            image_size: self.image_size(),
        };
        let snapshots = (!off.snapshots.is_empty()).then_some(&off.snapshots);
        let result = offline::relink(
            self.relink_input(),
            snapshots,
            &off.config,
            &seq,
            &mut report,
        )
        .map_err(js_error)?;
        if let Some(e) = thrown {
            return Err(js_error(BindingError::Progress {
                message: thrown_message(&e),
            }));
        }

        let map = result.id_map();
        let (w, h) = seq.image_size.unwrap_or((0, 0));
        for k in &mut self.history {
            if let Some(&root) = map.get(&k.shape.id) {
                k.shape.id = root;
            }
        }
        // A join may be made over a slave's coasted tail (the pass ignores coasted shapes):
        // where that tail now meets the master's observed shape, the observation stays.
        let observed: std::collections::HashSet<(u64, u32)> = self
            .history
            .iter()
            .filter(|k| !k.shape.interpolated)
            .map(|k| (k.shape.id, k.shape.frame))
            .collect();
        self.history
            .retain(|k| !(k.shape.interpolated && observed.contains(&(k.shape.id, k.shape.frame))));
        // The history keeps the online pass's coasted shapes (tracker output the page already
        // shows): only the gaps the offline pass filled where nothing was shown are new.
        let present: std::collections::HashSet<(u64, u32)> = self
            .history
            .iter()
            .map(|k| (k.shape.id, k.shape.frame))
            .collect();
        let mut added = Vec::new();
        for mut s in result
            .shapes
            .into_iter()
            .filter(|s| s.interpolated && !present.contains(&(s.id, s.frame)))
        {
            let rle = s.mask.take().map(|m| Rle::from_mask(&m, w, h));
            let kept = Kept { shape: s, rle };
            added.push(kept.record());
            self.history.push(kept);
        }
        self.history.sort_by_key(|k| (k.shape.frame, k.shape.id));
        self.finished = true;
        // The snapshots are not needed any more.
        if let Some(off) = self.offline.as_mut() {
            off.snapshots = Snapshots::new();
        }
        let records: Vec<Record> = self.history.iter().map(Kept::record).collect();
        ts(&OfflineOutput {
            records: from_core_records(&records),
            joins: result.joins.iter().map(JoinJs::from).collect(),
            filled: added.len() as u32,
            added: from_core_records(&added),
        })
    }
}

impl Tracker {
    fn check_next(&self, frame: u32) -> Result<(), JsValue> {
        if self.finished {
            return Err(js_error(BindingError::Finished));
        }
        let expected = self.inner.frame() + 1;
        if frame != expected {
            return Err(js_error(BindingError::FrameOrder {
                expected,
                got: frame,
            }));
        }
        Ok(())
    }

    fn check_size(&mut self, width: u32, height: u32) -> Result<(), JsValue> {
        match self.size {
            None => self.size = Some((width, height)),
            Some((w, h)) if (w, h) != (width, height) => {
                return Err(js_error(BindingError::SizeChanged {
                    expected: (w, h),
                    got: (width, height),
                }))
            }
            Some(_) => {}
        }
        Ok(())
    }

    /// The image size: from the frames, else from the offline options.
    fn image_size(&self) -> Option<(u32, u32)> {
        self.size.or(self.offline.as_ref().and_then(|o| o.size))
    }

    fn report(&mut self, shapes: Vec<TrackedShape>) -> Result<Ts<Shapes>, JsValue> {
        let (w, h) = self.image_size().unwrap_or((0, 0));
        let mut out = Vec::with_capacity(shapes.len());
        for mut s in shapes {
            let rle = s.mask.take().map(|m| Rle::from_mask(&m, w, h));
            out.push(ShapeJs::new(&s, rle.as_ref()));
            self.history.push(Kept { shape: s, rle });
        }
        ts(&Shapes(out))
    }

    /// The online shapes for the re-linker. Masks are decoded only for shapes at the end of a
    /// run of consecutive frames of their track: gap filling carries the mask of a gap's end
    /// along the path, and nothing else in the offline pass reads masks, so the whole video's
    /// masks never sit in memory as bitmaps at once.
    fn relink_input(&self) -> Vec<TrackedShape> {
        let present: std::collections::HashSet<(u64, u32)> = self
            .history
            .iter()
            .map(|k| (k.shape.id, k.shape.frame))
            .collect();
        self.history
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
