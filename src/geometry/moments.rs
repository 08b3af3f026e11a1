//! Image moments of a binary mask (thesis eq. 7–10) and the shape descriptors they give.

use serde::{Deserialize, Serialize};

use crate::frame::{BBox, Mask, Point};

/// Spatial and second-order central moments of a shape.
///
/// Pixels are unit point masses at their centres `(x+0.5, y+0.5)`, the convention of
/// [`Mask::centroid`]. OpenCV's `cv::moments` uses pixel indices instead, so its centroid is
/// half a pixel up-left of ours while the central moments `μ₂₀, μ₀₂, μ₁₁` agree exactly.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Moments {
    /// `M₀₀`: the area in pixels (eq. 8 with `i = j = 0`).
    pub m00: f64,
    /// Centroid `(M₁₀/M₀₀, M₀₁/M₀₀)` in image coordinates (eq. 10).
    pub centroid: Point,
    /// `μ₂₀ = Σ(x − x̄)²` (eq. 9).
    pub mu20: f64,
    /// `μ₀₂ = Σ(y − ȳ)²`.
    pub mu02: f64,
    /// `μ₁₁ = Σ(x − x̄)(y − ȳ)`.
    pub mu11: f64,
}

impl Moments {
    /// Moments of a mask's foreground; `None` when the mask is empty.
    pub fn of_mask(mask: &Mask) -> Option<Moments> {
        let w = mask.width() as usize;
        if w == 0 {
            return None;
        }
        // Sums in local (bitmap) coordinates: exact integers up to 2⁵³, and no cancellation
        // between large image offsets when central moments are derived from raw ones.
        let (mut n, mut sx, mut sy, mut sxx, mut syy, mut sxy) =
            (0u64, 0f64, 0f64, 0f64, 0f64, 0f64);
        for (ly, row) in mask.data().chunks_exact(w).enumerate() {
            let y = ly as f64;
            let (mut rn, mut rx, mut rxx) = (0u64, 0f64, 0f64);
            for (lx, _) in row.iter().enumerate().filter(|(_, &v)| v != 0) {
                let x = lx as f64;
                rn += 1;
                rx += x;
                rxx += x * x;
            }
            if rn == 0 {
                continue;
            }
            let rnf = rn as f64;
            n += rn;
            sx += rx;
            sy += y * rnf;
            sxx += rxx;
            syy += y * y * rnf;
            sxy += y * rx;
        }
        if n == 0 {
            return None;
        }
        let m00 = n as f64;
        let (cx, cy) = (sx / m00, sy / m00);
        Some(Moments {
            m00,
            centroid: Point::new(mask.x() as f64 + cx + 0.5, mask.y() as f64 + cy + 0.5),
            mu20: (sxx - cx * sx).max(0.0),
            mu02: (syy - cy * sy).max(0.0),
            mu11: sxy - cx * sy,
        })
    }

    /// Moments of a uniformly filled box (continuous: `μ₂₀ = w³h/12`), for box-only detections.
    pub fn of_box(b: &BBox) -> Moments {
        let (w, h) = (b.w.max(0.0), b.h.max(0.0));
        Moments {
            m00: w * h,
            centroid: b.center(),
            mu20: w * w * w * h / 12.0,
            mu02: w * h * h * h / 12.0,
            mu11: 0.0,
        }
    }

    /// Eigenvalues `(λ_major, λ_minor)` of the covariance matrix `[[μ₂₀, μ₁₁], [μ₁₁, μ₀₂]]/M₀₀`.
    pub fn covariance_eigenvalues(&self) -> (f64, f64) {
        if self.m00 <= 0.0 {
            return (0.0, 0.0);
        }
        let a = self.mu20 / self.m00;
        let c = self.mu02 / self.m00;
        let b = self.mu11 / self.m00;
        let mean = (a + c) / 2.0;
        let r = (((a - c) / 2.0).powi(2) + b * b).sqrt();
        ((mean + r).max(0.0), (mean - r).max(0.0))
    }

    /// Angle of the major axis from the +x axis, in radians in `(−π/2, π/2]`. Image y points
    /// down, so a positive angle turns clockwise on screen. 0 for isotropic shapes.
    pub fn orientation(&self) -> f64 {
        let t = 0.5 * (2.0 * self.mu11).atan2(self.mu20 - self.mu02);
        if t <= -std::f64::consts::FRAC_PI_2 {
            t + std::f64::consts::PI
        } else {
            t
        }
    }

    /// Elongation `1 − λ_minor/λ_major` in `[0, 1]`: 0 for a disc or square, 1 for a line.
    pub fn elongation(&self) -> f64 {
        let (l1, l2) = self.covariance_eigenvalues();
        if l1 <= 0.0 {
            0.0
        } else {
            (1.0 - l2 / l1).clamp(0.0, 1.0)
        }
    }

    /// Standard deviations along the major and minor axes, in pixels.
    pub fn axis_std(&self) -> (f64, f64) {
        let (l1, l2) = self.covariance_eigenvalues();
        (l1.sqrt(), l2.sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_mask_centroid_and_hand_values() {
        // 3×1 horizontal bar at (10, 20).
        let m = Mask::new(10, 20, 3, 1, vec![1, 1, 1]).unwrap();
        let mo = Moments::of_mask(&m).unwrap();
        assert_eq!(mo.m00, 3.0);
        assert_eq!(Some(mo.centroid), m.centroid());
        assert_eq!(mo.centroid, Point::new(11.5, 20.5));
        assert!((mo.mu20 - 2.0).abs() < 1e-12);
        assert_eq!(mo.mu02, 0.0);
        assert_eq!(mo.mu11, 0.0);
        assert_eq!(mo.orientation(), 0.0);
        assert_eq!(mo.elongation(), 1.0);
        assert!(Moments::of_mask(&Mask::empty()).is_none());
        assert!(Moments::of_mask(&Mask::new(0, 0, 2, 1, vec![0, 0]).unwrap()).is_none());
    }

    #[test]
    fn diagonal_line_orientation() {
        // Pixels on y = x (image coordinates): major axis at +45° (clockwise on screen).
        let mut d = vec![0u8; 25];
        for i in 0..5 {
            d[i * 5 + i] = 1;
        }
        let mo = Moments::of_mask(&Mask::new(0, 0, 5, 5, d).unwrap()).unwrap();
        assert!((mo.orientation() - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        assert!((mo.elongation() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn box_moments() {
        let mo = Moments::of_box(&BBox::new(0.0, 0.0, 4.0, 2.0));
        assert_eq!(mo.centroid, Point::new(2.0, 1.0));
        assert!((mo.axis_std().0 - (16.0f64 / 12.0).sqrt()).abs() < 1e-12);
        assert!((mo.elongation() - 0.75).abs() < 1e-12);
    }
}
