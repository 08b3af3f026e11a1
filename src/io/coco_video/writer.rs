//! Writing COCO-video JSON: records grouped into per-track, per-frame lists, in the
//! ground-truth form or the results form.

use super::{Category, CocoVideoData, VideoInfo};
use crate::io::limits::{MAX_FRAME, MAX_SLOTS};
use crate::io::{IoError, Record};
use serde::Serialize;
use std::collections::BTreeMap;

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

fn invalid(message: String) -> IoError {
    IoError::Invalid {
        file: "<coco-video output>".to_string(),
        line: 0,
        message,
    }
}

/// Groups a video's records into per-track, per-frame slots, checking they fit the video.
/// The format lays out every track over the whole video, so the slots (tracks × length) are
/// checked against [`MAX_FRAME`] and [`MAX_SLOTS`] before any is made: a length is a claim,
/// and one record in a video of 10⁹ frames would otherwise be gigabytes of `null`s.
/// Each track's records, in frame order (laid out over the video one track at a time by
/// [`slots_of`], so that memory holds one track's slots, not every track's).
fn tracks_of<'r>(
    video: &VideoInfo,
    records: &'r [Record],
) -> Result<BTreeMap<i64, Vec<&'r Record>>, IoError> {
    if video.length > MAX_FRAME {
        return Err(invalid(format!(
            "video {} has {} frames, beyond the cap of 2^20 frames ({MAX_FRAME}) a COCO-video \
             file may lay out",
            video.id, video.length
        )));
    }
    let ids: std::collections::BTreeSet<i64> = records.iter().map(|r| r.id).collect();
    let slots = ids.len() as u64 * u64::from(video.length);
    if slots > MAX_SLOTS {
        return Err(invalid(format!(
            "video {} would need {} tracks × {} frames = {slots} slots, beyond the cap of \
             2^26 ({MAX_SLOTS}) a COCO-video file may lay out (it lists every track's boxes \
             frame by frame)",
            video.id,
            ids.len(),
            video.length
        )));
    }
    let mut tracks: BTreeMap<i64, Vec<&Record>> = BTreeMap::new();
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
        tracks.entry(r.id).or_default().push(r);
    }
    for (id, list) in &mut tracks {
        list.sort_by_key(|r| r.frame);
        if let Some(w) = list.windows(2).find(|w| w[0].frame == w[1].frame) {
            return Err(invalid(format!(
                "id {id} appears twice in frame {} of video {}",
                w[0].frame, video.id
            )));
        }
    }
    Ok(tracks)
}

/// One track's records laid out over the video's frames (`None` where it is absent).
fn slots_of<'r>(video: &VideoInfo, list: &[&'r Record]) -> Vec<Option<&'r Record>> {
    let mut slots = vec![None; video.length as usize];
    for &r in list {
        slots[r.frame as usize - 1] = Some(r);
    }
    slots
}

/// Appends `item` to the JSON list being written in `out` (`first`: no comma before it).
fn push_json<T: Serialize>(out: &mut String, item: &T, first: bool) -> Result<(), IoError> {
    if !first {
        out.push(',');
    }
    out.push_str(&serde_json::to_string(item).map_err(|e| invalid(e.to_string()))?);
    Ok(())
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
    // Written as it goes, one track's slots at a time: the layout is tracks × length (up to
    // MAX_SLOTS), and holding every track's slots and their JSON values at once took
    // gigabytes (2.8 GB for 60 tracks over 2^20 frames) where the text is a fraction of it.
    let vids: Vec<&VideoInfo> = videos.iter().map(|(v, _)| v).collect();
    let mut out = String::from("{\"videos\":");
    out.push_str(&serde_json::to_string(&vids).map_err(|e| invalid(e.to_string()))?);
    out.push_str(",\"annotations\":[");
    let mut first = true;
    for (video, records) in videos {
        for (id, list) in tracks_of(video, records)? {
            push_json(
                &mut out,
                &track_out(video, id, &slots_of(video, &list), true)?,
                first,
            )?;
            first = false;
        }
    }
    out.push_str("],\"categories\":");
    out.push_str(&serde_json::to_string(categories).map_err(|e| invalid(e.to_string()))?);
    out.push('}');
    Ok(out)
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
    let mut out = String::from("[");
    let mut first = true;
    for (video, records) in videos {
        for (id, list) in tracks_of(video, records)? {
            push_json(
                &mut out,
                &track_out(video, id, &slots_of(video, &list), false)?,
                first,
            )?;
            first = false;
        }
    }
    out.push(']');
    Ok(out)
}
