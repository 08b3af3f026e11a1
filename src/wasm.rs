//! Browser bindings: the only module that knows wasm-bindgen.
//!
//! Everything here is thin on purpose. JavaScript values are turned into the core's plain
//! structs (serde-wasm-bindgen, with TypeScript types derived by `tsify` from the same structs,
//! so the generated `.d.ts` cannot drift from the code), the core does the work, and results go
//! back as serialisable output structs built with `From`. Every core error becomes a JS `Error`
//! carrying its message through [`js_error`]; a panic hook is installed when the module starts,
//! so a bug shows up as a readable message in the console instead of a bare `unreachable`.
//!
//! Frames do not cross the boundary as copies: JS allocates a [`FrameBuffer`] once, writes RGBA
//! pixels straight into wasm memory through `new Uint8ClampedArray(memory.buffer, buf.ptr(),
//! buf.len())`, and hands the buffer handle to the tracker or detector, which read it in place.

use crate::detect::{
    BackgroundConfig, BackgroundSubtractor, Connectivity, Detector, ShadowConfig, UpdatePolicy,
};
use crate::eval::{self, EvalConfig, Preprocessing, SequenceInput, Similarity, Summary};
use crate::frame::{BBox, Detection, Frame, Mask, Point, TrackState, TrackedShape};
use crate::io::{
    coco_video, cvat, label_studio, motchallenge, scalabel, yolo, Record, RecordFlags, Rle,
};
use crate::synth::{Scene, SynthConfig};
use crate::track::offline::{
    self, Join, JoinSolver, OfflineConfig, Phase, Progress, SequenceInfo, Snapshots, Trajectory,
};
use crate::track::{Config as TrackConfig, Tracker as CoreTracker};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use tsify::{Ts, Tsify};
use wasm_bindgen::prelude::*;
use wasm_bindgen::JsCast;

/// Installs the panic hook. Runs once, when the module is instantiated.
#[wasm_bindgen(start)]
pub fn start() {
    console_error_panic_hook::set_once();
}

/// Turns any core error into a JS `Error` whose message is the error and its sources.
///
/// The one place errors cross into JavaScript, so every function reports failures the same way.
fn js_error<E: std::error::Error>(e: E) -> JsValue {
    let mut msg = e.to_string();
    let mut src = e.source();
    while let Some(s) = src {
        let part = s.to_string();
        // Some messages already embed their source; do not repeat it.
        if !msg.contains(&part) {
            msg.push_str(": ");
            msg.push_str(&part);
        }
        src = s.source();
    }
    js_sys::Error::new(&msg).into()
}

/// An error raised by the bindings themselves (argument checks), as opposed to the core's.
#[derive(Debug, thiserror::Error)]
enum BindingError {
    /// An input that cannot be read: a settings object (see `settings`), a mask too large.
    #[error("{0}")]
    Invalid(String),
    /// A frame size outside what a browser canvas can hold.
    #[error("frame size {width}x{height} is outside 1..={max} on each side")]
    FrameSize {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
        /// Largest side accepted.
        max: u32,
    },
    /// Frames must be tracked in order, each once.
    #[error("frames must be tracked in order: expected frame {expected}, got {got}")]
    FrameOrder {
        /// The next frame.
        expected: u32,
        /// The frame given.
        got: u32,
    },
    /// A tracker sees one video: its frame size cannot change.
    #[error("frame size changed from {expected:?} to {got:?}: start a new tracker")]
    SizeChanged {
        /// Size of the first frame.
        expected: (u32, u32),
        /// Size of this frame.
        got: (u32, u32),
    },
    /// A frame number outside the sequence.
    #[error("frame {frame} is outside 1..={frames}")]
    FrameRange {
        /// The frame asked for.
        frame: u32,
        /// Frames in the sequence.
        frames: u32,
    },
    /// `finish` on a tracker built without offline options.
    #[error("this tracker was built without offline options: create it with new Tracker(config, {{ fps }}) to run finish()")]
    NotOffline,
    /// The offline pass has run: the tracker's result is final.
    #[error("this tracker is finished (the offline pass has run): start a new tracker")]
    Finished,
    /// The progress callback threw.
    #[error("progress callback threw: {message}")]
    Progress {
        /// The exception's message.
        message: String,
    },
    /// An option has a value the bindings do not accept.
    #[error("option {name}: {message}")]
    Option {
        /// The option.
        name: &'static str,
        /// What is wrong.
        message: String,
    },
}

/// Reads a typed JS argument into its Rust struct; a shape mismatch becomes a JS `Error`.
///
/// Deserialising inside the function (rather than in the ABI glue) keeps the failure an ordinary
/// `Result`, so nothing already converted leaks when the caller passes a bad value.
fn rust<T>(v: Ts<T>) -> Result<T, JsValue>
where
    T: Tsify + serde::de::DeserializeOwned,
    T::JsType: Clone,
{
    v.to_rust().map_err(js_error)
}

/// Reads a settings object strictly: an unknown field is an error naming it.
///
/// serde-wasm-bindgen reads only the fields a struct declares, so `deny_unknown_fields` never
/// fires through it and a typo (`max_lots`) would silently keep the default. Settings are
/// small, so they go through a JSON value, which sees every key.
///
/// Before that, the JS value is walked without recursion: a nesting deeper than
/// [`MAX_SETTINGS_DEPTH`] (which would overflow the stack and leave the module broken), more
/// than [`MAX_SETTINGS_NODES`] values, a number that is not finite (JSON has no NaN, so it
/// would silently read as "default") and a non-object where an object belongs (serde would
/// read an array into a struct field by field) are errors naming the place.
fn settings<T>(v: Ts<T>) -> Result<T, JsValue>
where
    T: Tsify + serde::de::DeserializeOwned,
    T::JsType: JsCast,
{
    let value = v.js_value();
    check_settings_value(&value)?;
    let json: serde_json::Value = serde_wasm_bindgen::from_value(value).map_err(js_error)?;
    serde_json::from_value(json).map_err(js_error)
}

/// Deepest nesting accepted in a settings object (the real ones nest 3 levels).
const MAX_SETTINGS_DEPTH: usize = 32;

/// Most values accepted in a settings object.
const MAX_SETTINGS_NODES: usize = 100_000;

/// The only settings fields that hold lists; an array anywhere else is an error.
const SETTINGS_LISTS: &[&str] = &["labels"];

/// The walk of [`settings`]: depth, size and finite numbers.
fn check_settings_value(root: &JsValue) -> Result<(), JsValue> {
    if !root.is_object() || js_sys::Array::is_array(root) {
        return Err(js_error(BindingError::Invalid(
            "settings must be a plain object".to_string(),
        )));
    }
    let mut stack: Vec<(JsValue, String, usize)> = vec![(root.clone(), "config".into(), 0)];
    let mut seen = 0usize;
    while let Some((v, path, depth)) = stack.pop() {
        seen += 1;
        if seen > MAX_SETTINGS_NODES {
            return Err(js_error(BindingError::Invalid(format!(
                "settings hold more than {MAX_SETTINGS_NODES} values"
            ))));
        }
        if let Some(x) = v.as_f64() {
            if !x.is_finite() {
                return Err(js_error(BindingError::Invalid(format!(
                    "{path} = {x}: must be a finite number"
                ))));
            }
        } else if v.is_object() {
            let key = path.rsplit('.').next().unwrap_or_default();
            if js_sys::Array::is_array(&v) && !SETTINGS_LISTS.contains(&key) {
                return Err(js_error(BindingError::Invalid(format!(
                    "{path} must be an object or a value, not an array"
                ))));
            }
            if depth >= MAX_SETTINGS_DEPTH {
                return Err(js_error(BindingError::Invalid(format!(
                    "{path}: nested deeper than {MAX_SETTINGS_DEPTH} levels"
                ))));
            }
            let obj: &js_sys::Object = v.unchecked_ref();
            for entry in js_sys::Object::entries(obj).iter() {
                let pair: js_sys::Array = entry.unchecked_into();
                let key = pair.get(0).as_string().unwrap_or_default();
                stack.push((pair.get(1), format!("{path}.{key}"), depth + 1));
            }
        }
    }
    Ok(())
}

/// Converts an output struct to its typed JS value.
fn ts<T: Tsify + Serialize>(v: &T) -> Result<Ts<T>, JsValue> {
    v.into_ts().map_err(js_error)
}

/// A whole number from JS that fits `u32`. wasm-bindgen's own `u32` parameters wrap
/// (`2**32 + 1` arrives as 1, `-1` as 4294967295), so the entry points that take sizes and
/// frame numbers take `f64` and check it here.
fn whole_u32(name: &'static str, v: f64) -> Result<u32, JsValue> {
    if v.fract() == 0.0 && (0.0..=u32::MAX as f64).contains(&v) {
        Ok(v as u32)
    } else {
        Err(js_error(BindingError::Option {
            name,
            message: format!("{v} (must be a whole number in 0..=4294967295)"),
        }))
    }
}

/// The largest frame side accepted (a 16k canvas is already beyond every browser's limit).
const MAX_SIDE: u32 = 16384;

/// An RGBA frame that lives in wasm memory; JavaScript writes pixels into it in place.
///
/// `ptr()`/`len()` locate the bytes in `memory.buffer`. A view on that buffer is invalidated
/// when wasm memory grows, so JS should build the `Uint8ClampedArray` view right before each
/// write rather than keep it.
#[wasm_bindgen]
pub struct FrameBuffer {
    data: Vec<u8>,
    width: u32,
    height: u32,
}

#[wasm_bindgen]
impl FrameBuffer {
    /// Allocates `width·height·4` zeroed bytes; an allocation the browser refuses is an
    /// error, not a trap.
    #[wasm_bindgen(constructor)]
    pub fn new(width: f64, height: f64) -> Result<FrameBuffer, JsValue> {
        let (width, height) = (whole_u32("width", width)?, whole_u32("height", height)?);
        if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
            return Err(js_error(BindingError::FrameSize {
                width,
                height,
                max: MAX_SIDE,
            }));
        }
        let n = width as usize * height as usize * 4;
        let mut data = Vec::new();
        data.try_reserve_exact(n).map_err(|_| {
            js_error(BindingError::Invalid(format!(
                "could not allocate a {width}x{height} frame ({n} bytes): out of memory"
            )))
        })?;
        data.resize(n, 0);
        Ok(FrameBuffer {
            data,
            width,
            height,
        })
    }

    /// Byte offset of the first pixel in `memory.buffer`.
    pub fn ptr(&self) -> *const u8 {
        self.data.as_ptr()
    }

    /// Number of bytes (`width·height·4`).
    #[allow(clippy::len_without_is_empty)] // never empty: the constructor rejects 0 sizes
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// Frame width in pixels.
    #[wasm_bindgen(getter)]
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Frame height in pixels.
    #[wasm_bindgen(getter)]
    pub fn height(&self) -> u32 {
        self.height
    }
}

impl FrameBuffer {
    /// The pixels as a core frame view (no copy).
    #[allow(dead_code)] // used by the tracker and detector bindings
    fn frame(&self) -> Result<Frame<'_>, JsValue> {
        Frame::rgba(&self.data, self.width, self.height).map_err(js_error)
    }

    /// Mutable pixels, for producers that live in wasm (the synthetic scene).
    #[allow(dead_code)] // used by the synthetic scene binding
    fn bytes_mut(&mut self) -> &mut [u8] {
        &mut self.data
    }
}

/// A box in pixels: top-left corner and size (MOTChallenge layout).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Tsify)]
pub struct BoxJs {
    /// Left edge.
    pub x: f64,
    /// Top edge.
    pub y: f64,
    /// Width.
    pub w: f64,
    /// Height.
    pub h: f64,
}

impl From<BBox> for BoxJs {
    fn from(b: BBox) -> Self {
        BoxJs {
            x: b.x,
            y: b.y,
            w: b.w,
            h: b.h,
        }
    }
}

impl From<BoxJs> for BBox {
    fn from(b: BoxJs) -> Self {
        BBox::new(b.x, b.y, b.w, b.h)
    }
}

/// A point in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Tsify)]
pub struct PointJs {
    /// Horizontal coordinate.
    pub x: f64,
    /// Vertical coordinate.
    pub y: f64,
}

impl From<Point> for PointJs {
    fn from(p: Point) -> Self {
        PointJs { x: p.x, y: p.y }
    }
}

/// A full-image mask in COCO's compressed RLE form (what MOTS and COCO files store).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Tsify)]
pub struct RleJs {
    /// `[height, width]` of the image, COCO order.
    pub size: [u32; 2],
    /// pycocotools' compressed counts string.
    pub counts: String,
}

impl From<&Rle> for RleJs {
    fn from(r: &Rle) -> Self {
        RleJs {
            size: [r.height, r.width],
            counts: r.to_compressed(),
        }
    }
}

impl RleJs {
    fn to_rle(&self) -> Result<Rle, JsValue> {
        let [h, w] = self.size;
        // The readers' cap (see `io::limits`): a mask must be decodable in wasm's memory.
        if !crate::io::limits::image_size_ok(w as u64, h as u64) {
            return Err(js_error(BindingError::Invalid(format!(
                "RLE size {h}x{w} is outside 1..={} per side or over {} pixels",
                crate::io::limits::MAX_SIDE,
                crate::io::limits::MAX_PIXELS
            ))));
        }
        Rle::from_compressed(&self.counts, h, w).map_err(js_error)
    }
}

fn minus_one() -> f64 {
    -1.0
}
fn minus_one_i32() -> i32 {
    -1
}
fn one() -> f64 {
    1.0
}

/// One object in one frame: the row of every track table, import and export.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Tsify)]
pub struct RecordJs {
    /// 1-based frame number.
    pub frame: u32,
    /// Track id (-1 for an unlinked detection).
    pub id: i64,
    /// Bounding box.
    pub bbox: BoxJs,
    /// Confidence, or the MOTChallenge gt "consider" flag (0 = ignore). Defaults to 1.
    #[serde(default = "one")]
    #[tsify(optional)]
    pub score: f64,
    /// Class label, -1 when unknown (the default).
    #[serde(default = "minus_one_i32")]
    #[tsify(optional)]
    pub class: i32,
    /// Visibility ratio, -1 when unknown (the default).
    #[serde(default = "minus_one")]
    #[tsify(optional)]
    pub visibility: f64,
    /// Instance mask, for mask formats.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub mask: Option<RleJs>,
    /// Filled in by interpolation rather than detected or drawn.
    #[serde(default)]
    #[tsify(optional)]
    pub interpolated: bool,
    /// Marked occluded by an annotator.
    #[serde(default)]
    #[tsify(optional)]
    pub occluded: bool,
}

impl From<&Record> for RecordJs {
    fn from(r: &Record) -> Self {
        RecordJs {
            frame: r.frame,
            id: r.id,
            bbox: r.bbox.into(),
            score: r.score,
            class: r.class,
            visibility: r.visibility,
            mask: r.mask.as_ref().map(RleJs::from),
            interpolated: r.flags.interpolated,
            occluded: r.flags.occluded,
        }
    }
}

impl RecordJs {
    fn to_record(&self) -> Result<Record, JsValue> {
        let bbox =
            BBox::checked(self.bbox.x, self.bbox.y, self.bbox.w, self.bbox.h).map_err(js_error)?;
        Ok(Record {
            frame: self.frame,
            id: self.id,
            bbox,
            score: self.score,
            class: self.class,
            visibility: self.visibility,
            mask: self.mask.as_ref().map(RleJs::to_rle).transpose()?,
            flags: RecordFlags {
                interpolated: self.interpolated,
                occluded: self.occluded,
            },
        })
    }
}

/// A list of records (what readers return and writers take).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Tsify)]
#[serde(transparent)]
pub struct Records(pub Vec<RecordJs>);

fn to_core_records(records: Records) -> Result<Vec<Record>, JsValue> {
    records.0.iter().map(RecordJs::to_record).collect()
}

fn from_core_records(records: &[Record]) -> Records {
    Records(records.iter().map(RecordJs::from).collect())
}

/// The annotation and result formats the app reads and writes (all through the Rust core).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Tsify)]
#[serde(rename_all = "kebab-case")]
pub enum Format {
    /// MOTChallenge txt: `frame,id,x,y,w,h,conf,...` per line.
    Mot,
    /// MOTS txt: `frame id class height width rle` per line.
    Mots,
    /// COCO-video / YouTube-VIS JSON (ground-truth form; the results list is read too).
    CocoVideo,
    /// CVAT for video 1.1 XML.
    Cvat,
    /// Scalabel / BDD100K JSON (the first video of the file). Classes are numbered as
    /// BDD100K's evaluation does (pedestrian 1 … bicycle 8, other names from 9): names survive
    /// a round trip, class numbers from other formats may not.
    Scalabel,
    /// Label Studio video JSON (`videorectangle` regions; boxes in percent of the frame, so
    /// reading and writing need the frame size; filled frames are the frames between
    /// keyframes).
    LabelStudio,
    /// YOLO-style txt with track ids, one file for the sequence:
    /// `frame class cx cy w h conf track_id`, normalised by the frame size (reading and
    /// writing need it); cannot flag filled frames.
    Yolo,
}

/// Label Studio seeks by time; its `<Video>` tag assumes 24 fps unless told otherwise.
const LABEL_STUDIO_FPS: f64 = 24.0;

/// A class and its name (COCO categories, CVAT labels).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Tsify)]
pub struct LabelJs {
    /// Class id, as in the records.
    pub class: i32,
    /// Name.
    pub name: String,
}

/// A file's records and what it says about its sequence.
#[derive(Debug, Clone, PartialEq, Serialize, Tsify)]
pub struct Annotations {
    /// The records (of the first video, for a COCO file with several).
    pub records: Records,
    /// Frame width, when the file gives it.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub width: Option<u32>,
    /// Frame height, when the file gives it.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub height: Option<u32>,
    /// Number of frames, when the file gives it.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub frames: Option<u32>,
    /// Class names, when the file gives them.
    pub labels: Vec<LabelJs>,
    /// Videos in the file (COCO files may hold several; only the first is read).
    pub videos: u32,
}

impl Annotations {
    fn plain(records: &[Record]) -> Self {
        Annotations {
            records: from_core_records(records),
            width: None,
            height: None,
            frames: None,
            labels: Vec::new(),
            videos: 1,
        }
    }
}

/// What a writer needs to know about the sequence besides its records.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct SequenceMeta {
    /// Frame width (COCO, CVAT, Label Studio and YOLO need it).
    #[tsify(optional)]
    pub width: Option<u32>,
    /// Frame height (COCO, CVAT, Label Studio and YOLO need it).
    #[tsify(optional)]
    pub height: Option<u32>,
    /// Number of frames (default: the last record's frame).
    #[tsify(optional)]
    pub frames: Option<u32>,
    /// Sequence name (CVAT task name, COCO file name stem).
    #[tsify(optional)]
    pub name: Option<String>,
    /// Class names; classes without one are named "object" (-1) or "class N".
    #[tsify(optional)]
    pub labels: Option<Vec<LabelJs>>,
}

/// Parses an annotation or result file. `name` names the file in error messages. `meta`
/// gives the frame size that Label Studio (percent) and YOLO (fractions) files need; other
/// formats ignore it (their files say the size, or use pixels).
#[wasm_bindgen(js_name = parseAnnotations)]
pub fn parse_annotations(
    format: Ts<Format>,
    #[wasm_bindgen(unchecked_param_type = "string")] text: JsValue,
    #[wasm_bindgen(unchecked_param_type = "string")] name: JsValue,
    meta: Option<Ts<SequenceMeta>>,
) -> Result<Ts<Annotations>, JsValue> {
    // Taken as JS values: a number passed as the text must be an error, not a trap in
    // wasm-bindgen's string conversion.
    let (text, name) = match (text.as_string(), name.as_string()) {
        (Some(t), Some(n)) => (t, n),
        _ => {
            return Err(js_error(BindingError::Invalid(
                "parseAnnotations(format, text, name): text and name must be strings".to_string(),
            )))
        }
    };
    let (text, name) = (text.as_str(), name.as_str());
    let meta = match meta {
        Some(m) => settings(m)?,
        None => SequenceMeta::default(),
    };
    let out = match rust(format)? {
        Format::Mot => Annotations::plain(&motchallenge::parse_mot(text, name).map_err(js_error)?),
        Format::Mots => {
            Annotations::plain(&motchallenge::parse_mots(text, name).map_err(js_error)?)
        }
        Format::CocoVideo if text.trim_start().starts_with('[') => {
            // The results form: a list of tracks; no video sizes.
            let per_video =
                coco_video::parse_coco_video_results(text, name, &[]).map_err(js_error)?;
            let videos = per_video.len() as u32;
            let records = per_video.into_values().next().unwrap_or_default();
            Annotations {
                videos,
                ..Annotations::plain(&records)
            }
        }
        Format::CocoVideo => {
            let data = coco_video::parse_coco_video(text, name).map_err(js_error)?;
            let labels = data
                .categories
                .iter()
                .map(|c| LabelJs {
                    class: c.id,
                    name: c.name.clone(),
                })
                .collect();
            let videos = data.videos.len() as u32;
            match data.videos.into_iter().next() {
                Some(v) => Annotations {
                    records: from_core_records(&v.records),
                    width: Some(v.video.width),
                    height: Some(v.video.height),
                    frames: Some(v.video.length),
                    labels,
                    videos,
                },
                None => Annotations {
                    labels,
                    videos,
                    ..Annotations::plain(&[])
                },
            }
        }
        Format::Cvat => {
            let a = cvat::parse_cvat(text, name, None).map_err(js_error)?;
            let nonzero = |v: u32| (v > 0).then_some(v);
            Annotations {
                records: from_core_records(&a.records),
                width: nonzero(a.meta.width),
                height: nonzero(a.meta.height),
                frames: nonzero(a.meta.size),
                labels: a
                    .labels
                    .iter()
                    .enumerate()
                    .map(|(i, n)| LabelJs {
                        class: i as i32,
                        name: n.clone(),
                    })
                    .collect(),
                videos: 1,
            }
        }
        Format::Scalabel => {
            let frames = scalabel::parse_scalabel(text, name).map_err(js_error)?;
            let videos = scalabel::split_videos(frames);
            let count = videos.len() as u32;
            let first = videos.into_values().next().unwrap_or_default();
            let (mut ids, mut cats) = (scalabel::IdMap::default(), scalabel::Categories::default());
            let records = scalabel::to_records(&first, &mut ids, &mut cats, false);
            let classes: std::collections::BTreeSet<i32> =
                records.iter().map(|r| r.class).collect();
            Annotations {
                frames: first.iter().map(|f| f.frame_index + 1).max(),
                labels: classes
                    .into_iter()
                    .filter_map(|c| {
                        cats.name(c).map(|n| LabelJs {
                            class: c,
                            name: n.to_string(),
                        })
                    })
                    .collect(),
                videos: count.max(1),
                ..Annotations::plain(&records)
            }
        }
        Format::LabelStudio => {
            let size = frame_size(&meta)?;
            let a = label_studio::parse_label_studio(text, name, size, None).map_err(js_error)?;
            Annotations {
                records: from_core_records(&a.records),
                width: Some(size.0),
                height: Some(size.1),
                frames: (a.frames > 0).then_some(a.frames),
                labels: a
                    .labels
                    .iter()
                    .enumerate()
                    .map(|(i, n)| LabelJs {
                        class: i as i32,
                        name: n.clone(),
                    })
                    .collect(),
                videos: a.tasks.max(1) as u32,
            }
        }
        Format::Yolo => {
            let size = frame_size(&meta)?;
            Annotations {
                width: Some(size.0),
                height: Some(size.1),
                ..Annotations::plain(&yolo::parse_yolo(text, name, size).map_err(js_error)?)
            }
        }
    };
    ts(&out)
}

/// The frame size from `meta`, for formats whose coordinates are relative to it.
fn frame_size(meta: &SequenceMeta) -> Result<(u32, u32), JsValue> {
    match (meta.width, meta.height) {
        (Some(w), Some(h)) if w > 0 && h > 0 => Ok((w, h)),
        _ => Err(js_error(BindingError::Option {
            name: "meta",
            message: "this format needs the frame width and height".to_string(),
        })),
    }
}

/// Class names for every class the records use: the given ones, else "object" for -1 and
/// "class N" for the others (COCO and CVAT need a name per class).
fn label_map(records: &[Record], given: &[LabelJs]) -> BTreeMap<i32, String> {
    let mut map: BTreeMap<i32, String> = given.iter().map(|l| (l.class, l.name.clone())).collect();
    for r in records {
        map.entry(r.class).or_insert_with(|| {
            if r.class == -1 {
                "object".to_string()
            } else {
                format!("class {}", r.class)
            }
        });
    }
    map
}

/// Writes records in `format`. MOTS skips records without a mask, as the format requires;
/// COCO-video, CVAT, Label Studio and YOLO need the frame size in `meta`.
#[wasm_bindgen(js_name = writeAnnotations)]
pub fn write_annotations(
    format: Ts<Format>,
    records: Ts<Records>,
    meta: Option<Ts<SequenceMeta>>,
) -> Result<String, JsValue> {
    let records = to_core_records(rust(records)?)?;
    let meta = match meta {
        Some(m) => settings(m)?,
        None => SequenceMeta::default(),
    };
    let frames = meta
        .frames
        .unwrap_or_else(|| records.iter().map(|r| r.frame).max().unwrap_or(0));
    let size = || frame_size(&meta);
    let labels = label_map(&records, meta.labels.as_deref().unwrap_or(&[]));
    match rust(format)? {
        Format::Mot => Ok(motchallenge::write_mot(&records)),
        Format::Mots => Ok(motchallenge::write_mots(&records)),
        Format::CocoVideo => {
            let (width, height) = size()?;
            let video = coco_video::VideoInfo {
                id: 1,
                width,
                height,
                length: frames,
                file_names: Vec::new(),
            };
            let categories: Vec<coco_video::Category> = labels
                .iter()
                .map(|(&id, name)| coco_video::Category {
                    id,
                    name: name.clone(),
                })
                .collect();
            coco_video::write_coco_video(&[(video, &records)], &categories).map_err(js_error)
        }
        Format::Cvat => {
            let (width, height) = size()?;
            let meta = cvat::CvatMeta {
                name: meta
                    .name
                    .clone()
                    .unwrap_or_else(|| "shapetrack".to_string()),
                size: frames,
                width,
                height,
            };
            cvat::write_cvat(&records, &meta, &labels).map_err(js_error)
        }
        Format::Scalabel => {
            let video = meta
                .name
                .clone()
                .unwrap_or_else(|| "shapetrack".to_string());
            let mut frames = scalabel::from_records(
                &records,
                &video,
                frames,
                None,
                &scalabel::Categories::default(),
            );
            // Categories by the app's names (BDD100K's numbering would rename other classes).
            let class_of: BTreeMap<(u32, String), i32> = records
                .iter()
                .map(|r| ((r.frame, r.id.to_string()), r.class))
                .collect();
            for f in &mut frames {
                for l in &mut f.labels {
                    let class = class_of.get(&(f.frame_index + 1, l.id.clone()));
                    l.category = class
                        .filter(|c| **c != -1)
                        .and_then(|c| labels.get(c).cloned());
                }
            }
            scalabel::write_scalabel(&frames).map_err(js_error)
        }
        Format::LabelStudio => {
            let (width, height) = size()?;
            let meta = label_studio::LabelStudioMeta {
                video: meta
                    .name
                    .clone()
                    .unwrap_or_else(|| "shapetrack".to_string()),
                width,
                height,
                frames,
                fps: LABEL_STUDIO_FPS,
            };
            label_studio::write_label_studio(&records, &meta, &labels).map_err(js_error)
        }
        Format::Yolo => yolo::write_yolo(&records, size()?).map_err(js_error),
    }
}

/// A mask cropped to its foreground: `data` holds `width·height` bytes (0/1), row-major, for
/// the rectangle whose top-left pixel is `(x, y)`.
#[derive(Debug, Clone, PartialEq, Serialize, Tsify)]
pub struct MaskBitmap {
    /// Image x of the left column.
    pub x: i32,
    /// Image y of the top row.
    pub y: i32,
    /// Bitmap width.
    pub width: u32,
    /// Bitmap height.
    pub height: u32,
    /// 0/1 bytes, row-major.
    #[serde(with = "serde_bytes")]
    #[tsify(type = "Uint8Array")]
    pub data: Vec<u8>,
}

impl From<&Mask> for MaskBitmap {
    fn from(m: &Mask) -> Self {
        MaskBitmap {
            x: m.x(),
            y: m.y(),
            width: m.width(),
            height: m.height(),
            data: m.data().to_vec(),
        }
    }
}

/// Decodes a compressed RLE into a bitmap cropped to its foreground, for drawing overlays.
#[wasm_bindgen(js_name = decodeMask)]
pub fn decode_mask(rle: Ts<RleJs>) -> Result<Ts<MaskBitmap>, JsValue> {
    let rle = rust(rle)?.to_rle()?;
    ts(&MaskBitmap::from(&rle.to_mask()))
}

/// Encodes a full-image bitmap (`width·height` bytes, non-zero = foreground) as compressed RLE.
#[wasm_bindgen(js_name = encodeMask)]
pub fn encode_mask(width: f64, height: f64, bitmap: &[u8]) -> Result<Ts<RleJs>, JsValue> {
    let (width, height) = (whole_u32("width", width)?, whole_u32("height", height)?);
    let rle = Rle::encode(width, height, bitmap).map_err(js_error)?;
    ts(&RleJs::from(&rle))
}

/// The crate version, shown in the app's footer and checked by the tests.
#[wasm_bindgen]
pub fn version() -> String {
    env!("CARGO_PKG_VERSION").to_string()
}

// ------------------------------------------------------------------------------------------
// Detections

/// A mask handed in by a JS detector: `data` holds `width·height` bytes (non-zero = object)
/// for the rectangle whose top-left pixel is `(x, y)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Tsify)]
pub struct MaskInput {
    /// Image x of the left column.
    pub x: i32,
    /// Image y of the top row.
    pub y: i32,
    /// Bitmap width.
    pub width: u32,
    /// Bitmap height.
    pub height: u32,
    /// Row-major bytes.
    #[serde(with = "serde_bytes")]
    #[tsify(type = "Uint8Array")]
    pub data: Vec<u8>,
    /// Detector confidence; defaults to 1.
    #[serde(default = "one")]
    #[tsify(optional)]
    pub score: f64,
    /// Class label; -1 (the default) when unknown.
    #[serde(default = "minus_one_i32")]
    #[tsify(optional)]
    pub class: i32,
}

/// A box handed in by a JS detector.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Tsify)]
pub struct BoxInput {
    /// The box.
    pub bbox: BoxJs,
    /// Detector confidence; defaults to 1.
    #[serde(default = "one")]
    #[tsify(optional)]
    pub score: f64,
    /// Class label; -1 (the default) when unknown.
    #[serde(default = "minus_one_i32")]
    #[tsify(optional)]
    pub class: i32,
}

/// What a detector written in JS returns: masks, boxes, or both.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
pub struct DetectionLists {
    /// Mask detections.
    #[serde(default)]
    #[tsify(optional)]
    pub masks: Vec<MaskInput>,
    /// Box-only detections.
    #[serde(default)]
    #[tsify(optional)]
    pub boxes: Vec<BoxInput>,
}

/// One detection as JS sees it (for drawing detector output).
#[derive(Debug, Clone, PartialEq, Serialize, Tsify)]
pub struct DetectionJs {
    /// Bounding box.
    pub bbox: BoxJs,
    /// Cropped mask, when the detector gave one.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub mask: Option<MaskBitmap>,
    /// Confidence.
    pub score: f64,
    /// Class label (-1 when unknown).
    pub class: i32,
}

impl From<&Detection> for DetectionJs {
    fn from(d: &Detection) -> Self {
        DetectionJs {
            bbox: d.bbox.into(),
            mask: d.mask.as_ref().map(MaskBitmap::from),
            score: d.score,
            class: d.class,
        }
    }
}

/// A list of detections as JS sees it.
#[derive(Debug, Clone, PartialEq, Serialize, Tsify)]
#[serde(transparent)]
pub struct DetectionList(pub Vec<DetectionJs>);

/// One frame's detections, kept in wasm memory: the background detector's output goes to the
/// tracker without crossing into JS. Detectors written in JS build one with `fromLists`.
#[wasm_bindgen]
pub struct Detections {
    inner: Vec<Detection>,
}

#[wasm_bindgen]
impl Detections {
    /// Detections from a JS detector's masks and boxes (checked: sizes, finite boxes).
    #[wasm_bindgen(js_name = fromLists)]
    pub fn from_lists(lists: Ts<DetectionLists>) -> Result<Detections, JsValue> {
        let lists = rust(lists)?;
        let mut inner = Vec::with_capacity(lists.masks.len() + lists.boxes.len());
        for m in lists.masks {
            let mask = Mask::new(m.x, m.y, m.width, m.height, m.data).map_err(js_error)?;
            let mut d = Detection::from_mask(mask, m.score);
            d.class = m.class;
            inner.push(d);
        }
        for b in lists.boxes {
            let bbox = BBox::checked(b.bbox.x, b.bbox.y, b.bbox.w, b.bbox.h).map_err(js_error)?;
            let mut d = Detection::from_box(bbox, b.score);
            d.class = b.class;
            inner.push(d);
        }
        Ok(Detections { inner })
    }

    /// Number of detections.
    #[wasm_bindgen(getter)]
    pub fn len(&self) -> usize {
        self.inner.len()
    }

    /// Whether there is no detection.
    #[wasm_bindgen(getter, js_name = isEmpty)]
    pub fn is_empty(&self) -> bool {
        self.inner.is_empty()
    }

    /// The detections as plain JS objects (copies the masks).
    #[wasm_bindgen(js_name = toList)]
    pub fn to_list(&self) -> Result<Ts<DetectionList>, JsValue> {
        ts(&DetectionList(
            self.inner.iter().map(DetectionJs::from).collect(),
        ))
    }
}

// ------------------------------------------------------------------------------------------
// Background detector

/// The adaptive background subtractor (thesis eq. 1–2) with morphology and connected
/// components: one mask per moving object, no model weights.
#[wasm_bindgen]
pub struct BackgroundDetector {
    inner: BackgroundSubtractor,
}

#[wasm_bindgen]
impl BackgroundDetector {
    /// A detector with the core's defaults, or the settings given (`BackgroundConfig`'s
    /// fields; missing ones keep their defaults).
    #[wasm_bindgen(constructor)]
    pub fn new(config: Option<Ts<BackgroundOptions>>) -> Result<BackgroundDetector, JsValue> {
        let cfg = match config {
            Some(c) => settings(c)?.into_core()?,
            None => BackgroundConfig::default(),
        };
        Ok(BackgroundDetector {
            inner: BackgroundSubtractor::new(cfg).map_err(js_error)?,
        })
    }

    /// Detects the moving objects of the frame in `buf` (frames must come in order).
    pub fn detect(&mut self, buf: &FrameBuffer) -> Result<Detections, JsValue> {
        let frame = buf.frame()?;
        let inner = self.inner.detect(&frame).map_err(js_error)?;
        Ok(Detections { inner })
    }

    /// Forgets the background model (e.g. after a cut or a size change).
    pub fn reset(&mut self) {
        self.inner.reset();
    }
}

/// Settings of the background detector; every field is optional and defaults to the core's
/// `BackgroundConfig::default()`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct BackgroundOptions {
    /// Frames averaged into the initial background.
    #[tsify(optional)]
    pub init_frames: Option<u32>,
    /// Learning rate of background pixels, in (0, 1].
    #[tsify(optional)]
    pub alpha: Option<f32>,
    /// Learning rate of foreground pixels (selective update); 0 = only by absorption.
    #[tsify(optional)]
    pub foreground_alpha: Option<f32>,
    /// Learn every pixel at `alpha` (the thesis' eq. 2 as written) instead of selectively.
    #[tsify(optional)]
    pub update_all: Option<bool>,
    /// Grey-level difference above which a pixel is foreground.
    #[tsify(optional)]
    pub threshold: Option<f32>,
    /// Frames after which a still foreground pixel is absorbed into the background (0 = never).
    #[tsify(optional)]
    pub absorb_frames: Option<u32>,
    /// Suppress cast shadows (with the core's default shadow settings).
    #[tsify(optional)]
    pub shadows: Option<bool>,
    /// Radius of the opening (0 = none).
    #[tsify(optional)]
    pub open_radius: Option<u32>,
    /// Radius of the closing (0 = none).
    #[tsify(optional)]
    pub close_radius: Option<u32>,
    /// Blobs with fewer pixels are dropped.
    #[tsify(optional)]
    pub min_area: Option<u32>,
    /// Pixel connectivity of blobs: 4 or 8.
    #[tsify(optional, type = "4 | 8")]
    pub connectivity: Option<u8>,
}

impl BackgroundOptions {
    fn into_core(self) -> Result<BackgroundConfig, JsValue> {
        let mut c = BackgroundConfig::default();
        if let Some(v) = self.init_frames {
            c.init_frames = v;
        }
        if let Some(v) = self.alpha {
            c.alpha = v;
        }
        match (self.update_all, self.foreground_alpha) {
            (Some(true), _) => c.update = UpdatePolicy::All,
            (_, Some(foreground_alpha)) => c.update = UpdatePolicy::Selective { foreground_alpha },
            _ => {}
        }
        if let Some(v) = self.threshold {
            c.threshold = v;
        }
        if let Some(v) = self.absorb_frames {
            c.absorb_frames = v;
        }
        if let Some(v) = self.shadows {
            c.shadow = v.then(ShadowConfig::default);
        }
        if let Some(v) = self.open_radius {
            c.open_radius = v;
        }
        if let Some(v) = self.close_radius {
            c.close_radius = v;
        }
        if let Some(v) = self.min_area {
            c.min_area = u64::from(v);
        }
        match self.connectivity {
            None => {}
            Some(4) => c.connectivity = Connectivity::Four,
            Some(8) => c.connectivity = Connectivity::Eight,
            Some(n) => {
                return Err(js_error(BindingError::Option {
                    name: "connectivity",
                    message: format!("{n} (expected 4 or 8)"),
                }))
            }
        }
        // The core checks ranges when the detector is built.
        Ok(c)
    }
}

// ------------------------------------------------------------------------------------------
// Tracker settings and shapes

/// Reads a field that may be absent (keep the default), `null` (no value) or a value.
fn double_option<'de, D, T>(d: D) -> Result<Option<Option<T>>, D::Error>
where
    D: serde::Deserializer<'de>,
    T: Deserialize<'de>,
{
    Option::<T>::deserialize(d).map(Some)
}

/// Weight, gate and scale of one pair-cost term; absent fields keep their defaults.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct TermOptions {
    /// Weight in the combined cost; 0 disables the term.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub weight: Option<f64>,
    /// Highest cost of this term a match may have; `null`: no gate.
    #[serde(
        deserialize_with = "double_option",
        skip_serializing_if = "Option::is_none"
    )]
    #[tsify(optional, type = "number | null")]
    pub gate: Option<Option<f64>>,
    /// Term-specific scale.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub scale: Option<f64>,
}

/// The pair-cost terms (see the core's `track::Terms` for what each measures).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct TermsOptions {
    /// Box IoU with the predicted box.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub iou: Option<TermOptions>,
    /// Box IoU with the track's last observed box (finds a lost track where it was last seen).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub last_iou: Option<TermOptions>,
    /// Generalised IoU.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub giou: Option<TermOptions>,
    /// How much of the detection's box lies outside the (grown) predicted box: a partly
    /// hidden shape lies inside its whole predicted box.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub ioa: Option<TermOptions>,
    /// Centre distance.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub centre: Option<TermOptions>,
    /// Size ratio.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub size: Option<TermOptions>,
    /// Mahalanobis distance under the Kalman filter.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub mahalanobis: Option<TermOptions>,
    /// Mask IoU.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub mask_iou: Option<TermOptions>,
    /// Shape context (thesis ch. 4.3).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub shape_context: Option<TermOptions>,
    /// Spatial colour (thesis ch. 4.4).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub colour: Option<TermOptions>,
    /// SIFT matches.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub sift: Option<TermOptions>,
}

/// Noise of the constant-velocity box Kalman filter, as fractions of the box size.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct MotionOptions {
    /// Position process noise per frame.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub std_position: Option<f64>,
    /// Velocity process noise per frame.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub std_velocity: Option<f64>,
    /// Measurement noise.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub std_measurement: Option<f64>,
}

/// The starting point of a tracker's settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, Tsify)]
#[serde(rename_all = "kebab-case")]
pub enum Preset {
    /// The core's defaults (`Config::default()`), tuned on MOTChallenge boxes.
    #[default]
    Default,
    /// The mask preset (`Config::masks()`): instance masks with frames, appearance in
    /// ambiguous clusters, re-identification by colour and SIFT, amodal completion, fragment
    /// merging.
    Masks,
}

/// The tracker's settings (the core's `track::Config`, every field optional: absent fields keep
/// the preset's values, by default the core's documented defaults). A test checks this mirrors
/// the core's fields exactly.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct TrackerConfig {
    /// What the other fields apply over: `"default"` (the core's defaults) or `"masks"`.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub preset: Option<Preset>,
    /// Detections scoring below this are ignored.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub min_score: Option<f64>,
    /// Detections at or above this score are matched first and may start tracks.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub high_score: Option<f64>,
    /// Score an unmatched detection needs to start a track.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub new_track_score: Option<f64>,
    /// Score thresholds from the sequence's own scores (`{ high_quantile, birth_quantile,
    /// window, warmup }`, absent fields at their defaults); `null`: the fixed thresholds.
    #[serde(
        deserialize_with = "double_option",
        skip_serializing_if = "Option::is_none"
    )]
    #[tsify(
        optional,
        type = "{ high_quantile?: number, birth_quantile?: number, window?: number, warmup?: number } | null"
    )]
    pub score_adaptation: Option<Option<serde_json::Value>>,
    /// An unmatched detection overlapping a matched one by more than this IoU starts no track.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub spawn_max_iou: Option<f64>,
    /// Matches a tentative track needs to be confirmed.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub min_hits: Option<u32>,
    /// Fewest matches confirmation needs however low the frame rate.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub min_hits_floor: Option<u32>,
    /// Weight of a match below the birth threshold towards confirmation (`null`: births
    /// need the threshold and every match counts 1).
    #[serde(
        deserialize_with = "double_option",
        skip_serializing_if = "Option::is_none"
    )]
    #[tsify(optional, type = "number | null")]
    pub birth_evidence: Option<Option<f64>>,
    /// Frames a tentative track may go unmatched.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub max_tentative_misses: Option<u32>,
    /// Frames a confirmed track stays lost (and re-identifiable) before removal.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub max_lost: Option<u32>,
    /// Report a confirmed track's tentative frames too.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub report_tentative: Option<bool>,
    /// Growth of a track's predicted box before region estimation, as a fraction of its size.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub region_margin: Option<f64>,
    /// Extra growth per frame unmatched.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub region_margin_per_miss: Option<f64>,
    /// Highest cost accepted for a high detection.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub max_cost: Option<f64>,
    /// The main gate at 30 fps (scaled by the frame interval, at most `max_cost`); `null`:
    /// `max_cost` at any frame rate.
    #[serde(
        deserialize_with = "double_option",
        skip_serializing_if = "Option::is_none"
    )]
    #[tsify(optional, type = "number | null")]
    pub reference_max_cost: Option<Option<f64>>,
    /// Highest cost accepted for a low detection.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub max_cost_low: Option<f64>,
    /// Highest cost accepted for a tentative track.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub max_cost_tentative: Option<f64>,
    /// Cost of leaving a track or detection unmatched; `null`: maximise matches first.
    #[serde(
        deserialize_with = "double_option",
        skip_serializing_if = "Option::is_none"
    )]
    #[tsify(optional, type = "number | null")]
    pub unmatched_cost: Option<Option<f64>>,
    /// Per-frame decay of a lost track's velocity.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub lost_velocity_decay: Option<f64>,
    /// Re-run a re-found lost track's filter along the gap (OC-SORT's re-update).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub reupdate_after_gap: Option<bool>,
    /// Tentative tracks compete with confirmed ones in the first association (ByteTrack).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub tentative_first: Option<bool>,
    /// Match lost tracks after the tracks seen in the previous frame.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub lost_second: Option<bool>,
    /// Terms of the main association.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub terms: Option<TermsOptions>,
    /// Terms of the re-identification stage.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub reid_terms: Option<TermsOptions>,
    /// Highest re-identification cost accepted.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub reid_max_cost: Option<f64>,
    /// Kalman filter noise.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub motion: Option<MotionOptions>,
    /// Lost tracks are matched only by re-identification (appearance), not by the main
    /// association.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub lost_reid_only: Option<bool>,
    /// With `lost_reid_only`, lost tracks missed for at most this many frames (at 30 fps)
    /// still take part in the main association.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub lost_main_frames: Option<u32>,
    /// A track being confirmed first looks for a lost track it re-identifies and takes its id.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub reid_at_confirmation: Option<bool>,
    /// Mask features and when appearance is computed (the core's `track::AppearanceConfig`:
    /// `shell`, `sift`, `colour`, `shape_context`, `lazy`, `ambiguity`, `refresh`,
    /// `whole_ratio`); checked by the core, unknown fields are errors.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional, type = "Record<string, unknown>")]
    pub appearance: Option<serde_json::Value>,
    /// How the shape context cost fits its transform: thesis Alg. 4 or Alg. 5.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional, type = "\"Contour\" | \"Sift\"")]
    pub shape_variant: Option<String>,
    /// SIFT matching (`ratio`, `cross_check`).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional, type = "{ ratio?: number, cross_check?: boolean }")]
    pub sift_matching: Option<serde_json::Value>,
    /// Fewest keypoints on both sides for the SIFT term to have data.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub sift_min_keypoints: Option<u32>,
    /// Update a partly hidden mask's track with the box of its whole shape.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub amodal: Option<bool>,
    /// Below this fraction of its reference area a matched mask does not correct the motion.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub sliver_ratio: Option<f64>,
    /// Merge a shape the detector split in two before its track is updated.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub merge_fragments: Option<bool>,
    /// Frames a confirmed track last seen whole may go undetected and still be reported at
    /// its predicted place.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub coast_frames: Option<u32>,
    /// Coast only when this tracker's own gaps of that length usually close
    /// (`{ min_probability }`); `null`: always coast up to `coast_frames`.
    #[serde(
        deserialize_with = "double_option",
        skip_serializing_if = "Option::is_none"
    )]
    #[tsify(optional, type = "{ min_probability?: number } | null")]
    pub coasting: Option<Option<serde_json::Value>>,
    /// Frames per second of the video (time-measuring frame counts scale to it); `null`:
    /// unknown, counts used as given.
    #[serde(
        deserialize_with = "double_option",
        skip_serializing_if = "Option::is_none"
    )]
    #[tsify(optional, type = "number | null")]
    pub frame_rate: Option<Option<f64>>,
    /// Scale the motion filter's process noise with the time between frames.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub motion_per_second: Option<bool>,
    /// The frame rate `max_lost` and `coast_frames` are given at.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub frame_counts_at: Option<f64>,
    /// The box reported for a matched detection: the detection's, the association filter's
    /// (box detections only), or (default) the detection smoothed only as far as smoothing
    /// agrees with the following detections of this sequence, mask detections included (the
    /// app's mask detectors ask for `detection`: a label's box is its mask's extent).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional, type = "\"detection\" | \"filter\" | \"adaptive\"")]
    pub report_box: Option<String>,
    /// Lost tracks follow a camera motion the seen tracks agree on (a pan, a shake).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub camera_motion: Option<bool>,
}

impl TrackerConfig {
    /// The core config: the given fields over the preset, nested objects merged field by
    /// field ([`TrackConfig::overlay`]).
    pub fn to_core(&self) -> Result<TrackConfig, JsValue> {
        let base = match self.preset.unwrap_or_default() {
            Preset::Default => TrackConfig::default(),
            Preset::Masks => TrackConfig::masks(),
        };
        let patch = TrackerConfig {
            preset: None,
            ..self.clone()
        };
        let v = serde_json::to_value(&patch).map_err(js_error)?;
        base.overlay(&v).map_err(js_error)
    }
}

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

// ------------------------------------------------------------------------------------------
// Offline pass (thesis ch. 5): options, progress, result

/// Settings of the re-linker (the core's `track::offline::RelinkConfig`, every field
/// optional: absent fields keep the core's defaults).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct RelinkOptions {
    /// A slave must end at most this long (seconds) before its master starts.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub max_gap_seconds: Option<f64>,
    /// Slaves kept per master, the most recently ended first.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub max_slaves: Option<u32>,
    /// Of those, how many with the most SIFT connections are kept (with frames only).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub appearance_keep: Option<u32>,
    /// Length (seconds) of the centroid history velocity and acceleration are fitted on.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub history_seconds: Option<f64>,
    /// Shapes smaller than this fraction of the median size near an end are not used for
    /// its motion (they are entering or leaving an occlusion).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub reliable_size: Option<f64>,
    /// Scale of the estimated acceleration in the rollout (1: the thesis, 0: constant velocity).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub acceleration: Option<f64>,
    /// Also roll the master back to the slave's end and average both errors.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub bidirectional: Option<bool>,
    /// Gate radius at zero gap, in shape sizes.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub gate_base: Option<f64>,
    /// Growth of the gate radius per second of gap, in shape sizes.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub gate_per_second: Option<f64>,
    /// Largest ratio of the two ends' sizes a join accepts.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub max_size_ratio: Option<f64>,
    /// How joins are chosen: all together (min-cost matching) or the thesis' greedy order.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional, type = "\"global\" | \"greedy\"")]
    pub solver: Option<JoinSolver>,
    /// Refuse a join whose predicted path leaves the image.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub stay_in_view: Option<bool>,
}

/// Settings of gap filling (the core's `FillConfig`; absent fields keep their defaults).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct FillOptions {
    /// Longest gap filled, in missing frames (0: no filling).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub max_gap: Option<u32>,
    /// Also fill gaps inside one online track, not only between joined ones.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub within_tracks: Option<bool>,
    /// Path of the filled shapes.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional, type = "\"linear\" | \"kalman\"")]
    pub trajectory: Option<Trajectory>,
    /// Gaps between two partial mask views (below this fraction of the shape's usual area)
    /// are hides and are not filled (0: fill them too).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub hidden_ratio: Option<f64>,
    /// Keep the online pass's coasted shapes after an identity's last observation.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub coasted_tails: Option<bool>,
    /// Longest gap filled in seconds (instead of `max_gap` frames).
    #[serde(
        deserialize_with = "double_option",
        skip_serializing_if = "Option::is_none"
    )]
    #[tsify(optional, type = "number | null")]
    pub max_gap_seconds: Option<Option<f64>>,
}

/// SIFT detector settings for the appearance snapshots (the core's `SiftConfig`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct SiftOptions {
    /// Layers per octave (1..=8).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub n_octave_layers: Option<u32>,
    /// Contrast threshold.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub contrast_threshold: Option<f32>,
    /// Edge rejection threshold.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub edge_threshold: Option<f32>,
    /// Blur of the first layer.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub sigma: Option<f32>,
    /// Upsample the crop 2× first.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub upsample: Option<bool>,
    /// Keep only the strongest keypoints; `null`: all.
    #[serde(
        deserialize_with = "double_option",
        skip_serializing_if = "Option::is_none"
    )]
    #[tsify(optional, type = "number | null")]
    pub max_keypoints: Option<Option<u32>>,
    /// Downscale crops whose longer side exceeds this; `null`: never.
    #[serde(
        deserialize_with = "double_option",
        skip_serializing_if = "Option::is_none"
    )]
    #[tsify(optional, type = "number | null")]
    pub max_side: Option<Option<u32>>,
}

/// Descriptor matching settings (the core's `MatchConfig`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct MatchOptions {
    /// Lowe's ratio.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub ratio: Option<f32>,
    /// Require mutual nearest neighbours.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub cross_check: Option<bool>,
}

/// Appearance snapshots (the core's `AppearanceConfig`): a small grey crop of each track's
/// first and last appearance, taken from the frames during the online pass.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct AppearanceOptions {
    /// Take snapshots at all (only `update` with pixels can).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub enabled: Option<bool>,
    /// Longer side crops are downscaled to.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub max_side: Option<u32>,
    /// SIFT detector settings.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub sift: Option<SiftOptions>,
    /// Descriptor matching settings.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub matching: Option<MatchOptions>,
}

/// What a tracker needs to run the offline pass at the end: the video's frame rate, and the
/// offline stages' settings (every one optional; the online part is the tracker's config).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Tsify)]
#[serde(deny_unknown_fields)]
pub struct OfflineOptions {
    /// Frames per second of the video: the re-linker's filter steps `Δt = 1/fps`, and its
    /// gates are in seconds.
    pub fps: f64,
    /// Image width, for box-only tracking (`updateDetections`); frames tell it otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub width: Option<u32>,
    /// Image height, for box-only tracking.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub height: Option<u32>,
    /// The re-linker.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub relink: Option<RelinkOptions>,
    /// Gap filling.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub fill: Option<FillOptions>,
    /// Appearance snapshots.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub appearance: Option<AppearanceOptions>,
    /// Identities shorter than this many seconds of observed shapes are dropped.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub min_track_seconds: Option<f64>,
}

impl OfflineOptions {
    /// The core config: the given offline settings over the defaults, around `online`.
    pub fn to_core(&self, online: TrackConfig) -> Result<OfflineConfig, JsValue> {
        // Every part takes defaults for absent fields, so a JSON round trip does the overlay.
        let mut parts = serde_json::json!({
            "relink": self.relink.clone().unwrap_or_default(),
            "fill": self.fill.clone().unwrap_or_default(),
            "appearance": self.appearance.clone().unwrap_or_default(),
        });
        if let (Some(m), Some(s)) = (parts.as_object_mut(), self.min_track_seconds) {
            m.insert("min_track_seconds".into(), serde_json::json!(s));
        }
        let mut cfg: OfflineConfig = serde_json::from_value(parts).map_err(js_error)?;
        cfg.online = online;
        cfg.validate().map_err(js_error)?;
        Ok(cfg)
    }
}

/// Where the offline pass is: its phase and how far into it, in `[0, 1]`. `finish` reports
/// the phases after the online pass, in order: candidates, appearance (only with frames),
/// matching, filling, done.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Tsify)]
pub struct OfflineProgress {
    /// Current phase.
    #[tsify(
        type = "\"online\" | \"candidates\" | \"appearance\" | \"matching\" | \"filling\" | \"done\""
    )]
    pub phase: Phase,
    /// Fraction of the phase done.
    pub fraction: f64,
}

impl From<Progress> for OfflineProgress {
    fn from(p: Progress) -> Self {
        OfflineProgress {
            phase: p.phase,
            fraction: p.fraction,
        }
    }
}

/// One join the re-linker made: track `master` (an online id) continues track `slave`, and
/// now carries the slave's identity.
#[derive(Debug, Clone, PartialEq, Serialize, Tsify)]
pub struct JoinJs {
    /// Online id of the track that ended.
    pub slave: i64,
    /// Online id of the track that continues it.
    pub master: i64,
    /// The slave's last frame.
    pub slave_last: u32,
    /// The master's first frame.
    pub master_first: u32,
    /// Gate-normalised cost of the join, in `[0, 1]`.
    pub cost: f64,
    /// SIFT connections between the two ends, when both had appearance snapshots.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub connections: Option<u32>,
}

impl From<&Join> for JoinJs {
    fn from(j: &Join) -> Self {
        JoinJs {
            slave: j.slave as i64,
            master: j.master as i64,
            slave_last: j.slave_last,
            master_first: j.master_first,
            cost: j.cost,
            connections: j.connections.map(|c| c as u32),
        }
    }
}

/// What `finish` returns.
#[derive(Debug, Clone, PartialEq, Serialize, Tsify)]
pub struct OfflineOutput {
    /// Every record after the offline pass, by frame then id: the online records under their
    /// joined ids, and the filled-in ones (`interpolated: true`).
    pub records: Records,
    /// The joins made, by the master's first frame.
    pub joins: Vec<JoinJs>,
    /// Number of records filled in.
    pub filled: u32,
    /// The records filled in by this pass (not those the online pass had already coasted
    /// over, which are in `records` flagged interpolated too).
    pub added: Records,
}

#[wasm_bindgen]
extern "C" {
    /// A progress callback: called with each progress report of the offline pass.
    // Parenthesised: the generated signature appends `| null` to optional parameters.
    #[wasm_bindgen(typescript_type = "((progress: OfflineProgress) => void)")]
    pub type ProgressCallback;
}

/// A JS exception's message (an `Error`'s message, else the value as text).
fn thrown_message(v: &JsValue) -> String {
    if let Some(e) = v.dyn_ref::<js_sys::Error>() {
        return String::from(e.message());
    }
    if let Some(s) = v.as_string() {
        return s;
    }
    js_sys::JSON::stringify(v)
        .ok()
        .and_then(|s| s.as_string())
        .unwrap_or_else(|| format!("{v:?}"))
}

// ------------------------------------------------------------------------------------------
// Tracker

/// The shapes one update reports.
#[derive(Debug, Clone, PartialEq, Serialize, Tsify)]
#[serde(transparent)]
pub struct Shapes(pub Vec<ShapeJs>);

/// One reported shape as the tracker keeps it: the shape without its mask bitmap, and the
/// mask as RLE (a few hundred bytes instead of a bitmap the size of the box), so a long video's
/// history stays small.
#[derive(Debug, Clone)]
struct Kept {
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
struct OfflineState {
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
        self.check_size(buf.width, buf.height)?;
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

// ------------------------------------------------------------------------------------------
// Synthetic scene (the embedded demo)

/// The synthetic scenes the app offers, by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Tsify)]
#[serde(rename_all = "kebab-case")]
pub enum ScenePreset {
    /// 1280×720, 600 frames, 12 shapes entering and leaving, two occluding bars.
    Demo,
    /// The core's default scene: 640×480, 300 frames, 10 shapes.
    Default,
    /// Crossings and occlusions: 8 shapes bouncing behind two bars, 640×480.
    Occlusion,
}

/// Frames between two saved scene states: stepping back replays at most this many frames.
const CHECKPOINT_EVERY: u32 = 100;

/// A deterministic synthetic sequence with ground truth, rendered in wasm straight into a
/// [`FrameBuffer`]: the demo needs nothing downloaded.
#[wasm_bindgen]
pub struct SynthScene {
    /// Positioned at the next frame to render in order.
    scene: Scene,
    /// Scene states before frames 1, 1+N, 1+2N, ... for random access (display scrubbing).
    checkpoints: Vec<Scene>,
}

#[wasm_bindgen]
impl SynthScene {
    /// The named scene.
    #[wasm_bindgen(constructor)]
    pub fn new(preset: Ts<ScenePreset>) -> Result<SynthScene, JsValue> {
        let cfg = match rust(preset)? {
            ScenePreset::Demo => SynthConfig::demo(),
            ScenePreset::Default => SynthConfig::default(),
            ScenePreset::Occlusion => SynthConfig::occlusion_scene(0),
        };
        let scene = Scene::new(cfg).map_err(js_error)?;
        Ok(SynthScene {
            checkpoints: vec![scene.clone()],
            scene,
        })
    }

    /// Frame width.
    #[wasm_bindgen(getter)]
    pub fn width(&self) -> u32 {
        self.scene.config().width
    }

    /// Frame height.
    #[wasm_bindgen(getter)]
    pub fn height(&self) -> u32 {
        self.scene.config().height
    }

    /// Number of frames.
    #[wasm_bindgen(getter)]
    pub fn frames(&self) -> u32 {
        self.scene.config().frames
    }

    /// Frame rate.
    #[wasm_bindgen(getter)]
    pub fn fps(&self) -> f64 {
        self.scene.config().fps
    }

    /// Renders frame `n` (1-based) as RGBA into `buf`, with its ground truth and the scene's
    /// own (noisy) detections. In-order frames cost one render; others replay from the nearest
    /// saved state.
    pub fn render(&mut self, n: f64, buf: &mut FrameBuffer) -> Result<SceneFrame, JsValue> {
        let n = whole_u32("n", n)?;
        let (w, h, frames) = (self.width(), self.height(), self.frames());
        if n < 1 || n > frames {
            return Err(js_error(BindingError::FrameRange { frame: n, frames }));
        }
        if (buf.width, buf.height) != (w, h) {
            return Err(js_error(BindingError::SizeChanged {
                expected: (w, h),
                got: (buf.width, buf.height),
            }));
        }
        if self.scene.next_index() != n {
            let k = ((n - 1) / CHECKPOINT_EVERY) as usize;
            // Checkpoints exist for every block already reached in order; beyond, start from
            // the last one.
            let cp = k.min(self.checkpoints.len().saturating_sub(1));
            if let Some(s) = self.checkpoints.get(cp) {
                if self.scene.next_index() > n || s.next_index() > self.scene.next_index() {
                    self.scene = s.clone();
                }
            }
        }
        let mut frame = None;
        while self.scene.next_index() <= n {
            let next = self.scene.next_index();
            if (next - 1) % CHECKPOINT_EVERY == 0 {
                let k = ((next - 1) / CHECKPOINT_EVERY) as usize;
                if k == self.checkpoints.len() {
                    self.checkpoints.push(self.scene.clone());
                }
            }
            frame = self.scene.frame();
            if frame.is_none() {
                break;
            }
        }
        let Some(f) = frame.filter(|f| f.index == n) else {
            return Err(js_error(BindingError::FrameRange { frame: n, frames }));
        };
        for (dst, src) in buf.data.chunks_exact_mut(4).zip(f.image.chunks_exact(3)) {
            dst[..3].copy_from_slice(src);
            dst[3] = 255;
        }
        Ok(SceneFrame {
            index: f.index,
            gt: f.gt_records(),
            detections: f.detections,
        })
    }
}

/// One rendered synthetic frame's ground truth and detections (the pixels are in the buffer).
#[wasm_bindgen]
pub struct SceneFrame {
    index: u32,
    gt: Vec<Record>,
    detections: Vec<Detection>,
}

#[wasm_bindgen]
impl SceneFrame {
    /// Frame number (1-based).
    #[wasm_bindgen(getter)]
    pub fn index(&self) -> u32 {
        self.index
    }

    /// Ground truth of the visible objects, as records with masks.
    #[wasm_bindgen(js_name = groundTruth)]
    pub fn ground_truth(&self) -> Result<Ts<Records>, JsValue> {
        ts(&from_core_records(&self.gt))
    }

    /// The scene's own noisy mask detections (misses, jitter, false positives).
    pub fn detections(&self) -> Detections {
        Detections {
            inner: self.detections.clone(),
        }
    }
}

// ------------------------------------------------------------------------------------------
// Evaluation

/// How to score: which similarity, threshold and preprocessing (defaults: box IoU, 0.5, none).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct EvalOptions {
    /// Pair similarity: box IoU or mask IoU.
    #[tsify(optional, type = "\"box\" | \"mask\"")]
    pub similarity: Option<String>,
    /// Similarity a CLEAR or Identity match needs.
    #[tsify(optional)]
    pub threshold: Option<f64>,
    /// TrackEval's preprocessing of a benchmark: "mot15", "mot17", "mot20", "mots"; absent:
    /// score every record as given.
    #[tsify(optional, type = "\"mot15\" | \"mot17\" | \"mot20\" | \"mots\"")]
    pub benchmark: Option<String>,
}

impl EvalOptions {
    fn to_core(&self) -> Result<EvalConfig, JsValue> {
        let masks = match self.similarity.as_deref() {
            None | Some("box") => false,
            Some("mask") => true,
            Some(other) => {
                return Err(js_error(BindingError::Option {
                    name: "similarity",
                    message: format!("{other:?} (expected \"box\" or \"mask\")"),
                }))
            }
        };
        let mut cfg = match self.benchmark.as_deref() {
            None => EvalConfig {
                preprocessing: Preprocessing::None,
                ..EvalConfig::default()
            },
            Some(b @ ("mot15" | "mot17" | "mot20" | "mots")) => EvalConfig::for_benchmark(b, masks),
            Some(other) => {
                return Err(js_error(BindingError::Option {
                    name: "benchmark",
                    message: format!("{other:?} (expected mot15, mot17, mot20 or mots)"),
                }))
            }
        };
        cfg.similarity = if masks {
            Similarity::MaskIou
        } else {
            Similarity::BoxIou
        };
        if let Some(t) = self.threshold {
            cfg.threshold = t;
        }
        Ok(cfg)
    }
}

/// The headline MOT metrics, as TrackEval prints them (percentages 0–100, counts).
#[derive(Debug, Clone, PartialEq, Serialize, Tsify)]
pub struct Scores {
    /// HOTA.
    pub hota: f64,
    /// Detection accuracy (HOTA's).
    pub deta: f64,
    /// Association accuracy (HOTA's).
    pub assa: f64,
    /// Localisation accuracy (HOTA's).
    pub loca: f64,
    /// MOTA.
    pub mota: f64,
    /// MOTP.
    pub motp: f64,
    /// IDF1.
    pub idf1: f64,
    /// Identity precision.
    pub idp: f64,
    /// Identity recall.
    pub idr: f64,
    /// Identity switches.
    pub idsw: u64,
    /// False positives.
    pub fp: u64,
    /// False negatives (misses).
    #[serde(rename = "fn")]
    pub fn_: u64,
    /// Fragmentations.
    pub frag: u64,
    /// Mostly tracked ground-truth tracks.
    pub mt: u64,
    /// Partly tracked.
    pub pt: u64,
    /// Mostly lost.
    pub ml: u64,
    /// Ground-truth tracks.
    pub gt_ids: u64,
    /// Tracker tracks.
    pub ids: u64,
}

impl From<&Summary> for Scores {
    fn from(s: &Summary) -> Self {
        Scores {
            hota: s.hota,
            deta: s.det_a,
            assa: s.ass_a,
            loca: s.loc_a,
            mota: s.mota,
            motp: s.motp,
            idf1: s.idf1,
            idp: s.idp,
            idr: s.idr,
            idsw: s.idsw,
            fp: s.fp,
            fn_: s.fn_,
            frag: s.frag,
            mt: s.mt,
            pt: s.pt,
            ml: s.ml,
            gt_ids: s.gt_ids,
            ids: s.ids,
        }
    }
}

/// Scores `results` against `gt` over frames `1..=frames` with the core's evaluator (the same
/// numbers as TrackEval).
#[wasm_bindgen]
pub fn evaluate(
    gt: Ts<Records>,
    results: Ts<Records>,
    frames: u32,
    options: Option<Ts<EvalOptions>>,
) -> Result<Ts<Scores>, JsValue> {
    let cfg = match options {
        Some(o) => settings(o)?.to_core()?,
        None => EvalOptions::default().to_core()?,
    };
    let gt = to_core_records(rust(gt)?)?;
    let res = to_core_records(rust(results)?)?;
    let input = [SequenceInput::new("sequence", frames, gt, res)];
    let r = eval::evaluate(&input, &cfg).map_err(js_error)?;
    ts(&Scores::from(&r.summary().combined))
}
