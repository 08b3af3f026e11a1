//! `shapetrack eval-vot` end to end on the toolkit fixture.

use std::process::Command;

#[test]
fn eval_vot_cli_reproduces_toolkit_numbers() {
    let root = env!("CARGO_MANIFEST_DIR");
    let json =
        std::env::temp_dir().join(format!("shapetrack-eval-vot-{}.json", std::process::id()));
    let out = Command::new(env!("CARGO_BIN_EXE_shapetrack"))
        .args([
            "eval-vot",
            "--gt",
            &format!("{root}/../shared/data/vot-bag"),
            "--tracker",
        ])
        .arg(format!("{root}/tests/data/vot/results/constant/baseline"))
        .args(["--sequence", "bag", "--toolkit", "--anchors"])
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
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let r: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(format!("{root}/tests/data/vot/toolkit_reference.json")).unwrap(),
    )
    .unwrap();
    let want = &r["trackers"]["constant"]["anchor"];
    for k in ["accuracy", "robustness", "eao"] {
        let (a, b) = (v[k].as_f64().unwrap(), want[k].as_f64().unwrap());
        assert!((a - b).abs() < 1e-12, "{k}: {a} vs {b}");
    }
    assert_eq!(v["anchors"].as_array().unwrap().len(), 4);
    let _ = std::fs::remove_file(&json);

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
