//! Polygon segmentations rasterised into RLE exactly as pycocotools' `rleFrPoly` does.

use crate::io::Rle;

/// The most boundary points [`rle_from_polygon`] will generate (about 200 MB of work); a
/// polygon whose perimeter needs more is rejected rather than exhausting memory.
const MAX_POLYGON_STEPS: u64 = 1 << 24;

/// Errors rasterising a polygon.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PolygonError {
    /// A polygon needs at least 3 points, given as an even number of coordinates.
    #[error("a polygon needs an even number (at least 6) of coordinates, got {0}")]
    TooFewCoordinates(usize),
    /// A coordinate is NaN or infinite.
    #[error("polygon coordinate {0} is not finite")]
    NotFinite(f64),
    /// The polygon is so large that rasterising it would exhaust memory.
    #[error("polygon perimeter is too long to rasterise ({steps} boundary steps)")]
    TooLarge {
        /// Boundary steps the rasteriser would need.
        steps: u64,
    },
}

/// Rasterises a polygon (`[x0, y0, x1, y1, …]`, pixel coordinates) into an `height × width`
/// RLE exactly as pycocotools' `rleFrPoly`: the boundary is walked on a 5× grid and a pixel is
/// foreground when its centre's column crossing lies inside, so the result is byte-identical
/// to `pycocotools.mask.frPyObjects([poly], h, w)`.
pub fn rle_from_polygon(xy: &[f64], height: u32, width: u32) -> Result<Rle, PolygonError> {
    if xy.len() < 6 || xy.len() % 2 != 0 {
        return Err(PolygonError::TooFewCoordinates(xy.len()));
    }
    if let Some(&v) = xy.iter().find(|v| !v.is_finite()) {
        return Err(PolygonError::NotFinite(v));
    }
    let (h, w) = (height as i64, width as i64);
    if h == 0 || w == 0 {
        return Ok(Rle::empty(width, height));
    }
    let scale = 5.0f64;
    let k = xy.len() / 2;
    // C's `(int)(scale*v + .5)`: truncation toward zero, which `as` also does (saturating, so
    // absurd coordinates cannot overflow; they are caught by the step limit below).
    let px: Vec<i64> = (0..=k)
        .map(|j| (scale * xy[2 * (j % k)] + 0.5) as i32 as i64)
        .collect();
    let py: Vec<i64> = (0..=k)
        .map(|j| (scale * xy[2 * (j % k) + 1] + 0.5) as i32 as i64)
        .collect();
    let steps: u64 = (0..k)
        .map(|j| {
            (px[j] - px[j + 1])
                .unsigned_abs()
                .max((py[j] - py[j + 1]).unsigned_abs())
                + 1
        })
        .sum();
    if steps > MAX_POLYGON_STEPS {
        return Err(PolygonError::TooLarge { steps });
    }
    // Dense points along the whole boundary.
    let mut u: Vec<i64> = Vec::with_capacity(steps as usize);
    let mut v: Vec<i64> = Vec::with_capacity(steps as usize);
    for j in 0..k {
        let (mut xs, mut xe, mut ys, mut ye) = (px[j], px[j + 1], py[j], py[j + 1]);
        let dx = (xe - xs).abs();
        let dy = (ys - ye).abs();
        let flip = (dx >= dy && xs > xe) || (dx < dy && ys > ye);
        if flip {
            std::mem::swap(&mut xs, &mut xe);
            std::mem::swap(&mut ys, &mut ye);
        }
        if dx >= dy {
            let s = if dx == 0 {
                0.0
            } else {
                (ye - ys) as f64 / dx as f64
            };
            for d in 0..=dx {
                let t = if flip { dx - d } else { d };
                u.push(t + xs);
                v.push((ys as f64 + s * t as f64 + 0.5) as i64);
            }
        } else {
            let s = (xe - xs) as f64 / dy as f64;
            for d in 0..=dy {
                let t = if flip { dy - d } else { d };
                v.push(t + ys);
                u.push((xs as f64 + s * t as f64 + 0.5) as i64);
            }
        }
    }
    // Points where the boundary crosses a pixel-centre column, downsampled to pixels.
    let mut a: Vec<i64> = Vec::new();
    for j in 1..u.len() {
        if u[j] == u[j - 1] {
            continue;
        }
        let xd = if u[j] < u[j - 1] { u[j] } else { u[j] - 1 } as f64;
        let xd = (xd + 0.5) / scale - 0.5;
        if xd.floor() != xd || xd < 0.0 || xd > (w - 1) as f64 {
            continue;
        }
        let yd = if v[j] < v[j - 1] { v[j] } else { v[j - 1] } as f64;
        let mut yd = (yd + 0.5) / scale - 0.5;
        if yd < 0.0 {
            yd = 0.0;
        } else if yd > h as f64 {
            yd = h as f64;
        }
        a.push(xd as i64 * h + yd.ceil() as i64);
    }
    a.push(h * w);
    a.sort_unstable();
    let mut prev = 0i64;
    for x in a.iter_mut() {
        let t = *x;
        *x -= prev;
        prev = t;
    }
    // Two crossings at the same pixel cancel: fold the run after a zero gap into the one before.
    let mut counts: Vec<u32> = Vec::with_capacity(a.len());
    counts.push(a[0] as u32);
    let mut j = 1;
    while j < a.len() {
        if a[j] > 0 {
            counts.push(a[j] as u32);
            j += 1;
        } else {
            j += 1;
            if j < a.len() {
                if let Some(last) = counts.last_mut() {
                    *last += a[j] as u32;
                }
                j += 1;
            }
        }
    }
    Ok(Rle {
        height,
        width,
        counts,
    })
}
