//! Inputs a second robustness probe of the CLI (issue 65) found misread or destroyed: text
//! without line breaks or with classic Mac line endings, outputs over files a run reads
//! without naming them (the seqinfo found beside the detections, the frame read for the
//! image size, a dataset's annotations), a sequence name that matches nothing, a synthetic
//! scene longer than any reader takes. Each case failed before: exit 0 with a wrong result,
//! a destroyed input, or memory until the process was killed.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shapetrack"))
        .args(args)
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("shapetrack-inputs-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn shared(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data")
        .join(rel)
}

#[test]
fn classic_mac_line_endings_are_refused_not_read_as_one_record() {
    let dir = scratch("cr");
    let det = dir.join("det.txt");
    // Three frames of one box, lines ending in CR alone: read by LF lines this was one line,
    // one record, and an empty result with exit 0.
    std::fs::write(
        &det,
        "1,-1,10,10,20,30,0.9,-1,-1,-1\r2,-1,11,10,20,30,0.9,-1,-1,-1\r3,-1,12,10,20,30,0.9,-1,-1,-1\r",
    )
    .unwrap();
    let o = run(&["track", "--det", s(&det), "--out", s(&dir.join("o.txt"))]);
    assert!(!o.status.success(), "accepted");
    assert!(stderr(&o).contains("carriage return"), "{}", stderr(&o));
    // The whole-file readers say the same (eval's ground truth and results).
    let err = shapetrack::io::read_text(&det).unwrap_err().to_string();
    assert!(err.contains("carriage return"), "{err}");
    // CRLF (Windows) is fine.
    std::fs::write(
        &det,
        "1,-1,10,10,20,30,0.9,-1,-1,-1\r\n2,-1,11,10,20,30,0.9,-1,-1,-1\r\n",
    )
    .unwrap();
    assert!(shapetrack::io::read_text(&det).is_ok());
    let o = run(&["track", "--det", s(&det), "--out", s(&dir.join("o.txt"))]);
    assert!(o.status.success(), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
#[cfg(unix)]
fn a_detection_file_without_line_breaks_is_refused_after_its_line_cap() {
    // /dev/zero was read as one endless line until the allocator gave up (4 GB).
    let dir = scratch("zero");
    let o = run(&[
        "track",
        "--det",
        "/dev/zero",
        "--out",
        s(&dir.join("o.txt")),
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("longer than 64 MiB"), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn track_out_over_the_seqinfo_it_found_is_refused() {
    // The seqinfo two levels above --det is read (fps, size) without being named: it is an
    // input all the same, and was replaced by MOT rows.
    let dir = scratch("seqinfo");
    std::fs::create_dir_all(dir.join("det")).unwrap();
    let det = dir.join("det/det.txt");
    std::fs::write(&det, "1,-1,10,10,20,30,0.9,-1,-1,-1\n").unwrap();
    let seqinfo = dir.join("seqinfo.ini");
    let ini = "[Sequence]\nname=s\nimDir=img1\nframeRate=25\nseqLength=1\nimWidth=64\nimHeight=64\nimExt=.jpg\n";
    std::fs::write(&seqinfo, ini).unwrap();
    let o = run(&["track", "--det", s(&det), "--out", s(&seqinfo)]);
    assert!(!o.status.success(), "accepted");
    assert!(stderr(&o).contains("is an input"), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(&seqinfo).unwrap(), ini);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn eval_vot_json_over_the_frame_it_sizes_from_is_refused() {
    // Without --size the first frame gives the bounds; --json naming it replaced the image
    // with JSON, and the next run evaluated without bounds.
    let dir = scratch("votframe");
    std::fs::create_dir_all(dir.join("results")).unwrap();
    std::fs::copy(
        shared("vot-bag/groundtruth.txt"),
        dir.join("groundtruth.txt"),
    )
    .unwrap();
    let frame = dir.join("00000001.jpg");
    std::fs::copy(shared("vot-bag/00000001.jpg"), &frame).unwrap();
    let root = env!("CARGO_MANIFEST_DIR");
    for e in std::fs::read_dir(format!("{root}/tests/data/vot/results/constant/baseline")).unwrap()
    {
        let e = e.unwrap();
        std::fs::copy(e.path(), dir.join("results").join(e.file_name())).unwrap();
    }
    let before = std::fs::read(&frame).unwrap();
    let o = run(&[
        "eval-vot",
        "--gt",
        s(&dir),
        "--tracker",
        s(&dir.join("results")),
        "--sequence",
        "bag",
        "--json",
        s(&frame),
    ]);
    assert!(!o.status.success(), "accepted");
    assert!(
        stderr(&o).contains("is an input of this run"),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read(&frame).unwrap(), before);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn detect_eval_refuses_frames_out_in_its_dataset_and_unknown_sequences() {
    let dir = scratch("davis");
    let (jpg, ann) = (
        dir.join("DAVIS/JPEGImages/480p/cs"),
        dir.join("DAVIS/Annotations/480p/cs"),
    );
    std::fs::create_dir_all(&jpg).unwrap();
    std::fs::create_dir_all(&ann).unwrap();
    let src = shared("davis-car-shadow/DAVIS");
    std::fs::copy(
        src.join("JPEGImages/480p/car-shadow/00000.jpg"),
        jpg.join("00000.jpg"),
    )
    .unwrap();
    let gt = ann.join("00000.png");
    std::fs::copy(src.join("Annotations/480p/car-shadow/00000.png"), &gt).unwrap();
    let before = std::fs::read(&gt).unwrap();
    let base = [
        "detect-eval",
        "--davis",
        s(&dir),
        "--methods",
        "box",
        "--model",
        "none",
    ];
    // --frames-out on a ground-truth mask of the dataset: refused before any work, kept.
    let o = run(&[&base[..], &["--frames-out", s(&gt)]].concat());
    assert!(!o.status.success(), "accepted");
    assert!(stderr(&o).contains("lies in the dataset"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&gt).unwrap(), before);
    // A sequence that is not there is named, not an empty table with exit 0.
    let o = run(&[&base[..], &["--sequences", "cs,nonexist"]].concat());
    assert!(!o.status.success(), "accepted");
    assert!(
        stderr(&o).contains("--sequences nonexist"),
        "{}",
        stderr(&o)
    );
    // The sequence that is there still runs.
    let o = run(&[&base[..], &["--sequences", "cs"]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn synth_refuses_more_frames_than_the_readers_take() {
    // 2^20 + 1 frames wrote PNGs until the disk or the clock ran out.
    let dir = scratch("synth");
    let over = (shapetrack::io::limits::MAX_FRAME + 1).to_string();
    let o = run(&[
        "synth",
        "--frames",
        &over,
        "--width",
        "16",
        "--height",
        "16",
        "--out",
        s(&dir),
    ]);
    assert!(!o.status.success(), "accepted");
    assert!(stderr(&o).contains("frames"), "{}", stderr(&o));
    assert!(!dir.join("img1/000001.png").exists(), "nothing written");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn vot_sequence_name_cannot_lead_out_of_the_output_folder() {
    // --sequence is part of each result file's name: `../../x` wrote outside --out.
    let dir = scratch("votname");
    let out = dir.join("out");
    for bad in ["../escape", "a/b", ".."] {
        let o = run(&[
            "vot",
            "--seq",
            s(&shared("vot-bag")),
            "--out",
            s(&out),
            "--model",
            "none",
            "--sequence",
            bad,
        ]);
        assert!(!o.status.success(), "{bad} accepted");
        assert!(stderr(&o).contains("a name, not a path"), "{}", stderr(&o));
    }
    assert!(
        !dir.join("escape").exists() && !out.exists(),
        "nothing written"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
