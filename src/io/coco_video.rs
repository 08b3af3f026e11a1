//! COCO-video / YouTube-VIS JSON: ground truth (`videos`, `annotations`, `categories`) and the
//! results form (a list of `{video_id, category_id, score, segmentations}`).
//!
//! One annotation is one object track in one video; its per-frame lists (`segmentations`,
//! `bboxes`, `areas`) are indexed by frame, so a [`Record`]'s frame is the list index + 1. A
//! `null` entry means the object is absent from that frame. Segmentations are read with
//! pycocotools' `frPyObjects` semantics: compressed RLE strings, uncompressed `counts` lists, or
//! polygon lists (rasterised exactly as pycocotools' `rleFrPoly`, several polygons united).
//!
//! Our writer adds optional per-frame lists other tools ignore: `interpolated` and `occluded`
//! (booleans) and `scores` (per-frame confidence), written only when some entry differs from
//! the default (`false`, `false`, `1`). Visibility is not stored.
//!
//! Errors carry the line and column of the offending JSON value: the document is first split
//! into borrowed raw values, whose byte offsets in the text give exact positions even for
//! errors found after parsing (an unknown `video_id`, an RLE that does not fit the video).

use super::{json_err, line_col, serde_message, IoError, Record, RecordFlags, Rle};
use crate::frame::BBox;
use serde::{Deserialize, Serialize};
use serde_json::value::RawValue;
use std::collections::{BTreeMap, BTreeSet};

/// The most boundary points [`rle_from_polygon`] will generate (about 200 MB of work); a
/// polygon whose perimeter needs more is rejected rather than exhausting memory.
const MAX_POLYGON_STEPS: u64 = 1 << 24;

use super::limits::{MAX_PIXELS, MAX_SIDE};

/// One video of a COCO-video file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VideoInfo {
    /// Video id (annotations refer to it).
    pub id: i64,
    /// Frame width in pixels.
    pub width: u32,
    /// Frame height in pixels.
    pub height: u32,
    /// Number of frames (`length`, or the number of `file_names` when absent).
    pub length: u32,
    /// Frame file names, in frame order (may be empty).
    pub file_names: Vec<String>,
}

/// One category (class) of a COCO-video file.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Category {
    /// Category id (the records' `class`).
    pub id: i32,
    /// Category name.
    pub name: String,
}

/// One video with its records.
#[derive(Debug, Clone, PartialEq)]
pub struct VideoRecords {
    /// The video.
    pub video: VideoInfo,
    /// Its records (track id = annotation id, class = category id), sorted by frame then id.
    pub records: Vec<Record>,
}

/// A whole COCO-video ground-truth file.
#[derive(Debug, Clone, PartialEq)]
pub struct CocoVideoData {
    /// Videos in file order, each with its records.
    pub videos: Vec<VideoRecords>,
    /// Categories in file order.
    pub categories: Vec<Category>,
}

/// Errors rasterising a polygon.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PolygonError {
    /// A polygon needs at least 3 points, given as an even number of coordinates.
    #[error("a polygon needs an even number (at least 6) of coordinates, got {0}")]
    TooFewCoordinates(usize),
    /// A coordinate is NaN or infinite.
    #[error("polygon coordinate {0} is not finite")]
    NotFinite(f64),
    /// The polygon is so large that rasterising it would exhaust memory.
    #[error("polygon perimeter is too long to rasterise ({steps} boundary steps)")]
    TooLarge {
        /// Boundary steps the rasteriser would need.
        steps: u64,
    },
}

/// Rasterises a polygon (`[x0, y0, x1, y1, …]`, pixel coordinates) into an `height × width`
/// RLE exactly as pycocotools' `rleFrPoly`: the boundary is walked on a 5× grid and a pixel is
/// foreground when its centre's column crossing lies inside, so the result is byte-identical
/// to `pycocotools.mask.frPyObjects([poly], h, w)`.
pub fn rle_from_polygon(xy: &[f64], height: u32, width: u32) -> Result<Rle, PolygonError> {
    if xy.len() < 6 || xy.len() % 2 != 0 {
        return Err(PolygonError::TooFewCoordinates(xy.len()));
    }
    if let Some(&v) = xy.iter().find(|v| !v.is_finite()) {
        return Err(PolygonError::NotFinite(v));
    }
    let (h, w) = (height as i64, width as i64);
    if h == 0 || w == 0 {
        return Ok(Rle::empty(width, height));
    }
    let scale = 5.0f64;
    let k = xy.len() / 2;
    // C's `(int)(scale*v + .5)`: truncation toward zero, which `as` also does (saturating, so
    // absurd coordinates cannot overflow; they are caught by the step limit below).
    let px: Vec<i64> = (0..=k)
        .map(|j| (scale * xy[2 * (j % k)] + 0.5) as i32 as i64)
        .collect();
    let py: Vec<i64> = (0..=k)
        .map(|j| (scale * xy[2 * (j % k) + 1] + 0.5) as i32 as i64)
        .collect();
    let steps: u64 = (0..k)
        .map(|j| {
            (px[j] - px[j + 1])
                .unsigned_abs()
                .max((py[j] - py[j + 1]).unsigned_abs())
                + 1
        })
        .sum();
    if steps > MAX_POLYGON_STEPS {
        return Err(PolygonError::TooLarge { steps });
    }
    // Dense points along the whole boundary.
    let mut u: Vec<i64> = Vec::with_capacity(steps as usize);
    let mut v: Vec<i64> = Vec::with_capacity(steps as usize);
    for j in 0..k {
        let (mut xs, mut xe, mut ys, mut ye) = (px[j], px[j + 1], py[j], py[j + 1]);
        let dx = (xe - xs).abs();
        let dy = (ys - ye).abs();
        let flip = (dx >= dy && xs > xe) || (dx < dy && ys > ye);
        if flip {
            std::mem::swap(&mut xs, &mut xe);
            std::mem::swap(&mut ys, &mut ye);
        }
        if dx >= dy {
            let s = if dx == 0 {
                0.0
            } else {
                (ye - ys) as f64 / dx as f64
            };
            for d in 0..=dx {
                let t = if flip { dx - d } else { d };
                u.push(t + xs);
                v.push((ys as f64 + s * t as f64 + 0.5) as i64);
            }
        } else {
            let s = (xe - xs) as f64 / dy as f64;
            for d in 0..=dy {
                let t = if flip { dy - d } else { d };
                v.push(t + ys);
                u.push((xs as f64 + s * t as f64 + 0.5) as i64);
            }
        }
    }
    // Points where the boundary crosses a pixel-centre column, downsampled to pixels.
    let mut a: Vec<i64> = Vec::new();
    for j in 1..u.len() {
        if u[j] == u[j - 1] {
            continue;
        }
        let xd = if u[j] < u[j - 1] { u[j] } else { u[j] - 1 } as f64;
        let xd = (xd + 0.5) / scale - 0.5;
        if xd.floor() != xd || xd < 0.0 || xd > (w - 1) as f64 {
            continue;
        }
        let yd = if v[j] < v[j - 1] { v[j] } else { v[j - 1] } as f64;
        let mut yd = (yd + 0.5) / scale - 0.5;
        if yd < 0.0 {
            yd = 0.0;
        } else if yd > h as f64 {
            yd = h as f64;
        }
        a.push(xd as i64 * h + yd.ceil() as i64);
    }
    a.push(h * w);
    a.sort_unstable();
    let mut prev = 0i64;
    for x in a.iter_mut() {
        let t = *x;
        *x -= prev;
        prev = t;
    }
    // Two crossings at the same pixel cancel: fold the run after a zero gap into the one before.
    let mut counts: Vec<u32> = Vec::with_capacity(a.len());
    counts.push(a[0] as u32);
    let mut j = 1;
    while j < a.len() {
        if a[j] > 0 {
            counts.push(a[j] as u32);
            j += 1;
        } else {
            j += 1;
            if j < a.len() {
                if let Some(last) = counts.last_mut() {
                    *last += a[j] as u32;
                }
                j += 1;
            }
        }
    }
    Ok(Rle {
        height,
        width,
        counts,
    })
}

/// Where raw JSON values live in the source text, for error positions.
struct Ctx<'t> {
    file: &'t str,
    text: &'t str,
}

impl<'t> Ctx<'t> {
    /// Line and column where `raw` (borrowed from `self.text`) starts.
    fn pos(&self, raw: &RawValue) -> (usize, usize) {
        let offset = (raw.get().as_ptr() as usize).wrapping_sub(self.text.as_ptr() as usize);
        line_col(self.text, offset)
    }

    fn err_at(&self, raw: &RawValue, message: impl Into<String>) -> IoError {
        let (line, column) = self.pos(raw);
        IoError::Json {
            file: self.file.to_string(),
            line,
            column,
            message: message.into(),
        }
    }

    /// Parses `raw` as `T`, reporting serde errors at their absolute position.
    fn parse<'a, T: Deserialize<'a>>(&self, raw: &'a RawValue) -> Result<T, IoError> {
        serde_json::from_str(raw.get()).map_err(|e| {
            let (l0, c0) = self.pos(raw);
            let (line, column) = match (e.line(), e.column()) {
                (0, _) => (l0, c0),
                (1, c) => (l0, c0 + c.saturating_sub(1)),
                (l, c) => (l0 + l - 1, c),
            };
            IoError::Json {
                file: self.file.to_string(),
                line,
                column,
                message: serde_message(&e),
            }
        })
    }
}

#[derive(Deserialize)]
struct TopRaw<'a> {
    #[serde(borrow)]
    videos: Vec<&'a RawValue>,
    #[serde(borrow, default)]
    annotations: Vec<&'a RawValue>,
    #[serde(borrow, default)]
    categories: Vec<&'a RawValue>,
}

#[derive(Deserialize)]
struct VideoRaw {
    id: i64,
    width: u32,
    height: u32,
    #[serde(default)]
    length: Option<u32>,
    #[serde(default)]
    file_names: Vec<String>,
}

#[derive(Deserialize)]
struct CategoryRaw {
    id: i32,
    name: String,
}

/// Fields shared by ground-truth annotations and results.
#[derive(Deserialize)]
struct TrackRaw<'a> {
    #[serde(default)]
    id: Option<i64>,
    video_id: i64,
    category_id: i32,
    #[serde(default)]
    score: Option<f64>,
    #[serde(borrow, default)]
    segmentations: Option<Vec<Option<&'a RawValue>>>,
    #[serde(default)]
    bboxes: Option<Vec<Option<[f64; 4]>>>,
    #[serde(default)]
    interpolated: Option<Vec<Option<bool>>>,
    #[serde(default)]
    occluded: Option<Vec<Option<bool>>>,
    #[serde(default)]
    scores: Option<Vec<Option<f64>>>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum Counts {
    Compressed(String),
    Uncompressed(Vec<u64>),
}

#[derive(Deserialize)]
#[serde(untagged)]
enum Segmentation {
    Rle { size: [u32; 2], counts: Counts },
    Polygons(Vec<Vec<f64>>),
}

fn video_from_raw(ctx: &Ctx, raw: &RawValue) -> Result<VideoInfo, IoError> {
    let v: VideoRaw = ctx.parse(raw)?;
    if v.width == 0
        || v.height == 0
        || v.width > MAX_SIDE
        || v.height > MAX_SIDE
        || v.width as u64 * v.height as u64 > MAX_PIXELS
    {
        return Err(ctx.err_at(
            raw,
            format!(
                "video {} has size {}x{}; expected sides in 1..=65536",
                v.id, v.width, v.height
            ),
        ));
    }
    let length = match v.length {
        Some(l) => {
            if !v.file_names.is_empty() && v.file_names.len() != l as usize {
                return Err(ctx.err_at(
                    raw,
                    format!(
                        "video {} has length {} but {} file names",
                        v.id,
                        l,
                        v.file_names.len()
                    ),
                ));
            }
            l
        }
        None => {
            u32::try_from(v.file_names.len()).map_err(|_| ctx.err_at(raw, "too many file names"))?
        }
    };
    Ok(VideoInfo {
        id: v.id,
        width: v.width,
        height: v.height,
        length,
        file_names: v.file_names,
    })
}

/// Decodes one segmentation (RLE dict or polygon list) for a `height × width` video.
fn segmentation_rle(ctx: &Ctx, raw: &RawValue, size: Option<(u32, u32)>) -> Result<Rle, IoError> {
    match ctx.parse::<Segmentation>(raw)? {
        Segmentation::Rle {
            size: [h, w],
            counts,
        } => {
            if let Some((vw, vh)) = size {
                if (h, w) != (vh, vw) {
                    return Err(ctx.err_at(
                        raw,
                        format!("RLE size [{h}, {w}] differs from the video's [{vh}, {vw}]"),
                    ));
                }
            }
            if h > MAX_SIDE || w > MAX_SIDE || h as u64 * w as u64 > MAX_PIXELS {
                return Err(ctx.err_at(raw, format!("RLE size [{h}, {w}] is too large")));
            }
            match counts {
                Counts::Compressed(s) => {
                    Rle::from_compressed(&s, h, w).map_err(|source| IoError::Rle {
                        file: ctx.file.to_string(),
                        line: ctx.pos(raw).0,
                        source,
                    })
                }
                Counts::Uncompressed(c) => {
                    // Checked: counts near 2⁶⁴ must not wrap around to the mask's area.
                    let total = c.iter().try_fold(0u64, |a, &x| a.checked_add(x));
                    if total != Some(h as u64 * w as u64) || c.iter().any(|&x| x > u32::MAX as u64)
                    {
                        return Err(ctx.err_at(
                            raw,
                            format!(
                                "RLE counts cover {} pixels but the mask is {h}x{w}",
                                total.map_or("more than 2^64".to_string(), |t| t.to_string())
                            ),
                        ));
                    }
                    Ok(Rle {
                        height: h,
                        width: w,
                        counts: c.into_iter().map(|x| x as u32).collect(),
                    })
                }
            }
        }
        Segmentation::Polygons(polys) => {
            let Some((w, h)) = size else {
                return Err(ctx.err_at(
                    raw,
                    "polygon segmentation needs the video's size (unknown video)",
                ));
            };
            let mut out = Rle::empty(w, h);
            for p in &polys {
                let r = rle_from_polygon(p, h, w)
                    .map_err(|e| ctx.err_at(raw, format!("bad polygon: {e}")))?;
                out = out.union(&r);
            }
            Ok(out)
        }
    }
}

/// Turns one annotation/result track into records. `id` is the record id to use.
fn track_records(
    ctx: &Ctx,
    raw: &RawValue,
    t: &TrackRaw,
    id: i64,
    video: Option<&VideoInfo>,
) -> Result<Vec<Record>, IoError> {
    let size = video.map(|v| (v.width, v.height));
    let n = [
        t.segmentations.as_ref().map(Vec::len),
        t.bboxes.as_ref().map(Vec::len),
    ]
    .into_iter()
    .flatten()
    .max()
    .unwrap_or(0);
    if let Some(v) = video {
        if n > v.length as usize {
            return Err(ctx.err_at(
                raw,
                format!(
                    "track has {n} per-frame entries but video {} has {} frames",
                    v.id, v.length
                ),
            ));
        }
    }
    let track_score = t.score.unwrap_or(1.0);
    if !track_score.is_finite() {
        return Err(ctx.err_at(raw, "score is not finite"));
    }
    let mut out = Vec::new();
    for f in 0..n {
        let seg = t
            .segmentations
            .as_ref()
            .and_then(|s| s.get(f).copied().flatten());
        let bbox = t.bboxes.as_ref().and_then(|b| b.get(f).copied().flatten());
        if seg.is_none() && bbox.is_none() {
            continue;
        }
        let mask = match seg {
            Some(s) => Some(segmentation_rle(ctx, s, size)?),
            None => None,
        };
        let bbox = match bbox {
            Some([x, y, w, h]) => BBox::checked(x, y, w, h)
                .map_err(|e| ctx.err_at(raw, format!("frame {}: {e}", f + 1)))?,
            None => mask.as_ref().map(|m| m.bbox()).unwrap_or_default(),
        };
        let flag = |l: &Option<Vec<Option<bool>>>| {
            l.as_ref()
                .and_then(|v| v.get(f).copied().flatten())
                .unwrap_or(false)
        };
        let score = match t.scores.as_ref().and_then(|v| v.get(f).copied().flatten()) {
            Some(s) if s.is_finite() => s,
            Some(_) => return Err(ctx.err_at(raw, format!("frame {}: score is not finite", f + 1))),
            None => track_score,
        };
        out.push(Record {
            frame: f as u32 + 1,
            id,
            bbox,
            score,
            class: t.category_id,
            visibility: -1.0,
            mask,
            flags: RecordFlags {
                interpolated: flag(&t.interpolated),
                occluded: flag(&t.occluded),
            },
        });
    }
    Ok(out)
}

/// Parses a COCO-video / YouTube-VIS ground-truth file. `file` names it in errors.
///
/// `videos` is required; `annotations` and `categories` may be absent. Every annotation must
/// name a known video, have at most `length` per-frame entries, and its RLE sizes must match
/// the video. Record ids are the annotation ids (unique per video), classes the category ids.
pub fn parse_coco_video(text: &str, file: &str) -> Result<CocoVideoData, IoError> {
    let ctx = Ctx { file, text };
    let top: TopRaw = serde_json::from_str(text).map_err(|e| json_err(file, e))?;
    let mut videos: Vec<VideoRecords> = Vec::with_capacity(top.videos.len());
    let mut index: BTreeMap<i64, usize> = BTreeMap::new();
    for raw in &top.videos {
        let v = video_from_raw(&ctx, raw)?;
        if index.insert(v.id, videos.len()).is_some() {
            return Err(ctx.err_at(raw, format!("duplicate video id {}", v.id)));
        }
        videos.push(VideoRecords {
            video: v,
            records: Vec::new(),
        });
    }
    let mut categories = Vec::with_capacity(top.categories.len());
    for raw in &top.categories {
        let c: CategoryRaw = ctx.parse(raw)?;
        if categories.iter().any(|x: &Category| x.id == c.id) {
            return Err(ctx.err_at(raw, format!("duplicate category id {}", c.id)));
        }
        categories.push(Category {
            id: c.id,
            name: c.name,
        });
    }
    let mut seen: BTreeSet<(i64, i64)> = BTreeSet::new();
    for raw in &top.annotations {
        let t: TrackRaw = ctx.parse(raw)?;
        let Some(id) = t.id else {
            return Err(ctx.err_at(raw, "annotation has no \"id\""));
        };
        let Some(&vi) = index.get(&t.video_id) else {
            return Err(ctx.err_at(
                raw,
                format!("annotation {id} names unknown video {}", t.video_id),
            ));
        };
        if !seen.insert((t.video_id, id)) {
            return Err(ctx.err_at(
                raw,
                format!("duplicate annotation id {id} in video {}", t.video_id),
            ));
        }
        let recs = track_records(&ctx, raw, &t, id, Some(&videos[vi].video))?;
        videos[vi].records.extend(recs);
    }
    for v in &mut videos {
        v.records.sort_by_key(|r| (r.frame, r.id));
    }
    Ok(CocoVideoData { videos, categories })
}

/// Parses a COCO-video results file (a JSON list of `{video_id, category_id, score,
/// segmentations[, bboxes]}`). Each entry becomes a track whose id is its 1-based position in
/// the list; records are returned per video id, sorted by frame then id. `videos` gives frame
/// sizes and lengths (needed for polygons and checked when given; pass `&[]` to skip).
pub fn parse_coco_video_results(
    text: &str,
    file: &str,
    videos: &[VideoInfo],
) -> Result<BTreeMap<i64, Vec<Record>>, IoError> {
    let ctx = Ctx { file, text };
    let list: Vec<&RawValue> = serde_json::from_str(text).map_err(|e| json_err(file, e))?;
    let mut out: BTreeMap<i64, Vec<Record>> = BTreeMap::new();
    for (i, raw) in list.iter().enumerate() {
        let t: TrackRaw = ctx.parse(raw)?;
        let video = videos.iter().find(|v| v.id == t.video_id);
        if video.is_none() && !videos.is_empty() {
            return Err(ctx.err_at(raw, format!("result names unknown video {}", t.video_id)));
        }
        let recs = track_records(&ctx, raw, &t, i as i64 + 1, video)?;
        out.entry(t.video_id).or_default().extend(recs);
    }
    for recs in out.values_mut() {
        recs.sort_by_key(|r| (r.frame, r.id));
    }
    Ok(out)
}

#[derive(Serialize)]
struct RleOut {
    size: [u32; 2],
    counts: String,
}

#[derive(Serialize)]
struct TrackOut {
    #[serde(skip_serializing_if = "Option::is_none")]
    id: Option<i64>,
    video_id: i64,
    category_id: i32,
    #[serde(skip_serializing_if = "Option::is_none")]
    iscrowd: Option<u8>,
    #[serde(skip_serializing_if = "Option::is_none")]
    score: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    segmentations: Option<Vec<Option<RleOut>>>,
    bboxes: Vec<Option<[f64; 4]>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    areas: Option<Vec<Option<f64>>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    interpolated: Option<Vec<bool>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    occluded: Option<Vec<bool>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    scores: Option<Vec<Option<f64>>>,
}

#[derive(Serialize)]
struct TopOut<'a> {
    videos: Vec<&'a VideoInfo>,
    annotations: Vec<TrackOut>,
    categories: &'a [Category],
}

fn invalid(message: String) -> IoError {
    IoError::Invalid {
        file: "<coco-video output>".to_string(),
        line: 0,
        message,
    }
}

/// Groups a video's records into per-track, per-frame slots, checking they fit the video.
fn tracks_of<'r>(
    video: &VideoInfo,
    records: &'r [Record],
) -> Result<BTreeMap<i64, Vec<Option<&'r Record>>>, IoError> {
    let mut tracks: BTreeMap<i64, Vec<Option<&Record>>> = BTreeMap::new();
    for r in records {
        if r.frame < 1 || r.frame > video.length {
            return Err(invalid(format!(
                "record of id {} is in frame {} but video {} has frames 1..={}",
                r.id, r.frame, video.id, video.length
            )));
        }
        if let Some(m) = &r.mask {
            if (m.width, m.height) != (video.width, video.height) {
                return Err(invalid(format!(
                    "mask of id {} frame {} is {}x{} but video {} is {}x{}",
                    r.id, r.frame, m.width, m.height, video.id, video.width, video.height
                )));
            }
        }
        let slots = tracks
            .entry(r.id)
            .or_insert_with(|| vec![None; video.length as usize]);
        let slot = &mut slots[r.frame as usize - 1];
        if slot.is_some() {
            return Err(invalid(format!(
                "id {} appears twice in frame {} of video {}",
                r.id, r.frame, video.id
            )));
        }
        *slot = Some(r);
    }
    Ok(tracks)
}

fn track_out(
    video: &VideoInfo,
    id: i64,
    slots: &[Option<&Record>],
    gt: bool,
) -> Result<TrackOut, IoError> {
    let present: Vec<&Record> = slots.iter().flatten().copied().collect();
    let class = present.first().map_or(-1, |r| r.class);
    if let Some(r) = present.iter().find(|r| r.class != class) {
        return Err(invalid(format!(
            "id {id} has classes {class} and {} in video {}; COCO-video has one category per track",
            r.class, video.id
        )));
    }
    let any_mask = present.iter().any(|r| r.mask.is_some());
    let segmentations = any_mask.then(|| {
        slots
            .iter()
            .map(|s| {
                s.and_then(|r| r.mask.as_ref()).map(|m| RleOut {
                    size: [m.height, m.width],
                    counts: m.to_compressed(),
                })
            })
            .collect()
    });
    let bboxes = slots
        .iter()
        .map(|s| s.map(|r| [r.bbox.x, r.bbox.y, r.bbox.w, r.bbox.h]))
        .collect();
    let areas = slots
        .iter()
        .map(|s| {
            s.map(|r| match &r.mask {
                Some(m) => m.area() as f64,
                None => r.bbox.area(),
            })
        })
        .collect();
    let flag_list = |f: fn(&Record) -> bool| {
        present
            .iter()
            .any(|r| f(r))
            .then(|| slots.iter().map(|s| s.is_some_and(f)).collect())
    };
    let mean_score = if present.is_empty() {
        1.0
    } else {
        present.iter().map(|r| r.score).sum::<f64>() / present.len() as f64
    };
    // Ground truth keeps per-frame scores only when they differ from 1; results always have a
    // track score (the mean) and keep per-frame scores when they are not all equal to it.
    let per_frame_needed = if gt {
        present.iter().any(|r| r.score != 1.0)
    } else {
        present.iter().any(|r| r.score != mean_score)
    };
    let scores = per_frame_needed.then(|| slots.iter().map(|s| s.map(|r| r.score)).collect());
    Ok(TrackOut {
        id: gt.then_some(id),
        video_id: video.id,
        category_id: class,
        iscrowd: gt.then_some(0),
        score: (!gt).then_some(mean_score),
        segmentations,
        bboxes,
        areas: gt.then_some(areas),
        interpolated: flag_list(|r| r.flags.interpolated),
        occluded: flag_list(|r| r.flags.occluded),
        scores,
    })
}

/// Writes a COCO-video ground-truth file: one annotation per (video, track id) with the track's
/// id as annotation id and its class as `category_id` (one class per track). Masks must have
/// the video's size and frames must lie in `1..=length`.
pub fn write_coco_video(
    videos: &[(VideoInfo, &[Record])],
    categories: &[Category],
) -> Result<String, IoError> {
    let mut annotations = Vec::new();
    for (video, records) in videos {
        for (id, slots) in tracks_of(video, records)? {
            annotations.push(track_out(video, id, &slots, true)?);
        }
    }
    let top = TopOut {
        videos: videos.iter().map(|(v, _)| v).collect(),
        annotations,
        categories,
    };
    serde_json::to_string(&top).map_err(|e| invalid(e.to_string()))
}

impl CocoVideoData {
    /// Writes this data back as a COCO-video ground-truth file (see [`write_coco_video`]).
    pub fn to_json(&self) -> Result<String, IoError> {
        let v: Vec<(VideoInfo, &[Record])> = self
            .videos
            .iter()
            .map(|v| (v.video.clone(), v.records.as_slice()))
            .collect();
        write_coco_video(&v, &self.categories)
    }
}

/// Writes the results form: one entry per (video, track id) with `score` = the mean of the
/// track's record scores (per-frame `scores` are added when they differ), `segmentations` when
/// the track has masks, and `bboxes` always.
pub fn write_coco_video_results(videos: &[(VideoInfo, &[Record])]) -> Result<String, IoError> {
    let mut out = Vec::new();
    for (video, records) in videos {
        for (id, slots) in tracks_of(video, records)? {
            out.push(track_out(video, id, &slots, false)?);
        }
    }
    serde_json::to_string(&out).map_err(|e| invalid(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square_rle(w: u32, h: u32, x0: usize, y0: usize, s: usize) -> Rle {
        let mut m = vec![0u8; (w * h) as usize];
        for y in y0..y0 + s {
            for x in x0..x0 + s {
                m[y * w as usize + x] = 1;
            }
        }
        Rle::encode(w, h, &m).unwrap()
    }

    #[test]
    fn axis_aligned_polygon_covers_pixel_centres() {
        // A square with corners on pixel boundaries covers exactly the pixels inside it.
        let r = rle_from_polygon(&[2.0, 1.0, 6.0, 1.0, 6.0, 4.0, 2.0, 4.0], 8, 10).unwrap();
        let m = r.to_mask();
        assert_eq!(m.bbox(), BBox::new(2.0, 1.0, 4.0, 3.0));
        assert_eq!(r.area(), 12);
    }

    #[test]
    fn polygon_rejects_bad_input() {
        assert!(rle_from_polygon(&[0.0, 0.0, 1.0, 1.0], 5, 5).is_err());
        assert!(rle_from_polygon(&[0.0, 0.0, 1.0, f64::NAN, 2.0, 0.0], 5, 5).is_err());
        assert!(matches!(
            rle_from_polygon(&[0.0, 0.0, 1e9, 0.0, 0.0, 1e9], 5, 5),
            Err(PolygonError::TooLarge { .. })
        ));
    }

    #[test]
    fn errors_point_at_the_annotation() {
        let text = "{\"videos\":[{\"id\":1,\"width\":4,\"height\":3,\"length\":2}],\n\"annotations\":[\n{\"id\":5,\"video_id\":9,\"category_id\":1,\"segmentations\":[null,null]}]}";
        match parse_coco_video(text, "x.json") {
            Err(IoError::Json {
                line,
                column,
                message,
                ..
            }) => {
                assert_eq!((line, column), (3, 1), "{message}");
                assert!(message.contains("unknown video 9"));
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn roundtrip_masks_boxes_and_flags() {
        let video = VideoInfo {
            id: 3,
            width: 6,
            height: 5,
            length: 4,
            file_names: vec![],
        };
        let mut a = Record::from_box(1, 7, BBox::new(1.0, 1.0, 2.0, 2.0));
        a.class = 2;
        a.mask = Some(square_rle(6, 5, 1, 1, 2));
        let mut b = a.clone();
        b.frame = 3;
        b.flags.interpolated = true;
        b.flags.occluded = true;
        let mut c = Record::from_box(2, 8, BBox::new(0.5, 0.25, 3.0, 1.5));
        c.class = 1;
        let recs = vec![a, c, b];
        let cats = vec![
            Category {
                id: 1,
                name: "a".into(),
            },
            Category {
                id: 2,
                name: "b".into(),
            },
        ];
        let text = write_coco_video(&[(video.clone(), &recs)], &cats).unwrap();
        let back = parse_coco_video(&text, "rt.json").unwrap();
        assert_eq!(back.categories, cats);
        assert_eq!(back.videos.len(), 1);
        assert_eq!(back.videos[0].video, video);
        let mut want = recs.clone();
        want.sort_by_key(|r| (r.frame, r.id));
        assert_eq!(back.videos[0].records, want);
    }
}
