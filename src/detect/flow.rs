//! Dense optical flow between two grey working frames, for the moving-camera detector.
//!
//! The method is DIS, *dense inverse search* (Kroeger, Timofte, Dai and Van Gool, "Fast
//! Optical Flow using Dense Inverse Search", ECCV 2016), with the variational refinement that
//! OpenCV's `DISOpticalFlow` runs after it at every scale (the brightness- and
//! gradient-constancy data terms and the robust smoothness term of Brox, Bruhn, Papenberg and
//! Weickert 2004, linearised once per scale and solved by successive over-relaxation). Per
//! scale of a pyramid, coarse to fine:
//!
//! 1. **Patch search.** Patches of [`FlowConfig::patch_size`] pixels every
//!    [`FlowConfig::patch_stride`] pixels each look for their displacement by Gauss–Newton
//!    steps on the patch's mean-normalised squared difference (so a patch that only got
//!    brighter still matches), starting from the coarser scale's flow or from a neighbour
//!    patch's, whichever matches best (a forward and a backward sweep). A step that ends
//!    farther than a patch size from its start is not taken.
//! 2. **Densification.** Each pixel's flow is the average of the flows of the patches that
//!    cover it, each weighted by how well it explains that pixel (`1 / max(1, |I₁(x + u) −
//!    I₀(x)|)`): patches across a motion boundary lose at the pixels they do not fit.
//! 3. **Variational refinement** (OpenCV's defaults: α = 20, δ = 5, γ = 10, five fixed-point
//!    iterations of five SOR sweeps): smooths the flow where the image says nothing and keeps
//!    its edges where it does.
//!
//! Why by hand: no maintained Rust crate computes dense flow in pure Rust (the `opencv`
//! crate binds the C++ library, which does not build for wasm32). Why DIS: in a prototype of
//! the moving detector with OpenCV (mean J on the 8 DAVIS moving-camera sequences, refined
//! blob boxes), DIS gave 0.54 where Farnebäck's flow gave 0.46 under the same camera model,
//! and DIS without its variational refinement 0.45 against 0.57 with it
//! (`tests/data/detect/README.md`); it is also among the fastest dense methods per pixel.
//!
//! The working frames are small (at most [`super::MovingConfig::work_side`] pixels on their
//! longer side), so the whole pyramid is a few hundred kilobytes, kept between calls.

mod config;
mod variational;

pub use config::FlowConfig;
use config::MAX_PATCH;
use variational::Refiner;

/// A grey image (or one flow component) of one pyramid scale.
#[derive(Debug, Clone, Default)]
struct Plane {
    w: usize,
    h: usize,
    v: Vec<f32>,
}

impl Plane {
    fn resize(&mut self, w: usize, h: usize) {
        self.w = w;
        self.h = h;
        self.v.clear();
        self.v.resize(w * h, 0.0);
    }

    /// Bilinear sample with the border repeated outside.
    #[inline]
    fn sample(&self, x: f32, y: f32) -> f32 {
        let x = x.clamp(0.0, (self.w - 1) as f32);
        let y = y.clamp(0.0, (self.h - 1) as f32);
        let (x0, y0) = (x as usize, y as usize);
        let (x1, y1) = ((x0 + 1).min(self.w - 1), (y0 + 1).min(self.h - 1));
        let (tx, ty) = (x - x0 as f32, y - y0 as f32);
        let r0 = &self.v[y0 * self.w..];
        let r1 = &self.v[y1 * self.w..];
        let a = r0[x0] + tx * (r0[x1] - r0[x0]);
        let b = r1[x0] + tx * (r1[x1] - r1[x0]);
        a + ty * (b - a)
    }
}

/// `dst` = `src` averaged down by 2 (2×2 blocks; an odd last row or column is dropped).
fn halve(src: &Plane, dst: &mut Plane) {
    let (w, h) = (src.w / 2, src.h / 2);
    dst.resize(w, h);
    for y in 0..h {
        let (r0, r1) = (&src.v[2 * y * src.w..], &src.v[(2 * y + 1) * src.w..]);
        for x in 0..w {
            dst.v[y * w + x] = 0.25 * (r0[2 * x] + r0[2 * x + 1] + r1[2 * x] + r1[2 * x + 1]);
        }
    }
}

/// `dst` (already sized) = `src` resized bilinearly (pixel centres aligned) times `factor`.
fn upscale_into(src: &Plane, dst: &mut Plane, factor: f32) {
    let (sx, sy) = (src.w as f32 / dst.w as f32, src.h as f32 / dst.h as f32);
    for y in 0..dst.h {
        let fy = ((y as f32 + 0.5) * sy - 0.5).max(0.0);
        for x in 0..dst.w {
            let fx = ((x as f32 + 0.5) * sx - 0.5).max(0.0);
            dst.v[y * dst.w + x] = factor * src.sample(fx, fy);
        }
    }
}

/// A dense flow field: pixel `(x, y)` of the first image is found at `(x + u, y + v)` in the
/// second.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FlowField {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Horizontal displacement per pixel, row-major.
    pub u: Vec<f32>,
    /// Vertical displacement per pixel, row-major.
    pub v: Vec<f32>,
}

/// Dense optical flow (see the module docs); keeps its buffers between calls.
#[derive(Debug, Clone, Default)]
pub struct DenseFlow {
    cfg: FlowConfig,
    i0: Vec<Plane>,
    i1: Vec<Plane>,
    u: Vec<Plane>,
    v: Vec<Plane>,
    gx: Plane,
    gy: Plane,
    /// Per patch: its flow and the inverse of its mean-normalised structure tensor.
    sx: Vec<f32>,
    sy: Vec<f32>,
    patch: Vec<PatchTensor>,
    vr: Refiner,
    /// The dominant-motion guess of the current call ([`DenseFlow::compute_guided`]).
    guess: Option<[f64; 6]>,
}

/// A patch's gradient sums: `Σ∇I₀` and the inverse of `Σ(∇I₀ − mean)(∇I₀ − mean)ᵀ`.
#[derive(Debug, Clone, Copy, Default)]
struct PatchTensor {
    gx: f32,
    gy: f32,
    i11: f32,
    i12: f32,
    i22: f32,
    /// Whether the tensor could be inverted (a flat patch has no Gauss–Newton step).
    ok: bool,
}

impl DenseFlow {
    /// A flow computer with these settings (see [`FlowConfig::check`]).
    pub fn new(cfg: FlowConfig) -> Self {
        Self {
            cfg,
            ..Self::default()
        }
    }

    /// The flow from `i0` to `i1`, both `w × h` grey images (row-major, any range; the
    /// settings assume 0–255), written into `out`. Images smaller than a patch, and settings
    /// [`FlowConfig::check`] refuses, get zero flow.
    pub fn compute(&mut self, i0: &[f32], i1: &[f32], w: usize, h: usize, out: &mut FlowField) {
        self.compute_guided(i0, i1, w, h, None, out);
    }

    /// [`compute`](Self::compute) with a guess of the dominant motion: an affine map `[a, b,
    /// c, d, e, f]` taking pixel `(x, y)` of `i0` to `(a·x + b·y + c, d·x + e·y + f)` in `i1`
    /// (the camera's motion, found from sparse matches). The coarsest scale starts from it
    /// instead of from zero, and at every scale each patch also tries it beside the coarser
    /// scale's flow and its neighbours'. Coarse-to-fine search alone loses its way on fine
    /// repetitive texture (a fence, a façade's windows, foliage): at the coarse scales the
    /// pattern aliases and the first displacements found are a period off, which the finer
    /// scales then keep; the guess puts the background's patches at the right period.
    pub fn compute_guided(
        &mut self,
        i0: &[f32],
        i1: &[f32],
        w: usize,
        h: usize,
        guess: Option<[f64; 6]>,
        out: &mut FlowField,
    ) {
        self.guess = guess.filter(|g| g.iter().all(|v| v.is_finite()));
        out.width = w;
        out.height = h;
        out.u.clear();
        out.u.resize(w * h, 0.0);
        out.v.clear();
        out.v.resize(w * h, 0.0);
        let ps = self.cfg.patch_size as usize;
        // Settings `FlowConfig::check` refuses (a detector checks them first) give zero flow:
        // the patch search's per-column sums hold `MAX_PATCH` columns at most.
        if self.cfg.check().is_err() || w < ps || h < ps || i0.len() < w * h || i1.len() < w * h {
            return;
        }
        // Coarsest scale as DIS picks it: `round(log2(max side / 4 patches))`, so that a
        // displacement of up to a quarter of the frame can be found, and no coarser than the
        // scale that still holds a patch (`floor(log2(min side / patch))`). In integers, so
        // that native and wasm builds agree whatever their `log2`.
        let (long, short) = (w.max(h) as u64, w.min(h) as u64);
        let (m2, d2) = (long * long, 16 * (ps * ps) as u64);
        let mut by_motion = 0;
        while m2 >= d2 << (2 * by_motion + 1) {
            by_motion += 1;
        }
        let mut by_patch = 0;
        while short >= (ps as u64) << (by_patch + 1) {
            by_patch += 1;
        }
        let levels = by_motion.min(by_patch) + 1;
        for list in [&mut self.i0, &mut self.i1, &mut self.u, &mut self.v] {
            list.resize_with(levels, Plane::default);
        }
        self.i0[0].resize(w, h);
        self.i0[0].v.copy_from_slice(&i0[..w * h]);
        self.i1[0].resize(w, h);
        self.i1[0].v.copy_from_slice(&i1[..w * h]);
        for l in 1..levels {
            let (lo, hi) = self.i0.split_at_mut(l);
            halve(&lo[l - 1], &mut hi[0]);
            let (lo, hi) = self.i1.split_at_mut(l);
            halve(&lo[l - 1], &mut hi[0]);
        }
        let top = levels - 1;
        let (tw, th) = (self.i0[top].w, self.i0[top].h);
        self.u[top].resize(tw, th);
        self.v[top].resize(tw, th);
        if self.guess.is_some() {
            for y in 0..th {
                for x in 0..tw {
                    if let Some((gu, gv)) = self.guess_at(top, x, y) {
                        self.u[top].v[y * tw + x] = gu;
                        self.v[top].v[y * tw + x] = gv;
                    }
                }
            }
        }
        for l in (0..levels).rev() {
            if l < top {
                let (lw, lh) = (self.i0[l].w, self.i0[l].h);
                for comp in [&mut self.u, &mut self.v] {
                    let (lo, hi) = comp.split_at_mut(l + 1);
                    lo[l].resize(lw, lh);
                    upscale_into(&hi[0], &mut lo[l], 2.0);
                }
            }
            self.level(l);
        }
        out.u.copy_from_slice(&self.u[0].v);
        out.v.copy_from_slice(&self.v[0].v);
    }

    /// The guessed flow at pixel `(x, y)` of scale `l`, in that scale's pixels.
    fn guess_at(&self, l: usize, x: usize, y: usize) -> Option<(f32, f32)> {
        let g = self.guess?;
        let f = (1u32 << l) as f64;
        // The pixel's centre in full-scale coordinates.
        let (px, py) = ((x as f64 + 0.5) * f - 0.5, (y as f64 + 0.5) * f - 0.5);
        let (qx, qy) = (g[0] * px + g[1] * py + g[2], g[3] * px + g[4] * py + g[5]);
        Some((((qx - px) / f) as f32, ((qy - py) / f) as f32))
    }

    /// Patch search, densification and refinement at one scale; `u`/`v` hold the initial
    /// flow on entry and the result on return.
    fn level(&mut self, l: usize) {
        let (w, h) = (self.i0[l].w, self.i0[l].h);
        let ps = self.cfg.patch_size as usize;
        let st = self.cfg.patch_stride as usize;
        if w < ps || h < ps {
            return;
        }
        self.gradients(l);
        let ws = 1 + (w - ps) / st;
        let hs = 1 + (h - ps) / st;
        self.tensors(l, ws, hs);
        self.search(l, ws, hs);
        self.densify(l, ws, hs);
        if self.cfg.refine_iterations > 0 && self.cfg.sor_iterations > 0 {
            let (i0, i1) = (&self.i0[l], &self.i1[l]);
            self.vr
                .refine(&self.cfg, i0, i1, &mut self.u[l].v, &mut self.v[l].v);
        }
    }

    /// Sobel gradients of `i0` at scale `l` (normalised to grey levels per pixel), border
    /// repeated.
    fn gradients(&mut self, l: usize) {
        let img = &self.i0[l];
        let (w, h) = (img.w, img.h);
        self.gx.resize(w, h);
        self.gy.resize(w, h);
        let at = |x: isize, y: isize| {
            let x = x.clamp(0, w as isize - 1) as usize;
            let y = y.clamp(0, h as isize - 1) as usize;
            img.v[y * w + x]
        };
        for y in 0..h as isize {
            for x in 0..w as isize {
                let gx = (at(x + 1, y - 1) + 2.0 * at(x + 1, y) + at(x + 1, y + 1))
                    - (at(x - 1, y - 1) + 2.0 * at(x - 1, y) + at(x - 1, y + 1));
                let gy = (at(x - 1, y + 1) + 2.0 * at(x, y + 1) + at(x + 1, y + 1))
                    - (at(x - 1, y - 1) + 2.0 * at(x, y - 1) + at(x + 1, y - 1));
                let i = y as usize * w + x as usize;
                self.gx.v[i] = gx * 0.125;
                self.gy.v[i] = gy * 0.125;
            }
        }
    }

    /// Each patch's mean-normalised structure tensor, inverted.
    fn tensors(&mut self, l: usize, ws: usize, hs: usize) {
        let w = self.i0[l].w;
        let ps = self.cfg.patch_size as usize;
        let st = self.cfg.patch_stride as usize;
        let n = (ps * ps) as f32;
        self.patch.clear();
        for is in 0..hs {
            for js in 0..ws {
                let (x0, y0) = (js * st, is * st);
                let (mut sx, mut sy, mut sxx, mut syy, mut sxy) = (0f32, 0f32, 0f32, 0f32, 0f32);
                for y in y0..y0 + ps {
                    let (rx, ry) = (
                        &self.gx.v[y * w + x0..][..ps],
                        &self.gy.v[y * w + x0..][..ps],
                    );
                    for (&a, &b) in rx.iter().zip(ry) {
                        sx += a;
                        sy += b;
                        sxx += a * a;
                        syy += b * b;
                        sxy += a * b;
                    }
                }
                let (a, b, c) = (sxx - sx * sx / n, sxy - sx * sy / n, syy - sy * sy / n);
                let det = a * c - b * b;
                // A patch whose gradients are all alike (flat, or one straight edge) has no
                // reliable step: it keeps its candidate flow.
                let tr = (a + c).max(1e-6);
                let ok = det > 1e-3 * tr * tr && det > 1e-6;
                let (i11, i12, i22) = if ok {
                    (c / det, -b / det, a / det)
                } else {
                    (0.0, 0.0, 0.0)
                };
                self.patch.push(PatchTensor {
                    gx: sx,
                    gy: sy,
                    i11,
                    i12,
                    i22,
                    ok,
                });
            }
        }
    }

    /// `(cost, Σgx·d, Σgy·d, Σd)` of the patch at `(x0, y0)` displaced by `(u, v)`: its
    /// mean-normalised SSD and the sums a Gauss–Newton step needs (`d` = `I₁(x + u) − I₀(x)`).
    #[inline]
    fn patch_cost(&self, l: usize, x0: usize, y0: usize, u: f32, v: f32) -> (f32, f32, f32, f32) {
        let (i0, i1) = (&self.i0[l], &self.i1[l]);
        let w = i0.w;
        let ps = self.cfg.patch_size as usize;
        let n = (ps * ps) as f32;
        let (px, py) = (x0 as f32 + u, y0 as f32 + v);
        let (fx, fy) = (px.floor(), py.floor());
        let (tx, ty) = (px - fx, py - fy);
        let (bx, by) = (fx as isize, fy as isize);
        // Per-column running sums (a patch column per lane), added up at the end: the rows'
        // updates are then independent across columns and vectorised, where four chains of
        // dependent additions over all ps² pixels left the loop waiting on each.
        let (mut ld, mut ldd, mut lgx, mut lgy) = (
            [0f32; MAX_PATCH],
            [0f32; MAX_PATCH],
            [0f32; MAX_PATCH],
            [0f32; MAX_PATCH],
        );
        let inside = bx >= 0 && by >= 0 && bx as usize + ps < i1.w && by as usize + ps < i1.h;
        let (w00, w01, w10, w11) = (
            (1.0 - tx) * (1.0 - ty),
            tx * (1.0 - ty),
            (1.0 - tx) * ty,
            tx * ty,
        );
        for r in 0..ps {
            let row0 = &i0.v[(y0 + r) * w + x0..][..ps];
            let (grx, gry) = (
                &self.gx.v[(y0 + r) * w + x0..][..ps],
                &self.gy.v[(y0 + r) * w + x0..][..ps],
            );
            let (ld, ldd, lgx, lgy) = (
                &mut ld[..ps],
                &mut ldd[..ps],
                &mut lgx[..ps],
                &mut lgy[..ps],
            );
            if inside {
                let a = &i1.v[(by as usize + r) * i1.w + bx as usize..][..ps + 1];
                let b = &i1.v[(by as usize + r + 1) * i1.w + bx as usize..][..ps + 1];
                for c in 0..ps {
                    let s = w00 * a[c] + w01 * a[c + 1] + w10 * b[c] + w11 * b[c + 1];
                    let d = s - row0[c];
                    ld[c] += d;
                    ldd[c] += d * d;
                    lgx[c] += grx[c] * d;
                    lgy[c] += gry[c] * d;
                }
            } else {
                for c in 0..ps {
                    let s = i1.sample(px + c as f32, py + r as f32);
                    let d = s - row0[c];
                    ld[c] += d;
                    ldd[c] += d * d;
                    lgx[c] += grx[c] * d;
                    lgy[c] += gry[c] * d;
                }
            }
        }
        let total = |l: &[f32; MAX_PATCH]| l[..ps].iter().sum::<f32>();
        let (sd, sdd, sgx, sgy) = (total(&ld), total(&ldd), total(&lgx), total(&lgy));
        (sdd - sd * sd / n, sgx, sgy, sd)
    }

    /// The two sweeps of patch search at scale `l`.
    fn search(&mut self, l: usize, ws: usize, hs: usize) {
        let w = self.i0[l].w;
        let ps = self.cfg.patch_size as usize;
        let st = self.cfg.patch_stride as usize;
        let half = ps / 2;
        let n = (ps * ps) as f32;
        self.sx.clear();
        self.sy.clear();
        for is in 0..hs {
            for js in 0..ws {
                let c = (is * st + half) * w + js * st + half;
                self.sx.push(self.u[l].v[c]);
                self.sy.push(self.v[l].v[c]);
            }
        }
        let steps = (self.cfg.descent_iterations / 2).max(1);
        for pass in 0..2 {
            let forward = pass == 0;
            for k in 0..hs * ws {
                let idx = if forward { k } else { hs * ws - 1 - k };
                let (is, js) = (idx / ws, idx % ws);
                let (x0, y0) = (js * st, is * st);
                // Candidates: this patch's flow, the guess, and the neighbours' already swept
                // this pass.
                let mut best = (self.sx[idx], self.sy[idx]);
                let mut best_cost = self.patch_cost(l, x0, y0, best.0, best.1).0;
                let guessed = self
                    .guess_at(l, x0 + half, y0 + half)
                    .map(|(gu, gv)| ((gu, gv), self.patch_cost(l, x0, y0, gu, gv).0));
                if let Some((g, c)) = guessed {
                    if c < best_cost {
                        best = g;
                        best_cost = c;
                    }
                }
                let mut cands = [None, None];
                if forward {
                    if js > 0 {
                        cands[0] = Some(idx - 1);
                    }
                    if is > 0 {
                        cands[1] = Some(idx - ws);
                    }
                } else {
                    if js + 1 < ws {
                        cands[0] = Some(idx + 1);
                    }
                    if is + 1 < hs {
                        cands[1] = Some(idx + ws);
                    }
                }
                for j in cands.into_iter().flatten() {
                    let (cu, cv) = (self.sx[j], self.sy[j]);
                    let c = self.patch_cost(l, x0, y0, cu, cv).0;
                    if c < best_cost {
                        best = (cu, cv);
                        best_cost = c;
                    }
                }
                let start = best;
                let t = self.patch[idx];
                if t.ok {
                    let (mut u, mut v) = best;
                    for _ in 0..steps {
                        let (cost, sgx, sgy, sd) = self.patch_cost(l, x0, y0, u, v);
                        if cost < best_cost || (u, v) == start {
                            if cost <= best_cost {
                                best = (u, v);
                                best_cost = cost;
                            }
                        } else {
                            break;
                        }
                        // Gauss–Newton on the mean-normalised residual.
                        let bx = sgx - sd * t.gx / n;
                        let by = sgy - sd * t.gy / n;
                        let du = t.i11 * bx + t.i12 * by;
                        let dv = t.i12 * bx + t.i22 * by;
                        if !(du.is_finite() && dv.is_finite()) {
                            break;
                        }
                        u -= du;
                        v -= dv;
                        if du.abs() + dv.abs() < 1e-3 {
                            break;
                        }
                    }
                    let (fu, fv) = best;
                    if (fu - start.0) * (fu - start.0) + (fv - start.1) * (fv - start.1)
                        <= (ps * ps) as f32
                    {
                        self.sx[idx] = fu;
                        self.sy[idx] = fv;
                    } else {
                        self.sx[idx] = start.0;
                        self.sy[idx] = start.1;
                    }
                } else {
                    self.sx[idx] = start.0;
                    self.sy[idx] = start.1;
                }
            }
        }
    }

    /// Each pixel's flow from the patches covering it (see step 2 of the module docs).
    fn densify(&mut self, l: usize, ws: usize, hs: usize) {
        let (i0, i1) = (&self.i0[l], &self.i1[l]);
        let (w, h) = (i0.w, i0.h);
        let ps = self.cfg.patch_size as usize;
        let st = self.cfg.patch_stride as usize;
        // Patches covering coordinate `x` along one axis: `js·st ≤ x < js·st + ps`.
        let span = |x: usize, n: usize| {
            let lo = if x + 1 > ps {
                (x + 1 - ps).div_ceil(st)
            } else {
                0
            };
            let hi = (x / st).min(n - 1);
            // Past the last patch (a frame not a whole number of strides): the last one.
            if lo > hi {
                (n - 1, n - 1)
            } else {
                (lo, hi)
            }
        };
        let (u, v) = (&mut self.u[l].v, &mut self.v[l].v);
        for y in 0..h {
            let (ilo, ihi) = span(y, hs);
            for x in 0..w {
                let (jlo, jhi) = span(x, ws);
                let z = i0.v[y * w + x];
                let (mut su, mut sv, mut sw) = (0f32, 0f32, 0f32);
                for is in ilo..=ihi {
                    for js in jlo..=jhi {
                        let k = is * ws + js;
                        let (fu, fv) = (self.sx[k], self.sy[k]);
                        let d = i1.sample(x as f32 + fu, y as f32 + fv) - z;
                        let c = 1.0 / d.abs().max(1.0);
                        su += c * fu;
                        sv += c * fv;
                        sw += c;
                    }
                }
                u[y * w + x] = su / sw;
                v[y * w + x] = sv / sw;
            }
        }
    }
}
#[cfg(test)]
#[path = "flow_tests.rs"]
mod tests;
