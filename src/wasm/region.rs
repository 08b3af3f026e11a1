//! A detection's pixels as [`super::Detections`]' overlap tests compare them: its mask, or
//! its box kept as a rectangle (split from `detect.rs`, which holds the bindings).

use crate::frame::{Detection, Mask};

/// A detection's pixels for [`Detections::add_uncovered`]: its mask, or the pixels whose
/// centres its box covers (as `Mask::from_bbox` rasterises it), kept as a rectangle: a box of
/// any size from a JS detector costs nothing to compare, where rasterising it could exhaust
/// wasm memory.
pub(super) enum Region<'a> {
    Mask(&'a Mask),
    /// `[x0, y0, x1, y1)` in whole pixels.
    Rect([f64; 4]),
}

impl<'a> Region<'a> {
    pub(super) fn of(d: &'a Detection) -> Self {
        match &d.mask {
            Some(m) => Region::Mask(m),
            None => {
                let b = &d.bbox;
                let px = |v: f64| (v - 0.5).ceil();
                Region::Rect([px(b.x), px(b.y), px(b.x2()), px(b.y2())])
            }
        }
    }

    pub(super) fn area(&self) -> f64 {
        match self {
            Region::Mask(m) => m.area() as f64,
            Region::Rect([x0, y0, x1, y1]) => (x1 - x0).max(0.0) * (y1 - y0).max(0.0),
        }
    }

    /// Pixels in both.
    pub(super) fn overlap(&self, other: &Region) -> f64 {
        match (self, other) {
            (Region::Mask(a), Region::Mask(b)) => a.intersection(b) as f64,
            (Region::Mask(m), Region::Rect(r)) | (Region::Rect(r), Region::Mask(m)) => {
                mask_in_rect(m, r)
            }
            (Region::Rect([a0, b0, a1, b1]), Region::Rect([c0, d0, c1, d1])) => {
                (a1.min(*c1) - a0.max(*c0)).max(0.0) * (b1.min(*d1) - b0.max(*d0)).max(0.0)
            }
        }
    }
}

/// The pixels of `m` inside the rectangle `[x0, y0, x1, y1)`: a walk over the part of the
/// mask's own bitmap the rectangle covers.
fn mask_in_rect(m: &Mask, &[x0, y0, x1, y1]: &[f64; 4]) -> f64 {
    let (mx, my) = (f64::from(m.x()), f64::from(m.y()));
    let (w, h) = (f64::from(m.width()), f64::from(m.height()));
    // Bitmap columns and rows, clamped to the bitmap (so the casts cannot overflow).
    let cols = (x0 - mx).clamp(0.0, w) as usize..(x1 - mx).clamp(0.0, w) as usize;
    let rows = (y0 - my).clamp(0.0, h) as usize..(y1 - my).clamp(0.0, h) as usize;
    let stride = m.width() as usize;
    let data = m.data();
    rows.map(|r| {
        data.get(r * stride + cols.start..r * stride + cols.end)
            .map_or(0, |row| row.iter().filter(|&&v| v != 0).count())
    })
    .sum::<usize>() as f64
}
