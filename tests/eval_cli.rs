//! `shapetrack eval` end to end: flags other tools rely on, the table, and the JSON file.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn fixture(case: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/eval")
        .join(case)
}

fn run(args: &[&std::ffi::OsStr]) -> (String, String, bool) {
    let out = Command::new(env!("CARGO_BIN_EXE_shapetrack"))
        .arg("eval")
        .args(args)
        .output()
        .unwrap();
    (
        String::from_utf8_lossy(&out.stdout).to_string(),
        String::from_utf8_lossy(&out.stderr).to_string(),
        out.status.success(),
    )
}

fn json_path(tag: &str) -> PathBuf {
    std::env::temp_dir().join(format!(
        "shapetrack-eval-cli-{}-{tag}.json",
        std::process::id()
    ))
}

/// Runs the CLI on a fixture and compares the JSON with TrackEval's expected.json, every field.
fn cli_matches_trackeval(case: &str, bench: &str, extra: &[&str]) {
    let dir = fixture(case);
    let out_json = json_path(case);
    let tracker = dir
        .join("trackers")
        .join(format!("{bench}-train"))
        .join("test/data");
    let mut args: Vec<std::ffi::OsString> = vec![
        "--gt".into(),
        dir.join("gt").into(),
        "--tracker".into(),
        tracker.into(),
        "--benchmark".into(),
        bench.into(),
        "--split".into(),
        "train".into(),
        "--json".into(),
        out_json.clone().into(),
    ];
    args.extend(extra.iter().map(|s| s.into()));
    let refs: Vec<&std::ffi::OsStr> = args.iter().map(|s| s.as_os_str()).collect();
    let (stdout, stderr, ok) = run(&refs);
    assert!(ok, "{stderr}");
    assert!(stdout.starts_with("Sequence"), "{stdout}");
    assert!(stdout.lines().last().unwrap().starts_with("COMBINED"));
    for col in [
        "HOTA", "DetA", "AssA", "LocA", "MOTA", "MOTP", "IDF1", "IDSW", "Frag", "ML",
    ] {
        assert!(stdout.lines().next().unwrap().contains(col));
    }
    let ours: Value = serde_json::from_str(&std::fs::read_to_string(&out_json).unwrap()).unwrap();
    let _ = std::fs::remove_file(&out_json);
    let exp: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("expected.json")).unwrap()).unwrap();
    let mut rows: Vec<(String, &Value, &Value)> = exp["sequences"]
        .as_object()
        .unwrap()
        .iter()
        .map(|(k, v)| (k.clone(), v, &ours["sequences"][k]))
        .collect();
    rows.push(("combined".into(), &exp["combined"], &ours["combined"]));
    for (name, want, got) in rows {
        for (field, w) in want.as_object().unwrap() {
            let g = &got[field];
            // Counts are JSON integers in both.
            assert_eq!(w.is_u64(), g.is_u64(), "{name} {field}: {g}");
            let (w, g) = (w.as_f64().unwrap(), g.as_f64().unwrap());
            assert!(
                (w - g).abs() <= 1e-9 * w.abs().max(1.0),
                "{name} {field}: {g} vs {w}"
            );
        }
    }
}

#[test]
fn cli_json_equals_trackeval_mot17() {
    cli_matches_trackeval("mot17", "MOT17", &[]);
}

#[test]
fn cli_json_equals_trackeval_mots() {
    cli_matches_trackeval("mots", "MOTS", &["--masks"]);
}

#[test]
fn cli_seq_selection_and_flat_layout() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    let out_json = json_path("sel");
    let (stdout, stderr, ok) = run(&[
        "--gt".as_ref(),
        data.join("mot15-train").as_os_str(),
        "--tracker".as_ref(),
        data.join("mot15-train-baselines/rf_sort/data").as_os_str(),
        "--benchmark".as_ref(),
        "MOT15".as_ref(),
        "--seq".as_ref(),
        "TUD-Campus".as_ref(),
        "--seq".as_ref(),
        "KITTI-17".as_ref(),
        "--json".as_ref(),
        out_json.as_os_str(),
    ]);
    assert!(ok, "{stderr}");
    assert_eq!(stdout.lines().count(), 4, "{stdout}");
    let ours: Value = serde_json::from_str(&std::fs::read_to_string(&out_json).unwrap()).unwrap();
    let _ = std::fs::remove_file(&out_json);
    let seqs = ours["sequences"].as_object().unwrap();
    assert_eq!(seqs.len(), 2);
    // trackeval_summary.txt: TUD-Campus HOTA 44.111, MOTA 56.267, IDSW 8.
    let tud = &seqs["TUD-Campus"];
    assert_eq!(format!("{:.3}", tud["HOTA"].as_f64().unwrap()), "44.111");
    assert_eq!(format!("{:.3}", tud["MOTA"].as_f64().unwrap()), "56.267");
    assert_eq!(tud["IDSW"].as_u64(), Some(8));
    // An unknown sequence is an error naming it.
    let (_, stderr, ok) = run(&[
        "--gt".as_ref(),
        data.join("mot15-train").as_os_str(),
        "--tracker".as_ref(),
        data.join("mot15-train-baselines/rf_sort/data").as_os_str(),
        "--benchmark".as_ref(),
        "MOT15".as_ref(),
        "--seq".as_ref(),
        "Nope".as_ref(),
    ]);
    assert!(
        !ok && stderr.contains("sequence Nope is not in the ground truth"),
        "{stderr}"
    );
}

/// Copies a folder tree (a fixture into a scratch place the test may damage).
fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let dest = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_tree(&e.path(), &dest);
        } else {
            std::fs::copy(e.path(), dest).unwrap();
        }
    }
}

#[test]
fn json_over_a_file_the_run_reads_is_refused_and_the_file_kept() {
    let dir =
        std::env::temp_dir().join(format!("shapetrack-eval-cli-{}-inputs", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    copy_tree(&fixture("mot20"), &dir);
    let tracker = dir.join("trackers/MOT20-train/test/data");
    let gt_file = dir.join("gt/MOT20-train/MOT20-A/gt/gt.txt");
    let results = tracker.join("MOT20-A.txt");
    for target in [&results, &gt_file] {
        let before = std::fs::read(target).unwrap();
        let (_, stderr, ok) = run(&[
            "--gt".as_ref(),
            dir.join("gt").as_os_str(),
            "--tracker".as_ref(),
            tracker.as_os_str(),
            "--benchmark".as_ref(),
            "MOT20".as_ref(),
            "--json".as_ref(),
            target.as_os_str(),
        ]);
        assert!(!ok, "--json {} was accepted", target.display());
        assert!(stderr.contains("is an input of this run"), "{stderr}");
        assert_eq!(
            std::fs::read(target).unwrap(),
            before,
            "{} changed",
            target.display()
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
