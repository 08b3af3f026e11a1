//! A mutation fuzzer that runs on the stable toolchain, in `cargo test`: every reader of an
//! outside file (and the config readers) is fed seeded mutations of real inputs — from
//! `tests/data` and `../shared/data` — and must answer `Ok` or a typed error, never panic,
//! and never take long (a slow input is how an allocation or interpolation bomb shows before
//! it aborts the process).
//!
//! `FUZZ_ITERS` sets the executions per reader (`FUZZ_TARGETS` which readers) (default 100,000 in release builds, 2,000 in
//! debug ones, where `cargo test` runs it on every change); `FUZZ_SEED` the seed. The long run
//! whose figures are in the README:
//!
//! ```text
//! FUZZ_ITERS=1000000 CARGO_PROFILE_RELEASE_OVERFLOW_CHECKS=true \
//!     cargo test --release --test fuzz_parsers -- --nocapture
//! ```
//!
//! Overflow checks stay on (debug, or the release profile with them turned on): an arithmetic
//! overflow that would silently wrap in a release build is a finding too. An input that
//! panics or is slow is written to `target/fuzz-findings/` and fails the test.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use shapetrack::io::coco_video::{parse_coco_video, parse_coco_video_results};
use shapetrack::io::cvat::parse_cvat;
use shapetrack::io::motchallenge::{parse_mot, parse_mots, write_mots, SeqInfo};
use shapetrack::io::png_masks::{decode_png_masks, encode_png_masks, EightBit};
use shapetrack::io::scalabel::parse_scalabel;
use shapetrack::io::vot::{parse_anchor_values, parse_regions};
use shapetrack::io::{label_studio, yolo, Record, Rle};
use shapetrack::track::offline::OfflineConfig;
use shapetrack::track::Config;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;
use std::time::{Duration, Instant};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn read(rel: &str) -> Vec<u8> {
    std::fs::read(root().join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

/// The first `n` lines of a file.
fn head(rel: &str, n: usize) -> Vec<u8> {
    let text = String::from_utf8(read(rel)).unwrap();
    let mut out: String = text.lines().take(n).collect::<Vec<_>>().join("\n");
    out.push('\n');
    out.into_bytes()
}

fn small_mask_records() -> Vec<Record> {
    let mut recs = Vec::new();
    for (k, id) in [(1u32, 1i64), (1, 2), (2, 1)] {
        let mut bitmap = vec![0u8; 32 * 24];
        for y in 4..12 + k as usize {
            for x in (3 * id as usize)..(10 + 3 * id as usize) {
                bitmap[y * 32 + x] = 1;
            }
        }
        let mut r = Record::from_box(k, id, Default::default());
        r.mask = Some(Rle::encode(32, 24, &bitmap).unwrap());
        recs.push(r);
    }
    recs
}

/// Numbers that sit on the edges readers must check.
const INTERESTING: &[&str] = &[
    "0",
    "-1",
    "1",
    "65536",
    "65537",
    "1048576",
    "1048577",
    "2147483648",
    "4294967295",
    "4294967296",
    "18446744073709551615",
    "18446744073709551611",
    "1e300",
    "-1e300",
    "NaN",
    "inf",
    "1e-300",
    "100000000",
    "8192",
    "16384",
    "\"\"",
    "[]",
    "{}",
    "null",
];

/// One mutation of `seed` (bytes), using `other` seeds for splicing.
fn mutate(rng: &mut Xoshiro256PlusPlus, seed: &[u8], others: &[Vec<u8>]) -> Vec<u8> {
    let mut out = seed.to_vec();
    let rounds = 1 + rng.gen_range(0..4);
    for _ in 0..rounds {
        let len = out.len();
        let at = if len == 0 { 0 } else { rng.gen_range(0..=len) };
        match rng.gen_range(0..8) {
            // Flip a bit.
            0 if len > 0 => {
                let i = rng.gen_range(0..len);
                out[i] ^= 1 << rng.gen_range(0..8);
            }
            // Insert a random printable byte.
            1 => out.insert(at, rng.gen_range(b' '..=b'~')),
            // Delete a range.
            2 if len > 0 => {
                let n = rng.gen_range(1..=16.min(len - at.min(len - 1)));
                let a = at.min(len - 1);
                out.drain(a..(a + n).min(len));
            }
            // Duplicate a range (repeats lines, keys, keyframes).
            3 if len > 0 => {
                let a = at.min(len - 1);
                let n = rng.gen_range(1..=200.min(len - a));
                let piece: Vec<u8> = out[a..a + n].to_vec();
                let to = rng.gen_range(0..=out.len());
                out.splice(to..to, piece);
            }
            // Splice in a piece of another seed.
            4 if !others.is_empty() => {
                let o = &others[rng.gen_range(0..others.len())];
                if !o.is_empty() {
                    let a = rng.gen_range(0..o.len());
                    let n = rng.gen_range(1..=64.min(o.len() - a));
                    out.splice(at..at, o[a..a + n].iter().copied());
                }
            }
            // Replace a number with an interesting one.
            5 | 6 => {
                let starts: Vec<usize> = (0..len)
                    .filter(|&i| {
                        out[i].is_ascii_digit() && (i == 0 || !out[i - 1].is_ascii_digit())
                    })
                    .collect();
                if let Some(&s) = starts.get(rng.gen_range(0..starts.len().max(1))) {
                    let mut e = s;
                    while e < len && (out[e].is_ascii_digit() || out[e] == b'.') {
                        e += 1;
                    }
                    let v = INTERESTING[rng.gen_range(0..INTERESTING.len())];
                    out.splice(s..e, v.bytes());
                }
            }
            // Insert an interesting token.
            _ => {
                let v = INTERESTING[rng.gen_range(0..INTERESTING.len())];
                out.splice(at..at, v.bytes());
            }
        }
    }
    out
}

struct Target {
    name: &'static str,
    seeds: Vec<Vec<u8>>,
    run: fn(&[u8]),
}

fn text(b: &[u8]) -> std::borrow::Cow<'_, str> {
    String::from_utf8_lossy(b)
}

fn targets() -> Vec<Target> {
    let mot = vec![
        head("../shared/data/mot15-train/TUD-Campus/det/det.txt", 40),
        head("../shared/data/mot15-train/KITTI-13/gt/gt.txt", 40),
    ];
    let mots = vec![write_mots(&small_mask_records()).into_bytes()];
    let seqinfo = vec![read("../shared/data/mot15-train/TUD-Campus/seqinfo.ini")];
    let cvat = vec![read("tests/data/formats/cvat_video_1_1.xml")];
    let coco = vec![read("tests/data/formats/coco_video_pycocotools.json")];
    let scalabel = {
        let v: serde_json::Value = serde_json::from_slice(&read(
            "../shared/data/bdd100k-sample/box_track/track_predictions.json",
        ))
        .unwrap();
        let first: Vec<serde_json::Value> = v.as_array().unwrap().iter().take(2).cloned().collect();
        let seg: serde_json::Value = serde_json::from_slice(&read(
            "../shared/data/bdd100k-sample/seg_track/seg_track_preds.json",
        ))
        .unwrap();
        let seg_first = match &seg {
            serde_json::Value::Array(a) => {
                serde_json::Value::Array(a.iter().take(1).cloned().collect())
            }
            other => other.clone(),
        };
        vec![
            serde_json::to_vec(&first).unwrap(),
            serde_json::to_vec(&seg_first).unwrap(),
        ]
    };
    // Label Studio and YOLO: the writers' output for a few tracks with gaps and filled frames,
    // and a hand-written export with sparse keyframes, a rotation and a labels result.
    let boxes: Vec<Record> = small_mask_records()
        .into_iter()
        .map(|mut r| {
            r.mask = None;
            r.bbox = shapetrack::BBox::new(3.0 * r.id as f64, 4.0, 7.0, 8.0 + r.frame as f64);
            r.class = 0;
            r.flags.interpolated = r.frame == 2;
            r
        })
        .collect();
    let frames = boxes.iter().map(|r| r.frame).max().unwrap_or(1);
    let label_studio = vec![
        label_studio::write_label_studio(
            &boxes,
            &label_studio::LabelStudioMeta {
                video: "v.mp4".into(),
                width: 32,
                height: 24,
                frames,
                fps: 24.0,
            },
            &[(0, "car".to_string())].into_iter().collect(),
        )
        .unwrap()
        .into_bytes(),
        br#"[{"data":{"video":"v"},"annotations":[{"result":[{"id":"q1","type":"videorectangle","value":{"framesCount":9,"labels":["a"],"sequence":[{"frame":1,"enabled":true,"x":10,"y":10,"width":20,"height":20,"rotation":30},{"frame":4,"enabled":false,"x":20,"y":10,"width":20,"height":20}]}},{"id":"q1","type":"labels","value":{"labels":["b"]}}]}]}]"#.to_vec(),
    ];
    let yolo_seeds = vec![
        yolo::write_yolo(&boxes, (32, 24)).unwrap().into_bytes(),
        b"0 0.5 0.5 0.25 0.5 7\n2 0.25 0.25 0.1 0.1 0.66 8\n1 0.5 0.5 1 1\n".to_vec(),
    ];
    let vot = vec![
        {
            let mut v = head("../shared/data/vot-bag/groundtruth.txt", 20);
            v.extend_from_slice(b"m2,3,3,2,1,4,1\n0\n1\n2\nnan,nan,nan,nan\n");
            v
        },
        b"1\n10.5,20,30,40\n1,2,3,4,5,6,7,8\nm0,0,8,8,0,1\n".to_vec(),
    ];
    let anchors = vec![head("tests/data/vot/bag_anchor.value", 20)];
    let rle = small_mask_records()
        .iter()
        .filter_map(|r| r.mask.as_ref())
        .map(|m| format!("{} {}\n{}", m.height, m.width, m.to_compressed()).into_bytes())
        .collect();
    let png = vec![encode_png_masks(&small_mask_records()[..2], 32, 24).unwrap()];
    let config = vec![
        serde_json::to_vec(&Config::default()).unwrap(),
        br#"{"max_lost": 7, "terms": {"iou": {"weight": 2.0}}, "motion": {"std_measurement": 0.2}}"#
            .to_vec(),
        serde_json::to_vec(&OfflineConfig::default()).unwrap(),
    ];
    vec![
        Target {
            name: "mot",
            seeds: mot,
            run: |b| drop(parse_mot(&text(b), "f")),
        },
        Target {
            name: "mots",
            seeds: mots,
            run: |b| drop(parse_mots(&text(b), "f")),
        },
        Target {
            name: "seqinfo",
            seeds: seqinfo,
            run: |b| drop(SeqInfo::parse(&text(b), "f")),
        },
        Target {
            name: "cvat",
            seeds: cvat,
            run: |b| drop(parse_cvat(&text(b), "f", None)),
        },
        Target {
            name: "coco",
            seeds: coco,
            run: |b| {
                let t = text(b);
                if let Ok(d) = parse_coco_video(&t, "f") {
                    let videos: Vec<_> = d.videos.into_iter().map(|v| v.video).collect();
                    let _ = parse_coco_video_results(&t, "f", &videos);
                }
            },
        },
        Target {
            name: "scalabel",
            seeds: scalabel,
            run: |b| drop(parse_scalabel(&text(b), "f")),
        },
        Target {
            name: "label-studio",
            seeds: label_studio,
            run: |b| {
                drop(label_studio::parse_label_studio(
                    &text(b),
                    "f",
                    (32, 24),
                    None,
                ))
            },
        },
        Target {
            name: "yolo",
            seeds: yolo_seeds,
            run: |b| {
                let t = text(b);
                let _ = yolo::parse_yolo(&t, "f", (32, 24));
                let _ = yolo::parse_yolo_frame(&t, "f", 3, (32, 24));
            },
        },
        Target {
            name: "vot",
            seeds: vot,
            run: |b| drop(parse_regions(&text(b), "f")),
        },
        Target {
            name: "vot-anchors",
            seeds: anchors,
            run: |b| drop(parse_anchor_values(&text(b), "f")),
        },
        Target {
            name: "rle",
            seeds: rle,
            run: |b| {
                let t = text(b);
                let (dims, s) = t.split_once('\n').unwrap_or(("1 1", &t));
                let mut d = dims
                    .split_whitespace()
                    .map(|v| v.parse::<u32>().unwrap_or(1));
                let (h, w) = (d.next().unwrap_or(1), d.next().unwrap_or(1));
                // Only sizes a reader would accept reach the decoder (they check first).
                if (h as u64) * (w as u64) <= 1 << 20 {
                    if let Ok(r) = Rle::from_compressed(s, h, w) {
                        let _ = r.bbox();
                        let _ = r.to_mask();
                    }
                }
            },
        },
        Target {
            name: "png-masks",
            seeds: png,
            run: |b| {
                let _ = decode_png_masks(b, 1, "f.png", EightBit::Ids);
                let _ = decode_png_masks(b, 1, "f.png", EightBit::Binary { id: 3 });
            },
        },
        Target {
            name: "config",
            seeds: config,
            run: |b| {
                let t = text(b);
                let _ = Config::default().overlay_json(&t).map(|c| c.validate());
                let _ = OfflineConfig::from_json(&t);
            },
        },
    ]
}

/// Longest an execution may take before it counts as a finding (`FUZZ_SLOW_MS` to look for
/// smaller amplifications): a hostile size shows here, and every seed takes well under a
/// millisecond, so a busy machine is far from it.
fn slow() -> Duration {
    let ms = std::env::var("FUZZ_SLOW_MS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10_000);
    Duration::from_millis(ms)
}

#[test]
fn mutated_inputs_never_panic_or_hang() {
    let iters: usize = std::env::var("FUZZ_ITERS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(if cfg!(debug_assertions) {
            2_000
        } else {
            100_000
        });
    let seed: u64 = std::env::var("FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0x5eed);
    let findings = root().join("target/fuzz-findings");
    // The panics are expected to be caught; keep the default hook from printing each one.
    let hook = std::panic::take_hook();
    // …but keep the last one's message and place for the findings.
    static LAST: std::sync::Mutex<String> = std::sync::Mutex::new(String::new());
    std::panic::set_hook(Box::new(|info| {
        if let Ok(mut l) = LAST.lock() {
            *l = info.to_string();
        }
    }));
    let mut failures = Vec::new();
    let slow = slow();
    // `FUZZ_TARGETS=cvat,coco` runs only those readers.
    let only = std::env::var("FUZZ_TARGETS").ok();
    for t in targets() {
        if only
            .as_deref()
            .is_some_and(|o| !o.split(',').any(|n| n == t.name))
        {
            continue;
        }
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed ^ t.name.len() as u64);
        let t0 = Instant::now();
        let mut worst = Duration::ZERO;
        for k in 0..iters {
            let base = &t.seeds[k % t.seeds.len()];
            // Every 16th input is a seed itself, the rest mutations (some of mutations).
            let input = if k % 16 == 0 {
                base.clone()
            } else {
                let once = mutate(&mut rng, base, &t.seeds);
                if k % 3 == 0 {
                    mutate(&mut rng, &once, &t.seeds)
                } else {
                    once
                }
            };
            let s = Instant::now();
            let r = catch_unwind(AssertUnwindSafe(|| (t.run)(&input)));
            let dt = s.elapsed();
            worst = worst.max(dt);
            if r.is_err() || dt > slow {
                let _ = std::fs::create_dir_all(&findings);
                let file = findings.join(format!("{}-{k}.bin", t.name));
                let _ = std::fs::write(&file, &input);
                let what = match &r {
                    Err(_) => format!(
                        "panic ({})",
                        LAST.lock().map(|l| l.clone()).unwrap_or_default()
                    ),
                    Ok(()) => "slow".to_string(),
                };
                failures.push(format!("{} {what} ({dt:?}): {}", t.name, file.display()));
                if failures.len() > 20 {
                    break;
                }
            }
        }
        println!(
            "fuzz {:12} {iters} executions in {:.1} s, slowest {:.1} ms",
            t.name,
            t0.elapsed().as_secs_f64(),
            worst.as_secs_f64() * 1e3
        );
    }
    std::panic::set_hook(hook);
    assert!(failures.is_empty(), "findings:\n{}", failures.join("\n"));
}

/// The repros of the robustness report, each a typed error (or a correct result) now.
#[test]
fn hostile_inputs_get_typed_errors() {
    // A frame number far beyond any video.
    let e = parse_mot("1,-1,1,1,5,5,1\n4294967295,-1,1,1,5,5,1\n", "det.txt").unwrap_err();
    assert!(
        e.to_string().contains("det.txt") && e.to_string().contains("cap"),
        "{e}"
    );
    // seqinfo declaring four billion frames, or a zero width.
    let ini = "[Sequence]\nname=x\nframeRate=30\nseqLength=4294967295\nimWidth=64\nimHeight=48\n";
    assert!(SeqInfo::parse(ini, "seqinfo.ini").is_err());
    let ini = "[Sequence]\nname=x\nframeRate=30\nseqLength=10\nimWidth=0\nimHeight=48\n";
    assert!(SeqInfo::parse(ini, "seqinfo.ini").is_err());
    // A 25-byte MOTS line declaring a 65536 × 65536 mask.
    let runs = Rle {
        height: 65536,
        width: 65536,
        counts: vec![0, 1 << 31, 1 << 31],
    };
    let line = format!("1 -1 -1 65536 65536 {}\n", runs.to_compressed());
    let e = parse_mots(&line, "m.txt").unwrap_err();
    assert!(e.to_string().contains("pixels"), "{e}");
    // CVAT run lengths that wrap around 2⁶⁴ to the box's area, and keyframes a million
    // frames apart.
    let cvat = |shapes: &str, size: u32| {
        format!(
            "<annotations><version>1.1</version><meta><task><size>{size}</size>\
             <original_size><width>64</width><height>48</height></original_size>\
             </task></meta><track id=\"0\" label=\"a\">{shapes}</track></annotations>"
        )
    };
    let wrap = cvat(
        "<mask frame=\"0\" keyframe=\"1\" outside=\"0\" occluded=\"0\" rle=\"0, 10, 18446744073709551611\" \
         left=\"0\" top=\"47\" width=\"5\" height=\"1\"/>",
        10,
    );
    assert!(parse_cvat(&wrap, "c.xml", None).is_err());
    let far = cvat(
        "<box frame=\"0\" keyframe=\"1\" outside=\"0\" occluded=\"0\" xtl=\"1\" ytl=\"1\" xbr=\"5\" ybr=\"5\"/>\
         <box frame=\"1048575\" keyframe=\"1\" outside=\"0\" occluded=\"0\" xtl=\"1\" ytl=\"1\" xbr=\"5\" ybr=\"5\"/>",
        0,
    );
    let e = parse_cvat(&far, "c.xml", None).err().map(|e| e.to_string());
    assert!(
        e.as_ref()
            .is_some_and(|e| e.contains("expands to more than")),
        "{e:?}"
    );
    // Twenty 8192 × 8192 VOT masks in 400 bytes: each holds one pixel, stored as one.
    let vot = "m0,0,8192,8192,0,1\n".repeat(20);
    let regions = parse_regions(&vot, "g.txt").unwrap();
    assert!(regions.iter().all(|r| match r {
        shapetrack::io::vot::Region::Mask(m) => m.width() * m.height() == 1,
        _ => false,
    }));
    // Polygons at ±1e300 (once an accuracy of NaN).
    let huge = "1e300,-1e300,1e300,1e300,-1e300,1e300,-1e300,-1e300\n";
    assert!(parse_regions(huge, "g.txt").is_err());
    // A config that is an array is not read field by field.
    assert!(Config::default().overlay_json("[1,2,3]").is_err());
}
