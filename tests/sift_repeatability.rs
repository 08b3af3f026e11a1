//! Repeatability of SIFT matches under a known similarity transform.
//!
//! Image A (200×200) is a textured shape on a plain background: a wavy closed outline filled with
//! a base colour, soft colour blobs, striped patches and rectangles, all drawn from a seeded RNG
//! in RGB and converted to grey. Image B is A rotated by 30° and scaled by 1.5 about A's centre,
//! drawn (by bilinear inverse warping) on a canvas large enough to hold all of it, so the
//! transform `T(p) = c_B + 1.5 · R(30°) · (p − c_A)` is known exactly.
//!
//! Measures, all computed from A's side:
//! - **candidates**: keypoints of A whose transformed position `T(p)` lies inside B, at least
//!   8 px from its border (here: all of A's keypoints, since B holds the whole warped image);
//! - **matches**: A→B descriptor matches passing Lowe's ratio test (0.8, no cross check);
//! - **correct matches**: matches whose B keypoint lies within 3 px (B pixels, i.e. 2 px of A)
//!   of `T(p)` of their A keypoint;
//! - **repeatable-match rate** = correct matches / candidates (required ≥ 60 %);
//! - **precision** = correct matches / matches (required ≥ 90 %).
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use image::{GrayImage, Luma, Rgb, RgbImage};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use shapetrack::features::sift::{
    detect_and_compute, match_descriptors, MatchConfig, SiftConfig, SiftFeatures,
};

const ANGLE_DEG: f64 = 30.0;
const SCALE: f64 = 1.5;
const TOL_PX: f64 = 3.0;

/// The textured shape on a plain background (see the module docs), in RGB.
fn textured_shape(w: u32, h: u32, seed: u64) -> RgbImage {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let bg = [40.0f64, 90.0, 60.0];
    let (cx, cy) = (w as f64 / 2.0, h as f64 / 2.0);
    let r0 = 0.36 * w.min(h) as f64;
    let (p3, p5): (f64, f64) = (
        rng.gen_range(0.0..std::f64::consts::TAU),
        rng.gen_range(0.0..std::f64::consts::TAU),
    );
    let inside = |x: f64, y: f64| {
        let t = (y - cy).atan2(x - cx);
        let r = r0 * (1.0 + 0.15 * (3.0 * t + p3).sin() + 0.08 * (5.0 * t + p5).sin());
        (x - cx).hypot(y - cy) < r
    };
    let col = |rng: &mut Xoshiro256PlusPlus| {
        [
            rng.gen_range(0.0..255.0),
            rng.gen_range(0.0..255.0),
            rng.gen_range(0.0..255.0),
        ]
    };
    let base = col(&mut rng);
    let n = (w * h) as usize;
    let mut img: Vec<[f64; 3]> = vec![base; n];
    let blend = |img: &mut Vec<[f64; 3]>, i: usize, c: [f64; 3], a: f64| {
        for k in 0..3 {
            img[i][k] = img[i][k] * (1.0 - a) + c[k] * a;
        }
    };
    // Soft colour blobs.
    for _ in 0..220 {
        let (bx, by) = (rng.gen_range(0.0..w as f64), rng.gen_range(0.0..h as f64));
        let s = rng.gen_range(1.2..4.5);
        let c = col(&mut rng);
        for y in 0..h {
            for x in 0..w {
                let d2 = ((x as f64 + 0.5 - bx).powi(2) + (y as f64 + 0.5 - by).powi(2)) / (s * s);
                if d2 < 12.0 {
                    blend(&mut img, (y * w + x) as usize, c, (-0.5 * d2).exp());
                }
            }
        }
    }
    // Striped discs.
    for _ in 0..6 {
        let (bx, by) = (rng.gen_range(0.0..w as f64), rng.gen_range(0.0..h as f64));
        let rad = rng.gen_range(8.0..18.0);
        let (period, theta) = (
            rng.gen_range(5.0f64..11.0),
            rng.gen_range(0.0f64..std::f64::consts::PI),
        );
        let c = col(&mut rng);
        for y in 0..h {
            for x in 0..w {
                let (dx, dy) = (x as f64 + 0.5 - bx, y as f64 + 0.5 - by);
                if dx.hypot(dy) < rad {
                    let u = dx * theta.cos() + dy * theta.sin();
                    let a = 0.5 + 0.5 * (std::f64::consts::TAU * u / period).sin();
                    blend(&mut img, (y * w + x) as usize, c, a);
                }
            }
        }
    }
    // Hard-edged rectangles.
    for _ in 0..60 {
        let (x0, y0) = (rng.gen_range(0..w), rng.gen_range(0..h));
        let (rw, rh) = (rng.gen_range(3..14), rng.gen_range(3..14));
        let c = col(&mut rng);
        for y in y0..(y0 + rh).min(h) {
            for x in x0..(x0 + rw).min(w) {
                blend(&mut img, (y * w + x) as usize, c, 1.0);
            }
        }
    }
    RgbImage::from_fn(w, h, |x, y| {
        // Anti-alias the outline with 4×4 supersampling.
        let mut cover = 0.0;
        for sy in 0..4 {
            for sx in 0..4 {
                let (px, py) = (
                    x as f64 + (sx as f64 + 0.5) / 4.0,
                    y as f64 + (sy as f64 + 0.5) / 4.0,
                );
                if inside(px, py) {
                    cover += 1.0 / 16.0;
                }
            }
        }
        let v = img[(y * w + x) as usize];
        Rgb(std::array::from_fn(|k| {
            (v[k] * cover + bg[k] * (1.0 - cover))
                .round()
                .clamp(0.0, 255.0) as u8
        }))
    })
}

/// The similarity `p ↦ c_b + s R(θ) (p − c_a)` in continuous pixel coordinates.
#[derive(Clone, Copy)]
struct Similarity {
    ca: (f64, f64),
    cb: (f64, f64),
    cos: f64,
    sin: f64,
    scale: f64,
}

impl Similarity {
    fn apply(&self, x: f64, y: f64) -> (f64, f64) {
        let (dx, dy) = (x - self.ca.0, y - self.ca.1);
        (
            self.cb.0 + self.scale * (self.cos * dx - self.sin * dy),
            self.cb.1 + self.scale * (self.sin * dx + self.cos * dy),
        )
    }

    fn invert(&self, x: f64, y: f64) -> (f64, f64) {
        let (dx, dy) = ((x - self.cb.0) / self.scale, (y - self.cb.1) / self.scale);
        (
            self.ca.0 + self.cos * dx + self.sin * dy,
            self.ca.1 - self.sin * dx + self.cos * dy,
        )
    }
}

/// Inverse bilinear warp of `a` onto a `w × h` canvas; pixel centres sit at `i + 0.5`, and
/// samples outside `a` take its nearest edge value (the plain background).
fn warp(a: &GrayImage, t: &Similarity, w: u32, h: u32) -> GrayImage {
    let (aw, ah) = (a.width() as f64, a.height() as f64);
    let px = |x: f64, y: f64| {
        let xi = x.clamp(0.0, aw - 1.0) as u32;
        let yi = y.clamp(0.0, ah - 1.0) as u32;
        f64::from(a.get_pixel(xi, yi).0[0])
    };
    GrayImage::from_fn(w, h, |x, y| {
        let (sx, sy) = t.invert(x as f64 + 0.5, y as f64 + 0.5);
        let (u, v) = (sx - 0.5, sy - 0.5);
        let (u0, v0) = (u.floor(), v.floor());
        let (fu, fv) = (u - u0, v - v0);
        let val = px(u0, v0) * (1.0 - fu) * (1.0 - fv)
            + px(u0 + 1.0, v0) * fu * (1.0 - fv)
            + px(u0, v0 + 1.0) * (1.0 - fu) * fv
            + px(u0 + 1.0, v0 + 1.0) * fu * fv;
        Luma([val.round().clamp(0.0, 255.0) as u8])
    })
}

/// The measures defined in the module docs.
#[derive(Debug)]
struct Repeatability {
    keypoints_a: usize,
    keypoints_b: usize,
    candidates: usize,
    matches: usize,
    correct: usize,
}

fn measure(a: &SiftFeatures, b: &SiftFeatures, t: &Similarity, bw: u32, bh: u32) -> Repeatability {
    let margin = 8.0;
    let inside = |(x, y): (f64, f64)| {
        x >= margin && y >= margin && x < bw as f64 - margin && y < bh as f64 - margin
    };
    let candidate: Vec<bool> = a
        .keypoints
        .iter()
        .map(|k| inside(t.apply(k.x as f64, k.y as f64)))
        .collect();
    let matches: Vec<_> = match_descriptors(a, b, &MatchConfig::default())
        .into_iter()
        .filter(|m| candidate[m.query])
        .collect();
    let correct = matches
        .iter()
        .filter(|m| {
            let (ka, kb) = (&a.keypoints[m.query], &b.keypoints[m.train]);
            let (x, y) = t.apply(ka.x as f64, ka.y as f64);
            (x - kb.x as f64).hypot(y - kb.y as f64) <= TOL_PX
        })
        .count();
    Repeatability {
        keypoints_a: a.len(),
        keypoints_b: b.len(),
        candidates: candidate.iter().filter(|&&c| c).count(),
        matches: matches.len(),
        correct,
    }
}

/// Builds A and B for `seed` and measures them.
fn run_seed(seed: u64) -> Repeatability {
    let (aw, ah) = (200u32, 200u32);
    let a = image::DynamicImage::ImageRgb8(textured_shape(aw, ah, seed)).to_luma8();
    // A canvas that holds the whole rotated, scaled image.
    let (cos, sin) = (ANGLE_DEG.to_radians().cos(), ANGLE_DEG.to_radians().sin());
    let side = (SCALE * aw as f64 * (cos + sin)).ceil() as u32 + 4;
    let t = Similarity {
        ca: (aw as f64 / 2.0, ah as f64 / 2.0),
        cb: (side as f64 / 2.0, side as f64 / 2.0),
        cos,
        sin,
        scale: SCALE,
    };
    let b = warp(&a, &t, side, side);
    if let Ok(dir) = std::env::var("SIFT_DUMP") {
        a.save(format!("{dir}/a{seed}.png")).unwrap();
        b.save(format!("{dir}/b{seed}.png")).unwrap();
    }
    let cfg = SiftConfig::default();
    let fa = detect_and_compute(&a, None, &cfg).unwrap();
    let fb = detect_and_compute(&b, None, &cfg).unwrap();
    measure(&fa, &fb, &t, side, side)
}

/// Five seeded scenes; each must reach a 60 % repeatable-match rate and 90 % precision.
#[test]
fn matches_survive_30_degree_rotation_and_1_5x_scale() {
    let (mut cand, mut matches, mut correct) = (0, 0, 0);
    for seed in 1..=5 {
        let r = run_seed(seed);
        let rate = r.correct as f64 / r.candidates as f64;
        let precision = r.correct as f64 / r.matches as f64;
        eprintln!(
            "seed {seed}: keypoints A {} B {}; candidates {}, matches {}, correct {}: \
             repeatable-match rate {:.1} %, precision {:.1} %",
            r.keypoints_a,
            r.keypoints_b,
            r.candidates,
            r.matches,
            r.correct,
            100.0 * rate,
            100.0 * precision
        );
        assert!(r.candidates >= 80, "seed {seed}: {r:?}");
        assert!(
            rate >= 0.60,
            "seed {seed}: repeatable-match rate {rate:.3}: {r:?}"
        );
        assert!(
            precision >= 0.90,
            "seed {seed}: precision {precision:.3}: {r:?}"
        );
        cand += r.candidates;
        matches += r.matches;
        correct += r.correct;
    }
    eprintln!(
        "all seeds: candidates {cand}, matches {matches}, correct {correct}: \
         repeatable-match rate {:.1} %, precision {:.1} %",
        100.0 * correct as f64 / cand as f64,
        100.0 * correct as f64 / matches as f64
    );
}
