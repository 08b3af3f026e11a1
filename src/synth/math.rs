//! Arithmetic that gives the same bits on every target.
//!
//! The scene must render byte-identical frames natively and in wasm32. IEEE 754 guarantees
//! correctly rounded `+ - * /` and `sqrt`, and Rust never fuses multiply-adds on its own, but
//! `sin`, `cos`, `exp` and friends come from the platform's libm and may differ in the last bit.
//! So the few transcendental values the scene needs are computed here from basic operations only,
//! and random integers are drawn with fixed-width types (never `usize`, whose sampling differs
//! between 32- and 64-bit targets).

use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// `sin(x)` and `cos(x)` from a polynomial on `[-π/4, π/4]` after a Cody–Waite reduction: about
/// 1e-16 absolute error for the angles the scene uses (|x| < 1e6), bit-identical everywhere.
pub(crate) fn sin_cos(x: f64) -> (f64, f64) {
    if !x.is_finite() {
        return (0.0, 1.0);
    }
    const PIO2_HI: f64 = std::f64::consts::FRAC_PI_2;
    const PIO2_LO: f64 = 6.123_233_995_736_766e-17;
    let q = (x * std::f64::consts::FRAC_2_PI + 0.5).floor();
    let r = (x - q * PIO2_HI) - q * PIO2_LO;
    let r2 = r * r;
    let s = r
        * (1.0
            + r2 * (-1.0 / 6.0
                + r2 * (1.0 / 120.0
                    + r2 * (-1.0 / 5040.0
                        + r2 * (1.0 / 362_880.0
                            + r2 * (-1.0 / 39_916_800.0
                                + r2 * (1.0 / 6_227_020_800.0
                                    + r2 * (-1.0 / 1_307_674_368_000.0))))))));
    let c = 1.0
        + r2 * (-0.5
            + r2 * (1.0 / 24.0
                + r2 * (-1.0 / 720.0
                    + r2 * (1.0 / 40_320.0
                        + r2 * (-1.0 / 3_628_800.0
                            + r2 * (1.0 / 479_001_600.0
                                + r2 * (-1.0 / 87_178_291_200.0
                                    + r2 * (1.0 / 20_922_789_888_000.0))))))));
    match (q as i64).rem_euclid(4) {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// An independent random stream for one purpose (motion, detection noise, ...), so that changing
/// one knob (say the miss rate) never changes what another stream produces (the images).
pub(crate) fn stream(seed: u64, purpose: u64) -> Xoshiro256PlusPlus {
    Xoshiro256PlusPlus::seed_from_u64(seed ^ purpose.wrapping_mul(0x9E37_79B9_7F4A_7C15))
}

/// Uniform in `[lo, hi)` (or `lo` when the range is empty).
#[inline]
pub(crate) fn uniform<R: Rng>(rng: &mut R, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.gen::<f64>()
}

/// A uniform integer in `lo..hi` (`lo` when empty), drawn as `u32` on every target.
#[inline]
pub(crate) fn below<R: Rng>(rng: &mut R, lo: u32, hi: u32) -> u32 {
    if hi <= lo {
        lo
    } else {
        rng.gen_range(lo..hi)
    }
}

/// An approximately standard normal value (Irwin–Hall sum of four uniforms, rescaled), which
/// needs no `ln`/`cos` and is bounded by ±3.46.
pub(crate) fn normal<R: Rng>(rng: &mut R) -> f64 {
    let s: f64 = (0..4).map(|_| rng.gen::<f64>()).sum();
    (s - 2.0) * 1.732_050_807_568_877_2
}

/// A 32-bit integer hash (lowbias32), for lattice noise.
#[inline]
pub(crate) fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// Smooth value noise in `[0, 1)` at `(x, y)` with lattice spacing 1: bilinear interpolation of
/// hashed lattice values with a smoothstep, basic arithmetic only.
pub(crate) fn value_noise(x: f64, y: f64, salt: u32) -> f64 {
    let (fx, fy) = (x.floor(), y.floor());
    let (ix, iy) = (fx as i32 as u32, fy as i32 as u32);
    let (tx, ty) = (x - fx, y - fy);
    let (sx, sy) = (tx * tx * (3.0 - 2.0 * tx), ty * ty * (3.0 - 2.0 * ty));
    let h = |a: u32, b: u32| {
        let v = hash32(a.wrapping_mul(0x9E37_79B1) ^ hash32(b ^ salt));
        (v >> 8) as f64 / (1u32 << 24) as f64
    };
    let (v00, v10) = (h(ix, iy), h(ix.wrapping_add(1), iy));
    let (v01, v11) = (
        h(ix, iy.wrapping_add(1)),
        h(ix.wrapping_add(1), iy.wrapping_add(1)),
    );
    let a = v00 + (v10 - v00) * sx;
    let b = v01 + (v11 - v01) * sx;
    a + (b - a) * sy
}

/// Luma (BT.601) of an RGB colour, in `[0, 255]`.
#[inline]
pub(crate) fn luma(c: [u8; 3]) -> f64 {
    0.299 * c[0] as f64 + 0.587 * c[1] as f64 + 0.114 * c[2] as f64
}

/// An RGB colour from hue (`[0, 6)` sextants), saturation and value in `[0, 1]`, without trig.
pub(crate) fn hsv(h: f64, s: f64, v: f64) -> [u8; 3] {
    let h = h.rem_euclid(6.0);
    let i = h.floor();
    let f = h - i;
    let (p, q, t) = (v * (1.0 - s), v * (1.0 - s * f), v * (1.0 - s * (1.0 - f)));
    let (r, g, b) = match i as i32 {
        0 => (v, t, p),
        1 => (q, v, p),
        2 => (p, v, t),
        3 => (p, q, v),
        4 => (t, p, v),
        _ => (v, p, q),
    };
    let q8 = |x: f64| (x * 255.0 + 0.5).clamp(0.0, 255.0) as u8;
    [q8(r), q8(g), q8(b)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sin_cos_matches_libm() {
        let mut x = -50.0;
        while x < 50.0 {
            let (s, c) = sin_cos(x);
            assert!((s - x.sin()).abs() < 1e-14, "sin {x}");
            assert!((c - x.cos()).abs() < 1e-14, "cos {x}");
            x += 0.0137;
        }
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
    }

    #[test]
    fn streams_are_independent_and_repeatable() {
        let (mut s1, mut s2) = (stream(7, 1), stream(7, 1));
        let a: Vec<u64> = (0..4).map(|_| s1.gen()).collect();
        let b: Vec<u64> = (0..4).map(|_| s2.gen()).collect();
        assert_eq!(a, b);
        assert_ne!(a[0], a[1]);
        assert_ne!(stream(7, 1).gen::<u64>(), stream(7, 2).gen::<u64>());
    }

    #[test]
    fn noise_and_normal_stay_in_range() {
        let mut rng = stream(1, 1);
        for i in 0..1000 {
            let v = value_noise(i as f64 * 0.37, i as f64 * 0.11, 5);
            assert!((0.0..1.0).contains(&v));
            assert!(normal(&mut rng).abs() < 3.5);
        }
        assert_eq!(hsv(0.0, 1.0, 1.0), [255, 0, 0]);
        assert_eq!(hsv(2.0, 1.0, 1.0), [0, 255, 0]);
    }
}
