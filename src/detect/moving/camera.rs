//! The camera's motion between two working frames from sparse matches (a global shift over
//! the frame's outer band, corner points matched around it, an affine fit by RANSAC), the
//! grey working frames it is measured on, and [`CameraJudge`], which tells moving-camera
//! footage from static.

use crate::detect::gray::gray;
use crate::features::transform::{ransac, RansacConfig, Transform, TransformKind};
use crate::frame::{Frame, Point};

/// A grey image at working resolution.
#[derive(Debug, Clone, Default)]
pub(super) struct Gray {
    pub(super) w: usize,
    pub(super) h: usize,
    pub(super) v: Vec<f32>,
}

impl Gray {
    fn at(&self, x: usize, y: usize) -> f32 {
        self.v[y * self.w + x]
    }

    /// Bilinear sample; `None` outside.
    pub(super) fn sample(&self, x: f64, y: f64) -> Option<f32> {
        if !(x >= 0.0 && y >= 0.0 && x <= (self.w - 1) as f64 && y <= (self.h - 1) as f64) {
            return None;
        }
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(self.w - 1), (y0 + 1).min(self.h - 1));
        let (tx, ty) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
        let a = self.at(x0, y0) * (1.0 - tx) + self.at(x1, y0) * tx;
        let b = self.at(x0, y1) * (1.0 - tx) + self.at(x1, y1) * tx;
        Some(a * (1.0 - ty) + b * ty)
    }

    /// Area-averaged by an integer factor.
    fn shrink(&self, f: usize) -> Gray {
        let (w, h) = ((self.w / f).max(1), (self.h / f).max(1));
        let mut v = vec![0f32; w * h];
        let k = 1.0 / (f * f) as f32;
        for y in 0..h {
            for x in 0..w {
                let mut s = 0.0;
                for yy in y * f..(y * f + f).min(self.h) {
                    for xx in x * f..(x * f + f).min(self.w) {
                        s += self.at(xx, yy);
                    }
                }
                v[y * w + x] = s * k;
            }
        }
        Gray { w, h, v }
    }
}

/// The frame's grey levels area-averaged down by `scale` (BT.601 luma).
pub(super) fn downscale(frame: &Frame, scale: usize) -> Gray {
    let (fw, fh) = (frame.width() as usize, frame.height() as usize);
    let (w, h) = ((fw / scale).max(1), (fh / scale).max(1));
    let mut v = vec![0f32; w * h];
    let c = frame.format().channels();
    let data = frame.data();
    let k = 1.0 / (scale * scale) as f32;
    for y in 0..h {
        for yy in y * scale..(y * scale + scale).min(fh) {
            let row = &data[yy * frame.stride()..yy * frame.stride() + fw * c];
            for x in 0..w {
                let mut s = 0.0;
                for xx in x * scale..(x * scale + scale).min(fw) {
                    let p = &row[xx * c..xx * c + 3];
                    s += gray(p[0], p[1], p[2]);
                }
                v[y * w + x] += s * k;
            }
        }
    }
    Gray { w, h, v }
}

/// A camera motion between two working frames and how much to trust it.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraMotion {
    /// Maps previous-frame to current-frame working coordinates.
    pub transform: Transform,
    /// Matches tried.
    pub matches: usize,
    /// RANSAC inliers.
    pub inliers: usize,
    /// Largest displacement of a working-frame corner under `transform`, in working pixels.
    pub displacement: f64,
}

/// Patch radius of the point matcher (7×7 patches).
const PATCH: isize = 3;
/// Local search radius around the globally shifted position (working pixels).
const LOCAL: isize = 3;
/// Global shift search radius at half the working size (±12 → ±24 working pixels).
const GLOBAL: isize = 12;
/// Grid cell of the corner picker (working pixels): ~100 points on 214×120.
const CELL: usize = 16;

/// Normalised distance of `(x, y)` from the centre of a `w × h` frame: 0 at the centre, 1 on
/// the border (the larger of the two axes' ratios).
fn periphery(x: f64, y: f64, w: usize, h: usize) -> f64 {
    let (cx, cy) = (0.5 * w as f64, 0.5 * h as f64);
    ((x - cx).abs() / cx).max((y - cy).abs() / cy).min(1.0)
}

/// Pixels at least this far out ([`periphery`]) decide the global shift: the camera motion is
/// the motion of the frame's surroundings. A camera that follows an object keeps it near the
/// centre, where its own motion (near zero in the image) would otherwise win the match.
const PERIPHERY_BAND: f64 = 0.5;

/// Sum of absolute differences of `a` shifted by `(dx, dy)` against `b` over the outer band of
/// the central region (a mean, so shifts that see different overlaps compare fairly).
fn global_shift(a: &Gray, b: &Gray) -> (isize, isize) {
    let m = GLOBAL as usize;
    if a.w <= 2 * m + 4 || a.h <= 2 * m + 4 {
        return (0, 0);
    }
    // The band as runs of columns per row (a row crosses it whole, or in two runs beside the
    // centre): the sums below then run over plain slices, without a test per pixel.
    let rows: Vec<(usize, Vec<(usize, usize)>)> = (m..a.h - m)
        .map(|y| {
            let mut runs: Vec<(usize, usize)> = Vec::new();
            for x in m..a.w - m {
                if periphery(x as f64, y as f64, a.w, a.h) < PERIPHERY_BAND {
                    continue;
                }
                match runs.last_mut() {
                    Some(r) if r.1 == x => r.1 = x + 1,
                    _ => runs.push((x, x + 1)),
                }
            }
            (y, runs)
        })
        .collect();
    let mut best = ((0, 0), f32::INFINITY);
    for dy in -GLOBAL..=GLOBAL {
        for dx in -GLOBAL..=GLOBAL {
            // Eight running sums, added up at the end: one chain of dependent additions
            // would leave the loop waiting on each; eight are vectorised.
            let mut lanes = [0f32; 8];
            for (y, runs) in &rows {
                let yb = (*y as isize + dy) as usize;
                let (ra, rb) = (&a.v[y * a.w..][..a.w], &b.v[yb * b.w..][..b.w]);
                for &(x0, x1) in runs {
                    let xb = (x0 as isize + dx) as usize;
                    let (pa, pb) = (&ra[x0..x1], &rb[xb..xb + (x1 - x0)]);
                    let (ca, cb) = (pa.chunks_exact(8), pb.chunks_exact(8));
                    let (ta, tb) = (ca.remainder(), cb.remainder());
                    for (qa, qb) in ca.zip(cb) {
                        for k in 0..8 {
                            lanes[k] += (qa[k] - qb[k]).abs();
                        }
                    }
                    for (k, (p, q)) in ta.iter().zip(tb).enumerate() {
                        lanes[k] += (p - q).abs();
                    }
                }
            }
            let s: f32 = lanes.iter().sum();
            // A slight preference for small shifts breaks ties on flat frames.
            let s = s * (1.0 + 0.002 * (dx.abs() + dy.abs()) as f32);
            if s < best.1 {
                best = ((dx, dy), s);
            }
        }
    }
    best.0
}

/// Corner points of `g`: the strongest Shi–Tomasi response of each grid cell, when strong.
fn corners(g: &Gray) -> Vec<(usize, usize)> {
    let b = (PATCH + LOCAL + 2) as usize;
    let mut out = Vec::new();
    if g.w <= 2 * b || g.h <= 2 * b {
        return out;
    }
    // The central differences once per pixel, not once per window that holds it (25 times):
    // the same values, summed in the same order below.
    let (mut gxs, mut gys) = (vec![0f32; g.w * g.h], vec![0f32; g.w * g.h]);
    for y in 1..g.h - 1 {
        for x in 1..g.w - 1 {
            gxs[y * g.w + x] = g.at(x + 1, y) - g.at(x - 1, y);
            gys[y * g.w + x] = g.at(x, y + 1) - g.at(x, y - 1);
        }
    }
    let mut cy = b;
    while cy < g.h - b {
        let mut cx = b;
        while cx < g.w - b {
            let mut best = (0usize, 0usize, 0f32);
            for y in cy..(cy + CELL).min(g.h - b) {
                for x in cx..(cx + CELL).min(g.w - b) {
                    let (mut sxx, mut syy, mut sxy) = (0f32, 0f32, 0f32);
                    for yy in y - 2..=y + 2 {
                        let (rx, ry) =
                            (&gxs[yy * g.w + x - 2..][..5], &gys[yy * g.w + x - 2..][..5]);
                        for (&gx, &gy) in rx.iter().zip(ry) {
                            sxx += gx * gx;
                            syy += gy * gy;
                            sxy += gx * gy;
                        }
                    }
                    let tr = 0.5 * (sxx + syy);
                    let det = ((0.5 * (sxx - syy)).powi(2) + sxy * sxy).sqrt();
                    let lmin = tr - det;
                    if lmin > best.2 {
                        best = (x, y, lmin);
                    }
                }
            }
            // Minimum eigenvalue of the 5×5 structure tensor: ~25·(4 grey levels)² means a
            // real corner, not JPEG noise on a flat wall.
            if best.2 > 400.0 {
                out.push((best.0, best.1));
            }
            cx += CELL;
        }
        cy += CELL;
    }
    out
}

fn ssd(a: &Gray, ax: usize, ay: usize, b: &Gray, bx: usize, by: usize) -> f32 {
    let mut s = 0.0;
    for dy in -PATCH..=PATCH {
        for dx in -PATCH..=PATCH {
            let d = a.at((ax as isize + dx) as usize, (ay as isize + dy) as usize)
                - b.at((bx as isize + dx) as usize, (by as isize + dy) as usize);
            s += d * d;
        }
    }
    s
}

/// Largest displacement under `t` of a corner of a `w × h` frame ([`CameraMotion`]'s).
pub(super) fn corner_displacement(t: &Transform, w: usize, h: usize) -> f64 {
    let (w, h) = (w as f64, h as f64);
    [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)]
        .iter()
        .map(|&(x, y)| {
            let p = Point::new(x, y);
            t.apply(p).dist(p)
        })
        .fold(0.0, f64::max)
}

/// Estimates the camera motion from `prev` to `cur` (working frames of equal size).
pub(super) fn estimate_motion(prev: &Gray, cur: &Gray, seed: u64) -> Option<CameraMotion> {
    let (gx, gy) = global_shift(&prev.shrink(2), &cur.shrink(2));
    let (gx, gy) = (2 * gx, 2 * gy);
    let mut matches = Vec::new();
    let lo = PATCH + 1;
    for (x, y) in corners(prev) {
        let (px, py) = (x as isize + gx, y as isize + gy);
        let mut best = (0isize, 0isize, f32::INFINITY);
        let mut costs = [[f32::INFINITY; (2 * LOCAL + 1) as usize]; (2 * LOCAL + 1) as usize];
        for dy in -LOCAL..=LOCAL {
            for dx in -LOCAL..=LOCAL {
                let (qx, qy) = (px + dx, py + dy);
                if qx < lo || qy < lo || qx >= cur.w as isize - lo || qy >= cur.h as isize - lo {
                    continue;
                }
                let c = ssd(prev, x, y, cur, qx as usize, qy as usize);
                costs[(dy + LOCAL) as usize][(dx + LOCAL) as usize] = c;
                if c < best.2 {
                    best = (dx, dy, c);
                }
            }
        }
        if !best.2.is_finite() {
            continue;
        }
        // Sub-pixel: a parabola through the best cost and its neighbours, per axis.
        let sub = |m: f32, c: f32, p: f32| {
            let den = m - 2.0 * c + p;
            if m.is_finite() && p.is_finite() && den > 1e-6 {
                (0.5 * (m - p) / den).clamp(-0.5, 0.5)
            } else {
                0.0
            }
        };
        let (bi, bj) = ((best.0 + LOCAL) as usize, (best.1 + LOCAL) as usize);
        let at = |i: isize, j: isize| {
            if i < 0 || j < 0 || i > 2 * LOCAL || j > 2 * LOCAL {
                f32::INFINITY
            } else {
                costs[j as usize][i as usize]
            }
        };
        let sx = sub(
            at(bi as isize - 1, bj as isize),
            best.2,
            at(bi as isize + 1, bj as isize),
        );
        let sy = sub(
            at(bi as isize, bj as isize - 1),
            best.2,
            at(bi as isize, bj as isize + 1),
        );
        let q = Point::new(
            (px + best.0) as f64 + sx as f64,
            (py + best.1) as f64 + sy as f64,
        );
        matches.push((Point::new(x as f64, y as f64), q));
    }
    if matches.len() < 3 {
        return None;
    }
    let fit = ransac(
        TransformKind::Affine,
        &matches,
        &RansacConfig {
            threshold: 1.0,
            max_iterations: 300,
            seed,
            ..RansacConfig::default()
        },
    )
    .ok()?;
    let t = fit.transform;
    Some(CameraMotion {
        transform: t,
        matches: matches.len(),
        inliers: fit.inliers.len(),
        displacement: corner_displacement(&t, prev.w, prev.h),
    })
}

/// Whether a camera moves, judged from the motion between consecutive frames: the median
/// corner displacement, in frame pixels per frame, over the frames given. A static camera
/// measures well under a pixel (JPEG noise, a flickering light); a hand-held one several.
#[derive(Debug, Clone, Default)]
pub struct CameraJudge {
    prev: Option<Gray>,
    scale: usize,
    displacements: Vec<f64>,
}

/// Median displacement (frame pixels per frame) above which the camera counts as moving.
pub const MOVING_CAMERA_PX: f64 = 1.0;

impl CameraJudge {
    /// A judge with no frames yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Looks at the next frame. Frames of another size than the first are ignored.
    pub fn observe(&mut self, frame: &Frame) {
        if self.prev.is_none() {
            self.scale = (frame.width().max(frame.height()) as usize)
                .div_ceil(240)
                .max(1);
        }
        let cur = downscale(frame, self.scale);
        if let Some(p) = &self.prev {
            if (p.w, p.h) != (cur.w, cur.h) {
                return;
            }
            let d = estimate_motion(p, &cur, 1)
                .filter(|m| m.inliers >= 8)
                // An unreliable estimate says "something moves": a static camera gives clean
                // matches on its texture.
                .map_or(f64::INFINITY, |m| m.displacement * self.scale as f64);
            self.displacements.push(d);
        }
        self.prev = Some(cur);
    }

    /// Frame pairs measured so far.
    pub fn pairs(&self) -> usize {
        self.displacements.len()
    }

    /// Whether the camera moves (`None` before the first pair).
    pub fn moving(&self) -> Option<bool> {
        if self.displacements.is_empty() {
            return None;
        }
        let mut d = self.displacements.clone();
        d.sort_by(f64::total_cmp);
        Some(d[d.len() / 2] > MOVING_CAMERA_PX)
    }
}
