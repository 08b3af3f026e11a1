//! Synthetic side of the offline tuning (not compiled by cargo: copy it to `examples/` to run).
//!
//! Reads OfflineConfig JSON lines on stdin; for each synthetic seed runs the online tracker and
//! one OfflineTracker per config over the same mask detections and frames, and prints per-seed
//! and total HOTA / IDF1 / IDSW (box IoU against the visible-part boxes, as the quality gate),
//! then `CFG i HOTA IDF1 IDSW worst-ΔHOTA worst-IDSW-ratio` lines for the joint search.
//!
//! ```text
//! cp tests/data/quality/tune_synth.rs examples/ && cargo build --release --example tune_synth
//! echo '{}' | SEEDS=11,12,13 ./target/release/examples/tune_synth
//! ```
//!
//! Env: SEEDS (default 1,2,3), W (frame width, 800), HF (bar hidden_frames, 20), RW (width of
//! the extra pillar at x = W − 100, 60; 0 = none): the defaults are the quality gate's scene.
//! JD=1 prints every join as right/wrong/unknown against the ground truth; SD=1 prints SIFT
//! connection counts of all (slave, master) pairs within 75 frames, right vs wrong.
use shapetrack::eval::{evaluate, EvalConfig, Preprocessing, SequenceInput, Similarity};
use shapetrack::synth::{OccluderRect, Scene, SynthConfig};
use shapetrack::track::offline::{OfflineConfig, OfflineTracker};
use shapetrack::track::{to_records, Config, Tracker};
use std::collections::HashMap;

fn scene(seed: u64) -> SynthConfig {
    let mut c = SynthConfig::occlusion_scene(seed);
    c.width = std::env::var("W")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(800);
    c.occlusion.hidden_frames = std::env::var("HF")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(20.0);
    let rw: u32 = std::env::var("RW")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(60);
    if rw > 0 {
        c.occlusion.rects = vec![OccluderRect {
            x: c.width - 100,
            y: 0,
            w: rw,
            h: c.height,
        }];
    }
    c
}

fn main() {
    let cfgs: Vec<OfflineConfig> = std::io::stdin()
        .lines()
        .map(|l| l.unwrap())
        .filter(|l| !l.trim().is_empty())
        .map(|l| OfflineConfig::from_json(&l).unwrap())
        .collect();
    let seeds: Vec<u64> = std::env::var("SEEDS")
        .unwrap_or("1,2,3".into())
        .split(',')
        .map(|s| s.parse().unwrap())
        .collect();
    let ev = EvalConfig {
        preprocessing: Preprocessing::None,
        similarity: Similarity::BoxIou,
        threshold: 0.5,
    };
    let mut tot: Vec<(f64, f64, i64)> = vec![(0.0, 0.0, 0); cfgs.len() + 1];
    let mut worst: Vec<f64> = vec![f64::INFINITY; cfgs.len()];
    let mut worst_ratio: Vec<f64> = vec![0.0; cfgs.len()];
    for &seed in &seeds {
        let sc = scene(seed);
        let (w, h, n, fps) = (sc.width, sc.height, sc.frames, sc.fps);
        let mut s = Scene::new(sc).unwrap();
        let mut online = Tracker::new(Config::default()).unwrap();
        let mut offs: Vec<OfflineTracker> = cfgs
            .iter()
            .map(|c| OfflineTracker::new(c.clone(), fps).unwrap())
            .collect();
        let mut gt = Vec::new();
        let mut on_shapes = Vec::new();
        let mut present: HashMap<u64, Vec<u32>> = HashMap::new();
        let mut src: HashMap<(u32, usize), Option<u64>> = HashMap::new();
        while let Some(f) = s.frame() {
            for g in &f.gt {
                present.entry(g.id).or_default().push(f.index);
            }
            for (k, s2) in f.detection_sources.iter().enumerate() {
                src.insert((f.index, k), *s2);
            }
            let mut g = f.gt_records();
            for r in &mut g {
                r.mask = None;
            }
            gt.extend(g);
            let fr = f.frame().unwrap();
            on_shapes.extend(online.update(Some(&fr), &f.detections).unwrap());
            for o in &mut offs {
                o.push_frame(Some(&fr), &f.detections).unwrap();
            }
        }
        let mut hides: Vec<u32> = Vec::new();
        for fs in present.values() {
            for w2 in fs.windows(2) {
                if w2[1] - w2[0] > 1 {
                    hides.push(w2[1] - w2[0] - 1);
                }
            }
        }
        hides.sort();
        let long: Vec<u32> = hides.iter().copied().filter(|&x| x >= 2).collect();
        eprintln!(
            "seed {seed}: hides>=2: n={} min={:?} max={:?} median={:?} >=5:{} >=20:{}",
            long.len(),
            long.first(),
            long.last(),
            long.get(long.len() / 2),
            long.iter().filter(|&&x| x >= 5).count(),
            long.iter().filter(|&&x| x >= 20).count()
        );
        let score = |shapes: &[shapetrack::TrackedShape]| {
            let mut sh = shapes.to_vec();
            for x in &mut sh {
                x.mask = None;
            }
            let res = to_records(&sh, 1, Some((w, h)));
            let r = evaluate(&[SequenceInput::new("s", n, gt.clone(), res)], &ev).unwrap();
            let c = r.summary().combined;
            (c.hota, c.idf1, c.idsw as i64)
        };
        let on = score(&on_shapes);
        println!(
            "seed {seed} online HOTA {:.3} IDF1 {:.3} IDSW {}",
            on.0, on.1, on.2
        );
        tot[0].0 += on.0;
        tot[0].1 += on.1;
        tot[0].2 += on.2;
        for (i, o) in offs.into_iter().enumerate() {
            let online_shapes = o.online_shapes().to_vec();
            if std::env::var("SD").is_ok() {
                use shapetrack::features::sift::match_descriptors;
                let snaps = o.snapshots();
                let cfgapp = o.config().appearance.clone();
                let mut ends: HashMap<u64, (u32, u32, Option<u64>, Option<u64>)> = HashMap::new();
                for s in &online_shapes {
                    let g = s
                        .det_index
                        .and_then(|d| src.get(&(s.frame, d)).copied().flatten());
                    let e = ends.entry(s.id).or_insert((s.frame, s.frame, g, g));
                    if s.frame < e.0 {
                        e.0 = s.frame;
                        e.2 = g;
                    }
                    if s.frame > e.1 {
                        e.1 = s.frame;
                        e.3 = g;
                    }
                }
                let mut hist: HashMap<(bool, usize), u32> = HashMap::new();
                for (&m, me) in &ends {
                    for (&sl, se) in &ends {
                        if se.1 >= me.0 || me.0 - se.1 > 75 {
                            continue;
                        }
                        let (Some(a), Some(b)) = (snaps.last(sl), snaps.first(m)) else {
                            continue;
                        };
                        let fa = a.features(&cfgapp).unwrap();
                        let fb = b.features(&cfgapp).unwrap();
                        let c = match_descriptors(&fa, &fb, &cfgapp.matching).len().min(10);
                        let right = se.3.is_some() && se.3 == me.2;
                        *hist.entry((right, c)).or_default() += 1;
                    }
                }
                let mut v: Vec<_> = hist.into_iter().collect();
                v.sort();
                println!("SIFT seed {seed}: {:?}", v);
            }
            let r = o.finish(|_| {}).unwrap();
            if std::env::var("JD").is_ok() {
                let gid = |id: u64, last: bool| -> Option<u64> {
                    let mut v: Vec<&shapetrack::TrackedShape> =
                        online_shapes.iter().filter(|s| s.id == id).collect();
                    v.sort_by_key(|s| s.frame);
                    let s = if last { v.last()? } else { v.first()? };
                    src.get(&(s.frame, s.det_index?)).copied().flatten()
                };
                for j in &r.joins {
                    let (a, b) = (gid(j.slave, true), gid(j.master, false));
                    let k = match (a, b) {
                        (Some(x), Some(y)) if x == y => "right",
                        (Some(_), Some(_)) => "wrong",
                        _ => "unknown",
                    };
                    println!(
                        "JOIN seed {seed} cfg{i} {k} gap {} cost {:.2} conn {:?}",
                        j.master_first - j.slave_last,
                        j.cost,
                        j.connections
                    );
                }
            }
            let sc2 = score(&r.shapes);
            println!(
                "seed {seed} cfg{i} HOTA {:.3} IDF1 {:.3} IDSW {} joins {} filled {}",
                sc2.0,
                sc2.1,
                sc2.2,
                r.joins.len(),
                r.filled
            );
            worst[i] = worst[i].min(sc2.0 - on.0);
            worst_ratio[i] = f64::max(worst_ratio[i], sc2.2 as f64 / on.2.max(1) as f64);
            tot[i + 1].0 += sc2.0;
            tot[i + 1].1 += sc2.1;
            tot[i + 1].2 += sc2.2;
        }
    }
    let k = seeds.len() as f64;
    for (i, t) in tot.iter().enumerate() {
        if i > 0 {
            println!(
                "CFG {} {:.3} {:.3} {} {:.3} {:.3}",
                i - 1,
                t.0 / k,
                t.1 / k,
                t.2,
                worst[i - 1],
                worst_ratio[i - 1]
            );
        }
        println!(
            "TOTAL {} HOTA {:.3} IDF1 {:.3} IDSW {}",
            if i == 0 {
                "online".to_string()
            } else {
                format!("cfg{}", i - 1)
            },
            t.0 / k,
            t.1 / k,
            t.2
        );
    }
}
