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
    // A video up to DENSE_FRAMES long is listed whole, however few its records.
    let n = shapetrack::io::scalabel::DENSE_FRAMES;
    let frames = from_records(&[rec(3, 7)], "v", n, None, &Categories::default());
    assert_eq!(frames.len(), n as usize);
}

/// Within the frame cap but far beyond what the records fill, only the labelled frames are
/// listed: one record at frame 2^20 (a probe's 4 KB input) was 2^20 frame entries and 1.9 GB.
#[test]
fn scalabel_lists_only_labelled_frames_of_a_mostly_empty_long_video() {
    let records = [rec(1, 7), rec(2, 7), rec(MAX_FRAME, 8)];
    let frames = from_records(&records, "v", 0, None, &Categories::default());
    let index: Vec<u32> = frames.iter().map(|f| f.frame_index).collect();
    assert_eq!(index, vec![0, 1, MAX_FRAME - 1]);
    // Records on a quarter of the frames or more: listed whole.
    let n = 3 * shapetrack::io::scalabel::DENSE_FRAMES;
    let records: Vec<Record> = (1..=n / 4).map(|f| rec(4 * f - 3, 1)).collect();
    let frames = from_records(&records, "v", n, None, &Categories::default());
    assert_eq!(frames.len(), n as usize);
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

/// COCO-video is written one track at a time: 8 tracks over 2^20 frames (8 M slots, the
/// layout the format asks for) held every track's slots and values at once; now memory is
/// the text and one track's slots (the same text, byte for byte).
#[test]
fn coco_video_from_the_cli_holds_one_track_at_a_time() {
    let dir = std::env::temp_dir().join(format!("shapetrack-coco-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let det = dir.join("det.txt");
    let mut text = String::new();
    for id in 1..=8 {
        for f in 1..=6 {
            text.push_str(&format!("{f},-1,{},10,20,30,0.9,-1,-1,-1\n", 40 * id));
        }
    }
    text.push_str(&format!("{MAX_FRAME},-1,5,5,20,30,0.9,-1,-1,-1\n"));
    std::fs::write(&det, text).unwrap();
    let out = dir.join("out.json");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_shapetrack"))
        .args(["track", "--format", "coco", "--det"])
        .arg(&det)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{err}");
    let summary = String::from_utf8_lossy(&run.stdout);
    let peak_kb: u64 = summary
        .split("peak_mem_kb=")
        .nth(1)
        .and_then(|t| t.split(|c: char| !c.is_ascii_digit()).next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("no peak_mem_kb in {summary}"));
    let bytes = std::fs::metadata(&out).unwrap().len();
    let _ = std::fs::remove_dir_all(&dir);
    // The text itself (176 MB), plus one track's slots (2^20 × ~100 B), plus the program:
    // 318 MB; all tracks at once it was 788 MB.
    assert!(
        peak_kb * 1024 < 2 * bytes + (100 << 20),
        "peak {peak_kb} kB for {bytes} bytes of output: {summary}"
    );
}
