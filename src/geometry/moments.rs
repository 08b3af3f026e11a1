//! Image moments of a binary mask (thesis eq. 7–10) and the shape descriptors they give.

use serde::{Deserialize, Serialize};

use crate::frame::{BBox, Mask, Point};
use crate::runs::runs;

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

/// `0² + 1² + … + (m − 1)²` for `m ≤ 2²⁰` ([`WORD_ROWS`]), exactly: the product
/// `(m − 1)·m·(2m − 1) < 2⁶¹` fits in 64 bits.
fn squares_below(m: u64) -> u64 {
    if m == 0 {
        return 0;
    }
    (m - 1) * m * (2 * m - 1) / 6
}

/// [`squares_below`] in floating point, for rows wider than [`WORD_ROWS`] (none reaches the
/// tracker: `io::limits` caps a side at 65536).
fn squares_below_f64(m: u64) -> f64 {
    let m = m as f64;
    (m - 1.0) * m * (2.0 * m - 1.0) / 6.0
}

/// The widest row whose closed-form sums [`Moments::of_mask`] computes in 64 bits: a row's
/// `Σx² < w³/3 ≤ 2⁶⁰` and [`squares_below`]'s product `< 2⁶¹`. Masks are capped far below
/// (`io::limits`: 65536 per side), so the floating-point path for wider rows is a guard only
/// (its sums pass 2⁵³, where the per-pixel sums were not exact either). The sums were in 128
/// bits before: in wasm every 128-bit multiply, divide and conversion to `f64` is a call into
/// compiler-builtins (`__multi3`, `__udivti3`, `__floatuntidf`), ~4 % of the browser build's
/// tracker time on the demo scene, where natively they are a few instructions (issue 10).
const WORD_ROWS: usize = 1 << 20;

/// Raw sums of a mask's pixel coordinates, added a row at a time, in local (bitmap)
/// coordinates.
#[derive(Default)]
struct Sums {
    n: u64,
    sx: f64,
    sy: f64,
    sxx: f64,
    syy: f64,
    sxy: f64,
}

impl Sums {
    /// Adds row `y`'s `rn` pixels, their x sum `rx` and x² sum `rxx`.
    fn add_row(&mut self, y: f64, rn: u64, rx: f64, rxx: f64) {
        if rn == 0 {
            return;
        }
        let rnf = rn as f64;
        self.n += rn;
        self.sx += rx;
        self.sy += y * rnf;
        self.sxx += rxx;
        self.syy += y * y * rnf;
        self.sxy += y * rx;
    }

    /// Central moments from the raw sums; `None` when no pixel was added.
    fn moments(&self, mask: &Mask) -> Option<Moments> {
        if self.n == 0 {
            return None;
        }
        let m00 = self.n as f64;
        let (cx, cy) = (self.sx / m00, self.sy / m00);
        Some(Moments {
            m00,
            centroid: Point::new(mask.x() as f64 + cx + 0.5, mask.y() as f64 + cy + 0.5),
            mu20: (self.sxx - cx * self.sx).max(0.0),
            mu02: (self.syy - cy * self.sy).max(0.0),
            mu11: self.sxy - cx * self.sy,
        })
    }
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
        let mut sums = Sums::default();
        // Each row's sums come from its runs in closed form (a run's pixels are consecutive
        // integers), found a word at a time: the per-pixel loop was a few percent of the
        // tracker in wasm (issue 10). The integers are those the per-pixel float sums held
        // exactly (below 2⁵³), so the moments are the same bit for bit.
        for (ly, row) in mask.data().chunks_exact(w).enumerate() {
            // The same integers either way, so the same f64s: a conversion rounds the value,
            // whatever its width.
            let (rn, rx, rxx) = if w <= WORD_ROWS {
                let (mut rn, mut rx, mut rxx) = (0u64, 0u64, 0u64);
                for (a, b) in runs(row) {
                    let (a, b) = (a as u64, b as u64);
                    rn += b - a;
                    rx += (a + b - 1) * (b - a) / 2;
                    rxx += squares_below(b) - squares_below(a);
                }
                (rn, rx as f64, rxx as f64)
            } else {
                let (mut rn, mut rx, mut rxx) = (0u64, 0f64, 0f64);
                for (a, b) in runs(row) {
                    let (a, b) = (a as u64, b as u64);
                    rn += b - a;
                    rx += (a + b - 1) as f64 * (b - a) as f64 / 2.0;
                    rxx += squares_below_f64(b) - squares_below_f64(a);
                }
                (rn, rx, rxx)
            };
            sums.add_row(ly as f64, rn, rx, rxx);
        }
        sums.moments(mask)
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

    /// The per-pixel float sums [`Moments::of_mask`] replaced by runs in closed form.
    fn per_pixel(mask: &Mask) -> Option<Moments> {
        let w = mask.width() as usize;
        let mut sums = Sums::default();
        for (ly, row) in mask.data().chunks_exact(w.max(1)).enumerate() {
            let y = ly as f64;
            let (mut rn, mut rx, mut rxx) = (0u64, 0f64, 0f64);
            for (lx, _) in row.iter().enumerate().filter(|(_, &v)| v != 0) {
                let x = lx as f64;
                rn += 1;
                rx += x;
                rxx += x * x;
            }
            sums.add_row(y, rn, rx, rxx);
        }
        sums.moments(mask)
    }

    #[test]
    fn run_sums_equal_per_pixel_sums_bit_for_bit() {
        let mut s = 7u32;
        let mut next = |m: u32| {
            s = s.wrapping_mul(1_103_515_245).wrapping_add(12345);
            (s >> 8) % m
        };
        for _ in 0..400 {
            let (w, h) = (1 + next(300), 1 + next(60));
            // Blobs, specks and empty rows: runs of random length of either kind.
            let mut d = Vec::with_capacity((w * h) as usize);
            while d.len() < (w * h) as usize {
                let v = u8::from(next(3) == 0);
                d.extend(std::iter::repeat_n(v, 1 + next(40) as usize));
            }
            d.truncate((w * h) as usize);
            let m = Mask::new(next(2000) as i32 - 1000, next(2000) as i32, w, h, d).unwrap();
            assert_eq!(Moments::of_mask(&m), per_pixel(&m));
        }
    }

    #[test]
    fn the_64_bit_row_sums_are_exact_up_to_their_bound() {
        // The closed form at and near the widest row the 64-bit path takes, against 128 bits.
        let wide = |m: u64| {
            let m = u128::from(m);
            m.checked_sub(1).map_or(0, |m1| m1 * m * (2 * m - 1) / 6)
        };
        for m in (0..2000u64).chain((WORD_ROWS as u64 - 2000)..=WORD_ROWS as u64) {
            assert_eq!(u128::from(squares_below(m)), wide(m), "m = {m}");
        }
        // A row as wide as the bound, with runs at both ends: the per-pixel sums bit for bit;
        // one past it (the floating-point guard): the same to rounding.
        for w in [WORD_ROWS, WORD_ROWS + 1] {
            let mut d = vec![0u8; w];
            d[..3].fill(1);
            d[w / 2..w / 2 + 1000].fill(1);
            d[w - 5..].fill(1);
            let m = Mask::new(-7, 3, w as u32, 1, d).unwrap();
            let (got, want) = (Moments::of_mask(&m).unwrap(), per_pixel(&m).unwrap());
            if w == WORD_ROWS {
                assert_eq!(got, want);
            } else {
                let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1.0);
                assert!(close(got.centroid.x, want.centroid.x), "{got:?} {want:?}");
                assert!(close(got.mu20, want.mu20), "{got:?} {want:?}");
            }
        }
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
