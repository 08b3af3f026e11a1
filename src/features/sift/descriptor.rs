//! The 4×4×8 SIFT descriptor (Lowe 2004, §6; OpenCV's `calcSIFTDescriptor`).

use super::detect::{cv_round, fast_atan2_deg};
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

/// Computes the descriptor of the keypoint at `(x, y)` (octave coordinates), orientation `ori`
/// degrees (in the y-up convention of the gradients: OpenCV passes `360 - angle`) and scale
/// `scl` (octave pixels). Returns the clipped vector normalised to unit L2 norm (all zeros when
/// the window has no gradient).
pub(crate) fn calc_descriptor(img: &Plane, x: f32, y: f32, ori: f32, scl: f32) -> [f32; DESCR_LEN] {
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

    let mut hist = [0f32; HIST_LEN];
    for i in -radius..=radius {
        let r = pt_y + i;
        if r <= 0 || r >= rows - 1 {
            continue;
        }
        let (up, row, down) = (
            img.row(r as usize - 1),
            img.row(r as usize),
            img.row(r as usize + 1),
        );
        for j in -radius..=radius {
            // Sample position in the rotated histogram frame; the -0.5 makes a sample at the
            // centre of a cell put its whole weight in that cell.
            let c_rot = j as f32 * cos_t - i as f32 * sin_t;
            let r_rot = j as f32 * sin_t + i as f32 * cos_t;
            let rbin = r_rot + half_d - 0.5;
            let cbin = c_rot + half_d - 0.5;
            let c = pt_x + j;
            if !(rbin > -1.0 && rbin < D as f32 && cbin > -1.0 && cbin < D as f32)
                || c <= 0
                || c >= cols - 1
            {
                continue;
            }
            let cu = c as usize;
            let dx = row[cu + 1] - row[cu - 1];
            let dy = up[cu] - down[cu];
            let grad_ori = fast_atan2_deg(dy, dx);
            let mag =
                (dx * dx + dy * dy).sqrt() * ((c_rot * c_rot + r_rot * r_rot) * exp_scale).exp();
            let mut obin = (grad_ori - ori) * bins_per_deg;

            let r0 = rbin.floor();
            let c0 = cbin.floor();
            let o0 = obin.floor();
            let (rf, cf) = (rbin - r0, cbin - c0);
            obin -= o0;
            let mut o0 = o0 as i32;
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

            let idx = (((r0 as i32 + 1) as usize * (D + 2)) + (c0 as i32 + 1) as usize) * (N + 2)
                + o0 as usize;
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
        *o = (x * INT_DESCR_FCTR).round_ties_even().clamp(0.0, 255.0) as u8;
    }
    out
}
