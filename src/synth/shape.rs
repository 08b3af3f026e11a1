//! Shape outlines, colour palettes and procedural textures, all built once in object space.
//!
//! Rendering a frame then needs no trigonometry per pixel: an object's polygon is rotated and
//! scaled (a handful of vertices), filled by scanlines, and each filled pixel maps back to a
//! texel by an incremental affine step.

use super::math::{hsv, luma, sin_cos, uniform, value_noise};
use rand::Rng;
use serde::{Deserialize, Serialize};

/// The outline family of a synthetic shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ShapeKind {
    /// A circle (a 64-gon) of the given radius.
    Disc,
    /// An ellipse (64-gon), semi-axes `r` and `r·aspect`.
    Ellipse,
    /// A rectangle of half-sizes `r` and `r·aspect`.
    Rectangle,
    /// A triangle inscribed in radius `r`, corners jittered by up to ±15°.
    Triangle,
    /// A 5–7 pointed star, outer radius `r`.
    Star,
    /// An L: the square of half-side `r` with one quadrant-like corner cut out (non-convex).
    LShape,
    /// A random star-shaped (hence simple) polygon of 7–11 vertices within radius `r`.
    Irregular,
}

impl ShapeKind {
    /// Every kind, in the order random scenes draw from.
    pub const ALL: [ShapeKind; 7] = [
        ShapeKind::Disc,
        ShapeKind::Ellipse,
        ShapeKind::Rectangle,
        ShapeKind::Triangle,
        ShapeKind::Star,
        ShapeKind::LShape,
        ShapeKind::Irregular,
    ];
}

/// An object-space outline (centred on the origin) for `kind` with size `r` and `aspect`
/// (used by ellipses and rectangles; random for the others when drawn from `rng`).
pub(crate) fn outline<R: Rng>(kind: ShapeKind, r: f64, aspect: f64, rng: &mut R) -> Vec<[f64; 2]> {
    let ring = |n: u32, rx: f64, ry: f64| -> Vec<[f64; 2]> {
        (0..n)
            .map(|i| {
                let (s, c) = sin_cos(std::f64::consts::TAU * i as f64 / n as f64);
                [rx * c, ry * s]
            })
            .collect()
    };
    match kind {
        ShapeKind::Disc => ring(64, r, r),
        ShapeKind::Ellipse => ring(64, r, r * aspect),
        ShapeKind::Rectangle => {
            let h = r * aspect;
            vec![[-r, -h], [r, -h], [r, h], [-r, h]]
        }
        ShapeKind::Triangle => (0..3)
            .map(|i| {
                let a = -std::f64::consts::FRAC_PI_2
                    + std::f64::consts::TAU * i as f64 / 3.0
                    + uniform(rng, -0.26, 0.26);
                let (s, c) = sin_cos(a);
                [r * c, r * s]
            })
            .collect(),
        ShapeKind::Star => {
            let points = rng.gen_range(5u32..8);
            let inner = r * uniform(rng, 0.45, 0.6);
            (0..2 * points)
                .map(|i| {
                    let a = std::f64::consts::PI * i as f64 / points as f64;
                    let (s, c) = sin_cos(a - std::f64::consts::FRAC_PI_2);
                    let rr = if i % 2 == 0 { r } else { inner };
                    [rr * c, rr * s]
                })
                .collect()
        }
        ShapeKind::LShape => {
            let t = r * uniform(rng, -0.2, 0.2);
            vec![[-r, -r], [t, -r], [t, t], [r, t], [r, r], [-r, r]]
        }
        ShapeKind::Irregular => {
            let n = rng.gen_range(7u32..12);
            (0..n)
                .map(|i| {
                    let a = std::f64::consts::TAU * (i as f64 + uniform(rng, -0.3, 0.3)) / n as f64;
                    let rr = r * uniform(rng, 0.55, 1.0);
                    let (s, c) = sin_cos(a);
                    [rr * c, rr * s]
                })
                .collect()
        }
    }
}

/// Largest distance of a vertex from the origin.
pub(crate) fn bound(poly: &[[f64; 2]]) -> f64 {
    poly.iter()
        .map(|p| (p[0] * p[0] + p[1] * p[1]).sqrt())
        .fold(0.0, f64::max)
}

/// 2–4 saturated colours, each at least `contrast` grey levels away from the background luma
/// `bg` (so a grey-level background subtractor can see every part of the shape) and far enough
/// apart from one another for the texture to be visible.
pub(crate) fn palette<R: Rng>(rng: &mut R, bg: f64, contrast: f64) -> Vec<[u8; 3]> {
    let k = rng.gen_range(2u32..5) as usize;
    let mut out: Vec<[u8; 3]> = Vec::with_capacity(k);
    for _ in 0..400 {
        if out.len() == k {
            break;
        }
        let c = hsv(
            uniform(rng, 0.0, 6.0),
            uniform(rng, 0.55, 1.0),
            uniform(rng, 0.15, 1.0),
        );
        if (luma(c) - bg).abs() < contrast {
            continue;
        }
        let far = out.iter().all(|o| {
            let d: i32 = (0..3).map(|i| (o[i] as i32 - c[i] as i32).abs()).sum();
            d >= 120
        });
        if far {
            out.push(c);
        }
    }
    // Only reachable with an extreme background: fall back on black and white, which are as
    // far from any mid-grey as colours get.
    for c in [[12, 12, 12], [245, 245, 245]] {
        if out.len() < 2 && !out.contains(&c) {
            out.push(c);
        }
    }
    out
}

/// 2–3 colours within `spread` of hue `base` (on the 0–6 hue circle), alternately dark and
/// bright, contrasting with the background like [`palette`]'s: look-alike objects for crowd
/// scenes. Falls back on
/// [`palette`]'s rules (any hue) when the band holds no contrasting colour.
pub(crate) fn palette_near<R: Rng>(
    rng: &mut R,
    bg: f64,
    contrast: f64,
    base: f64,
    spread: f64,
) -> Vec<[u8; 3]> {
    let k = rng.gen_range(2u32..4) as usize;
    let mut out: Vec<[u8; 3]> = Vec::with_capacity(k);
    for _ in 0..400 {
        if out.len() == k {
            break;
        }
        let hue = (base + uniform(rng, -spread, spread)).rem_euclid(6.0);
        // Alternate a dark and a bright shade, so every object has the same light structure.
        let v = if out.len() % 2 == 0 {
            uniform(rng, 0.15, 0.4)
        } else {
            uniform(rng, 0.8, 1.0)
        };
        let c = hsv(hue, uniform(rng, 0.6, 1.0), v);
        if (luma(c) - bg).abs() < contrast {
            continue;
        }
        // Look-alikes: colours only need to differ enough for the texture to show.
        let far = out.iter().all(|o| {
            let d: i32 = (0..3).map(|i| (o[i] as i32 - c[i] as i32).abs()).sum();
            d >= 60
        });
        if far {
            out.push(c);
        }
    }
    if out.len() < 2 {
        return palette(rng, bg, contrast);
    }
    out
}

/// `poly` with every edge longer than `step` split into equal parts no longer than it (exact
/// linear interpolation), so a deformation of the outline has vertices to move.
pub(crate) fn subdivide(poly: &[[f64; 2]], step: f64) -> Vec<[f64; 2]> {
    if step.is_nan() || step <= 0.0 {
        return poly.to_vec();
    }
    let mut out = Vec::with_capacity(poly.len() * 4);
    for (i, a) in poly.iter().enumerate() {
        let b = poly[(i + 1) % poly.len()];
        let len = ((b[0] - a[0]) * (b[0] - a[0]) + (b[1] - a[1]) * (b[1] - a[1])).sqrt();
        let n = ((len / step).ceil() as usize).clamp(1, 64);
        for j in 0..n {
            let t = j as f64 / n as f64;
            out.push([a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t]);
        }
    }
    out
}

/// A texture in object space: texel `(i, j)` covers object coordinates
/// `[i - half, i - half + 1) × [j - half, j - half + 1)`.
#[derive(Debug, Clone)]
pub(crate) struct Texture {
    side: i32,
    half: f64,
    rgb: Vec<u8>,
}

impl Texture {
    /// Byte offset of the texel under object point `(u, v)` (clamped to the texture).
    #[inline]
    pub(crate) fn offset(&self, u: f64, v: f64) -> usize {
        let i = ((u + self.half) as i32).clamp(0, self.side - 1);
        let j = ((v + self.half) as i32).clamp(0, self.side - 1);
        3 * (j as usize * self.side as usize + i as usize)
    }

    /// The RGB bytes.
    #[inline]
    pub(crate) fn bytes(&self) -> &[u8] {
        &self.rgb
    }
}

/// A texture of radius `bound` painted with `pal`: stripes, checks, rings, blobs or
/// quantised noise, chosen and parameterised by `rng`.
pub(crate) fn texture<R: Rng>(rng: &mut R, bound: f64, pal: &[[u8; 3]]) -> Texture {
    let half = bound.ceil() + 2.0;
    let side = 2 * half as i32;
    let k = pal.len().max(1) as i64;
    let style = rng.gen_range(0u32..5);
    let period = uniform(rng, 0.18, 0.4) * bound.max(4.0);
    let (sa, ca) = sin_cos(uniform(rng, 0.0, std::f64::consts::PI));
    let salt: u32 = rng.gen();
    let blobs: Vec<(f64, f64, f64, usize)> = (0..rng.gen_range(3u32..7))
        .map(|j| {
            (
                uniform(rng, -0.7, 0.7) * bound,
                uniform(rng, -0.7, 0.7) * bound,
                uniform(rng, 0.15, 0.4) * bound,
                1 + j as usize % (k as usize - 1).max(1),
            )
        })
        .collect();
    let mut rgb = Vec::with_capacity(3 * (side * side) as usize);
    for j in 0..side {
        for i in 0..side {
            let u = i as f64 - half + 0.5;
            let v = j as f64 - half + 0.5;
            let idx = match style {
                0 => ((u * ca + v * sa) / period).floor() as i64,
                1 => (u / period).floor() as i64 + (v / period).floor() as i64,
                2 => ((u * u + v * v).sqrt() / period).floor() as i64,
                3 => blobs
                    .iter()
                    .rev()
                    .find(|b| (u - b.0) * (u - b.0) + (v - b.1) * (v - b.1) < b.2 * b.2)
                    .map_or(0, |b| b.3 as i64),
                _ => (value_noise(u / period, v / period, salt) * k as f64).floor() as i64,
            };
            let c = pal
                .get(idx.rem_euclid(k) as usize)
                .copied()
                .unwrap_or([0; 3]);
            rgb.extend_from_slice(&c);
        }
    }
    Texture { side, half, rgb }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::math::stream;

    #[test]
    fn outlines_fit_their_radius() {
        let mut rng = stream(3, 9);
        for kind in ShapeKind::ALL {
            let p = outline(kind, 20.0, 0.6, &mut rng);
            assert!(p.len() >= 3);
            assert!(
                bound(&p) <= 20.0 * std::f64::consts::SQRT_2 + 1e-9,
                "{kind:?}"
            );
        }
    }

    #[test]
    fn palettes_contrast_with_background() {
        let mut rng = stream(4, 9);
        for _ in 0..100 {
            let p = palette(&mut rng, 120.0, 45.0);
            assert!((2..=4).contains(&p.len()));
            assert!(p.iter().all(|&c| (luma(c) - 120.0).abs() >= 45.0));
        }
    }

    #[test]
    fn texture_uses_only_palette_colours() {
        let mut rng = stream(5, 9);
        let pal = palette(&mut rng, 120.0, 45.0);
        for _ in 0..10 {
            let t = texture(&mut rng, 25.0, &pal);
            assert!(t
                .bytes()
                .chunks_exact(3)
                .all(|c| pal.contains(&[c[0], c[1], c[2]])));
            let o = t.offset(1e9, -1e9);
            assert!(o + 3 <= t.bytes().len());
        }
    }
}
