//! Robust fitting: a seeded RANSAC ([`ransac`]) that scores models by MSAC and refits the
//! consensus set by least squares.

use super::{
    check_count, check_finite, Transform, TransformError, TransformKind, DEFAULT_MIN_RELATIVE_AREA,
};
use crate::frame::Point;
use rand::seq::index::sample;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256Plus;
use serde::{Deserialize, Serialize};

#[cfg(doc)]
use super::relative_area;

/// Settings of [`ransac`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RansacConfig {
    /// Largest residual `|T(source) − target|` (target units) for a match to count as an inlier.
    pub threshold: f64,
    /// Upper bound on sampling iterations (the adaptive stop usually ends much earlier).
    pub max_iterations: usize,
    /// Probability of having drawn at least one all-inlier sample before stopping early.
    pub confidence: f64,
    /// Seed of the sampling RNG; equal seeds give equal results.
    pub seed: u64,
    /// Minimum [`relative_area`] of an affine sample (see [`DEFAULT_MIN_RELATIVE_AREA`]).
    pub min_relative_area: f64,
}

impl Default for RansacConfig {
    fn default() -> Self {
        Self {
            threshold: 3.0,
            max_iterations: 500,
            confidence: 0.999,
            seed: 0x5eed_5eed,
            min_relative_area: DEFAULT_MIN_RELATIVE_AREA,
        }
    }
}

impl RansacConfig {
    fn validate(&self) -> Result<(), TransformError> {
        if !(self.threshold.is_finite() && self.threshold > 0.0) {
            return Err(TransformError::InvalidConfig {
                field: "threshold",
                reason: "must be finite and > 0",
            });
        }
        if self.max_iterations == 0 {
            return Err(TransformError::InvalidConfig {
                field: "max_iterations",
                reason: "must be ≥ 1",
            });
        }
        if !(self.confidence > 0.0 && self.confidence < 1.0) {
            return Err(TransformError::InvalidConfig {
                field: "confidence",
                reason: "must be in (0, 1)",
            });
        }
        if !(self.min_relative_area.is_finite() && self.min_relative_area >= 0.0) {
            return Err(TransformError::InvalidConfig {
                field: "min_relative_area",
                reason: "must be finite and ≥ 0",
            });
        }
        Ok(())
    }
}

/// Result of [`ransac`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RansacFit {
    /// The model refitted by least squares on the consensus set.
    pub transform: Transform,
    /// Indices (into the input matches) of the inliers of `transform`.
    pub inliers: Vec<usize>,
    /// Root-mean-square residual over the inliers (0 when there are none).
    pub rms: f64,
    /// Sampling iterations actually run.
    pub iterations: usize,
}

/// Truncated squared residuals (MSAC): scores a model by how well it explains inliers as well
/// as how many there are, which separates models that plain inlier counting ties.
fn msac_score(t: &Transform, matches: &[(Point, Point)], thr2: f64) -> f64 {
    matches
        .iter()
        .map(|(s, q)| t.apply(*s).dist2(*q).min(thr2))
        .sum()
}

fn inliers_of(t: &Transform, matches: &[(Point, Point)], thr2: f64) -> (Vec<usize>, f64) {
    let mut idx = Vec::new();
    let mut sum = 0.0;
    for (i, (s, q)) in matches.iter().enumerate() {
        let r2 = t.apply(*s).dist2(*q);
        if r2 <= thr2 {
            idx.push(i);
            sum += r2;
        }
    }
    let rms = if idx.is_empty() {
        0.0
    } else {
        (sum / idx.len() as f64).sqrt()
    };
    (idx, rms)
}

/// Robust fit of model `kind` to matches that contain outliers.
///
/// Draws minimal samples with a [`Xoshiro256Plus`] seeded from `cfg.seed`, scores each model
/// by MSAC, stops when `cfg.confidence` is reached (the standard `log(1−p)/log(1−wᵐ)` bound on
/// the observed inlier ratio `w`) or after `cfg.max_iterations`, then refits by least squares on
/// the consensus set (repeated while the consensus improves). Degenerate samples (coincident or
/// collinear sources) are skipped. With exactly the minimal number of matches the model is
/// fitted directly.
pub fn ransac(
    kind: TransformKind,
    matches: &[(Point, Point)],
    cfg: &RansacConfig,
) -> Result<RansacFit, TransformError> {
    cfg.validate()?;
    check_count(matches, kind)?;
    check_finite(matches)?;
    let m = kind.min_matches();
    let n = matches.len();
    let thr2 = cfg.threshold * cfg.threshold;
    let fit = |sample: &[(Point, Point)]| Transform::fit(kind, sample, cfg.min_relative_area);

    let mut best: Option<(Transform, f64)> = None;
    let mut iterations = 0;
    if n == m {
        best = Some((fit(matches)?, 0.0));
    } else {
        let mut rng = Xoshiro256Plus::seed_from_u64(cfg.seed);
        let mut needed = cfg.max_iterations;
        let mut sample_buf = Vec::with_capacity(m);
        while iterations < needed.min(cfg.max_iterations) {
            iterations += 1;
            sample_buf.clear();
            sample_buf.extend(sample(&mut rng, n, m).into_iter().map(|i| matches[i]));
            let Ok(t) = fit(&sample_buf) else { continue };
            let score = msac_score(&t, matches, thr2);
            if best.as_ref().is_none_or(|(_, s)| score < *s) {
                let count = matches
                    .iter()
                    .filter(|(s, q)| t.apply(*s).dist2(*q) <= thr2)
                    .count();
                best = Some((t, score));
                let w = count as f64 / n as f64;
                let p_good = w.powi(m as i32);
                needed = if p_good >= 1.0 {
                    iterations
                } else if p_good <= 0.0 {
                    cfg.max_iterations
                } else {
                    let k = (1.0 - cfg.confidence).ln() / (1.0 - p_good).ln();
                    if k.is_finite() {
                        (k.ceil() as usize).max(1)
                    } else {
                        cfg.max_iterations
                    }
                };
            }
        }
    }
    let Some((mut t, mut score)) = best else {
        return Err(TransformError::NoConsensus { iterations });
    };
    // Local optimisation: a least-squares refit on the consensus set is far more accurate than
    // the minimal-sample model; repeat while it keeps improving the robust score.
    for _ in 0..4 {
        let (idx, _) = inliers_of(&t, matches, thr2);
        if idx.len() < m {
            break;
        }
        let subset: Vec<(Point, Point)> = idx.iter().map(|&i| matches[i]).collect();
        let Ok(refit) = fit(&subset) else { break };
        let s = msac_score(&refit, matches, thr2);
        if s <= score {
            let improved = s < score - 1e-12 * (1.0 + score);
            t = refit;
            score = s;
            if !improved {
                break;
            }
        } else {
            break;
        }
    }
    let (inliers, rms) = inliers_of(&t, matches, thr2);
    Ok(RansacFit {
        transform: t,
        inliers,
        rms,
        iterations,
    })
}
