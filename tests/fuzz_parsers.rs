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
//! panics, is slow, or makes one allocation larger than the caps admit ([`MAX_ALLOC`]) is
//! written to `target/fuzz-findings/` and fails the test.
//!
//! Besides the readers, the surfaces added since (issue 65, class 8): image headers (PNG and
//! JPEG frames, PNG instance maps), the writers' inputs (records built from the bytes), and
//! the detectors built from settings JSON and run on small frames. The wasm API's call
//! sequences (what the worker sends) are fuzzed in Node: `tests/wasm-node/sequence-fuzz.test.mjs`.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;
use shapetrack::detect::{
    BackgroundConfig, BackgroundSubtractor, BoxRefiner, Detector, MovingCameraDetector,
    MovingConfig, RefineConfig,
};
use shapetrack::frame::{Detection, Frame};
use shapetrack::io::coco_video::{parse_coco_video, parse_coco_video_results};
use shapetrack::io::coco_video::{write_coco_video, write_coco_video_results, Category, VideoInfo};
use shapetrack::io::cvat::parse_cvat;
use shapetrack::io::cvat::{write_cvat, CvatMeta};
use shapetrack::io::image_file::decode_image;
use shapetrack::io::limits::{MAX_FRAME, MAX_ID, MAX_PIXELS};
use shapetrack::io::motchallenge::write_mot;
use shapetrack::io::motchallenge::{parse_mot, parse_mots, write_mots, SeqInfo};
use shapetrack::io::png_masks::{decode_png_masks, encode_png_masks, EightBit};
use shapetrack::io::scalabel::parse_scalabel;
use shapetrack::io::scalabel::{from_records, write_scalabel, Categories};
use shapetrack::io::vot::{parse_anchor_values, parse_regions};
use shapetrack::io::{label_studio, yolo, Record, Rle};
use shapetrack::track::offline::OfflineConfig;
use shapetrack::track::Config;
use shapetrack::BBox;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::collections::BTreeMap;
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
        // Image headers: PNG and JPEG frames and PNG instance maps, sizes checked before
        // decoding (the run repairs PNG checksums, so mutated headers reach the check).
        Target {
            name: "image-headers",
            seeds: image_seeds(),
            run: decode_images,
        },
        // Records built from the bytes (frames, ids, boxes with NaN, ±inf and 1e308, masks of
        // the frame's size and others) through every writer.
        Target {
            name: "writers",
            seeds: writer_seeds(),
            run: write_all,
        },
        // The detectors (background, moving camera, box refinement) built from mutated
        // settings JSON and run on a few small frames.
        Target {
            name: "detectors",
            seeds: detect_seeds(),
            run: detect_case,
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
    // …but keep the last one's message and place for the findings (per thread: the hook runs
    // on the thread that panicked).
    thread_local! {
        static LAST: std::cell::RefCell<String> = const { std::cell::RefCell::new(String::new()) };
    }
    std::panic::set_hook(Box::new(|info| {
        let _ = LAST.try_with(|l| *l.borrow_mut() = info.to_string());
    }));
    let slow = slow();
    // `FUZZ_TARGETS=cvat,coco` runs only those readers.
    let only = std::env::var("FUZZ_TARGETS").ok();
    let targets: Vec<Target> = targets()
        .into_iter()
        .filter(|t| {
            only.as_deref()
                .is_none_or(|o| o.split(',').any(|n| n == t.name))
        })
        .collect();
    // One target's executions, in order, from its own seeded generator: the same inputs
    // whichever thread runs it. Returns its findings.
    let fuzz = |t: &Target| -> Vec<String> {
        let mut failures = Vec::new();
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
            LARGEST.with(|l| l.set(0));
            TRACKING.with(|on| on.set(true));
            let r = catch_unwind(AssertUnwindSafe(|| (t.run)(&input)));
            TRACKING.with(|on| on.set(false));
            let largest = LARGEST.with(Cell::get);
            let dt = s.elapsed();
            worst = worst.max(dt);
            if r.is_err() || dt > slow || largest > MAX_ALLOC {
                let _ = std::fs::create_dir_all(&findings);
                let file = findings.join(format!("{}-{k}.bin", t.name));
                let _ = std::fs::write(&file, &input);
                let what = match &r {
                    Err(_) => format!("panic ({})", LAST.with(|l| l.borrow().clone())),
                    Ok(()) if largest > MAX_ALLOC => {
                        format!("an allocation of {largest} bytes (over {MAX_ALLOC})")
                    }
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
        failures
    };
    // The targets are independent, so they run on every core (rayon's pool): the same
    // executions, in a fraction of the time.
    let mut failures: Vec<String> = targets.par_iter().flat_map_iter(fuzz).collect();
    failures.sort();
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

// ------------------------------------------------------------------------------------------
// The new surfaces (issue 65, class 8): image headers, the writers' inputs, detector
// construction from settings JSON. Each also runs under the allocation bound below.

/// The system allocator, noting the largest single request made on a thread while its
/// tracking is on: an input that makes a reader ask for more than the caps admit is a finding
/// even when the machine could give it (here it usually can, lazily; in wasm it is a trap).
struct Largest;

thread_local! {
    static TRACKING: Cell<bool> = const { Cell::new(false) };
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

fn note_alloc(size: usize) {
    // `try_with`: the thread-locals may be gone while a thread shuts down.
    let _ = TRACKING.try_with(|on| {
        if on.get() {
            let _ = LARGEST.try_with(|l| l.set(l.get().max(size)));
        }
    });
}

// SAFETY: every call is forwarded to `System` unchanged; the noting touches only
// const-initialised thread-locals, which never allocate.
unsafe impl GlobalAlloc for Largest {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note_alloc(layout.size());
        // SAFETY: the caller's contract is passed on as is.
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note_alloc(layout.size());
        // SAFETY: as above.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: as above.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note_alloc(new_size);
        // SAFETY: as above.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOC: Largest = Largest;

/// The largest single allocation any target may make for one input: a decoded image at the
/// pixel cap in the widest pixel type the decoders give (16-bit RGBA, 8 bytes a pixel), and
/// a megabyte of slack. A header over the cap that is decoded anyway (20000 × 20000 is 3.2 GB)
/// is far above it.
const MAX_ALLOC: usize = (MAX_PIXELS as usize) * 8 + (1 << 20);

/// CRC-32 (PNG's) of `bytes`.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// `png` with every whole chunk's CRC recomputed, so that a mutated header or palette reaches
/// the decoder instead of failing its checksum (unchanged when it is not a PNG).
fn fix_png_crcs(png: &[u8]) -> Vec<u8> {
    let mut out = png.to_vec();
    if !out.starts_with(b"\x89PNG\r\n\x1a\n") {
        return out;
    }
    let mut i = 8;
    while i + 12 <= out.len() {
        let len = u32::from_be_bytes([out[i], out[i + 1], out[i + 2], out[i + 3]]) as usize;
        let Some(end) = (i + 8).checked_add(len).filter(|&e| e + 4 <= out.len()) else {
            break;
        };
        let crc = crc32(&out[i + 4..end]);
        out[end..end + 4].copy_from_slice(&crc.to_be_bytes());
        i = end + 4;
    }
    out
}

fn encoded(img: image::DynamicImage, format: image::ImageFormat) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, format).unwrap();
    out.into_inner()
}

/// A PNG whose header claims `w × h` (a 1 × 1 image's data; CRCs right).
fn png_claiming(w: u32, h: u32, color: image::DynamicImage) -> Vec<u8> {
    let mut png = encoded(color, image::ImageFormat::Png);
    // Signature (8), IHDR length and type (8), then width and height.
    png[16..20].copy_from_slice(&w.to_be_bytes());
    png[20..24].copy_from_slice(&h.to_be_bytes());
    fix_png_crcs(&png)
}

/// A JPEG whose frame header claims `w × h` (16-bit sides: up to 65535 × 65535).
fn jpeg_claiming(w: u16, h: u16) -> Vec<u8> {
    let mut jpg = encoded(
        image::DynamicImage::ImageRgb8(image::RgbImage::from_pixel(8, 8, image::Rgb([9, 99, 199]))),
        image::ImageFormat::Jpeg,
    );
    let sof = jpg
        .windows(2)
        .position(|p| p[0] == 0xFF && (0xC0..=0xC2).contains(&p[1]))
        .expect("a JPEG frame header");
    // Marker (2), length (2), precision (1), then height and width.
    jpg[sof + 5..sof + 7].copy_from_slice(&h.to_be_bytes());
    jpg[sof + 7..sof + 9].copy_from_slice(&w.to_be_bytes());
    jpg
}

fn image_seeds() -> Vec<Vec<u8>> {
    use image::{DynamicImage as D, ImageBuffer, ImageFormat as F, Luma};
    let ids8 = ImageBuffer::from_fn(6, 5, |x, y| Luma([((x / 2 + y / 2) % 3) as u8]));
    let ids16: ImageBuffer<Luma<u16>, Vec<u16>> = ImageBuffer::from_fn(6, 5, |x, y| {
        Luma([[0u16, 7, 300, 65535][((x + y) % 4) as usize]])
    });
    let rgb = image::RgbImage::from_fn(5, 4, |x, y| image::Rgb([x as u8 * 40, y as u8 * 60, 7]));
    let rgba = image::RgbaImage::from_fn(3, 3, |x, y| image::Rgba([x as u8, y as u8, 1, 200]));
    let la = image::GrayAlphaImage::from_pixel(2, 2, image::LumaA([5, 9]));
    let one = || D::ImageLuma8(image::GrayImage::from_pixel(1, 1, Luma([1])));
    vec![
        encoded(D::ImageLuma8(ids8.clone()), F::Png),
        encoded(D::ImageLuma16(ids16), F::Png),
        encoded(D::ImageRgb8(rgb.clone()), F::Png),
        encoded(D::ImageRgba8(rgba), F::Png),
        encoded(D::ImageLumaA8(la), F::Png),
        encoded(D::ImageRgb8(rgb), F::Jpeg),
        encoded(D::ImageLuma8(ids8), F::Jpeg),
        // Headers over the cap (the 20000 × 20000 PNG bomb of the report), at it, and wide.
        png_claiming(20_000, 20_000, one()),
        png_claiming(8192, 8192, one()),
        png_claiming(65_536, 1, one()),
        png_claiming(u32::MAX, 2, one()),
        jpeg_claiming(20_000, 20_000),
        jpeg_claiming(8192, 8192),
        jpeg_claiming(65_535, 1),
    ]
}

/// Largest size the image target decodes in full. A header within the caps is decoded,
/// whatever the data holds: a 600-byte JPEG claiming 8192 × 8192 decodes (zeros after its
/// end) in ~3 s, allowed work but too slow for 10⁵ executions; those inputs run only the
/// entry points that refuse them before decoding (a frame of another size). Headers over the
/// caps go through every entry point: they must be refused before decoding.
const DECODE_PIXELS: u64 = 1 << 16;

/// Whether the image target decodes `bytes` in full as `format` (guessed when `None`): when
/// its header is unreadable, small, or over the caps (see [`DECODE_PIXELS`]).
fn decode_in_full(bytes: &[u8], format: Option<image::ImageFormat>) -> bool {
    let reader = std::io::Cursor::new(bytes);
    let reader = match format {
        Some(f) => Ok(image::ImageReader::with_format(reader, f)),
        None => image::ImageReader::new(reader).with_guessed_format(),
    };
    match reader.ok().and_then(|r| r.into_dimensions().ok()) {
        Some((w, h)) => {
            u64::from(w) * u64::from(h) <= DECODE_PIXELS
                || !shapetrack::io::limits::image_size_ok(w.into(), h.into())
        }
        None => true,
    }
}

/// Every image and PNG-mask entry point on `b`, and on `b` with its PNG checksums repaired.
fn decode_images(b: &[u8]) {
    use image::ImageFormat as F;
    let fixed = fix_png_crcs(b);
    let both = [b.to_vec(), fixed];
    // Once when the checksums were right already (or it is not a PNG).
    let inputs = if both[0] == both[1] {
        &both[..1]
    } else {
        &both[..]
    };
    for bytes in inputs {
        let _ = decode_image(bytes, Some(F::Png), "f.png", Some((6, 5)));
        let _ = decode_image(bytes, Some(F::Jpeg), "f.jpg", Some((5, 4)));
        if decode_in_full(bytes, None) {
            let _ = decode_image(bytes, None, "f", None);
        }
        if decode_in_full(bytes, Some(F::Jpeg)) {
            let _ = decode_image(bytes, Some(F::Jpeg), "f.jpg", None);
        }
        if decode_in_full(bytes, Some(F::Png)) {
            let _ = decode_png_masks(bytes, 1, "f.png", EightBit::Ids);
            let _ = decode_png_masks(bytes, 2, "f.png", EightBit::Binary { id: 4 });
        }
    }
}

/// Reads fuzzed bytes as numbers, with the edges the writers must handle picked often.
struct Draw<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Draw<'_> {
    fn byte(&mut self) -> u8 {
        let b = self.bytes.get(self.at).copied().unwrap_or(0);
        self.at += 1;
        b
    }
    fn more(&self) -> bool {
        self.at < self.bytes.len()
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes([self.byte(), self.byte()])
    }
    fn frame(&mut self) -> u32 {
        match self.byte() % 16 {
            0 => 0,
            1 => u32::MAX,
            2 => MAX_FRAME,
            3 => MAX_FRAME + 1,
            4 => 1 << 16,
            _ => 1 + u32::from(self.u16() % 48),
        }
    }
    fn id(&mut self) -> i64 {
        match self.byte() % 16 {
            0 => -1,
            1 => i64::MIN,
            2 => i64::MAX,
            3 => MAX_ID,
            4 => MAX_ID + 1,
            5 => -MAX_ID - 1,
            _ => i64::from(self.byte() % 6),
        }
    }
    fn f64(&mut self) -> f64 {
        match self.byte() % 16 {
            0 => f64::NAN,
            1 => f64::INFINITY,
            2 => f64::NEG_INFINITY,
            3 => 1e308,
            4 => -1e308,
            5 => -0.0,
            6 => f64::MIN_POSITIVE,
            7 => 4294967296.5,
            8 => -3.0,
            _ => f64::from(self.u16()) / 100.0,
        }
    }
    fn class(&mut self) -> i32 {
        match self.byte() % 8 {
            0 => -1,
            1 => i32::MIN,
            2 => i32::MAX,
            3 => 7,
            _ => i32::from(self.byte() % 2),
        }
    }
    /// A side for a frame or a meta field: small mostly, 0 and over the caps sometimes.
    fn side(&mut self, small: u32) -> u32 {
        match self.byte() % 16 {
            0 => 0,
            1 => u32::MAX,
            2 => 65_537,
            3 => 8193,
            _ => small,
        }
    }
}

/// What the writers' target builds from one input.
struct WriterCase {
    records: Vec<Record>,
    /// The frame size the records' masks mostly have.
    size: (u32, u32),
    /// The size and length the writers' metadata claim.
    meta: (u32, u32, u32),
    fps: f64,
}

/// Frame numbers the writers may be handed here. The COCO-video and Scalabel writers allocate
/// one slot per frame up to the video's length or the highest frame number (issue 65, class 2:
/// "writers never materialise empty frames up to a frame number", being fixed in the writers);
/// until then those two see frames and lengths up to this, so one case cannot ask for
/// gigabytes legitimately. The others see every frame number.
const MATERIALISED_FRAMES: u32 = 1 << 9;

fn writer_case(b: &[u8]) -> WriterCase {
    let mut d = Draw { bytes: b, at: 0 };
    let (w, h) = (1 + u32::from(d.byte() % 40), 1 + u32::from(d.byte() % 30));
    let meta = (d.side(w), d.side(h), {
        let f = d.frame();
        if f == 0 {
            0
        } else {
            f.max(48)
        }
    });
    let fps = d.f64();
    let mut records = Vec::new();
    while d.more() && records.len() < 64 {
        let mut r = Record::from_box(
            d.frame(),
            d.id(),
            BBox::new(d.f64(), d.f64(), d.f64(), d.f64()),
        );
        let flags = d.byte();
        r.class = d.class();
        if flags & 1 != 0 {
            r.score = d.f64();
        }
        if flags & 2 != 0 {
            r.visibility = d.f64();
        }
        r.flags.interpolated = flags & 4 != 0;
        r.flags.occluded = flags & 8 != 0;
        r.mask = match (flags >> 4) % 4 {
            0 | 1 => None,
            2 => Some(Rle::empty(w, h)),
            _ => {
                // Mostly the frame's size, sometimes another one.
                let (mw, mh) = if d.byte() % 4 == 0 {
                    (1 + u32::from(d.byte() % 50), 1 + u32::from(d.byte() % 50))
                } else {
                    (w, h)
                };
                let (x0, y0, n) = (d.byte(), d.byte(), d.byte());
                let bitmap: Vec<u8> = (0..mw * mh)
                    .map(|i| {
                        let (x, y) = (i % mw, i / mw);
                        let dx = x.wrapping_sub(u32::from(x0) % mw);
                        let dy = y.wrapping_sub(u32::from(y0) % mh);
                        u8::from(dx < u32::from(n % 16) && dy < u32::from(n / 16))
                    })
                    .collect();
                Some(Rle::encode(mw, mh, &bitmap).unwrap())
            }
        };
        records.push(r);
    }
    WriterCase {
        records,
        size: (w, h),
        meta,
        fps,
    }
}

/// Every writer in `shapetrack::io` on the records and metadata of `b`.
fn write_all(b: &[u8]) {
    let c = writer_case(b);
    let recs = &c.records;
    let (mw, mh, mframes) = c.meta;
    let _ = write_mot(recs);
    let _ = write_mots(recs);
    for size in [c.size, (mw, mh)] {
        let _ = yolo::write_yolo(recs, size);
        let _ = yolo::write_yolo_frames(recs, size);
    }
    let labels: BTreeMap<i32, String> = [(0, "car".to_string()), (1, "a<&\"b".to_string())]
        .into_iter()
        .collect();
    let _ = write_cvat(
        recs,
        &CvatMeta {
            name: "t<&>".into(),
            size: mframes,
            width: mw,
            height: mh,
        },
        &labels,
    );
    for (width, height) in [c.size, (mw, mh)] {
        let _ = label_studio::write_label_studio(
            recs,
            &label_studio::LabelStudioMeta {
                video: "v\"\\.mp4".into(),
                width,
                height,
                frames: mframes,
                fps: c.fps,
            },
            &labels,
        );
    }
    // The two writers that hold a slot per frame (see `MATERIALISED_FRAMES`).
    let capped: Vec<Record> = recs
        .iter()
        .filter(|r| r.frame <= MATERIALISED_FRAMES)
        .cloned()
        .collect();
    let length = mframes.min(MATERIALISED_FRAMES);
    for (width, height) in [c.size, (mw, mh)] {
        let video = VideoInfo {
            id: 1,
            width,
            height,
            length,
            file_names: Vec::new(),
        };
        let videos = [(video, capped.as_slice())];
        let categories = [
            Category {
                id: 0,
                name: "car".into(),
            },
            Category {
                id: 1,
                name: "x".into(),
            },
        ];
        let _ = write_coco_video(&videos, &categories);
        let _ = write_coco_video_results(&videos);
    }
    let frames = from_records(&capped, "v", length, None, &Categories::default());
    let _ = write_scalabel(&frames);
}

fn writer_seeds() -> Vec<Vec<u8>> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(65);
    let mut seeds: Vec<Vec<u8>> = (0..6)
        .map(|k| (0..40 + 60 * k).map(|_| rng.gen()).collect())
        .collect();
    // A tidy case: a 32 × 24 video of 48 frames, three tracks of sane boxes and masks (byte
    // 0x3f picks the small branch of each draw).
    let mut tidy = vec![31, 23, 0xff, 0xff, 0xff, 0xff, 0xff];
    for k in 0..12u8 {
        tidy.extend_from_slice(&[0xff, 1 + k / 3, 0, 0xff, k % 3]);
        for v in [10u8, 20, 30, 40] {
            tidy.extend_from_slice(&[0xff, v, 1]);
        }
        tidy.extend_from_slice(&[0x31 + (k % 2) * 0x10, 0xfc, 0, 0x01, k, 4, 0x44]);
    }
    seeds.push(tidy);
    seeds
}

/// A test frame: a grey gradient with a square that moves with `t`.
fn test_frame(w: u32, h: u32, t: u32) -> Vec<u8> {
    let mut data = vec![0u8; (w * h * 3) as usize];
    for y in 0..h {
        for x in 0..w {
            let inside = x.wrapping_sub(2 + 3 * t) < w / 3 && y.wrapping_sub(h / 4) < h / 2;
            let v = if inside {
                230
            } else {
                (40 + (x * 3 + y * 2) % 60) as u8
            };
            let i = ((y * w + x) * 3) as usize;
            data[i..i + 3].copy_from_slice(&[v, v / 2 + 20, 255 - v]);
        }
    }
    data
}

/// Largest frame the detectors' target runs (each case stays well under a millisecond or
/// two); a larger size from the input is still given to `Frame::new`, then shrunk.
const DETECT_PIXELS: u64 = 48 * 36;

/// `kind w h` on the first line, the detector's settings JSON after it: the detector is built
/// from the settings (missing fields default, unknown or out-of-range ones are errors) and
/// run on a few frames of the size given (the last of another size when `h` is odd, which
/// must be an error, not a panic).
fn detect_case(b: &[u8]) {
    let t = text(b);
    let (head, json) = t.split_once('\n').unwrap_or(("bg 16 12", &t));
    let mut f = head.split_whitespace();
    let kind = f.next().unwrap_or("bg");
    let mut num = || {
        f.next()
            .and_then(|v| v.parse::<f64>().ok())
            .map_or(16, |v| v as u32)
    };
    let (mut w, mut h) = (num(), num());
    let _ = Frame::rgb(&[], w, h);
    if w == 0 || h == 0 || u64::from(w) * u64::from(h) > DETECT_PIXELS {
        w = w.clamp(1, 48);
        h = h.clamp(1, 36);
    }
    let frames: Vec<Vec<u8>> = (0..3).map(|k| test_frame(w, h, k)).collect();
    let other = test_frame(w + 1, h, 3);
    let mut views: Vec<Frame> = frames
        .iter()
        .map(|d| Frame::rgb(d, w, h).unwrap())
        .collect();
    if h % 2 == 1 {
        views.push(Frame::rgb(&other, w + 1, h).unwrap());
    }
    let boxes = || {
        vec![
            Detection::from_box(BBox::new(1.0, 1.0, w as f64 / 2.0, h as f64 / 2.0), 0.9),
            Detection::from_box(BBox::new(-5.0, h as f64 - 2.0, 1e9, 3.0), 0.5),
            Detection::from_box(BBox::new(f64::NAN, 0.0, 3.0, f64::INFINITY), 0.7),
            Detection::from_box(BBox::new(2.0, 2.0, 0.0, 0.0), f64::NAN),
        ]
    };
    match kind {
        "bg" => {
            let Ok(cfg) = serde_json::from_str::<BackgroundConfig>(json) else {
                return;
            };
            if let Ok(mut det) = BackgroundSubtractor::new(cfg) {
                for v in &views {
                    let _ = det.detect(v);
                }
                det.reset();
                let _ = det.detect(&views[0]);
            }
        }
        "moving" => {
            let Ok(cfg) = serde_json::from_str::<MovingConfig>(json) else {
                return;
            };
            if let Ok(mut det) = MovingCameraDetector::new(cfg) {
                for v in &views {
                    let _ = det.detect(v);
                }
                det.reset();
                let _ = det.detect(&views[0]);
            }
        }
        _ => {
            let Ok(cfg) = serde_json::from_str::<RefineConfig>(json) else {
                return;
            };
            if let Ok(mut det) = BoxRefiner::new(cfg) {
                det.set_boxes(boxes());
                let _ = det.detect(&views[0]);
                let mut dets = boxes();
                let _ = det.refine_all(views.last().unwrap(), &mut dets, Some(2));
            }
        }
    }
}

fn detect_seeds() -> Vec<Vec<u8>> {
    let with = |head: &str, json: String| format!("{head}\n{json}").into_bytes();
    let bg = BackgroundConfig {
        init_frames: 1,
        ..Default::default()
    };
    let bg_shadow = BackgroundConfig {
        init_frames: 2,
        shadow: Some(Default::default()),
        min_area: 2,
        ..Default::default()
    };
    let moving_bg =
        serde_json::json!({"cue": "background", "min_age": 1, "refine": null, "work_side": 32});
    let refine_small = serde_json::json!({"max_side": 16, "iterations": 2, "clusters": 3});
    vec![
        with("bg 32 24", serde_json::to_string(&bg).unwrap()),
        with("bg 31 23", serde_json::to_string(&bg_shadow).unwrap()),
        with(
            "moving 40 30",
            serde_json::to_string(&MovingConfig::default()).unwrap(),
        ),
        with("moving 24 17", moving_bg.to_string()),
        with(
            "refine 32 24",
            serde_json::to_string(&RefineConfig::default()).unwrap(),
        ),
        with("refine 20 15", refine_small.to_string()),
    ]
}

/// The fuzzers' findings on the new surfaces, each fixed.
#[test]
fn writer_findings_hold() {
    // Class `i32::MIN` (a MOT file's class column can hold it): the Scalabel writer's category
    // lookup computed `class - 1` and overflowed (a panic with overflow checks on).
    let mut r = Record::from_box(1, 1, BBox::new(1.0, 2.0, 3.0, 4.0));
    r.class = i32::MIN;
    let frames = from_records(&[r], "v", 1, None, &Categories::default());
    let json = write_scalabel(&frames).unwrap();
    let back = parse_scalabel(&json, "s.json").unwrap();
    assert_eq!(
        back.iter().map(|f| f.labels.len()).sum::<usize>(),
        1,
        "{json}"
    );
    assert_eq!(Categories::default().name(i32::MIN), None);
}

/// The image bombs among the seeds are refused from their headers: an error, and no
/// allocation near the size they claim.
#[test]
fn image_bombs_refused_before_decoding() {
    let rgba = image::DynamicImage::ImageRgba8(image::RgbaImage::new(1, 1));
    for bomb in [
        png_claiming(20_000, 20_000, rgba.clone()),
        png_claiming(65_536, 1, rgba),
        jpeg_claiming(20_000, 20_000),
    ] {
        LARGEST.with(|l| l.set(0));
        TRACKING.with(|on| on.set(true));
        let e = decode_image(&bomb, None, "bomb", None).map(|_| ());
        let m = decode_png_masks(&bomb, 1, "bomb.png", EightBit::Ids).map(|_| ());
        TRACKING.with(|on| on.set(false));
        let e = e.unwrap_err().to_string();
        // The cap's message, or the PNG decoder's own refusal of a header whose data cannot
        // fill it (png checks that before the size reaches the cap).
        assert!(
            e.contains("refused before decoding") || e.contains("not have enough data"),
            "{e}"
        );
        assert!(m.is_err());
        let largest = LARGEST.with(Cell::get);
        assert!(largest < 1 << 20, "{largest} bytes allocated for {e}");
    }
}
