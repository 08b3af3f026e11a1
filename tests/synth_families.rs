//! The synthetic scenario families (`SynthConfig::family`): each family's defining stress is
//! measured on its generated ground truth, and every family is deterministic.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::frame::BBox;
use shapetrack::synth::{Family, GtObject, Scene, SceneStats, SynthConfig};
use std::collections::BTreeMap;

/// Ground truth per frame, and a hash of the images.
fn run(cfg: SynthConfig) -> (Vec<Vec<GtObject>>, u64) {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    let mut gt = Vec::new();
    for f in Scene::new(cfg).unwrap() {
        f.image.hash(&mut h);
        gt.push(f.gt);
    }
    (gt, h.finish())
}

/// Per object: (frame index, object) in order.
fn tracks(gt: &[Vec<GtObject>]) -> BTreeMap<u64, Vec<(usize, &GtObject)>> {
    let mut t: BTreeMap<u64, Vec<(usize, &GtObject)>> = BTreeMap::new();
    for (k, f) in gt.iter().enumerate() {
        for g in f {
            t.entry(g.id).or_default().push((k, g));
        }
    }
    t
}

fn centre(g: &GtObject) -> (f64, f64) {
    let c = g.bbox.center();
    (c.x, c.y)
}

#[test]
fn families_are_deterministic_and_named() {
    for f in Family::ALL {
        let cfg = SynthConfig {
            frames: 30,
            ..SynthConfig::family(f, 5)
        };
        assert_eq!(run(cfg.clone()).1, run(cfg).1, "{f:?}");
        assert_eq!(f.name().parse::<Family>().unwrap(), f);
    }
    assert!("nope".parse::<Family>().is_err());
}

#[test]
fn deform_changes_area_by_up_to_half_and_the_outline_every_frame() {
    let (gt, _) = run(SynthConfig::family(Family::Deform, 3));
    let t = tracks(&gt);
    assert_eq!(t.len(), 8, "rigid ids: no object is replaced");
    let mut ratios = Vec::new();
    let mut outline_changes = 0;
    let mut pairs = 0;
    for obs in t.values() {
        let areas: Vec<f64> = obs
            .iter()
            .filter(|(_, g)| g.visibility > 0.99)
            .map(|(_, g)| g.mask.area() as f64)
            .collect();
        let (lo, hi) = areas
            .iter()
            .fold((f64::MAX, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
        ratios.push(hi / lo);
        // Outline change: mask IoU of consecutive frames after aligning the boxes' corners.
        for w in obs.windows(2) {
            let ((k0, a), (k1, b)) = (w[0], w[1]);
            if k1 != k0 + 1 || a.visibility < 0.99 || b.visibility < 0.99 {
                continue;
            }
            let (dx, dy) = (a.mask.x() - b.mask.x(), a.mask.y() - b.mask.y());
            let iou = b.mask.iou_shifted(dx, dy, &a.mask);
            pairs += 1;
            if iou < 0.97 {
                outline_changes += 1;
            }
        }
    }
    ratios.sort_by(f64::total_cmp);
    // Area amplitude drawn in [0.25, 0.5]: the largest view is 1.7–3× the smallest.
    assert!(ratios[0] >= 1.5, "{ratios:?}");
    assert!(ratios[ratios.len() / 2] >= 2.0, "{ratios:?}");
    assert!(
        outline_changes * 2 > pairs,
        "{outline_changes} of {pairs} consecutive views changed"
    );
}

#[test]
fn camera_pans_and_zooms() {
    let cfg = SynthConfig::family(Family::Camera, 4);
    let frames: Vec<_> = Scene::new(cfg).unwrap().take(120).collect();
    // The background moves: pixels outside every object differ between frames 1 and 60.
    let (a, b) = (&frames[0], &frames[59]);
    let free = |f: &shapetrack::synth::SynthFrame, x: u32, y: u32| {
        !f.gt.iter().any(|g| {
            g.bbox
                .expanded(2.0)
                .overlaps(&shapetrack::BBox::new(x as f64, y as f64, 1.0, 1.0))
        })
    };
    let mut differ = 0;
    let mut n = 0;
    for y in (0..480).step_by(16) {
        for x in (0..640).step_by(16) {
            if free(a, x, y) && free(b, x, y) {
                let i = 3 * (y as usize * 640 + x as usize);
                n += 1;
                if a.image[i..i + 3] != b.image[i..i + 3] {
                    differ += 1;
                }
            }
        }
    }
    assert!(differ * 2 > n, "{differ} of {n} background samples changed");
    // The zoom changes object sizes: an object seen whole at the zoom's extremes changes its
    // full area by the zoom ratio squared (objects do not scale on their own here).
    let gt: Vec<Vec<GtObject>> = frames.iter().map(|f| f.gt.clone()).collect();
    let t = tracks(&gt);
    let spread = t
        .values()
        .map(|obs| {
            let a: Vec<f64> = obs.iter().map(|(_, g)| g.full_area as f64).collect();
            a.iter().cloned().fold(0.0, f64::max) / a.iter().cloned().fold(f64::MAX, f64::min)
        })
        .fold(0.0, f64::max);
    assert!(spread > 1.5, "{spread}");
    // Objects leave and re-enter the view (gaps in an id's ground truth).
    let gaps = t
        .values()
        .filter(|obs| obs.windows(2).any(|w| w[1].0 > w[0].0 + 1))
        .count();
    assert!(gaps >= 1);
}

#[test]
fn crowd_is_dense_look_alike_and_touching() {
    let cfg = SynthConfig::family(Family::Crowd, 2);
    let (gt, _) = run(cfg);
    assert!(
        gt.iter().all(|f| f.len() >= 25),
        "30 objects, a few hidden at times"
    );
    // Touching or overlapping boxes in most frames.
    let touching = gt
        .iter()
        .filter(|f| {
            f.iter().enumerate().any(|(i, a)| {
                f[i + 1..]
                    .iter()
                    .any(|b| a.bbox.expanded(1.0).overlaps(&b.bbox))
            })
        })
        .count();
    assert!(touching * 10 > gt.len() * 8, "{touching}");
    // Look-alike colours: the mean hue-band palette distance is far below a default scene's.
    let spread = |gt: &[Vec<GtObject>]| {
        let pals: Vec<[f64; 3]> = gt[0]
            .iter()
            .map(|g| {
                let n = g.palette.len() as f64;
                let mut m = [0.0; 3];
                for c in &g.palette {
                    for i in 0..3 {
                        m[i] += c[i] as f64 / n;
                    }
                }
                m
            })
            .collect();
        let mut d = 0.0;
        let mut k = 0;
        for i in 0..pals.len() {
            for j in i + 1..pals.len() {
                d += (0..3).map(|c| (pals[i][c] - pals[j][c]).abs()).sum::<f64>();
                k += 1;
            }
        }
        d / k as f64
    };
    let default = SynthConfig {
        shapes: 30,
        frames: 1,
        ..SynthConfig::with_seed(2)
    };
    let (dgt, _) = run(default);
    let (crowd, other) = (spread(&gt), spread(&dgt));
    assert!(crowd < 0.6 * other, "crowd {crowd} vs default {other}");
}

#[test]
fn crossing_streams_meet_head_on_and_at_right_angles() {
    let (gt, _) = run(SynthConfig::family(Family::Crossing, 6));
    let t = tracks(&gt);
    // Velocity of each object per frame, from its box centre.
    let mut vel: BTreeMap<(u64, usize), (f64, f64)> = BTreeMap::new();
    for (id, obs) in &t {
        for w in obs.windows(2) {
            let ((k0, a), (k1, b)) = (w[0], w[1]);
            if k1 == k0 + 1 && a.visibility > 0.9 && b.visibility > 0.9 {
                let (p, q) = (centre(a), centre(b));
                vel.insert((*id, k1), (q.0 - p.0, q.1 - p.1));
            }
        }
    }
    let mut crossings = 0;
    for (k, f) in gt.iter().enumerate() {
        let hit = f.iter().enumerate().any(|(i, a)| {
            f[i + 1..].iter().any(|b| {
                if !a.bbox.overlaps(&b.bbox) {
                    return false;
                }
                match (vel.get(&(a.id, k)), vel.get(&(b.id, k))) {
                    (Some(u), Some(v)) => {
                        let cos =
                            (u.0 * v.0 + u.1 * v.1) / ((u.0.hypot(u.1) * v.0.hypot(v.1)).max(1e-9));
                        cos < 0.5
                    }
                    _ => false,
                }
            })
        });
        crossings += usize::from(hit);
    }
    assert!(crossings >= 20, "{crossings} frames with crossing objects");
    assert!(
        t.len() > 10,
        "streams leave and new objects enter: {}",
        t.len()
    );
}

#[test]
fn occluders_hide_objects_for_long_stretches() {
    let (gt, _) = run(SynthConfig::family(Family::Occluders, 1));
    let t = tracks(&gt);
    let hides: Vec<usize> = t
        .values()
        .flat_map(|obs| {
            obs.windows(2)
                .map(|w| w[1].0 - w[0].0 - 1)
                .filter(|&g| g > 0)
                .collect::<Vec<_>>()
        })
        .collect();
    assert!(hides.iter().filter(|&&g| g >= 20).count() >= 3, "{hides:?}");
    assert!(
        hides.iter().filter(|&&g| (5..20).contains(&g)).count() >= 5,
        "{hides:?}"
    );
    // Partial views too: visibility between 0.1 and 0.9 in many frames.
    let partial = gt
        .iter()
        .flatten()
        .filter(|g| (0.1..0.9).contains(&g.visibility))
        .count();
    assert!(partial > 100, "{partial}");
}

#[test]
fn enter_leave_births_and_deaths_at_every_border() {
    let (gt, _) = run(SynthConfig::family(Family::EnterLeave, 8));
    let t = tracks(&gt);
    assert!(t.len() >= 30, "{} ids", t.len());
    // Where objects first and last appear: every border sees both.
    let side = |g: &GtObject| {
        let b = g.bbox;
        if b.x <= 1.0 {
            Some(0)
        } else if b.x2() >= 639.0 {
            Some(1)
        } else if b.y <= 1.0 {
            Some(2)
        } else if b.y2() >= 479.0 {
            Some(3)
        } else {
            None
        }
    };
    let (mut births, mut deaths) = ([0; 4], [0; 4]);
    for obs in t.values() {
        let (first, last) = (obs[0], obs[obs.len() - 1]);
        if first.0 > 0 {
            if let Some(s) = side(first.1) {
                births[s] += 1;
            }
        }
        if last.0 + 1 < gt.len() {
            if let Some(s) = side(last.1) {
                deaths[s] += 1;
            }
        }
    }
    assert!(births.iter().all(|&b| b >= 2), "{births:?}");
    assert!(deaths.iter().all(|&d| d >= 2), "{deaths:?}");
}

#[test]
fn new_settings_are_validated() {
    let mut c = SynthConfig::family(Family::Deform, 1);
    c.motion.deform.as_mut().unwrap().area_amplitude = 2.0;
    assert!(Scene::new(c).is_err());
    let mut c = SynthConfig::family(Family::Camera, 1);
    c.camera.as_mut().unwrap().zoom_range = (0.1, 1.0);
    assert!(Scene::new(c).is_err(), "a view wider than the world");
    let mut c = SynthConfig::family(Family::Crossing, 1);
    c.motion.headings = Some(vec![]);
    assert!(Scene::new(c).is_err());
    let mut c = SynthConfig::family(Family::Crowd, 1);
    c.motion.kinds = Some(vec![]);
    assert!(Scene::new(c).is_err());
    let mut c = SynthConfig::family(Family::Crowd, 1);
    c.appearance.similar_colours = Some(f64::NAN);
    assert!(Scene::new(c).is_err());
    let mut c = SynthConfig::family(Family::Pedestrians, 1);
    c.crowd.as_mut().unwrap().walkway = (0.9, 0.3);
    assert!(Scene::new(c).is_err(), "an empty walkway");
    let mut c = SynthConfig::family(Family::Pedestrians, 1);
    c.crowd.as_mut().unwrap().height.1 = f64::INFINITY;
    assert!(Scene::new(c).is_err());
    let mut c = SynthConfig::family(Family::Pedestrians, 1);
    c.noise.occlusion_miss = -0.1;
    assert!(Scene::new(c).is_err());
}

/// Whether box `b` lies within box `a`.
fn contains(a: &BBox, b: &BBox) -> bool {
    b.x >= a.x && b.y >= a.y && b.x2() <= a.x2() && b.y2() <= a.y2()
}

/// The dense crowd's scene, shortened to keep the test in seconds (people are placed on the
/// walkway from the first frame, so the density holds from the start).
fn pedestrians(seed: u64, frames: u32) -> SynthConfig {
    SynthConfig {
        frames,
        ..SynthConfig::family(Family::Pedestrians, seed)
    }
}

#[test]
fn pedestrians_are_a_dense_half_hidden_crowd() {
    // Issue 64's crowd: ~46 people a frame, median visibility 0.44, 1080p at 25 fps.
    let cfg = pedestrians(2, 60);
    assert_eq!((cfg.width, cfg.height, cfg.fps), (1920, 1080, 25.0));
    let s = SceneStats::measure(&cfg).unwrap();
    eprintln!("{s:?}");
    assert!(
        (38.0..=56.0).contains(&s.objects_mean),
        "people per frame {}",
        s.objects_mean
    );
    let median_vis = s.visibility_quantiles[2];
    assert!(
        (0.3..=0.6).contains(&median_vis),
        "median visibility {median_vis}"
    );
    assert!(
        (0.003..=0.1).contains(&s.hidden_fraction),
        "fully hidden {}",
        s.hidden_fraction
    );
    // Misses follow visibility: the barely visible are missed far more than the visible.
    let [low, mid, high] = s.missed_by_visibility;
    assert!(low > mid && mid > high, "{:?}", s.missed_by_visibility);
    assert!(low > 0.4 && high < 0.1, "{:?}", s.missed_by_visibility);
    assert!(s.gaps > 50 && s.gap_p90 >= 3.0, "{s:?}");
    // Same seed, same figures; another seed, another scene.
    assert_eq!(SceneStats::measure(&cfg).unwrap(), s);
    assert_ne!(SceneStats::measure(&pedestrians(3, 60)).unwrap(), s);
}

#[test]
fn pedestrians_walk_both_ways_with_amodal_truth_and_shrunk_detections() {
    let cfg = pedestrians(4, 40);
    let morph = cfg.noise.morph_max as f64;
    let (w, h) = (cfg.width as f64, cfg.height as f64);
    let mut first_x: BTreeMap<u64, f64> = BTreeMap::new();
    let mut last_x: BTreeMap<u64, f64> = BTreeMap::new();
    let (mut partial, mut shrunk, mut nearest_checked) = (0, 0, 0);
    for f in Scene::new(cfg).unwrap() {
        let amodal = f.amodal_gt_records();
        assert_eq!(amodal.len(), f.silhouettes.len());
        for (r, s) in amodal.iter().zip(&f.silhouettes) {
            assert_eq!(
                (r.id as u64, r.bbox, r.visibility),
                (s.id, s.bbox, s.visibility)
            );
            // A hidden person keeps its box but has no mask; a visible one has its visible
            // pixels, inside the whole body's box.
            assert_eq!(r.mask.is_some(), s.visibility > 0.0);
            first_x.entry(s.id).or_insert(s.bbox.center().x);
            last_x.insert(s.id, s.bbox.center().x);
        }
        for g in &f.gt {
            let s = f.silhouettes.iter().find(|s| s.id == g.id).unwrap();
            assert!(contains(&s.bbox, &g.bbox), "visible part outside the body");
        }
        // Detections report the visible part: inside the amodal box (up to the detector's
        // dilation), and smaller than it for partly hidden people.
        for (d, src) in f.detections.iter().zip(&f.detection_sources) {
            let Some(id) = src else { continue };
            let s = f.silhouettes.iter().find(|s| s.id == *id).unwrap();
            assert!(contains(&s.bbox.expanded(morph), &d.bbox), "{d:?} {s:?}");
            if s.visibility < 0.6 {
                partial += 1;
                if d.bbox.area() < 0.8 * s.bbox.area() {
                    shrunk += 1;
                }
            }
        }
        // Depth by the box's bottom: the person whose feet are lowest is in front of all
        // (unless cut by the frame border, which lowers visibility too, or tied).
        let mut by_bottom: Vec<_> = f.silhouettes.iter().collect();
        by_bottom.sort_by(|a, b| b.bbox.y2().total_cmp(&a.bbox.y2()));
        if let [a, b, ..] = by_bottom[..] {
            let inside = a.bbox.x > 0.0 && a.bbox.x2() < w && a.bbox.y2() < h;
            if inside && a.bbox.y2() > b.bbox.y2() + 2.0 {
                nearest_checked += 1;
                assert!(a.visibility > 0.999, "nearest person hidden: {a:?}");
            }
        }
    }
    assert!(
        partial > 100 && shrunk * 10 > partial * 6,
        "{shrunk} of {partial}"
    );
    assert!(nearest_checked > 5, "{nearest_checked}");
    // Both directions, at walking pace (0.47–1.0 heights a second): nobody stands still.
    let (mut right, mut left) = (0, 0);
    for (id, x0) in &first_x {
        let dx = last_x[id] - x0;
        if dx > 5.0 {
            right += 1;
        } else if dx < -5.0 {
            left += 1;
        }
    }
    assert!(right >= 15 && left >= 15, "right {right}, left {left}");
}
