//! Kalman filters: a constant-velocity box filter for the online tracker and the thesis'
//! constant-acceleration centroid filter (ch. 5, eq. 44–52) for the offline re-linker.
//!
//! Both implement [`MotionModel`], so the tracker's filter is swappable: the online tracker is
//! generic over any `MotionModel<Measurement = BBox>` built by a [`MotionFactory`].
//!
//! # The online box filter ([`BoxKalman`])
//!
//! State `x = [cx, cy, w, h, vcx, vcy, vw, vh]`: box centre, width, height and their velocities
//! in pixels per frame; the measurement is `[cx, cy, w, h]` of a detection. We filter width and
//! height rather than SORT's area/aspect or ByteTrack's aspect/height because a pedestrian box
//! changes width and height independently (arms, occlusion, truncation at the image border) and
//! a plain `[w, h]` state keeps every noise term in pixels (BoT-SORT made the same choice).
//!
//! Noise is proportional to the box size, as in DeepSORT/ByteTrack/BoT-SORT: a 400-pixel-tall
//! person close to the camera moves and jitters many more pixels per frame than a 40-pixel one
//! far away, so a fixed pixel noise would either over-trust small boxes or under-trust large
//! ones. With `σp` = [`BoxKalmanParams::std_position`] and `σv` =
//! [`BoxKalmanParams::std_velocity`], for the x-like coordinates (`cx`, `w`) the scale is the
//! width and for the y-like ones (`cy`, `h`) the height:
//!
//! - initial covariance: position std `2·σp·size`, velocity std `10·σv·size` (the velocity of
//!   a new track is unknown; a large prior lets two updates fix it);
//! - process noise per frame: position std `σp·size`, velocity std `σv·size`;
//! - measurement noise: std `σm·size` with `σm` = [`BoxKalmanParams::std_measurement`].
//!
//! Sizes below one pixel count as one pixel, so covariances never become singular.
//!
//! # The re-linker filter ([`ConstantAcceleration`])
//!
//! State `[u, v, u̇, v̇]` (centroid and its velocity, pixels and pixels per second), control
//! `[a_u, a_v]` entering through `B` (eq. 47), `Δt = 1/fps`, no process noise (eq. 49), and
//! `P₀ = R = 0.5·I`. The thesis says "0.5 for each element"; read literally (every entry 0.5)
//! `H P Hᵀ + R` is a rank-one matrix and eq. 50 cannot be evaluated, so we put 0.5 on the
//! diagonals.

use crate::frame::{BBox, Point};
use nalgebra::{SMatrix, SVector};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Errors raised by the motion filters.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum MotionError {
    /// A measurement or control value is NaN or infinite.
    #[error("{what} has a non-finite value {value}")]
    NonFinite {
        /// Which input.
        what: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A measurement box has a negative size.
    #[error("measurement box has negative size {w}x{h}")]
    NegativeSize {
        /// Width.
        w: f64,
        /// Height.
        h: f64,
    },
    /// The innovation covariance `H P Hᵀ + R` is not positive definite.
    #[error("innovation covariance is not positive definite")]
    Singular,
    /// A filter parameter is out of range.
    #[error(
        "motion parameter {name} = {}: {reason}",
        crate::settings::Short::of(.value)
    )]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Value given.
        value: f64,
        /// What is wrong.
        reason: &'static str,
    },
}

/// A recursive motion filter: predict, correct with a measurement, and measure how far a
/// measurement is from the prediction.
pub trait MotionModel {
    /// What the filter observes (a box for the online tracker, a centroid for the re-linker).
    type Measurement;

    /// Advances the state by one time step.
    fn predict(&mut self);

    /// Corrects the state with a measurement.
    fn update(&mut self, z: &Self::Measurement) -> Result<(), MotionError>;

    /// The measurement the current state predicts (`H x`).
    fn project(&self) -> Self::Measurement;

    /// Squared Mahalanobis distance of `z` from the projected state under the innovation
    /// covariance `H P Hᵀ + R`; `None` when that covariance is not positive definite.
    fn mahalanobis2(&self, z: &Self::Measurement) -> Option<f64>;

    /// The velocity of the tracked point (pixels per time step of the filter).
    fn velocity(&self) -> Point;

    /// Multiplies the velocity state by `factor`; used on tracks unseen for a while, whose
    /// stale velocity would carry the prediction away. Filters without one ignore it.
    fn damp_velocity(&mut self, factor: f64) {
        let _ = factor;
    }

    /// Moves the state's position by `(dx, dy)` pixels (the whole image moved: camera
    /// motion). Filters without a position ignore it.
    fn translate(&mut self, dx: f64, dy: f64) {
        let _ = (dx, dy);
    }
}

/// A box filter that can be cloned behind a pointer: what a track owns, so the tracker can keep
/// a snapshot of it (for the re-update after a gap). Every `Clone` box filter is one.
pub trait BoxMotionModel: MotionModel<Measurement = BBox> + Send {
    /// A boxed copy.
    fn clone_box(&self) -> Box<dyn BoxMotionModel>;
}

impl<T: MotionModel<Measurement = BBox> + Clone + Send + 'static> BoxMotionModel for T {
    fn clone_box(&self) -> Box<dyn BoxMotionModel> {
        Box::new(self.clone())
    }
}

/// Builds a filter for a new track from its first measurement.
pub trait MotionFactory {
    /// The filter type it builds.
    type Model: MotionModel<Measurement = BBox> + Clone + Send + 'static;

    /// A filter whose state is the box `z` at rest.
    fn init(&self, z: &BBox) -> Result<Self::Model, MotionError>;
}

/// Noise parameters of [`BoxKalman`], as fractions of the box size (see the module docs).
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BoxKalmanParams {
    /// Position process-noise std per frame, as a fraction of the box size (`σp`).
    /// Default 1/20, as ByteTrack/BoT-SORT.
    pub std_position: f64,
    /// Velocity process-noise std per frame, as a fraction of the box size (`σv`).
    /// Default 1/160, as ByteTrack/BoT-SORT.
    pub std_velocity: f64,
    /// Measurement-noise std, as a fraction of the box size (`σm`). Default 1/20.
    pub std_measurement: f64,
}

impl Default for BoxKalmanParams {
    fn default() -> Self {
        Self {
            std_position: 1.0 / 20.0,
            std_velocity: 1.0 / 160.0,
            std_measurement: 1.0 / 20.0,
        }
    }
}

impl BoxKalmanParams {
    /// Checks that every parameter is finite and positive.
    pub fn validate(&self) -> Result<(), MotionError> {
        for (name, value) in [
            ("std_position", self.std_position),
            ("std_velocity", self.std_velocity),
            ("std_measurement", self.std_measurement),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(MotionError::InvalidParameter {
                    name,
                    value,
                    reason: "must be finite and > 0",
                });
            }
        }
        Ok(())
    }
}

impl MotionFactory for BoxKalmanParams {
    type Model = BoxKalman;

    fn init(&self, z: &BBox) -> Result<BoxKalman, MotionError> {
        BoxKalman::new(z, *self)
    }
}

type V8 = SVector<f64, 8>;
type M8 = SMatrix<f64, 8, 8>;
type V4 = SVector<f64, 4>;
type M4 = SMatrix<f64, 4, 4>;

/// Sizes below one pixel count as one pixel in noise terms, so no covariance is ever zero.
const MIN_NOISE_SIZE: f64 = 1.0;

/// Constant-velocity Kalman filter on `[cx, cy, w, h]` with size-scaled noise (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct BoxKalman {
    x: V8,
    p: M8,
    params: BoxKalmanParams,
}

fn check_box(z: &BBox) -> Result<V4, MotionError> {
    for v in [z.x, z.y, z.w, z.h] {
        if !v.is_finite() {
            return Err(MotionError::NonFinite {
                what: "measurement box",
                value: v,
            });
        }
    }
    if z.w < 0.0 || z.h < 0.0 {
        return Err(MotionError::NegativeSize { w: z.w, h: z.h });
    }
    let c = z.center();
    Ok(V4::new(c.x, c.y, z.w, z.h))
}

/// The per-coordinate size scale: width for `cx` and `w`, height for `cy` and `h`.
fn scales(w: f64, h: f64) -> [f64; 4] {
    let (w, h) = (w.max(MIN_NOISE_SIZE), h.max(MIN_NOISE_SIZE));
    [w, h, w, h]
}

impl BoxKalman {
    /// A filter at rest on the box `z`.
    pub fn new(z: &BBox, params: BoxKalmanParams) -> Result<Self, MotionError> {
        params.validate()?;
        let m = check_box(z)?;
        let mut x = V8::zeros();
        x.fixed_rows_mut::<4>(0).copy_from(&m);
        let s = scales(z.w, z.h);
        let mut p = M8::zeros();
        for i in 0..4 {
            p[(i, i)] = (2.0 * params.std_position * s[i]).powi(2);
            p[(i + 4, i + 4)] = (10.0 * params.std_velocity * s[i]).powi(2);
        }
        Ok(Self { x, p, params })
    }

    /// The state vector `[cx, cy, w, h, vcx, vcy, vw, vh]`.
    pub fn state(&self) -> [f64; 8] {
        let mut out = [0.0; 8];
        out.copy_from_slice(self.x.as_slice());
        out
    }

    /// The state covariance, row-major.
    pub fn covariance(&self) -> [[f64; 8]; 8] {
        let mut out = [[0.0; 8]; 8];
        for (i, row) in out.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = self.p[(i, j)];
            }
        }
        out
    }

    /// The estimated box (sizes never negative).
    pub fn bbox(&self) -> BBox {
        BBox::from_center(
            Point::new(self.x[0], self.x[1]),
            self.x[2].max(0.0),
            self.x[3].max(0.0),
        )
    }

    /// Innovation `z - Hx` and its covariance `S = H P Hᵀ + R`.
    fn innovation(&self, m: &V4) -> (V4, M4) {
        let y = m - self.x.fixed_rows::<4>(0);
        let mut s: M4 = self.p.fixed_view::<4, 4>(0, 0).into_owned();
        let sc = scales(self.x[2], self.x[3]);
        for (i, sz) in sc.iter().enumerate() {
            s[(i, i)] += (self.params.std_measurement * sz).powi(2);
        }
        (y, s)
    }
}

impl MotionModel for BoxKalman {
    type Measurement = BBox;

    fn predict(&mut self) {
        // A shrinking box must not shrink through zero: stop its size velocity first (SORT).
        for i in 2..4 {
            if self.x[i] + self.x[i + 4] <= 0.0 {
                self.x[i + 4] = 0.0;
            }
        }
        let sc = scales(self.x[2], self.x[3]);
        // x' = F x with F = [[I, I], [0, I]] (one frame per step).
        for i in 0..4 {
            self.x[i] += self.x[i + 4];
        }
        // P' = F P Fᵀ + Q, written out blockwise: with P = [[A, B], [Bᵀ, C]],
        // F P Fᵀ = [[A + B + Bᵀ + C, B + C], [Bᵀ + C, C]].
        let a = self.p.fixed_view::<4, 4>(0, 0).into_owned();
        let b = self.p.fixed_view::<4, 4>(0, 4).into_owned();
        let c = self.p.fixed_view::<4, 4>(4, 4).into_owned();
        let bt = b.transpose();
        let mut na = a + b + bt + c;
        let nb = b + c;
        let mut nc = c;
        for (i, sz) in sc.iter().enumerate() {
            na[(i, i)] += (self.params.std_position * sz).powi(2);
            nc[(i, i)] += (self.params.std_velocity * sz).powi(2);
        }
        self.p.fixed_view_mut::<4, 4>(0, 0).copy_from(&na);
        self.p.fixed_view_mut::<4, 4>(0, 4).copy_from(&nb);
        self.p
            .fixed_view_mut::<4, 4>(4, 0)
            .copy_from(&nb.transpose());
        self.p.fixed_view_mut::<4, 4>(4, 4).copy_from(&nc);
    }

    fn update(&mut self, z: &BBox) -> Result<(), MotionError> {
        let m = check_box(z)?;
        let (y, s) = self.innovation(&m);
        let chol = s.cholesky().ok_or(MotionError::Singular)?;
        // K = P Hᵀ S⁻¹; with H = [I 0], H P is the top four rows of P, and S is symmetric, so
        // Kᵀ = S⁻¹ (H P).
        let hp: SMatrix<f64, 4, 8> = self.p.fixed_rows::<4>(0).into_owned();
        let kt = chol.solve(&hp);
        let k = kt.transpose();
        self.x += k * y;
        // Joseph-free form P - K H P is fine here: S is well conditioned by the size floor.
        self.p -= k * hp;
        // Keep P symmetric against rounding drift over thousands of frames.
        self.p = (self.p + self.p.transpose()) * 0.5;
        Ok(())
    }

    fn project(&self) -> BBox {
        self.bbox()
    }

    fn mahalanobis2(&self, z: &BBox) -> Option<f64> {
        let m = check_box(z).ok()?;
        let (y, s) = self.innovation(&m);
        let chol = s.cholesky()?;
        let d = y.dot(&chol.solve(&y));
        d.is_finite().then_some(d)
    }

    fn velocity(&self) -> Point {
        Point::new(self.x[4], self.x[5])
    }

    fn damp_velocity(&mut self, factor: f64) {
        if factor.is_finite() {
            for i in 4..8 {
                self.x[i] *= factor;
            }
        }
    }

    fn translate(&mut self, dx: f64, dy: f64) {
        if dx.is_finite() && dy.is_finite() {
            self.x[0] += dx;
            self.x[1] += dy;
        }
    }
}

/// 95 % quantile of the χ² distribution with 4 degrees of freedom: the usual Mahalanobis gate
/// for a 4-D box measurement (DeepSORT's `chi2inv95[4]`).
pub const CHI2_95_4DOF: f64 = 9.4877;

/// 95 % quantile of the χ² distribution with 2 degrees of freedom (a 2-D centroid).
pub const CHI2_95_2DOF: f64 = 5.9915;

type V4c = V4;
type M4c = M4;

/// The thesis' constant-acceleration centroid filter (eq. 44–52), used by the offline
/// re-linker to carry a track's centroid across an occlusion.
///
/// State `[u, v, u̇, v̇]`; `predict` applies `x ← A x + B a` and `P ← A P Aᵀ` (eq. 47, 49, no
/// process noise); `update` applies eq. 50–52 with `H = [I 0]`.
#[derive(Debug, Clone, PartialEq)]
pub struct ConstantAcceleration {
    x: V4c,
    p: M4c,
    r: SMatrix<f64, 2, 2>,
    accel: SVector<f64, 2>,
    dt: f64,
}

impl ConstantAcceleration {
    /// The thesis' initial covariances: `P₀ = R = 0.5·I` (see the module docs).
    pub const INITIAL_COVARIANCE: f64 = 0.5;

    /// A filter at `position` moving with `velocity` (pixels per second) under the constant
    /// control acceleration `accel` (pixels per second²), stepping `Δt = 1/fps`.
    pub fn new(
        position: Point,
        velocity: Point,
        accel: Point,
        fps: f64,
    ) -> Result<Self, MotionError> {
        if !(fps.is_finite() && fps > 0.0) {
            return Err(MotionError::InvalidParameter {
                name: "fps",
                value: fps,
                reason: "must be finite and > 0",
            });
        }
        for (what, p) in [
            ("position", position),
            ("velocity", velocity),
            ("acceleration", accel),
        ] {
            for v in [p.x, p.y] {
                if !v.is_finite() {
                    return Err(MotionError::NonFinite { what, value: v });
                }
            }
        }
        Ok(Self {
            x: V4c::new(position.x, position.y, velocity.x, velocity.y),
            p: M4c::identity() * Self::INITIAL_COVARIANCE,
            r: SMatrix::<f64, 2, 2>::identity() * Self::INITIAL_COVARIANCE,
            accel: SVector::<f64, 2>::new(accel.x, accel.y),
            dt: 1.0 / fps,
        })
    }

    /// A filter started from a track's centroid history (one point per frame, oldest first):
    /// velocity from the first two points, control acceleration = mean second difference (the
    /// thesis' "average relative x and y components of the acceleration"), then every point is
    /// fed through predict/update so the state ends on the last observation.
    pub fn from_history(history: &[Point], fps: f64) -> Result<Self, MotionError> {
        let Some(&first) = history.first() else {
            return Err(MotionError::InvalidParameter {
                name: "history length",
                value: 0.0,
                reason: "needs at least one centroid",
            });
        };
        let accel = mean_acceleration(history, fps);
        let mut f = Self::new(first, Point::default(), accel, fps)?;
        // Seed the velocity from the first difference so the first predictions are sane.
        if let Some(&second) = history.get(1) {
            f.x[2] = (second.x - first.x) * fps;
            f.x[3] = (second.y - first.y) * fps;
        }
        for p in history.iter().skip(1) {
            f.predict();
            f.update(p)?;
        }
        Ok(f)
    }

    /// The state `[u, v, u̇, v̇]`.
    pub fn state(&self) -> [f64; 4] {
        [self.x[0], self.x[1], self.x[2], self.x[3]]
    }

    /// The state covariance, row-major.
    pub fn covariance(&self) -> [[f64; 4]; 4] {
        let mut out = [[0.0; 4]; 4];
        for (i, row) in out.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = self.p[(i, j)];
            }
        }
        out
    }

    /// The control acceleration `[a_u, a_v]` (pixels per second²).
    pub fn acceleration(&self) -> Point {
        Point::new(self.accel[0], self.accel[1])
    }

    /// Predict-only rollout: the centroids of the next `steps` predictions (the state is left
    /// unchanged). This is how the re-linker carries a slave track to the master's start.
    pub fn rollout(&self, steps: usize) -> Vec<Point> {
        let mut f = self.clone();
        (0..steps)
            .map(|_| {
                f.predict();
                f.project()
            })
            .collect()
    }

    fn a_matrix(&self) -> M4c {
        let dt = self.dt;
        M4c::new(
            1.0, 0.0, dt, 0.0, //
            0.0, 1.0, 0.0, dt, //
            0.0, 0.0, 1.0, 0.0, //
            0.0, 0.0, 0.0, 1.0,
        )
    }

    fn b_matrix(&self) -> SMatrix<f64, 4, 2> {
        let dt = self.dt;
        SMatrix::<f64, 4, 2>::new(
            dt * dt / 2.0,
            0.0, //
            0.0,
            dt * dt / 2.0, //
            dt,
            0.0, //
            0.0,
            dt,
        )
    }
}

/// Mean acceleration (pixels per second²) of a centroid sequence sampled at `fps`: the mean of
/// the second differences divided by `Δt²`; zero with fewer than three points.
pub fn mean_acceleration(history: &[Point], fps: f64) -> Point {
    if history.len() < 3 || !(fps.is_finite() && fps > 0.0) {
        return Point::default();
    }
    let n = (history.len() - 2) as f64;
    let (mut ax, mut ay) = (0.0, 0.0);
    for w in history.windows(3) {
        ax += w[2].x - 2.0 * w[1].x + w[0].x;
        ay += w[2].y - 2.0 * w[1].y + w[0].y;
    }
    Point::new(ax / n * fps * fps, ay / n * fps * fps)
}

impl MotionModel for ConstantAcceleration {
    type Measurement = Point;

    fn predict(&mut self) {
        let a = self.a_matrix();
        self.x = a * self.x + self.b_matrix() * self.accel;
        self.p = a * self.p * a.transpose();
    }

    fn update(&mut self, z: &Point) -> Result<(), MotionError> {
        for v in [z.x, z.y] {
            if !v.is_finite() {
                return Err(MotionError::NonFinite {
                    what: "centroid",
                    value: v,
                });
            }
        }
        let y = SVector::<f64, 2>::new(z.x - self.x[0], z.y - self.x[1]);
        let hp: SMatrix<f64, 2, 4> = self.p.fixed_rows::<2>(0).into_owned();
        let s = self.p.fixed_view::<2, 2>(0, 0).into_owned() + self.r;
        let chol = s.cholesky().ok_or(MotionError::Singular)?;
        let k = chol.solve(&hp).transpose();
        self.x += k * y;
        self.p -= k * hp;
        Ok(())
    }

    fn project(&self) -> Point {
        Point::new(self.x[0], self.x[1])
    }

    fn mahalanobis2(&self, z: &Point) -> Option<f64> {
        let y = SVector::<f64, 2>::new(z.x - self.x[0], z.y - self.x[1]);
        let s = self.p.fixed_view::<2, 2>(0, 0).into_owned() + self.r;
        let chol = s.cholesky()?;
        let d = y.dot(&chol.solve(&y));
        d.is_finite().then_some(d)
    }

    fn velocity(&self) -> Point {
        Point::new(self.x[2], self.x[3])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-9 * (1.0 + a.abs().max(b.abs()))
    }

    /// One coordinate worked by hand. Box 100×200 centred at (50, 100), default noise
    /// (σp = σm = 1/20, σv = 1/160). For `cx` the scale is w = 100:
    /// P₀ = diag(2·5², (10·0.625)²) = diag(100, 39.0625).
    /// Predict: P = [[100 + 39.0625 + 25, 39.0625], [39.0625, 39.0625 + 0.390625]]
    ///            = [[164.0625, 39.0625], [39.0625, 39.453125]], x unchanged (v = 0).
    /// Update with cx = 60: S = 164.0625 + 25 = 189.0625, K = [164.0625, 39.0625] / S,
    /// cx = 50 + 10·K₀, vcx = 10·K₁, P₀₀ = 164.0625·(1 − K₀), P₀₁ = 39.0625·(1 − K₀),
    /// P₁₁ = 39.453125 − K₁·39.0625.
    #[test]
    fn box_kalman_matches_hand_computation() {
        let z0 = BBox::from_center(Point::new(50.0, 100.0), 100.0, 200.0);
        let mut kf = BoxKalman::new(&z0, BoxKalmanParams::default()).unwrap();
        let p0 = kf.covariance();
        assert!(close(p0[0][0], 100.0));
        assert!(close(p0[4][4], 39.0625));
        assert!(close(p0[1][1], 400.0)); // 2·(200/20) = 20 → 400
        kf.predict();
        let p = kf.covariance();
        assert!(close(p[0][0], 164.0625));
        assert!(close(p[0][4], 39.0625));
        assert!(close(p[4][4], 39.453125));
        assert_eq!(kf.state()[0], 50.0);

        // Mahalanobis distance of an innovation in cx only: 10² / S.
        let z1 = BBox::from_center(Point::new(60.0, 100.0), 100.0, 200.0);
        let s = 164.0625 + 25.0;
        assert!(close(kf.mahalanobis2(&z1).unwrap(), 100.0 / s));

        kf.update(&z1).unwrap();
        let (k0, k1) = (164.0625 / s, 39.0625 / s);
        let st = kf.state();
        assert!(close(st[0], 50.0 + 10.0 * k0));
        assert!(close(st[4], 10.0 * k1));
        // Other coordinates saw zero innovation.
        assert!(close(st[1], 100.0) && close(st[2], 100.0) && close(st[3], 200.0));
        let p = kf.covariance();
        assert!(close(p[0][0], 164.0625 * (1.0 - k0)));
        assert!(close(p[0][4], 39.0625 * (1.0 - k0)));
        assert!(close(p[4][4], 39.453125 - k1 * 39.0625));
    }

    #[test]
    fn box_kalman_follows_constant_velocity() {
        let params = BoxKalmanParams::default();
        let mut kf = BoxKalman::new(&BBox::new(0.0, 0.0, 40.0, 80.0), params).unwrap();
        for t in 1..60 {
            kf.predict();
            kf.update(&BBox::new(3.0 * t as f64, -2.0 * t as f64, 40.0, 80.0))
                .unwrap();
        }
        let v = kf.velocity();
        assert!(
            (v.x - 3.0).abs() < 0.05 && (v.y + 2.0).abs() < 0.05,
            "{v:?}"
        );
        kf.predict();
        let b = kf.project();
        assert!(
            (b.x - 180.0).abs() < 0.5 && (b.y + 120.0).abs() < 0.5,
            "{b:?}"
        );
    }

    #[test]
    fn box_kalman_never_predicts_negative_sizes() {
        let mut kf = BoxKalman::new(&BBox::new(0.0, 0.0, 40.0, 40.0), Default::default()).unwrap();
        for w in [30.0, 20.0, 10.0, 2.0] {
            kf.predict();
            kf.update(&BBox::new(0.0, 0.0, w, w)).unwrap();
        }
        for _ in 0..20 {
            kf.predict();
            let b = kf.bbox();
            assert!(b.w >= 0.0 && b.h >= 0.0);
        }
    }

    #[test]
    fn box_kalman_rejects_bad_measurements() {
        let p = BoxKalmanParams::default();
        assert!(matches!(
            BoxKalman::new(&BBox::new(f64::NAN, 0.0, 1.0, 1.0), p),
            Err(MotionError::NonFinite { .. })
        ));
        let mut kf = BoxKalman::new(&BBox::new(0.0, 0.0, 10.0, 10.0), p).unwrap();
        assert!(kf.update(&BBox::new(0.0, f64::INFINITY, 1.0, 1.0)).is_err());
        assert!(matches!(
            kf.update(&BBox::new(0.0, 0.0, -1.0, 1.0)),
            Err(MotionError::NegativeSize { .. })
        ));
        assert_eq!(kf.mahalanobis2(&BBox::new(f64::NAN, 0.0, 1.0, 1.0)), None);
        let bad = BoxKalmanParams {
            std_velocity: 0.0,
            ..p
        };
        assert!(bad.validate().is_err());
    }

    #[test]
    fn mahalanobis_grows_with_distance_and_shrinks_with_uncertainty() {
        let mut kf = BoxKalman::new(&BBox::new(0.0, 0.0, 50.0, 100.0), Default::default()).unwrap();
        kf.predict();
        let near = kf.mahalanobis2(&BBox::new(5.0, 0.0, 50.0, 100.0)).unwrap();
        let far = kf.mahalanobis2(&BBox::new(20.0, 0.0, 50.0, 100.0)).unwrap();
        assert!(near < far);
        for _ in 0..10 {
            kf.predict();
        }
        let later = kf.mahalanobis2(&BBox::new(20.0, 0.0, 50.0, 100.0)).unwrap();
        assert!(later < far);
    }

    /// With zero noise the filter's prediction is Newton's s = ut + ½at² (eq. 42) and
    /// v = u + at (eq. 43) exactly, at every step.
    #[test]
    fn ca_rollout_reproduces_newton() {
        let (fps, u, a) = (25.0, Point::new(12.0, -4.0), Point::new(3.0, 9.5));
        let p0 = Point::new(100.0, 50.0);
        let f = ConstantAcceleration::new(p0, u, a, fps).unwrap();
        let pts = f.rollout(100);
        for (k, p) in pts.iter().enumerate() {
            let t = (k + 1) as f64 / fps;
            let sx = p0.x + u.x * t + 0.5 * a.x * t * t;
            let sy = p0.y + u.y * t + 0.5 * a.y * t * t;
            assert!(
                close(p.x, sx) && close(p.y, sy),
                "step {k}: {p:?} vs ({sx}, {sy})"
            );
        }
        // The rollout leaves the filter itself untouched.
        assert_eq!(f.state(), [100.0, 50.0, 12.0, -4.0]);
        let mut g = f.clone();
        for _ in 0..100 {
            g.predict();
        }
        let st = g.state();
        assert!(close(st[2], u.x + a.x * 4.0) && close(st[3], u.y + a.y * 4.0));
    }

    #[test]
    fn ca_matches_hand_computed_update() {
        // fps = 1 (Δt = 1), P₀ = R = 0.5 I, a = 0. After predict:
        // P = A P Aᵀ: for u: [[0.5 + 0.5, 0.5], [0.5, 0.5]] = [[1, .5], [.5, .5]].
        // S = 1 + 0.5 = 1.5, K = [1/1.5, 0.5/1.5] = [2/3, 1/3].
        let mut f = ConstantAcceleration::new(
            Point::new(0.0, 0.0),
            Point::new(1.0, 0.0),
            Point::default(),
            1.0,
        )
        .unwrap();
        f.predict();
        assert_eq!(f.project(), Point::new(1.0, 0.0));
        let p = f.covariance();
        assert!(close(p[0][0], 1.0) && close(p[0][2], 0.5) && close(p[2][2], 0.5));
        f.update(&Point::new(4.0, 0.0)).unwrap();
        let st = f.state();
        assert!(close(st[0], 1.0 + 3.0 * 2.0 / 3.0));
        assert!(close(st[2], 1.0 + 3.0 / 3.0));
        let p = f.covariance();
        assert!(close(p[0][0], 1.0 / 3.0)); // (1 − 2/3)·1
        assert!(close(p[2][2], 0.5 - 0.5 / 3.0)); // 0.5 − K₁·0.5
    }

    #[test]
    fn ca_from_history_estimates_acceleration() {
        let fps = 10.0;
        let hist: Vec<Point> = (0..20)
            .map(|k| {
                let t = k as f64 / fps;
                Point::new(5.0 + 2.0 * t + 0.5 * 4.0 * t * t, 7.0 - 3.0 * t)
            })
            .collect();
        let a = mean_acceleration(&hist, fps);
        assert!(close(a.x, 4.0) && a.y.abs() < 1e-9, "{a:?}");
        let f = ConstantAcceleration::from_history(&hist, fps).unwrap();
        let last = hist[hist.len() - 1];
        assert!(f.project().dist(last) < 0.5);
        assert!(ConstantAcceleration::from_history(&[], fps).is_err());
        assert!(ConstantAcceleration::new(last, last, last, 0.0).is_err());
    }
}
