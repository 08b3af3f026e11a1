//! The per-pixel colour model of a followed target: foreground and surrounding-background
//! colour histograms, and the refinement of a warped mask in a band around its outline.
//!
//! Histograms rather than k-means palettes: the refinement asks "how much more likely is this
//! colour on the target than just around it" for every band pixel of every frame, which a
//! histogram answers with one lookup, and it updates by blending instead of re-clustering.

use crate::frame::{Frame, Mask};

/// Bits kept per RGB channel: 4 bits (16 levels) gives 4096 bins, fine enough to separate a
/// target from its surroundings yet coarse enough that a few thousand samples fill it.
const BITS: u32 = 4;
const BINS: usize = 1 << (3 * BITS);

/// Additive smoothing of the normalised histograms, so an unseen colour gets a likelihood
/// ratio near 1 instead of 0 or infinity.
const SMOOTH: f32 = 2.0 / BINS as f32;

/// Largest |log-likelihood ratio| one colour contributes: keeps a single vivid colour from
/// overruling the shape prior.
const MAX_LLR: f32 = 3.0;

fn bin(rgb: [u8; 3]) -> usize {
    let s = 8 - BITS;
    ((rgb[0] as usize >> s) << (2 * BITS))
        | ((rgb[1] as usize >> s) << BITS)
        | (rgb[2] as usize >> s)
}

/// A sampling grid over a window of the frame: cell `(gx, gy)` stands for the frame pixel at
/// `(x0 + gx·step + step/2, y0 + gy·step + step/2)`. Bounds the per-frame work on large
/// targets (`max(gw, gh) ≤ max_side`).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Grid {
    pub x0: i32,
    pub y0: i32,
    pub step: i32,
    pub gw: usize,
    pub gh: usize,
}

impl Grid {
    /// The grid over frame rectangle `[x0, x1) × [y0, y1)`.
    pub fn new(x0: i32, y0: i32, x1: i32, y1: i32, max_side: u32) -> Grid {
        let (w, h) = ((x1 - x0).max(1), (y1 - y0).max(1));
        let step = ((w.max(h) as f64) / max_side.max(1) as f64).ceil().max(1.0) as i32;
        Grid {
            x0,
            y0,
            step,
            gw: ((w + step - 1) / step) as usize,
            gh: ((h + step - 1) / step) as usize,
        }
    }

    /// Frame pixel sampled by cell `(gx, gy)`.
    pub fn pixel(&self, gx: usize, gy: usize) -> (i32, i32) {
        (
            self.x0 + gx as i32 * self.step + self.step / 2,
            self.y0 + gy as i32 * self.step + self.step / 2,
        )
    }

    /// The mask sampled on the grid (0/1 per cell).
    pub fn sample_mask(&self, m: &Mask) -> Vec<u8> {
        let mut out = vec![0u8; self.gw * self.gh];
        for gy in 0..self.gh {
            for gx in 0..self.gw {
                let (x, y) = self.pixel(gx, gy);
                out[gy * self.gw + gx] = m.get(x, y) as u8;
            }
        }
        out
    }

    /// A full-resolution mask from grid cells (each cell fills its `step × step` block),
    /// clipped to the frame.
    pub fn cells_to_mask(&self, cells: &[u8], img_w: u32, img_h: u32) -> Mask {
        let s = self.step as usize;
        let (w, h) = (self.gw * s, self.gh * s);
        let mut data = vec![0u8; w * h];
        for gy in 0..self.gh {
            for gx in 0..self.gw {
                if cells[gy * self.gw + gx] == 0 {
                    continue;
                }
                for dy in 0..s {
                    let row = (gy * s + dy) * w + gx * s;
                    data[row..row + s].fill(1);
                }
            }
        }
        Mask::new(self.x0, self.y0, w as u32, h as u32, data)
            .map(|m| m.clipped(img_w, img_h).tight())
            .unwrap_or_else(|_| Mask::empty())
    }
}

/// Two-pass chamfer (3-4) distance, in grid cells, from every cell to the nearest cell whose
/// value differs from `target`'s complement: `dist(cells, 1)` is, for each background cell,
/// the distance to the foreground (0 on foreground cells).
fn chamfer(cells: &[u8], gw: usize, gh: usize, to: u8) -> Vec<f32> {
    const BIG: f32 = 1e9;
    let mut d: Vec<f32> = cells
        .iter()
        .map(|&v| if v == to { 0.0 } else { BIG })
        .collect();
    for y in 0..gh {
        for x in 0..gw {
            let i = y * gw + x;
            let mut v = d[i];
            if x > 0 {
                v = v.min(d[i - 1] + 3.0);
            }
            if y > 0 {
                v = v.min(d[i - gw] + 3.0);
                if x > 0 {
                    v = v.min(d[i - gw - 1] + 4.0);
                }
                if x + 1 < gw {
                    v = v.min(d[i - gw + 1] + 4.0);
                }
            }
            d[i] = v;
        }
    }
    for y in (0..gh).rev() {
        for x in (0..gw).rev() {
            let i = y * gw + x;
            let mut v = d[i];
            if x + 1 < gw {
                v = v.min(d[i + 1] + 3.0);
            }
            if y + 1 < gh {
                v = v.min(d[i + gw] + 3.0);
                if x + 1 < gw {
                    v = v.min(d[i + gw + 1] + 4.0);
                }
                if x > 0 {
                    v = v.min(d[i + gw - 1] + 4.0);
                }
            }
            d[i] = v;
        }
    }
    d.iter().map(|v| v / 3.0).collect()
}

/// Signed distance in grid cells to the mask's outline: positive inside, negative outside.
pub(crate) fn signed_distance(cells: &[u8], gw: usize, gh: usize) -> Vec<f32> {
    let to_fg = chamfer(cells, gw, gh, 1);
    let to_bg = chamfer(cells, gw, gh, 0);
    to_fg.iter().zip(&to_bg).map(|(f, b)| b - f).collect()
}

/// Foreground and background colour histograms (each normalised to sum 1).
#[derive(Debug, Clone)]
pub(crate) struct ColourModel {
    fg: Vec<f32>,
    bg: Vec<f32>,
}

/// Where around a mask the background is learnt: the pixels farther than `guard` px from it
/// and at most `guard + width` px.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Ring {
    /// Pixels next to the outline left out of the background (in frame pixels).
    pub guard: f64,
    /// Width of the ring beyond the guard (in frame pixels).
    pub width: f64,
}

impl ColourModel {
    /// Histograms of `mask`'s pixels and of the `ring` around it.
    pub fn learn(frame: &Frame<'_>, mask: &Mask, ring: &Ring, max_side: u32) -> ColourModel {
        let (fg, bg) = histograms(frame, mask, ring, max_side);
        ColourModel { fg, bg }
    }

    /// Blends in the histograms of a new view at `rate` (0 keeps the old model).
    pub fn update(
        &mut self,
        frame: &Frame<'_>,
        mask: &Mask,
        ring: &Ring,
        max_side: u32,
        rate: f32,
    ) {
        let (fg, bg) = histograms(frame, mask, ring, max_side);
        for (a, b) in self.fg.iter_mut().zip(&fg) {
            *a = (1.0 - rate) * *a + rate * b;
        }
        for (a, b) in self.bg.iter_mut().zip(&bg) {
            *a = (1.0 - rate) * *a + rate * b;
        }
    }

    /// The pixels of `mask` that are in `keep`, or whose colour's [`llr`](Self::llr) exceeds
    /// `min_llr`, cropped to their bounding rectangle.
    pub fn vet(&self, frame: &Frame<'_>, mask: &Mask, keep: &Mask, min_llr: f32) -> Mask {
        let (x0, y0, w, h) = (mask.x(), mask.y(), mask.width(), mask.height());
        let data = (0..h as i32)
            .flat_map(|y| (0..w as i32).map(move |x| (x0 + x, y0 + y)))
            .map(|(x, y)| {
                let coloured = || {
                    u32::try_from(x)
                        .ok()
                        .zip(u32::try_from(y).ok())
                        .and_then(|(x, y)| frame.rgb_at(x, y))
                        .is_some_and(|c| self.llr(c) > min_llr)
                };
                u8::from(mask.get(x, y) && (keep.get(x, y) || coloured()))
            })
            .collect();
        Mask::new(x0, y0, w, h, data).map_or_else(|_| Mask::empty(), |m| m.tight())
    }

    /// Clamped log-likelihood ratio foreground : background of a colour.
    pub fn llr(&self, rgb: [u8; 3]) -> f32 {
        let b = bin(rgb);
        ((self.fg[b] + SMOOTH) / (self.bg[b] + SMOOTH))
            .ln()
            .clamp(-MAX_LLR, MAX_LLR)
    }
}

fn histograms(frame: &Frame<'_>, mask: &Mask, ring: &Ring, max_side: u32) -> (Vec<f32>, Vec<f32>) {
    let mut fg = vec![0f32; BINS];
    let mut bg = vec![0f32; BINS];
    let m = mask.tight();
    if m.is_empty() {
        return (fg, bg);
    }
    let outer = ring.guard.max(0.0) + ring.width.max(1.0);
    let r = outer.ceil() as i32;
    let (fw, fh) = (frame.width() as i32, frame.height() as i32);
    let x0 = (m.x() - r).max(0);
    let y0 = (m.y() - r).max(0);
    let x1 = (m.x() + m.width() as i32 + r).min(fw);
    let y1 = (m.y() + m.height() as i32 + r).min(fh);
    if x1 <= x0 || y1 <= y0 {
        return (fg, bg);
    }
    let grid = Grid::new(x0, y0, x1, y1, max_side);
    let cells = grid.sample_mask(&m);
    let sd = signed_distance(&cells, grid.gw, grid.gh);
    let (guard_cells, outer_cells) = (
        (ring.guard.max(0.0) / grid.step as f64) as f32,
        (outer / grid.step as f64) as f32,
    );
    for gy in 0..grid.gh {
        for gx in 0..grid.gw {
            let i = gy * grid.gw + gx;
            let (x, y) = grid.pixel(gx, gy);
            let Some(rgb) = frame.rgb_at(x as u32, y as u32) else {
                continue;
            };
            if cells[i] != 0 {
                fg[bin(rgb)] += 1.0;
            } else if -sd[i] > guard_cells && -sd[i] <= outer_cells {
                bg[bin(rgb)] += 1.0;
            }
        }
    }
    for h in [&mut fg, &mut bg] {
        let s: f32 = h.iter().sum();
        if s > 0.0 {
            h.iter_mut().for_each(|v| *v /= s);
        }
    }
    (fg, bg)
}

/// Settings of [`refine`] (all from [`super::FollowConfig`]).
pub(crate) struct RefineParams {
    /// Half-width of the band, in frame pixels.
    pub band: f64,
    /// Weight of the shape prior (signed distance / band) against the colour evidence.
    pub prior_weight: f32,
    /// Longest grid side.
    pub max_side: u32,
    /// Largest relative change of the area from the warped mask's.
    pub max_area_change: f64,
}

/// Relabels the pixels within `band` of `warped`'s outline by colour: a pixel is target when
/// its colour log-likelihood ratio plus the shape prior (how deep inside the warped mask it
/// lies) is positive. Pixels deeper than the band keep the warped label, so a colour model
/// that is briefly wrong can move the outline by at most the band. Then 3×3 majority smoothing
/// and only components that reach inside the warped mask are kept.
pub(crate) fn refine(
    frame: &Frame<'_>,
    warped: &Mask,
    model: &ColourModel,
    p: &RefineParams,
) -> Mask {
    let m = warped.tight();
    if m.is_empty() {
        return m;
    }
    let (fw, fh) = (frame.width() as i32, frame.height() as i32);
    let r = (p.band.ceil() as i32) + 2;
    let x0 = (m.x() - r).max(0);
    let y0 = (m.y() - r).max(0);
    let x1 = (m.x() + m.width() as i32 + r).min(fw);
    let y1 = (m.y() + m.height() as i32 + r).min(fh);
    if x1 <= x0 || y1 <= y0 {
        return Mask::empty();
    }
    let grid = Grid::new(x0, y0, x1, y1, p.max_side);
    let (gw, gh) = (grid.gw, grid.gh);
    let cells = grid.sample_mask(&m);
    let sd = signed_distance(&cells, gw, gh);
    let band = (p.band / grid.step as f64).max(1.0) as f32;
    let mut lab = vec![0u8; gw * gh];
    let mut scored: Vec<(f32, usize)> = Vec::new();
    let mut core = 0usize;
    let mut warped_cells = 0usize;
    for gy in 0..gh {
        for gx in 0..gw {
            let i = gy * gw + gx;
            let d = sd[i];
            warped_cells += usize::from(cells[i] != 0);
            if d > band {
                lab[i] = 1;
                core += 1;
            } else if d >= -band {
                let (x, y) = grid.pixel(gx, gy);
                let llr = frame
                    .rgb_at(x as u32, y as u32)
                    .map_or(0.0, |c| model.llr(c));
                scored.push((llr + p.prior_weight * (d / band), i));
            }
        }
    }
    // The per-pixel decision is score > 0, but the area may change by at most
    // `max_area_change` per frame: the transform already accounts for scale, and a colour
    // model that slightly prefers the surroundings would otherwise grow the mask a band a frame.
    scored.sort_by(|a, b| b.0.total_cmp(&a.0));
    let positive = scored.iter().take_while(|s| s.0 > 0.0).count();
    let lo = ((warped_cells as f64) * (1.0 - p.max_area_change)) as usize;
    let hi = ((warped_cells as f64) * (1.0 + p.max_area_change)).ceil() as usize;
    let take = positive.clamp(
        lo.saturating_sub(core),
        hi.saturating_sub(core).max(lo.saturating_sub(core)),
    );
    for &(_, i) in scored.iter().take(take) {
        lab[i] = 1;
    }
    let lab = majority(&lab, gw, gh);
    let lab = keep_anchored(&lab, &sd, gw, gh);
    grid.cells_to_mask(&lab, frame.width(), frame.height())
}

/// 3×3 majority vote: removes single-pixel speckle of the per-pixel decision.
fn majority(lab: &[u8], gw: usize, gh: usize) -> Vec<u8> {
    let mut out = lab.to_vec();
    for y in 0..gh {
        for x in 0..gw {
            let mut n = 0;
            let mut c = 0;
            for yy in y.saturating_sub(1)..(y + 2).min(gh) {
                for xx in x.saturating_sub(1)..(x + 2).min(gw) {
                    n += 1;
                    c += lab[yy * gw + xx] as usize;
                }
            }
            out[y * gw + x] = (2 * c > n) as u8;
        }
    }
    out
}

/// Keeps the 4-connected foreground components that contain a cell inside the warped mask
/// (signed distance > 0): colour look-alikes in the band that do not touch the target go.
fn keep_anchored(lab: &[u8], sd: &[f32], gw: usize, gh: usize) -> Vec<u8> {
    let mut out = vec![0u8; lab.len()];
    let mut seen = vec![false; lab.len()];
    let mut stack = Vec::new();
    let mut comp = Vec::new();
    for start in 0..lab.len() {
        if lab[start] == 0 || seen[start] {
            continue;
        }
        comp.clear();
        let mut anchored = false;
        seen[start] = true;
        stack.push(start);
        while let Some(i) = stack.pop() {
            comp.push(i);
            anchored |= sd[i] > 0.0;
            let (x, y) = (i % gw, i / gw);
            let mut push = |j: usize| {
                if lab[j] != 0 && !seen[j] {
                    seen[j] = true;
                    stack.push(j);
                }
            };
            if x > 0 {
                push(i - 1);
            }
            if x + 1 < gw {
                push(i + 1);
            }
            if y > 0 {
                push(i - gw);
            }
            if y + 1 < gh {
                push(i + gw);
            }
        }
        if anchored {
            for &i in &comp {
                out[i] = 1;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signed_distance_is_positive_inside() {
        let (gw, gh) = (9, 9);
        let mut cells = vec![0u8; gw * gh];
        for y in 2..7 {
            for x in 2..7 {
                cells[y * gw + x] = 1;
            }
        }
        let sd = signed_distance(&cells, gw, gh);
        assert!(sd[4 * gw + 4] > 2.0);
        assert!(sd[0] < -1.5);
    }

    #[test]
    fn vet_drops_background_coloured_pixels_outside_the_kept_mask() {
        // A red square (10..30) on blue: the model learns red as target, blue as surroundings.
        let (w, h) = (40u32, 40u32);
        let inside = |x: u32, y: u32| (10..30).contains(&x) && (10..30).contains(&y);
        let rgb: Vec<u8> = (0..w * h)
            .flat_map(|i| {
                if inside(i % w, i / w) {
                    [200, 30, 30]
                } else {
                    [30, 30, 200]
                }
            })
            .collect();
        let frame = Frame::rgb(&rgb, w, h).unwrap();
        let square = Mask::new(10, 10, 20, 20, vec![1; 400]).unwrap();
        let ring = Ring {
            guard: 2.0,
            width: 6.0,
        };
        let model = ColourModel::learn(&frame, &square, &ring, 64);
        // A detection 4 px too tall at the bottom (blue): the blue rows go unless kept.
        let loose = Mask::new(10, 10, 20, 24, vec![1; 480]).unwrap();
        let vetted = model.vet(&frame, &loose, &Mask::empty(), -1.0);
        assert_eq!(vetted.area(), 400);
        assert_eq!((vetted.x(), vetted.y(), vetted.height()), (10, 10, 20));
        // Pixels in `keep` stay whatever their colour.
        let keep = Mask::new(10, 30, 20, 2, vec![1; 40]).unwrap();
        assert_eq!(model.vet(&frame, &loose, &keep, -1.0).area(), 440);
        // A bound no colour reaches keeps only `keep`'s pixels.
        assert_eq!(model.vet(&frame, &loose, &keep, 10.0).area(), 40);
    }
}
