use super::*;

/// `n` frames of `k` objects side by side (no overlap), 40×100 boxes, moving right 2 px/frame.
fn walkers(n: u32, k: usize) -> GtSequence {
    let frames = (0..n)
        .map(|f| {
            (0..k)
                .map(|i| GtObject {
                    id: i as i64 + 1,
                    bbox: BBox::new(20.0 + 60.0 * i as f64 + 2.0 * f as f64, 50.0, 40.0, 100.0),
                    mask: None,
                    visibility: None,
                })
                .collect()
        })
        .collect();
    GtSequence {
        width: 1280,
        height: 720,
        frames,
    }
}

fn by_frame(recs: &[Record], n: u32) -> Vec<Vec<&Record>> {
    let mut v = vec![Vec::new(); n as usize];
    for r in recs {
        v[r.frame as usize - 1].push(r);
    }
    v
}

fn quantile(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q) as usize]
}

#[test]
fn deterministic_and_seeded() {
    let gt = walkers(50, 8);
    for p in profiles() {
        let a = p.apply(&gt, 7);
        assert_eq!(a, p.apply(&gt, 7), "{}", p.name);
        assert_ne!(a, p.apply(&gt, 8), "{}", p.name);
    }
}

#[test]
fn exact_model_reports_the_ground_truth() {
    let gt = walkers(10, 3);
    let d = DetectorModel::exact("exact").apply(&gt, 1);
    assert_eq!(d.len(), 30);
    assert!(d.iter().all(|r| r.score == 1.0 && r.id == -1));
    assert_eq!(d[0].bbox, gt.frames[0][0].bbox);
}

#[test]
fn fully_hidden_objects_are_never_detected() {
    // Amodal ground truth (the pedestrian crowd) keeps hidden people with visibility 0: no
    // detector sees them, whatever its occlusion rate; a barely visible one may be seen.
    let mut gt = walkers(10, 3);
    for f in &mut gt.frames {
        f[0].visibility = Some(0.0);
        f[1].visibility = Some(0.05);
    }
    let d = DetectorModel::exact("exact").apply(&gt, 1);
    assert_eq!(d.len(), 20);
    assert!(d
        .iter()
        .all(|r| r.bbox != gt.frames[r.frame as usize - 1][0].bbox));
}

#[test]
fn random_misses_have_the_configured_rate_and_come_in_runs() {
    let gt = walkers(2000, 5);
    for burst in [1.0, 6.0] {
        let m = DetectorModel {
            misses: MissModel {
                random: 0.2,
                burst,
                ..MissModel::default()
            },
            ..DetectorModel::exact("m")
        };
        let d = m.apply(&gt, 3);
        let rate = 1.0 - d.len() as f64 / 10_000.0;
        assert!((rate - 0.2).abs() < 0.03, "burst {burst}: rate {rate}");
        // Mean run length of misses of object 1 (its box is at x = 20 + 2·(frame − 1)).
        let seen: Vec<bool> = by_frame(&d, 2000)
            .iter()
            .enumerate()
            .map(|(k, fr)| fr.iter().any(|r| r.bbox.x == 20.0 + 2.0 * k as f64))
            .collect();
        let runs: Vec<usize> = seen
            .split(|&s| s)
            .map(|r| r.len())
            .filter(|&l| l > 0)
            .collect();
        let mean = runs.iter().sum::<usize>() as f64 / runs.len() as f64;
        assert!(
            (mean - burst).abs() < 0.35 * burst + 0.3,
            "burst {burst}: mean run {mean}"
        );
    }
}

#[test]
fn occluded_and_small_objects_are_missed_more() {
    // Object 2 stands in front of object 1 (lower bottom edge), hiding all of it.
    let frames = (0..1000)
        .map(|_| {
            vec![
                GtObject {
                    id: 1,
                    bbox: BBox::new(100.0, 100.0, 40.0, 100.0),
                    mask: None,
                    visibility: None,
                },
                GtObject {
                    id: 2,
                    bbox: BBox::new(90.0, 90.0, 60.0, 120.0),
                    mask: None,
                    visibility: None,
                },
                // Small (a fifth of the median height).
                GtObject {
                    id: 3,
                    bbox: BBox::new(600.0, 100.0, 8.0, 20.0),
                    mask: None,
                    visibility: None,
                },
            ]
        })
        .collect();
    let gt = GtSequence {
        width: 800,
        height: 600,
        frames,
    };
    assert_eq!(
        estimate_visibility(&gt.frames[0].iter().map(|o| o.bbox).collect::<Vec<_>>()),
        vec![0.0, 1.0, 1.0]
    );
    let m = DetectorModel {
        misses: MissModel {
            occlusion: 0.8,
            small: 0.6,
            small_below: 0.5,
            ..MissModel::default()
        },
        ..DetectorModel::exact("m")
    };
    let d = m.apply(&gt, 5);
    let count = |x: f64| d.iter().filter(|r| r.bbox.x == x).count() as f64 / 1000.0;
    assert!((count(100.0) - 0.2).abs() < 0.05, "{}", count(100.0));
    assert_eq!(count(90.0), 1.0);
    // Height 20 vs median 100 → small factor (50 − 20)/50 = 0.6 → miss 0.36.
    assert!((count(600.0) - 0.64).abs() < 0.05, "{}", count(600.0));
}

#[test]
fn score_calibrations_fall_in_their_ranges() {
    let gt = walkers(400, 8);
    let scores = |s: ScoreModel| -> Vec<f64> {
        let m = DetectorModel {
            scores: s,
            ..DetectorModel::exact("s")
        };
        m.apply(&gt, 11).iter().map(|r| r.score).collect()
    };
    let mut hn = scores(ScoreModel::HighNarrow);
    assert!(hn.iter().all(|&s| (0.5..=1.0).contains(&s)));
    let (p10, p50) = (quantile(&mut hn, 0.1), quantile(&mut hn, 0.5));
    assert!(p50 > 0.96 && p10 > 0.5 && p10 < 0.97, "{p10} {p50}");
    let mut wide = scores(ScoreModel::Wide);
    assert!(quantile(&mut wide, 0.05) < 0.45 && quantile(&mut wide, 0.95) > 0.85);
    let mut low = scores(ScoreModel::Low);
    assert!(low.iter().all(|&s| (0.1..=0.55).contains(&s)));
    assert!(quantile(&mut low, 0.5) < 0.4);
    assert!(scores(ScoreModel::Constant(1.0)).iter().all(|&s| s == 1.0));
    // An object's score drifts smoothly: consecutive frames correlate.
    let obj1: Vec<f64> = wide_of_object(&gt);
    let n = obj1.len() - 1;
    let mean = obj1.iter().sum::<f64>() / obj1.len() as f64;
    let var: f64 = obj1.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / obj1.len() as f64;
    let cov: f64 = (0..n)
        .map(|i| (obj1[i] - mean) * (obj1[i + 1] - mean))
        .sum::<f64>()
        / n as f64;
    assert!(cov / var > 0.6, "lag-1 correlation {}", cov / var);
}

fn wide_of_object(gt: &GtSequence) -> Vec<f64> {
    let m = DetectorModel {
        scores: ScoreModel::Wide,
        ..DetectorModel::exact("w")
    };
    m.apply(gt, 2)
        .iter()
        .filter(|r| (r.bbox.x - 2.0 * (r.frame as f64 - 1.0) - 20.0).abs() < 1e-9)
        .map(|r| r.score)
        .collect()
}

#[test]
fn jitter_is_proportional_to_size() {
    let gt = walkers(500, 4);
    let m = DetectorModel {
        jitter: 0.1,
        ..DetectorModel::exact("j")
    };
    let d = m.apply(&gt, 9);
    let f = by_frame(&d, 500);
    let mut dx = Vec::new();
    for (k, fr) in f.iter().enumerate() {
        for (i, r) in fr.iter().enumerate() {
            dx.push((r.bbox.x - gt.frames[k][i].bbox.x) / 40.0);
        }
    }
    let sd = (dx.iter().map(|v| v * v).sum::<f64>() / dx.len() as f64).sqrt();
    assert!((sd - 0.1).abs() < 0.015, "{sd}");
}

#[test]
fn false_positives_near_far_and_persistent() {
    let mut gt = walkers(1000, 2);
    // Keep the two objects far apart, so "near" means near one of them only.
    for f in &mut gt.frames {
        f[1].bbox.x += 400.0;
    }
    let count_fp = |fp: FalsePositives| {
        let m = DetectorModel {
            false_positives: fp,
            ..DetectorModel::exact("f")
        };
        let d = m.apply(&gt, 4);
        (d.len() as f64 - 2000.0) / 1000.0
    };
    let far = count_fp(FalsePositives {
        far: 1.5,
        ..FalsePositives::default()
    });
    assert!((far - 1.5).abs() < 0.15, "{far}");
    // Persistence p: each FP lives 1/(1−p) frames on average.
    let persistent = count_fp(FalsePositives {
        far: 0.5,
        persist: 0.5,
        ..FalsePositives::default()
    });
    assert!((persistent - 1.0).abs() < 0.15, "{persistent}");
    // Near ones sit beside an object: IoU with it below 0.3, but close.
    let m = DetectorModel {
        false_positives: FalsePositives {
            near: 1.0,
            ..FalsePositives::default()
        },
        ..DetectorModel::exact("n")
    };
    let d = m.apply(&gt, 4);
    let f = by_frame(&d, 1000);
    let mut near = 0;
    for (k, fr) in f.iter().enumerate() {
        for r in fr.iter().skip(2) {
            let best = gt.frames[k]
                .iter()
                .map(|o| o.bbox.iou(&r.bbox))
                .fold(0.0, f64::max);
            assert!(best < 0.35, "{best}");
            let close = gt.frames[k]
                .iter()
                .any(|o| o.bbox.center().dist(r.bbox.center()) < 1.5 * o.bbox.w);
            near += usize::from(close);
        }
    }
    assert!(near > 800, "{near}");
}

#[test]
fn duplicates_and_split_boxes() {
    let gt = walkers(500, 4);
    let m = DetectorModel {
        duplicate: 1.0,
        ..DetectorModel::exact("d")
    };
    let f = m.apply(&gt, 6);
    assert_eq!(f.len(), 4000);
    let fr = by_frame(&f, 500);
    for (k, dets) in fr.iter().enumerate() {
        for i in 0..4 {
            let iou = dets[2 * i].bbox.iou(&dets[2 * i + 1].bbox);
            assert!((0.4..0.95).contains(&iou), "{iou}");
            assert!(dets[2 * i + 1].score < dets[2 * i].score);
            assert!(gt.frames[k][i].bbox.iou(&dets[2 * i].bbox) == 1.0);
        }
    }
    let s = DetectorModel {
        split: 1.0,
        ..DetectorModel::exact("s")
    };
    let d = s.apply(&gt, 6);
    assert_eq!(d.len(), 4000);
    for pair in d.chunks(2) {
        let (a, b) = (pair[0].bbox, pair[1].bbox);
        // Two parts of a tall box: top and bottom, each 60 % of it, inside it.
        assert!(a.y < b.y && (a.h - 60.0).abs() < 1e-9 && a.w == 40.0);
        assert!((b.y2() - a.y - 100.0).abs() < 1e-9);
    }
}

#[test]
fn mask_noise_and_dropped_frames() {
    let sq = |x: i32| Mask::from_bbox(&BBox::new(x as f64, 40.0, 30.0, 30.0));
    let frames: Vec<Vec<GtObject>> = (0..300)
        .map(|_| {
            vec![
                GtObject {
                    id: 1,
                    bbox: BBox::new(100.0, 40.0, 30.0, 30.0),
                    mask: Some(sq(100)),
                    visibility: Some(1.0),
                },
                // Touching object 1 on its right.
                GtObject {
                    id: 2,
                    bbox: BBox::new(130.0, 40.0, 30.0, 30.0),
                    mask: Some(sq(130)),
                    visibility: Some(1.0),
                },
            ]
        })
        .collect();
    let gt = GtSequence {
        width: 320,
        height: 240,
        frames,
    };
    let with = |n: MaskNoise, drop: f64| {
        DetectorModel {
            masks: Some(n),
            drop_frame: drop,
            ..DetectorModel::exact("m")
        }
        .apply(&gt, 12)
    };
    // Erosion by 1..=2 px shrinks area below 900, dilation grows it above.
    let e = with(
        MaskNoise {
            morph: 1.0,
            morph_max: 2,
            ..MaskNoise::default()
        },
        0.0,
    );
    let areas: Vec<u64> = e.iter().map(|r| r.mask_bitmap().unwrap().area()).collect();
    assert!(areas.iter().any(|&a| a < 900) && areas.iter().any(|&a| a > 900));
    assert!(areas.iter().all(|&a| a != 900));
    // Ragged outlines: area changes, the core stays.
    let r = with(
        MaskNoise {
            ragged: 1.0,
            ..MaskNoise::default()
        },
        0.0,
    );
    for rec in &r {
        let m = rec.mask_bitmap().unwrap();
        // Not the square any more, but still mostly it.
        assert_ne!(m.tight(), Mask::from_bbox(&rec.bbox).tight());
        assert!(m.area() > 700 && m.area() < 1100, "{}", m.area());
    }
    // Split masks: two detections per object.
    let s = with(
        MaskNoise {
            split: 1.0,
            ..MaskNoise::default()
        },
        0.0,
    );
    assert_eq!(s.len(), 1200);
    // Merged masks: the touching pair reported as one 1800-px mask.
    let m = with(
        MaskNoise {
            merge: 1.0,
            ..MaskNoise::default()
        },
        0.0,
    );
    assert_eq!(m.len(), 300);
    assert!(m.iter().all(|r| r.mask_bitmap().unwrap().area() == 1800));
    // Dropped frames: whole frames empty.
    let d = with(MaskNoise::default(), 0.2);
    let empty = by_frame(&d, 300).iter().filter(|f| f.is_empty()).count();
    assert!((empty as f64 / 300.0 - 0.2).abs() < 0.06, "{empty}");
    assert_eq!(d.len(), 2 * (300 - empty));
}

#[test]
fn no_panic_on_degenerate_input() {
    let gt = GtSequence {
        width: 0,
        height: 0,
        frames: vec![
            vec![],
            vec![GtObject {
                id: 1,
                bbox: BBox::new(-10.0, -10.0, 0.0, 5.0),
                mask: Some(Mask::empty()),
                visibility: Some(2.0),
            }],
        ],
    };
    for p in profiles() {
        let _ = p.apply(&gt, 1);
    }
    assert!(profile("mot15like").is_some() && profile("nope").is_none());
    assert_eq!(profiles().len(), 8);
}
