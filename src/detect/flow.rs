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

use serde::{Deserialize, Serialize};

/// Settings of the dense flow.
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FlowConfig {
    /// Side of a search patch in pixels. Default `8` (DIS's).
    pub patch_size: u32,
    /// Distance between neighbouring patches in pixels. Default `4` (OpenCV's "fast" preset;
    /// 3, its "medium", matched J on DAVIS within 0.01 for 40 % more patches).
    pub patch_stride: u32,
    /// Gauss–Newton steps per patch, over both sweeps. Default `16`.
    pub descent_iterations: u32,
    /// Fixed-point iterations of the variational refinement per scale (0 = none). Default `5`.
    pub refine_iterations: u32,
    /// SOR sweeps per fixed-point iteration. Default `5`.
    pub sor_iterations: u32,
    /// Smoothness weight `α`. Default `20`.
    pub alpha: f32,
    /// Brightness-constancy weight `δ`. Default `5`.
    pub delta: f32,
    /// Gradient-constancy weight `γ`. Default `10`.
    pub gamma: f32,
}

impl Default for FlowConfig {
    fn default() -> Self {
        Self {
            patch_size: 8,
            patch_stride: 4,
            descent_iterations: 16,
            refine_iterations: 5,
            sor_iterations: 5,
            alpha: 20.0,
            delta: 5.0,
            gamma: 10.0,
        }
    }
}

impl FlowConfig {
    /// Checks every setting: `Err((field, value, reason))`.
    pub fn check(&self) -> Result<(), (&'static str, f64, &'static str)> {
        if !(4..=32).contains(&self.patch_size) {
            return Err((
                "flow.patch_size",
                self.patch_size as f64,
                "must be in 4..=32",
            ));
        }
        if !(1..=self.patch_size).contains(&self.patch_stride) {
            return Err((
                "flow.patch_stride",
                self.patch_stride as f64,
                "must be in 1..=patch_size",
            ));
        }
        if self.descent_iterations > 100 {
            return Err((
                "flow.descent_iterations",
                self.descent_iterations as f64,
                "must be at most 100",
            ));
        }
        if self.refine_iterations > 50 || self.sor_iterations > 50 {
            return Err((
                "flow.refine_iterations",
                self.refine_iterations.max(self.sor_iterations) as f64,
                "refine_iterations and sor_iterations must be at most 50",
            ));
        }
        for (f, v) in [
            ("flow.alpha", self.alpha),
            ("flow.delta", self.delta),
            ("flow.gamma", self.gamma),
        ] {
            if !(v.is_finite() && (0.0..=1000.0).contains(&v)) {
                return Err((f, v as f64, "must be in [0, 1000]"));
            }
        }
        Ok(())
    }
}

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
    /// settings assume 0–255), written into `out`. Images smaller than a patch get zero flow.
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
        if w < ps || h < ps || i0.len() < w * h || i1.len() < w * h {
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
        let (mut sd, mut sdd, mut sgx, mut sgy) = (0f32, 0f32, 0f32, 0f32);
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
            if inside {
                let a = &i1.v[(by as usize + r) * i1.w + bx as usize..][..ps + 1];
                let b = &i1.v[(by as usize + r + 1) * i1.w + bx as usize..][..ps + 1];
                for c in 0..ps {
                    let s = w00 * a[c] + w01 * a[c + 1] + w10 * b[c] + w11 * b[c + 1];
                    let d = s - row0[c];
                    sd += d;
                    sdd += d * d;
                    sgx += grx[c] * d;
                    sgy += gry[c] * d;
                }
            } else {
                for c in 0..ps {
                    let s = i1.sample(px + c as f32, py + r as f32);
                    let d = s - row0[c];
                    sd += d;
                    sdd += d * d;
                    sgx += grx[c] * d;
                    sgy += gry[c] * d;
                }
            }
        }
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

/// The variational refinement's buffers (see [`Refiner::refine`]).
#[derive(Debug, Clone, Default)]
struct Refiner {
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
    fn refine(&mut self, cfg: &FlowConfig, i0: &Plane, i1: &Plane, u: &mut [f32], v: &mut [f32]) {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth random-looking texture (sum of sines), sampled at `(x + dx, y + dy)`.
    fn texture(w: usize, h: usize, dx: f32, dy: f32) -> Vec<f32> {
        let mut v = Vec::with_capacity(w * h);
        for y in 0..h {
            for x in 0..w {
                let (fx, fy) = (x as f32 + dx, y as f32 + dy);
                let t = (0.31 * fx).sin() * 40.0
                    + (0.17 * fy + 0.4).sin() * 35.0
                    + (0.23 * (fx + fy)).cos() * 25.0
                    + (0.11 * fx - 0.29 * fy).sin() * 30.0;
                v.push(128.0 + t);
            }
        }
        v
    }

    fn mean_error(f: &FlowField, u: f32, v: f32, margin: usize) -> f32 {
        let mut s = 0.0;
        let mut n = 0;
        for y in margin..f.height - margin {
            for x in margin..f.width - margin {
                let i = y * f.width + x;
                s += (f.u[i] - u).hypot(f.v[i] - v);
                n += 1;
            }
        }
        s / n as f32
    }

    #[test]
    fn a_translated_texture_gives_its_shift_everywhere() {
        let (w, h) = (160, 96);
        // i1 shows the scene moved by (+3.4, −1.7): a pixel of i0 is found at x + 3.4.
        let i0 = texture(w, h, 0.0, 0.0);
        let i1 = texture(w, h, -3.4, 1.7);
        let mut flow = DenseFlow::new(FlowConfig::default());
        let mut out = FlowField::default();
        flow.compute(&i0, &i1, w, h, &mut out);
        let e = mean_error(&out, 3.4, -1.7, 10);
        assert!(e < 0.15, "mean end-point error {e}");
    }

    #[test]
    fn a_moving_square_stands_out_of_a_still_background() {
        let (w, h) = (160, 96);
        let bg = texture(w, h, 0.0, 0.0);
        // A checkered square whose left edge is at `x0`; its pattern moves with it.
        let with_square = |x0: usize| {
            let mut img = bg.clone();
            for y in 30..60usize {
                for x in x0..x0 + 40 {
                    img[y * w + x] = 60.0 + 90.0 * ((((x - x0) / 4) + (y / 4)) % 2) as f32;
                }
            }
            img
        };
        // The square moved 4 px right from the previous frame to the current one.
        let (cur, prev) = (with_square(54), with_square(50));
        let mut flow = DenseFlow::new(FlowConfig::default());
        let mut out = FlowField::default();
        flow.compute(&cur, &prev, w, h, &mut out);
        // Inside the square (current frame) the flow points back 4 px; far from it, zero.
        let at = |x: usize, y: usize| (out.u[y * w + x], out.v[y * w + x]);
        let (u, v) = at(74, 45);
        assert!((u + 4.0).abs() < 0.5 && v.abs() < 0.5, "inside: ({u}, {v})");
        let (u, v) = at(20, 80);
        assert!(u.abs() < 0.3 && v.abs() < 0.3, "outside: ({u}, {v})");
    }

    #[test]
    fn tiny_or_flat_images_give_zero_flow_without_panicking() {
        let mut flow = DenseFlow::new(FlowConfig::default());
        let mut out = FlowField::default();
        flow.compute(&[1.0; 12], &[2.0; 12], 4, 3, &mut out);
        assert_eq!(out.u, vec![0.0; 12]);
        let flat = vec![100.0; 64 * 48];
        flow.compute(&flat, &flat, 64, 48, &mut out);
        assert!(out
            .u
            .iter()
            .chain(&out.v)
            .all(|x| x.is_finite() && x.abs() < 1e-3));
    }
}
