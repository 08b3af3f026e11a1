//! `shapetrack eval-vot` end to end on the toolkit fixture.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use std::process::Command;

/// Runs `eval-vot` on the constant tracker's toolkit fixture with extra `flags`; returns the JSON.
fn run_constant(flags: &[&str]) -> serde_json::Value {
    let root = env!("CARGO_MANIFEST_DIR");
    let json = std::env::temp_dir().join(format!(
        "shapetrack-eval-vot-{}-{}.json",
        std::process::id(),
        flags.join("")
    ));
    let out = Command::new(env!("CARGO_BIN_EXE_shapetrack"))
        .args([
            "eval-vot",
            "--gt",
            &format!("{root}/../shared/data/vot-bag"),
            "--tracker",
        ])
        .arg(format!("{root}/tests/data/vot/results/constant/baseline"))
        .args(["--sequence", "bag"])
        .args(flags)
        .arg("--anchors")
        .arg(format!("{root}/tests/data/vot/bag_anchor.value"))
        .arg("--json")
        .arg(&json)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let _ = std::fs::remove_file(&json);
    v
}

#[test]
fn eval_vot_cli_reproduces_toolkit_numbers() {
    let root = env!("CARGO_MANIFEST_DIR");
    let r: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(format!("{root}/tests/data/vot/toolkit_reference.json")).unwrap(),
    )
    .unwrap();
    let want = &r["trackers"]["constant"]["anchor"];
    // The toolkit's semantics are the default; `--toolkit` says so explicitly.
    for flags in [&["--toolkit"][..], &[][..]] {
        let v = run_constant(flags);
        for k in ["accuracy", "robustness", "eao"] {
            let (a, b) = (v[k].as_f64().unwrap(), want[k].as_f64().unwrap());
            assert!((a - b).abs() < 1e-12, "{flags:?} {k}: {a} vs {b}");
        }
        assert_eq!(v["anchors"].as_array().unwrap().len(), 4);
    }
    // `--exact` counts the anchor frames as overlap 1, so accuracy differs from the toolkit's.
    let exact = run_constant(&["--exact"]);
    let (a, b) = (
        exact["accuracy"].as_f64().unwrap(),
        want["accuracy"].as_f64().unwrap(),
    );
    assert!(a > b, "exact accuracy {a} should exceed the toolkit's {b}");

    // A missing result file is a clean error, not a panic.
    let out = Command::new(env!("CARGO_BIN_EXE_shapetrack"))
        .args([
            "eval-vot",
            "--gt",
            &format!("{root}/../shared/data/vot-bag"),
            "--tracker",
            "/nonexistent",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("no result file"));
}

#[test]
fn json_over_a_file_the_run_reads_is_refused_and_the_file_kept() {
    let root = env!("CARGO_MANIFEST_DIR");
    let dir =
        std::env::temp_dir().join(format!("shapetrack-eval-vot-{}-inputs", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("results")).unwrap();
    std::fs::copy(
        format!("{root}/../shared/data/vot-bag/groundtruth.txt"),
        dir.join("groundtruth.txt"),
    )
    .unwrap();
    for e in std::fs::read_dir(format!("{root}/tests/data/vot/results/constant/baseline")).unwrap()
    {
        let e = e.unwrap();
        std::fs::copy(e.path(), dir.join("results").join(e.file_name())).unwrap();
    }
    let anchors = dir.join("anchor.value");
    std::fs::copy(format!("{root}/tests/data/vot/bag_anchor.value"), &anchors).unwrap();
    let gt = dir.join("groundtruth.txt");
    let result = dir.join("results/bag_00000050.txt");
    for target in [&gt, &anchors, &result] {
        let before = std::fs::read(target).unwrap();
        let out = Command::new(env!("CARGO_BIN_EXE_shapetrack"))
            .args(["eval-vot", "--gt"])
            .arg(&dir)
            .arg("--tracker")
            .arg(dir.join("results"))
            .args(["--sequence", "bag", "--size", "480x360", "--json"])
            .arg(target)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success(),
            "--json {} was accepted",
            target.display()
        );
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
