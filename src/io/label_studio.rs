//! Label Studio video JSON: the tasks list Label Studio exports ("JSON" export) and imports,
//! with `videorectangle` results for object tracking.
//!
//! ```text
//! [{"id": 1, "data": {"video": "…"}, "annotations": [{"result": [
//!   {"id": "7", "type": "videorectangle", "from_name": "box", "to_name": "video",
//!    "origin": "manual",
//!    "value": {"framesCount": 300, "duration": 12, "labels": ["car"],
//!              "sequence": [{"frame": 1, "enabled": true, "x": 10, "y": 20,
//!                            "width": 5, "height": 8, "rotation": 0, "time": 0}, …]}}]}]}]
//! ```
//!
//! One result is one track; its `sequence` lists **keyframes** only. Label Studio shows a
//! box between two keyframes by linear interpolation of x, y, width and height when the
//! earlier keyframe is `enabled`, and nothing after a keyframe whose `enabled` is false until
//! the next keyframe; after the last keyframe an enabled box stays to the end of the video.
//! Coordinates are **percent** of the frame width and height, so both readers and writers
//! need the frame size (Label Studio's video results do not carry it). Frames are 1-based,
//! like [`Record::frame`].
//!
//! **Reading** expands keyframes the way Label Studio displays them: each keyframe is a record;
//! the frames Label Studio would interpolate become records with `flags.interpolated = true`
//! (boxes linear between enabled keyframes; after the last enabled keyframe the box is held
//! to `framesCount`). A rotated box becomes the axis-aligned bounds of its corners (rotation
//! is about the top-left corner, as Label Studio draws it). Labels come from `value.labels`
//! or from a `labels` result with the same region id; the first label is the class (with a
//! label map, its class; without, its index among the file's label names in order of first
//! appearance; no label is class −1). Region ids that are all integers are kept as track ids,
//! otherwise tracks are numbered 1, 2, … in file order. The first task with an annotation
//! is read (its first annotation not `was_cancelled`); other result types (choices, text,
//! timeline labels) are skipped.
//!
//! **Writing** produces one task with one annotation and a result per track. Label Studio has
//! no per-frame "interpolated" flag, but it interpolates between keyframes itself, so a filled
//! frame is flagged by *not being a keyframe*: an interpolated record inside a run of
//! consecutive frames is left out of `sequence`, and reading the file back marks it
//! interpolated again (with the linear box Label Studio would show; a filled box that was not
//! linear comes back straightened). The first and last frame of a run are always keyframes
//! (a filled frame there comes back unflagged: Label Studio has nothing to interpolate it
//! from), and the last one has `enabled: false` so the box ends there (a gap, or the track's
//! end). Keyframe `time` is the frame's start, `(frame − 1) / fps`.
//! Scores, visibility, occlusion and masks are not written (Label Studio's video boxes have
//! none of them; it has no video masks or polygons).
//!
//! **Errors** are [`IoError::Json`] with the line and column of the bad value: malformed JSON,
//! a result without `value.sequence`, a keyframe without an integer `frame` ≥ 1 or a numeric
//! x / y / width / height, a non-finite value (e.g. `1e999`), a negative size, two keyframes
//! on one frame, two tracks with one id; a file that expands past [`MAX_RECORDS`] records is
//! refused.

use std::collections::{BTreeMap, BTreeSet};

use serde_json::value::RawValue;
use serde_json::{json, Value};

use super::limits::{id_message, id_ok, image_size_ok, MAX_FRAME, MAX_RECORDS};
use super::{json_err, IoError, JsonCtx as Ctx, Record, RecordFlags};
use crate::frame::BBox;

/// What a Label Studio file says besides its records.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LabelStudioTracks {
    /// The records, sorted by frame then id.
    pub records: Vec<Record>,
    /// Label names in order of first appearance (class `i` is `labels[i]` without a label map).
    pub labels: Vec<String>,
    /// The video's frame count (largest `framesCount`; 0 when absent).
    pub frames: u32,
    /// `data.video` of the task read, when it is a string.
    pub video: Option<String>,
    /// Number of tasks in the file (only the first annotated one is read).
    pub tasks: usize,
}

/// What the writer needs besides the records.
#[derive(Debug, Clone, PartialEq)]
pub struct LabelStudioMeta {
    /// `data.video` of the task (a URL or path Label Studio can open).
    pub video: String,
    /// Frame width in pixels.
    pub width: u32,
    /// Frame height in pixels.
    pub height: u32,
    /// Number of frames (`framesCount`); records must be in `1..=frames`.
    pub frames: u32,
    /// Frame rate, for `duration` and keyframe `time` (Label Studio seeks by time).
    pub fps: f64,
}

fn size_err(file: &str, size: (u32, u32)) -> IoError {
    IoError::Invalid {
        file: file.to_string(),
        line: 0,
        message: format!(
            "Label Studio boxes are percent of the frame: a valid frame width and height are \
             needed, got {} × {}",
            size.0, size.1
        ),
    }
}

/// One keyframe, in pixels.
struct Key<'a> {
    raw: &'a RawValue,
    frame: u32,
    enabled: bool,
    bbox: BBox,
}

/// One track as read.
struct Track<'a> {
    raw: &'a RawValue,
    id: String,
    labels: Vec<String>,
    score: f64,
    frames_count: u32,
    keys: Vec<Key<'a>>,
}

fn parse_key<'a>(ctx: &Ctx<'_>, raw: &'a RawValue, (w, h): (f64, f64)) -> Result<Key<'a>, IoError> {
    let obj = ctx.object(raw, "a keyframe")?;
    let field = |k: &str| {
        obj.get(k)
            .copied()
            .ok_or_else(|| ctx.err_at(raw, format!("a keyframe without \"{k}\"")))
    };
    let f = field("frame")?;
    let frame = serde_json::from_str::<u32>(f.get())
        .ok()
        .filter(|v| (1..=MAX_FRAME).contains(v))
        .ok_or_else(|| ctx.err_at(f, format!("frame must be an integer in 1..={MAX_FRAME}")))?;
    let enabled = match obj.get("enabled") {
        Some(e) => serde_json::from_str::<bool>(e.get())
            .map_err(|_| ctx.err_at(e, "enabled must be true or false"))?,
        None => true,
    };
    let mut v = [0.0; 4];
    for (k, name) in ["x", "y", "width", "height"].iter().enumerate() {
        let r = field(name)?;
        v[k] = ctx.number(r, name)?;
        if k >= 2 && v[k] < 0.0 {
            return Err(ctx.err_at(r, format!("{name} must be ≥ 0")));
        }
    }
    let rotation = match obj.get("rotation") {
        Some(r) => ctx.number(r, "rotation")?,
        None => 0.0,
    };
    // Multiplied first: whole percentages of whole sizes give exact pixels.
    let (x, y, bw, bh) = (
        v[0] * w / 100.0,
        v[1] * h / 100.0,
        v[2] * w / 100.0,
        v[3] * h / 100.0,
    );
    let bbox = if rotation.rem_euclid(360.0) == 0.0 {
        BBox::new(x, y, bw, bh)
    } else {
        // Rotated about the top-left corner: keep the bounds of the four corners.
        let (s, c) = rotation.to_radians().sin_cos();
        let pts = [(0.0, 0.0), (bw, 0.0), (0.0, bh), (bw, bh)]
            .map(|(dx, dy)| (x + dx * c - dy * s, y + dx * s + dy * c));
        let x1 = pts.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
        let y1 = pts.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
        let x2 = pts.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max);
        let y2 = pts.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max);
        BBox::from_xyxy(x1, y1, x2, y2)
    };
    Ok(Key {
        raw,
        frame,
        enabled,
        bbox,
    })
}

fn strings(raw: Option<&&RawValue>) -> Vec<String> {
    raw.and_then(|r| serde_json::from_str::<Vec<String>>(r.get()).ok())
        .unwrap_or_default()
}

/// Parses a Label Studio JSON export (a list of tasks, or one task). `size` is the frame
/// (width, height) the percentages refer to. With `labels` (class → name), a track's class is
/// the class of its label (an unknown label is an error).
pub fn parse_label_studio(
    text: &str,
    file: &str,
    size: (u32, u32),
    labels: Option<&BTreeMap<i32, String>>,
) -> Result<LabelStudioTracks, IoError> {
    if !image_size_ok(size.0 as u64, size.1 as u64) {
        return Err(size_err(file, size));
    }
    let img = (size.0 as f64, size.1 as f64);
    let ctx = Ctx { file, text };
    let top: &RawValue = serde_json::from_str(text).map_err(|e| json_err(file, e))?;
    let tasks: Vec<&RawValue> = if top.get().trim_start().starts_with('[') {
        ctx.list(top, "the file")?
    } else {
        vec![top]
    };
    let mut out = LabelStudioTracks {
        tasks: tasks.len(),
        ..Default::default()
    };
    // The first task with a usable annotation, and that annotation's results.
    let mut chosen: Option<(BTreeMap<String, &RawValue>, Vec<&RawValue>)> = None;
    for t in &tasks {
        let task = ctx.object(t, "a task")?;
        let Some(anns) = task.get("annotations").or_else(|| task.get("completions")) else {
            return Err(ctx.err_at(t, "a task without \"annotations\""));
        };
        for a in ctx.list(anns, "annotations")? {
            let ann = ctx.object(a, "an annotation")?;
            let cancelled = ann
                .get("was_cancelled")
                .and_then(|c| serde_json::from_str::<bool>(c.get()).ok())
                .unwrap_or(false);
            if cancelled {
                continue;
            }
            let res = ann
                .get("result")
                .ok_or_else(|| ctx.err_at(a, "an annotation without \"result\""))?;
            chosen = Some((task.clone(), ctx.list(res, "result")?));
            break;
        }
        if chosen.is_some() {
            break;
        }
    }
    let Some((task, results)) = chosen else {
        return Ok(out);
    };
    out.video = task
        .get("data")
        .and_then(|d| serde_json::from_str::<BTreeMap<String, Value>>(d.get()).ok())
        .and_then(|d| d.get("video").and_then(Value::as_str).map(str::to_string));

    let mut tracks: Vec<Track<'_>> = Vec::new();
    let mut extra_labels: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for r in results {
        let obj = ctx.object(r, "a result")?;
        let kind: String = obj
            .get("type")
            .and_then(|t| serde_json::from_str(t.get()).ok())
            .ok_or_else(|| ctx.err_at(r, "a result without a string \"type\""))?;
        let id = match obj.get("id") {
            Some(i) => serde_json::from_str::<Value>(i.get())
                .ok()
                .and_then(|v| match v {
                    Value::String(s) => Some(s),
                    Value::Number(n) => Some(n.to_string()),
                    _ => None,
                })
                .ok_or_else(|| ctx.err_at(i, "id must be a string or a number"))?,
            None => String::new(),
        };
        let value = obj
            .get("value")
            .ok_or_else(|| ctx.err_at(r, "a result without \"value\""))?;
        let vobj = ctx.object(value, "value")?;
        match kind.as_str() {
            "videorectangle" => {}
            "labels" => {
                extra_labels
                    .entry(id)
                    .or_default()
                    .extend(strings(vobj.get("labels")));
                continue;
            }
            _ => continue,
        }
        if id.is_empty() {
            return Err(ctx.err_at(r, "a videorectangle result without \"id\""));
        }
        let seq = vobj
            .get("sequence")
            .ok_or_else(|| ctx.err_at(value, "a videorectangle without \"sequence\""))?;
        let mut keys = ctx
            .list(seq, "sequence")?
            .into_iter()
            .map(|k| parse_key(&ctx, k, img))
            .collect::<Result<Vec<_>, _>>()?;
        keys.sort_by_key(|k| k.frame);
        if let Some(w) = keys.windows(2).find(|w| w[0].frame == w[1].frame) {
            return Err(ctx.err_at(
                w[1].raw,
                format!("two keyframes on frame {} in region {id:?}", w[1].frame),
            ));
        }
        let frames_count = match vobj.get("framesCount") {
            Some(f) => serde_json::from_str::<u32>(f.get())
                .ok()
                .filter(|v| *v <= MAX_FRAME)
                .ok_or_else(|| {
                    ctx.err_at(
                        f,
                        format!("framesCount must be an integer in 0..={MAX_FRAME}"),
                    )
                })?,
            None => 0,
        };
        let score = match obj.get("score") {
            Some(s) => ctx.number(s, "score")?,
            None => 1.0,
        };
        tracks.push(Track {
            raw: r,
            id,
            labels: strings(vobj.get("labels")),
            score,
            frames_count,
            keys,
        });
    }

    // Region ids become track ids when they are all integers (files this crate wrote).
    let numeric: Option<Vec<i64>> = tracks
        .iter()
        .map(|t| t.id.parse::<i64>().ok().filter(|i| *i >= 0))
        .collect();
    let mut seen = BTreeSet::new();
    // Different region ids that read as the same number ("7", "07", "+7") would merge two
    // regions into one track: refused, naming both.
    let mut by_number: BTreeMap<i64, &str> = BTreeMap::new();
    let mut budget = 0u64;
    out.frames = tracks.iter().map(|t| t.frames_count).max().unwrap_or(0);
    for (k, t) in tracks.iter().enumerate() {
        if !seen.insert(t.id.clone()) {
            return Err(ctx.err_at(t.raw, format!("two regions with id {:?}", t.id)));
        }
        let id = numeric.as_ref().map_or(k as i64 + 1, |n| n[k]);
        if let Some(first) = by_number.insert(id, &t.id) {
            return Err(ctx.err_at(
                t.raw,
                format!(
                    "region ids {first:?} and {:?} are both track {id}: give them different \
                     numbers",
                    t.id
                ),
            ));
        }
        if !id_ok(id) {
            return Err(ctx.err_at(t.raw, id_message(&t.id)));
        }
        let mut names = t.labels.clone();
        if let Some(more) = extra_labels.get(&t.id) {
            names.extend(more.iter().cloned());
        }
        let class = match (names.first(), labels) {
            (None, _) => -1,
            (Some(name), Some(map)) => {
                *map.iter()
                    .find(|(_, n)| *n == name)
                    .ok_or_else(|| {
                        ctx.err_at(t.raw, format!("label {name:?} is not in the label map"))
                    })?
                    .0
            }
            (Some(name), None) => match out.labels.iter().position(|n| n == name) {
                Some(i) => i as i32,
                None => {
                    out.labels.push(name.clone());
                    out.labels.len() as i32 - 1
                }
            },
        };
        if labels.is_some() {
            for name in &names {
                if !out.labels.contains(name) {
                    out.labels.push(name.clone());
                }
            }
        }
        let end = out.frames.max(t.frames_count);
        for (i, key) in t.keys.iter().enumerate() {
            let next = t.keys.get(i + 1);
            let stop = match next {
                Some(n) => n.frame,
                None => end.max(key.frame) + 1,
            };
            let filled = if key.enabled { stop - key.frame - 1 } else { 0 };
            budget += 1 + filled as u64;
            if budget > MAX_RECORDS {
                return Err(ctx.err_at(
                    key.raw,
                    format!(
                        "the file expands to more than {MAX_RECORDS} boxes (keyframes far \
                         apart?); split the task"
                    ),
                ));
            }
            let record = |frame: u32, bbox: BBox, interpolated: bool| Record {
                score: t.score,
                class,
                flags: RecordFlags {
                    interpolated,
                    occluded: false,
                },
                ..Record::from_box(frame, id, bbox)
            };
            out.records.push(record(key.frame, key.bbox, false));
            if !key.enabled {
                continue;
            }
            for f in key.frame + 1..stop {
                let bbox = match next {
                    Some(n) => {
                        // Label Studio's interpolation: linear in each of x, y, width, height.
                        let s = (f - key.frame) as f64 / (n.frame - key.frame) as f64;
                        let (a, b) = (key.bbox, n.bbox);
                        BBox::new(
                            a.x + (b.x - a.x) * s,
                            a.y + (b.y - a.y) * s,
                            a.w + (b.w - a.w) * s,
                            a.h + (b.h - a.h) * s,
                        )
                    }
                    None => key.bbox,
                };
                out.records.push(record(f, bbox, true));
            }
        }
    }
    out.records.sort_by_key(|r| (r.frame, r.id));
    Ok(out)
}

/// Writes records as a Label Studio tasks list (one task, one annotation, one
/// `videorectangle` result per track; see the module docs for keyframes and filled frames).
/// `labels` names classes; a class other than −1 without a name is an error, as is a track
/// with two classes, a record outside `1..=meta.frames`, or an invalid frame size.
pub fn write_label_studio(
    records: &[Record],
    meta: &LabelStudioMeta,
    labels: &BTreeMap<i32, String>,
) -> Result<String, IoError> {
    let file = "<label studio output>";
    let invalid = |message: String| IoError::Invalid {
        file: file.to_string(),
        line: 0,
        message,
    };
    if !image_size_ok(meta.width as u64, meta.height as u64) {
        return Err(size_err(file, (meta.width, meta.height)));
    }
    if !(meta.fps.is_finite() && meta.fps > 0.0) {
        return Err(invalid(format!(
            "frame rate {} is not a positive number",
            meta.fps
        )));
    }
    let (w, h) = (meta.width as f64, meta.height as f64);
    let mut tracks: BTreeMap<i64, Vec<&Record>> = BTreeMap::new();
    for r in records {
        if r.frame < 1 || r.frame > meta.frames {
            return Err(invalid(format!(
                "record of id {} is in frame {} outside the video's frames 1..={}",
                r.id, r.frame, meta.frames
            )));
        }
        let b = &r.bbox;
        if BBox::checked(b.x, b.y, b.w, b.h).is_err() {
            return Err(invalid(format!(
                "record of id {} in frame {} has a non-finite or negative box",
                r.id, r.frame
            )));
        }
        tracks.entry(r.id).or_default().push(r);
    }
    let duration = meta.frames as f64 / meta.fps;
    let mut results = Vec::new();
    for (id, mut rs) in tracks {
        if id < 0 {
            return Err(invalid(format!(
                "id {id}: a Label Studio region is a track; unlinked boxes cannot be written"
            )));
        }
        rs.sort_by_key(|r| r.frame);
        if let Some(p) = rs.windows(2).find(|p| p[0].frame == p[1].frame) {
            return Err(invalid(format!(
                "id {id} appears twice in frame {}",
                p[0].frame
            )));
        }
        let class = rs[0].class;
        if let Some(r) = rs.iter().find(|r| r.class != class) {
            return Err(invalid(format!(
                "id {id} has classes {class} and {}; a Label Studio region has one label",
                r.class
            )));
        }
        let names: Vec<&str> = if class == -1 {
            Vec::new()
        } else {
            vec![labels
                .get(&class)
                .ok_or_else(|| invalid(format!("class {class} of id {id} has no label name")))?]
        };
        let mut sequence = Vec::new();
        for (i, r) in rs.iter().enumerate() {
            let starts_run = i == 0 || rs[i - 1].frame + 1 != r.frame;
            let ends_run = rs.get(i + 1).is_none_or(|n| n.frame != r.frame + 1);
            // A filled frame inside a run is left to Label Studio's own interpolation.
            if r.flags.interpolated && !starts_run && !ends_run {
                continue;
            }
            let b = &r.bbox;
            sequence.push(json!({
                "frame": r.frame,
                "enabled": !ends_run,
                "x": b.x / w * 100.0,
                "y": b.y / h * 100.0,
                "width": b.w / w * 100.0,
                "height": b.h / h * 100.0,
                "rotation": 0,
                "time": (r.frame - 1) as f64 / meta.fps,
            }));
        }
        results.push(json!({
            "id": id.to_string(),
            "type": "videorectangle",
            "from_name": "box",
            "to_name": "video",
            "origin": "manual",
            "value": {
                "framesCount": meta.frames,
                "duration": duration,
                "sequence": sequence,
                "labels": names,
            },
        }));
    }
    let tasks = json!([{
        "id": 1,
        "data": {"video": meta.video},
        "annotations": [{"id": 1, "result": results}],
    }]);
    serde_json::to_string_pretty(&tasks).map_err(|e| invalid(e.to_string()))
}
