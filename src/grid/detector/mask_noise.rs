//! The outline noise of mask detections ([`MaskNoise`](super::MaskNoise)): eroded, dilated
//! and ragged outlines, and touching objects' masks merged into one detection. The box-level
//! behaviours stay in the parent module.

use rand::Rng;

use super::{Det, DetectorModel, GtObject};
use crate::frame::Mask;
use crate::synth::noise::morph;

impl DetectorModel {
    /// An object's mask with this model's outline noise.
    pub(super) fn noisy_mask<R: Rng>(&self, m: &Mask, rng: &mut R, w: u32, h: u32) -> Mask {
        let u: [f64; 4] = [rng.gen(), rng.gen(), rng.gen(), rng.gen()];
        let Some(n) = self.masks else {
            return m.clone();
        };
        let mut out = m.clone();
        if u[0] < n.morph && n.morph_max > 0 {
            let k = 1 + (u[1] * n.morph_max as f64) as i32;
            let k = k.min(n.morph_max as i32);
            let moved = morph(&out, if u[2] < 0.5 { k } else { -k }).clipped(w, h);
            if moved.area() >= 16 {
                out = moved;
            }
        }
        if u[3] < n.ragged {
            out = ragged(&out, rng).clipped(w, h);
        }
        out
    }
}

/// Reports pairs of touching objects' whole masks as one detection, with probability `p` per
/// touching pair (each detection merged at most once).
pub(super) fn merge_touching<R: Rng>(
    objects: &[GtObject],
    dets: &mut Vec<Det>,
    rng: &mut R,
    p: f64,
) {
    let mut merged = vec![false; dets.len()];
    let mut add = Vec::new();
    for a in 0..dets.len() {
        for c in a + 1..dets.len() {
            let u: f64 = rng.gen();
            let (da, dc) = (&dets[a], &dets[c]);
            let (Some(oa), Some(oc)) = (da.owner, dc.owner) else {
                continue;
            };
            if merged[a] || merged[c] || !da.whole || !dc.whole || oa == oc || u >= p {
                continue;
            }
            let (ba, bc) = (&objects[oa].bbox, &objects[oc].bbox);
            if !ba.expanded(2.0).overlaps(bc) {
                continue;
            }
            let (Some(ma), Some(mc)) = (&da.mask, &dc.mask) else {
                continue;
            };
            let m = union(ma, mc);
            merged[a] = true;
            merged[c] = true;
            add.push(Det::of(
                m.bbox(),
                da.score.max(dc.score),
                Some(m),
                None,
                false,
            ));
        }
    }
    let mut i = 0;
    dets.retain(|_| {
        let keep = !merged[i];
        i += 1;
        keep
    });
    dets.extend(add);
}

/// The union of two masks in their joint rectangle.
fn union(a: &Mask, b: &Mask) -> Mask {
    let x0 = a.x().min(b.x());
    let y0 = a.y().min(b.y());
    let x1 = (a.x() as i64 + a.width() as i64).max(b.x() as i64 + b.width() as i64);
    let y1 = (a.y() as i64 + a.height() as i64).max(b.y() as i64 + b.height() as i64);
    let (w, h) = ((x1 - x0 as i64) as u32, (y1 - y0 as i64) as u32);
    let mut bits = vec![0u8; w as usize * h as usize];
    for (x, y) in a.pixels().chain(b.pixels()) {
        let i = (y - y0) as usize * w as usize + (x - x0) as usize;
        if let Some(v) = bits.get_mut(i) {
            *v = 1;
        }
    }
    Mask::new(x0, y0, w, h, bits).unwrap_or_else(|_| a.clone())
}

/// A ragged outline: the pixels within 2 px of the mask's edge are redrawn at random (inside
/// ones kept with probability 0.6, outside ones added with probability 0.25).
fn ragged<R: Rng>(m: &Mask, rng: &mut R) -> Mask {
    let outer = morph(m, 2);
    let inner = morph(m, -2);
    let (x0, y0, w, h) = (outer.x(), outer.y(), outer.width(), outer.height());
    let mut bits = vec![0u8; w as usize * h as usize];
    for (x, y) in outer.pixels() {
        let i = (y - y0) as usize * w as usize + (x - x0) as usize;
        let u: f64 = rng.gen();
        let v = if inner.get(x, y) {
            true
        } else if m.get(x, y) {
            u < 0.6
        } else {
            u < 0.25
        };
        bits[i] = u8::from(v);
    }
    Mask::new(x0, y0, w, h, bits).map_or_else(|_| m.clone(), |r| r.tight())
}
