//! Scalabel JSON, the format of BDD100K's tracking labels and of trackers evaluated on it: a
//! list of frames `{name, videoName, frameIndex, labels: [{id, category, attributes, score?,
//! box2d: {x1, y1, x2, y2} | rle: {counts, size: [h, w]} | poly2d …}]}`, or Scalabel's dataset
//! form `{"frames": [...], "config": …}`.
//!
//! - [`parse_scalabel`] reads a file into [`ScalabelFrame`]s. Every field the reader does not
//!   model is kept (including `null`s), so [`write_scalabel`] writes a file read unchanged
//!   back as the same JSON.
//! - [`to_records`] turns frames into the house [`Record`]s: frame = `frameIndex + 1` (records
//!   are 1-based), string ids → integers per video (a plain positive integer keeps its value,
//!   other strings are numbered in order of first appearance; the [`IdMap`] restores them),
//!   categories → class integers ([`Categories`], BDD100K's MOT list first), `score` (absent:
//!   1), `attributes.occluded` → [`RecordFlags::occluded`]; labels flagged `crowd` can be left
//!   out (BDD100K's evaluation ignores them).
//! - [`from_records`] writes records (a tracker's output) as frames of one video.
//!
//! **Boxes.** Scalabel's `box2d` includes its last pixel: width = `x2 − x1 + 1` (Scalabel's own
//! `box2d_to_bbox` in `scalabel/label/transforms.py`), so a box `(x, y, w, h)` is written as
//! `x2 = x + w − 1`. A label with an `rle` mask gets the mask's tight box.
//!
//! **Errors** carry the line and column of the offending value: malformed JSON, a frame without
//! an integer `frameIndex`, a label without an `id` (string or integer), a `box2d` with a
//! missing or non-finite coordinate or `x2 < x1 − 1`, a malformed RLE or one whose size
//! disagrees with the other masks of the file, two labels with one id in a frame.

use std::collections::BTreeMap;

use serde_json::value::RawValue;
use serde_json::{Map, Value};

use super::{json_err, line_col, IoError, JsonCtx as Ctx, Record, RecordFlags, Rle};
use crate::frame::BBox;

/// BDD100K's MOT categories, numbered from 1 as its evaluation does.
pub const BDD_CATEGORIES: [&str; 8] = [
    "pedestrian",
    "rider",
    "car",
    "truck",
    "bus",
    "train",
    "motorcycle",
    "bicycle",
];

/// One labelled object in one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct ScalabelLabel {
    /// Track id (integers in the file are read as their decimal text).
    pub id: String,
    /// Category name.
    pub category: Option<String>,
    /// Confidence, when the label is a prediction.
    pub score: Option<f64>,
    /// Box (`box2d` converted, inclusive end), or the mask's tight box.
    pub bbox: Option<BBox>,
    /// Instance mask.
    pub rle: Option<Rle>,
    /// `attributes.occluded`.
    pub occluded: bool,
    /// `attributes.crowd`: a group of objects, not one (evaluation ignores it).
    pub crowd: bool,
    /// `attributes.interpolated`: a box the tracker predicted or filled, not a detection
    /// (this crate's attribute; Scalabel tools ignore attributes they do not know).
    pub interpolated: bool,
    /// Every field of the label object as read; [`write_scalabel`] writes it unchanged.
    /// Empty for labels made by [`from_records`].
    pub raw: Map<String, Value>,
}

/// One frame.
#[derive(Debug, Clone, PartialEq)]
pub struct ScalabelFrame {
    /// Image name.
    pub name: Option<String>,
    /// Video name.
    pub video_name: Option<String>,
    /// 0-based frame index within the video.
    pub frame_index: u32,
    /// Labels.
    pub labels: Vec<ScalabelLabel>,
    /// Every other field of the frame object as read (without `labels`).
    pub raw: Map<String, Value>,
}

/// Track ids of one video: the file's strings ↔ the records' integers. An id written as a
/// positive integer in plain decimal (`"7"`, not `"07"`) keeps its value, so a tracker's ids
/// survive a round trip through the file; any other string (`"a-00122062"`), or one whose
/// value is already taken, gets the integer after the largest given so far (1, 2, … in order
/// of first appearance when no id is a number).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct IdMap {
    to_int: BTreeMap<String, i64>,
    to_str: BTreeMap<i64, String>,
}

/// The largest id kept as its own value: JavaScript's largest exact integer, since records
/// reach the browser as JS numbers.
const MAX_KEPT_ID: i64 = (1 << 53) - 1;

/// `s` as an id of its own value: a positive integer in plain decimal, at most
/// [`MAX_KEPT_ID`].
fn plain_integer(s: &str) -> Option<i64> {
    let plain = !s.is_empty() && !s.starts_with('0') && s.bytes().all(|b| b.is_ascii_digit());
    plain
        .then(|| s.parse::<i64>().ok())
        .flatten()
        .filter(|&i| (1..=MAX_KEPT_ID).contains(&i))
}

impl IdMap {
    /// The integer of `s` (see [`IdMap`]).
    pub fn intern(&mut self, s: &str) -> i64 {
        if let Some(&i) = self.to_int.get(s) {
            return i;
        }
        let i = match plain_integer(s) {
            Some(i) if !self.to_str.contains_key(&i) => i,
            _ => self.to_str.last_key_value().map_or(1, |(&k, _)| k + 1),
        };
        self.to_str.insert(i, s.to_string());
        self.to_int.insert(s.to_string(), i);
        i
    }

    /// The string of integer id `i` (`None` for ids this map did not give).
    pub fn name(&self, i: i64) -> Option<&str> {
        self.to_str.get(&i).map(String::as_str)
    }

    /// Number of ids.
    pub fn len(&self) -> usize {
        self.to_str.len()
    }

    /// Whether no id was given.
    pub fn is_empty(&self) -> bool {
        self.to_str.is_empty()
    }
}

/// Category names ↔ class integers: BDD100K's MOT categories as 1–8, other names numbered on
/// from 9 in order of first appearance; no category is class −1.
#[derive(Debug, Clone, PartialEq)]
pub struct Categories {
    names: Vec<String>,
}

impl Default for Categories {
    fn default() -> Self {
        Self {
            names: BDD_CATEGORIES.iter().map(|s| s.to_string()).collect(),
        }
    }
}

impl Categories {
    /// The class of `name`, adding it when new.
    pub fn class(&mut self, name: Option<&str>) -> i32 {
        let Some(name) = name else {
            return -1;
        };
        match self.names.iter().position(|n| n == name) {
            Some(k) => k as i32 + 1,
            None => {
                self.names.push(name.to_string());
                self.names.len() as i32
            }
        }
    }

    /// The name of class `c` (`None` for −1 and unknown classes).
    pub fn name(&self, c: i32) -> Option<&str> {
        // Checked: `i32::MIN - 1` overflows (a class a MOT file can hold).
        c.checked_sub(1)
            .and_then(|k| usize::try_from(k).ok())
            .and_then(|k| self.names.get(k))
            .map(String::as_str)
    }
}

/// Reads a Scalabel file (a list of frames, or `{"frames": [...]}`).
pub fn parse_scalabel(text: &str, file: &str) -> Result<Vec<ScalabelFrame>, IoError> {
    let ctx = Ctx { file, text };
    let top: &RawValue = serde_json::from_str(text).map_err(|e| json_err(file, e))?;
    let frames: Vec<&RawValue> = match serde_json::from_str::<Vec<&RawValue>>(top.get()) {
        Ok(v) => v,
        Err(_) => {
            let obj: BTreeMap<String, &RawValue> = serde_json::from_str(top.get())
                .map_err(|_| ctx.err_at(top, "expected a list of frames or {\"frames\": [...]}"))?;
            let f = obj
                .get("frames")
                .ok_or_else(|| ctx.err_at(top, "no \"frames\" list"))?;
            serde_json::from_str(f.get()).map_err(|_| ctx.err_at(f, "\"frames\" is not a list"))?
        }
    };
    let mut size: Option<(u32, u32)> = None;
    frames
        .iter()
        .map(|raw| frame_from_raw(&ctx, raw, &mut size))
        .collect()
}

fn frame_from_raw(
    ctx: &Ctx<'_>,
    raw: &RawValue,
    size: &mut Option<(u32, u32)>,
) -> Result<ScalabelFrame, IoError> {
    let obj: BTreeMap<String, &RawValue> =
        serde_json::from_str(raw.get()).map_err(|_| ctx.err_at(raw, "a frame is not an object"))?;
    let frame_index = match obj.get("frameIndex") {
        Some(v) => serde_json::from_str::<u32>(v.get())
            .map_err(|_| ctx.err_at(v, "frameIndex must be an integer ≥ 0"))?,
        None => return Err(ctx.err_at(raw, "a frame without frameIndex")),
    };
    let text_of = |k: &str| -> Option<String> {
        obj.get(k).and_then(|v| {
            serde_json::from_str::<Option<String>>(v.get())
                .ok()
                .flatten()
        })
    };
    let mut labels = Vec::new();
    if let Some(l) = obj.get("labels") {
        let list: Option<Vec<&RawValue>> =
            serde_json::from_str(l.get()).map_err(|_| ctx.err_at(l, "labels is not a list"))?;
        let mut seen = std::collections::BTreeSet::new();
        for lr in list.unwrap_or_default() {
            let label = label_from_raw(ctx, lr, size)?;
            if !seen.insert(label.id.clone()) {
                return Err(ctx.err_at(
                    lr,
                    format!("two labels with id {:?} in frame {frame_index}", label.id),
                ));
            }
            labels.push(label);
        }
    }
    let mut all: Map<String, Value> =
        serde_json::from_str(raw.get()).map_err(|e| json_err(ctx.file, e))?;
    // A list of labels lives in `labels`; `raw` keeps an empty list in its place, or the
    // original `null`, or nothing when the file had no `labels`, so the writer can tell.
    if let Some(Value::Array(_)) = all.get("labels") {
        all.insert("labels".into(), Value::Array(Vec::new()));
    }
    Ok(ScalabelFrame {
        name: text_of("name"),
        video_name: text_of("videoName"),
        frame_index,
        labels,
        raw: all,
    })
}

fn label_from_raw(
    ctx: &Ctx<'_>,
    raw: &RawValue,
    size: &mut Option<(u32, u32)>,
) -> Result<ScalabelLabel, IoError> {
    let obj: BTreeMap<String, &RawValue> =
        serde_json::from_str(raw.get()).map_err(|_| ctx.err_at(raw, "a label is not an object"))?;
    let id = match obj
        .get("id")
        .map(|v| serde_json::from_str::<Value>(v.get()))
    {
        Some(Ok(Value::String(s))) => s,
        Some(Ok(Value::Number(n))) => n.to_string(),
        _ => return Err(ctx.err_at(raw, "a label without an id (string or integer)")),
    };
    let nullable = |k: &str| obj.get(k).filter(|v| v.get() != "null");
    let category = match nullable("category") {
        Some(v) => Some(
            serde_json::from_str::<String>(v.get())
                .map_err(|_| ctx.err_at(v, "category must be a string"))?,
        ),
        None => None,
    };
    let score = match nullable("score") {
        Some(v) => {
            let s: f64 = serde_json::from_str(v.get())
                .map_err(|_| ctx.err_at(v, "score must be a number"))?;
            Some(s)
        }
        None => None,
    };
    let bbox = match nullable("box2d") {
        Some(v) => {
            let b: BTreeMap<String, Value> = serde_json::from_str(v.get())
                .map_err(|_| ctx.err_at(v, "box2d must be an object"))?;
            let coord = |k: &str| -> Result<f64, IoError> {
                b.get(k)
                    .and_then(Value::as_f64)
                    .filter(|x| x.is_finite() && x.abs() <= 1e9)
                    .ok_or_else(|| ctx.err_at(v, format!("box2d.{k} must be a finite number")))
            };
            let (x1, y1, x2, y2) = (coord("x1")?, coord("y1")?, coord("x2")?, coord("y2")?);
            // Inclusive ends: a one-pixel box has x2 = x1; anything narrower is wrong.
            if x2 < x1 - 1.0 || y2 < y1 - 1.0 {
                return Err(ctx.err_at(v, format!("box2d has x2 < x1 or y2 < y1: {b:?}")));
            }
            Some(BBox::new(x1, y1, x2 - x1 + 1.0, y2 - y1 + 1.0))
        }
        None => None,
    };
    let rle = match nullable("rle") {
        Some(v) => {
            #[derive(serde::Deserialize)]
            struct RleJson {
                counts: String,
                size: [u32; 2],
            }
            let r: RleJson = serde_json::from_str(v.get())
                .map_err(|_| ctx.err_at(v, "rle must be {counts: string, size: [h, w]}"))?;
            let [h, w] = r.size;
            if size.is_some_and(|s| s != (h, w)) {
                return Err(ctx.err_at(
                    v,
                    format!("rle size {h}x{w} differs from the file's other masks {size:?}"),
                ));
            }
            *size = Some((h, w));
            let (line, _) = {
                let offset = (v.get().as_ptr() as usize).wrapping_sub(ctx.text.as_ptr() as usize);
                line_col(ctx.text, offset)
            };
            Some(
                Rle::from_compressed(&r.counts, h, w).map_err(|source| IoError::Rle {
                    file: ctx.file.to_string(),
                    line,
                    source,
                })?,
            )
        }
        None => None,
    };
    let attr = |k: &str| -> bool {
        obj.get("attributes")
            .and_then(|a| serde_json::from_str::<Map<String, Value>>(a.get()).ok())
            .and_then(|a| a.get(k).and_then(Value::as_bool))
            .unwrap_or(false)
    };
    let all: Map<String, Value> =
        serde_json::from_str(raw.get()).map_err(|e| json_err(ctx.file, e))?;
    let bbox = match (&rle, bbox) {
        (Some(r), None) if r.area() > 0 => Some(r.bbox()),
        (_, b) => b,
    };
    Ok(ScalabelLabel {
        id,
        category,
        score,
        bbox,
        rle,
        occluded: attr("occluded"),
        crowd: attr("crowd"),
        interpolated: attr("interpolated"),
        raw: all,
    })
}

/// Writes frames as a Scalabel JSON list (labels read from a file are written as read).
pub fn write_scalabel(frames: &[ScalabelFrame]) -> Result<String, IoError> {
    // One frame's JSON value at a time: all of them at once took ~1.8 KB a frame (1.9 GB for
    // 2^20 frames) where the text is a tenth of it.
    let mut out = String::from("[");
    for (i, f) in frames.iter().enumerate() {
        if i > 0 {
            out.push(',');
        }
        let text = serde_json::to_string(&frame_json(f)).map_err(|e| IoError::Invalid {
            file: "scalabel".into(),
            line: 0,
            message: e.to_string(),
        })?;
        out.push_str(&text);
    }
    out.push(']');
    Ok(out)
}

fn frame_json(f: &ScalabelFrame) -> Value {
    let mut m = f.raw.clone();
    if let Some(n) = &f.name {
        m.insert("name".into(), Value::String(n.clone()));
    }
    if let Some(v) = &f.video_name {
        m.insert("videoName".into(), Value::String(v.clone()));
    }
    m.insert("frameIndex".into(), Value::from(f.frame_index));
    // Keep a file's `labels: null` or missing `labels` when the frame has none.
    let keep = f.labels.is_empty() && !matches!(m.get("labels"), Some(Value::Array(_)));
    if !keep {
        m.insert(
            "labels".into(),
            Value::Array(f.labels.iter().map(label_json).collect()),
        );
    }
    Value::Object(m)
}

fn label_json(l: &ScalabelLabel) -> Value {
    if !l.raw.is_empty() {
        return Value::Object(l.raw.clone());
    }
    let mut m = Map::new();
    m.insert("id".into(), Value::String(l.id.clone()));
    if let Some(c) = &l.category {
        m.insert("category".into(), Value::String(c.clone()));
    }
    if let Some(s) = l.score {
        m.insert("score".into(), Value::from(s));
    }
    let mut attrs = Map::new();
    attrs.insert("occluded".into(), Value::Bool(l.occluded));
    attrs.insert("crowd".into(), Value::Bool(l.crowd));
    if l.interpolated {
        attrs.insert("interpolated".into(), Value::Bool(true));
    }
    m.insert("attributes".into(), Value::Object(attrs));
    match (&l.rle, l.bbox) {
        (Some(r), _) => {
            let mut rm = Map::new();
            rm.insert("counts".into(), Value::String(r.to_compressed()));
            rm.insert("size".into(), Value::from(vec![r.height, r.width]));
            m.insert("rle".into(), Value::Object(rm));
        }
        (None, Some(b)) => {
            let mut bm = Map::new();
            bm.insert("x1".into(), Value::from(b.x));
            bm.insert("y1".into(), Value::from(b.y));
            bm.insert("x2".into(), Value::from(b.x + b.w - 1.0));
            bm.insert("y2".into(), Value::from(b.y + b.h - 1.0));
            m.insert("box2d".into(), Value::Object(bm));
        }
        (None, None) => {}
    }
    Value::Object(m)
}

/// The frames of each video (by `videoName`; frames without one under `""`), in file order.
pub fn split_videos(frames: Vec<ScalabelFrame>) -> BTreeMap<String, Vec<ScalabelFrame>> {
    let mut out: BTreeMap<String, Vec<ScalabelFrame>> = BTreeMap::new();
    for f in frames {
        out.entry(f.video_name.clone().unwrap_or_default())
            .or_default()
            .push(f);
    }
    out
}

/// The records of one video's frames (see the module docs); labels without a box or mask
/// (tags) and, with `skip_crowd`, crowd labels are left out. `ids` and `categories` are
/// extended with what the frames name.
pub fn to_records(
    frames: &[ScalabelFrame],
    ids: &mut IdMap,
    categories: &mut Categories,
    skip_crowd: bool,
) -> Vec<Record> {
    let mut out = Vec::new();
    for f in frames {
        for l in &f.labels {
            let Some(bbox) = l.bbox else {
                continue;
            };
            if skip_crowd && l.crowd {
                continue;
            }
            out.push(Record {
                frame: f.frame_index + 1,
                id: ids.intern(&l.id),
                bbox,
                score: l.score.unwrap_or(1.0),
                class: categories.class(l.category.as_deref()),
                visibility: -1.0,
                mask: l.rle.clone(),
                flags: RecordFlags {
                    interpolated: l.interpolated,
                    occluded: l.occluded,
                },
            });
        }
    }
    out
}

/// Longest video [`from_records`] lists frame by frame whatever its records (2^17 frames:
/// over an hour at 30 fps), empty frames included, as a labelling tool shows it.
pub const DENSE_FRAMES: u32 = 1 << 17;

/// Frames `1..=num_frames` of video `video` holding `records` (a tracker's output): image names
/// `<video>-<frame:07>.jpg` (BDD100K's), ids written as `ids` names them (else as integers),
/// classes as `categories` names them, scores kept, masks as RLE.
///
/// Every frame is listed, empty ones too, when the video is at most [`DENSE_FRAMES`] long or
/// at most four times as long as its frames with records; otherwise (a frame number or
/// `num_frames` far beyond what the records fill) only the frames holding records are listed,
/// each with its `frameIndex`, so a single record at frame 10⁶ or 10⁹ is one frame entry, not
/// a million empty ones.
pub fn from_records(
    records: &[Record],
    video: &str,
    num_frames: u32,
    ids: Option<&IdMap>,
    categories: &Categories,
) -> Vec<ScalabelFrame> {
    let n = num_frames.max(records.iter().map(|r| r.frame).max().unwrap_or(0));
    let empty_frame = |f: u32| ScalabelFrame {
        name: Some(format!("{video}-{f:07}.jpg")),
        video_name: Some(video.to_string()),
        frame_index: f - 1,
        labels: Vec::new(),
        raw: Map::from_iter([("labels".to_string(), Value::Array(Vec::new()))]),
    };
    let mut sorted: Vec<&Record> = records.iter().filter(|r| r.frame >= 1).collect();
    sorted.sort_by_key(|r| (r.frame, r.id));
    let labelled = sorted
        .windows(2)
        .filter(|w| w[0].frame != w[1].frame)
        .count()
        + usize::from(!sorted.is_empty());
    let dense = n <= crate::io::limits::MAX_FRAME
        && (n <= DENSE_FRAMES || u64::from(n) <= 4 * labelled as u64);
    let mut frames: Vec<ScalabelFrame> = if dense {
        (1..=n).map(empty_frame).collect()
    } else {
        Vec::new()
    };
    for r in sorted {
        let slot = if dense {
            r.frame as usize - 1
        } else {
            // Sparse: the records are in frame order, so a new frame is the next entry.
            if frames.last().is_none_or(|f| f.frame_index != r.frame - 1) {
                frames.push(empty_frame(r.frame));
            }
            frames.len() - 1
        };
        let Some(f) = frames.get_mut(slot) else {
            continue;
        };
        let id = ids
            .and_then(|m| m.name(r.id))
            .map_or_else(|| r.id.to_string(), str::to_string);
        f.labels.push(ScalabelLabel {
            id,
            category: categories.name(r.class).map(str::to_string),
            score: Some(r.score),
            bbox: Some(r.bbox),
            rle: r.mask.clone(),
            occluded: r.flags.occluded,
            crowd: false,
            interpolated: r.flags.interpolated,
            raw: Map::new(),
        });
    }
    frames
}
