//! 2-D transforms between two shapes' frames, their least-squares fits, a seeded RANSAC
//! wrapper, and a nearest-point index to measure how well a transform aligns two point sets.
//!
//! A match is a pair `(source, target)`; a fitted transform maps each source point onto its
//! target. Three models, from cheapest to most general:
//!
//! - [`Translation`]: 1 match; the fallback when nothing better can be fitted.
//! - [`Similarity`]: scale, rotation, translation (thesis eq. 28–37); 2 matches; fitted in
//!   closed form (Umeyama's least squares, which in 2-D reduces to complex division).
//! - [`Affine`]: 6 parameters; 3 non-collinear matches. Collinearity is tested with a
//!   *relative area* (see [`relative_area`]) rather than the thesis' exact zero of eq. 26,
//!   because with pixel noise an almost-collinear sample gives a wildly wrong shear.
//!
//! Everything is `f64`. Nothing here panics on user data: bad input is a [`TransformError`].

use crate::frame::Point;
use rand::seq::index::sample;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256Plus;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Default minimum [`relative_area`] of an affine fit's source points. A 100-pixel base with
/// a 2-pixel apex height scores about 0.046: at that point a pixel of noise tilts the fit.
pub const DEFAULT_MIN_RELATIVE_AREA: f64 = 0.05;

/// Errors from fitting, inverting or robustly estimating a transform.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum TransformError {
    /// Fewer matches than the model's minimal sample.
    #[error("{kind:?} fit needs at least {needed} matches, got {got}")]
    TooFewMatches {
        /// The model being fitted.
        kind: TransformKind,
        /// Matches needed.
        needed: usize,
        /// Matches given.
        got: usize,
    },
    /// A match has a NaN or infinite coordinate.
    #[error("match {index} has a non-finite coordinate")]
    NonFinite {
        /// Index of the offending match.
        index: usize,
    },
    /// The source (or target) points all coincide, so scale and rotation are undefined.
    #[error("the {which} points coincide (spread {spread:.3e})")]
    Coincident {
        /// `"source"` or `"target"`.
        which: &'static str,
        /// Root-mean-square distance of the points to their mean.
        spread: f64,
    },
    /// The source points are (nearly) collinear, so an affine fit is undetermined.
    #[error("source points are collinear: relative area {relative_area:.3e} < {threshold:.3e}")]
    Collinear {
        /// The points' [`relative_area`].
        relative_area: f64,
        /// The threshold it had to reach.
        threshold: f64,
    },
    /// The linear part is singular.
    #[error("transform is not invertible (determinant {det:.3e})")]
    NotInvertible {
        /// Determinant of the linear part.
        det: f64,
    },
    /// Every RANSAC sample was degenerate.
    #[error("RANSAC found no non-degenerate model in {iterations} iterations")]
    NoConsensus {
        /// Iterations run.
        iterations: usize,
    },
    /// A configuration value is out of range.
    #[error("invalid configuration: {field} {reason}")]
    InvalidConfig {
        /// The field.
        field: &'static str,
        /// What is wrong with it.
        reason: &'static str,
    },
}

/// Which transform model to fit.
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum TransformKind {
    /// Translation only (2 degrees of freedom).
    Translation,
    /// Uniform scale, rotation and translation (4 degrees of freedom).
    Similarity,
    /// General affine map (6 degrees of freedom).
    Affine,
}

impl TransformKind {
    /// Size of the minimal sample that determines the model.
    pub const fn min_matches(self) -> usize {
        match self {
            TransformKind::Translation => 1,
            TransformKind::Similarity => 2,
            TransformKind::Affine => 3,
        }
    }
}

/// A pure translation `p ↦ p + (dx, dy)`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Translation {
    /// Horizontal shift.
    pub dx: f64,
    /// Vertical shift.
    pub dy: f64,
}

/// A similarity `p ↦ s·R(θ)·p + t`.
///
/// In the thesis' notation (eq. 32–33) `x' = a·x − b·y + c`, `y' = b·x + a·y + d` with
/// `a = s·cos θ`, `b = s·sin θ` (the thesis' α of eq. 28 is −θ, and its eq. 37 `tanh⁻¹`
/// should read `atan2`: `θ = atan2(b, a)`). In image coordinates (y down) a positive `θ` turns the x axis
/// towards +y, i.e. clockwise on screen.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Similarity {
    /// Uniform scale factor (> 0 for a fitted transform).
    pub scale: f64,
    /// Rotation angle in radians.
    pub angle: f64,
    /// Horizontal translation.
    pub tx: f64,
    /// Vertical translation.
    pub ty: f64,
}

impl Default for Similarity {
    fn default() -> Self {
        Self {
            scale: 1.0,
            angle: 0.0,
            tx: 0.0,
            ty: 0.0,
        }
    }
}

/// An affine map `x' = a·x + b·y + tx`, `y' = c·x + d·y + ty`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Affine {
    /// Row 1, column 1 of the linear part.
    pub a: f64,
    /// Row 1, column 2 of the linear part.
    pub b: f64,
    /// Row 2, column 1 of the linear part.
    pub c: f64,
    /// Row 2, column 2 of the linear part.
    pub d: f64,
    /// Horizontal translation.
    pub tx: f64,
    /// Vertical translation.
    pub ty: f64,
}

impl Default for Affine {
    fn default() -> Self {
        Self {
            a: 1.0,
            b: 0.0,
            c: 0.0,
            d: 1.0,
            tx: 0.0,
            ty: 0.0,
        }
    }
}

/// Any of the three models, so that callers can switch model by configuration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Transform {
    /// See [`Translation`].
    Translation(Translation),
    /// See [`Similarity`].
    Similarity(Similarity),
    /// See [`Affine`].
    Affine(Affine),
}

impl Default for Transform {
    fn default() -> Self {
        Transform::Translation(Translation::default())
    }
}

fn check_finite(matches: &[(Point, Point)]) -> Result<(), TransformError> {
    match matches.iter().position(|(s, t)| {
        !(s.x.is_finite() && s.y.is_finite() && t.x.is_finite() && t.y.is_finite())
    }) {
        Some(index) => Err(TransformError::NonFinite { index }),
        None => Ok(()),
    }
}

fn check_count(matches: &[(Point, Point)], kind: TransformKind) -> Result<(), TransformError> {
    let needed = kind.min_matches();
    if matches.len() < needed {
        return Err(TransformError::TooFewMatches {
            kind,
            needed,
            got: matches.len(),
        });
    }
    Ok(())
}

/// Means of the source and target points (non-empty input).
fn means(matches: &[(Point, Point)]) -> (Point, Point) {
    let n = matches.len().max(1) as f64;
    let (mut s, mut t) = (Point::default(), Point::default());
    for (a, b) in matches {
        s = s + *a;
        t = t + *b;
    }
    (s * (1.0 / n), t * (1.0 / n))
}

/// Whether a spread (RMS distance to the mean) is negligible next to the coordinates' size,
/// which is what matters in floating point.
fn negligible_spread(spread: f64, centre: Point) -> bool {
    spread <= 1e-9 * (1.0 + centre.x.abs().max(centre.y.abs()))
}

/// How far a point set is from lying on a line, in `[0, 1]`.
///
/// With `S` the points' scatter matrix (sum of `(p − p̄)(p − p̄)ᵀ`) this is
/// `2·√det S / tr S`: the area of the scatter ellipse relative to the circle with the same
/// total spread. It is 1 for an equilateral triangle (or any isotropic set), 0 for collinear
/// points, and scale-free. For three points `det S = (4/3)·area²`, so it is the thesis'
/// triangle-area test (eq. 26) made relative. Returns 0 for fewer than 3 points or when the
/// points coincide or are not finite.
pub fn relative_area(points: &[Point]) -> f64 {
    let (sxx, sxy, syy) = scatter(points.iter().copied());
    relative_area_of(sxx, sxy, syy, points.len())
}

fn relative_area_of(sxx: f64, sxy: f64, syy: f64, n: usize) -> f64 {
    let tr = sxx + syy;
    if n < 3 || !tr.is_finite() || tr <= 0.0 {
        return 0.0;
    }
    let det = (sxx * syy - sxy * sxy).max(0.0);
    (2.0 * det.sqrt() / tr).clamp(0.0, 1.0)
}

/// Scatter matrix entries `(Σdx², Σdx·dy, Σdy²)` around the mean.
fn scatter(points: impl Iterator<Item = Point> + Clone) -> (f64, f64, f64) {
    let (mut n, mut m) = (0usize, Point::default());
    for p in points.clone() {
        n += 1;
        m = m + p;
    }
    if n == 0 {
        return (0.0, 0.0, 0.0);
    }
    m = m * (1.0 / n as f64);
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for p in points {
        let d = p - m;
        sxx += d.x * d.x;
        sxy += d.x * d.y;
        syy += d.y * d.y;
    }
    (sxx, sxy, syy)
}

impl Translation {
    /// Applies the translation.
    #[inline]
    pub fn apply(&self, p: Point) -> Point {
        Point::new(p.x + self.dx, p.y + self.dy)
    }

    /// The opposite shift (always exists).
    pub fn inverse(&self) -> Translation {
        Translation {
            dx: -self.dx,
            dy: -self.dy,
        }
    }

    /// Least-squares fit: the mean displacement from source to target (≥ 1 match).
    pub fn fit(matches: &[(Point, Point)]) -> Result<Self, TransformError> {
        check_count(matches, TransformKind::Translation)?;
        check_finite(matches)?;
        let (ms, mt) = means(matches);
        Ok(Translation {
            dx: mt.x - ms.x,
            dy: mt.y - ms.y,
        })
    }

    /// The same map as an [`Affine`].
    pub fn to_affine(&self) -> Affine {
        Affine {
            tx: self.dx,
            ty: self.dy,
            ..Affine::default()
        }
    }
}

impl Similarity {
    /// Applies the similarity.
    #[inline]
    pub fn apply(&self, p: Point) -> Point {
        let (s, c) = self.angle.sin_cos();
        let (a, b) = (self.scale * c, self.scale * s);
        Point::new(a * p.x - b * p.y + self.tx, b * p.x + a * p.y + self.ty)
    }

    /// The inverse similarity; fails when the scale is not positive and finite.
    pub fn inverse(&self) -> Result<Similarity, TransformError> {
        if !(self.scale.is_finite() && self.scale > 0.0 && self.angle.is_finite()) {
            return Err(TransformError::NotInvertible {
                det: self.scale * self.scale,
            });
        }
        let inv = Similarity {
            scale: 1.0 / self.scale,
            angle: -self.angle,
            tx: 0.0,
            ty: 0.0,
        };
        let t = inv.apply(Point::new(self.tx, self.ty));
        Ok(Similarity {
            tx: -t.x,
            ty: -t.y,
            ..inv
        })
    }

    /// Least-squares fit from ≥ 2 matches (Umeyama 1991, without reflections).
    ///
    /// In 2-D the rotation-and-scale part `[a −b; b a]` minimising `Σ|q − (Ap + t)|²` over the
    /// centred points is `(a + ib) = Σ conj(p)·q / Σ|p|²`, which equals Umeyama's SVD solution
    /// whenever it has positive determinant — always, since reflections are excluded.
    pub fn fit(matches: &[(Point, Point)]) -> Result<Self, TransformError> {
        check_count(matches, TransformKind::Similarity)?;
        check_finite(matches)?;
        let (ms, mt) = means(matches);
        let n = matches.len() as f64;
        let (mut var, mut var_t, mut re, mut im) = (0.0, 0.0, 0.0, 0.0);
        for (s, t) in matches {
            let (p, q) = (*s - ms, *t - mt);
            var += p.x * p.x + p.y * p.y;
            var_t += q.x * q.x + q.y * q.y;
            re += p.x * q.x + p.y * q.y;
            im += p.x * q.y - p.y * q.x;
        }
        let spread = (var / n).sqrt();
        if negligible_spread(spread, ms) {
            return Err(TransformError::Coincident {
                which: "source",
                spread,
            });
        }
        let spread_t = (var_t / n).sqrt();
        if negligible_spread(spread_t, mt) {
            return Err(TransformError::Coincident {
                which: "target",
                spread: spread_t,
            });
        }
        let (a, b) = (re / var, im / var);
        let scale = a.hypot(b);
        if !(scale.is_finite() && scale > 0.0) {
            // Targets spread out but uncorrelated with the sources in every direction.
            return Err(TransformError::NotInvertible { det: scale * scale });
        }
        Ok(Similarity {
            scale,
            angle: b.atan2(a),
            tx: mt.x - (a * ms.x - b * ms.y),
            ty: mt.y - (b * ms.x + a * ms.y),
        })
    }

    /// The same map as an [`Affine`].
    pub fn to_affine(&self) -> Affine {
        let (s, c) = self.angle.sin_cos();
        Affine {
            a: self.scale * c,
            b: -self.scale * s,
            c: self.scale * s,
            d: self.scale * c,
            tx: self.tx,
            ty: self.ty,
        }
    }
}

impl Affine {
    /// Applies the map.
    #[inline]
    pub fn apply(&self, p: Point) -> Point {
        Point::new(
            self.a * p.x + self.b * p.y + self.tx,
            self.c * p.x + self.d * p.y + self.ty,
        )
    }

    /// Determinant of the linear part (area scale factor; negative for a reflection).
    pub fn det(&self) -> f64 {
        self.a * self.d - self.b * self.c
    }

    /// The inverse map; fails when the linear part is (numerically) singular.
    pub fn inverse(&self) -> Result<Affine, TransformError> {
        let det = self.det();
        let norm2 = self.a * self.a + self.b * self.b + self.c * self.c + self.d * self.d;
        if !(det.is_finite() && norm2.is_finite()) || det.abs() <= 1e-12 * norm2 {
            return Err(TransformError::NotInvertible { det });
        }
        let (a, b, c, d) = (self.d / det, -self.b / det, -self.c / det, self.a / det);
        Ok(Affine {
            a,
            b,
            c,
            d,
            tx: -(a * self.tx + b * self.ty),
            ty: -(c * self.tx + d * self.ty),
        })
    }

    /// Least-squares fit from ≥ 3 matches whose source points are not collinear
    /// (their [`relative_area`] must reach `min_relative_area`, e.g.
    /// [`DEFAULT_MIN_RELATIVE_AREA`]).
    pub fn fit(matches: &[(Point, Point)], min_relative_area: f64) -> Result<Self, TransformError> {
        check_count(matches, TransformKind::Affine)?;
        check_finite(matches)?;
        let (ms, mt) = means(matches);
        let n = matches.len() as f64;
        let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
        // Cross moments Σ q pᵀ.
        let (mut uxx, mut uxy, mut uyx, mut uyy) = (0.0, 0.0, 0.0, 0.0);
        for (s, t) in matches {
            let (p, q) = (*s - ms, *t - mt);
            sxx += p.x * p.x;
            sxy += p.x * p.y;
            syy += p.y * p.y;
            uxx += q.x * p.x;
            uxy += q.x * p.y;
            uyx += q.y * p.x;
            uyy += q.y * p.y;
        }
        let spread = ((sxx + syy) / n).sqrt();
        if negligible_spread(spread, ms) {
            return Err(TransformError::Coincident {
                which: "source",
                spread,
            });
        }
        let relative_area = relative_area_of(sxx, sxy, syy, matches.len());
        if relative_area < min_relative_area || relative_area <= 0.0 {
            return Err(TransformError::Collinear {
                relative_area,
                threshold: min_relative_area,
            });
        }
        let det = sxx * syy - sxy * sxy;
        // M = U · S⁻¹ with S⁻¹ = [syy −sxy; −sxy sxx] / det.
        let (i11, i12, i22) = (syy / det, -sxy / det, sxx / det);
        let (a, b) = (uxx * i11 + uxy * i12, uxx * i12 + uxy * i22);
        let (c, d) = (uyx * i11 + uyy * i12, uyx * i12 + uyy * i22);
        let out = Affine {
            a,
            b,
            c,
            d,
            tx: mt.x - (a * ms.x + b * ms.y),
            ty: mt.y - (c * ms.x + d * ms.y),
        };
        if [out.a, out.b, out.c, out.d, out.tx, out.ty]
            .iter()
            .all(|v| v.is_finite())
        {
            Ok(out)
        } else {
            Err(TransformError::NotInvertible { det })
        }
    }
}

impl Transform {
    /// The identity map.
    pub fn identity() -> Self {
        Transform::default()
    }

    /// Which model this is.
    pub fn kind(&self) -> TransformKind {
        match self {
            Transform::Translation(_) => TransformKind::Translation,
            Transform::Similarity(_) => TransformKind::Similarity,
            Transform::Affine(_) => TransformKind::Affine,
        }
    }

    /// Applies the map.
    #[inline]
    pub fn apply(&self, p: Point) -> Point {
        match self {
            Transform::Translation(t) => t.apply(p),
            Transform::Similarity(t) => t.apply(p),
            Transform::Affine(t) => t.apply(p),
        }
    }

    /// The inverse map, of the same model.
    pub fn inverse(&self) -> Result<Transform, TransformError> {
        Ok(match self {
            Transform::Translation(t) => Transform::Translation(t.inverse()),
            Transform::Similarity(t) => Transform::Similarity(t.inverse()?),
            Transform::Affine(t) => Transform::Affine(t.inverse()?),
        })
    }

    /// The same map as an [`Affine`].
    pub fn to_affine(&self) -> Affine {
        match self {
            Transform::Translation(t) => t.to_affine(),
            Transform::Similarity(t) => t.to_affine(),
            Transform::Affine(t) => *t,
        }
    }

    /// Linear scale factor `√|det|` (1 for a translation): how much lengths grow on average.
    pub fn scale(&self) -> f64 {
        match self {
            Transform::Translation(_) => 1.0,
            Transform::Similarity(t) => t.scale.abs(),
            Transform::Affine(t) => t.det().abs().sqrt(),
        }
    }

    /// Least-squares fit of model `kind` to all `matches` (no outlier rejection; see
    /// [`ransac`]). `min_relative_area` only matters for [`TransformKind::Affine`].
    pub fn fit(
        kind: TransformKind,
        matches: &[(Point, Point)],
        min_relative_area: f64,
    ) -> Result<Transform, TransformError> {
        Ok(match kind {
            TransformKind::Translation => Transform::Translation(Translation::fit(matches)?),
            TransformKind::Similarity => Transform::Similarity(Similarity::fit(matches)?),
            TransformKind::Affine => Transform::Affine(Affine::fit(matches, min_relative_area)?),
        })
    }
}

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

/// A static 2-D k-d tree over a point set, for nearest-point queries in `O(log n)` on average
/// (built in `O(n log n)`).
///
/// Non-finite points are left out; the indices it reports refer to the input slice.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PointIndex {
    /// Points with their input index, arranged as an implicit balanced tree: the median of
    /// each range is its node, split on x at even depths and y at odd ones.
    nodes: Vec<(Point, usize)>,
}

impl PointIndex {
    /// Builds the index.
    pub fn new(points: &[Point]) -> Self {
        let mut nodes: Vec<(Point, usize)> = points
            .iter()
            .copied()
            .enumerate()
            .filter(|(_, p)| p.x.is_finite() && p.y.is_finite())
            .map(|(i, p)| (p, i))
            .collect();
        build(&mut nodes, 0);
        Self { nodes }
    }

    /// Number of indexed points.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether no point is indexed.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The indexed point nearest to `q`: `(input index, distance)`; `None` when empty or `q`
    /// is not finite.
    pub fn nearest(&self, q: Point) -> Option<(usize, f64)> {
        if self.nodes.is_empty() || !(q.x.is_finite() && q.y.is_finite()) {
            return None;
        }
        let mut best = (usize::MAX, f64::INFINITY);
        nearest_in(&self.nodes, 0, q, &mut best);
        (best.0 != usize::MAX).then(|| (best.0, best.1.sqrt()))
    }
}

/// A uniform grid of buckets over a point set, for "the nearest point within `r`" queries
/// in `O(1)` when `r` is about the cell size: the colour analyser's look-ups of one shape's
/// samples (laid on a grid `spacing` apart) under another's, where only neighbours within a
/// fraction of the spacing count. [`PointIndex`] answers the same question in `O(log n)` with
/// backtracking; on a crowd's colour comparisons that was 15 % of the frame (issue 10).
///
/// Non-finite points are left out; the indices it reports refer to the input slice.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CellIndex {
    /// Lower corner of cell (0, 0).
    origin: Point,
    /// Cell side.
    cell: f64,
    /// Cells per row and per column.
    cols: usize,
    rows: usize,
    /// Cell `c`'s points are `items[starts[c]..starts[c + 1]]`, in input order.
    starts: Vec<usize>,
    items: Vec<(Point, usize)>,
}

impl CellIndex {
    /// Builds the index with cells of side `cell` (grown when the points' extent would need
    /// more than a few cells per point; a non-positive side gives one cell).
    pub fn new(points: &[Point], cell: f64) -> Self {
        let finite: Vec<(Point, usize)> = points
            .iter()
            .copied()
            .enumerate()
            .filter(|(_, p)| p.x.is_finite() && p.y.is_finite())
            .map(|(i, p)| (p, i))
            .collect();
        let Some(&(first, _)) = finite.first() else {
            return Self::default();
        };
        let (mut lo, mut hi) = (first, first);
        for &(p, _) in &finite {
            lo = Point::new(lo.x.min(p.x), lo.y.min(p.y));
            hi = Point::new(hi.x.max(p.x), hi.y.max(p.y));
        }
        let (w, h) = (hi.x - lo.x, hi.y - lo.y);
        // At most ~4 cells per point: sparse points with a small cell would otherwise ask
        // for an unbounded table.
        let budget = 4.0 * finite.len() as f64 + 16.0;
        let mut cell = if cell.is_finite() && cell > 0.0 {
            cell
        } else {
            w.max(h).max(1.0)
        };
        if (w / cell + 1.0) * (h / cell + 1.0) > budget {
            cell = ((w + cell) * (h + cell) / budget).sqrt().max(cell);
            while (w / cell + 1.0) * (h / cell + 1.0) > budget {
                cell *= 1.5;
            }
        }
        let cols = (w / cell) as usize + 1;
        let rows = (h / cell) as usize + 1;
        let cell_of = |p: Point| {
            let cx = (((p.x - lo.x) / cell) as usize).min(cols - 1);
            let cy = (((p.y - lo.y) / cell) as usize).min(rows - 1);
            cy * cols + cx
        };
        let mut starts = vec![0usize; cols * rows + 1];
        for &(p, _) in &finite {
            starts[cell_of(p) + 1] += 1;
        }
        for c in 0..cols * rows {
            starts[c + 1] += starts[c];
        }
        let mut fill = starts.clone();
        let mut items = vec![(Point::default(), 0); finite.len()];
        for &(p, i) in &finite {
            let c = cell_of(p);
            items[fill[c]] = (p, i);
            fill[c] += 1;
        }
        Self {
            origin: lo,
            cell,
            cols,
            rows,
            starts,
            items,
        }
    }

    /// Number of indexed points.
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// Whether no point is indexed.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// The indexed point nearest to `q` when one lies within `r` of it: `(input index,
    /// distance)`, the lowest index among equally near ones (as [`PointIndex::nearest`]).
    /// May also answer with a point slightly beyond `r` (within rounding); `None` when none
    /// is that near, or `q` or `r` is not finite.
    pub fn nearest_within(&self, q: Point, r: f64) -> Option<(usize, f64)> {
        if self.items.is_empty() || !(q.x.is_finite() && q.y.is_finite() && r.is_finite()) {
            return None;
        }
        // A margin above any rounding, so every point a `d ≤ r` test would keep is scanned.
        let r = r.max(0.0) * (1.0 + 1e-9) + 1e-9;
        let span = |v: f64, o: f64, n: usize| -> Option<(usize, usize)> {
            let (a, b) = ((v - r - o) / self.cell, (v + r - o) / self.cell);
            if b < 0.0 || a >= n as f64 {
                return None;
            }
            Some((a.max(0.0) as usize, (b as usize).min(n - 1)))
        };
        let (x0, x1) = span(q.x, self.origin.x, self.cols)?;
        let (y0, y1) = span(q.y, self.origin.y, self.rows)?;
        let mut best = (usize::MAX, f64::INFINITY);
        for cy in y0..=y1 {
            let row = cy * self.cols;
            for &(p, i) in &self.items[self.starts[row + x0]..self.starts[row + x1 + 1]] {
                let d2 = p.dist2(q);
                if d2 < best.1 || (d2 == best.1 && i < best.0) {
                    best = (i, d2);
                }
            }
        }
        (best.0 != usize::MAX && best.1 <= r * r).then(|| (best.0, best.1.sqrt()))
    }
}

fn axis_of(p: &Point, depth: usize) -> f64 {
    if depth % 2 == 0 {
        p.x
    } else {
        p.y
    }
}

fn build(nodes: &mut [(Point, usize)], depth: usize) {
    if nodes.len() <= 1 {
        return;
    }
    let mid = nodes.len() / 2;
    nodes.select_nth_unstable_by(mid, |a, b| {
        axis_of(&a.0, depth).total_cmp(&axis_of(&b.0, depth))
    });
    let (left, right) = nodes.split_at_mut(mid);
    build(left, depth + 1);
    if let Some((_, rest)) = right.split_first_mut() {
        build(rest, depth + 1);
    }
}

fn nearest_in(nodes: &[(Point, usize)], depth: usize, q: Point, best: &mut (usize, f64)) {
    let mid = nodes.len() / 2;
    let Some(&(p, idx)) = nodes.get(mid) else {
        return;
    };
    let d2 = p.dist2(q);
    if d2 < best.1 || (d2 == best.1 && idx < best.0) {
        *best = (idx, d2);
    }
    let diff = axis_of(&q, depth) - axis_of(&p, depth);
    let (left, right) = (&nodes[..mid], &nodes[mid + 1..]);
    let (near, far) = if diff < 0.0 {
        (left, right)
    } else {
        (right, left)
    };
    nearest_in(near, depth + 1, q, best);
    if diff * diff <= best.1 {
        nearest_in(far, depth + 1, q, best);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pts(v: &[(f64, f64)]) -> Vec<Point> {
        v.iter().map(|&(x, y)| Point::new(x, y)).collect()
    }

    #[test]
    fn similarity_roundtrip_and_inverse() {
        let t = Similarity {
            scale: 1.7,
            angle: 0.4,
            tx: 3.0,
            ty: -2.0,
        };
        let src = pts(&[(0.0, 0.0), (10.0, 0.0), (3.0, 7.0), (-4.0, 2.0)]);
        let m: Vec<_> = src.iter().map(|&p| (p, t.apply(p))).collect();
        let f = Similarity::fit(&m).unwrap();
        assert!((f.scale - 1.7).abs() < 1e-12 && (f.angle - 0.4).abs() < 1e-12);
        assert!((f.tx - 3.0).abs() < 1e-10 && (f.ty + 2.0).abs() < 1e-10);
        let inv = f.inverse().unwrap();
        for p in &src {
            assert!(inv.apply(f.apply(*p)).dist(*p) < 1e-10);
        }
    }

    #[test]
    fn affine_recovers_shear_and_inverse() {
        let t = Affine {
            a: 1.2,
            b: 0.3,
            c: -0.2,
            d: 0.9,
            tx: 5.0,
            ty: 1.0,
        };
        let src = pts(&[(0.0, 0.0), (10.0, 0.0), (3.0, 7.0), (-4.0, 2.0)]);
        let m: Vec<_> = src.iter().map(|&p| (p, t.apply(p))).collect();
        let f = Affine::fit(&m, DEFAULT_MIN_RELATIVE_AREA).unwrap();
        for (p, q) in &m {
            assert!(f.apply(*p).dist(*q) < 1e-10);
        }
        let inv = f.inverse().unwrap();
        for (p, q) in &m {
            assert!(inv.apply(*q).dist(*p) < 1e-9);
        }
    }

    #[test]
    fn relative_area_is_one_for_equilateral_and_zero_for_collinear() {
        let h = 3f64.sqrt() / 2.0;
        assert!((relative_area(&pts(&[(0.0, 0.0), (1.0, 0.0), (0.5, h)])) - 1.0).abs() < 1e-12);
        assert_eq!(
            relative_area(&pts(&[(0.0, 0.0), (1.0, 1.0), (2.0, 2.0)])),
            0.0
        );
        assert_eq!(relative_area(&pts(&[(0.0, 0.0), (1.0, 1.0)])), 0.0);
    }

    #[test]
    fn degenerate_inputs_are_typed_errors() {
        let p = Point::new(1.0, 1.0);
        assert!(matches!(
            Similarity::fit(&[(p, p)]),
            Err(TransformError::TooFewMatches { needed: 2, .. })
        ));
        assert!(matches!(
            Similarity::fit(&[(p, p), (p, p)]),
            Err(TransformError::Coincident { .. })
        ));
        assert!(matches!(
            Translation::fit(&[]),
            Err(TransformError::TooFewMatches { .. })
        ));
        let nan = Point::new(f64::NAN, 0.0);
        assert!(matches!(
            Translation::fit(&[(p, p), (nan, p)]),
            Err(TransformError::NonFinite { index: 1 })
        ));
        let singular = Affine {
            a: 1.0,
            b: 2.0,
            c: 2.0,
            d: 4.0,
            tx: 0.0,
            ty: 0.0,
        };
        assert!(matches!(
            singular.inverse(),
            Err(TransformError::NotInvertible { .. })
        ));
        assert!(matches!(
            ransac(
                TransformKind::Similarity,
                &[(p, p), (p, p), (p, p)],
                &RansacConfig::default()
            ),
            Err(TransformError::NoConsensus { .. })
        ));
    }

    #[test]
    fn point_index_agrees_with_brute_force() {
        let mut s = 12345u64;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64) * 100.0
        };
        let points: Vec<Point> = (0..300).map(|_| Point::new(next(), next())).collect();
        let index = PointIndex::new(&points);
        assert_eq!(index.len(), 300);
        for _ in 0..200 {
            let q = Point::new(next() * 1.2 - 10.0, next() * 1.2 - 10.0);
            let (i, d) = index.nearest(q).unwrap();
            let brute = points
                .iter()
                .map(|p| p.dist(q))
                .fold(f64::INFINITY, f64::min);
            assert!((d - brute).abs() < 1e-12);
            assert!((points[i].dist(q) - d).abs() < 1e-12);
        }
        assert!(PointIndex::new(&[]).nearest(Point::default()).is_none());
    }

    /// The cell index keeps what "the nearest point, if within `r`" keeps: the same point
    /// (lowest index among ties) and distance, on scattered points, points on a grid with
    /// duplicates (exact ties), odd cell sizes and radii on both sides of the spacing.
    #[test]
    fn cell_index_agrees_with_the_nearest_point() {
        let mut s = 777u64;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        for case in 0..40 {
            let points: Vec<Point> = if case % 2 == 0 {
                (0..1 + case * 7)
                    .map(|_| Point::new(next() * 80.0, next() * 50.0))
                    .collect()
            } else {
                // A sample grid 3 px apart, with some points repeated.
                (0..1 + case * 7)
                    .map(|i| Point::new((i % 13) as f64 * 3.0 + 0.5, (i / 13) as f64 * 3.0 + 0.5))
                    .chain((0..case).map(|i| Point::new((i % 5) as f64 * 3.0 + 0.5, 0.5)))
                    .collect()
            };
            let cell = [3.0, 0.1, 17.0, 0.0, f64::NAN][case % 5];
            let (cells, tree) = (CellIndex::new(&points, cell), PointIndex::new(&points));
            assert_eq!(cells.len(), points.len());
            for _ in 0..200 {
                let q = Point::new(next() * 100.0 - 10.0, next() * 70.0 - 10.0);
                let r = [1.5, 3.0, 0.0, 40.0][(next() * 4.0) as usize % 4];
                let want = tree.nearest(q).filter(|&(_, d)| d <= r);
                let got = cells.nearest_within(q, r).filter(|&(_, d)| d <= r);
                assert_eq!(got, want, "case {case} q {q:?} r {r}");
            }
            // Queries exactly on grid points (distance 0; ties between repeats).
            for p in &points {
                assert_eq!(
                    cells.nearest_within(*p, 1.0),
                    tree.nearest(*p),
                    "case {case}"
                );
            }
        }
        assert!(CellIndex::new(&[], 1.0)
            .nearest_within(Point::default(), 5.0)
            .is_none());
        let one = CellIndex::new(&[Point::new(1.0, 1.0)], 1.0);
        assert!(one.nearest_within(Point::new(f64::NAN, 0.0), 5.0).is_none());
        assert!(one.nearest_within(Point::new(9.0, 9.0), 1.0).is_none());
    }
}
