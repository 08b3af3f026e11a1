//! Malformed inputs give typed errors naming file and line, through the library and through
//! `shapetrack eval` (exit status and message); never a panic.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::eval::{evaluate, EvalConfig, EvalError, Problem, SequenceInput, Side};
use shapetrack::io::layout::{discover, load_sequence, Format};
use shapetrack::io::IoError;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};

static COUNTER: AtomicUsize = AtomicUsize::new(0);

const SEQINFO: &str = "[Sequence]\nname=S\nframeRate=25\nseqLength=3\nimWidth=64\nimHeight=48\n";
const GT: &str = "1,1,0,0,10,10,1,1,1\n2,1,1,0,10,10,1,1,1\n3,1,2,0,10,10,1,1,1\n";
const RES: &str = "1,7,0,0,10,10,1,-1,-1,-1\n2,7,1,0,10,10,1,-1,-1,-1\n";

/// A flat TrackEval layout in a fresh temp folder: `<root>/gt/S/...` and `<root>/res/S.txt`.
struct Case {
    root: PathBuf,
}

impl Case {
    fn new(gt: &str, seqinfo: &str, results: Option<&str>) -> Case {
        let root = std::env::temp_dir().join(format!(
            "shapetrack-eval-errors-{}-{}",
            std::process::id(),
            COUNTER.fetch_add(1, Ordering::SeqCst)
        ));
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(root.join("gt/S/gt")).unwrap();
        std::fs::create_dir_all(root.join("res")).unwrap();
        std::fs::write(root.join("gt/S/gt/gt.txt"), gt).unwrap();
        std::fs::write(root.join("gt/S/seqinfo.ini"), seqinfo).unwrap();
        if let Some(r) = results {
            std::fs::write(root.join("res/S.txt"), r).unwrap();
        }
        Case { root }
    }

    fn gt(&self) -> PathBuf {
        self.root.join("gt")
    }

    fn res(&self) -> PathBuf {
        self.root.join("res")
    }

    /// Library path: discover, load, evaluate; the first error as text plus its debug form.
    fn library(&self, bench: &str, masks: bool) -> Result<(), Box<dyn std::error::Error>> {
        let layout = discover(&self.gt(), bench, "train")?;
        let format = if masks { Format::Mots } else { Format::Mot };
        let inputs = layout
            .sequences
            .iter()
            .map(|e| load_sequence(e, &self.res(), format, false))
            .collect::<Result<Vec<_>, _>>()?;
        evaluate(&inputs, &EvalConfig::for_benchmark(bench, masks))?;
        Ok(())
    }

    /// CLI path: exit status must be failure, stderr returned.
    fn cli_fails(&self, bench: &str, extra: &[&str]) -> String {
        let out = Command::new(env!("CARGO_BIN_EXE_shapetrack"))
            .arg("eval")
            .arg("--gt")
            .arg(self.gt())
            .arg("--tracker")
            .arg(self.res())
            .args(["--benchmark", bench])
            .args(extra)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr).to_string();
        assert!(!out.status.success(), "expected failure, got success");
        assert!(stderr.starts_with("error: "), "{stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        stderr
    }
}

impl Drop for Case {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.root);
    }
}

fn file_of(p: &Path) -> String {
    p.display().to_string()
}

#[test]
fn valid_case_passes() {
    let c = Case::new(GT, SEQINFO, Some(RES));
    c.library("MOT15", false).unwrap();
}

#[test]
fn bad_number_names_file_line_and_column() {
    let c = Case::new(GT, SEQINFO, Some("1,7,0,0,10,10,1\n2,7,abc,0,10,10,1\n"));
    let e = c.library("MOT15", false).unwrap_err();
    match e.downcast_ref::<IoError>() {
        Some(IoError::Parse {
            file, line, column, ..
        }) => {
            assert_eq!(file, &file_of(&c.res().join("S.txt")));
            assert_eq!((*line, *column), (2, 3));
        }
        other => panic!("unexpected {other:?}"),
    }
    let msg = c.cli_fails("MOT15", &[]);
    assert!(msg.contains("S.txt:2:3"), "{msg}");
}

#[test]
fn missing_fields_are_reported() {
    let c = Case::new(GT, SEQINFO, Some("1,7,0,0,10,10\n2,7,0,0\n"));
    let e = c.library("MOT15", false).unwrap_err();
    assert!(
        matches!(
            e.downcast_ref::<IoError>(),
            Some(IoError::Parse { line: 2, .. })
        ),
        "{e:?}"
    );
    assert!(c.cli_fails("MOT15", &[]).contains("S.txt:2:"));
    // Ground truth needs TrackEval's 8 columns (conf and class).
    let c = Case::new("1,1,0,0,10,10,1\n", SEQINFO, Some(RES));
    let e = c.library("MOT15", false).unwrap_err();
    assert!(
        matches!(
            e.downcast_ref::<IoError>(),
            Some(IoError::Parse {
                line: 1,
                column: 8,
                ..
            })
        ),
        "{e:?}"
    );
    assert!(c.cli_fails("MOT15", &[]).contains("gt.txt:1:8"));
}

#[test]
fn duplicate_id_in_a_frame_names_the_second_line() {
    let c = Case::new(
        GT,
        SEQINFO,
        Some("1,7,0,0,10,10,1\n2,7,0,0,10,10,1\n2,7,5,5,10,10,1\n"),
    );
    let e = c.library("MOT15", false).unwrap_err();
    match e.downcast_ref::<EvalError>() {
        Some(EvalError::Data { location, problem }) => {
            assert_eq!(location.side, Side::Tracker);
            assert_eq!(
                location.file.as_deref(),
                Some(file_of(&c.res().join("S.txt")).as_str())
            );
            assert_eq!(location.line, 3);
            assert_eq!(problem, &Problem::DuplicateId { frame: 2, id: 7 });
        }
        other => panic!("unexpected {other:?}"),
    }
    let msg = c.cli_fails("MOT15", &[]);
    assert!(
        msg.contains("S.txt:3: id 7 appears more than once in frame 2"),
        "{msg}"
    );
    // The same in ground truth.
    let c = Case::new(
        "1,1,0,0,10,10,1,1\n\n1,1,0,0,10,10,1,1\n",
        SEQINFO,
        Some(RES),
    );
    assert!(c
        .cli_fails("MOT15", &[])
        .contains("gt.txt:3: id 1 appears more than once"));
}

#[test]
fn frame_beyond_seq_length_is_an_error() {
    let c = Case::new(GT, SEQINFO, Some("1,7,0,0,10,10,1\n4,7,0,0,10,10,1\n"));
    let e = c.library("MOT15", false).unwrap_err();
    assert!(
        matches!(
            e.downcast_ref::<EvalError>(),
            Some(EvalError::Data {
                problem: Problem::InvalidTimestep {
                    frame: 4,
                    num_frames: 3
                },
                ..
            })
        ),
        "{e:?}"
    );
    assert!(c
        .cli_fails("MOT15", &[])
        .contains("S.txt:2: frame 4 is outside"));
    // Frame 0 (a 0-based file) too.
    let c = Case::new(GT, SEQINFO, Some("0,7,0,0,10,10,1\n"));
    assert!(c
        .cli_fails("MOT15", &[])
        .contains("S.txt:1: frame 0 is outside"));
}

#[test]
fn missing_seqinfo_key_names_the_file() {
    let c = Case::new(GT, "[Sequence]\nname=S\nframeRate=25\n", Some(RES));
    let e = c.library("MOT15", false).unwrap_err();
    match e.downcast_ref::<IoError>() {
        Some(IoError::Invalid { file, message, .. }) => {
            assert!(file.ends_with("seqinfo.ini"), "{file}");
            assert!(message.contains("seqLength"), "{message}");
        }
        other => panic!("unexpected {other:?}"),
    }
    assert!(c.cli_fails("MOT15", &[]).contains("seqinfo.ini"));
}

#[test]
fn missing_results_file_is_an_error_unless_allowed() {
    let c = Case::new(GT, SEQINFO, None);
    let e = c.library("MOT15", false).unwrap_err();
    assert!(e.to_string().contains("S.txt"), "{e}");
    assert!(c
        .cli_fails("MOT15", &[])
        .contains("results file for sequence S not found"));
    let out = Command::new(env!("CARGO_BIN_EXE_shapetrack"))
        .arg("eval")
        .arg("--gt")
        .arg(c.gt())
        .arg("--tracker")
        .arg(c.res())
        .args(["--benchmark", "MOT15", "--allow-missing-results"])
        .output()
        .unwrap();
    assert!(out.status.success());
}

#[test]
fn mot17_rules_refuse_bad_classes() {
    // Ground-truth class 14 does not exist in MOTChallenge.
    let c = Case::new("1,1,0,0,10,10,1,14,1\n", SEQINFO, Some(RES));
    let e = c.library("MOT17", false).unwrap_err();
    assert!(
        matches!(
            e.downcast_ref::<EvalError>(),
            Some(EvalError::Data {
                problem: Problem::InvalidGtClass { class: 14, .. },
                ..
            })
        ),
        "{e:?}"
    );
    assert!(c
        .cli_fails("MOT17", &[])
        .contains("gt.txt:1: ground-truth class 14"));
    // Tracker rows must be pedestrians (class column ≤ 1), under every MOT rule set.
    let c = Case::new(GT, SEQINFO, Some("1,7,0,0,10,10,1,3,-1\n"));
    assert!(c
        .cli_fails("MOT15", &[])
        .contains("S.txt:1: tracker class 3"));
    // ... unless preprocessing is off.
    let out = Command::new(env!("CARGO_BIN_EXE_shapetrack"))
        .arg("eval")
        .arg("--gt")
        .arg(c.gt())
        .arg("--tracker")
        .arg(c.res())
        .args(["--benchmark", "MOT15", "--preproc", "none"])
        .output()
        .unwrap();
    assert!(out.status.success());
}

#[test]
fn mots_overlapping_masks_and_bad_rle() {
    // 4x3 image; masks "125ON" (3 px) and "0:0" style strings from pycocotools.
    let gt = "1 2001 2 4 3 125ON\n";
    // Two tracker masks sharing pixels.
    let res = "1 1 2 4 3 125ON\n1 2 2 4 3 125ON\n";
    // The seqinfo says the masks' size (masks of another size are refused first).
    let seqinfo = "[Sequence]\nname=S\nframeRate=25\nseqLength=3\nimWidth=3\nimHeight=4\n";
    let c = Case::new(gt, seqinfo, Some(res));
    let e = c.library("MOTS", true).unwrap_err();
    assert!(
        matches!(
            e.downcast_ref::<EvalError>(),
            Some(EvalError::Data {
                problem: Problem::OverlappingMasks { frame: 1 },
                ..
            })
        ),
        "{e:?}"
    );
    assert!(c
        .cli_fails("MOTS", &["--masks"])
        .contains("S.txt:2: mask overlaps"));
    let c = Case::new(gt, seqinfo, Some("1 1 2 4 3 12\n"));
    assert!(c
        .cli_fails("MOTS", &["--masks"])
        .contains("S.txt:1: bad RLE mask"));
}

#[test]
fn in_memory_errors_name_sequence_and_record() {
    use shapetrack::io::Record;
    use shapetrack::BBox;
    let b = BBox::new(0.0, 0.0, 10.0, 10.0);
    let gt = vec![Record::from_box(1, 1, b)];
    let res = vec![Record::from_box(1, 5, b), Record::from_box(1, 5, b)];
    let e = evaluate(
        &[SequenceInput::new("mem", 1, gt, res)],
        &EvalConfig::default(),
    )
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "sequence mem, tracker record 2: id 5 appears more than once in frame 1"
    );
    assert!(matches!(
        evaluate(&[], &EvalConfig::default()),
        Err(EvalError::NoSequences)
    ));
}
