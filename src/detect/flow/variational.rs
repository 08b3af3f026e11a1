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
        const ZETA2: f32 = 0.01;
        const EPS2: f32 = 1e-6;
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
            // Data terms, linearised around the current increment (robust weights).
            for i in 0..n {
                let (ix, iy, iz) = (self.ix[i], self.iy[i], self.iz[i]);
                let (du, dv) = (self.du[i], self.dv[i]);
                let bn = self.bn[i];
                let r = iz + ix * du + iy * dv;
                let wb = delta2 * bn / (r * r * bn + EPS2).sqrt();
                let rx = self.ixz[i] + self.ixx[i] * du + self.ixy[i] * dv;
                let ry = self.iyz[i] + self.ixy[i] * du + self.iyy[i] * dv;
                let wg = gamma2 / (rx * rx * self.g1[i] + ry * ry * self.g2[i] + EPS2).sqrt();
                self.a11[i] = wb * ix * ix + ZETA2 + wg * self.ga11[i];
                self.a12[i] = wb * ix * iy + wg * self.ga12[i];
                self.a22[i] = wb * iy * iy + ZETA2 + wg * self.ga22[i];
                self.b1[i] = -wb * iz * ix - wg * self.gb1[i];
                self.b2[i] = -wb * iz * iy - wg * self.gb2[i];
            }
            // Smoothness: one robust weight per pixel from the forward differences of the
            // current flow, shared by its right and lower neighbour links (0 past the border).
            for y in 0..h {
                let row = y * w;
                for x in 0..w {
                    let i = row + x;
                    let (tu, tv) = (u[i] + self.du[i], v[i] + self.dv[i]);
                    let r = row + (x + 1).min(w - 1);
                    let d = (y + 1).min(h - 1) * w + x;
                    let (ux, vx) = (u[r] + self.du[r] - tu, v[r] + self.dv[r] - tv);
                    let (uy, vy) = (u[d] + self.du[d] - tu, v[d] + self.dv[d] - tv);
                    self.smooth[i] = alpha2 / (ux * ux + uy * uy + vx * vx + vy * vy + EPS2).sqrt();
                }
            }
            // Each pixel gathers its four links: `wx`/`wy` are the weights of the links to its
            // right and lower neighbours (none on the last column and row).
            let sm = &self.smooth;
            let link = |i: usize, x: usize, y: usize| -> (f32, f32, f32, f32) {
                let wr = if x + 1 < w { sm[i] } else { 0.0 };
                let wd = if y + 1 < h { sm[i] } else { 0.0 };
                let wl = if x > 0 { sm[i - 1] } else { 0.0 };
                let wu = if y > 0 { sm[i - w] } else { 0.0 };
                (wr, wd, wl, wu)
            };
            for y in 0..h {
                for x in 0..w {
                    let i = y * w + x;
                    let (wr, wd, wl, wu) = link(i, x, y);
                    let at =
                        |f: &[f32], j: usize, wgt: f32| if wgt > 0.0 { f[j] - f[i] } else { 0.0 };
                    let gu = wr * at(u, i + (x + 1 < w) as usize, wr)
                        + wd * at(u, i + if y + 1 < h { w } else { 0 }, wd)
                        + wl * at(u, i - (x > 0) as usize, wl)
                        + wu * at(u, i - if y > 0 { w } else { 0 }, wu);
                    let gv = wr * at(v, i + (x + 1 < w) as usize, wr)
                        + wd * at(v, i + if y + 1 < h { w } else { 0 }, wd)
                        + wl * at(v, i - (x > 0) as usize, wl)
                        + wu * at(v, i - if y > 0 { w } else { 0 }, wu);
                    let sum = wr + wd + wl + wu;
                    // The SOR below divides by these: keep their inverses.
                    self.a11[i] = 1.0 / (self.a11[i] + sum);
                    self.a22[i] = 1.0 / (self.a22[i] + sum);
                    self.b1[i] += gu;
                    self.b2[i] += gv;
                }
            }
            self.sor(cfg.sor_iterations, w, h);
        }
        for i in 0..n {
            u[i] += self.du[i];
            v[i] += self.dv[i];
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
    let mut x = (y + colour) % 2;
    while x < w {
        let i = row + x;
        if interior && x > 0 && x + 1 < w {
            du[i] = tu[x];
            dv[i] = tv[x];
        } else {
            // Border pixels: only the links that exist.
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
        x += 2;
    }
}
