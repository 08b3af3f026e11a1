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

mod polygon;
mod writer;

pub use polygon::{rle_from_polygon, PolygonError};
pub use writer::{write_coco_video, write_coco_video_results};

use super::{json_err, line_col, serde_message, IoError, Record, RecordFlags, Rle};
use crate::frame::BBox;
use serde::{Deserialize, Serialize};
use serde_json::value::RawValue;
use std::collections::{BTreeMap, BTreeSet};

use super::limits::{id_message, id_ok, MAX_PIXELS, MAX_SIDE};

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
        if !id_ok(id) {
            return Err(ctx.err_at(raw, id_message(&id.to_string())));
        }
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

#[cfg(test)]
#[path = "coco_video_tests.rs"]
mod tests;
