//! The offline pass's boxes: each track's detections smoothed with the whole track known
//! (a fixed-interval Rauch–Tung–Striebel smoother), as far as the sequence's own detections
//! show that smoothing helps.
//!
//! The online tracker reports a box smoothed only by the past (`estimate`): a
//! causal filter lags behind a turn or a change of size, so it is chosen only where the
//! detector's noise outweighs that lag. With the whole sequence known, the estimate at frame
//! `t` also uses the detections after it and lags behind nothing. Per sequence and coordinate
//! (centre x, centre y, width, height):
//!
//! - every run of consecutive observed frames of a track (at least [`SmoothConfig::min_run`])
//!   is smoothed by a bank of local-linear-trend smoothers that differ only in the ratio of
//!   process to measurement noise (the online bank's `RATIOS`, noise proportional to the
//!   box size);
//! - the ratio is chosen by leave-one-out cross-validation: how well the smoother predicts
//!   each detection from all the others, which for a linear smoother is the residual
//!   `z − x̂` over `1 − h` (`h` the weight of the detection on its own estimate; no refit);
//! - a detection the chosen smoother predicts very badly (a split, a merged or a clipped mask,
//!   a box on another object for one frame) is down-weighted for the neighbours' estimates
//!   (Huber weights, [`SmoothConfig::huber`] robust standard deviations, re-fitted
//!   [`SmoothConfig::reweight`] times);
//! - a coordinate is smoothed only when the best smoother predicts left-out detections
//!   clearly better than the lightest one ([`SmoothConfig::min_gain`]); otherwise it keeps the
//!   detection. Cross-validation cannot score the detection itself, and where it is already
//!   more exact than any smoother (a clean segmenter's centres; a 5 fps driving video whose
//!   boxes move more between frames than they jitter) the bank's curve is flat.
//!
//! Measured on the robustness grid (`shapetrack grid eval --mode offline`,
//! `tests/data/quality/README.md`). A mask keeps its mask and centroid; only its box is
//! smoothed, as online.

use super::config::SmoothConfig;
use crate::frame::{BBox, TrackedShape};
use crate::track::estimate::{coords, scales, Trend, RATIOS};
use std::collections::BTreeMap;

/// Left-out error (share of the box size) below which detections count as exact.
const EXACT: f64 = 1e-3;

/// Scale from the median absolute deviation to a normal standard deviation.
const MAD_TO_SIGMA: f64 = 1.4826;

/// A run's coordinates: centre x, centre y, width, height per frame, and the size scale of
/// each (width for centre x and width, height for the others).
struct Run {
    /// Indices into the shapes, in frame order.
    index: Vec<usize>,
    z: [Vec<f64>; 4],
    s: [Vec<f64>; 4],
    /// Measurement variance multipliers (Huber weights), per coordinate and frame.
    infl: [Vec<f64>; 4],
}

/// One scalar series smoothed with a local-linear-trend model: returns each frame's smoothed
/// position and `h`, the weight of its own measurement on it (`P_smooth / R`).
fn rts(z: &[f64], s: &[f64], infl: &[f64], ratio: f64, x_out: &mut Vec<f64>, h_out: &mut Vec<f64>) {
    let n = z.len();
    x_out.clear();
    h_out.clear();
    if n == 0 {
        return;
    }
    // The forward pass is the online bank's filter (`Trend`); the predicted and filtered
    // states are kept for the backward pass.
    let mut pred = Vec::with_capacity(n);
    let mut filt = Vec::with_capacity(n);
    let mut f = Trend::new(z[0], s[0]);
    for t in 0..n {
        if t > 0 {
            f.predict(ratio * s[t - 1] * s[t - 1]);
        }
        pred.push((f.x, f.p));
        f.update(z[t], s[t] * s[t] * infl[t]);
        filt.push((f.x, f.p));
    }
    let mut sm = filt.clone();
    for t in (0..n - 1).rev() {
        let ((xf, pf), (xp, pp), (xs, ps)) = (filt[t], pred[t + 1], sm[t + 1]);
        let det = pp[0] * pp[2] - pp[1] * pp[1];
        if !(det.is_finite() && det > 0.0) {
            continue;
        }
        let (i00, i01, i11) = (pp[2] / det, -pp[1] / det, pp[0] / det);
        // C = P_f Fᵀ P_p⁻¹ with F = [[1, 1], [0, 1]].
        let (a00, a01, a10, a11) = (pf[0] + pf[1], pf[1], pf[1] + pf[2], pf[2]);
        let c = [
            a00 * i00 + a01 * i01,
            a00 * i01 + a01 * i11,
            a10 * i00 + a11 * i01,
            a10 * i01 + a11 * i11,
        ];
        let d = [xs[0] - xp[0], xs[1] - xp[1]];
        let x = [
            xf[0] + c[0] * d[0] + c[1] * d[1],
            xf[1] + c[2] * d[0] + c[3] * d[1],
        ];
        let dp = [ps[0] - pp[0], ps[1] - pp[1], ps[2] - pp[2]];
        // P_s = P_f + C (P_s' − P_p') Cᵀ.
        let e = [
            c[0] * dp[0] + c[1] * dp[1],
            c[0] * dp[1] + c[1] * dp[2],
            c[2] * dp[0] + c[3] * dp[1],
            c[2] * dp[1] + c[3] * dp[2],
        ];
        let p = [
            pf[0] + e[0] * c[0] + e[1] * c[1],
            pf[1] + e[0] * c[2] + e[1] * c[3],
            pf[2] + e[2] * c[2] + e[3] * c[3],
        ];
        sm[t] = (x, p);
    }
    for t in 0..n {
        let r = s[t] * s[t] * infl[t];
        x_out.push(sm[t].0[0]);
        h_out.push((sm[t].1[0] / r).clamp(0.0, 1.0));
    }
}

/// Huber's loss of a residual `e` at threshold `c` (quadratic inside, linear outside).
fn huber(e: f64, c: f64) -> f64 {
    let a = e.abs();
    if a <= c {
        a * a
    } else {
        c * (2.0 * a - c)
    }
}

/// The median of `v` (reordered); 0 when empty.
fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, f64::total_cmp);
    *m
}

/// Smooths the boxes of `shapes` (observed shapes, any order) in place, per track and run of
/// consecutive frames (see the module docs). `measured[i]` is shape `i`'s detection box when
/// known (else its own box is the measurement); `is_mask[i]` says whether it has a mask (its
/// centroid then stays the mask's).
pub(super) fn smooth_boxes(
    shapes: &mut [TrackedShape],
    measured: &[Option<BBox>],
    is_mask: &[bool],
    config: &SmoothConfig,
) {
    if !config.enabled {
        return;
    }
    let mut by_id: BTreeMap<u64, Vec<usize>> = BTreeMap::new();
    for (i, s) in shapes.iter().enumerate() {
        by_id.entry(s.id).or_default().push(i);
    }
    let boxes: Vec<BBox> = shapes
        .iter()
        .enumerate()
        .map(|(i, s)| measured.get(i).copied().flatten().unwrap_or(s.bbox))
        .collect();
    let min_run = config.min_run.max(3) as usize;
    let mut runs = Vec::new();
    for (_, mut ix) in by_id {
        ix.sort_by_key(|&i| shapes[i].frame);
        let mut start = 0;
        for k in 1..=ix.len() {
            let ends = k == ix.len() || shapes[ix[k]].frame != shapes[ix[k - 1]].frame + 1;
            if ends {
                if k - start >= min_run {
                    runs.push(run_of(&ix[start..k], &boxes));
                }
                start = k;
            }
        }
    }
    if runs.is_empty() {
        return;
    }
    let best = choose(&mut runs, config);
    let (mut x, mut h) = (Vec::new(), Vec::new());
    for run in &runs {
        let mut c: [Vec<f64>; 4] = Default::default();
        for k in 0..4 {
            match best[k] {
                Some(j) => {
                    rts(
                        &run.z[k],
                        &run.s[k],
                        &run.infl[k],
                        RATIOS[j],
                        &mut x,
                        &mut h,
                    );
                    c[k] = std::mem::take(&mut x);
                }
                None => c[k] = run.z[k].clone(),
            }
        }
        for (t, &i) in run.index.iter().enumerate() {
            let (w, hh) = (c[2][t].max(0.0), c[3][t].max(0.0));
            let b = BBox::new(c[0][t] - w / 2.0, c[1][t] - hh / 2.0, w, hh);
            // Only a finite box is written; the detection stands otherwise.
            let b = if b.is_valid() { b } else { boxes[i] };
            shapes[i].bbox = b;
            if !is_mask.get(i).copied().unwrap_or(false) {
                shapes[i].centroid = b.center();
            }
        }
    }
}

/// A run over the shapes `index` (consecutive frames of one track), measured by `boxes`.
fn run_of(index: &[usize], boxes: &[BBox]) -> Run {
    let mut z: [Vec<f64>; 4] = Default::default();
    let mut s: [Vec<f64>; 4] = Default::default();
    for &i in index {
        // The online bank's coordinates and size scales (sizes floored at one pixel).
        let b = &boxes[i];
        for (k, (v, sc)) in coords(b).into_iter().zip(scales(b.w, b.h)).enumerate() {
            z[k].push(v);
            s[k].push(sc);
        }
    }
    let n = index.len();
    Run {
        index: index.to_vec(),
        z,
        s,
        infl: std::array::from_fn(|_| vec![1.0; n]),
    }
}

/// Per coordinate, the ratio (index into [`RATIOS`]) whose smoother best predicts left-out
/// detections over all `runs`, or `None` to keep the detections; sets the runs' Huber
/// weights on the way.
fn choose(runs: &mut [Run], config: &SmoothConfig) -> [Option<usize>; 4] {
    let (mut x, mut h) = (Vec::new(), Vec::new());
    let mut sigma: Option<[f64; 4]> = None;
    let mut best = [RATIOS.len() - 1; 4];
    let mut cv = [[0.0f64; RATIOS.len()]; 4];
    for pass in 0..=config.reweight {
        cv = [[0.0; RATIOS.len()]; 4];
        for run in runs.iter() {
            for (k, cvk) in cv.iter_mut().enumerate() {
                for (j, &ratio) in RATIOS.iter().enumerate() {
                    rts(&run.z[k], &run.s[k], &run.infl[k], ratio, &mut x, &mut h);
                    for t in 0..x.len() {
                        let e = loo(run.z[k][t], x[t], h[t], run.s[k][t]);
                        cvk[j] += match sigma {
                            Some(sg) => huber(e, config.huber * sg[k]),
                            None => e * e,
                        };
                    }
                }
            }
        }
        for k in 0..4 {
            best[k] = (0..RATIOS.len())
                .min_by(|&a, &b| cv[k][a].total_cmp(&cv[k][b]))
                .unwrap_or(RATIOS.len() - 1);
        }
        if pass == config.reweight {
            break;
        }
        // The robust spread of the chosen smoothers' left-out residuals, then each detection's
        // weight from its own residual.
        let mut sg = [0.0; 4];
        let mut res: [Vec<(usize, usize, f64)>; 4] = Default::default();
        for (r, run) in runs.iter().enumerate() {
            for (k, rk) in res.iter_mut().enumerate() {
                rts(
                    &run.z[k],
                    &run.s[k],
                    &run.infl[k],
                    RATIOS[best[k]],
                    &mut x,
                    &mut h,
                );
                for t in 0..x.len() {
                    rk.push((r, t, loo(run.z[k][t], x[t], h[t], run.s[k][t])));
                }
            }
        }
        for k in 0..4 {
            let mut a: Vec<f64> = res[k].iter().map(|&(_, _, e)| e.abs()).collect();
            sg[k] = MAD_TO_SIGMA * median(&mut a) + 1e-9;
            for &(r, t, e) in &res[k] {
                let u = e.abs() / (config.huber * sg[k]);
                runs[r].infl[k][t] = (u * u).max(1.0);
            }
        }
        sigma = Some(sg);
    }
    let last = RATIOS.len() - 1;
    let n: usize = runs.iter().map(|r| r.index.len()).sum();
    std::array::from_fn(|k| {
        let gain = cv[k][best[k]] <= config.min_gain * cv[k][last];
        // Detections that a path through their neighbours predicts to within a thousandth of
        // their size (exact ones) have nothing to smooth; the bank's comparison there is
        // rounding noise.
        let noisy = cv[k][last] > EXACT * EXACT * n as f64;
        (gain && noisy).then_some(best[k])
    })
}

/// The left-out residual of a detection `z` whose smoothed estimate is `x` with self-weight
/// `h`, relative to the size scale `s`.
fn loo(z: f64, x: f64, h: f64, s: f64) -> f64 {
    (z - x) / (1.0 - h).max(1e-6) / s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::TrackState;

    /// A deterministic pseudo-random sequence in [-1, 1].
    fn noise(i: u32) -> f64 {
        let x = (i as f64 * 12.9898).sin() * 43758.5453;
        2.0 * (x - x.floor()) - 1.0
    }

    fn shape(id: u64, frame: u32, b: BBox) -> TrackedShape {
        TrackedShape {
            id,
            frame,
            bbox: b,
            mask: None,
            centroid: b.center(),
            state: TrackState::Confirmed,
            score: 0.9,
            class: 1,
            cost: 0.0,
            det_index: Some(0),
            interpolated: false,
        }
    }

    /// Tracks on curving paths; `jitter` (share of the size) on every coordinate.
    fn tracks(jitter: f64) -> (Vec<TrackedShape>, Vec<BBox>) {
        let (mut shapes, mut truth) = (Vec::new(), Vec::new());
        for id in 1..=6u64 {
            for f in 1..=60u32 {
                let (ff, a) = (f as f64, id as f64);
                let x = 10.0 * a + 2.0 * ff + 30.0 * (ff / 4.0 + a).sin();
                let t = BBox::new(x, 50.0 + ff + 20.0 * (ff / 5.0).cos(), 40.0, 80.0);
                let k = (id as u32) * 1000 + f * 4;
                let b = BBox::new(
                    t.x + jitter * 40.0 * noise(k),
                    t.y + jitter * 80.0 * noise(k + 1),
                    t.w * (1.0 + jitter * noise(k + 2)),
                    t.h * (1.0 + jitter * noise(k + 3)),
                );
                shapes.push(shape(id, f, b));
                truth.push(t);
            }
        }
        (shapes, truth)
    }

    fn error(shapes: &[TrackedShape], truth: &[BBox]) -> f64 {
        shapes
            .iter()
            .zip(truth)
            .map(|(s, t)| 1.0 - s.bbox.iou(t))
            .sum::<f64>()
            / truth.len() as f64
    }

    #[test]
    fn jittery_detections_are_smoothed_towards_the_truth() {
        let (mut shapes, truth) = tracks(0.1);
        let before = error(&shapes, &truth);
        let n = shapes.len();
        smooth_boxes(
            &mut shapes,
            &vec![None; n],
            &vec![false; n],
            &SmoothConfig::default(),
        );
        let after = error(&shapes, &truth);
        assert!(after < 0.6 * before, "{before} -> {after}");
        // A box shape's centroid follows its box.
        assert!(shapes
            .iter()
            .all(|s| s.centroid.dist(s.bbox.center()) < 1e-9));
    }

    #[test]
    fn exact_detections_are_kept() {
        // No noise: no smoother predicts a left-out detection clearly better than the
        // lightest one, so every box stays the detection's.
        let (mut shapes, truth) = tracks(0.0);
        let n = shapes.len();
        smooth_boxes(
            &mut shapes,
            &vec![None; n],
            &vec![false; n],
            &SmoothConfig::default(),
        );
        for (s, t) in shapes.iter().zip(&truth) {
            assert!(s.bbox.iou(t) > 1.0 - 1e-9, "{:?} vs {t:?}", s.bbox);
        }
    }

    #[test]
    fn a_one_frame_outlier_does_not_drag_its_neighbours() {
        let (mut shapes, truth) = tracks(0.1);
        // Frame 30 of track 1: a sliver (a clipped mask) a tenth of the height.
        let i = shapes
            .iter()
            .position(|s| s.id == 1 && s.frame == 30)
            .unwrap();
        shapes[i].bbox.h = 8.0;
        let n = shapes.len();
        let run = |reweight: u32| {
            let mut v = shapes.clone();
            let config = SmoothConfig {
                reweight,
                ..SmoothConfig::default()
            };
            smooth_boxes(&mut v, &vec![None; n], &vec![false; n], &config);
            // The neighbours' height error.
            v.iter()
                .zip(&truth)
                .filter(|(s, _)| s.id == 1 && (s.frame == 29 || s.frame == 31))
                .map(|(s, t)| (s.bbox.h - t.h).abs())
                .fold(0.0f64, f64::max)
        };
        let (robust, plain) = (run(2), run(0));
        assert!(robust < 0.5 * plain, "{robust} vs {plain}");
        assert!(robust < 6.0, "{robust}");
    }

    #[test]
    fn detection_boxes_are_the_measurements_and_masks_keep_their_centroid() {
        let (shapes, truth) = tracks(0.1);
        let n = shapes.len();
        // The shapes carry a box somewhere else (a causal estimate); the detections are given.
        let measured: Vec<Option<BBox>> = shapes.iter().map(|s| Some(s.bbox)).collect();
        let mut moved: Vec<TrackedShape> = shapes
            .iter()
            .map(|s| {
                let mut m = s.clone();
                m.bbox.x += 500.0;
                m.centroid.x = -7.0;
                m
            })
            .collect();
        smooth_boxes(
            &mut moved,
            &measured,
            &vec![true; n],
            &SmoothConfig::default(),
        );
        assert!(error(&moved, &truth) < 0.6 * error(&shapes, &truth));
        assert!(moved.iter().all(|s| s.centroid.x == -7.0));
    }

    #[test]
    fn short_runs_and_disabled_smoothing_change_nothing() {
        let (mut shapes, _) = tracks(0.1);
        shapes.retain(|s| s.frame % 3 != 0);
        let n = shapes.len();
        let before = shapes.clone();
        let config = SmoothConfig {
            min_run: 3,
            ..SmoothConfig::default()
        };
        smooth_boxes(&mut shapes, &vec![None; n], &vec![false; n], &config);
        assert_eq!(shapes, before, "runs of two frames are left as they are");
        let (mut shapes, _) = tracks(0.1);
        let before = shapes.clone();
        let off = SmoothConfig {
            enabled: false,
            ..SmoothConfig::default()
        };
        let n = shapes.len();
        smooth_boxes(&mut shapes, &vec![None; n], &[], &off);
        assert_eq!(shapes, before);
    }
}
