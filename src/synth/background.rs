//! The static backdrop: a low-contrast textured floor and the occluding bars drawn over it.
//!
//! Its luma stays within about ±22 of [`BG_LUMA`] so that every object colour, chosen at least
//! `min_contrast` away from that luma, stays visible to a grey-level background subtractor.

use super::math::{hash32, uniform, value_noise};
use super::OccluderRect;
use rand::Rng;

/// The nominal luma of the background, which object palettes keep away from.
pub(crate) const BG_LUMA: f64 = 118.0;

/// Renders the background (RGB8, `w·h·3` bytes): two octaves of value noise, a faint tile grid
/// and a static per-pixel grain, slightly tinted.
pub(crate) fn render<R: Rng>(rng: &mut R, w: u32, h: u32) -> Vec<u8> {
    let (s1, s2): (u32, u32) = (rng.gen(), rng.gen());
    let tint = [
        uniform(rng, -5.0, 5.0),
        uniform(rng, -3.0, 3.0),
        uniform(rng, -5.0, 5.0),
    ];
    let tile = 40 + 8 * (rng.gen_range(0u32..6) as i64);
    let mut out = Vec::with_capacity(w as usize * h as usize * 3);
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let coarse = value_noise(x as f64 / 97.0, y as f64 / 97.0, s1) - 0.5;
            let fine = value_noise(x as f64 / 13.0, y as f64 / 13.0, s2) - 0.5;
            let grout = if x % tile < 2 || y % tile < 2 {
                -6.0
            } else {
                0.0
            };
            let grain =
                (hash32((x as u32).wrapping_mul(73_856_093) ^ (y as u32).wrapping_mul(19_349_663))
                    % 5) as f64
                    - 2.0;
            let l = BG_LUMA + 20.0 * coarse + 10.0 * fine + grout + grain;
            for t in tint {
                out.push((l + t + 0.5).clamp(0.0, 255.0) as u8);
            }
        }
    }
    out
}

/// The occluders of a scene: `bars` full-height vertical bars of width `bar_w`, spread evenly
/// across the frame with a seeded jitter, followed by the explicit `extra` rectangles.
pub(crate) fn occluders<R: Rng>(
    rng: &mut R,
    w: u32,
    h: u32,
    bars: u32,
    bar_w: u32,
    extra: &[OccluderRect],
) -> Vec<OccluderRect> {
    let mut out = Vec::with_capacity(bars as usize + extra.len());
    let bar_w = bar_w.min(w);
    for i in 0..bars {
        let slot = w as f64 / (bars + 1) as f64;
        let cx = slot * (i + 1) as f64 + uniform(rng, -0.2, 0.2) * slot;
        let x = (cx - bar_w as f64 / 2.0)
            .round()
            .clamp(0.0, (w - bar_w) as f64) as u32;
        out.push(OccluderRect {
            x,
            y: 0,
            w: bar_w,
            h,
        });
    }
    out.extend_from_slice(extra);
    out
}

/// Paints the occluders into `img` (shaded brick pillars) and marks their pixels in `occ`.
pub(crate) fn draw_occluders<R: Rng>(
    rng: &mut R,
    img: &mut [u8],
    occ: &mut [u8],
    w: u32,
    h: u32,
    rects: &[OccluderRect],
) {
    for r in rects {
        let base = [
            uniform(rng, 60.0, 150.0),
            uniform(rng, 45.0, 110.0),
            uniform(rng, 35.0, 90.0),
        ];
        let (bw, bh) = (
            rng.gen_range(14u32..26) as i64,
            rng.gen_range(7u32..12) as i64,
        );
        let salt: u32 = rng.gen();
        let x1 = (r.x as u64 + r.w as u64).min(w as u64) as i64;
        let y1 = (r.y as u64 + r.h as u64).min(h as u64) as i64;
        let half = (r.w as f64 / 2.0).max(1.0);
        for y in r.y as i64..y1 {
            let row = (y - r.y as i64) / bh;
            let shift = if row % 2 == 0 { 0 } else { bw / 2 };
            for x in r.x as i64..x1 {
                let lx = x - r.x as i64 + shift;
                let mortar = (y - r.y as i64) % bh == 0 || lx % bw == 0;
                let t = (x as f64 + 0.5 - r.x as f64 - half) / half;
                let shade = 1.15 - 0.45 * t * t;
                let brick = 0.85 + 0.3 * value_noise(lx as f64 / 9.0, row as f64 * 3.1, salt);
                let k = if mortar { 0.55 } else { shade * brick };
                let i = y as usize * w as usize + x as usize;
                occ[i] = 1;
                for c in 0..3 {
                    img[3 * i + c] = (base[c] * k + 0.5).clamp(0.0, 255.0) as u8;
                }
            }
        }
    }
}
