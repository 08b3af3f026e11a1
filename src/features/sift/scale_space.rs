//! Gaussian scale space: float image planes, separable Gaussian blur, the resamplers SIFT needs
//! and the Gaussian / difference-of-Gaussians pyramids.
//!
//! The numerics follow OpenCV 4.x's float SIFT path (`sift.dispatch.cpp`, `DoG_TYPE_SHORT 0`):
//! kernel sizes, border handling (reflect-101), the bilinear 2× upsampling and the nearest
//! 2× downsampling between octaves are the same, so extrema land where OpenCV's do.

/// A single-channel `f32` image stored row-major without padding.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Plane {
    /// Width in pixels.
    pub w: usize,
    /// Height in pixels.
    pub h: usize,
    /// `w * h` samples, row by row.
    pub data: Vec<f32>,
}

impl Plane {
    /// A zero-filled plane.
    pub fn new(w: usize, h: usize) -> Self {
        Plane {
            w,
            h,
            data: vec![0.0; w * h],
        }
    }

    /// Row `y` (caller guarantees `y < h`).
    #[inline]
    pub fn row(&self, y: usize) -> &[f32] {
        &self.data[y * self.w..(y + 1) * self.w]
    }

    /// Sample at column `x`, row `y` (caller guarantees both are in range).
    #[inline]
    pub fn at(&self, x: usize, y: usize) -> f32 {
        self.data[y * self.w + x]
    }

    /// Reshape in place, reusing the allocation; contents are unspecified afterwards.
    fn resize_to(&mut self, w: usize, h: usize) {
        self.w = w;
        self.h = h;
        self.data.resize(w * h, 0.0);
    }
}

/// OpenCV's `BORDER_REFLECT_101` index mapping (`gfedcb|abcdefgh|gfedcba`), looping so kernels
/// wider than the image still land inside it.
#[inline]
pub(crate) fn reflect101(mut p: isize, len: usize) -> usize {
    let n = len as isize;
    if n <= 1 {
        return 0;
    }
    while p < 0 || p >= n {
        p = if p < 0 { -p } else { 2 * (n - 1) - p };
    }
    p as usize
}

/// One half of a normalised, symmetric Gaussian kernel: `k[0]` is the centre tap and `k[i]`
/// the weight at offsets `±i`.
///
/// The size rule is OpenCV's for float images (`ksize = round(8σ + 1) | 1`, i.e. ±4σ) and the
/// taps are computed in `f64` and normalised before rounding to `f32`, as `getGaussianKernel`.
pub(crate) fn gaussian_half_kernel(sigma: f64) -> Vec<f32> {
    let ksize = ((sigma * 8.0 + 1.0).round_ties_even() as i64 | 1).max(1);
    let radius = (ksize / 2) as usize;
    let scale = -0.5 / (sigma * sigma);
    let full: Vec<f64> = (0..ksize)
        .map(|i| {
            let x = i as f64 - (ksize - 1) as f64 * 0.5;
            (scale * x * x).exp()
        })
        .collect();
    let sum: f64 = full.iter().sum();
    full[radius..].iter().map(|&t| (t / sum) as f32).collect()
}

/// Reusable buffers for [`gaussian_blur`], so a pyramid build allocates them once.
#[derive(Debug, Default)]
pub(crate) struct BlurScratch {
    tmp: Plane,
    padded: Vec<f32>,
}

/// Separable Gaussian blur with reflect-101 borders: `dst = G_sigma * src`.
///
/// Both passes loop over the kernel taps outside and the pixels inside, so the inner loop is a
/// contiguous multiply-add over a row that the compiler vectorises; the symmetric taps are folded
/// (`k_i * (a + b)`) to halve the multiplications.
pub(crate) fn gaussian_blur(src: &Plane, dst: &mut Plane, sigma: f64, scratch: &mut BlurScratch) {
    let k = gaussian_half_kernel(sigma);
    let r = k.len() - 1;
    let (w, h) = (src.w, src.h);
    let k0 = k[0];
    scratch.tmp.resize_to(w, h);
    dst.resize_to(w, h);
    if w == 0 || h == 0 {
        return;
    }

    // Horizontal pass into tmp.
    scratch.padded.clear();
    scratch.padded.resize(w + 2 * r, 0.0);
    for y in 0..h {
        let row = src.row(y);
        let padded = &mut scratch.padded;
        padded[r..r + w].copy_from_slice(row);
        for j in 1..=r {
            padded[r - j] = row[reflect101(-(j as isize), w)];
            padded[r + w - 1 + j] = row[reflect101((w - 1 + j) as isize, w)];
        }
        let out = &mut scratch.tmp.data[y * w..(y + 1) * w];
        for (o, &p) in out.iter_mut().zip(&padded[r..r + w]) {
            *o = k0 * p;
        }
        for (i, &ki) in k.iter().enumerate().skip(1) {
            let a = &padded[r - i..r - i + w];
            let b = &padded[r + i..r + i + w];
            for ((o, &pa), &pb) in out.iter_mut().zip(a).zip(b) {
                *o += ki * (pa + pb);
            }
        }
    }

    // Vertical pass into dst.
    let tmp = &scratch.tmp;
    for y in 0..h {
        let out = &mut dst.data[y * w..(y + 1) * w];
        for (o, &p) in out.iter_mut().zip(tmp.row(y)) {
            *o = k0 * p;
        }
        for (i, &ki) in k.iter().enumerate().skip(1) {
            let a = tmp.row(reflect101(y as isize - i as isize, h));
            let b = tmp.row(reflect101((y + i) as isize, h));
            for ((o, &pa), &pb) in out.iter_mut().zip(a).zip(b) {
                *o += ki * (pa + pb);
            }
        }
    }
}

/// Bilinear 2× upsampling with OpenCV's `INTER_LINEAR` geometry (half-pixel centres: output
/// sample `i` reads input position `i/2 - 1/4`, clamped at the borders).
pub(crate) fn upsample2x(src: &Plane) -> Plane {
    let (w, h) = (src.w, src.h);
    let (w2, h2) = (w * 2, h * 2);
    // (index0, index1, weight1) per output coordinate.
    let taps = |n: usize, len: usize| -> Vec<(usize, usize, f32)> {
        (0..n)
            .map(|i| {
                let f = (i as f32 + 0.5) * 0.5 - 0.5;
                let s = f.floor();
                let mut frac = f - s;
                let mut s = s as isize;
                if s < 0 {
                    s = 0;
                    frac = 0.0;
                }
                if s >= len as isize - 1 {
                    s = len as isize - 1;
                    frac = 0.0;
                }
                let s = s.max(0) as usize;
                (s, (s + 1).min(len - 1), frac)
            })
            .collect()
    };
    let mut out = Plane::new(w2, h2);
    if w == 0 || h == 0 {
        return out;
    }
    let xt = taps(w2, w);
    let yt = taps(h2, h);
    // Horizontally resample every source row once, then blend rows.
    let mut horiz = Plane::new(w2, h);
    for y in 0..h {
        let row = src.row(y);
        let dst = &mut horiz.data[y * w2..(y + 1) * w2];
        for (d, &(x0, x1, f)) in dst.iter_mut().zip(&xt) {
            *d = row[x0] * (1.0 - f) + row[x1] * f;
        }
    }
    for (y, &(y0, y1, f)) in yt.iter().enumerate() {
        let (r0, r1) = (horiz.row(y0), horiz.row(y1));
        let dst = &mut out.data[y * w2..(y + 1) * w2];
        for ((d, &a), &b) in dst.iter_mut().zip(r0).zip(r1) {
            *d = a * (1.0 - f) + b * f;
        }
    }
    out
}

/// Nearest 2× downsampling (`dst(x, y) = src(2x, 2y)`), OpenCV's `INTER_NEAREST` to half size.
pub(crate) fn downsample2x(src: &Plane) -> Plane {
    let (w, h) = (src.w / 2, src.h / 2);
    let mut out = Plane::new(w, h);
    for y in 0..h {
        let row = src.row(2 * y);
        for (x, d) in out.data[y * w..(y + 1) * w].iter_mut().enumerate() {
            *d = row[2 * x];
        }
    }
    out
}

/// Area-weighted resampling to `new_w × new_h` (OpenCV's `INTER_AREA` for shrinking): each
/// output pixel averages the input area it covers, so shrinking does not alias fine texture
/// into spurious extrema.
pub(crate) fn area_resize(src: &Plane, new_w: usize, new_h: usize) -> Plane {
    // For each output index, the list of (input index, weight) that covers it.
    fn weights(n_in: usize, n_out: usize) -> Vec<Vec<(usize, f32)>> {
        let scale = n_in as f64 / n_out as f64;
        (0..n_out)
            .map(|o| {
                let (a, b) = (o as f64 * scale, (o + 1) as f64 * scale);
                let mut v = Vec::new();
                let mut i = a.floor() as usize;
                while (i as f64) < b && i < n_in {
                    let overlap = (b.min(i as f64 + 1.0) - a.max(i as f64)).max(0.0);
                    if overlap > 0.0 {
                        v.push((i, (overlap / scale) as f32));
                    }
                    i += 1;
                }
                v
            })
            .collect()
    }
    let mut out = Plane::new(new_w, new_h);
    if src.w == 0 || src.h == 0 || new_w == 0 || new_h == 0 {
        return out;
    }
    let xw = weights(src.w, new_w);
    let yw = weights(src.h, new_h);
    let mut horiz = Plane::new(new_w, src.h);
    for y in 0..src.h {
        let row = src.row(y);
        for (x, taps) in xw.iter().enumerate() {
            horiz.data[y * new_w + x] = taps.iter().map(|&(i, wt)| row[i] * wt).sum();
        }
    }
    for (y, taps) in yw.iter().enumerate() {
        let dst = &mut out.data[y * new_w..(y + 1) * new_w];
        for &(i, wt) in taps {
            for (d, &s) in dst.iter_mut().zip(horiz.row(i)) {
                *d += s * wt;
            }
        }
    }
    out
}

/// The octave base: the input (optionally upsampled 2×) blurred from the assumed camera blur
/// (σ = 0.5, doubled to 1.0 by upsampling) up to `sigma`.
pub(crate) fn initial_image(img: &Plane, upsample: bool, sigma: f32) -> Plane {
    const INIT_SIGMA: f32 = 0.5;
    let mut scratch = BlurScratch::default();
    let mut out = Plane::default();
    if upsample {
        let sig_diff = (sigma * sigma - INIT_SIGMA * INIT_SIGMA * 4.0)
            .max(0.01)
            .sqrt();
        let dbl = upsample2x(img);
        gaussian_blur(&dbl, &mut out, f64::from(sig_diff), &mut scratch);
    } else {
        let sig_diff = (sigma * sigma - INIT_SIGMA * INIT_SIGMA).max(0.01).sqrt();
        gaussian_blur(img, &mut out, f64::from(sig_diff), &mut scratch);
    }
    out
}

/// Incremental blur sigmas within an octave: layer `i` is layer `i-1` blurred by `sig[i]` so
/// that its total blur is `sigma * k^i`, `k = 2^(1/n_layers)`.
pub(crate) fn layer_sigmas(sigma: f64, n_layers: usize) -> Vec<f64> {
    let k = 2f64.powf(1.0 / n_layers as f64);
    let mut sig = vec![sigma; n_layers + 3];
    for (i, s) in sig.iter_mut().enumerate().skip(1) {
        let prev = k.powi(i as i32 - 1) * sigma;
        let total = prev * k;
        *s = (total * total - prev * prev).sqrt();
    }
    sig
}

/// Gaussian pyramid: `n_octaves` octaves of `n_layers + 3` planes each. The base of octave
/// `o > 0` is layer `n_layers` of octave `o - 1` (blur 2σ) taken every other pixel.
///
/// Stops early (returning fewer octaves) when an octave would have an empty side.
pub(crate) fn gaussian_pyramid(
    base: Plane,
    n_octaves: usize,
    n_layers: usize,
    sigma: f64,
) -> Vec<Plane> {
    let per = n_layers + 3;
    let sig = layer_sigmas(sigma, n_layers);
    let mut pyr: Vec<Plane> = Vec::with_capacity(n_octaves * per);
    let mut scratch = BlurScratch::default();
    let mut next_base = Some(base);
    for o in 0..n_octaves {
        let Some(b) = next_base.take() else { break };
        if b.w == 0 || b.h == 0 {
            break;
        }
        pyr.push(b);
        for s in sig.iter().skip(1) {
            let mut dst = Plane::default();
            if let Some(src) = pyr.last() {
                gaussian_blur(src, &mut dst, *s, &mut scratch);
            }
            pyr.push(dst);
        }
        if o + 1 < n_octaves {
            next_base = pyr.get(o * per + n_layers).map(downsample2x);
        }
    }
    pyr
}

/// Difference-of-Gaussians pyramid: `n_layers + 2` planes per octave, `D_i = G_{i+1} - G_i`.
pub(crate) fn dog_pyramid(gpyr: &[Plane], n_layers: usize) -> Vec<Plane> {
    let per = n_layers + 3;
    let mut dog = Vec::with_capacity(gpyr.len() / per * (n_layers + 2));
    for octave in gpyr.chunks_exact(per) {
        for pair in octave.windows(2) {
            let (a, b) = (&pair[0], &pair[1]);
            dog.push(Plane {
                w: a.w,
                h: a.h,
                data: b.data.iter().zip(&a.data).map(|(&y, &x)| y - x).collect(),
            });
        }
    }
    dog
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaussian_kernel_sums_to_one() {
        for &sigma in &[0.5, 1.0, 1.2489996, 1.6, 2.0159, 3.0938, 7.5] {
            let k = gaussian_half_kernel(sigma);
            let sum: f64 =
                f64::from(k[0]) + 2.0 * k.iter().skip(1).map(|&v| f64::from(v)).sum::<f64>();
            assert!((sum - 1.0).abs() < 1e-6, "sigma {sigma}: sum {sum}");
            // OpenCV's size rule for float images: radius = round(8σ + 1) / 2.
            let ksize = ((sigma * 8.0 + 1.0).round() as usize) | 1;
            assert_eq!(k.len(), ksize / 2 + 1);
            // Monotonically decreasing away from the centre.
            assert!(k.windows(2).all(|p| p[0] > p[1]));
        }
    }

    #[test]
    fn reflect101_matches_opencv() {
        // gfedcb|abcdefgh|gfedcba on indices 0..8
        let got: Vec<usize> = (-3..11).map(|p| reflect101(p, 8)).collect();
        assert_eq!(got, vec![3, 2, 1, 0, 1, 2, 3, 4, 5, 6, 7, 6, 5, 4]);
        assert_eq!(reflect101(-5, 1), 0);
        assert_eq!(reflect101(-7, 2), 1);
        assert!((-50..50).all(|p| reflect101(p, 3) < 3));
    }

    #[test]
    fn blur_preserves_constant_and_mass() {
        let mut p = Plane::new(13, 7);
        p.data.iter_mut().for_each(|v| *v = 42.0);
        let mut out = Plane::default();
        gaussian_blur(&p, &mut out, 2.5, &mut BlurScratch::default());
        assert!(out.data.iter().all(|&v| (v - 42.0).abs() < 1e-3));
        // A centred impulse on a large plane spreads but keeps its mass.
        let mut imp = Plane::new(41, 41);
        imp.data[20 * 41 + 20] = 1.0;
        gaussian_blur(&imp, &mut out, 1.6, &mut BlurScratch::default());
        let mass: f32 = out.data.iter().sum();
        assert!((mass - 1.0).abs() < 1e-4);
        assert!(out.at(20, 20) > out.at(21, 20) && out.at(21, 20) > out.at(22, 20));
        assert!((out.at(19, 20) - out.at(21, 20)).abs() < 1e-7);
    }

    #[test]
    fn tiny_planes_do_not_panic() {
        for (w, h) in [(1, 1), (1, 5), (5, 1), (2, 2)] {
            let p = Plane {
                w,
                h,
                data: (0..w * h).map(|i| i as f32).collect(),
            };
            let mut out = Plane::default();
            gaussian_blur(&p, &mut out, 3.0, &mut BlurScratch::default());
            assert_eq!(out.data.len(), w * h);
            let up = upsample2x(&p);
            assert_eq!((up.w, up.h), (2 * w, 2 * h));
            let down = downsample2x(&p);
            assert_eq!((down.w, down.h), (w / 2, h / 2));
        }
    }

    #[test]
    fn upsample_matches_inter_linear_weights() {
        let p = Plane {
            w: 3,
            h: 1,
            data: vec![0.0, 4.0, 8.0],
        };
        let up = upsample2x(&p);
        // dst(0) clamps to src(0); dst(1) = .75 src(0) + .25 src(1); ... dst(5) clamps to src(2).
        assert_eq!(up.row(0), &[0.0, 1.0, 3.0, 5.0, 7.0, 8.0]);
    }

    #[test]
    fn area_resize_averages_blocks() {
        let p = Plane {
            w: 4,
            h: 2,
            data: vec![0.0, 2.0, 4.0, 6.0, 2.0, 4.0, 6.0, 8.0],
        };
        let out = area_resize(&p, 2, 1);
        assert_eq!(out.data, vec![2.0, 6.0]);
        let out = area_resize(&p, 3, 2);
        // Non-integer factor: mass is preserved up to the scale factor.
        let s_in: f32 = p.data.iter().sum();
        let s_out: f32 = out.data.iter().sum();
        assert!((s_out * (8.0 / 6.0) - s_in).abs() < 1e-4);
    }

    #[test]
    fn layer_sigmas_compose_to_geometric_series() {
        let sig = layer_sigmas(1.6, 3);
        let mut total2 = sig[0] * sig[0];
        for (i, s) in sig.iter().enumerate().skip(1) {
            total2 += s * s;
            let expected = 1.6 * 2f64.powf(i as f64 / 3.0);
            assert!((total2.sqrt() - expected).abs() < 1e-9);
        }
    }
}
