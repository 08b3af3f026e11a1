//! Exact geometry by a vertical sweep.
//!
//! (The `Exact` overlap method; see the parent module's doc for the sweep and its exactness.)

use crate::frame::{Mask, Point};
use crate::io::vot::Region;

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
        (Geo::Edges { segs, axis }, Geo::Pixels(m)) => sweep(segs, *axis, &mask_edges(m), true, fb),
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
