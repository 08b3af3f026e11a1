//! The 4×4×8 SIFT descriptor (Lowe 2004, §6; OpenCV's `calcSIFTDescriptor`).

use super::detect::{cv_round, fast_atan2_deg, floor_i32};
use super::scale_space::Plane;

/// Spatial cells per side.
const D: usize = 4;
/// Orientation bins per cell.
const N: usize = 8;
/// Descriptor length.
pub(crate) const DESCR_LEN: usize = D * D * N;
/// Width of one spatial cell, in keypoint scales.
const DESCR_SCL_FCTR: f32 = 3.0;
/// Entries are clipped at this fraction of the vector's norm (illumination robustness).
const DESCR_MAG_THR: f32 = 0.2;
/// Scale from the unit vector to bytes (OpenCV's `SIFT_INT_DESCR_FCTR`).
pub(crate) const INT_DESCR_FCTR: f32 = 512.0;

/// Histogram with one cell of padding on each spatial side and two wrap-around orientation
/// bins, so trilinear interpolation never needs a bounds test.
const HIST_LEN: usize = (D + 2) * (D + 2) * (N + 2);

/// The open interval of integers `j` with `lo < a·j < hi`, widened by one on each side (the
/// caller re-tests each sample exactly; the widening absorbs rounding), clamped to
/// `[min, max]`. Empty intervals come back with `start > end`.
fn solve_band(a: f32, lo: f32, hi: f32, min: isize, max: isize) -> (isize, isize) {
    if a.abs() < 1e-6 {
        return if lo < 0.0 && 0.0 < hi {
            (min, max)
        } else {
            (1, 0)
        };
    }
    let (p, q) = (lo / a, hi / a);
    let (p, q) = if p < q { (p, q) } else { (q, p) };
    let start = (floor_i32(p.max(min as f32 - 1.0)) as isize - 1).max(min);
    let end = (floor_i32(q.min(max as f32 + 1.0)) as isize + 1).min(max);
    (start, end)
}

/// Scratch buffers reused across keypoints so the descriptor loop never allocates.
#[derive(Debug, Default)]
pub(crate) struct DescriptorScratch {
    /// Gaussian weight per offset `-radius..=radius` (index `offset + radius`).
    weights: Vec<f32>,
    /// Per-sample values of the current row.
    dx: Vec<f32>,
    dy: Vec<f32>,
    ori: Vec<f32>,
    mag: Vec<f32>,
}

/// Computes the descriptor of the keypoint at `(x, y)` (octave coordinates), orientation `ori`
/// degrees (in the y-up convention of the gradients: OpenCV passes `360 - angle`) and scale
/// `scl` (octave pixels). Returns the clipped vector normalised to unit L2 norm (all zeros when
/// the window has no gradient).
pub(crate) fn calc_descriptor(
    img: &Plane,
    x: f32,
    y: f32,
    ori: f32,
    scl: f32,
    scratch: &mut DescriptorScratch,
) -> [f32; DESCR_LEN] {
    let pt_x = cv_round(x) as isize;
    let pt_y = cv_round(y) as isize;
    let (cos_t, sin_t) = {
        let a = ori * (std::f32::consts::PI / 180.0);
        (a.cos(), a.sin())
    };
    let bins_per_deg = N as f32 / 360.0;
    let exp_scale = -1.0 / (D as f32 * D as f32 * 0.5);
    let hist_width = DESCR_SCL_FCTR * scl;
    let diag = ((img.w as f64).powi(2) + (img.h as f64).powi(2)).sqrt() as i32;
    let radius =
        cv_round(hist_width * std::f32::consts::SQRT_2 * (D as f32 + 1.0) * 0.5).min(diag) as isize;
    let cos_t = cos_t / hist_width;
    let sin_t = sin_t / hist_width;
    let (rows, cols) = (img.h as isize, img.w as isize);
    let half_d = (D / 2) as f32;
    // Half-width of the window in rotated histogram units: cells -1..D after the -0.5 shift.
    let half_win = half_d + 0.5;

    // The Gaussian weight exp(|(c_rot, r_rot)|² · s) only depends on i² + j² (a rotation keeps
    // lengths), so it factors into exp(i²·t) · exp(j²·t): one exp per offset, not per sample.
    let t = exp_scale / (hist_width * hist_width);
    let DescriptorScratch {
        weights,
        dx: dxs,
        dy: dys,
        ori: oris,
        mag: mags,
    } = scratch;
    weights.clear();
    weights.extend((-radius..=radius).map(|k| ((k * k) as f32 * t).exp()));

    // Rows and columns whose gradient exists.
    let i_min = (1 - pt_y).max(-radius);
    let i_max = (rows - 2 - pt_y).min(radius);
    let j_min_img = (1 - pt_x).max(-radius);
    let j_max_img = (cols - 2 - pt_x).min(radius);

    let mut hist = [0f32; HIST_LEN];
    for i in i_min..=i_max {
        let r = (pt_y + i) as usize;
        let (up, row, down) = (img.row(r - 1), img.row(r), img.row(r + 1));
        let fi = i as f32;
        // Columns where both rotated coordinates can lie inside the window.
        let (a0, a1) = solve_band(
            sin_t,
            -half_win - fi * cos_t,
            half_win - fi * cos_t,
            j_min_img,
            j_max_img,
        );
        let (b0, b1) = solve_band(
            cos_t,
            -half_win + fi * sin_t,
            half_win + fi * sin_t,
            j_min_img,
            j_max_img,
        );
        let (j0, j1) = (a0.max(b0), a1.min(b1));
        if j0 > j1 {
            continue;
        }
        // Gradients, orientations and weighted magnitudes of the whole row segment first, in
        // straight-line loops the compiler vectorises; then the scalar histogram scatter.
        let (c0, c1) = ((pt_x + j0) as usize, (pt_x + j1) as usize);
        let n = c1 - c0 + 1;
        let wi = weights[(i + radius) as usize];
        let wrow = &weights[(j0 + radius) as usize..=(j1 + radius) as usize];
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
                .map(|((&dx, &dy), &wj)| (dx * dx + dy * dy).sqrt() * (wi * wj)),
        );
        for k in 0..n {
            let j = j0 + k as isize;
            // Sample position in the rotated histogram frame; the -0.5 makes a sample at the
            // centre of a cell put its whole weight in that cell.
            let c_rot = j as f32 * cos_t - fi * sin_t;
            let r_rot = j as f32 * sin_t + fi * cos_t;
            let rbin = r_rot + half_d - 0.5;
            let cbin = c_rot + half_d - 0.5;
            if !(rbin > -1.0 && rbin < D as f32 && cbin > -1.0 && cbin < D as f32) {
                continue;
            }
            let (grad_ori, mag) = (oris[k], mags[k]);
            let mut obin = (grad_ori - ori) * bins_per_deg;

            let r0 = floor_i32(rbin);
            let c0 = floor_i32(cbin);
            let mut o0 = floor_i32(obin);
            let (rf, cf) = (rbin - r0 as f32, cbin - c0 as f32);
            obin -= o0 as f32;
            if o0 < 0 {
                o0 += N as i32;
            }
            if o0 >= N as i32 {
                o0 -= N as i32;
            }
            // Trilinear interpolation into the 8 neighbouring (row, col, orientation) bins.
            let v_r1 = mag * rf;
            let v_r0 = mag - v_r1;
            let v_rc11 = v_r1 * cf;
            let v_rc10 = v_r1 - v_rc11;
            let v_rc01 = v_r0 * cf;
            let v_rc00 = v_r0 - v_rc01;
            let v_rco111 = v_rc11 * obin;
            let v_rco110 = v_rc11 - v_rco111;
            let v_rco101 = v_rc10 * obin;
            let v_rco100 = v_rc10 - v_rco101;
            let v_rco011 = v_rc01 * obin;
            let v_rco010 = v_rc01 - v_rco011;
            let v_rco001 = v_rc00 * obin;
            let v_rco000 = v_rc00 - v_rco001;

            let idx = (((r0 + 1) as usize * (D + 2)) + (c0 + 1) as usize) * (N + 2) + o0 as usize;
            hist[idx] += v_rco000;
            hist[idx + 1] += v_rco001;
            hist[idx + (N + 2)] += v_rco010;
            hist[idx + (N + 3)] += v_rco011;
            hist[idx + (D + 2) * (N + 2)] += v_rco100;
            hist[idx + (D + 2) * (N + 2) + 1] += v_rco101;
            hist[idx + (D + 3) * (N + 2)] += v_rco110;
            hist[idx + (D + 3) * (N + 2) + 1] += v_rco111;
        }
    }

    // Fold the circular orientation bins and drop the spatial padding.
    let mut dst = [0f32; DESCR_LEN];
    for i in 0..D {
        for j in 0..D {
            let idx = ((i + 1) * (D + 2) + (j + 1)) * (N + 2);
            hist[idx] += hist[idx + N];
            hist[idx + 1] += hist[idx + N + 1];
            dst[(i * D + j) * N..(i * D + j + 1) * N].copy_from_slice(&hist[idx..idx + N]);
        }
    }

    // Clip large gradients (non-linear illumination changes) and renormalise.
    let nrm2: f32 = dst.iter().map(|v| v * v).sum();
    let thr = nrm2.sqrt() * DESCR_MAG_THR;
    let mut nrm2 = 0f32;
    for v in dst.iter_mut() {
        *v = v.min(thr);
        nrm2 += *v * *v;
    }
    let inv = 1.0 / nrm2.sqrt().max(f32::EPSILON);
    if nrm2 > 0.0 {
        dst.iter_mut().for_each(|v| *v *= inv);
    }
    dst
}

/// Bytes as OpenCV stores them: `saturate(round(512 · v))`.
pub(crate) fn quantize(v: &[f32; DESCR_LEN]) -> [u8; DESCR_LEN] {
    let mut out = [0u8; DESCR_LEN];
    for (o, &x) in out.iter_mut().zip(v) {
        *o = cv_round(x * INT_DESCR_FCTR).clamp(0, 255) as u8;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_xoshiro::Xoshiro256PlusPlus;

    /// The direct transcription: every sample of the square window, tested one by one, with
    /// one exp per sample. The optimised version must agree with it.
    fn reference(img: &Plane, x: f32, y: f32, ori: f32, scl: f32) -> [f32; DESCR_LEN] {
        let (pt_x, pt_y) = (cv_round(x) as isize, cv_round(y) as isize);
        let a = ori * (std::f32::consts::PI / 180.0);
        let hist_width = DESCR_SCL_FCTR * scl;
        let diag = ((img.w as f64).powi(2) + (img.h as f64).powi(2)).sqrt() as i32;
        let radius = cv_round(hist_width * std::f32::consts::SQRT_2 * 2.5).min(diag) as isize;
        let (cos_t, sin_t) = (a.cos() / hist_width, a.sin() / hist_width);
        let mut raw = [0f32; DESCR_LEN];
        for i in -radius..=radius {
            for j in -radius..=radius {
                let c_rot = j as f32 * cos_t - i as f32 * sin_t;
                let r_rot = j as f32 * sin_t + i as f32 * cos_t;
                let (rbin, cbin) = (r_rot + 1.5, c_rot + 1.5);
                let (r, c) = (pt_y + i, pt_x + j);
                if !(rbin > -1.0 && rbin < 4.0 && cbin > -1.0 && cbin < 4.0)
                    || r <= 0
                    || r >= img.h as isize - 1
                    || c <= 0
                    || c >= img.w as isize - 1
                {
                    continue;
                }
                let (r, c) = (r as usize, c as usize);
                let dx = img.at(c + 1, r) - img.at(c - 1, r);
                let dy = img.at(c, r - 1) - img.at(c, r + 1);
                let mag = (dx * dx + dy * dy).sqrt()
                    * ((c_rot * c_rot + r_rot * r_rot) * (-1.0 / 8.0)).exp();
                let obin = (fast_atan2_deg(dy, dx) - ori) * (8.0 / 360.0);
                // Trilinear weights, accumulated into the cells that exist (wrapping angles).
                let (r0, c0, o0) = (rbin.floor(), cbin.floor(), obin.floor());
                let (fr, fc, fo) = (rbin - r0, cbin - c0, obin - o0);
                for (dr, wr) in [(0, 1.0 - fr), (1, fr)] {
                    for (dc, wc) in [(0, 1.0 - fc), (1, fc)] {
                        for (dob, wo) in [(0, 1.0 - fo), (1, fo)] {
                            let (rr, cc) = (r0 as i32 + dr, c0 as i32 + dc);
                            if !(0..4).contains(&rr) || !(0..4).contains(&cc) {
                                continue;
                            }
                            let oo = (o0 as i32 + dob).rem_euclid(8);
                            raw[((rr * 4 + cc) * 8 + oo) as usize] += mag * wr * wc * wo;
                        }
                    }
                }
            }
        }
        let n: f32 = raw.iter().map(|v| v * v).sum::<f32>().sqrt();
        raw.iter_mut().for_each(|v| *v = v.min(0.2 * n));
        let n: f32 = raw.iter().map(|v| v * v).sum::<f32>().sqrt();
        raw.iter_mut().for_each(|v| *v /= n.max(f32::EPSILON));
        raw
    }

    #[test]
    fn optimised_window_agrees_with_direct_transcription() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(99);
        let (w, h) = (70, 50);
        let img = Plane {
            w,
            h,
            data: (0..w * h).map(|_| rng.gen_range(0.0..255.0)).collect(),
        };
        let mut weights = DescriptorScratch::default();
        for _ in 0..300 {
            // Include keypoints near and beyond the borders and every orientation.
            let (x, y) = (rng.gen_range(-3.0..73.0), rng.gen_range(-3.0..53.0));
            let ori = rng.gen_range(0.0f32..360.0);
            let scl = rng.gen_range(1.0f32..6.0);
            let got = calc_descriptor(&img, x, y, ori, scl, &mut weights);
            let want = reference(&img, x, y, ori, scl);
            let err = got
                .iter()
                .zip(&want)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0f32, f32::max);
            assert!(
                err < 1e-4,
                "x {x} y {y} ori {ori} scl {scl}: max diff {err}"
            );
        }
        // Axis-aligned orientations exercise the degenerate bands (sin or cos = 0).
        for ori in [0.0f32, 90.0, 180.0, 270.0] {
            let got = calc_descriptor(&img, 35.0, 25.0, ori, 2.0, &mut weights);
            let want = reference(&img, 35.0, 25.0, ori, 2.0);
            assert!(got.iter().zip(&want).all(|(a, b)| (a - b).abs() < 1e-4));
        }
    }
}
