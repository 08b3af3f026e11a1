//! The variational refinement that follows the patch search at every scale (step 3 of the
//! module docs of `flow`): the brightness- and gradient-constancy data terms and the robust
//! smoothness term of Brox et al., linearised once per scale and solved by successive
//! over-relaxation, red-black.

use super::{FlowConfig, Plane};

/// The variational refinement's buffers (see [`Refiner::refine`]).
#[derive(Debug, Clone, Default)]
pub(super) struct Refiner {
    iz: Vec<f32>,
    ix: Vec<f32>,
    iy: Vec<f32>,
    ixz: Vec<f32>,
    iyz: Vec<f32>,
    ixx: Vec<f32>,
    ixy: Vec<f32>,
    iyy: Vec<f32>,
    avg: Vec<f32>,
    a11: Vec<f32>,
    a12: Vec<f32>,
    a22: Vec<f32>,
    b1: Vec<f32>,
    b2: Vec<f32>,
    smooth: Vec<f32>,
    du: Vec<f32>,
    dv: Vec<f32>,
    /// Per pixel, fixed for a call: `1/(|∇I|² + ζ²)`, the gradient term's two
    /// normalisers, and its coefficients with the normalisers applied.
    bn: Vec<f32>,
    g1: Vec<f32>,
    g2: Vec<f32>,
    ga11: Vec<f32>,
    ga12: Vec<f32>,
    ga22: Vec<f32>,
    gb1: Vec<f32>,
    gb2: Vec<f32>,
    /// One row of SOR updates (both colours; see [`Refiner::sor`]).
    row_u: Vec<f32>,
    row_v: Vec<f32>,
}

/// `out[i] = f(x+1) − f(x−1)` along x (`dx`) or y, border repeated: the unnormalised
/// central difference OpenCV's refinement uses (Sobel with a 1-tap kernel), which the
/// weights α, δ and γ were set for.
fn central(f: &[f32], w: usize, h: usize, along_x: bool, out: &mut Vec<f32>) {
    out.clear();
    out.resize(w * h, 0.0);
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            out[i] = if along_x {
                f[y * w + (x + 1).min(w - 1)] - f[y * w + x.saturating_sub(1)]
            } else {
                f[(y + 1).min(h - 1) * w + x] - f[y.saturating_sub(1) * w + x]
            };
        }
    }
}

impl Refiner {
    /// Refines `(u, v)` from `i0` to `i1` in place.
    pub(super) fn refine(
        &mut self,
        cfg: &FlowConfig,
        i0: &Plane,
        i1: &Plane,
        u: &mut [f32],
        v: &mut [f32],
    ) {
        let (w, h) = (i0.w, i0.h);
        let n = w * h;
        // The linearisation point: `i1` warped back by the current flow.
        self.iz.clear();
        self.avg.clear();
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let s = i1.sample(x as f32 + u[i], y as f32 + v[i]);
                self.iz.push(s - i0.v[i]);
                self.avg.push(0.5 * (s + i0.v[i]));
            }
        }
        central(&self.avg, w, h, true, &mut self.ix);
        central(&self.avg, w, h, false, &mut self.iy);
        central(&self.iz, w, h, true, &mut self.ixz);
        central(&self.iz, w, h, false, &mut self.iyz);
        central(&self.ix, w, h, true, &mut self.ixx);
        central(&self.ix, w, h, false, &mut self.ixy);
        central(&self.iy, w, h, false, &mut self.iyy);
        for b in [
            &mut self.a11,
            &mut self.a12,
            &mut self.a22,
            &mut self.b1,
            &mut self.b2,
            &mut self.smooth,
            &mut self.du,
            &mut self.dv,
        ] {
            b.clear();
            b.resize(n, 0.0);
        }
        let (delta2, gamma2, alpha2) = (cfg.delta / 2.0, cfg.gamma / 2.0, cfg.alpha / 2.0);
        // The parts of the data terms that do not change with the increment, once per call
        // (the per-iteration loop then needs two square roots and no division per pixel).
        for b in [
            &mut self.bn,
            &mut self.g1,
            &mut self.g2,
            &mut self.ga11,
            &mut self.ga12,
            &mut self.ga22,
            &mut self.gb1,
            &mut self.gb2,
        ] {
            b.clear();
            b.resize(n, 0.0);
        }
        for i in 0..n {
            let (ix, iy) = (self.ix[i], self.iy[i]);
            let (ixx, ixy, iyy) = (self.ixx[i], self.ixy[i], self.iyy[i]);
            let (ixz, iyz) = (self.ixz[i], self.iyz[i]);
            self.bn[i] = 1.0 / (ix * ix + iy * iy + ZETA2);
            let g1 = 1.0 / (ixx * ixx + ixy * ixy + ZETA2);
            let g2 = 1.0 / (iyy * iyy + ixy * ixy + ZETA2);
            self.g1[i] = g1;
            self.g2[i] = g2;
            self.ga11[i] = ixx * ixx * g1 + ixy * ixy * g2;
            self.ga12[i] = ixx * ixy * g1 + ixy * iyy * g2;
            self.ga22[i] = ixy * ixy * g1 + iyy * iyy * g2;
            self.gb1[i] = ixx * ixz * g1 + ixy * iyz * g2;
            self.gb2[i] = ixy * ixz * g1 + iyy * iyz * g2;
        }
        for _ in 0..cfg.refine_iterations {
            self.data_terms(n, delta2, gamma2);
            self.smoothness(u, v, w, h, alpha2);
            self.links(u, v, w, h);
            self.sor(cfg.sor_iterations, w, h);
        }
        for i in 0..n {
            u[i] += self.du[i];
            v[i] += self.dv[i];
        }
    }
}

/// [`Refiner::links`] for a pixel with some links missing (on the border): only those that
/// exist. Out of line: a frame's border is a small share of its pixels, and the code is not
/// copied into every place that calls it.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn link_border(
    sm: &[f32],
    u: &[f32],
    v: &[f32],
    [a11, a22, b1, b2]: [&mut [f32]; 4],
    w: usize,
    h: usize,
    x: usize,
    y: usize,
) {
    let i = y * w + x;
    let wr = if x + 1 < w { sm[i] } else { 0.0 };
    let wd = if y + 1 < h { sm[i] } else { 0.0 };
    let wl = if x > 0 { sm[i - 1] } else { 0.0 };
    let wu = if y > 0 { sm[i - w] } else { 0.0 };
    let at = |f: &[f32], j: usize, wgt: f32| if wgt > 0.0 { f[j] - f[i] } else { 0.0 };
    let gu = wr * at(u, i + (x + 1 < w) as usize, wr)
        + wd * at(u, i + if y + 1 < h { w } else { 0 }, wd)
        + wl * at(u, i - (x > 0) as usize, wl)
        + wu * at(u, i - if y > 0 { w } else { 0 }, wu);
    let gv = wr * at(v, i + (x + 1 < w) as usize, wr)
        + wd * at(v, i + if y + 1 < h { w } else { 0 }, wd)
        + wl * at(v, i - (x > 0) as usize, wl)
        + wu * at(v, i - if y > 0 { w } else { 0 }, wu);
    let sum = wr + wd + wl + wu;
    a11[i] = 1.0 / (a11[i] + sum);
    a22[i] = 1.0 / (a22[i] + sum);
    b1[i] += gu;
    b2[i] += gv;
}

/// `ZETA2` and `EPS2` of the refinement (OpenCV's): the data terms' regulariser and the
/// robust penalties' epsilon.
const ZETA2: f32 = 0.01;
const EPS2: f32 = 1e-6;

// The loops below are written over slices of one length (and, for the neighbours, over
// shifted windows of a row) so that they carry no bounds checks or per-pixel branches and are
// vectorised; each pixel's arithmetic is the same expression, in the same order, as a plain
// per-pixel loop's, so the results are too, bit for bit.
impl Refiner {
    /// The data terms, linearised around the current increment (robust weights): `a11`,
    /// `a12`, `a22`, `b1`, `b2` from the image derivatives and `du`, `dv`.
    fn data_terms(&mut self, n: usize, delta2: f32, gamma2: f32) {
        let (ix, iy, iz) = (&self.ix[..n], &self.iy[..n], &self.iz[..n]);
        let (du, dv, bn) = (&self.du[..n], &self.dv[..n], &self.bn[..n]);
        let (ixz, iyz) = (&self.ixz[..n], &self.iyz[..n]);
        let (ixx, ixy, iyy) = (&self.ixx[..n], &self.ixy[..n], &self.iyy[..n]);
        let (g1, g2) = (&self.g1[..n], &self.g2[..n]);
        let (ga11, ga12, ga22) = (&self.ga11[..n], &self.ga12[..n], &self.ga22[..n]);
        let (gb1, gb2) = (&self.gb1[..n], &self.gb2[..n]);
        let (a11, a12, a22) = (&mut self.a11[..n], &mut self.a12[..n], &mut self.a22[..n]);
        let (b1, b2) = (&mut self.b1[..n], &mut self.b2[..n]);
        for i in 0..n {
            let (ix, iy, iz) = (ix[i], iy[i], iz[i]);
            let (du, dv) = (du[i], dv[i]);
            let bn = bn[i];
            let r = iz + ix * du + iy * dv;
            let wb = delta2 * bn / (r * r * bn + EPS2).sqrt();
            let rx = ixz[i] + ixx[i] * du + ixy[i] * dv;
            let ry = iyz[i] + ixy[i] * du + iyy[i] * dv;
            let wg = gamma2 / (rx * rx * g1[i] + ry * ry * g2[i] + EPS2).sqrt();
            a11[i] = wb * ix * ix + ZETA2 + wg * ga11[i];
            a12[i] = wb * ix * iy + wg * ga12[i];
            a22[i] = wb * iy * iy + ZETA2 + wg * ga22[i];
            b1[i] = -wb * iz * ix - wg * gb1[i];
            b2[i] = -wb * iz * iy - wg * gb2[i];
        }
    }

    /// Smoothness: one robust weight per pixel from the forward differences of the current
    /// flow `u + du`, `v + dv`, shared by its right and lower neighbour links (a difference
    /// past the border is 0).
    fn smoothness(&mut self, u: &[f32], v: &[f32], w: usize, h: usize, alpha2: f32) {
        let weight = |tu: f32, tv: f32, ru: f32, rv: f32, du_: f32, dv_: f32| {
            let (ux, vx) = (ru - tu, rv - tv);
            let (uy, vy) = (du_ - tu, dv_ - tv);
            alpha2 / (ux * ux + uy * uy + vx * vx + vy * vy + EPS2).sqrt()
        };
        let (du, dv) = (&self.du, &self.dv);
        for y in 0..h {
            let row = y * w;
            let down = (y + 1).min(h - 1) * w;
            let out = &mut self.smooth[row..row + w];
            let (u0, v0, du0, dv0) = (
                &u[row..row + w],
                &v[row..row + w],
                &du[row..row + w],
                &dv[row..row + w],
            );
            let (ud, vd, dud, dvd) = (
                &u[down..down + w],
                &v[down..down + w],
                &du[down..down + w],
                &dv[down..down + w],
            );
            for x in 0..w - 1 {
                let (tu, tv) = (u0[x] + du0[x], v0[x] + dv0[x]);
                out[x] = weight(
                    tu,
                    tv,
                    u0[x + 1] + du0[x + 1],
                    v0[x + 1] + dv0[x + 1],
                    ud[x] + dud[x],
                    vd[x] + dvd[x],
                );
            }
            let x = w - 1;
            let (tu, tv) = (u0[x] + du0[x], v0[x] + dv0[x]);
            out[x] = weight(tu, tv, tu, tv, ud[x] + dud[x], vd[x] + dvd[x]);
        }
    }

    /// Each pixel gathers its four links (the weights of the links to its right and lower
    /// neighbours are its own `smooth`, to its left and upper ones theirs; none past the
    /// border): their pull on the flow joins `b1`, `b2`, their sum the diagonal, whose
    /// inverse `a11`/`a22` then hold for the SOR.
    fn links(&mut self, u: &[f32], v: &[f32], w: usize, h: usize) {
        let sm = &self.smooth;
        let (a11, a22, b1, b2) = (&mut self.a11, &mut self.a22, &mut self.b1, &mut self.b2);
        for y in 0..h {
            let row = y * w;
            if y == 0 || y + 1 == h || w < 3 {
                for x in 0..w {
                    link_border(
                        sm,
                        u,
                        v,
                        [&mut *a11, &mut *a22, &mut *b1, &mut *b2],
                        w,
                        h,
                        x,
                        y,
                    );
                }
                continue;
            }
            for x in [0, w - 1] {
                link_border(
                    sm,
                    u,
                    v,
                    [&mut *a11, &mut *a22, &mut *b1, &mut *b2],
                    w,
                    h,
                    x,
                    y,
                );
            }
            // Interior: all four links. Their weights (alpha over a square root) are positive
            // unless `alpha` is 0, where a term is then ±0 instead of +0: the same sums.
            let r = row + 1..row + w - 1;
            let (s, sl, su) = (
                &sm[r.clone()],
                &sm[row..row + w - 2],
                &sm[row - w + 1..row - 1],
            );
            let (uc, ur, ul) = (&u[r.clone()], &u[row + 2..row + w], &u[row..row + w - 2]);
            let (ud, uu) = (&u[row + w + 1..row + 2 * w - 1], &u[row - w + 1..row - 1]);
            let (vc, vr, vl) = (&v[r.clone()], &v[row + 2..row + w], &v[row..row + w - 2]);
            let (vd, vu) = (&v[row + w + 1..row + 2 * w - 1], &v[row - w + 1..row - 1]);
            let (a11, a22) = (&mut a11[r.clone()], &mut a22[r.clone()]);
            let (b1, b2) = (&mut b1[r.clone()], &mut b2[r]);
            for x in 0..w - 2 {
                let (wr, wl, wu) = (s[x], sl[x], su[x]);
                let gu = wr * (ur[x] - uc[x])
                    + wr * (ud[x] - uc[x])
                    + wl * (ul[x] - uc[x])
                    + wu * (uu[x] - uc[x]);
                let gv = wr * (vr[x] - vc[x])
                    + wr * (vd[x] - vc[x])
                    + wl * (vl[x] - vc[x])
                    + wu * (vu[x] - vc[x]);
                let sum = wr + wr + wl + wu;
                a11[x] = 1.0 / (a11[x] + sum);
                a22[x] = 1.0 / (a22[x] + sum);
                b1[x] += gu;
                b2[x] += gv;
            }
        }
    }
}

impl Refiner {
    /// Successive over-relaxation on the increments `du`, `dv`, red-black order (pixels with
    /// `x + y` even, then odd). A pixel's update reads only the other colour, so each row of
    /// one colour is computed from values that do not change during its pass: the interior
    /// of a row is one loop without a chain of dependent divisions, which the compiler
    /// vectorises (the plain Gauss–Seidel order was three quarters of the flow's time). The
    /// row loop computes both colours and keeps the pass's own: twice the arithmetic, in
    /// lanes. `a11`/`a22` hold the inverses of the system's diagonal.
    fn sor(&mut self, sweeps: u32, w: usize, h: usize) {
        let sys = System {
            sm: &self.smooth,
            a12: &self.a12,
            i11: &self.a11,
            i22: &self.a22,
            b1: &self.b1,
            b2: &self.b2,
        };
        self.row_u.clear();
        self.row_u.resize(w, 0.0);
        self.row_v.clear();
        self.row_v.resize(w, 0.0);
        for _ in 0..sweeps {
            for colour in 0..2 {
                for y in 0..h {
                    sor_row(
                        &sys,
                        &mut self.du,
                        &mut self.dv,
                        &mut self.row_u,
                        &mut self.row_v,
                        w,
                        h,
                        y,
                        colour,
                    );
                }
            }
        }
    }
}

/// The fixed coefficients of one fixed-point iteration's linear system.
struct System<'a> {
    sm: &'a [f32],
    a12: &'a [f32],
    i11: &'a [f32],
    i22: &'a [f32],
    b1: &'a [f32],
    b2: &'a [f32],
}

/// Over-relaxation factor of the SOR sweeps (OpenCV's).
const OMEGA: f32 = 1.6;

/// One row's pass of one colour of [`Refiner::sor`].
#[allow(clippy::too_many_arguments)]
#[inline]
fn sor_row(
    sys: &System,
    du: &mut [f32],
    dv: &mut [f32],
    tu: &mut [f32],
    tv: &mut [f32],
    w: usize,
    h: usize,
    y: usize,
    colour: usize,
) {
    let row = y * w;
    let interior = y > 0 && y + 1 < h && w > 2;
    if interior {
        // Exact-length row windows, so the loop below needs no bounds checks.
        let (above, rest) = du.split_at(row);
        let (cur_u, below_u) = rest.split_at(w);
        let (up_u, down_u) = (&above[row - w..], &below_u[..w]);
        let (above, rest) = dv.split_at(row);
        let (cur_v, below_v) = rest.split_at(w);
        let (up_v, down_v) = (&above[row - w..], &below_v[..w]);
        let s = &sys.sm[row..row + w];
        let s_up = &sys.sm[row - w..row];
        let (a12, i11, i22) = (
            &sys.a12[row..row + w],
            &sys.i11[row..row + w],
            &sys.i22[row..row + w],
        );
        let (b1, b2) = (&sys.b1[row..row + w], &sys.b2[row..row + w]);
        let (tu, tv) = (&mut tu[..w], &mut tv[..w]);
        for x in 1..w - 1 {
            let su =
                s[x] * (cur_u[x + 1] + down_u[x]) + s[x - 1] * cur_u[x - 1] + s_up[x] * up_u[x];
            let sv =
                s[x] * (cur_v[x + 1] + down_v[x]) + s[x - 1] * cur_v[x - 1] + s_up[x] * up_v[x];
            let nu = cur_u[x] + OMEGA * ((su + b1[x] - a12[x] * cur_v[x]) * i11[x] - cur_u[x]);
            tu[x] = nu;
            tv[x] = cur_v[x] + OMEGA * ((sv + b2[x] - a12[x] * nu) * i22[x] - cur_v[x]);
        }
    }
    // This colour's pixels of the row: the interior ones take the values computed above; the
    // border ones are computed here from the links they have. Either reads only the other
    // colour, which this pass leaves as it is, so the order of the two does not matter.
    let first = (y + colour) % 2;
    if interior {
        // A select over the whole row (vectorised), not a strided copy.
        let (du_row, dv_row) = (&mut du[row + 1..row + w - 1], &mut dv[row + 1..row + w - 1]);
        let (tu, tv) = (&tu[1..w - 1], &tv[1..w - 1]);
        for k in 0..w - 2 {
            // Pixel x = k + 1 is of this colour when x % 2 == first.
            let take = (k + 1 + first) % 2 == 0;
            du_row[k] = if take { tu[k] } else { du_row[k] };
            dv_row[k] = if take { tv[k] } else { dv_row[k] };
        }
        for x in [0, w - 1] {
            if x % 2 == first {
                sor_border(sys, du, dv, w, h, y, x);
            }
        }
    } else {
        for x in (first..w).step_by(2) {
            sor_border(sys, du, dv, w, h, y, x);
        }
    }
}

/// [`sor_row`]'s update of a border pixel: only the links that exist. Out of line, as
/// [`link_border`].
#[inline(never)]
fn sor_border(
    sys: &System,
    du: &mut [f32],
    dv: &mut [f32],
    w: usize,
    h: usize,
    y: usize,
    x: usize,
) {
    let i = y * w + x;
    let sm = sys.sm;
    let (mut su, mut sv) = (0f32, 0f32);
    if x + 1 < w {
        su += sm[i] * du[i + 1];
        sv += sm[i] * dv[i + 1];
    }
    if y + 1 < h {
        su += sm[i] * du[i + w];
        sv += sm[i] * dv[i + w];
    }
    if x > 0 {
        su += sm[i - 1] * du[i - 1];
        sv += sm[i - 1] * dv[i - 1];
    }
    if y > 0 {
        su += sm[i - w] * du[i - w];
        sv += sm[i - w] * dv[i - w];
    }
    let nu = du[i] + OMEGA * ((su + sys.b1[i] - sys.a12[i] * dv[i]) * sys.i11[i] - du[i]);
    dv[i] += OMEGA * ((sv + sys.b2[i] - sys.a12[i] * nu) * sys.i22[i] - dv[i]);
    du[i] = nu;
}
