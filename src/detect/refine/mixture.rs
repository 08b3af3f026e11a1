//! The refinement's colour models: mixtures of full-covariance Gaussians over colour and
//! texture, fitted per palette label and scored by their most likely part.

/// One Gaussian of a colour (+ texture) mixture (full covariance).
#[derive(Clone, Copy)]
pub(super) struct Gauss {
    pub(super) mean: [f64; 4],
    /// `−½·Σ⁻¹` as its upper triangle, off-diagonal terms doubled (the quadratic form of a
    /// symmetric matrix in 10 products instead of 16): diagonal `00 11 22 33`, then `01 02
    /// 03 12 13 23`.
    quad: [f64; 10],
    /// `ln(weight) − ½·ln det Σ` (the constant `−2·ln 2π` is common to all and dropped).
    log_norm: f64,
}

/// Colour noise floor added to each covariance's diagonal (JPEG noise, quantisation): keeps a
/// Gaussian fitted on one flat colour from becoming infinitely sharp.
const COV_FLOOR: f64 = 9.0;

pub(super) struct Mixture {
    pub(super) parts: Vec<Gauss>,
}

impl Mixture {
    /// Fits one Gaussian per label from weighted pixels' colour and texture (`labels[i]` in
    /// `0..k`).
    pub(super) fn fit(
        feat: &[[f32; 4]],
        weights: &[f64],
        labels: &[usize],
        k: usize,
    ) -> Option<Mixture> {
        const D: usize = 4;
        let mut sw = vec![0f64; k];
        let mut sm = vec![[0f64; D]; k];
        let mut ss = vec![[[0f64; D]; D]; k];
        for ((c, &w), &l) in feat.iter().zip(weights).zip(labels) {
            if w <= 0.0 || l >= k {
                continue;
            }
            sw[l] += w;
            for a in 0..D {
                let ca = c[a] as f64;
                sm[l][a] += w * ca;
                for b in 0..D {
                    ss[l][a][b] += w * ca * c[b] as f64;
                }
            }
        }
        let total: f64 = sw.iter().sum();
        if total <= 0.0 {
            return None;
        }
        let mut parts = Vec::new();
        for l in 0..k {
            if sw[l] < 1e-9 {
                continue;
            }
            let mut mean = [0f64; D];
            for a in 0..D {
                mean[a] = sm[l][a] / sw[l];
            }
            let mut cov = nalgebra::Matrix4::<f64>::zeros();
            for a in 0..D {
                for b in 0..D {
                    cov[(a, b)] = ss[l][a][b] / sw[l] - mean[a] * mean[b];
                }
                cov[(a, a)] += COV_FLOOR;
            }
            let det = cov.determinant();
            if !(det.is_finite() && det > 1e-9) {
                continue;
            }
            let Some(inv_m) = cov.try_inverse() else {
                continue;
            };
            let (i, mut quad) = (|a, b| inv_m[(a, b)], [0f64; 10]);
            for (a, q) in quad.iter_mut().take(D).enumerate() {
                *q = -0.5 * i(a, a);
            }
            for (k, (a, b)) in [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
                .into_iter()
                .enumerate()
            {
                quad[D + k] = -0.5 * (i(a, b) + i(b, a));
            }
            let weight = sw[l] / total;
            parts.push(Gauss {
                mean,
                quad,
                log_norm: weight.ln() - 0.5 * det.ln(),
            });
        }
        (!parts.is_empty()).then_some(Mixture { parts })
    }

    /// `(index of the most likely Gaussian k, its cost −ln(w_k·N(c; μ_k, Σ_k)))` up to a
    /// constant shared by every mixture: GrabCut's data term (Rother, Kolmogorov and Blake,
    /// 2004), where each pixel is charged by its own Gaussian, not by the whole mixture's
    /// likelihood.
    ///
    /// Why not the mixture's `−ln Σ_k w_k·N(c; μ_k, Σ_k)`, as before (issue 11): it costs an
    /// `exp` per Gaussian and a `ln` per pixel, two mixtures and two rounds per crop pixel,
    /// and in wasm those are software routines: about a fifth of the moving-camera detector's
    /// time in headless Chromium. The mixture's cost is at most this one and at least this
    /// one − `ln K`, nearly equal where one Gaussian dominates (the usual case); on the DAVIS
    /// sequences mean J is unchanged to the third decimal (`tests/data/detect/README.md`).
    pub(super) fn eval(&self, c: &[f32; 4]) -> (usize, f64) {
        let mut best = (0, f64::NEG_INFINITY);
        for (i, g) in self.parts.iter().enumerate() {
            let d = [
                c[0] as f64 - g.mean[0],
                c[1] as f64 - g.mean[1],
                c[2] as f64 - g.mean[2],
                c[3] as f64 - g.mean[3],
            ];
            let w = &g.quad;
            let t = g.log_norm
                + w[0] * d[0] * d[0]
                + w[1] * d[1] * d[1]
                + w[2] * d[2] * d[2]
                + w[3] * d[3] * d[3]
                + d[0] * (w[4] * d[1] + w[5] * d[2] + w[6] * d[3])
                + d[1] * (w[7] * d[2] + w[8] * d[3])
                + w[9] * d[2] * d[3];
            if t > best.1 {
                best = (i, t);
            }
        }
        (best.0, -best.1)
    }
}
