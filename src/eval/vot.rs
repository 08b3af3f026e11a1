//! VOT short-term metrics: region overlap, the VOT2020 anchor protocol (accuracy, robustness,
//! EAO; thesis §6.1, eq. 53–56) and the reset protocol of VOT2016–2019.
//!
//! # Overlap
//!
//! [`overlap`] is the intersection over union of two [`Region`]s of any kind, with two methods:
//!
//! - [`OverlapMethod::Exact`] (default): continuous geometry. Rectangles and polygons are
//!   areas bounded by their edges, filled by the even-odd rule (so non-convex and
//!   self-intersecting polygons work); a mask is the union of its pixels' unit squares. Areas
//!   are integrated exactly by a vertical sweep: between consecutive event abscissae (all
//!   vertices and all edge–edge crossings) no edge crosses another, so the covered length of
//!   each vertical line is linear in x and the midpoint rule is exact. The result is exact up
//!   to floating-point rounding for convex and non-convex polygons alike.
//! - [`OverlapMethod::Toolkit`]: a port of the VOT toolkit's `calculate_overlap` (vot-toolkit
//!   0.9, `vot/region/raster.py`): coordinates rounded half-to-even, rectangles and polygons
//!   rasterised with its scan-line rules, pixel counts compared. It reproduces the toolkit's
//!   numbers bit for bit (including its quirks); it falls back to `Exact` if the raster would
//!   exceed 2²⁶ pixels (the toolkit would allocate it).
//!
//! Both follow VOT's conventions: two empty regions (special codes, degenerate shapes) overlap
//! 1; `bounds = Some((w, h))` clips both regions to the image `[0, w] × [0, h]` first.
//!
//! # Anchor protocol (VOT2020, thesis eq. 53–56)
//!
//! The tracker is initialised at every anchor and run to the end of the sequence (forward
//! anchors) or to its first frame (backward anchors); the toolkit's trajectory of an anchor
//! has, in run order, the special code 1 at the anchor then one region per frame. Ported from
//! the toolkit's `multistart_ar`, `multistart_eao_curves`, `multistart_eao_curve` and
//! `multistart_eao_score` analyses:
//!
//! - per anchor run of N frames: overlaps o₀…o_{N−1} against the ground truth (bounded by the
//!   image when `bounds` is given). Failure: the first frame of `grace` (θ_N = 10) consecutive
//!   frames whose overlap is ≤ `threshold` (θ_φ = 0.1) and whose ground truth is not empty;
//!   N^F = the index of that frame (N when there is none);
//! - sequence: A = Σ_a Σ_{i<N^F_a} o_i / Σ_a N^F_a, R = Σ_a N^F_a / Σ_a N_a (eq. 53, 54
//!   pooled over the sequence's anchors); dataset: A weighted by Σ_a N^F_a, R by the
//!   sequence's length;
//! - EAO curve (eq. 55): for length j ≥ 1, each run with N > j contributes mean(o₁…o_j); a run
//!   that failed and has N ≤ j contributes Σ_{1≤i<N} o_i / (j − 1) with overlaps after N^F set
//!   to 0 (the toolkit divides by j − 1 here, not j; we keep it); a successful run shorter
//!   than j does not contribute. Sequences are pooled by contributing runs. Curve length
//!   `eao_high` (755); EAO = the mean of curve[`eao_low`..`eao_high`) — 640 values — where a
//!   length no run reaches counts as 0 (toolkit), and [`AnchorSummary::eao_defined`] is the
//!   mean over the lengths some run reaches (eq. 55 read literally: Φ̂_i is undefined when
//!   S(i) is empty).
//! - The anchor frame: the toolkit stores the special code 1 there, whose overlap with the
//!   ground truth is 0, so it counts as a 0 in A (and towards the grace counter). With
//!   [`InitFrame::GroundTruth`] (our default) it counts as overlap 1 instead — the tracker was
//!   given the ground truth — so a perfect tracker scores A = 1. [`AnchorParams::toolkit`]
//!   reproduces the toolkit exactly.
//!
//! The toolkit reads anchors from a sequence's `anchor.value` file; [`anchors_every`] places
//! them as VOT2020 describes: every Δ = 50 frames from the first, each run in the direction
//! that gives the longer sub-sequence (forward in the first half, backward in the second).
//!
//! # Reset protocol (VOT2016–2019)
//!
//! Ported from the toolkit's `SupervisedExperiment` and `supervised_*` analyses: the tracker
//! is initialised in frame 0 (special code 1); a frame whose overlap is ≤ `failure_overlap`
//! (0) is a failure (code 2) and the tracker is re-initialised `skip_initialize` (5) frames
//! later, the frames between being code 0. Accuracy = mean overlap over frames that are not
//! special and not within `burnin` (10) frames of an initialisation (the initialisation frame
//! included); failures = number of code-2 frames; reliability = exp(−S·F/L) with S = 30. Over
//! sequences A and F are length-weighted means. EAO: each initialisation starts a run that
//! ends before its failure (failed) or at the sequence end (successful); `curve[j]` = mean over
//! runs of mean(o₁…o_j) with failed runs padded with zeros and successful runs counted only
//! while j < their length (`curve[0]` = mean o₀); EAO = mean of `curve[eao_low..=eao_high]`
//! (VOT2019: 46–291).

use crate::frame::{Mask, Point};
use crate::io::vot::{Anchor, Direction, Region, SPECIAL_FAILURE, SPECIAL_INIT, SPECIAL_UNKNOWN};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Errors of the VOT protocols.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum VotError {
    /// Two lists that must have the same length do not.
    #[error("{what}: expected {expected} entries, got {got}")]
    LengthMismatch {
        /// Which list.
        what: String,
        /// Entries expected.
        expected: usize,
        /// Entries given.
        got: usize,
    },
    /// An anchor lies outside the sequence.
    #[error("anchor at frame {frame} is outside the sequence of {len} frames")]
    AnchorOutOfRange {
        /// 0-based anchor frame.
        frame: usize,
        /// Sequence length.
        len: usize,
    },
    /// There is nothing to evaluate.
    #[error("no anchors / sequences to evaluate")]
    Empty,
}

/// How region overlap is computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum OverlapMethod {
    /// Exact continuous geometry (even-odd polygons, pixel-square masks).
    #[default]
    Exact,
    /// The VOT toolkit's rasterisation, bit for bit.
    Toolkit,
}

/// Rasters larger than this fall back to exact geometry in [`OverlapMethod::Toolkit`].
const MAX_RASTER: i64 = 1 << 26;

/// Intersection over union of two regions (see the module doc for conventions).
pub fn overlap(a: &Region, b: &Region, bounds: Option<(u32, u32)>, method: OverlapMethod) -> f64 {
    match method {
        OverlapMethod::Exact => exact::overlap(a, b, bounds),
        OverlapMethod::Toolkit => {
            toolkit::overlap(a, b, bounds).unwrap_or_else(|| exact::overlap(a, b, bounds))
        }
    }
}

/// Per-frame overlaps of two region lists of equal length.
pub fn overlaps(
    a: &[Region],
    b: &[Region],
    bounds: Option<(u32, u32)>,
    method: OverlapMethod,
) -> Result<Vec<f64>, VotError> {
    if a.len() != b.len() {
        return Err(VotError::LengthMismatch {
            what: "regions to compare".into(),
            expected: b.len(),
            got: a.len(),
        });
    }
    Ok(a.iter()
        .zip(b)
        .map(|(x, y)| overlap(x, y, bounds, method))
        .collect())
}

/// Exact geometry by a vertical sweep.
mod exact {
    use super::*;

    /// A non-vertical edge stored left to right.
    #[derive(Clone, Copy, Debug)]
    struct Seg {
        x0: f64,
        y0: f64,
        x1: f64,
        y1: f64,
    }

    impl Seg {
        fn new(p: Point, q: Point) -> Option<Seg> {
            if p.x == q.x {
                return None;
            }
            let (a, b) = if p.x < q.x { (p, q) } else { (q, p) };
            Some(Seg {
                x0: a.x,
                y0: a.y,
                x1: b.x,
                y1: b.y,
            })
        }

        fn horizontal(&self) -> bool {
            self.y0 == self.y1
        }

        fn y_at(&self, x: f64) -> f64 {
            self.y0 + (x - self.x0) * (self.y1 - self.y0) / (self.x1 - self.x0)
        }
    }

    /// Abscissa where two segments cross, if they do (parallel ones never "cross").
    fn crossing(s: &Seg, t: &Seg) -> Option<f64> {
        let (rx, ry) = (s.x1 - s.x0, s.y1 - s.y0);
        let (qx, qy) = (t.x1 - t.x0, t.y1 - t.y0);
        let d = rx * qy - ry * qx;
        if d == 0.0 {
            return None;
        }
        let (wx, wy) = (t.x0 - s.x0, t.y0 - s.y0);
        let u = (wx * qy - wy * qx) / d;
        let v = (wx * ry - wy * rx) / d;
        ((0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&v)).then_some(s.x0 + u * rx)
    }

    /// A region as edges filled by the even-odd rule, or as pixels.
    enum Geo {
        Empty,
        Edges { segs: Vec<Seg>, axis: bool },
        Pixels(Mask),
    }

    fn finite(p: &[Point]) -> bool {
        p.iter().all(|q| q.x.is_finite() && q.y.is_finite())
    }

    fn poly_edges(p: &[Point], axis: bool) -> Geo {
        if p.len() < 3 || !finite(p) {
            return Geo::Empty;
        }
        let segs: Vec<Seg> = (0..p.len())
            .filter_map(|i| Seg::new(p[i], p[(i + 1) % p.len()]))
            .collect();
        Geo::Edges { segs, axis }
    }

    /// The horizontal edges of a mask's row runs (vertical ones never cross a sweep line).
    fn mask_edges(m: &Mask) -> Vec<Seg> {
        let mut segs = Vec::new();
        let w = m.width() as usize;
        for (ly, row) in m.data().chunks(w.max(1)).enumerate() {
            let y = (m.y() as i64 + ly as i64) as f64;
            for (start, end) in crate::runs::runs(row) {
                let (a, b) = (
                    (m.x() as i64 + start as i64) as f64,
                    (m.x() as i64 + end as i64) as f64,
                );
                segs.push(Seg {
                    x0: a,
                    y0: y,
                    x1: b,
                    y1: y,
                });
                segs.push(Seg {
                    x0: a,
                    y0: y + 1.0,
                    x1: b,
                    y1: y + 1.0,
                });
            }
        }
        segs
    }

    fn geo(r: &Region, bounds: Option<(u32, u32)>) -> Geo {
        match r {
            Region::Special(_) => Geo::Empty,
            Region::Rectangle(b) => {
                if !(b.w > 0.0 && b.h > 0.0) {
                    return Geo::Empty;
                }
                poly_edges(&b.corners(), true)
            }
            Region::Polygon(p) => poly_edges(p, false),
            Region::Mask(m) => {
                let m = match bounds {
                    Some((w, h)) => m.clipped(w, h),
                    None => m.clone(),
                };
                if m.is_empty() {
                    Geo::Empty
                } else {
                    Geo::Pixels(m)
                }
            }
        }
    }

    /// Even-odd intervals of the edges crossing the vertical line at `x`, clipped to `[0, h]`.
    fn intervals(segs: &[Seg], x: f64, clip: Option<f64>, ys: &mut Vec<f64>) -> Vec<(f64, f64)> {
        ys.clear();
        ys.extend(
            segs.iter()
                .filter(|s| s.x0 < x && x < s.x1)
                .map(|s| s.y_at(x)),
        );
        ys.sort_by(f64::total_cmp);
        ys.chunks_exact(2)
            .filter_map(|c| {
                let (mut a, mut b) = (c[0], c[1]);
                if let Some(h) = clip {
                    a = a.max(0.0);
                    b = b.min(h);
                }
                (b > a).then_some((a, b))
            })
            .collect()
    }

    fn length(iv: &[(f64, f64)]) -> f64 {
        iv.iter().map(|(a, b)| b - a).sum()
    }

    fn common_length(a: &[(f64, f64)], b: &[(f64, f64)]) -> f64 {
        let (mut i, mut j, mut total) = (0, 0, 0.0);
        while i < a.len() && j < b.len() {
            let lo = a[i].0.max(b[j].0);
            let hi = a[i].1.min(b[j].1);
            if hi > lo {
                total += hi - lo;
            }
            if a[i].1 < b[j].1 {
                i += 1;
            } else {
                j += 1;
            }
        }
        total
    }

    /// (area A, area B, area A∩B) of two edge sets by the vertical sweep.
    fn sweep(
        a: &[Seg],
        a_axis: bool,
        b: &[Seg],
        b_axis: bool,
        bounds: Option<(f64, f64)>,
    ) -> (f64, f64, f64) {
        let mut xs: Vec<f64> = a.iter().chain(b).flat_map(|s| [s.x0, s.x1]).collect();
        if let Some((w, h)) = bounds {
            xs.push(0.0);
            xs.push(w);
            // Clipping intervals to [0, h] bends their length where an edge crosses the top or
            // bottom of the image: those abscissae are events too.
            for s in a.iter().chain(b) {
                for yc in [0.0, h] {
                    if (s.y0 - yc) * (s.y1 - yc) < 0.0 {
                        xs.push(s.x0 + (yc - s.y0) * (s.x1 - s.x0) / (s.y1 - s.y0));
                    }
                }
            }
        }
        let mut cross = |s: &[Seg], t: &[Seg], same: bool| {
            for (i, p) in s.iter().enumerate() {
                let rest = if same { &t[i + 1..] } else { t };
                for q in rest {
                    if p.horizontal() && q.horizontal() {
                        continue;
                    }
                    if let Some(x) = crossing(p, q) {
                        xs.push(x);
                    }
                }
            }
        };
        if !a_axis {
            cross(a, a, true);
        }
        if !b_axis {
            cross(b, b, true);
        }
        cross(a, b, false);
        xs.retain(|x| x.is_finite());
        xs.sort_by(f64::total_cmp);
        xs.dedup();
        let clip = bounds.map(|(_, h)| h);
        let (mut area_a, mut area_b, mut area_ab) = (0.0, 0.0, 0.0);
        let mut buf = Vec::new();
        for win in xs.windows(2) {
            let (xl, xr) = (win[0], win[1]);
            if let Some((w, _)) = bounds {
                if xr <= 0.0 || xl >= w {
                    continue;
                }
            }
            let xm = 0.5 * (xl + xr);
            let dx = xr - xl;
            let ia = intervals(a, xm, clip, &mut buf);
            let ib = intervals(b, xm, clip, &mut buf);
            area_a += dx * length(&ia);
            area_b += dx * length(&ib);
            area_ab += dx * common_length(&ia, &ib);
        }
        (area_a, area_b, area_ab)
    }

    /// Area of a single region (bounded).
    pub(super) fn area(r: &Region, bounds: Option<(u32, u32)>) -> f64 {
        let fb = bounds.map(|(w, h)| (w as f64, h as f64));
        match geo(r, bounds) {
            Geo::Empty => 0.0,
            Geo::Pixels(m) => m.area() as f64,
            Geo::Edges { segs, axis } => sweep(&segs, axis, &[], true, fb).0,
        }
    }

    pub(super) fn overlap(a: &Region, b: &Region, bounds: Option<(u32, u32)>) -> f64 {
        let fb = bounds.map(|(w, h)| (w as f64, h as f64));
        let (ga, gb) = (geo(a, bounds), geo(b, bounds));
        let (sa, sb, si) = match (&ga, &gb) {
            (Geo::Empty, Geo::Empty) => return 1.0,
            (Geo::Empty, _) | (_, Geo::Empty) => return 0.0,
            (Geo::Pixels(m), Geo::Pixels(n)) => {
                (m.area() as f64, n.area() as f64, m.intersection(n) as f64)
            }
            (Geo::Edges { segs, axis }, Geo::Pixels(m)) => {
                sweep(segs, *axis, &mask_edges(m), true, fb)
            }
            (Geo::Pixels(m), Geo::Edges { segs, axis }) => {
                let (x, y, z) = sweep(segs, *axis, &mask_edges(m), true, fb);
                (y, x, z)
            }
            (Geo::Edges { segs: s, axis: ax }, Geo::Edges { segs: t, axis: bx }) => {
                sweep(s, *ax, t, *bx, fb)
            }
        };
        if sa <= 0.0 && sb <= 0.0 {
            return 1.0;
        }
        let union = sa + sb - si;
        if union <= 0.0 {
            0.0
        } else {
            (si / union).clamp(0.0, 1.0)
        }
    }
}

/// A port of the VOT toolkit's raster overlap (`vot/region/raster.py`).
mod toolkit {
    use super::*;

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
}

/// The area of a region, by exact geometry (clipped to `bounds` when given).
pub fn region_area(r: &Region, bounds: Option<(u32, u32)>) -> f64 {
    exact::area(r, bounds)
}

/// Anchors every `spacing` frames from frame 0, each run in the direction of the longer
/// sub-sequence (forward when `n − f ≥ f + 1`), as VOT2020 places them.
pub fn anchors_every(num_frames: usize, spacing: usize) -> Vec<Anchor> {
    let spacing = spacing.max(1);
    (0..num_frames)
        .step_by(spacing)
        .map(|f| Anchor {
            frame: f,
            direction: if num_frames - f > f {
                Direction::Forward
            } else {
                Direction::Backward
            },
        })
        .collect()
}

/// The 0-based sequence frames an anchor's run visits, in run order.
pub fn anchor_frames(anchor: &Anchor, num_frames: usize) -> Vec<usize> {
    match anchor.direction {
        Direction::Forward => (anchor.frame..num_frames).collect(),
        Direction::Backward => (0..=anchor.frame.min(num_frames.saturating_sub(1)))
            .rev()
            .collect(),
    }
}

/// What the anchor frame (where the tracker is given the ground truth) counts as in accuracy
/// and in the failure test.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InitFrame {
    /// Overlap 1: the tracker was given the ground truth there.
    GroundTruth,
    /// Overlap of the special code 1 with the ground truth (0), as the toolkit computes it.
    Special,
}

/// Parameters of the anchor protocol.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AnchorParams {
    /// Overlap at or below which a frame counts towards a failure (θ_φ).
    pub threshold: f64,
    /// Consecutive such frames that make a failure (θ_N).
    pub grace: usize,
    /// Image size for clipping regions, when known.
    pub bounds: Option<(u32, u32)>,
    /// Overlap computation.
    pub method: OverlapMethod,
    /// What the anchor frame counts as.
    pub init_frame: InitFrame,
    /// First EAO curve index averaged (N_lo).
    pub eao_low: usize,
    /// EAO curve length; indices `eao_low..eao_high` are averaged (N_hi).
    pub eao_high: usize,
}

impl Default for AnchorParams {
    fn default() -> Self {
        Self {
            threshold: 0.1,
            grace: 10,
            bounds: None,
            method: OverlapMethod::Exact,
            init_frame: InitFrame::GroundTruth,
            eao_low: 115,
            eao_high: 755,
        }
    }
}

impl AnchorParams {
    /// The VOT toolkit's `vot2020/shortterm` baseline settings, reproduced exactly (raster
    /// overlap, special anchor frame); the toolkit clips to the image, so give its size.
    pub fn toolkit(bounds: Option<(u32, u32)>) -> Self {
        Self {
            bounds,
            method: OverlapMethod::Toolkit,
            init_frame: InitFrame::Special,
            ..Self::default()
        }
    }
}

/// One anchor's run evaluated.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AnchorRun {
    /// The anchor.
    pub anchor: Anchor,
    /// Frames in the run (N).
    pub length: usize,
    /// Frames before the failure (N^F; `length` when it did not fail).
    pub progress: usize,
    /// Whether the run failed.
    pub failed: bool,
    /// Accuracy of the run alone: mean overlap of its first `progress` frames.
    pub accuracy: f64,
    /// Overlap per frame in run order (after a failure as measured, not zeroed).
    pub overlaps: Vec<f64>,
}

/// A sequence evaluated under the anchor protocol.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AnchorSequence {
    /// Runs, in the order given.
    pub runs: Vec<AnchorRun>,
    /// Sequence accuracy (pooled over anchors).
    pub accuracy: f64,
    /// Sequence robustness (pooled over anchors).
    pub robustness: f64,
    /// Σ N^F (the accuracy's weight across sequences).
    pub accuracy_weight: f64,
    /// Sequence length (the robustness's weight).
    pub robustness_weight: f64,
    /// Per-length sum of run contributions to the EAO curve (index = length j).
    pub eao_sum: Vec<f64>,
    /// Per-length number of contributing runs.
    pub eao_active: Vec<f64>,
}

/// Evaluates the stored runs of one sequence. `runs[k]` is the trajectory of `anchors[k]` in
/// run order (its first entry, at the anchor, is ignored: it is the initialisation).
pub fn evaluate_anchor_sequence(
    gt: &[Region],
    anchors: &[Anchor],
    runs: &[Vec<Region>],
    params: &AnchorParams,
) -> Result<AnchorSequence, VotError> {
    if anchors.is_empty() {
        return Err(VotError::Empty);
    }
    if anchors.len() != runs.len() {
        return Err(VotError::LengthMismatch {
            what: "anchor trajectories".into(),
            expected: anchors.len(),
            got: runs.len(),
        });
    }
    let n = gt.len();
    let mut out = Vec::with_capacity(anchors.len());
    let (mut progress_sum, mut acc_sum, mut total) = (0usize, 0.0, 0usize);
    let curve_len = params.eao_high;
    let mut eao_sum = vec![0.0; curve_len];
    let mut eao_active = vec![0.0; curve_len];
    for (anchor, traj) in anchors.iter().zip(runs) {
        if anchor.frame >= n {
            return Err(VotError::AnchorOutOfRange {
                frame: anchor.frame,
                len: n,
            });
        }
        let frames = anchor_frames(anchor, n);
        if traj.len() != frames.len() {
            return Err(VotError::LengthMismatch {
                what: format!("trajectory of the anchor at frame {}", anchor.frame),
                expected: frames.len(),
                got: traj.len(),
            });
        }
        let mut ov: Vec<f64> = frames
            .iter()
            .zip(traj)
            .map(|(&f, r)| overlap(r, &gt[f], params.bounds, params.method))
            .collect();
        ov[0] = match params.init_frame {
            InitFrame::GroundTruth => 1.0,
            InitFrame::Special => overlap(
                &Region::Special(SPECIAL_INIT),
                &gt[frames[0]],
                params.bounds,
                params.method,
            ),
        };
        let mut grace = params.grace;
        let mut progress = ov.len();
        for (j, &o) in ov.iter().enumerate() {
            if o <= params.threshold && !gt[frames[j]].is_empty() {
                grace = grace.saturating_sub(1);
                if grace == 0 {
                    progress = (j + 1).saturating_sub(params.grace);
                    break;
                }
            } else {
                grace = params.grace;
            }
        }
        let failed = progress < ov.len();
        let run_acc: f64 = ov[..progress].iter().sum();
        progress_sum += progress;
        acc_sum += run_acc;
        total += ov.len();
        // EAO contribution (toolkit's compute_eao_partial) with post-failure overlaps zeroed.
        let mut zeroed = ov.clone();
        zeroed[progress..].fill(0.0);
        let mut prefix = 0.0;
        let tail: f64 = zeroed.iter().skip(1).sum();
        for j in 1..curve_len {
            if j < zeroed.len() {
                prefix += zeroed[j];
                eao_sum[j] += prefix / j as f64;
                eao_active[j] += 1.0;
            } else if failed {
                eao_sum[j] += tail / (j - 1).max(1) as f64;
                eao_active[j] += 1.0;
            }
        }
        out.push(AnchorRun {
            anchor: *anchor,
            length: ov.len(),
            progress,
            failed,
            accuracy: if progress > 0 {
                run_acc / progress as f64
            } else {
                0.0
            },
            overlaps: ov,
        });
    }
    Ok(AnchorSequence {
        runs: out,
        accuracy: if progress_sum > 0 {
            acc_sum / progress_sum as f64
        } else {
            0.0
        },
        robustness: progress_sum as f64 / total as f64,
        accuracy_weight: progress_sum as f64,
        robustness_weight: n as f64,
        eao_sum,
        eao_active,
    })
}

/// Dataset-level anchor-protocol scores.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AnchorSummary {
    /// Accuracy A.
    pub accuracy: f64,
    /// Robustness R.
    pub robustness: f64,
    /// EAO as the toolkit computes it (undefined curve points count as 0).
    pub eao: f64,
    /// Mean of the EAO curve over the defined points of `[eao_low, eao_high)` (`None` when no
    /// run reaches `eao_low` frames).
    pub eao_defined: Option<f64>,
    /// EAO curve Φ̂_j for j = 0..eao_high (`None` where no run contributes).
    pub eao_curve: Vec<Option<f64>>,
    /// Number of sequences.
    pub sequences: usize,
}

/// Pools sequences as the toolkit's `multistart_average_ar` and `multistart_eao_*` analyses.
pub fn summarize_anchor(
    seqs: &[AnchorSequence],
    params: &AnchorParams,
) -> Result<AnchorSummary, VotError> {
    if seqs.is_empty() {
        return Err(VotError::Empty);
    }
    let (mut a, mut wa, mut r, mut wr) = (0.0, 0.0, 0.0, 0.0);
    let mut sum = vec![0.0; params.eao_high];
    let mut active = vec![0.0; params.eao_high];
    for s in seqs {
        a += s.accuracy * s.accuracy_weight;
        wa += s.accuracy_weight;
        r += s.robustness * s.robustness_weight;
        wr += s.robustness_weight;
        for j in 0..params.eao_high {
            // A sequence's curve point is its runs' mean; pooled by its active count.
            sum[j] += s.eao_sum.get(j).copied().unwrap_or(0.0);
            active[j] += s.eao_active.get(j).copied().unwrap_or(0.0);
        }
    }
    let curve: Vec<Option<f64>> = sum
        .iter()
        .zip(&active)
        .map(|(&s, &n)| (n > 0.0).then(|| s / n))
        .collect();
    let lo = params.eao_low.min(params.eao_high);
    let window = &curve[lo..];
    let eao = if window.is_empty() {
        0.0
    } else {
        window.iter().map(|v| v.unwrap_or(0.0)).sum::<f64>() / window.len() as f64
    };
    let defined: Vec<f64> = window.iter().flatten().copied().collect();
    Ok(AnchorSummary {
        accuracy: if wa > 0.0 { a / wa } else { 0.0 },
        robustness: if wr > 0.0 { r / wr } else { 0.0 },
        eao,
        eao_defined: (!defined.is_empty())
            .then(|| defined.iter().sum::<f64>() / defined.len() as f64),
        eao_curve: curve,
        sequences: seqs.len(),
    })
}

/// Runs a tracker under the anchor protocol. For each anchor, `tracker(start, init, direction)`
/// is given the 0-based start frame, the ground truth there and the direction, and must return
/// one region for each following frame of the run (`anchor_frames(..).len() − 1` regions, in
/// run order). Returns each anchor's trajectory in run order, starting with the special code 1.
pub fn run_anchor_protocol<F>(
    frames_count: usize,
    gt: &[Region],
    anchors: &[Anchor],
    mut tracker: F,
) -> Result<Vec<Vec<Region>>, VotError>
where
    F: FnMut(usize, &Region, Direction) -> Vec<Region>,
{
    if gt.len() != frames_count {
        return Err(VotError::LengthMismatch {
            what: "ground truth".into(),
            expected: frames_count,
            got: gt.len(),
        });
    }
    let mut out = Vec::with_capacity(anchors.len());
    for a in anchors {
        if a.frame >= frames_count {
            return Err(VotError::AnchorOutOfRange {
                frame: a.frame,
                len: frames_count,
            });
        }
        let frames = anchor_frames(a, frames_count);
        let regions = tracker(a.frame, &gt[a.frame], a.direction);
        if regions.len() + 1 != frames.len() {
            return Err(VotError::LengthMismatch {
                what: format!("tracker output for the anchor at frame {}", a.frame),
                expected: frames.len() - 1,
                got: regions.len(),
            });
        }
        let mut traj = Vec::with_capacity(frames.len());
        traj.push(Region::Special(SPECIAL_INIT));
        traj.extend(regions);
        out.push(traj);
    }
    Ok(out)
}

/// Parameters of the reset protocol.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ResetParams {
    /// Overlap at or below which a frame is a failure.
    pub failure_overlap: f64,
    /// Frames from a failure to the re-initialisation.
    pub skip_initialize: usize,
    /// Frames from an initialisation (itself included) left out of accuracy.
    pub burnin: usize,
    /// Reliability sensitivity S in exp(−S·F/L).
    pub sensitivity: f64,
    /// Image size for clipping regions, when known.
    pub bounds: Option<(u32, u32)>,
    /// Overlap computation.
    pub method: OverlapMethod,
    /// First EAO curve index averaged.
    pub eao_low: usize,
    /// Last EAO curve index averaged (inclusive).
    pub eao_high: usize,
}

impl Default for ResetParams {
    fn default() -> Self {
        Self {
            failure_overlap: 0.0,
            skip_initialize: 5,
            burnin: 10,
            sensitivity: 30.0,
            bounds: None,
            method: OverlapMethod::Exact,
            eao_low: 46,
            eao_high: 291,
        }
    }
}

/// Runs a tracker under the reset protocol. `tracker(start, init)` is given the 0-based start
/// frame and the ground truth there and returns its regions for frames `start + 1 ..` (it may
/// stop early: missing frames count as failures). Returns the trajectory: code 1 at
/// initialisations, code 2 at failures, code 0 for skipped frames, regions elsewhere.
pub fn run_reset_protocol<F>(gt: &[Region], params: &ResetParams, mut tracker: F) -> Vec<Region>
where
    F: FnMut(usize, &Region) -> Vec<Region>,
{
    let n = gt.len();
    let mut traj = vec![Region::Special(SPECIAL_UNKNOWN); n];
    let mut frame = 0;
    while frame < n {
        traj[frame] = Region::Special(SPECIAL_INIT);
        let start = frame;
        let out = tracker(start, &gt[start]);
        frame += 1;
        while frame < n {
            let r = out.get(frame - start - 1);
            let o = r.map_or(0.0, |r| {
                overlap(r, &gt[frame], params.bounds, params.method)
            });
            match r {
                Some(r) if o > params.failure_overlap => {
                    traj[frame] = r.clone();
                    frame += 1;
                }
                _ => {
                    traj[frame] = Region::Special(SPECIAL_FAILURE);
                    frame += params.skip_initialize.max(1);
                    break;
                }
            }
        }
    }
    traj
}

/// A sequence evaluated under the reset protocol.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResetSequence {
    /// Mean overlap over the frames counted for accuracy (0 when none).
    pub accuracy: f64,
    /// Frames counted for accuracy.
    pub accuracy_frames: usize,
    /// Number of failures.
    pub failures: usize,
    /// Sequence length.
    pub length: usize,
    /// Frames (0-based) where the tracker failed.
    pub failure_frames: Vec<usize>,
    /// EAO runs: overlaps from an initialisation to just before its failure (or the end), and
    /// whether it reached the end.
    pub runs: Vec<(Vec<f64>, bool)>,
}

/// Evaluates a reset-protocol trajectory against the ground truth.
pub fn evaluate_reset_sequence(
    gt: &[Region],
    trajectory: &[Region],
    params: &ResetParams,
) -> Result<ResetSequence, VotError> {
    let ov = overlaps(trajectory, gt, params.bounds, params.method)?;
    let n = ov.len();
    let mut counted = vec![true; n];
    let (mut fails, mut inits) = (Vec::new(), Vec::new());
    for (i, r) in trajectory.iter().enumerate() {
        match r.special() {
            Some(SPECIAL_UNKNOWN) => counted[i] = false,
            Some(SPECIAL_INIT) => {
                inits.push(i);
                for c in counted.iter_mut().skip(i).take(params.burnin) {
                    *c = false;
                }
            }
            Some(SPECIAL_FAILURE) => {
                fails.push(i);
                counted[i] = false;
            }
            _ => {}
        }
    }
    let kept: Vec<f64> = ov
        .iter()
        .zip(&counted)
        .filter(|(_, &c)| c)
        .map(|(&o, _)| o)
        .collect();
    let mut runs = Vec::new();
    if fails.is_empty() {
        runs.push((ov.clone(), true));
    } else {
        for (k, &f) in fails.iter().enumerate() {
            let start = inits.get(k).copied().unwrap_or(0).min(f);
            runs.push((ov[start..f].to_vec(), false));
        }
        if inits.len() > fails.len() {
            if let Some(&last) = inits.last() {
                runs.push((ov[last..].to_vec(), true));
            }
        }
    }
    Ok(ResetSequence {
        accuracy: if kept.is_empty() {
            0.0
        } else {
            kept.iter().sum::<f64>() / kept.len() as f64
        },
        accuracy_frames: kept.len(),
        failures: fails.len(),
        length: n,
        failure_frames: fails,
        runs,
    })
}

/// Dataset-level reset-protocol scores.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResetSummary {
    /// Accuracy (length-weighted mean of sequence accuracies).
    pub accuracy: f64,
    /// Failures per sequence (length-weighted mean).
    pub failures: f64,
    /// Total failures.
    pub total_failures: usize,
    /// Reliability exp(−S·F/L̄) with L̄ the mean sequence length (the toolkit's robustness).
    pub reliability: f64,
    /// EAO (`None` when the curve does not reach `eao_low`).
    pub eao: Option<f64>,
    /// EAO curve.
    pub eao_curve: Vec<f64>,
}

/// Pools sequences as the toolkit's `supervised_average_ar` and `supervised_eao_*` analyses.
pub fn summarize_reset(
    seqs: &[ResetSequence],
    params: &ResetParams,
) -> Result<ResetSummary, VotError> {
    if seqs.is_empty() {
        return Err(VotError::Empty);
    }
    let wsum: f64 = seqs.iter().map(|s| s.length as f64).sum();
    let acc = seqs
        .iter()
        .map(|s| s.accuracy * s.length as f64)
        .sum::<f64>()
        / wsum;
    let fail = seqs
        .iter()
        .map(|s| s.failures as f64 * s.length as f64)
        .sum::<f64>()
        / wsum;
    let mean_len = wsum / seqs.len() as f64;
    let runs: Vec<&(Vec<f64>, bool)> = seqs.iter().flat_map(|s| &s.runs).collect();
    let max_len = runs.iter().map(|r| r.0.len()).max().unwrap_or(0);
    let mut curve = vec![0.0; max_len];
    let mut weight = vec![0.0; max_len];
    for (o, success) in &runs {
        let mut prefix = 0.0;
        for j in 0..max_len {
            let v = if j == 0 {
                o.first().copied().unwrap_or(0.0)
            } else {
                prefix += o.get(j).copied().unwrap_or(0.0);
                prefix / j as f64
            };
            if !*success || j < o.len() {
                curve[j] += v;
                weight[j] += 1.0;
            }
        }
    }
    let curve: Vec<f64> = curve
        .iter()
        .zip(&weight)
        .map(|(c, w)| if *w > 0.0 { c / w } else { 0.0 })
        .collect();
    let hi = (params.eao_high + 1).min(curve.len());
    let eao = (params.eao_low < hi)
        .then(|| curve[params.eao_low..hi].iter().sum::<f64>() / (hi - params.eao_low) as f64);
    Ok(ResetSummary {
        accuracy: acc,
        failures: fail,
        total_failures: seqs.iter().map(|s| s.failures).sum(),
        reliability: (-params.sensitivity * fail / mean_len).exp(),
        eao,
        eao_curve: curve,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::BBox;

    fn poly(p: &[(f64, f64)]) -> Region {
        Region::Polygon(p.iter().map(|&(x, y)| Point::new(x, y)).collect())
    }

    #[test]
    fn exact_overlap_of_rectangles_and_rotated_boxes() {
        let a = Region::Rectangle(BBox::new(0.0, 0.0, 10.0, 10.0));
        let b = Region::Rectangle(BBox::new(5.0, 5.0, 10.0, 10.0));
        assert!((overlap(&a, &b, None, OverlapMethod::Exact) - 25.0 / 175.0).abs() < 1e-12);
        let d = poly(&[(5.0, 0.0), (10.0, 5.0), (5.0, 10.0), (0.0, 5.0)]);
        assert!((overlap(&d, &d, None, OverlapMethod::Exact) - 1.0).abs() < 1e-12);
        // The diamond inscribed in the square covers half of it.
        assert!((overlap(&a, &d, None, OverlapMethod::Exact) - 0.5).abs() < 1e-12);
        let far = poly(&[(105.0, 0.0), (110.0, 5.0), (105.0, 10.0), (100.0, 5.0)]);
        assert_eq!(overlap(&d, &far, None, OverlapMethod::Exact), 0.0);
        // Bounds clip: half of b lies outside a 10x10 image... a quarter of it inside.
        let inside = overlap(&a, &b, Some((10, 10)), OverlapMethod::Exact);
        assert!((inside - 25.0 / 100.0).abs() < 1e-12);
        // Two empty regions overlap 1, one empty region 0.
        let s = Region::Special(0);
        assert_eq!(overlap(&s, &s, None, OverlapMethod::Exact), 1.0);
        assert_eq!(overlap(&s, &a, None, OverlapMethod::Exact), 0.0);
    }

    #[test]
    fn non_convex_and_self_intersecting_polygons() {
        // An L shape: 3x3 square minus its top-right 2x2 → area 5.
        let l = poly(&[
            (0.0, 0.0),
            (1.0, 0.0),
            (1.0, 2.0),
            (3.0, 2.0),
            (3.0, 3.0),
            (0.0, 3.0),
        ]);
        assert!((region_area(&l, None) - 5.0).abs() < 1e-12);
        let sq = Region::Rectangle(BBox::new(0.0, 0.0, 3.0, 3.0));
        assert!((overlap(&l, &sq, None, OverlapMethod::Exact) - 5.0 / 9.0).abs() < 1e-12);
        // A bow tie (two triangles of area 1 each, even-odd).
        let bow = poly(&[(0.0, 0.0), (2.0, 2.0), (2.0, 0.0), (0.0, 2.0)]);
        assert!((region_area(&bow, None) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn polygon_against_mask_counts_pixel_squares() {
        let mut data = vec![0u8; 16];
        data[5] = 1; // pixel (1,1) of a 4x4 mask at (2, 3)
        data[6] = 1;
        let m = Region::Mask(Mask::new(2, 3, 4, 4, data).unwrap());
        let r = Region::Rectangle(BBox::new(3.0, 4.0, 2.0, 1.0));
        assert!((overlap(&m, &r, None, OverlapMethod::Exact) - 1.0).abs() < 1e-12);
        let half = Region::Rectangle(BBox::new(3.5, 4.0, 1.0, 1.0));
        assert!((overlap(&m, &half, None, OverlapMethod::Exact) - 0.5).abs() < 1e-12);
        assert!((overlap(&m, &m, None, OverlapMethod::Exact) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn toolkit_raster_matches_known_values() {
        let a = Region::Rectangle(BBox::new(0.0, 0.0, 10.0, 10.0));
        let b = Region::Rectangle(BBox::new(5.0, 5.0, 10.0, 10.0));
        // vot-toolkit 0.9: calculate_overlap(Rectangle(0,0,10,10), Rectangle(5,5,10,10)).
        assert!(
            (overlap(&a, &b, Some((480, 360)), OverlapMethod::Toolkit) - 1.0 / 7.0).abs() < 1e-15
        );
        let s = Region::Special(1);
        assert_eq!(overlap(&s, &s, None, OverlapMethod::Toolkit), 1.0);
        assert_eq!(
            overlap(&s, &a, Some((480, 360)), OverlapMethod::Toolkit),
            0.0
        );
    }

    #[test]
    fn anchors_run_towards_the_longer_side() {
        let a = anchors_every(196, 50);
        let f: Vec<(usize, Direction)> = a.iter().map(|a| (a.frame, a.direction)).collect();
        assert_eq!(
            f,
            vec![
                (0, Direction::Forward),
                (50, Direction::Forward),
                (100, Direction::Backward),
                (150, Direction::Backward)
            ]
        );
        assert_eq!(anchor_frames(&a[2], 196).len(), 101);
        assert_eq!(anchor_frames(&a[1], 196).len(), 146);
    }
}
