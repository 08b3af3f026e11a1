//! The synthetic scenario families (`SynthConfig::family`): each family's defining stress is
//! measured on its generated ground truth, and every family is deterministic.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::synth::{Family, GtObject, Scene, SynthConfig};
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
}
