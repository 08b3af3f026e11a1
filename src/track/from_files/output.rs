//! Where the tracked shapes of `shapetrack track` go: streamed to MOT/MOTS text frame by
//! frame, or collected and written whole (COCO-video, CVAT), and the counts of what went.

use crate::frame::{Mask, TrackedShape};
use crate::io::coco_video::{write_coco_video, Category, VideoInfo};
use crate::io::cvat::{write_cvat, CvatMeta};
use crate::io::motchallenge::{write_mot, write_mots};
use crate::io::{AtomicFile, IoError, Record};
use crate::track::to_records;
use std::collections::BTreeMap;
use std::path::Path;

/// Where tracked shapes go: straight to the output file, frame by frame (online MOT/MOTS), or
/// collected for formats written as a whole and for the offline pass.
pub(crate) enum Sink {
    Stream {
        out: AtomicFile,
        /// Shapes of frames not yet written (confirmation reports a few earlier frames late).
        pending: BTreeMap<u32, Vec<TrackedShape>>,
        mots: bool,
    },
    Collect(Vec<TrackedShape>),
}

/// Frames a streamed output holds back before writing them: a track confirmed late reports
/// the frames it was tentative in, and a lost track re-identified at confirmation takes over
/// those frames; both reach back at most a few times `min_hits` frames.
const REORDER_FRAMES: u32 = 256;

/// Shapes of an offline result written at a time (their masks unpacked together).
pub(crate) const WRITE_CHUNK: usize = 4096;

/// Counts of what was reported.
#[derive(Default)]
pub(crate) struct Tally {
    pub(crate) shapes: usize,
    pub(crate) interpolated: usize,
    pub(crate) ids: std::collections::HashSet<u64>,
}

impl Tally {
    pub(crate) fn add(&mut self, shapes: &[TrackedShape]) {
        self.shapes += shapes.len();
        self.interpolated += shapes.iter().filter(|s| s.interpolated).count();
        self.ids.extend(shapes.iter().map(|s| s.id));
    }
}

impl Sink {
    pub(crate) fn push(&mut self, shapes: Vec<TrackedShape>, ctx: &OutCtx) -> Result<(), IoError> {
        match self {
            Sink::Collect(v) => v.extend(shapes),
            Sink::Stream { pending, .. } => {
                for s in shapes {
                    pending.entry(s.frame).or_default().push(s);
                }
                self.flush_before(ctx.now.saturating_sub(REORDER_FRAMES), ctx)?;
            }
        }
        Ok(())
    }

    /// Writes the held frames before tracker frame `frame`.
    pub(crate) fn flush_before(&mut self, frame: u32, ctx: &OutCtx) -> Result<(), IoError> {
        use std::io::Write as _;
        let Sink::Stream { out, pending, mots } = self else {
            return Ok(());
        };
        while let Some(entry) = pending.first_entry() {
            if *entry.key() >= frame {
                break;
            }
            let mut shapes = entry.remove();
            if *mots {
                boxes_as_masks(&mut shapes);
            }
            let records = to_records(&shapes, ctx.first_frame, ctx.image_size);
            let text = if *mots {
                write_mots(&records)
            } else {
                write_mot(&records)
            };
            out.write_all(text.as_bytes())
                .map_err(|source| IoError::Io {
                    file: ctx.out.display().to_string(),
                    source,
                })?;
        }
        Ok(())
    }
}

/// MOTS has no box-only form: boxes are the degenerate case of masks, written filled.
pub(crate) fn boxes_as_masks(shapes: &mut [TrackedShape]) {
    for s in shapes.iter_mut().filter(|s| s.mask.is_none()) {
        s.mask = Some(Mask::from_bbox(&s.bbox));
    }
}

/// What the sink needs to turn shapes into lines.
pub(crate) struct OutCtx<'a> {
    pub(crate) out: &'a Path,
    pub(crate) first_frame: u32,
    pub(crate) image_size: Option<(u32, u32)>,
    /// The tracker's current frame.
    pub(crate) now: u32,
}

/// A label name per class present (`object` for the unknown class -1).
fn class_names(records: &[Record]) -> BTreeMap<i32, String> {
    records
        .iter()
        .map(|r| {
            let name = if r.class < 0 {
                "object".to_string()
            } else {
                format!("class{}", r.class)
            };
            (r.class, name)
        })
        .collect()
}

pub(crate) fn task_name(det: &Path) -> String {
    det.parent()
        .and_then(Path::parent)
        .and_then(Path::file_name)
        .or_else(|| det.file_stem())
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "sequence".to_string())
}

/// COCO-video (ground-truth form, so every track keeps its id) of one video.
pub(crate) fn coco(
    records: &[Record],
    num_frames: u32,
    image_size: Option<(u32, u32)>,
) -> Result<String, IoError> {
    let (width, height) = image_size.unwrap_or((0, 0));
    let video = VideoInfo {
        id: 1,
        width,
        height,
        length: num_frames,
        file_names: Vec::new(),
    };
    let categories: Vec<Category> = class_names(records)
        .into_iter()
        .map(|(id, name)| Category { id, name })
        .collect();
    write_coco_video(&[(video, records)], &categories)
}

/// CVAT for video 1.1 XML of one task.
pub(crate) fn cvat(
    records: &[Record],
    num_frames: u32,
    image_size: Option<(u32, u32)>,
    det: &Path,
) -> Result<String, IoError> {
    let (width, height) = image_size.unwrap_or((0, 0));
    let meta = CvatMeta {
        name: task_name(det),
        size: num_frames,
        width,
        height,
    };
    write_cvat(records, &meta, &class_names(records))
}
