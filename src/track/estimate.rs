//! The box a track reports: its detections smoothed only as far as smoothing is shown to help
//! on this sequence.
//!
//! A detector's box jitters around the object. A filtered box is closer to the truth when
//! that jitter is large against how unpredictably the object moves (a jittery detector on
//! walking people), and lags behind it when the object moves fast and the detector is precise
//! (a 5 fps driving video, athletes under a panning camera) — and real detectors' errors
//! persist from frame to frame, which no smoothing removes (MOT15's published detections
//! against their ground truth: lag-1 autocorrelation of the box error 0.1–0.6 per sequence
//! and coordinate, median 0.39). Which case holds differs by detector, frame rate and scene,
//! so no fixed smoothing suits every video, and the tracker measures it:
//!
//! - each track runs, per coordinate (centre x, centre y, width, height), a bank of
//!   local-linear-trend Kalman filters that differ only in the ratio of process to measurement
//!   noise ([`RATIOS`], from strong smoothing to following the detections), with noise
//!   proportional to the box size as in the association filter ([`crate::motion`]); the
//!   association filter's own corrected box (what SORT and ByteTrack report: one constant-
//!   velocity model over the whole box) is one more candidate, for box detections (box
//!   cells of the robustness grid: mean online HOTA 55.55 → 56.03, 26 of 33 cells equal or
//!   better, no dataset worse on average; a mask track's filter follows the amodal whole
//!   shape, not the detection's box, and is not a candidate);
//! - the tracker scores every filter, and the raw detection, against what came next: once a
//!   track has been matched in frames `t`, `t+1` and `t+2`, its estimate at `t` is compared with
//!   `2·z(t+1) − z(t+2)`, the next two detections extrapolated back to `t` (whose noise is
//!   independent of the estimate's when detection errors are independent, and which favours
//!   the raw detection when they persist — the cautious direction);
//! - a track reports, per coordinate, the candidate with the least squared error (relative to
//!   the box size) summed over this sequence so far — the raw detection until
//!   [`MIN_SCORED`] comparisons have been made.
//!
//! A mask track reports its mask as detected and this estimate as its box: a weak
//! segmenter's ragged, eroded, split or merged masks give boxes as noisy as any detector's
//! (mask cells of the robustness grid: mean HOTA 71.10 → 71.88, online and offline; a clean
//! segmenter's masks leave the raw box chosen).
//!
//! The association keeps its own filter ([`crate::motion::BoxKalman`], whose noise the
//! robustness grid chose for matching); this estimate only decides the reported box. On the
//! robustness grid it gains on MOT15's real detections (+0.5 HOTA online), is neutral on
//! BDD100K's (−0.2), and gains 1–4 on the detector models, whose box errors are drawn afresh
//! every frame (`tests/data/quality/README.md`).

use crate::frame::BBox;

/// Process-to-measurement noise ratios of the bank (white-noise acceleration over unit
/// measurement noise, both per frame and relative to the box size), log-spaced from strong
/// smoothing (steady-state gain 0.22) to following the detections (gain 0.97).
pub(crate) const RATIOS: [f64; 9] = [0.001, 0.004, 0.016, 0.064, 0.25, 1.0, 4.0, 16.0, 64.0];

/// Candidates: the filters, the raw detection, then the association filter's corrected box.
const CANDIDATES: usize = RATIOS.len() + 2;

/// The raw detection's index among the candidates.
const RAW: usize = RATIOS.len();

/// The association filter's index among the candidates: its corrected box (what SORT and
/// ByteTrack report) is one more smoother, with a constant-velocity model over the box's
/// centre, area and aspect instead of per coordinate, and the association's noise.
const FILTER: usize = RATIOS.len() + 1;

/// Comparisons (per coordinate) the tracker gathers before it reports anything but the raw
/// detection.
pub(crate) const MIN_SCORED: f64 = 30.0;

/// Matches of a track before its estimates are scored: the first ones mostly measure the
/// filters' start from rest, not the sequence's noise.
const WARMUP: u32 = 3;

/// Least IoU between the smoothed box and the detection it smooths: below, the detection is
/// reported (the usual match threshold of the metrics: a box further off would not count as
/// the object anyway).
const MIN_AGREEMENT: f64 = 0.5;

/// Sizes below this count as this (pixels), so no variance is ever zero.
const MIN_SIZE: f64 = 1.0;

/// One coordinate's local-linear-trend filter: position and velocity per frame.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Trend {
    /// Position and velocity.
    pub(crate) x: [f64; 2],
    /// Covariance `[p00, p01, p11]`.
    pub(crate) p: [f64; 3],
}

impl Trend {
    /// At `z` with a velocity prior of one size `s` per frame (unknown; two matches fix it).
    pub(crate) fn new(z: f64, s: f64) -> Self {
        Trend {
            x: [z, 0.0],
            p: [s * s, 0.0, s * s],
        }
    }

    /// One frame ahead under white-noise acceleration of variance `q`.
    pub(crate) fn predict(&mut self, q: f64) {
        let [p00, p01, p11] = self.p;
        self.x[0] += self.x[1];
        self.p = [
            p00 + 2.0 * p01 + p11 + q / 4.0,
            p01 + p11 + q / 2.0,
            p11 + q,
        ];
    }

    /// Corrects with `z` of measurement variance `r`.
    pub(crate) fn update(&mut self, z: f64, r: f64) {
        let [p00, p01, p11] = self.p;
        let s = p00 + r;
        let nu = z - self.x[0];
        let (k0, k1) = (p00 / s, p01 / s);
        self.x[0] += k0 * nu;
        self.x[1] += k1 * nu;
        self.p = [(1.0 - k0) * p00, (1.0 - k0) * p01, p11 - k1 * p01];
    }
}

/// The coordinates of a box: centre x, centre y, width, height.
pub(crate) fn coords(b: &BBox) -> [f64; 4] {
    let c = b.center();
    [c.x, c.y, b.w, b.h]
}

/// The size scale of each coordinate: width for centre x and width, height for the others.
pub(crate) fn scales(w: f64, h: f64) -> [f64; 4] {
    let (w, h) = (w.max(MIN_SIZE), h.max(MIN_SIZE));
    [w, h, w, h]
}

/// One update's coordinates and every candidate's estimate of them.
type Estimates = ([f64; 4], [[f64; CANDIDATES]; 4]);

/// A track's bank of filters (see the module docs).
#[derive(Debug, Clone)]
pub(crate) struct BoxEstimate {
    bank: [[Trend; RATIOS.len()]; 4],
    /// Size scales of the last measurement.
    scale: [f64; 4],
    /// Matches so far.
    updates: u32,
    /// The last two consecutive updates, oldest first (cleared by a frame without one).
    recent: [Option<Estimates>; 2],
}

impl BoxEstimate {
    /// A bank at rest on the box `z`.
    pub(crate) fn new(z: &BBox) -> Self {
        let (c, s) = (coords(z), scales(z.w, z.h));
        BoxEstimate {
            bank: std::array::from_fn(|k| [Trend::new(c[k], s[k]); RATIOS.len()]),
            scale: s,
            updates: 1,
            recent: [None, None],
        }
    }

    /// One frame ahead.
    pub(crate) fn predict(&mut self) {
        for (k, bank) in self.bank.iter_mut().enumerate() {
            let s2 = self.scale[k] * self.scale[k];
            for (f, ratio) in bank.iter_mut().zip(RATIOS) {
                f.predict(ratio * s2);
            }
        }
    }

    /// A frame passed without a match: the next comparisons need three consecutive ones.
    pub(crate) fn missed(&mut self) {
        self.recent = [None, None];
    }

    /// Moves every filter's position by `(dx, dy)` (the camera moved, see
    /// [`super::camera`]).
    pub(crate) fn translate(&mut self, dx: f64, dy: f64) {
        for (k, d) in [(0, dx), (1, dy)] {
            for f in &mut self.bank[k] {
                f.x[0] += d;
            }
        }
        self.recent = [None, None];
    }

    /// Candidate `j`'s estimate of coordinate `k`, given the raw detection's coordinates and
    /// the association filter's (`None`, or not finite: the raw detection stands in).
    fn candidate(&self, k: usize, j: usize, raw: &[f64; 4], filter: Option<&[f64; 4]>) -> f64 {
        match j {
            RAW => raw[k],
            FILTER => filter.map_or(raw[k], |a| if a[k].is_finite() { a[k] } else { raw[k] }),
            _ => self.bank[k][j].x[0],
        }
    }

    /// Corrects every filter with the detection box `z` (`filter`: the association filter's
    /// box after its own correction, when it is a candidate); once the track is past its
    /// warm-up, the estimates made two matches ago are scored against this one and the last
    /// (`fit`).
    pub(crate) fn update(&mut self, z: &BBox, filter: Option<&BBox>, fit: &mut NoiseFit) {
        let (c, s) = (coords(z), scales(z.w, z.h));
        if !c.iter().all(|v| v.is_finite()) {
            return;
        }
        self.scale = s;
        self.updates = self.updates.saturating_add(1);
        for (k, bank) in self.bank.iter_mut().enumerate() {
            for f in bank.iter_mut() {
                f.update(c[k], s[k] * s[k]);
            }
        }
        let a = filter.map(coords);
        let now: [[f64; CANDIDATES]; 4] =
            std::array::from_fn(|k| std::array::from_fn(|j| self.candidate(k, j, &c, a.as_ref())));
        if let ([Some((_, then)), Some((z1, _))], true) = (&self.recent, self.updates > WARMUP) {
            for k in 0..4 {
                // The next two detections extrapolated back to the estimate's frame.
                let reference = 2.0 * z1[k] - c[k];
                fit.score(k, &then[k], reference, s[k]);
            }
        }
        self.recent = [self.recent[1].take(), Some((c, now))];
    }

    /// The reported box: per coordinate, the candidate `fit` prefers, from the estimates of
    /// the last update (`last` is the raw detection, `filter` the association filter's box
    /// when it is a candidate); the raw detection while the track is in its warm-up (the
    /// filters started from rest and still lag).
    pub(crate) fn current(&self, fit: &NoiseFit, last: &BBox, filter: Option<&BBox>) -> BBox {
        let best = fit.best();
        // The detection itself, exactly (not rebuilt from its centre and size).
        if self.updates <= WARMUP || best == [RAW; 4] {
            return *last;
        }
        let (raw, a) = (coords(last), filter.map(coords));
        let v: [f64; 4] = std::array::from_fn(|k| self.candidate(k, best[k], &raw, a.as_ref()));
        let (w, h) = (v[2].max(0.0), v[3].max(0.0));
        let b = BBox::new(v[0] - w / 2.0, v[1] - h / 2.0, w, h);
        // A detection that jumped away from every smoother (a pose change, an occluder's
        // edge, a different object taken) is more likely right than a lagging estimate.
        if b.iou(last) < MIN_AGREEMENT {
            return *last;
        }
        b
    }
}

/// How well every candidate has agreed with what came next, per coordinate, over a sequence.
#[derive(Debug, Clone, Default)]
pub(crate) struct NoiseFit {
    /// Σ squared error (relative to the box size) per coordinate and candidate.
    error: [[f64; CANDIDATES]; 4],
    /// Comparisons per coordinate.
    n: [f64; 4],
}

impl NoiseFit {
    fn score(&mut self, k: usize, estimates: &[f64; CANDIDATES], reference: f64, size: f64) {
        let s2 = size * size;
        if !(reference.is_finite() && s2 > 0.0) {
            return;
        }
        for (e, x) in self.error[k].iter_mut().zip(estimates) {
            let d = x - reference;
            *e += d * d / s2;
        }
        self.n[k] += 1.0;
    }

    /// Per coordinate, the candidate with the least error so far (the raw detection until
    /// [`MIN_SCORED`] comparisons).
    pub(crate) fn best(&self) -> [usize; 4] {
        std::array::from_fn(|k| {
            if self.n[k] < MIN_SCORED {
                return RAW;
            }
            (0..CANDIDATES)
                .min_by(|&a, &b| self.error[k][a].total_cmp(&self.error[k][b]))
                .unwrap_or(RAW)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic pseudo-random sequence in [-1, 1].
    fn noise(i: u32) -> f64 {
        let x = (i as f64 * 12.9898).sin() * 43758.5453;
        2.0 * (x - x.floor()) - 1.0
    }

    /// Five tracks of 80 frames: a path whose velocity changes by `turn`, detection jitter
    /// `jitter` (share of the size), drawn afresh every frame or persisting (`memory`).
    /// Returns the choice and the mean absolute error of the reported centre x.
    fn run(jitter: f64, turn: f64, memory: f64) -> ([usize; 4], f64, f64) {
        let mut fit = NoiseFit::default();
        let (mut err_report, mut err_raw, mut n) = (0.0, 0.0, 0.0);
        for track in 0..5u32 {
            let b0 = BBox::new(100.0, 100.0, 50.0, 100.0);
            let mut e = BoxEstimate::new(&b0);
            let mut err = [0.0f64; 4];
            for t in 1..80u32 {
                e.predict();
                let tf = t as f64;
                let x = 100.0 + 2.0 * tf + turn * (tf / 6.0 + track as f64).sin() * 20.0;
                let k = track * 1000 + t;
                for (c, e) in err.iter_mut().enumerate() {
                    *e = memory * *e + (1.0 - memory * memory).sqrt() * noise(k + 7 * c as u32);
                }
                let z = BBox::new(
                    x - 25.0 + jitter * 50.0 * err[0],
                    100.0 + jitter * 100.0 * err[1],
                    50.0 * (1.0 + jitter * err[2]),
                    100.0 * (1.0 + jitter * err[3]),
                );
                e.update(&z, None, &mut fit);
                if t > 40 {
                    err_report += (e.current(&fit, &z, None).center().x - x).abs();
                    err_raw += (z.center().x - x).abs();
                    n += 1.0;
                }
            }
        }
        (fit.best(), err_report / n, err_raw / n)
    }

    #[test]
    fn jittery_boxes_on_steady_motion_are_smoothed() {
        let (best, report, raw) = run(0.1, 0.0, 0.0);
        assert!(best.iter().all(|&j| j <= 2), "{best:?}");
        // The reference the candidates are scored against (two later detections,
        // extrapolated) is noisier than the estimates it ranks, so over these 400 comparisons
        // the choice is among the smoothing filters but not always the strongest one.
        assert!(report < 0.8 * raw, "reported {report} vs raw {raw}");
    }

    #[test]
    fn precise_boxes_on_turning_motion_are_followed() {
        let (best, report, raw) = run(0.002, 1.0, 0.0);
        assert!(best[0] >= 6, "{best:?}");
        assert!(report <= 1.2 * raw + 0.01, "reported {report} vs raw {raw}");
    }

    #[test]
    fn the_association_filter_is_chosen_when_it_agrees_best() {
        // The association filter given here knows the true box (an ideal smoother); the bank
        // smooths jittery detections of a turning path less well, so the fit prefers it.
        let mut fit = NoiseFit::default();
        let (mut err_report, mut err_raw) = (0.0, 0.0);
        let mut e = BoxEstimate::new(&BBox::new(100.0, 100.0, 50.0, 100.0));
        for t in 1..200u32 {
            e.predict();
            let tf = t as f64;
            let x = 100.0 + 2.0 * tf + (tf / 6.0).sin() * 20.0;
            let truth = BBox::new(x - 25.0, 100.0, 50.0, 100.0);
            let z = BBox::new(
                x - 25.0 + 5.0 * noise(t),
                100.0 + 10.0 * noise(t + 500),
                50.0,
                100.0,
            );
            e.update(&z, Some(&truth), &mut fit);
            if t > 100 {
                err_report += (e.current(&fit, &z, Some(&truth)).center().x - x).abs();
                err_raw += (z.center().x - x).abs();
            }
        }
        assert_eq!(fit.best()[0], FILTER, "{:?}", fit.best());
        assert!(err_report < 0.1 * err_raw, "{err_report} vs {err_raw}");
    }

    #[test]
    fn nothing_is_smoothed_before_enough_comparisons() {
        let fit = NoiseFit::default();
        assert_eq!(fit.best(), [RAW; 4]);
        let b = BBox::new(10.0, 20.0, 30.0, 40.0);
        let e = BoxEstimate::new(&BBox::new(0.0, 0.0, 30.0, 40.0));
        assert_eq!(e.current(&fit, &b, None), b);
    }
}
