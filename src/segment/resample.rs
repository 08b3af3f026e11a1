//! Resampling between frame pixels and the network's fixed square grid.
//!
//! Downscaling uses a triangle filter whose support widens with the scale factor (what
//! Pillow's `BILINEAR` resize does), so a 600-pixel crop shrunk to 320 averages its pixels
//! instead of skipping some, as the model's training images were prepared. Every sum runs in
//! a fixed order in `f32`, so the wasm build computes the same tensor as the native one.

/// Per output index: the first source index and the normalised weights of its taps, stored
/// flat (one allocation per axis, not per output pixel).
pub(crate) struct Taps {
    starts: Vec<usize>,
    counts: Vec<usize>,
    offsets: Vec<usize>,
    weights: Vec<f32>,
}

impl Taps {
    /// Taps mapping `src_len` source samples onto `dst_len` output samples (both ≥ 1).
    pub(crate) fn new(src_len: usize, dst_len: usize) -> Taps {
        let (src, dst) = (src_len.max(1), dst_len.max(1));
        let scale = src as f64 / dst as f64;
        let filter_scale = scale.max(1.0);
        // The triangle filter's support is 1 source pixel when enlarging, `scale` pixels when
        // shrinking.
        let support = filter_scale;
        let mut t = Taps {
            starts: Vec::with_capacity(dst),
            counts: Vec::with_capacity(dst),
            offsets: Vec::with_capacity(dst),
            weights: Vec::new(),
        };
        for i in 0..dst {
            let centre = (i as f64 + 0.5) * scale;
            let lo = ((centre - support + 0.5).floor().max(0.0)) as usize;
            let hi = ((centre + support + 0.5).floor() as usize)
                .min(src)
                .max(lo + 1);
            let offset = t.weights.len();
            let mut sum = 0.0f64;
            for j in lo..hi {
                let x = (j as f64 + 0.5 - centre) / filter_scale;
                let w = (1.0 - x.abs()).max(0.0);
                t.weights.push(w as f32);
                sum += w;
            }
            if sum > 0.0 {
                for w in &mut t.weights[offset..] {
                    *w = (*w as f64 / sum) as f32;
                }
            } else {
                // A tap set with no weight (cannot happen for src ≥ 1, kept for safety): take
                // the nearest sample.
                for w in &mut t.weights[offset..] {
                    *w = 0.0;
                }
                if let Some(w) = t.weights.get_mut(offset) {
                    *w = 1.0;
                }
            }
            t.starts.push(lo);
            t.counts.push(hi - lo);
            t.offsets.push(offset);
        }
        t
    }

    /// The source start and weights of output index `i`.
    #[inline]
    pub(crate) fn get(&self, i: usize) -> (usize, &[f32]) {
        let (s, n, o) = (self.starts[i], self.counts[i], self.offsets[i]);
        (s, &self.weights[o..o + n])
    }
}

/// Bilinear sample of a `side × side` map at continuous position `(u, v)` in its pixel
/// coordinates (pixel centres at integers), clamped at the borders.
#[inline]
pub(crate) fn bilinear(map: &[f32], side: usize, u: f64, v: f64) -> f32 {
    let max = (side - 1) as f64;
    let u = u.clamp(0.0, max);
    let v = v.clamp(0.0, max);
    let (x0, y0) = (u.floor() as usize, v.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(side - 1), (y0 + 1).min(side - 1));
    let (fx, fy) = ((u - x0 as f64) as f32, (v - y0 as f64) as f32);
    let a = map[y0 * side + x0];
    let b = map[y0 * side + x1];
    let c = map[y1 * side + x0];
    let d = map[y1 * side + x1];
    let top = a + (b - a) * fx;
    let bottom = c + (d - c) * fx;
    top + (bottom - top) * fy
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn taps_sum_to_one_and_stay_in_range() {
        for (src, dst) in [
            (1, 320),
            (7, 320),
            (320, 320),
            (640, 320),
            (1917, 320),
            (3, 1),
        ] {
            let t = Taps::new(src, dst);
            for i in 0..dst {
                let (s, w) = t.get(i);
                assert!(s + w.len() <= src, "{src}->{dst} at {i}");
                let sum: f32 = w.iter().sum();
                assert!((sum - 1.0).abs() < 1e-5, "{src}->{dst} at {i}: {sum}");
            }
        }
    }

    #[test]
    fn same_size_is_the_identity_and_halving_averages_pairs() {
        let t = Taps::new(5, 5);
        for i in 0..5 {
            let (s, w) = t.get(i);
            let at: f32 = w.iter().enumerate().map(|(k, &w)| w * (s + k) as f32).sum();
            assert!((at - i as f32).abs() < 1e-6);
        }
        // Shrinking by two: each output is centred between two inputs, which weigh alike.
        let t = Taps::new(8, 4);
        let src = [0.0f32, 2.0, 4.0, 6.0, 8.0, 10.0, 12.0, 14.0];
        let out: Vec<f32> = (0..4)
            .map(|i| {
                let (s, w) = t.get(i);
                w.iter().enumerate().map(|(k, &w)| w * src[s + k]).sum()
            })
            .collect();
        // Linear data stays linear: an interior output is the source value at its centre,
        // source position 2i + 1 (value 4i + 1); the borders lose the taps outside.
        for (i, v) in out.iter().enumerate().take(3).skip(1) {
            assert!((v - (4 * i + 1) as f32).abs() < 1e-4, "{i}: {v}");
        }
    }

    #[test]
    fn bilinear_interpolates_and_clamps() {
        let map = [0.0f32, 1.0, 2.0, 3.0];
        assert_eq!(bilinear(&map, 2, 0.5, 0.0), 0.5);
        assert_eq!(bilinear(&map, 2, 0.5, 0.5), 1.5);
        assert_eq!(bilinear(&map, 2, -3.0, 9.0), 2.0);
    }
}
