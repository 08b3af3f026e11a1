//! Moving a mask by a fitted transform, and rasterising polygons.

use crate::detect::Morphology;
use crate::features::transform::Transform;
use crate::frame::{Mask, Point};
use crate::synth::raster::Rasterizer;

/// `mask` mapped by `t` (source → target image coordinates), sampled at the target pixel
/// centres by inverse mapping (nearest source pixel), clipped to the `img_w × img_h` frame.
/// A transform that cannot be inverted gives the mask unchanged.
pub fn warp_mask(mask: &Mask, t: &Transform, img_w: u32, img_h: u32) -> Mask {
    let m = mask.tight();
    if m.is_empty() {
        return m;
    }
    let Ok(inv) = t.inverse() else {
        return m.clipped(img_w, img_h);
    };
    let r = m.rect();
    let corners = r.corners().map(|c| t.apply(c));
    let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    for c in corners {
        x0 = x0.min(c.x);
        y0 = y0.min(c.y);
        x1 = x1.max(c.x);
        y1 = y1.max(c.y);
    }
    if !(x0.is_finite() && y0.is_finite() && x1.is_finite() && y1.is_finite()) {
        return m.clipped(img_w, img_h);
    }
    let x0 = (x0.floor() as i64).clamp(0, img_w as i64) as i32;
    let y0 = (y0.floor() as i64).clamp(0, img_h as i64) as i32;
    let x1 = (x1.ceil() as i64).clamp(0, img_w as i64) as i32;
    let y1 = (y1.ceil() as i64).clamp(0, img_h as i64) as i32;
    if x1 <= x0 || y1 <= y0 {
        return Mask::empty();
    }
    let (w, h) = ((x1 - x0) as usize, (y1 - y0) as usize);
    let mut data = vec![0u8; w * h];
    for y in 0..h {
        for x in 0..w {
            let q = Point::new(
                (x0 as usize + x) as f64 + 0.5,
                (y0 as usize + y) as f64 + 0.5,
            );
            let p = inv.apply(q);
            data[y * w + x] = m.get(p.x.floor() as i32, p.y.floor() as i32) as u8;
        }
    }
    Mask::new(x0, y0, w as u32, h as u32, data)
        .map(|m| m.tight())
        .unwrap_or_else(|_| Mask::empty())
}

/// Fills the polygon (even–odd rule, pixel centres) into an `img_w × img_h` frame. Fewer than
/// three vertices, or non-finite ones, give an empty mask.
pub fn rasterize_polygon(poly: &[Point], img_w: u32, img_h: u32) -> Mask {
    if poly.iter().any(|p| !(p.x.is_finite() && p.y.is_finite())) {
        return Mask::empty();
    }
    // The synthetic scenes' scanline filler (pixel centres, half-open edges), clipped here.
    let pts: Vec<[f64; 2]> = poly.iter().map(|p| [p.x, p.y]).collect();
    let w = img_w.min(i32::MAX as u32) as i32;
    let mut spans: Vec<(i32, i32, i32)> = Vec::new();
    Rasterizer::default().spans(&pts, 0..img_h.min(i32::MAX as u32) as i32, |y, a, b| {
        let (a, b) = (a.max(0), b.min(w));
        if b > a {
            spans.push((y, a, b));
        }
    });
    let (Some(first), Some(last)) = (spans.first(), spans.last()) else {
        return Mask::empty();
    };
    let (y0, y1) = (first.0, last.0 + 1);
    let x0 = spans.iter().map(|s| s.1).min().unwrap_or(0);
    let x1 = spans.iter().map(|s| s.2).max().unwrap_or(0);
    let width = (x1 - x0) as usize;
    let mut data = vec![0u8; width * (y1 - y0) as usize];
    for &(y, a, b) in &spans {
        let row = (y - y0) as usize * width;
        data[row + (a - x0) as usize..row + (b - x0) as usize].fill(1);
    }
    Mask::new(x0, y0, width as u32, (y1 - y0) as u32, data)
        .map(|m| m.tight())
        .unwrap_or_else(|_| Mask::empty())
}

/// The pixels of `mask` within `reach` pixels of `near` (Chebyshev distance: `near` grown by
/// a square of side `2·reach + 1`, the detectors' [`Morphology::dilate`]), cropped to their
/// bounding rectangle. Only `near`'s pixels in `mask`'s rectangle grown by `reach` can reach
/// it, so the dilation runs on that rectangle alone.
pub(crate) fn within_reach(mask: &Mask, near: &Mask, reach: u32) -> Mask {
    if mask.is_empty() || near.is_empty() {
        return Mask::empty();
    }
    let k = reach as usize;
    let (x0, y0) = (mask.x(), mask.y());
    let (w, h) = (mask.width() as usize, mask.height() as usize);
    let (ew, eh) = (w + 2 * k, h + 2 * k);
    let (gx0, gy0) = (x0 - k as i32, y0 - k as i32);
    let mut grown: Vec<u8> = (0..eh as i32)
        .flat_map(|y| (0..ew as i32).map(move |x| (gx0 + x, gy0 + y)))
        .map(|(x, y)| u8::from(near.get(x, y)))
        .collect();
    Morphology::new().dilate(&mut grown, ew, eh, reach);
    let data = mask.data();
    let out = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            u8::from(data[i] != 0 && grown[(y + k) * ew + x + k] != 0)
        })
        .collect();
    Mask::new(x0, y0, w as u32, h as u32, out).map_or_else(|_| Mask::empty(), |m| m.tight())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::transform::Translation;
    use crate::frame::BBox;

    #[test]
    fn translation_moves_the_mask() {
        let m = Mask::from_bbox(&BBox::from_xyxy(10.0, 10.0, 15.0, 14.0));
        let t = Transform::Translation(Translation { dx: 3.0, dy: -2.0 });
        let w = warp_mask(&m, &t, 100, 100);
        assert_eq!((w.x(), w.y(), w.width(), w.height()), (13, 8, 5, 4));
        assert_eq!(w.area(), 20);
    }

    #[test]
    fn square_polygon_fills_its_pixels() {
        let p = [
            Point::new(2.0, 2.0),
            Point::new(6.0, 2.0),
            Point::new(6.0, 5.0),
            Point::new(2.0, 5.0),
        ];
        let m = rasterize_polygon(&p, 10, 10);
        assert_eq!(m.area(), 12);
    }

    #[test]
    fn within_reach_matches_a_brute_force_search() {
        // Two overlapping blobs drawn by a hash, so edges run in every direction.
        let blob = |x0: i32, y0: i32, salt: u32| {
            let (w, h) = (23u32, 17u32);
            let data = (0..w * h)
                .map(|i| {
                    let v = (i ^ salt).wrapping_mul(2_654_435_761) >> 29;
                    u8::from(v < 5)
                })
                .collect();
            Mask::new(x0, y0, w, h, data).unwrap()
        };
        let (m, near) = (blob(5, 7, 3), blob(14, 3, 11));
        for reach in [0u32, 1, 2, 5] {
            let got = within_reach(&m, &near, reach);
            let k = reach as i32;
            let mut want = 0;
            for (x, y) in m.pixels() {
                let hit = (-k..=k).any(|dy| (-k..=k).any(|dx| near.get(x + dx, y + dy)));
                assert_eq!(got.get(x, y), hit, "reach {reach} at ({x}, {y})");
                want += u64::from(hit);
            }
            assert_eq!(got.area(), want, "reach {reach}");
        }
        assert!(within_reach(&m, &Mask::empty(), 3).is_empty());
        assert!(within_reach(&Mask::empty(), &near, 3).is_empty());
    }
}
