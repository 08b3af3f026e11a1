//! The detection noise model: what a decent but imperfect instance-segmentation detector would
//! report for a frame whose ground truth is known.
//!
//! Per visible object, independently: missed with probability `miss_rate` (plus, when set,
//! `occlusion_miss` scaled by how far its visibility is below 0.7); otherwise its mask is
//! eroded or dilated by 1..=`morph_max` pixels with probability `morph_prob`, cut in two across
//! its principal axis with probability `split_prob`, and scored in (0, 1] (lower when the object
//! is partly hidden). Then false positives: random blobs, `Binomial(16, false_positives/16)` of
//! them per frame. Every random value comes from a per-frame stream and the same number of
//! values is drawn per object whatever the outcome, so frames and objects do not perturb one
//! another and changing one rate leaves the other draws unchanged.

use super::math::{normal, stream, uniform};
use super::raster::Rasterizer;
use super::shape::{outline, ShapeKind};
use super::{GtObject, NoiseConfig};
use crate::frame::{BBox, Detection, Mask};
use rand::Rng;

/// Purposes of the per-frame streams (see [`super::math::stream`]).
const NOISE_STREAM: u64 = 0x6e6f_6973;
const FP_STREAM: u64 = 0x6670_6670;
const BOX_STREAM: u64 = 0x626f_7865;

/// Detections of one frame: masks, which ground-truth object each came from, and the box-only
/// variant (same order).
pub(crate) struct NoisyDetections {
    pub(crate) masks: Vec<Detection>,
    pub(crate) sources: Vec<Option<u64>>,
    pub(crate) boxes: Vec<Detection>,
}

fn frame_seed(seed: u64, index: u32) -> u64 {
    seed ^ (index as u64).wrapping_mul(0xD6E8_FEB8_6659_FD93)
}

/// Draws the detections of frame `index` from its ground truth.
pub(crate) fn detect(
    cfg: &NoiseConfig,
    seed: u64,
    index: u32,
    gt: &[GtObject],
    w: u32,
    h: u32,
    raster: &mut Rasterizer,
) -> NoisyDetections {
    let fs = frame_seed(seed, index);
    let mut rng = stream(fs, NOISE_STREAM);
    let mut masks = Vec::with_capacity(gt.len() + 2);
    let mut sources = Vec::with_capacity(gt.len() + 2);
    for g in gt {
        let u: [f64; 5] = [rng.gen(), rng.gen(), rng.gen(), rng.gen(), rng.gen()];
        // Partly hidden objects are missed more often: the extra rate rises linearly from 0
        // at 70 % visibility to `occlusion_miss` at none.
        let hidden = ((0.7 - g.visibility) / 0.7).clamp(0.0, 1.0);
        let p_miss = cfg.miss_rate + (1.0 - cfg.miss_rate) * cfg.occlusion_miss * hidden;
        if g.mask.area() < cfg.min_area || u[0] < p_miss {
            continue;
        }
        let mut m = g.mask.clone();
        if u[1] < cfg.morph_prob && cfg.morph_max > 0 {
            // One uniform picks both the direction (even/odd) and the radius 1..=morph_max.
            let idx = (u[2] * 2.0 * cfg.morph_max as f64) as i32;
            let (dilate, k) = (idx % 2 == 0, 1 + idx / 2);
            let moved = morph(&m, if dilate { k } else { -k }).clipped(w, h);
            // An erosion that would wipe a thin object out is not a miss the config asked for.
            if moved.area() >= cfg.min_area {
                m = moved;
            }
        }
        let score = (0.55 + 0.45 * u[4]) * (0.5 + 0.5 * g.visibility.clamp(0.0, 1.0));
        let parts = if u[3] < cfg.split_prob {
            split(&m, cfg.min_area)
        } else {
            None
        };
        match parts {
            Some((a, b)) => {
                for part in [a, b] {
                    masks.push(Detection::from_mask(part, score * 0.8));
                    sources.push(Some(g.id));
                }
            }
            None => {
                masks.push(Detection::from_mask(m, score));
                sources.push(Some(g.id));
            }
        }
    }
    let mut rng = stream(fs, FP_STREAM);
    let trials = 16u32;
    let n = (0..trials)
        .filter(|_| rng.gen::<f64>() < cfg.false_positives / trials as f64)
        .count();
    for _ in 0..n {
        let c = [
            uniform(&mut rng, 0.0, w as f64),
            uniform(&mut rng, 0.0, h as f64),
        ];
        let r = uniform(&mut rng, 5.0, 20.0);
        let score = uniform(&mut rng, 0.05, 0.5);
        let poly: Vec<[f64; 2]> = outline(ShapeKind::Irregular, r, 1.0, &mut rng)
            .into_iter()
            .map(|p| [p[0] + c[0], p[1] + c[1]])
            .collect();
        let m = fill(raster, &poly, w, h);
        if m.area() >= cfg.min_area.max(1) {
            masks.push(Detection::from_mask(m, score));
            sources.push(None);
        }
    }
    let mut rng = stream(fs, BOX_STREAM);
    let boxes = masks
        .iter()
        .map(|d| {
            let b = d.bbox;
            let (sx, sy) = (cfg.box_jitter * b.w, cfg.box_jitter * b.h);
            let n: [f64; 4] = [
                normal(&mut rng),
                normal(&mut rng),
                normal(&mut rng),
                normal(&mut rng),
            ];
            let jb = BBox::new(
                b.x + sx * n[0],
                b.y + sy * n[1],
                (b.w + sx * n[2]).max(1.0),
                (b.h + sy * n[3]).max(1.0),
            );
            Detection::from_box(jb, d.score)
        })
        .collect();
    NoisyDetections {
        masks,
        sources,
        boxes,
    }
}

/// The pixels of `poly`, clipped to a `w × h` image, as a tight mask.
pub(crate) fn fill(raster: &mut Rasterizer, poly: &[[f64; 2]], w: u32, h: u32) -> Mask {
    let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    for p in poly {
        x0 = x0.min(p[0]);
        y0 = y0.min(p[1]);
        x1 = x1.max(p[0]);
        y1 = y1.max(p[1]);
    }
    let bx0 = (x0.floor() as i32).clamp(0, w as i32);
    let by0 = (y0.floor() as i32).clamp(0, h as i32);
    let bx1 = (x1.ceil() as i32 + 1).clamp(0, w as i32);
    let by1 = (y1.ceil() as i32 + 1).clamp(0, h as i32);
    if bx1 <= bx0 || by1 <= by0 {
        return Mask::empty();
    }
    let (bw, bh) = ((bx1 - bx0) as usize, (by1 - by0) as usize);
    let mut data = vec![0u8; bw * bh];
    raster.spans(poly, by0..by1, |y, a, b| {
        let (a, b) = (a.max(bx0), b.min(bx1));
        if b > a {
            let row = (y - by0) as usize * bw;
            data[row + (a - bx0) as usize..row + (b - bx0) as usize].fill(1);
        }
    });
    Mask::new(bx0, by0, bw as u32, bh as u32, data)
        .map(|m| m.tight())
        .unwrap_or_else(|_| Mask::empty())
}

/// Dilates (`k > 0`) or erodes (`k < 0`) a mask by a `(2|k|+1)²` square, separably. The result
/// may extend outside the image; callers clip.
pub(crate) fn morph(m: &Mask, k: i32) -> Mask {
    if k == 0 || m.width() == 0 {
        return m.clone();
    }
    let r = k.unsigned_abs() as usize;
    let dilate = k > 0;
    let pad = if dilate { r } else { 0 };
    let (w, h) = (m.width() as usize + 2 * pad, m.height() as usize + 2 * pad);
    let mut a = vec![0u8; w * h];
    for (ly, row) in m.data().chunks_exact(m.width() as usize).enumerate() {
        a[(ly + pad) * w + pad..(ly + pad) * w + pad + row.len()].copy_from_slice(row);
    }
    // Outside the bitmap is background: a dilation grows into the padding, an erosion eats
    // from the bitmap's edge.
    let get = |v: &[u8], i: isize, n: usize| -> u8 {
        if i < 0 || i as usize >= n {
            0
        } else {
            v[i as usize]
        }
    };
    let mut b = vec![0u8; w * h];
    for y in 0..h {
        let row = &a[y * w..(y + 1) * w];
        for x in 0..w {
            let mut acc = if dilate { 0 } else { 1 };
            for d in -(r as isize)..=r as isize {
                let v = get(row, x as isize + d, w);
                acc = if dilate { acc | v } else { acc & v };
            }
            b[y * w + x] = acc;
        }
    }
    for x in 0..w {
        for y in 0..h {
            let mut acc = if dilate { 0 } else { 1 };
            for d in -(r as isize)..=r as isize {
                let yy = y as isize + d;
                let v = if yy < 0 || yy as usize >= h {
                    0
                } else {
                    b[yy as usize * w + x]
                };
                acc = if dilate { acc | v } else { acc & v };
            }
            a[y * w + x] = acc;
        }
    }
    Mask::new(
        m.x() - pad as i32,
        m.y() - pad as i32,
        w as u32,
        h as u32,
        a,
    )
    .map(|m| m.tight())
    .unwrap_or_else(|_| Mask::empty())
}

/// Cuts a mask across its principal (longest) axis through the centroid, leaving a gap of
/// about two pixels; `None` when either side would be smaller than `min_area` (or 1).
pub(crate) fn split(m: &Mask, min_area: u64) -> Option<(Mask, Mask)> {
    let (mut n, mut sx, mut sy) = (0f64, 0f64, 0f64);
    for (x, y) in m.pixels() {
        n += 1.0;
        sx += x as f64;
        sy += y as f64;
    }
    if n < 2.0 {
        return None;
    }
    let (cx, cy) = (sx / n, sy / n);
    let (mut a, mut b, mut c) = (0f64, 0f64, 0f64);
    for (x, y) in m.pixels() {
        let (dx, dy) = (x as f64 - cx, y as f64 - cy);
        a += dx * dx;
        b += dx * dy;
        c += dy * dy;
    }
    // Largest eigenvector of [[a, b], [b, c]]: the direction the mask is longest in.
    let l = (a + c) / 2.0 + (((a - c) / 2.0) * ((a - c) / 2.0) + b * b).sqrt();
    let (mut ex, mut ey) = if b.abs() > 1e-12 {
        (b, l - a)
    } else if a >= c {
        (1.0, 0.0)
    } else {
        (0.0, 1.0)
    };
    let norm = (ex * ex + ey * ey).sqrt();
    ex /= norm;
    ey /= norm;
    let (w, h) = (m.width() as usize, m.height() as usize);
    let (mut pa, mut pb) = (vec![0u8; w * h], vec![0u8; w * h]);
    for (x, y) in m.pixels() {
        let d = (x as f64 - cx) * ex + (y as f64 - cy) * ey;
        let i = (y - m.y()) as usize * w + (x - m.x()) as usize;
        if d > 1.0 {
            pa[i] = 1;
        } else if d < -1.0 {
            pb[i] = 1;
        }
    }
    let ma = Mask::new(m.x(), m.y(), w as u32, h as u32, pa)
        .ok()?
        .tight();
    let mb = Mask::new(m.x(), m.y(), w as u32, h as u32, pb)
        .ok()?
        .tight();
    let min = min_area.max(1);
    (ma.area() >= min && mb.area() >= min).then_some((ma, mb))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(x: i32, y: i32, s: u32) -> Mask {
        Mask::new(x, y, s, s, vec![1; (s * s) as usize]).unwrap()
    }

    #[test]
    fn morph_grows_and_shrinks_squares() {
        let m = square(10, 10, 10);
        let d = morph(&m, 2);
        assert_eq!(
            (d.x(), d.y(), d.width(), d.height(), d.area()),
            (8, 8, 14, 14, 196)
        );
        let e = morph(&m, -1);
        assert_eq!((e.x(), e.y(), e.width(), e.area()), (11, 11, 8, 64));
        assert!(morph(&square(0, 0, 2), -1).is_empty());
    }

    #[test]
    fn split_cuts_along_the_long_axis() {
        let m = Mask::new(0, 0, 20, 6, vec![1; 120]).unwrap();
        let (a, b) = split(&m, 10).unwrap();
        assert_eq!(a.intersection(&b), 0);
        assert!(a.area() + b.area() < 120 && a.area() + b.area() >= 120 - 18);
        // Cut across x: the halves are side by side.
        assert!(a.bbox().x2() <= b.bbox().x || b.bbox().x2() <= a.bbox().x);
        assert!(split(&square(0, 0, 3), 10).is_none());
    }

    #[test]
    fn fill_clips_to_the_image() {
        let mut r = Rasterizer::default();
        let m = fill(
            &mut r,
            &[[-5.0, -5.0], [5.0, -5.0], [5.0, 5.0], [-5.0, 5.0]],
            100,
            100,
        );
        assert_eq!(m.bbox(), BBox::new(0.0, 0.0, 5.0, 5.0));
        assert!(fill(
            &mut r,
            &[[-9.0, -9.0], [-5.0, -9.0], [-5.0, -5.0]],
            100,
            100
        )
        .is_empty());
    }
}
