//! Canny edges and outer contours of a mask (thesis §3.2.2–3.2.3), in image coordinates.
//!
//! Both work on a crop of the mask's foreground bounding box padded with background, so that
//! pixels on the mask's border still have an outside: Canny needs room for its blur and skips
//! the image's outermost row and column, and the border follower only starts an outer border
//! next to a background pixel.

use image::GrayImage;
use imageproc::contours::{find_contours, BorderType};

use super::shell::signed_area;
use super::GeometryError;
use crate::frame::{Mask, Point};

/// Background pixels added on every side of the crop. Canny blurs with σ = 1.4 and its edges
/// can fall one pixel outside the mask; 3 pixels keep every such edge away from the crop
/// border, where imageproc's non-maximum suppression does not look.
pub const CROP_PAD: u32 = 3;

/// A mask's foreground, padded, as a 0/255 grey image, with the image position of its
/// top-left pixel.
#[derive(Debug, Clone)]
pub struct MaskCrop {
    /// The padded crop, foreground 255.
    pub image: GrayImage,
    /// Image x of the crop's left column.
    pub x0: i64,
    /// Image y of the crop's top row.
    pub y0: i64,
}

impl MaskCrop {
    /// The crop of `mask`'s foreground bounding box padded by `pad`. Errors on an empty mask
    /// or a crop too large to address.
    pub fn new(mask: &Mask, pad: u32) -> Result<MaskCrop, GeometryError> {
        let w = mask.width() as usize;
        let data = mask.data();
        // Tight foreground rectangle in bitmap coordinates.
        let (mut lx0, mut ly0, mut lx1, mut ly1) = (usize::MAX, usize::MAX, 0usize, 0usize);
        if w > 0 {
            for (ly, row) in data.chunks_exact(w).enumerate() {
                if let (Some(a), Some(b)) = (
                    row.iter().position(|&v| v != 0),
                    row.iter().rposition(|&v| v != 0),
                ) {
                    lx0 = lx0.min(a);
                    lx1 = lx1.max(b);
                    ly0 = ly0.min(ly);
                    ly1 = ly1.max(ly);
                }
            }
        }
        if lx0 == usize::MAX {
            return Err(GeometryError::EmptyMask);
        }
        let too_large = || GeometryError::MaskTooLarge {
            width: mask.width(),
            height: mask.height(),
        };
        let fw = lx1 - lx0 + 1;
        let fh = ly1 - ly0 + 1;
        let pad_us = pad as usize;
        let cw = fw
            .checked_add(2 * pad_us)
            .filter(|&v| v <= u32::MAX as usize)
            .ok_or_else(too_large)?;
        let ch = fh
            .checked_add(2 * pad_us)
            .filter(|&v| v <= u32::MAX as usize)
            .ok_or_else(too_large)?;
        cw.checked_mul(ch).ok_or_else(too_large)?;
        let mut buf = vec![0u8; cw * ch];
        for ly in ly0..=ly1 {
            let src = &data[ly * w + lx0..=ly * w + lx1];
            let start = (ly - ly0 + pad_us) * cw + pad_us;
            for (o, &v) in buf[start..start + fw].iter_mut().zip(src) {
                *o = if v != 0 { 255 } else { 0 };
            }
        }
        let image = GrayImage::from_raw(cw as u32, ch as u32, buf).ok_or_else(too_large)?;
        Ok(MaskCrop {
            image,
            x0: mask.x() as i64 + lx0 as i64 - pad as i64,
            y0: mask.y() as i64 + ly0 as i64 - pad as i64,
        })
    }

    /// Image coordinates of the centre of crop pixel `(x, y)`.
    #[inline]
    pub fn to_image(&self, x: i64, y: i64) -> Point {
        Point::new((self.x0 + x) as f64 + 0.5, (self.y0 + y) as f64 + 0.5)
    }

    /// Centres of the Canny edge pixels (imageproc: Gaussian σ = 1.4, Sobel, non-maximum
    /// suppression, hysteresis between `low` and `high`), row by row.
    /// Thresholds must satisfy `0 ≤ low ≤ high` (checked by the caller's config).
    pub fn canny_points(&self, low: f32, high: f32) -> Vec<Point> {
        let edges = imageproc::edges::canny(&self.image, low, high);
        edges
            .enumerate_pixels()
            .filter(|(_, _, p)| p.0[0] != 0)
            .map(|(x, y, _)| self.to_image(x as i64, y as i64))
            .collect()
    }

    /// Every outer border (Suzuki–Abe border following, 8-connected), compressed like
    /// OpenCV's `CHAIN_APPROX_SIMPLE`, in image coordinates (pixel centres), largest enclosed
    /// area first. Holes are left out: they lie inside their outer border.
    pub fn outer_contours(&self) -> Vec<Vec<Point>> {
        let mut out: Vec<(f64, Vec<Point>)> = find_contours::<i32>(&self.image)
            .into_iter()
            .filter(|c| c.border_type == BorderType::Outer)
            .map(|c| {
                let chain: Vec<(i32, i32)> = c.points.iter().map(|p| (p.x, p.y)).collect();
                let pts: Vec<Point> = approx_simple(&chain)
                    .into_iter()
                    .map(|(x, y)| self.to_image(x as i64, y as i64))
                    .collect();
                // Border following goes counter-clockwise on screen, i.e. negative area in
                // the y-up convention: take the magnitude.
                (signed_area(&pts).abs(), pts)
            })
            .collect();
        // Stable: equal areas keep discovery (raster) order, so the choice is repeatable.
        out.sort_by(|a, b| b.0.total_cmp(&a.0).then(b.1.len().cmp(&a.1.len())));
        out.into_iter().map(|(_, p)| p).collect()
    }
}

/// OpenCV's `CHAIN_APPROX_SIMPLE` on a closed chain of 8-connected pixels: keeps only the
/// points where the step direction changes, i.e. drops the inner points of horizontal,
/// vertical and diagonal runs (a filled rectangle keeps its 4 corners). A one- or two-point
/// chain is returned as is.
pub fn approx_simple(chain: &[(i32, i32)]) -> Vec<(i32, i32)> {
    let n = chain.len();
    if n <= 2 {
        return chain.to_vec();
    }
    (0..n)
        .filter(|&i| {
            let p = chain[i];
            let prev = chain[(i + n - 1) % n];
            let next = chain[(i + 1) % n];
            (p.0 - prev.0, p.1 - prev.1) != (next.0 - p.0, next.1 - p.1)
        })
        .map(|i| chain[i])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn contour_px(m: &Mask) -> Vec<Vec<(i64, i64)>> {
        MaskCrop::new(m, CROP_PAD)
            .unwrap()
            .outer_contours()
            .into_iter()
            .map(|c| {
                c.into_iter()
                    .map(|p| ((p.x - 0.5) as i64, (p.y - 0.5) as i64))
                    .collect()
            })
            .collect()
    }

    #[test]
    fn filled_rectangle_gives_four_corners() {
        let m = Mask::new(3, 2, 5, 4, vec![1; 20]).unwrap();
        // Same points and order as OpenCV's findContours(RETR_EXTERNAL, CHAIN_APPROX_SIMPLE).
        assert_eq!(contour_px(&m), vec![vec![(3, 2), (3, 5), (7, 5), (7, 2)]]);
    }

    #[test]
    fn l_shape_gives_opencv_corners() {
        // 10×10 image, rows 1..8 × cols 1..4 plus rows 5..8 × cols 1..8 (the fixture script's
        // first case). The concave corner is cut diagonally by 8-connected border following,
        // so OpenCV — and we — return 7 points, not the 6 corners of the outline.
        let mut full = vec![0u8; 100];
        for y in 1..8 {
            for x in 1..4 {
                full[y * 10 + x] = 1;
            }
        }
        for y in 5..8 {
            for x in 1..8 {
                full[y * 10 + x] = 1;
            }
        }
        let m = Mask::from_full(10, 10, &full).unwrap();
        assert_eq!(
            contour_px(&m),
            vec![vec![(1, 1), (1, 7), (7, 7), (7, 5), (4, 5), (3, 4), (3, 1)]]
        );
    }

    #[test]
    fn lines_and_single_pixels() {
        let m = Mask::new(3, 2, 5, 1, vec![1; 5]).unwrap();
        assert_eq!(contour_px(&m), vec![vec![(3, 2), (7, 2)]]);
        let m = Mask::new(3, 2, 1, 1, vec![1]).unwrap();
        assert_eq!(contour_px(&m), vec![vec![(3, 2)]]);
        // Two parts: the larger first.
        let m = Mask::new(0, 0, 6, 2, vec![1, 0, 0, 1, 1, 1, 0, 0, 0, 1, 1, 1]).unwrap();
        let c = contour_px(&m);
        assert_eq!(c.len(), 2);
        assert_eq!(c[0], vec![(3, 0), (3, 1), (5, 1), (5, 0)]);
        assert_eq!(c[1], vec![(0, 0)]);
    }

    #[test]
    fn approx_simple_drops_diagonal_runs() {
        let chain = [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)];
        assert_eq!(approx_simple(&chain), vec![(0, 0), (2, 2), (0, 2)]);
    }

    #[test]
    fn empty_mask_is_an_error() {
        assert!(matches!(
            MaskCrop::new(&Mask::empty(), 3),
            Err(GeometryError::EmptyMask)
        ));
        assert!(matches!(
            MaskCrop::new(&Mask::new(0, 0, 2, 2, vec![0; 4]).unwrap(), 3),
            Err(GeometryError::EmptyMask)
        ));
    }
}
