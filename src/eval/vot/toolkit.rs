//! A port of the VOT toolkit's raster overlap (`vot/region/raster.py`).
//!
//! (The `Toolkit` overlap method: kept apart from the exact geometry because it reproduces
//! the toolkit's rasterisation rules, quirks included, rather than the geometry.)

use super::MAX_RASTER;
use crate::frame::Mask;
use crate::io::vot::Region;

enum Shape<'a> {
    Empty,
    Rect([f64; 4]),
    Poly(Vec<(f64, f64)>),
    Mask(&'a Mask),
}

type Bounds = (i64, i64, i64, i64);

fn shape(r: &Region) -> Option<Shape<'_>> {
    let finite = |v: f64| v.is_finite() && v.abs() < 1e12;
    Some(match r {
        Region::Special(_) => Shape::Empty,
        Region::Rectangle(b) => {
            let d = [b.x, b.y, b.w, b.h];
            if !d.iter().all(|&v| finite(v)) {
                return None;
            }
            Shape::Rect(d.map(f64::round_ties_even))
        }
        Region::Polygon(p) if p.len() < 3 => Shape::Empty,
        Region::Polygon(p) => {
            if !p.iter().all(|q| finite(q.x) && finite(q.y)) {
                return None;
            }
            Shape::Poly(
                p.iter()
                    .map(|q| (q.x.round_ties_even(), q.y.round_ties_even()))
                    .collect(),
            )
        }
        Region::Mask(m) => Shape::Mask(m),
    })
}

fn mask_bounds(m: &Mask) -> Bounds {
    let w = m.width() as usize;
    let (mut l, mut t, mut r, mut b) = (i64::MAX, i64::MAX, i64::MIN, i64::MIN);
    for (i, row) in m.data().chunks(w.max(1)).enumerate() {
        for (j, &v) in row.iter().enumerate() {
            if v != 0 {
                t = t.min(i as i64);
                b = b.max(i as i64);
                l = l.min(j as i64);
                r = r.max(j as i64);
            }
        }
    }
    if t == i64::MAX {
        return (0, 0, 0, 0);
    }
    (l, t, r, b)
}

fn bounds_of(s: &Shape) -> Bounds {
    match s {
        Shape::Empty => (0, 0, 0, 0),
        Shape::Rect(d) => (
            d[0] as i64,
            d[1] as i64,
            (d[0] + d[2] - 1.0) as i64,
            (d[1] + d[3] - 1.0) as i64,
        ),
        Shape::Poly(p) => {
            let (mut l, mut t, mut r, mut b) = (
                f64::from(f32::MAX),
                f64::from(f32::MAX),
                f64::from(f32::MIN),
                f64::from(f32::MIN),
            );
            for &(x, y) in p {
                t = t.min(y);
                b = b.max(y);
                l = l.min(x);
                r = r.max(x);
            }
            (l as i64, t as i64, r as i64, b as i64)
        }
        Shape::Mask(m) => {
            let (l, t, r, b) = mask_bounds(m);
            let (ox, oy) = (m.x() as i64, m.y() as i64);
            (l + ox, t + oy, r + ox, b + oy)
        }
    }
}

/// Python's `range(len)[start:stop]` for a non-negative `start`.
fn py_range(start: i64, stop: i64, len: i64) -> std::ops::Range<i64> {
    let stop = if stop < 0 {
        (stop + len).max(0)
    } else {
        stop.min(len)
    };
    let start = start.min(len);
    start..stop.max(start)
}

fn raster(s: &Shape, b: Bounds) -> Vec<u8> {
    let width = b.2 - b.0 + 1;
    let height = b.3 - b.1 + 1;
    let mut out = vec![0u8; (width * height) as usize];
    match s {
        Shape::Empty => {}
        Shape::Rect(d) => {
            let (x, y, w, h) = (d[0] as i64, d[1] as i64, d[2] as i64, d[3] as i64);
            if x > b.2 || x + w - 1 < b.0 || y > b.3 || y + h - 1 < b.1 {
                return out;
            }
            let left = 0.max(x - b.0);
            let top = 0.max(y - b.1);
            let right = b.2.min(x + w - 1 - b.0);
            let bottom = b.3.min(y + h - 1 - b.1);
            for i in py_range(top, bottom + 1, height) {
                for j in py_range(left, right + 1, width) {
                    out[(i * width + j) as usize] = 1;
                }
            }
        }
        Shape::Poly(p) => {
            let poly: Vec<(f64, f64)> = p
                .iter()
                .map(|&(x, y)| (x - b.0 as f64, y - b.1 as f64))
                .collect();
            let count = poly.len();
            let mut node_x = vec![0i64; count];
            for pixel_y in 0..height {
                let py = pixel_y as f64;
                let mut nodes = 0usize;
                let mut j = count - 1;
                for i in 0..count {
                    let (pi, pj) = (poly[i], poly[j]);
                    if (pi.1 <= py && pj.1 > py)
                        || (pj.1 <= py && pi.1 > py)
                        || (pi.1 < py && pj.1 >= py)
                        || (pj.1 < py && pi.1 >= py)
                        || (pi.1 == pj.1 && pi.1 == py)
                    {
                        let r = pj.1 - pi.1;
                        let k = pj.0 - pi.0;
                        node_x[nodes] = if r != 0.0 {
                            (pi.0 + (py - pi.1) / r * k) as i64
                        } else {
                            pi.0 as i64
                        };
                        nodes += 1;
                    }
                    j = i;
                }
                let mut i = 0usize;
                while i + 1 < nodes {
                    if node_x[i] > node_x[i + 1] {
                        node_x.swap(i, i + 1);
                        i = i.saturating_sub(1);
                    } else {
                        i += 1;
                    }
                }
                let mut i = 0usize;
                while i + 1 < nodes {
                    if node_x[i] >= width {
                        break;
                    }
                    if node_x[i] == node_x[i + 1] && i + 2 < nodes {
                        i += 1;
                        continue;
                    }
                    if node_x[i + 1] >= 0 {
                        if node_x[i] < 0 {
                            node_x[i] = 0;
                        }
                        if node_x[i + 1] >= width {
                            node_x[i + 1] = width - 1;
                        }
                        for x in node_x[i]..=node_x[i + 1] {
                            out[(pixel_y * width + x) as usize] = 1;
                        }
                    }
                    i += 2;
                }
            }
        }
        Shape::Mask(m) => {
            let (ox, oy) = (m.x() as i64, m.y() as i64);
            let (mw, mh) = (m.width() as i64, m.height() as i64);
            let tx = ox.max(b.0);
            let ty = oy.max(b.1);
            let (dx, dy) = (tx - b.0, ty - b.1);
            let (gx, gy) = (tx - ox, ty - oy);
            let tw = (b.2 + 1).min(ox + mw) - tx;
            let th = (b.3 + 1).min(oy + mh) - ty;
            for i in 0..th.max(0) {
                for j in 0..tw.max(0) {
                    out[((i + dy) * width + j + dx) as usize] =
                        m.data()[((i + gy) * mw + j + gx) as usize];
                }
            }
        }
    }
    out
}

/// `None` when the raster would be too large (or coordinates absurd).
pub(super) fn overlap(a: &Region, b: &Region, bounds: Option<(u32, u32)>) -> Option<f64> {
    let (sa, sb) = (shape(a)?, shape(b)?);
    let (b1, b2) = (bounds_of(&sa), bounds_of(&sb));
    let union = (
        b1.0.min(b2.0),
        b1.1.min(b2.1),
        b1.2.max(b2.2),
        b1.3.max(b2.3),
    );
    if union.0 >= union.2 || union.1 >= union.3 {
        return Some(1.0);
    }
    let rb = match bounds {
        Some((w, h)) => (
            union.0.max(0),
            union.1.max(0),
            (w as i64 - 1).min(union.2),
            (h as i64 - 1).min(union.3),
        ),
        None => union,
    };
    if rb.0 >= rb.2 || rb.1 >= rb.3 {
        return Some(0.0);
    }
    if (rb.2 - rb.0 + 1).checked_mul(rb.3 - rb.1 + 1)? > MAX_RASTER {
        return None;
    }
    let (m1, m2) = (raster(&sa, rb), raster(&sb, rb));
    let (mut inter, mut uni) = (0u64, 0u64);
    for (&p, &q) in m1.iter().zip(&m2) {
        if p != 0 || q != 0 {
            uni += 1;
            if p != 0 && q != 0 {
                inter += 1;
            }
        }
    }
    Some(if uni > 0 {
        inter as f64 / uni as f64
    } else {
        0.0
    })
}
