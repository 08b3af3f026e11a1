//! Whole-sequence helpers: detection records in, tracked records out (CLI, tests, benches).

use super::{Config, TrackError, Tracker};
use crate::frame::{Detection, TrackedShape};
use crate::io::Record;

/// Groups detection records into frames: `out[k]` holds the detections of frame
/// `first_frame + k`, for `num_frames` frames. Records with a mask become mask detections (box
/// = the mask's tight box); the record's score and class are kept. Records outside the range
/// are dropped.
pub fn detections_by_frame(
    records: &[Record],
    first_frame: u32,
    num_frames: u32,
) -> Vec<Vec<Detection>> {
    let mut out = vec![Vec::new(); num_frames as usize];
    for r in records {
        let Some(k) = r.frame.checked_sub(first_frame) else {
            continue;
        };
        let Some(v) = out.get_mut(k as usize) else {
            continue;
        };
        let det = match r.mask_bitmap() {
            Some(m) => Detection {
                class: r.class,
                ..Detection::from_mask(m, r.score)
            },
            None => Detection {
                class: r.class,
                ..Detection::from_box(r.bbox, r.score)
            },
        };
        v.push(det);
    }
    out
}

/// Tracks a whole sequence without images (box mode, or masks without pixels): one
/// [`Tracker::update`] per frame, every reported shape collected. Frame numbers in the result
/// are the tracker's (1 = the first element of `frames`).
pub fn track_sequence(
    config: Config,
    frames: &[Vec<Detection>],
) -> Result<Vec<TrackedShape>, TrackError> {
    let mut tracker = Tracker::new(config)?;
    let mut out = Vec::new();
    for dets in frames {
        out.extend(tracker.update(None, dets)?);
    }
    Ok(out)
}

/// The records of tracked shapes, renumbering frames so that tracker frame 1 is `first_frame`;
/// `image_size` (width, height) is needed to write masks.
pub fn to_records(
    shapes: &[TrackedShape],
    first_frame: u32,
    image_size: Option<(u32, u32)>,
) -> Vec<Record> {
    shapes
        .iter()
        .map(|s| {
            let mut r = Record::from_tracked(s, image_size);
            r.frame = (s.frame + first_frame).saturating_sub(1);
            r
        })
        .collect()
}
