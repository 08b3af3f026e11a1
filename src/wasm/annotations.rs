//! Annotation and result files: records as JS sees them, and the readers and writers of
//! every format the app imports and exports.

use super::*;
use crate::frame::BBox;
use crate::io::{
    coco_video, cvat, label_studio, motchallenge, scalabel, yolo, Record, RecordFlags,
};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use tsify::{Ts, Tsify};
use wasm_bindgen::prelude::*;

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

pub(super) fn to_core_records(records: Records) -> Result<Vec<Record>, JsValue> {
    records.0.iter().map(RecordJs::to_record).collect()
}

pub(super) fn from_core_records(records: &[Record]) -> Records {
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
pub(super) const LABEL_STUDIO_FPS: f64 = 24.0;

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
pub(super) fn frame_size(meta: &SequenceMeta) -> Result<(u32, u32), JsValue> {
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
pub(super) fn label_map(records: &[Record], given: &[LabelJs]) -> BTreeMap<i32, String> {
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
