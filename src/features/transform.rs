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

mod index;
mod robust;
#[cfg(test)]
mod tests;

pub use index::{CellIndex, PointIndex};
pub use robust::{ransac, RansacConfig, RansacFit};

use crate::frame::Point;
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
