//! The writers lay out frames from what the records hold, not from a frame number (issue 65,
//! class 2): a single record at frame 10⁹ must not become 10⁹ empty frame entries.
// A native suite (`cargo test`); for wasm32 it compiles to nothing.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::frame::BBox;
use shapetrack::io::coco_video::{write_coco_video, write_coco_video_results, VideoInfo};
use shapetrack::io::limits::{MAX_FRAME, MAX_SLOTS};
use shapetrack::io::scalabel::{from_records, write_scalabel, Categories};
use shapetrack::io::{IoError, Record};

fn rec(frame: u32, id: i64) -> Record {
    Record::from_box(frame, id, BBox::new(1.0, 2.0, 3.0, 4.0))
}

fn video(length: u32) -> VideoInfo {
    VideoInfo {
        id: 1,
        width: 64,
        height: 48,
        length,
        file_names: Vec::new(),
    }
}

/// Beyond the frame cap, Scalabel frames are written sparse: only the frames with labels.
#[test]
fn scalabel_lists_only_labelled_frames_beyond_the_frame_cap() {
    let frames = from_records(
        &[rec(1_000_000_000, 7)],
        "v",
        0,
        None,
        &Categories::default(),
    );
    assert_eq!(frames.len(), 1);
    assert_eq!(frames[0].frame_index, 999_999_999);
    assert!(write_scalabel(&frames).unwrap().contains("999999999"));
    // The same when the frame count is the caller's claim, not a record's.
    let frames = from_records(&[rec(3, 7)], "v", u32::MAX, None, &Categories::default());
    assert_eq!(frames.len(), 1);
}

/// Within the cap, every frame is listed as before (empty ones too).
#[test]
fn scalabel_lists_every_frame_within_the_cap() {
    let frames = from_records(&[rec(3, 7)], "v", 5, None, &Categories::default());
    assert_eq!(frames.len(), 5);
    assert!(frames[0].labels.is_empty() && frames[2].labels.len() == 1);
}

fn refused(r: Result<String, IoError>, what: &str) {
    match r {
        Err(e) => assert!(e.to_string().contains(what), "{e}"),
        Ok(s) => panic!("written ({} bytes)", s.len()),
    }
}

/// COCO-video lays out one slot per frame per track: a video length beyond the frame cap is
/// refused before any slot is made.
#[test]
fn coco_video_refuses_a_length_beyond_the_frame_cap() {
    let v = video(3 * MAX_FRAME);
    let records = [rec(2 * MAX_FRAME, 1)];
    refused(write_coco_video(&[(v.clone(), &records)], &[]), "2^20");
    refused(write_coco_video_results(&[(v, &records)]), "2^20");
}

/// Many tracks of a long video: tracks × length beyond the slot cap is refused before any
/// slot is made.
#[test]
fn coco_video_refuses_more_slots_than_the_cap() {
    let tracks = MAX_SLOTS / u64::from(MAX_FRAME) + 1;
    let records: Vec<Record> = (0..tracks as i64).map(|id| rec(1, id)).collect();
    refused(
        write_coco_video(&[(video(MAX_FRAME), &records)], &[]),
        "slots",
    );
}

/// A valid video is written as before.
#[test]
fn coco_video_writes_a_valid_video() {
    let s = write_coco_video(&[(video(4), &[rec(2, 1), rec(4, 1)])], &[]).unwrap();
    assert!(
        s.contains("\"bboxes\":[null,[1.0,2.0,3.0,4.0],null,[1.0,2.0,3.0,4.0]]"),
        "{s}"
    );
}
