//! The tracker: online updates, the kept history, and the offline pass at the end.

use super::*;
use crate::frame::TrackState;
use crate::io::Record;
use crate::track::offline::{
    OfflineConfig, OfflineError, OfflineTracker, Progress, RleHistory, RleShape,
};
use crate::track::Tracker as CoreTracker;
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

/// Where the tracker's time went since it was built, in milliseconds summed over the
/// frames (the core's `PhaseTimes`): the phases partition `update`'s time inside wasm, so
/// `update`'s time measured in JS minus their sum is the crossing into wasm and the shapes'
/// way back to JS.
#[derive(Debug, Clone, PartialEq, Serialize, Tsify)]
pub struct PhaseTimesJs {
    /// Frames timed.
    pub frames: u64,
    /// Per-detection features and every appearance description.
    pub features: f64,
    /// Motion prediction and region estimation.
    pub regions: f64,
    /// Pair costs of every association stage.
    pub costs: f64,
    /// The assignment stages.
    pub assignment: f64,
    /// Track updates: fragments, filters, lifecycle, coasting, spawning.
    pub update: f64,
}

#[wasm_bindgen]
extern "C" {
    /// The host's monotonic clock in milliseconds (browsers, workers and Node all have it).
    #[wasm_bindgen(js_namespace = performance, js_name = now)]
    fn performance_now() -> f64;
}

/// The shapes one update reports.
#[derive(Debug, Clone, PartialEq, Serialize, Tsify)]
#[serde(transparent)]
pub struct Shapes(pub Vec<ShapeJs>);

/// A kept shape as a record (its mask as RLE).
fn record_of(k: &RleShape) -> Record {
    let mut r = Record::from_tracked(&k.shape, None);
    r.mask = k.rle();
    r
}

/// Most shapes a [`Tracker`] keeps (its history, what `tracks()` and `finish()` read).
///
/// A long webcam session reports shapes without end; the kept `Vec` would exhaust wasm32's
/// memory and then overflow (a trap near 8 M shapes that killed the page's tracker with its
/// history). Two million is ~1.9 hours at 30 fps with ten objects in view; being under 2²¹
/// the `Vec` never doubles past 2²¹ slots (one frame adds at most a few thousand shapes), so
/// the history and the offline pass's copy of it stay within memory. Once it is full,
/// `update` refuses the next frame with an `Error` saying so and changes nothing: every kept
/// shape can still be read, exported or passed through `finish()`; a new tracker goes on.
pub const MAX_KEPT_SHAPES: usize = 2_000_000;

/// The tracker. Owns its ids (two trackers on a page never share a counter) and keeps every
/// reported shape, up to [`MAX_KEPT_SHAPES`], so the whole result can be read back or
/// exported at any time.
///
/// Built with offline options (`new Tracker(config, { fps })`) it also keeps what the offline
/// pass needs, and `finish()` runs that pass (thesis ch. 5: trajectory re-linking across
/// occlusions, then gap filling) over every frame tracked so far.
#[wasm_bindgen]
pub struct Tracker {
    /// The core's offline tracker, keeping every reported shape with its mask as RLE (a few
    /// hundred bytes instead of a bitmap the size of the box, so a long video's history stays
    /// small); after `finish`, the offline result. Built without offline options, it is only
    /// the online tracker and that history: appearance snapshots are off and `finish` refuses.
    inner: OfflineTracker<RleHistory>,
    /// Frame size, known from the first frame: later frames must match it.
    size: Option<(u32, u32)>,
    /// Whether the tracker was built for the offline pass.
    offline: bool,
    /// `finish` ran: the history is final and no frame may follow.
    finished: bool,
    /// Most shapes kept ([`MAX_KEPT_SHAPES`] unless set by [`Tracker::with_history_cap`]).
    cap: usize,
}

#[wasm_bindgen]
impl Tracker {
    /// A tracker with the core's defaults, or with the given settings over them. With
    /// `offline` options it can run the offline pass at the end (`finish`), and their `fps`
    /// is the online tracker's frame rate too (`frame_rate`, unless the settings give one),
    /// as `shapetrack track --fps` is: its frame counts that measure time (`max_lost`,
    /// `coast_frames`, `min_hits`, …), its main gate and its motion noise are then scaled to
    /// the video's rate.
    #[wasm_bindgen(constructor)]
    pub fn new(
        config: Option<TrackerSettings>,
        offline: Option<OfflineSettings>,
    ) -> Result<Tracker, JsValue> {
        let mut cfg = settings::track_config(config.as_ref())?;
        let (config, fps, size) = match offline {
            Some(o) => {
                let mut o = settings::offline_config(&o, cfg.clone())?;
                // Without the rate the counts stay at 30 fps: on a 5 fps video a lost track
                // took part in the main association for 1.6 s instead of 0.27 s, coasted as
                // long, and took a neighbour's detection (the car-shadow clip's car changed
                // id in the page, not in the CLI, which passes `--fps` to both).
                if cfg.frame_rate.is_none() {
                    cfg.frame_rate = Some(o.fps);
                    o.config.online.frame_rate = Some(o.fps);
                }
                (Some(o.config), o.fps, o.size)
            }
            None => (None, 1.0, None),
        };
        let offline = config.is_some();
        // Without offline options nothing is kept for a pass that never runs, and the frame
        // rate is unknown: the online tracker's counts are used as given.
        let config = config.unwrap_or_else(|| {
            let mut c = OfflineConfig {
                online: cfg.clone(),
                ..OfflineConfig::default()
            };
            c.appearance.enabled = false;
            c
        });
        // The phases are timed with the host's clock (the core never reads time itself); a
        // few calls per frame, so it is always on and `phaseTimes()` can report them.
        let tracker = CoreTracker::new(cfg)
            .map_err(js_error)?
            .with_clock(|| performance_now() / 1000.0);
        let inner = OfflineTracker::with_history(tracker, config, fps)
            .map_err(js_error)?
            .with_sequence_image_size(size);
        Ok(Tracker {
            inner,
            size: None,
            offline,
            finished: false,
            cap: MAX_KEPT_SHAPES,
        })
    }

    /// Number of shapes kept so far (see [`MAX_KEPT_SHAPES`]).
    #[wasm_bindgen(getter, js_name = keptShapes)]
    pub fn kept_shapes(&self) -> u32 {
        u32::try_from(self.inner.online_shapes().len()).unwrap_or(u32::MAX)
    }

    /// Most shapes this tracker keeps: once `keptShapes` reaches it, `update` refuses frames
    /// (see [`MAX_KEPT_SHAPES`]).
    #[wasm_bindgen(getter, js_name = maxKeptShapes)]
    pub fn max_kept_shapes(&self) -> u32 {
        u32::try_from(self.cap).unwrap_or(u32::MAX)
    }

    /// Number of frames tracked so far.
    #[wasm_bindgen(getter)]
    pub fn frame(&self) -> u32 {
        self.inner.frames()
    }

    /// Where `update`'s time went since the tracker was built, per phase (milliseconds summed
    /// over the frames): for bench pages and `shapetrack bench --wasm`.
    #[wasm_bindgen(js_name = phaseTimes)]
    pub fn phase_times(&self) -> Result<Ts<PhaseTimesJs>, JsValue> {
        let t = self.inner.phase_times();
        ts(&PhaseTimesJs {
            frames: t.frames,
            features: t.features * 1000.0,
            regions: t.regions * 1000.0,
            costs: t.costs * 1000.0,
            assignment: t.assignment * 1000.0,
            update: t.update * 1000.0,
        })
    }

    /// Whether this tracker can run the offline pass (it was built with offline options).
    #[wasm_bindgen(getter)]
    pub fn offline(&self) -> bool {
        self.offline
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
        let size = (buf.width(), buf.height());
        self.check_size(size)?;
        let image = buf.frame()?;
        let shapes = self
            .inner
            .push_frame(Some(&image), &detections.inner)
            .map_err(online_error)?;
        // Only a tracked frame sets the size: a first frame the core refused (too many
        // detections) no longer bound the tracker to its size, refusing every other size.
        self.size = Some(size);
        shapes_js(shapes)
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
        if self.inner.image_size().is_none() && detections.inner.iter().any(|d| d.mask.is_some()) {
            return Err(js_error(BindingError::Invalid(
                "mask detections without a frame need the image size: pass width and height \
                 in the tracker's options, or call update with a frame first"
                    .to_string(),
            )));
        }
        let shapes = self
            .inner
            .push_frame(None, &detections.inner)
            .map_err(online_error)?;
        shapes_js(shapes)
    }

    /// Every shape reported so far, as records (by frame, then id); after `finish`, the
    /// offline result.
    pub fn tracks(&self) -> Result<Ts<Records>, JsValue> {
        let mut recs: Vec<Record> = self.inner.online_shapes().iter().map(record_of).collect();
        recs.sort_by_key(|r| (r.frame, r.id));
        ts(&from_core_records(&recs))
    }

    /// The offline pass over every frame tracked so far: joins tracks broken by occlusions
    /// (Kalman trajectory re-linking, joins chosen together by min-cost matching) and fills
    /// the gaps with shapes marked interpolated. `progress` is called with each progress
    /// report; if it throws, `finish` throws an `Error` carrying that message, and the tracker
    /// is left as it was (`finish` may be called again). After `finish` the tracker is final:
    /// `tracks()` returns the result and `update` refuses new frames.
    ///
    /// Inside `progress` the tracker is busy: calling its methods throws an `Error`
    /// ("recursive use of an object"), which, uncaught, ends `finish` as above, the tracker
    /// unchanged. `free()` there throws too, but takes effect: the tracker is released when
    /// `finish` returns (nothing is used after it is freed, and nothing leaks).
    pub fn finish(
        &mut self,
        progress: Option<ProgressCallback>,
    ) -> Result<Ts<OfflineOutput>, JsValue> {
        if self.finished {
            return Err(js_error(BindingError::Finished));
        }
        if !self.offline {
            return Err(js_error(BindingError::NotOffline));
        }
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
        let result = self.inner.relink(&mut report).map_err(js_error)?;
        if let Some(e) = thrown {
            return Err(js_error(BindingError::Progress {
                message: thrown_message(&e),
            }));
        }
        // The conversion below can only fail on an id JS numbers cannot hold; checked while
        // nothing has changed, so every error leaves the tracker as it was.
        if let Some(s) = result.shapes.iter().find(|s| s.id > MAX_JS_ID) {
            return Err(js_error(BindingError::Invalid(format!(
                "track id {} is beyond 2^53: JavaScript numbers cannot hold it",
                s.id
            ))));
        }

        let added: Vec<Record> = self.inner.apply(&result).iter().map(record_of).collect();
        self.finished = true;
        let records: Vec<Record> = self.inner.online_shapes().iter().map(record_of).collect();
        ts(&OfflineOutput {
            records: from_core_records(&records),
            joins: result.joins.iter().map(JoinJs::from).collect(),
            filled: added.len() as u32,
            added: from_core_records(&added),
        })
    }
}

/// Largest integer a JS number holds exactly (`Number.MAX_SAFE_INTEGER`).
const MAX_JS_ID: u64 = (1 << 53) - 1;

impl Tracker {
    /// This tracker with its history capped at `cap` shapes instead of [`MAX_KEPT_SHAPES`]
    /// (tests reach the cap with it; a host with less memory can lower it).
    pub fn with_history_cap(mut self, cap: usize) -> Self {
        self.cap = cap;
        self
    }

    /// The next frame must be `frame`, and there must be room to keep its shapes.
    fn check_next(&self, frame: u32) -> Result<(), JsValue> {
        if self.finished {
            return Err(js_error(BindingError::Finished));
        }
        if self.inner.online_shapes().len() >= self.cap {
            return Err(js_error(BindingError::HistoryFull {
                cap: self.cap,
                frames: self.inner.frames(),
            }));
        }
        let expected = self.inner.frames() + 1;
        if frame != expected {
            return Err(js_error(BindingError::FrameOrder {
                expected,
                got: frame,
            }));
        }
        Ok(())
    }

    /// A frame of `size` may follow the frames tracked so far.
    fn check_size(&self, size: (u32, u32)) -> Result<(), JsValue> {
        match self.size {
            Some(expected) if expected != size => Err(js_error(BindingError::SizeChanged {
                expected,
                got: size,
            })),
            _ => Ok(()),
        }
    }
}

/// An error of the online pass as JS has always seen it: the tracker's own message, without
/// the offline tracker's "online pass" prefix.
fn online_error(e: OfflineError) -> JsValue {
    match e {
        OfflineError::Track(e) => js_error(e),
        e => js_error(e),
    }
}

/// The shapes one update reports, as JS sees them: the objects `ts(&Shapes(..))` would give,
/// key for key, built in JS from one array of numbers and one string of every mask's counts.
/// serde-wasm-bindgen sets each field with its own call out of wasm and decodes each counts
/// string on its own: 7–10 % of `update`'s time in Node on the demo and occlusion scenes (the
/// profile of `tracker_update`), where the native tracker has nothing to convert. One JSON
/// string parsed in JS was slower still (stop 48).
fn shapes_js(shapes: &[RleShape]) -> Result<Ts<Shapes>, JsValue> {
    let mut nums = Vec::with_capacity(shapes.len() * SHAPE_NUMS);
    let mut counts = String::new();
    let mut ends = Vec::with_capacity(shapes.len());
    for k in shapes {
        let s = &k.shape;
        let b = BoxJs::from(s.bbox);
        let c = PointJs::from(s.centroid);
        let state = match s.state {
            TrackState::Tentative => 0.0,
            TrackState::Confirmed => 1.0,
            TrackState::Lost => 2.0,
            TrackState::Removed => 3.0,
        };
        let (has_mask, mask_h, mask_w) = match &k.packed {
            Some(p) => {
                let (w, h) = p.size();
                counts.push_str(p.compressed());
                (1.0, h as f64, w as f64)
            }
            None => (0.0, 0.0, 0.0),
        };
        // The counts are ASCII (pycocotools' alphabet), so byte offsets are the JS string's
        // UTF-16 offsets too; a string longer than u32 cannot exist in wasm32.
        ends.push(counts.len() as u32);
        nums.extend_from_slice(&[
            s.frame as f64,
            s.id as f64,
            b.x,
            b.y,
            b.w,
            b.h,
            s.score,
            s.class as f64,
            if s.interpolated { 1.0 } else { 0.0 },
            state,
            c.x,
            c.y,
            s.cost,
            has_mask,
            mask_h,
            mask_w,
        ]);
    }
    Ok(Ts::new_unchecked(shapes_from(&nums, &counts, &ends)))
}

/// Numbers per shape in `shapes_js`'s array (the layout `shapesFrom` reads).
const SHAPE_NUMS: usize = 16;

// Builds the `Shape` objects from `shapes_js`'s layout. Object literals give every shape the
// same hidden class in V8; the key order is the struct's (and serde's): frame, id, bbox,
// score, class, mask (only when there is one), interpolated, state, centroid, cost.
#[wasm_bindgen(inline_js = r#"
const STATES = ['tentative', 'confirmed', 'lost', 'removed'];
export function shapesFrom(nums, counts, ends) {
  const out = new Array(ends.length);
  let start = 0;
  for (let i = 0, o = 0; i < ends.length; i++, o += 16) {
    const s = {
      frame: nums[o], id: nums[o + 1],
      bbox: { x: nums[o + 2], y: nums[o + 3], w: nums[o + 4], h: nums[o + 5] },
      score: nums[o + 6], class: nums[o + 7],
    };
    if (nums[o + 13] !== 0) {
      s.mask = { size: [nums[o + 14], nums[o + 15]], counts: counts.slice(start, ends[i]) };
    }
    s.interpolated = nums[o + 8] !== 0;
    s.state = STATES[nums[o + 9]];
    s.centroid = { x: nums[o + 10], y: nums[o + 11] };
    s.cost = nums[o + 12];
    start = ends[i];
    out[i] = s;
  }
  return out;
}
"#)]
extern "C" {
    /// See `shapes_js`: the numbers and the strings are read, not kept (wasm-bindgen passes
    /// views of wasm memory).
    #[wasm_bindgen(js_name = shapesFrom)]
    fn shapes_from(nums: &[f64], counts: &str, ends: &[u32]) -> JsValue;
}
