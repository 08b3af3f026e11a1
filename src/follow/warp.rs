//! Moving a mask by a fitted transform, and rasterising polygons.

use crate::features::transform::Transform;
use crate::frame::{Mask, Point};

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
    if poly.len() < 3 || poly.iter().any(|p| !(p.x.is_finite() && p.y.is_finite())) {
        return Mask::empty();
    }
    let (mut y0, mut y1, mut x0, mut x1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for p in poly {
        y0 = y0.min(p.y);
        y1 = y1.max(p.y);
        x0 = x0.min(p.x);
        x1 = x1.max(p.x);
    }
    let gx0 = (x0.floor().max(0.0) as u32).min(img_w);
    let gx1 = (x1.ceil().max(0.0) as u32).min(img_w);
    let gy0 = (y0.floor().max(0.0) as u32).min(img_h);
    let gy1 = (y1.ceil().max(0.0) as u32).min(img_h);
    if gx1 <= gx0 || gy1 <= gy0 {
        return Mask::empty();
    }
    let (w, h) = ((gx1 - gx0) as usize, (gy1 - gy0) as usize);
    let mut data = vec![0u8; w * h];
    let mut xs = Vec::new();
    for row in 0..h {
        let yc = (gy0 as usize + row) as f64 + 0.5;
        xs.clear();
        for i in 0..poly.len() {
            let a = poly[i];
            let b = poly[(i + 1) % poly.len()];
            // Half-open in y so a vertex on the scanline is counted once.
            if (a.y <= yc) != (b.y <= yc) {
                xs.push(a.x + (yc - a.y) / (b.y - a.y) * (b.x - a.x));
            }
        }
        xs.sort_by(f64::total_cmp);
        for pair in xs.chunks_exact(2) {
            // Pixel centres x + 0.5 within [pair[0], pair[1]).
            let from = ((pair[0] - 0.5).ceil().max(gx0 as f64) as i64 - gx0 as i64).max(0) as usize;
            let to = ((pair[1] - 0.5).ceil().min(gx1 as f64) as i64 - gx0 as i64).max(0) as usize;
            if to > from {
                data[row * w + from..row * w + to.min(w)].fill(1);
            }
        }
    }
    Mask::new(gx0 as i32, gy0 as i32, w as u32, h as u32, data)
        .map(|m| m.tight())
        .unwrap_or_else(|_| Mask::empty())
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
}
