//! Box → mask refinement: a GrabCut-like colour + edge segmentation inside a detector's box.
//!
//! Per box:
//!
//! 1. **Working crop.** The box grown by a ring ([`RefineConfig::ring`]) is cut out of the frame
//!    and area-averaged down so that its longer side is at most [`RefineConfig::max_side`]
//!    pixels: the cost per box is bounded whatever the box size (at the default 80 px a crop has
//!    at most 6,400 pixels).
//! 2. **Colour models.** The ring outside the box is background (a hard constraint); the box
//!    is unknown. The models see each pixel's colour and a texture value (its mean luma step,
//!    [`RefineConfig::texture`]): foliage and fences come apart from smooth objects of their
//!    colour. The colour analyser's k-means ([`joint_palette`], one palette for the ring and
//!    the box, seeded, fitted on at most [`RefineConfig::palette_samples`] of the crop's
//!    pixels) labels every crop pixel with its nearest palette colour; each palette colour
//!    becomes one Gaussian of a background mixture (fitted on the ring's pixels of that
//!    colour) and of a foreground mixture (fitted on the box pixels, weighted towards the box
//!    centre, where the object most likely is).
//! 3. **Min-cut.** Unary costs are GrabCut's data term, each pixel's negative log-likelihood
//!    under the most likely Gaussian of each mixture, with a weak foreground bonus that falls
//!    off from the box centre; pairwise costs between 8-neighbours are GrabCut's
//!    contrast-sensitive `γ·exp(−β‖zᵢ − zⱼ‖²)/dist` (so the cut follows colour edges). The cut
//!    is [`FlowGraph`]'s (Boykov–Kolmogorov, written by hand: see ARCHITECTURE.md).
//! 4. **Iterate.** Each mixture is refitted on the pixels the cut gave it (each pixel to its most
//!    likely Gaussian), and the cut is solved again, [`RefineConfig::iterations`] times.
//! 5. **Clean-up and output.** Components much smaller than the largest are dropped (stray
//!    bits of background that happened to match the object's colours), and the crop's labels
//!    are upsampled bilinearly to the frame's pixels inside the box; within one working pixel
//!    of the cut the frame's own pixel colours, scored by the last colour models, decide
//!    ([`RefineConfig::boundary_prior`]), so the outline follows the object's edge at the
//!    frame's resolution rather than the working crop's.

mod box_refiner;
mod config;
mod mixture;

use super::components::{Components, Connectivity};
use super::gray::gray_row;
use super::maxflow::{FlowGraph, INFINITE};
use super::DetectError;
use crate::features::color::{joint_palette, ColorConfig, ColorSample};
use crate::frame::{BBox, Frame, Mask, PixelFormat, Point};

pub use box_refiner::BoxRefiner;
pub use config::RefineConfig;
use mixture::Mixture;

/// The working crop: the frame region `[x0, x0 + cw·scale) × [y0, y0 + ch·scale)` averaged
/// down by `scale`.
struct Crop {
    x0: f64,
    y0: f64,
    scale: f64,
    w: usize,
    h: usize,
    /// Per pixel the block's mean colour and its texture: `[r, g, b, t]`, `t` the block's
    /// mean absolute luma step between frame neighbours times [`RefineConfig::texture`].
    feat: Vec<[f32; 4]>,
    /// 0 = ring (hard background), 1 = inside the box.
    inside: Vec<bool>,
    /// Centre prior per pixel in `[0, 1]`: 0 at the centre, 1 at the box border.
    radial: Vec<f32>,
    /// Inside pixels the detector's [`Hint`] marks (empty without a hint).
    hinted: Vec<bool>,
}

/// Where a detector saw its object: a bitmap on a grid of `scale × scale`-pixel cells over the
/// frame (the moving-camera detector's working foreground of one blob, for instance). The
/// refinement then starts its colour models from it, the object's from the marked pixels
/// inside the box and the background's from the ring and the box's unmarked pixels, instead
/// of taking the whole box for the object at first (GrabCut started from a mask rather than
/// a rectangle). A detector's blob often holds ground it joined: the box around both is
/// loose, and a first model of the whole box learns that ground as object.
#[derive(Debug, Clone, Copy)]
pub struct Hint<'a> {
    /// One byte per cell, row-major, non-zero where the object is.
    pub bits: &'a [u8],
    /// Cells per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Frame pixels per cell side.
    pub scale: f64,
}

impl Hint<'_> {
    /// Whether the cell under frame point `(x, y)` is marked.
    fn at(&self, x: f64, y: f64) -> bool {
        if !(x >= 0.0 && y >= 0.0 && self.scale > 0.0) {
            return false;
        }
        let (cx, cy) = ((x / self.scale) as usize, (y / self.scale) as usize);
        cx < self.width
            && cy < self.height
            && self.bits.get(cy * self.width + cx).is_some_and(|&b| b != 0)
    }
}

fn make_crop(frame: &Frame, bbox: &BBox, cfg: &RefineConfig, hint: Option<&Hint>) -> Option<Crop> {
    let (fw, fh) = (frame.width() as f64, frame.height() as f64);
    let b = BBox::from_xyxy(
        bbox.x.max(0.0),
        bbox.y.max(0.0),
        bbox.x2().min(fw),
        bbox.y2().min(fh),
    );
    if !(b.w >= 2.0 && b.h >= 2.0) {
        return None;
    }
    let side = b.w.max(b.h);
    let scale0 = ((1.0 + 2.0 * cfg.ring) * side / cfg.max_side as f64).max(1.0);
    let ring = (cfg.ring * side).max(2.0 * scale0);
    let rx0 = (b.x - ring).max(0.0).floor();
    let ry0 = (b.y - ring).max(0.0).floor();
    let rx1 = (b.x2() + ring).min(fw).ceil();
    let ry1 = (b.y2() + ring).min(fh).ceil();
    let scale = ((rx1 - rx0).max(ry1 - ry0) / cfg.max_side as f64).max(1.0);
    let w = ((rx1 - rx0) / scale).floor().max(1.0) as usize;
    let h = ((ry1 - ry0) / scale).floor().max(1.0) as usize;
    let mut feat = vec![[0f32; 4]; w * h];
    let tex_scale = cfg.texture as f32;
    // Each frame pixel's luma enters the texture sum up to three times (its own difference
    // and as its left and upper neighbours' neighbour): computed once per call over the
    // region the cells and their right and lower neighbours cover, by the detectors' shared
    // grey conversion (`Frame::gray_at`'s expression), so the sums are what per-pixel calls
    // gave, bit for bit.
    let (lx0, ly0) = (rx0 as u32, ry0 as u32);
    let lx1 = (rx1 as u32 + 2).min(frame.width());
    let ly1 = (ry1 as u32 + 2).min(frame.height());
    let lw = lx1.saturating_sub(lx0) as usize;
    let (data, stride, ch) = (frame.data(), frame.stride(), frame.format().channels());
    let mut lumas = Vec::new();
    if tex_scale > 0.0 {
        lumas.resize(lw * ly1.saturating_sub(ly0) as usize, 0.0);
        for (y, out) in (ly0..ly1).zip(lumas.chunks_exact_mut(lw.max(1))) {
            let src = &data[y as usize * stride + lx0 as usize * ch..][..lw * ch];
            match frame.format() {
                PixelFormat::Rgb8 => gray_row::<3>(src, out),
                PixelFormat::Rgba8 => gray_row::<4>(src, out),
            }
        }
    }
    let luma = |x: u32, y: u32| lumas[(y - ly0) as usize * lw + (x - lx0) as usize];
    let mut inside = vec![false; w * h];
    let mut radial = vec![0f32; w * h];
    let mut hinted = if hint.is_some() {
        vec![false; w * h]
    } else {
        Vec::new()
    };
    let (cx, cy) = (b.x + b.w / 2.0, b.y + b.h / 2.0);
    for j in 0..h {
        let ya = ry0 + j as f64 * scale;
        let (py0, py1) = (ya as u32, ((ya + scale) as u32).max(ya as u32 + 1));
        for i in 0..w {
            let xa = rx0 + i as f64 * scale;
            let (px0, px1) = (xa as u32, ((xa + scale) as u32).max(xa as u32 + 1));
            let mut s = [0f32; 3];
            let mut n = 0f32;
            let mut t = 0f32;
            for y in py0..py1.min(frame.height()) {
                let row = &data[y as usize * stride..];
                for x in px0..px1.min(frame.width()) {
                    let c = &row[x as usize * ch..][..3];
                    s[0] += c[0] as f32;
                    s[1] += c[1] as f32;
                    s[2] += c[2] as f32;
                    n += 1.0;
                    if tex_scale > 0.0 {
                        let l = luma(x, y);
                        if x + 1 < frame.width() {
                            t += (luma(x + 1, y) - l).abs();
                        }
                        if y + 1 < frame.height() {
                            t += (luma(x, y + 1) - l).abs();
                        }
                    }
                }
            }
            let k = j * w + i;
            if n > 0.0 {
                feat[k] = [s[0] / n, s[1] / n, s[2] / n, tex_scale * t / n];
            }
            let (mx, my) = (xa + scale / 2.0, ya + scale / 2.0);
            inside[k] = mx >= b.x && mx < b.x2() && my >= b.y && my < b.y2();
            if let Some(hint) = hint {
                hinted[k] = inside[k] && hint.at(mx, my);
            }
            let (dx, dy) = ((mx - cx) / (b.w / 2.0), (my - cy) / (b.h / 2.0));
            radial[k] = (dx * dx + dy * dy).sqrt().min(1.5) as f32;
        }
    }
    Some(Crop {
        x0: rx0,
        y0: ry0,
        scale,
        w,
        h,
        feat,
        inside,
        radial,
        hinted,
    })
}

/// Fixed-point scale of the cut's capacities (costs are in log-likelihood units).
const CAP_SCALE: f64 = 256.0;

/// Refines `bbox` into a mask of `frame`'s object inside it. `Ok(None)` when the box has no
/// usable area inside the frame (under 2×2 pixels) or the segmentation found nothing.
pub fn refine_box(
    frame: &Frame,
    bbox: &BBox,
    cfg: &RefineConfig,
) -> Result<Option<Mask>, DetectError> {
    refine_box_hinted(frame, bbox, cfg, None)
}

/// [`refine_box`] with the detector's [`Hint`] of where in the box the object is (ignored
/// when it marks no pixel of the box).
pub fn refine_box_hinted(
    frame: &Frame,
    bbox: &BBox,
    cfg: &RefineConfig,
    hint: Option<Hint>,
) -> Result<Option<Mask>, DetectError> {
    cfg.validate()?;
    if !bbox.is_valid() {
        return Ok(None);
    }
    let Some(crop) = make_crop(frame, bbox, cfg, hint.as_ref()) else {
        return Ok(None);
    };
    let n = crop.w * crop.h;
    let has_ring = crop.inside.iter().any(|&v| !v);
    // Without a ring (a box as large as the frame) the box border stands in for it.
    let ring: Vec<bool> = if has_ring {
        crop.inside.iter().map(|&v| !v).collect()
    } else {
        (0..n)
            .map(|k| {
                let (i, j) = (k % crop.w, k / crop.w);
                i == 0 || j == 0 || i + 1 == crop.w || j + 1 == crop.h
            })
            .collect()
    };
    let unknown: Vec<bool> = ring.iter().map(|&r| !r).collect();
    if !unknown.iter().any(|&u| u) {
        return Ok(None);
    }

    // Step 2: one palette for ring and box, from the colour analyser's k-means.
    // An even stride through the crop keeps both the ring's and the box's share.
    let stride = match cfg.palette_samples {
        0 => 1,
        m => n.div_ceil(m).max(1),
    };
    let sample = |sel: &dyn Fn(usize) -> bool| -> Result<ColorSample, DetectError> {
        let mut pos = Vec::new();
        let mut rgb = Vec::new();
        for k in (0..n).filter(|&k| sel(k)) {
            pos.push(Point::new((k % crop.w) as f64, (k / crop.w) as f64));
            let c = crop.feat[k];
            rgb.push([c[0] as u8, c[1] as u8, c[2] as u8]);
        }
        ColorSample::new(pos, rgb, 1.0).map_err(color_err)
    };
    let sampled = |k: usize| k % stride == 0;
    let (bg_s, fg_s) = match (
        sample(&|k| ring[k] && sampled(k)),
        sample(&|k| unknown[k] && sampled(k)),
    ) {
        (Ok(a), Ok(b)) if !a.rgb.is_empty() && !b.rgb.is_empty() => (a, b),
        // A thin ring or box can miss the stride: fit on every pixel then.
        _ => (sample(&|k| ring[k])?, sample(&|k| unknown[k])?),
    };
    let pal = joint_palette(
        &bg_s,
        &fg_s,
        &ColorConfig {
            clusters: cfg.clusters,
            seed: cfg.seed,
            max_iterations: 20,
            tolerance: 1.0,
            ..ColorConfig::default()
        },
    )
    .map_err(color_err)?;
    let k = pal.centroids.len();
    let mut label = vec![0usize; n];
    if bg_s.rgb.len() + fg_s.rgb.len() == n {
        let (mut ia, mut ib) = (pal.labels_a.iter(), pal.labels_b.iter());
        for (p, l) in label.iter_mut().enumerate() {
            let src = if ring[p] { ia.next() } else { ib.next() };
            *l = src.copied().unwrap_or(0);
        }
    } else {
        for (l, c) in label.iter_mut().zip(&crop.feat) {
            *l = nearest(&pal.centroids, c);
        }
    }
    // Initial foreground: the box's pixels (or those the hint marks), weighted more near the
    // box centre.
    let mut is_fg: Vec<bool> = if crop.hinted.iter().any(|&v| v) {
        crop.hinted
            .iter()
            .zip(&unknown)
            .map(|(&h, &u)| h && u)
            .collect()
    } else {
        unknown.clone()
    };
    let fg_weight = |is_fg: &[bool]| -> Vec<f64> {
        (0..n)
            .map(|p| {
                if is_fg[p] {
                    (1.0 - cfg.centre_weight * crop.radial[p] as f64).max(0.05)
                } else {
                    0.0
                }
            })
            .collect::<Vec<f64>>()
    };

    // Pairwise weights (GrabCut's β from the mean squared neighbour difference).
    let offsets: [(isize, isize, f64); 4] = [
        (1, 0, 1.0),
        (0, 1, 1.0),
        (1, 1, std::f64::consts::SQRT_2),
        (-1, 1, std::f64::consts::SQRT_2),
    ];
    let d2 = |a: &[f32; 4], b: &[f32; 4]| -> f64 {
        (0..3)
            .map(|c| {
                let d = (a[c] - b[c]) as f64;
                d * d
            })
            .sum()
    };
    let mut sum = 0.0;
    let mut cnt = 0usize;
    // `(p, q, distance, squared colour difference)` per neighbour pair.
    let mut pairs: Vec<(u32, u32, f64, f64)> = Vec::with_capacity(4 * n);
    for j in 0..crop.h {
        for i in 0..crop.w {
            for &(dx, dy, dist) in &offsets {
                let (ni, nj) = (i as isize + dx, j as isize + dy);
                if ni < 0 || nj < 0 || ni >= crop.w as isize || nj >= crop.h as isize {
                    continue;
                }
                let (p, q) = (j * crop.w + i, nj as usize * crop.w + ni as usize);
                let v = d2(&crop.feat[p], &crop.feat[q]);
                sum += v;
                cnt += 1;
                pairs.push((p as u32, q as u32, dist, v));
            }
        }
    }
    let beta = if sum > 0.0 {
        cnt as f64 / (2.0 * sum)
    } else {
        0.0
    };
    // One graph for every round: the ring and the smoothness arcs do not change, and each
    // later round starts from the flow of the one before (only the pixels' costs change).
    let mut g = FlowGraph::new(n);
    for &(p, q, dist, v) in &pairs {
        let c = (cfg.smoothness * (-beta * v).exp() / dist * CAP_SCALE).round() as i32;
        if c > 0 {
            g.add_edge(p as usize, q as usize, c, c);
        }
    }
    for (p, _) in ring.iter().enumerate().filter(|(_, &r)| r) {
        g.add_terminals(p, 0, INFINITE);
    }

    let mut first = true;
    let mut best = vec![(0usize, 0usize); n];
    // The colour models whose cut was kept, for the full-resolution boundary.
    let mut models: Option<(Mixture, Mixture)> = None;
    for _ in 0..cfg.iterations {
        let wf = fg_weight(&is_fg);
        let wb: Vec<f64> = (0..n).map(|p| if is_fg[p] { 0.0 } else { 1.0 }).collect();
        // In the first round the box is all "foreground" (without a hint), so the background
        // model sees only the ring: the box's own background colours are learnt from the
        // ring's; with a hint it also sees the box's pixels the hint leaves out.
        let (Some(fgm), Some(bgm)) = (
            Mixture::fit(&crop.feat, &wf, &label, k.max(1)),
            Mixture::fit(&crop.feat, &wb, &label, k.max(1)),
        ) else {
            break;
        };
        for (p, &hard_bg) in ring.iter().enumerate() {
            if hard_bg {
                continue;
            }
            let (lf, dfg) = fgm.eval(&crop.feat[p]);
            let (lb, dbg) = bgm.eval(&crop.feat[p]);
            // Kept for the refit below: whichever side the cut gives the pixel.
            best[p] = (lf, lb);
            // A bonus for the foreground that is largest at the box centre and nil on its
            // border: detectors centre their boxes on the object.
            let prior = cfg.centre_prior * (crop.radial[p] as f64 - 1.0).min(0.0);
            let cost_fg = dfg + prior;
            let cost_bg = dbg;
            // Source side = foreground: a pixel pays `cost_bg` if cut to the sink side.
            let m = cost_fg.min(cost_bg);
            let (to_source, to_sink) = (
                ((cost_bg - m) * CAP_SCALE).min(1e8) as i32,
                ((cost_fg - m) * CAP_SCALE).min(1e8) as i32,
            );
            g.set_terminals(p, to_source, to_sink);
        }
        let side = g.recut();
        let changed = side.iter().zip(&is_fg).filter(|(a, b)| a != b).count();
        // A cut that empties the box means the models have drifted onto the background's
        // colours (tight boxes around objects coloured like their surroundings): keep the
        // last non-empty answer instead.
        if !first && !side.iter().any(|&v| v) {
            break;
        }
        is_fg = side;
        let stop = !first && changed == 0;
        first = false;
        // Refit: each pixel to the most likely Gaussian of its side's mixture (the ring's
        // pixels, always background, were not evaluated for the graph).
        for p in 0..n {
            label[p] = match (ring[p], is_fg[p]) {
                (true, _) => bgm.eval(&crop.feat[p]).0,
                (false, true) => best[p].0,
                (false, false) => best[p].1,
            };
        }
        models = Some((fgm, bgm));
        if stop {
            break;
        }
    }

    // Step 5: keep the large components.
    let bits: Vec<u8> = is_fg.iter().map(|&v| v as u8).collect();
    let mut comps = Components::new();
    let blobs = comps
        .label(&bits, crop.w as u32, crop.h as u32, Connectivity::Eight)?
        .to_vec();
    let Some(largest) = blobs.iter().map(|b| b.area).max() else {
        return Ok(None);
    };
    let mut keep = vec![0f32; n];
    for (i, b) in blobs.iter().enumerate() {
        if (b.area as f64) < cfg.keep_fraction * largest as f64 {
            continue;
        }
        for r in comps.runs(i) {
            let row = r.y as usize * crop.w;
            keep[row + r.x0 as usize..row + r.x1 as usize].fill(1.0);
        }
    }
    let colour = match &models {
        Some((f, b)) if cfg.boundary_prior >= 0.0 => Some(Boundary {
            fg: f,
            bg: b,
            prior: cfg.boundary_prior,
            centre_prior: cfg.centre_prior,
        }),
        _ => None,
    };
    Ok(upsample(&crop, &keep, frame, bbox, colour))
}

/// What decides the frame pixels near the cut at full resolution.
struct Boundary<'a> {
    fg: &'a Mixture,
    bg: &'a Mixture,
    prior: f64,
    centre_prior: f64,
}

/// Index of the palette colour nearest to `c` (squared RGB distance, first on ties), `c`
/// taken as the 8-bit colour the palette was fitted on.
fn nearest(centroids: &[[f64; 3]], c: &[f32; 4]) -> usize {
    let mut best = (0, f64::INFINITY);
    for (i, m) in centroids.iter().enumerate() {
        let d: f64 = (0..3).map(|a| (f64::from(c[a] as u8) - m[a]).powi(2)).sum();
        if d < best.1 {
            best = (i, d);
        }
    }
    best.0
}

/// The crop's labels as a frame mask inside `bbox`: bilinear, threshold ½, or with `colour`
/// the frame's own pixels decide near the cut (see [`RefineConfig::boundary_prior`]).
fn upsample(
    crop: &Crop,
    keep: &[f32],
    frame: &Frame,
    bbox: &BBox,
    colour: Option<Boundary>,
) -> Option<Mask> {
    let x0 = bbox.x.max(0.0).floor() as u32;
    let y0 = bbox.y.max(0.0).floor() as u32;
    let x1 = (bbox.x2().ceil().max(0.0) as u32).min(frame.width());
    let y1 = (bbox.y2().ceil().max(0.0) as u32).min(frame.height());
    if x1 <= x0 || y1 <= y0 {
        return None;
    }
    let (w, h) = ((x1 - x0) as usize, (y1 - y0) as usize);
    // Interpolation taps per column and per row, computed once: `(lower, upper, t)` with the
    // crop indices clamped to its edge.
    let taps = |n: usize, start: u32, origin: f64, len: usize| -> Vec<(usize, usize, f32)> {
        (0..n)
            .map(|k| {
                let f = ((start as usize + k) as f64 + 0.5 - origin) / crop.scale - 0.5;
                let i = f.floor() as isize;
                let c = |i: isize| i.clamp(0, len as isize - 1) as usize;
                (c(i), c(i + 1), (f - f.floor()) as f32)
            })
            .collect()
    };
    let cols = taps(w, x0, crop.x0, crop.w);
    let rows = taps(h, y0, crop.y0, crop.h);
    let mut data = vec![0u8; w * h];
    let (cx, cy) = (bbox.x + bbox.w / 2.0, bbox.y + bbox.h / 2.0);
    for (y, &(ja, jb, ty)) in rows.iter().enumerate() {
        let (ra, rb) = (
            &keep[ja * crop.w..][..crop.w],
            &keep[jb * crop.w..][..crop.w],
        );
        for (x, &(ia, ib, tx)) in cols.iter().enumerate() {
            let (a, b, c, d) = (ra[ia], ra[ib], rb[ia], rb[ib]);
            // Away from the cut all four taps agree: no arithmetic needed.
            if a == b && a == c && a == d && (a == 0.0 || a == 1.0) {
                data[y * w + x] = (a == 1.0) as u8;
                continue;
            }
            let v = (1.0 - ty) * ((1.0 - tx) * a + tx * b) + ty * ((1.0 - tx) * c + tx * d);
            let on = match &colour {
                Some(m) if v > 0.0 && v < 1.0 => {
                    let (px, py) = (x0 + x as u32, y0 + y as u32);
                    match frame.rgb_at(px, py) {
                        Some(rgb) => {
                            // The texture value is a working pixel's (a frame pixel has
                            // none of its own): the nearest tap's.
                            let (j, i) = (
                                if ty < 0.5 { ja } else { jb },
                                if tx < 0.5 { ia } else { ib },
                            );
                            let cell = crop.feat[j * crop.w + i][3];
                            let z = [rgb[0] as f32, rgb[1] as f32, rgb[2] as f32, cell];
                            let (dx, dy) = (
                                (px as f64 + 0.5 - cx) / (bbox.w / 2.0),
                                (py as f64 + 0.5 - cy) / (bbox.h / 2.0),
                            );
                            let radial = (dx * dx + dy * dy).sqrt().min(1.5);
                            let cost_fg =
                                m.fg.eval(&z).1 + m.centre_prior * (radial - 1.0).min(0.0);
                            let cost_bg = m.bg.eval(&z).1;
                            cost_bg - cost_fg + m.prior * (2.0 * v as f64 - 1.0) > 0.0
                        }
                        None => v >= 0.5,
                    }
                }
                _ => v >= 0.5,
            };
            data[y * w + x] = on as u8;
        }
    }
    let m = Mask::new(x0 as i32, y0 as i32, w as u32, h as u32, data)
        .ok()?
        .tight();
    (!m.is_empty()).then_some(m)
}

fn color_err(e: crate::features::color::ColorError) -> DetectError {
    DetectError::Refine {
        reason: e.to_string(),
    }
}

#[cfg(test)]
#[path = "refine_tests.rs"]
mod tests;
