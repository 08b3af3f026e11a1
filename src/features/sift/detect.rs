//! Scale-space extrema: 3×3×3 DoG extrema, quadratic sub-pixel/sub-scale refinement, contrast and
//! edge rejection, and the dominant-orientation histogram (Lowe 2004, §§3–5; OpenCV's
//! `findScaleSpaceExtrema`, `adjustLocalExtrema` and `calcOrientationHist`).

use super::scale_space::Plane;

/// Keypoints closer than this to an octave's border are never detected (their descriptor window
/// would be mostly outside the image).
pub(crate) const IMG_BORDER: usize = 5;
/// Refinement steps before an extremum that keeps moving is dropped.
const MAX_INTERP_STEPS: usize = 5;
/// Orientation histogram bins (10° each).
pub(crate) const ORI_HIST_BINS: usize = 36;
/// Gaussian window σ for the orientation histogram, in keypoint scales.
const ORI_SIG_FCTR: f32 = 1.5;
/// Orientation window radius, in keypoint scales (3σ of the window).
const ORI_RADIUS: f32 = 3.0 * ORI_SIG_FCTR;
/// Secondary peaks at least this fraction of the highest spawn their own keypoint.
const ORI_PEAK_RATIO: f32 = 0.8;

/// A refined extremum with one dominant orientation, in pyramid coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct RawKeypoint {
    /// Pyramid octave index (0 = the base, which is the 2× upsampled image when upsampling).
    pub octave: usize,
    /// Integer layer (1..=n_layers) the extremum converged to.
    pub layer: usize,
    /// Sub-scale offset in `[-0.5, 0.5)` layers.
    pub xi: f32,
    /// Column in octave coordinates (sample centres at integers).
    pub x_oct: f32,
    /// Row in octave coordinates.
    pub y_oct: f32,
    /// Keypoint scale in octave pixels: `sigma * 2^((layer + xi) / n_layers)`.
    pub scale_oct: f32,
    /// Diameter in base-image pixels (OpenCV's `KeyPoint::size` before the first-octave fix).
    pub size_base: f32,
    /// |D| at the refined extremum, in units of full intensity range.
    pub response: f32,
    /// Orientation in degrees, `[0, 360)`, in image coordinates (x right, y down, measured from
    /// +x towards +y), OpenCV's `KeyPoint::angle` convention.
    pub angle: f32,
}

/// Thresholds of the detector.
#[derive(Debug, Clone, Copy)]
pub(crate) struct DetectParams {
    pub n_layers: usize,
    pub contrast_threshold: f32,
    pub edge_threshold: f32,
    pub sigma: f32,
}

/// OpenCV's `cvRound` for floats: nearest, ties to even.
///
/// Baseline x86-64 has no rounding instruction, so `round_ties_even` is a libm call; adding and
/// subtracting 1.5·2²³ rounds exactly (to even, in the default rounding mode) for |v| < 2²².
#[inline]
pub(crate) fn cv_round(v: f32) -> i32 {
    const MAGIC: f32 = 12_582_912.0;
    if v.abs() < 4_194_304.0 {
        ((v + MAGIC) - MAGIC) as i32
    } else {
        v.round_ties_even() as i32
    }
}

/// `floor(v)` as an integer, exact for |v| < 2³¹, without the libm call `f32::floor` costs on
/// baseline x86-64.
#[inline]
pub(crate) fn floor_i32(v: f32) -> i32 {
    let t = v as i32;
    t - i32::from((t as f32) > v)
}

/// Finds every keypoint (one per dominant orientation) in the pyramids. `keep(octave, x_oct,
/// y_oct)` is asked after refinement, before the orientation histogram, so masked-out
/// locations cost no more than their refinement.
pub(crate) fn find_scale_space_extrema(
    gpyr: &[Plane],
    dog: &[Plane],
    p: &DetectParams,
    mut keep: impl FnMut(usize, f32, f32) -> bool,
) -> Vec<RawKeypoint> {
    let n_layers = p.n_layers;
    let n_octaves = dog.len() / (n_layers + 2);
    // OpenCV truncates the pre-threshold to an integer grey level (floor(0.5 * 0.04 / 3 * 255)
    // = 1 for the defaults); keeping that makes the candidate sets identical.
    let threshold =
        (0.5 * f64::from(p.contrast_threshold) / n_layers as f64 * 255.0).floor() as f32;
    let mut out = Vec::new();
    let mut hist = [0f32; ORI_HIST_BINS];
    let mut scratch = HistScratch::default();
    for o in 0..n_octaves {
        for i in 1..=n_layers {
            let idx = o * (n_layers + 2) + i;
            let (prev, cur, next) = (&dog[idx - 1], &dog[idx], &dog[idx + 1]);
            let (w, h) = (cur.w, cur.h);
            if w <= 2 * IMG_BORDER || h <= 2 * IMG_BORDER {
                continue;
            }
            for r in IMG_BORDER..h - IMG_BORDER {
                let rows = [
                    prev.row(r - 1),
                    prev.row(r),
                    prev.row(r + 1),
                    cur.row(r - 1),
                    cur.row(r),
                    cur.row(r + 1),
                    next.row(r - 1),
                    next.row(r),
                    next.row(r + 1),
                ];
                let center = rows[4];
                for (c, &val) in center
                    .iter()
                    .enumerate()
                    .take(w - IMG_BORDER)
                    .skip(IMG_BORDER)
                {
                    if val.abs() <= threshold || !is_extremum(val, &rows, c) {
                        continue;
                    }
                    let Some(ext) = adjust_local_extrema(dog, o, i, r, c, p) else {
                        continue;
                    };
                    if !keep(o, ext.x_oct, ext.y_oct) {
                        continue;
                    }
                    let gimg = &gpyr[o * (n_layers + 3) + ext.layer];
                    let scl_octv = ext.size_base * 0.5 / (1u32 << o) as f32;
                    let omax = orientation_hist(
                        gimg,
                        ext.c as isize,
                        ext.r as isize,
                        cv_round(ORI_RADIUS * scl_octv),
                        ORI_SIG_FCTR * scl_octv,
                        &mut hist,
                        &mut scratch,
                    );
                    let mag_thr = omax * ORI_PEAK_RATIO;
                    let n = ORI_HIST_BINS;
                    for j in 0..n {
                        let l = if j > 0 { j - 1 } else { n - 1 };
                        let r2 = if j < n - 1 { j + 1 } else { 0 };
                        let (hl, hj, hr) = (hist[l], hist[j], hist[r2]);
                        if hj > hl && hj > hr && hj >= mag_thr {
                            // Parabolic peak interpolation over the three bins.
                            let mut bin = j as f32 + 0.5 * (hl - hr) / (hl - 2.0 * hj + hr);
                            if bin < 0.0 {
                                bin += n as f32;
                            } else if bin >= n as f32 {
                                bin -= n as f32;
                            }
                            // The histogram is built with y up; 360 - θ converts it to the
                            // y-down image convention.
                            let mut angle = 360.0 - (360.0 / n as f32) * bin;
                            if (angle - 360.0).abs() < f32::EPSILON {
                                angle = 0.0;
                            }
                            out.push(RawKeypoint {
                                octave: o,
                                layer: ext.layer,
                                xi: ext.xi,
                                x_oct: ext.x_oct,
                                y_oct: ext.y_oct,
                                scale_oct: ext.scale_oct,
                                size_base: ext.size_base,
                                response: ext.response,
                                angle,
                            });
                        }
                    }
                }
            }
        }
    }
    out
}

/// Whether `val` (at column `c` of `rows[4]`) is ≥ all 26 neighbours (when positive) or ≤ all of
/// them (when negative). Ties count as extrema, as in OpenCV.
#[inline]
fn is_extremum(val: f32, rows: &[&[f32]; 9], c: usize) -> bool {
    // The same-row neighbours first: they reject most pixels before the other 24 are read.
    let centre = rows[4];
    if val > 0.0 {
        val >= centre[c - 1]
            && val >= centre[c + 1]
            && rows
                .iter()
                .all(|row| val >= row[c - 1] && val >= row[c] && val >= row[c + 1])
    } else {
        val <= centre[c - 1]
            && val <= centre[c + 1]
            && rows
                .iter()
                .all(|row| val <= row[c - 1] && val <= row[c] && val <= row[c + 1])
    }
}

/// Output of the refinement.
#[derive(Debug, Clone, Copy)]
struct Extremum {
    layer: usize,
    r: usize,
    c: usize,
    xi: f32,
    x_oct: f32,
    y_oct: f32,
    scale_oct: f32,
    size_base: f32,
    response: f32,
}

/// Fits a 3-D quadratic to the DoG around `(layer, r, c)` and moves to the neighbouring sample
/// until the offset is below half a sample in every direction (at most five steps). Rejects
/// low-contrast extrema (|D(x̂)| · n_layers < contrast threshold) and edge responses (ratio of
/// principal curvatures above `edge_threshold`).
fn adjust_local_extrema(
    dog: &[Plane],
    octv: usize,
    layer: usize,
    r: usize,
    c: usize,
    p: &DetectParams,
) -> Option<Extremum> {
    let n_layers = p.n_layers;
    let img_scale = 1.0f32 / 255.0;
    let deriv_scale = img_scale * 0.5;
    let second_deriv_scale = img_scale;
    let cross_deriv_scale = img_scale * 0.25;
    let border = IMG_BORDER as isize;

    let (mut layer, mut r, mut c) = (layer as isize, r as isize, c as isize);
    let (mut xi, mut xr, mut xc) = (0f32, 0f32, 0f32);
    let mut converged = false;
    for _ in 0..MAX_INTERP_STEPS {
        let idx = octv * (n_layers + 2) + layer as usize;
        let (prev, img, next) = (&dog[idx - 1], &dog[idx], &dog[idx + 1]);
        let (ru, cu) = (r as usize, c as usize);
        let at = |pl: &Plane, dr: isize, dc: isize| {
            pl.at((cu as isize + dc) as usize, (ru as isize + dr) as usize)
        };
        let d_d = [
            (at(img, 0, 1) - at(img, 0, -1)) * deriv_scale,
            (at(img, 1, 0) - at(img, -1, 0)) * deriv_scale,
            (at(next, 0, 0) - at(prev, 0, 0)) * deriv_scale,
        ];
        let v2 = at(img, 0, 0) * 2.0;
        let dxx = (at(img, 0, 1) + at(img, 0, -1) - v2) * second_deriv_scale;
        let dyy = (at(img, 1, 0) + at(img, -1, 0) - v2) * second_deriv_scale;
        let dss = (at(next, 0, 0) + at(prev, 0, 0) - v2) * second_deriv_scale;
        let dxy =
            (at(img, 1, 1) - at(img, 1, -1) - at(img, -1, 1) + at(img, -1, -1)) * cross_deriv_scale;
        let dxs = (at(next, 0, 1) - at(next, 0, -1) - at(prev, 0, 1) + at(prev, 0, -1))
            * cross_deriv_scale;
        let dys = (at(next, 1, 0) - at(next, -1, 0) - at(prev, 1, 0) + at(prev, -1, 0))
            * cross_deriv_scale;
        let h = [[dxx, dxy, dxs], [dxy, dyy, dys], [dxs, dys, dss]];
        let x = solve3(&h, &d_d);
        xi = -x[2];
        xr = -x[1];
        xc = -x[0];

        if xi.abs() < 0.5 && xr.abs() < 0.5 && xc.abs() < 0.5 {
            converged = true;
            break;
        }
        // Also catches NaN offsets (from non-finite input), which must not reach the casts.
        let lim = (i32::MAX / 3) as f32;
        if !(xi.abs() <= lim && xr.abs() <= lim && xc.abs() <= lim) {
            return None;
        }
        c += cv_round(xc) as isize;
        r += cv_round(xr) as isize;
        layer += cv_round(xi) as isize;
        if layer < 1
            || layer > n_layers as isize
            || c < border
            || c >= img.w as isize - border
            || r < border
            || r >= img.h as isize - border
        {
            return None;
        }
    }
    if !converged {
        return None;
    }

    let layer = layer as usize;
    let (ru, cu) = (r as usize, c as usize);
    let idx = octv * (n_layers + 2) + layer;
    let (prev, img, next) = (&dog[idx - 1], &dog[idx], &dog[idx + 1]);
    let at = |pl: &Plane, dr: isize, dc: isize| {
        pl.at((cu as isize + dc) as usize, (ru as isize + dr) as usize)
    };
    let d_d = [
        (at(img, 0, 1) - at(img, 0, -1)) * deriv_scale,
        (at(img, 1, 0) - at(img, -1, 0)) * deriv_scale,
        (at(next, 0, 0) - at(prev, 0, 0)) * deriv_scale,
    ];
    let t = d_d[0] * xc + d_d[1] * xr + d_d[2] * xi;
    let contr = at(img, 0, 0) * img_scale + t * 0.5;
    if contr.abs() * (n_layers as f32) < p.contrast_threshold {
        return None;
    }
    // Edge rejection: tr(H)² / det(H) < (r + 1)² / r with r = edge_threshold.
    let v2 = at(img, 0, 0) * 2.0;
    let dxx = (at(img, 0, 1) + at(img, 0, -1) - v2) * second_deriv_scale;
    let dyy = (at(img, 1, 0) + at(img, -1, 0) - v2) * second_deriv_scale;
    let dxy =
        (at(img, 1, 1) - at(img, 1, -1) - at(img, -1, 1) + at(img, -1, -1)) * cross_deriv_scale;
    let tr = dxx + dyy;
    let det = dxx * dyy - dxy * dxy;
    let e = p.edge_threshold;
    if det <= 0.0 || tr * tr * e >= (e + 1.0) * (e + 1.0) * det {
        return None;
    }

    let scale_oct = p.sigma * 2f32.powf((layer as f32 + xi) / n_layers as f32);
    Some(Extremum {
        layer,
        r: ru,
        c: cu,
        xi,
        x_oct: cu as f32 + xc,
        y_oct: ru as f32 + xr,
        scale_oct,
        size_base: scale_oct * (1u32 << octv) as f32 * 2.0,
        response: contr.abs(),
    })
}

/// Solves the 3×3 system `H x = b` by Cramer's rule with the determinant in `f64` (what
/// OpenCV's `Matx33f::solve(…, DECOMP_LU)` does); a singular `H` gives `x = 0`, as there.
fn solve3(h: &[[f32; 3]; 3], b: &[f32; 3]) -> [f32; 3] {
    let m = |i: usize, j: usize| f64::from(h[i][j]);
    let det = m(0, 0) * (m(1, 1) * m(2, 2) - m(1, 2) * m(2, 1))
        - m(0, 1) * (m(1, 0) * m(2, 2) - m(1, 2) * m(2, 0))
        + m(0, 2) * (m(1, 0) * m(2, 1) - m(1, 1) * m(2, 0));
    if det == 0.0 || !det.is_finite() {
        return [0.0; 3];
    }
    let inv = 1.0 / det;
    let (b0, b1, b2) = (f64::from(b[0]), f64::from(b[1]), f64::from(b[2]));
    let x0 = inv
        * (b0 * (m(1, 1) * m(2, 2) - m(1, 2) * m(2, 1)) - m(0, 1) * (b1 * m(2, 2) - m(1, 2) * b2)
            + m(0, 2) * (b1 * m(2, 1) - m(1, 1) * b2));
    let x1 = inv
        * (m(0, 0) * (b1 * m(2, 2) - m(1, 2) * b2) - b0 * (m(1, 0) * m(2, 2) - m(1, 2) * m(2, 0))
            + m(0, 2) * (m(1, 0) * b2 - b1 * m(2, 0)));
    let x2 = inv
        * (m(0, 0) * (m(1, 1) * b2 - b1 * m(2, 1)) - m(0, 1) * (m(1, 0) * b2 - b1 * m(2, 0))
            + b0 * (m(1, 0) * m(2, 1) - m(1, 1) * m(2, 0)));
    [x0 as f32, x1 as f32, x2 as f32]
}

/// OpenCV's `fastAtan2`: a degree-7 odd polynomial in the octant ratio, in degrees `[0, 360]`,
/// accurate to about 0.3°. Used for gradient orientations so histograms bin like OpenCV's.
#[inline]
pub(crate) fn fast_atan2_deg(y: f32, x: f32) -> f32 {
    const P1: f32 = 57.283_627;
    const P3: f32 = -18.667_446;
    const P5: f32 = 8.914_001;
    const P7: f32 = -2.539_725;
    const EPS: f32 = f64::EPSILON as f32;
    let (ax, ay) = (x.abs(), y.abs());
    // Written with selects only (no early branches) so loops over it vectorise.
    let steep = ax < ay;
    let (num, den) = if steep { (ax, ay) } else { (ay, ax) };
    let c = num / (den + EPS);
    let c2 = c * c;
    let p = (((P7 * c2 + P5) * c2 + P3) * c2 + P1) * c;
    let a = if steep { 90.0 - p } else { p };
    let a = if x < 0.0 { 180.0 - a } else { a };
    if y < 0.0 {
        360.0 - a
    } else {
        a
    }
}

/// Scratch buffers reused across keypoints by [`orientation_hist`].
#[derive(Debug, Default)]
pub(crate) struct HistScratch {
    weights: Vec<f32>,
    dx: Vec<f32>,
    dy: Vec<f32>,
    ori: Vec<f32>,
    mag: Vec<f32>,
}

/// Gradient-orientation histogram (36 bins, magnitude × Gaussian weight) of the square of
/// `radius` around `(cx, cy)`, smoothed with the `[1 4 6 4 1] / 16` kernel; returns its maximum.
/// Gradients use y up (`dy = I(y-1) - I(y+1)`), as OpenCV.
pub(crate) fn orientation_hist(
    img: &Plane,
    cx: isize,
    cy: isize,
    radius: i32,
    sigma: f32,
    hist: &mut [f32; ORI_HIST_BINS],
    scratch: &mut HistScratch,
) -> f32 {
    const N: usize = ORI_HIST_BINS;
    let radius = radius.max(0) as isize;
    let expf_scale = -1.0 / (2.0 * sigma * sigma);
    let HistScratch {
        weights,
        dx: dxs,
        dy: dys,
        ori: oris,
        mag: mags,
    } = scratch;
    // exp((i² + j²)·s) = exp(i²·s)·exp(j²·s): one exp per offset instead of per sample.
    weights.clear();
    weights.extend((-radius..=radius).map(|k| ((k * k) as f32 * expf_scale).exp()));
    // Two bins of circular padding on each side for the smoothing.
    let mut temp = [0f32; N + 4];
    let (w, h) = (img.w as isize, img.h as isize);
    let (i0, i1) = ((1 - cy).max(-radius), (h - 2 - cy).min(radius));
    let (j0, j1) = ((1 - cx).max(-radius), (w - 2 - cx).min(radius));
    if j0 > j1 {
        return smooth(&mut temp, hist);
    }
    let (c0, c1) = ((cx + j0) as usize, (cx + j1) as usize);
    let wrow = &weights[(j0 + radius) as usize..=(j1 + radius) as usize];
    for i in i0..=i1 {
        let y = (cy + i) as usize;
        let (up, row, down) = (img.row(y - 1), img.row(y), img.row(y + 1));
        let wi = weights[(i + radius) as usize];
        // Vectorisable passes over the row segment, then the scalar binning.
        dxs.clear();
        dxs.extend(
            row[c0 + 1..=c1 + 1]
                .iter()
                .zip(&row[c0 - 1..=c1 - 1])
                .map(|(a, b)| a - b),
        );
        dys.clear();
        dys.extend(up[c0..=c1].iter().zip(&down[c0..=c1]).map(|(a, b)| a - b));
        oris.clear();
        oris.extend(
            dys.iter()
                .zip(dxs.iter())
                .map(|(&dy, &dx)| fast_atan2_deg(dy, dx)),
        );
        mags.clear();
        mags.extend(
            dxs.iter()
                .zip(dys.iter())
                .zip(wrow)
                .map(|((&dx, &dy), &wj)| (wi * wj) * (dx * dx + dy * dy).sqrt()),
        );
        for (&ori, &mag) in oris.iter().zip(mags.iter()) {
            let mut bin = cv_round((N as f32 / 360.0) * ori);
            if bin >= N as i32 {
                bin -= N as i32;
            }
            if bin < 0 {
                bin += N as i32;
            }
            temp[2 + bin as usize] += mag;
        }
    }
    smooth(&mut temp, hist)
}

/// Circularly pads `temp` (bins at `2..N+2`), smooths it into `hist` and returns the maximum.
fn smooth(temp: &mut [f32; ORI_HIST_BINS + 4], hist: &mut [f32; ORI_HIST_BINS]) -> f32 {
    const N: usize = ORI_HIST_BINS;
    temp[1] = temp[N + 1];
    temp[0] = temp[N];
    temp[N + 2] = temp[2];
    temp[N + 3] = temp[3];
    let mut maxval = 0f32;
    for (i, out) in hist.iter_mut().enumerate() {
        let t = &temp[i..i + 5];
        *out = (t[0] + t[4]) * (1.0 / 16.0) + (t[1] + t[3]) * (4.0 / 16.0) + t[2] * (6.0 / 16.0);
        if i == 0 || *out > maxval {
            maxval = *out;
        }
    }
    maxval
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_rounding_matches_std() {
        let vals = [
            -3.5f32,
            -2.5,
            -1.5,
            -0.5,
            -0.49,
            0.0,
            0.5,
            1.5,
            2.5,
            2.4999,
            7.5,
            1e6 + 0.5,
            5e6,
            -1e-9,
            -0.99999,
            3.0e9,
        ];
        for v in vals {
            assert_eq!(cv_round(v), v.round_ties_even() as i32, "round {v}");
            if v.abs() < 2e9 {
                assert_eq!(floor_i32(v), v.floor() as i32, "floor {v}");
            }
        }
        for k in -2000..2000 {
            let v = k as f32 * 0.0625;
            assert_eq!(cv_round(v), v.round_ties_even() as i32);
            assert_eq!(floor_i32(v), v.floor() as i32);
        }
    }

    #[test]
    fn fast_atan2_is_within_a_third_of_a_degree() {
        for k in 0..720 {
            let t = (k as f32 * 0.5).to_radians();
            let (y, x) = (t.sin() * 3.0, t.cos() * 3.0);
            let got = fast_atan2_deg(y, x);
            let want = y.atan2(x).to_degrees().rem_euclid(360.0);
            let diff = (got - want + 540.0).rem_euclid(360.0) - 180.0;
            assert!(diff.abs() < 0.3, "{k}: {got} vs {want}");
        }
    }

    #[test]
    fn solve3_inverts_and_handles_singular() {
        let h = [[2.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 1.0, 4.0]];
        let x_true = [1.0f32, -2.0, 0.5];
        let b = [2.0 * 1.0 + 1.0 * -2.0, 1.0 - 6.0 + 0.5, -2.0 + 2.0];
        let x = solve3(&h, &b);
        for k in 0..3 {
            assert!((x[k] - x_true[k]).abs() < 1e-5);
        }
        assert_eq!(solve3(&[[1.0, 2.0, 3.0]; 3], &b), [0.0; 3]);
    }

    #[test]
    fn orientation_hist_peaks_at_gradient_direction() {
        // Intensity grows to the right and downwards at 30° (y down): the gradient points at
        // 30° in image coordinates, i.e. -30° = 330° with y up.
        let (w, h) = (41, 41);
        let t = 30f32.to_radians();
        let data = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                x * t.cos() + y * t.sin()
            })
            .collect();
        let img = Plane { w, h, data };
        let mut hist = [0f32; ORI_HIST_BINS];
        let max = orientation_hist(&img, 20, 20, 8, 3.0, &mut hist, &mut HistScratch::default());
        let peak = hist.iter().position(|&v| v == max).unwrap();
        assert_eq!(peak, 33);
    }
}
