//! Our MOT figures against TrackEval's: published tables in ../shared/data and fixtures made
//! with the real TrackEval by tests/data/eval/make_fixtures.py.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use serde_json::Value;
use shapetrack::eval::{evaluate, EvalConfig, SequenceInput};
use shapetrack::io::layout::{discover, load_sequence, read_records, Format};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data")
}

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/eval")
}

/// How an expected value was published.
#[derive(Clone, Copy)]
enum Given {
    /// Printed with 3 decimals (`%.3f`): ours must print the same.
    Decimals3,
    /// Full double precision: ours must agree to 1e-9 (far inside 3 decimals).
    Full,
}

/// Expected rows: sequence name (or "COMBINED") → field → value.
type Rows = BTreeMap<String, BTreeMap<String, f64>>;

/// Evaluates `gt`+`results` (already paired in `inputs`) and compares every expected field.
fn check(inputs: &[SequenceInput], config: &EvalConfig, expected: &Rows, given: Given) {
    let results = evaluate(inputs, config).unwrap();
    let summary = serde_json::to_value(results.summary()).unwrap();
    let mut checked = 0;
    for (row, fields) in expected {
        let ours = if row == "COMBINED" {
            &summary["combined"]
        } else {
            &summary["sequences"][row]
        };
        assert!(ours.is_object(), "no row {row} in our results");
        for (field, &want) in fields {
            let got = ours[field]
                .as_f64()
                .unwrap_or_else(|| panic!("no field {field} in row {row}"));
            let ok = match given {
                Given::Decimals3 => format!("{got:.3}") == format!("{want:.3}"),
                Given::Full => (got - want).abs() <= 1e-9 * want.abs().max(1.0),
            };
            assert!(ok, "{row} {field}: ours {got}, TrackEval {want}");
            checked += 1;
        }
    }
    assert!(checked > 0, "nothing compared");
}

fn row(pairs: &[(&str, f64)]) -> BTreeMap<String, f64> {
    pairs.iter().map(|(k, v)| (k.to_string(), *v)).collect()
}

#[test]
fn tud_motmetrics_reference() {
    let root = data().join("tud-motmetrics-reference");
    let layout = discover(&root, "MOT15", "train").unwrap();
    let inputs: Vec<SequenceInput> = layout
        .sequences
        .iter()
        .map(|e| {
            let file = root
                .join(&e.name)
                .join("trackers/motmetrics_test")
                .join(format!("{}.txt", e.name));
            let (gt, gt_origin) = read_records(&e.gt_file, Format::Mot, true).unwrap();
            let (results, res_origin) = read_records(&file, Format::Mot, false).unwrap();
            SequenceInput {
                name: e.name.clone(),
                num_frames: e.num_frames,
                gt,
                results,
                gt_origin: Some(gt_origin),
                results_origin: Some(res_origin),
            }
        })
        .collect();
    assert_eq!(inputs.len(), 2);
    // TrackEval's figures as published in ../shared/data/README.md ("Reference numbers").
    let cols = [
        "HOTA", "DetA", "AssA", "MOTA", "MOTP", "IDF1", "IDSW", "MT", "ML",
    ];
    let table: [(&str, [f64; 9]); 3] = [
        (
            "TUD-Campus",
            [
                39.140, 41.805, 36.912, 52.646, 72.280, 55.766, 7.0, 1.0, 1.0,
            ],
        ),
        (
            "TUD-Stadtmitte",
            [
                39.785, 39.227, 40.884, 56.401, 65.410, 64.462, 7.0, 5.0, 1.0,
            ],
        ),
        (
            "COMBINED",
            [
                39.996, 39.768, 41.245, 55.512, 66.982, 62.430, 14.0, 6.0, 2.0,
            ],
        ),
    ];
    let expected: Rows = table
        .iter()
        .map(|(name, vals)| {
            let pairs: Vec<(&str, f64)> = cols.iter().copied().zip(vals.iter().copied()).collect();
            (name.to_string(), row(&pairs))
        })
        .collect();
    check(
        &inputs,
        &EvalConfig::for_benchmark("MOT15", false),
        &expected,
        Given::Decimals3,
    );
}

fn mot15_inputs(tracker: &str) -> Vec<SequenceInput> {
    let layout = discover(&data().join("mot15-train"), "MOT15", "train").unwrap();
    assert_eq!(layout.sequences.len(), 11);
    let res = data()
        .join("mot15-train-baselines")
        .join(tracker)
        .join("data");
    layout
        .sequences
        .iter()
        .map(|e| load_sequence(e, &res, Format::Mot, false).unwrap())
        .collect()
}

/// `SUMMARY seq HOTA DetA AssA MOTA MOTP IDF1 IDSW MT ML` lines of trackeval_summary.txt.
fn parse_trackeval_summary(path: &Path) -> Rows {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines().filter(|l| l.starts_with("SUMMARY "));
    let header: Vec<&str> = lines.next().unwrap().split_whitespace().skip(2).collect();
    assert_eq!(header[0], "HOTA");
    lines
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            let name = if f[1] == "COMBINED_SEQ" {
                "COMBINED"
            } else {
                f[1]
            };
            let vals = header
                .iter()
                .zip(&f[2..])
                .map(|(k, v)| (k.to_string(), v.parse::<f64>().unwrap()))
                .collect();
            (name.to_string(), vals)
        })
        .collect()
}

/// Every summary field of TrackEval's pedestrian_detailed.csv (full precision).
fn parse_trackeval_detailed(path: &Path) -> Rows {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    // Fields TrackEval stores as fractions, and the names our summary gives them.
    let percent = [
        "HOTA(0)",
        "LocA(0)",
        "HOTALocA(0)",
        "MOTA",
        "MOTP",
        "MODA",
        "CLR_Re",
        "CLR_Pr",
        "MTR",
        "PTR",
        "MLR",
        "sMOTA",
        "CLR_F1",
        "MOTAL",
        "IDF1",
        "IDR",
        "IDP",
    ];
    let plain = [
        ("FP_per_frame", "FP_per_frame"),
        ("CLR_TP", "CLR_TP"),
        ("CLR_FN", "FN"),
        ("CLR_FP", "FP"),
        ("IDSW", "IDSW"),
        ("MT", "MT"),
        ("PT", "PT"),
        ("ML", "ML"),
        ("Frag", "Frag"),
        ("CLR_Frames", "CLR_Frames"),
        ("IDTP", "IDTP"),
        ("IDFN", "IDFN"),
        ("IDFP", "IDFP"),
        ("Dets", "Dets"),
        ("GT_Dets", "GT_Dets"),
        ("IDs", "IDs"),
        ("GT_IDs", "GT_IDs"),
    ];
    let auc = [
        "HOTA", "DetA", "AssA", "DetRe", "DetPr", "AssRe", "AssPr", "LocA", "OWTA",
    ];
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let get = |k: &str| -> f64 {
                let i = header.iter().position(|h| *h == k).unwrap();
                f[i].parse().unwrap()
            };
            let mut r = BTreeMap::new();
            for k in percent {
                r.insert(k.to_string(), 100.0 * get(k));
            }
            for (theirs, ours) in plain {
                r.insert(ours.to_string(), get(theirs));
            }
            for k in auc {
                r.insert(k.to_string(), 100.0 * get(&format!("{k}___AUC")));
            }
            (f[0].to_string(), r)
        })
        .collect()
}

const BASELINES: [&str; 4] = ["rf_sort", "rf_bytetrack", "norfair", "motpy"];

#[test]
fn mot15_baselines_equal_trackeval_summary() {
    for t in BASELINES {
        let expected = parse_trackeval_summary(
            &data()
                .join("mot15-train-baselines")
                .join(t)
                .join("trackeval_summary.txt"),
        );
        assert_eq!(expected.len(), 12, "{t}: 11 sequences + combined");
        check(
            &mot15_inputs(t),
            &EvalConfig::for_benchmark("MOT15", false),
            &expected,
            Given::Decimals3,
        );
    }
}

#[test]
fn mot15_baselines_equal_trackeval_detailed_csv() {
    for t in BASELINES {
        let expected = parse_trackeval_detailed(
            &data()
                .join("mot15-train-baselines")
                .join(t)
                .join("pedestrian_detailed.csv"),
        );
        assert_eq!(expected.len(), 12);
        check(
            &mot15_inputs(t),
            &EvalConfig::for_benchmark("MOT15", false),
            &expected,
            Given::Full,
        );
    }
}

/// A fixture made by make_fixtures.py: `<case>/{gt,trackers}` and TrackEval's expected.json.
fn check_fixture(case: &str) {
    let dir = fixtures().join(case);
    let exp: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("expected.json")).unwrap()).unwrap();
    let bench = exp["benchmark"].as_str().unwrap();
    let masks = exp["masks"].as_bool().unwrap();
    let layout = discover(&dir.join("gt"), bench, "train").unwrap();
    let res = dir
        .join("trackers")
        .join(format!("{bench}-train"))
        .join("test/data");
    let format = if masks { Format::Mots } else { Format::Mot };
    let inputs: Vec<SequenceInput> = layout
        .sequences
        .iter()
        .map(|e| load_sequence(e, &res, format, false).unwrap())
        .collect();
    let to_row = |v: &Value| -> BTreeMap<String, f64> {
        v.as_object()
            .unwrap()
            .iter()
            .map(|(k, x)| (k.clone(), x.as_f64().unwrap()))
            .collect()
    };
    let mut expected: Rows = exp["sequences"]
        .as_object()
        .unwrap()
        .iter()
        .map(|(k, v)| (k.clone(), to_row(v)))
        .collect();
    assert_eq!(expected.len(), inputs.len());
    expected.insert("COMBINED".into(), to_row(&exp["combined"]));
    check(
        &inputs,
        &EvalConfig::for_benchmark(bench, masks),
        &expected,
        Given::Full,
    );
}

#[test]
fn fixture_mot17_preprocessing() {
    check_fixture("mot17");
}

#[test]
fn fixture_mot20_preprocessing() {
    check_fixture("mot20");
}

#[test]
fn fixture_mots_masks_and_ignore_regions() {
    check_fixture("mots");
}

#[test]
fn fixture_edge_cases() {
    check_fixture("edge");
}

/// Removing one tracker row can raise recall in TrackEval (see make_fixtures.py): we must agree
/// with TrackEval there too, not with the intuition.
#[test]
fn fixture_recall_is_not_monotone_in_trackeval() {
    check_fixture("nonmonotone");
    let dir = fixtures().join("nonmonotone");
    let exp: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("expected.json")).unwrap()).unwrap();
    let s = &exp["sequences"];
    assert!(s["clear-removed"]["CLR_Re"].as_f64() > s["clear-full"]["CLR_Re"].as_f64());
    assert!(s["hota-removed"]["DetRe"].as_f64() > s["hota-full"]["DetRe"].as_f64());
}
