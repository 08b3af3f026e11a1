//! The adaptive background subtractor of thesis §3.2.1 (eq. 1–2).
//!
//! Per frame `Z_t` (grey, BT.601 as [`Frame::gray_at`]):
//!
//! 1. **Initialisation (eq. 1).** For the first `init_frames` frames the model accumulates the
//!    grey frames; after the last one `B` is their mean. Those frames return no detection.
//! 2. **Foreground.** A pixel is foreground when `|Z_t − B_{t−1}| > threshold`. With
//!    [`ShadowConfig`] set, a foreground pixel that is a darker copy of the background
//!    (brightness ratio within `[min_ratio, max_ratio]` and normalised chromaticity within
//!    `max_chroma` of the background's) is a cast shadow and turned back into background.
//! 3. **Update (eq. 2).** `B_t = (1 − a)·B_{t−1} + a·Z_t`. With [`UpdatePolicy::All`] every
//!    pixel uses `a = alpha`, as the thesis writes it: objects leak into the model while they
//!    cover a pixel and leave trails behind them (measured on synthetic scenes with slow
//!    objects: 61–67% of isolated objects reach mask IoU 0.8, against 97–100% with the
//!    default; `tests/detect_background.rs`). With
//!    [`UpdatePolicy::Selective`] (the default, `foreground_alpha = 0`) foreground pixels do not
//!    learn, so moving objects never leak in; what must still fade out (ghosts of objects that
//!    stood in the initial frames, objects that stopped) is handled by `absorb_frames`: a pixel
//!    that stays foreground and unchanged (`|Z_t − Z_{t−1}| ≤ threshold/2`) for that many frames
//!    learns at `alpha` like background.
//! 4. **Clean-up.** Opening (removes specks) then closing (fills pinholes), square elements.
//! 5. **Blobs.** Connected components ([`Components`]); blobs smaller than `min_area` are
//!    dropped; each remaining one becomes a [`Detection`] with its mask, tight box and a score:
//!    the blob's mean `|Z − B|` over `4·threshold`, capped at 1 (so a blob at twice the
//!    threshold scores 0.5).
//!
//! Buffers are kept between frames; after the first frame a call allocates only the output.

use super::components::{Components, Connectivity};
use super::gray::{gray, gray_row};
use super::morphology::Morphology;
use super::{DetectError, Detector};
use crate::frame::{Detection, Frame, PixelFormat};
use serde::{Deserialize, Serialize};

/// How the background model learns (eq. 2).
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify))]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum UpdatePolicy {
    /// Every pixel at rate `alpha` (the thesis' eq. 2 as written).
    All,
    /// Background pixels at `alpha`, foreground pixels at `foreground_alpha`.
    Selective {
        /// Learning rate of pixels currently classified as foreground.
        foreground_alpha: f32,
    },
}

/// Cast-shadow suppression: shadows darken the background without changing its chromaticity.
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ShadowConfig {
    /// Smallest `Z/B` brightness ratio still taken as shadow. Default `0.4`.
    pub min_ratio: f32,
    /// Largest `Z/B` brightness ratio taken as shadow (below 1: shadows darken). Default `0.9`.
    pub max_ratio: f32,
    /// Largest L1 distance between the pixel's and the background's normalised `(r, g)`
    /// chromaticity (`r/(r+g+b)`, `g/(r+g+b)`). Default `0.04`.
    pub max_chroma: f32,
}

impl Default for ShadowConfig {
    fn default() -> Self {
        Self {
            min_ratio: 0.4,
            max_ratio: 0.9,
            max_chroma: 0.04,
        }
    }
}

/// Settings of the [`BackgroundSubtractor`].
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BackgroundConfig {
    /// Frames averaged into the initial background (eq. 1, `n`). Default `20`.
    pub init_frames: u32,
    /// Learning rate `α` of eq. 2, in `(0, 1]`. Default `0.05`.
    pub alpha: f32,
    /// Which pixels learn at which rate. Default `Selective { foreground_alpha: 0.0 }`: foreground
    /// pixels learn only through `absorb_frames`.
    pub update: UpdatePolicy,
    /// Grey-level difference above which a pixel is foreground. Default `20`.
    pub threshold: f32,
    /// A pixel that stays foreground *and* unchanged (`|Z_t − Z_{t−1}| ≤ threshold/2`) for this
    /// many consecutive frames is learnt at `alpha`, like background (0 = never). Such pixels
    /// are ghosts of the initial mean, background uncovered by an object that had leaked into
    /// the model, or objects that stopped: all fade into the background. Moving objects change
    /// their pixels and are not affected (except inside large flat-coloured regions of slow
    /// objects). At most 255. Default `20`.
    pub absorb_frames: u32,
    /// Shadow suppression (needs a colour model: 3 more planes). Default `None`.
    pub shadow: Option<ShadowConfig>,
    /// Radius of the opening's square (0 = none). Default `1` (3×3).
    pub open_radius: u32,
    /// Radius of the closing's square (0 = none). Default `1` (3×3).
    pub close_radius: u32,
    /// Blobs with fewer pixels are dropped. Default `50`.
    pub min_area: u64,
    /// Pixel connectivity of blobs. Default 8.
    pub connectivity: Connectivity,
}

impl Default for BackgroundConfig {
    fn default() -> Self {
        Self {
            init_frames: 20,
            alpha: 0.05,
            update: UpdatePolicy::Selective {
                foreground_alpha: 0.0,
            },
            threshold: 20.0,
            absorb_frames: 20,
            shadow: None,
            open_radius: 1,
            close_radius: 1,
            min_area: 50,
            connectivity: Connectivity::Eight,
        }
    }
}

impl BackgroundConfig {
    /// Checks every setting.
    pub fn validate(&self) -> Result<(), DetectError> {
        let bad = |field: &'static str, value: f64, reason: &'static str| {
            Err(DetectError::InvalidConfig {
                field,
                value,
                reason,
            })
        };
        let unit = |v: f32| v.is_finite() && v > 0.0 && v <= 1.0;
        if self.init_frames == 0 {
            return bad("init_frames", 0.0, "must be at least 1");
        }
        if !unit(self.alpha) {
            return bad("alpha", self.alpha as f64, "must be in (0, 1]");
        }
        if let UpdatePolicy::Selective { foreground_alpha } = self.update {
            if !(foreground_alpha.is_finite() && (0.0..=1.0).contains(&foreground_alpha)) {
                return bad(
                    "update.foreground_alpha",
                    foreground_alpha as f64,
                    "must be in [0, 1]",
                );
            }
        }
        if !(self.threshold.is_finite() && (0.0..255.0).contains(&self.threshold)) {
            return bad("threshold", self.threshold as f64, "must be in [0, 255)");
        }
        if self.absorb_frames > 255 {
            return bad(
                "absorb_frames",
                self.absorb_frames as f64,
                "must be at most 255",
            );
        }
        if let Some(s) = self.shadow {
            if !(s.min_ratio.is_finite()
                && s.max_ratio.is_finite()
                && 0.0 <= s.min_ratio
                && s.min_ratio <= s.max_ratio
                && s.max_ratio <= 1.0)
            {
                return bad(
                    "shadow.min_ratio",
                    s.min_ratio as f64,
                    "need 0 <= min_ratio <= max_ratio <= 1",
                );
            }
            if !(s.max_chroma.is_finite() && s.max_chroma >= 0.0) {
                return bad("shadow.max_chroma", s.max_chroma as f64, "must be >= 0");
            }
        }
        if self.open_radius > 32 {
            return bad("open_radius", self.open_radius as f64, "must be at most 32");
        }
        if self.close_radius > 32 {
            return bad(
                "close_radius",
                self.close_radius as f64,
                "must be at most 32",
            );
        }
        Ok(())
    }
}

/// The thesis' adaptive background subtractor; see the module docs for the exact steps.
#[derive(Debug, Clone)]
pub struct BackgroundSubtractor {
    cfg: BackgroundConfig,
    size: Option<(u32, u32)>,
    seen: u32,
    /// Grey background model (running sums during initialisation).
    bg: Vec<f32>,
    /// RGB background model, interleaved, only with shadow suppression.
    bg_rgb: Vec<f32>,
    /// Grey level of the previous frame.
    prev: Vec<f32>,
    /// Consecutive frames each pixel has been foreground and unchanged (saturating).
    still: Vec<u8>,
    /// `min(|Z − B|, 255)` of the last frame.
    diff: Vec<u8>,
    /// Foreground of the last frame (0/1), after clean-up.
    fg: Vec<u8>,
    morph: Morphology,
    comps: Components,
}

impl BackgroundSubtractor {
    /// A subtractor with validated settings; buffers are sized on the first frame.
    pub fn new(cfg: BackgroundConfig) -> Result<Self, DetectError> {
        cfg.validate()?;
        Ok(Self {
            cfg,
            size: None,
            seen: 0,
            bg: Vec::new(),
            bg_rgb: Vec::new(),
            prev: Vec::new(),
            still: Vec::new(),
            diff: Vec::new(),
            fg: Vec::new(),
            morph: Morphology::new(),
            comps: Components::new(),
        })
    }

    /// The settings.
    pub fn config(&self) -> &BackgroundConfig {
        &self.cfg
    }

    /// Whether the initial background is complete (detections start with the next frame).
    pub fn is_ready(&self) -> bool {
        self.size.is_some() && self.seen >= self.cfg.init_frames
    }

    /// Frames of the initial background learnt so far, and how many it takes (`init_frames`):
    /// a front end shows "learning the background" until they are equal.
    pub fn warmup(&self) -> (u32, u32) {
        let seen = if self.size.is_some() { self.seen } else { 0 };
        (seen.min(self.cfg.init_frames), self.cfg.init_frames)
    }

    /// Forgets the model and the frame size: the next frame starts a new initialisation.
    pub fn reset(&mut self) {
        self.size = None;
        self.seen = 0;
    }

    /// The grey background model, `width·height` values, once initialised.
    pub fn background(&self) -> Option<&[f32]> {
        self.is_ready().then_some(&self.bg[..])
    }

    /// The cleaned foreground bitmap (0/1, `width·height`) of the last detecting frame.
    pub fn foreground(&self) -> &[u8] {
        &self.fg
    }

    /// Uses `frame` as the whole initial background (a clean plate: an empty view of the
    /// scene), skipping the averaging of eq. 1. Fixes the frame size.
    pub fn set_background(&mut self, frame: &Frame) -> Result<(), DetectError> {
        self.reset();
        self.prepare(frame)?;
        let shadow = self.cfg.shadow.is_some();
        visit(frame, |i, z, rgb| {
            self.bg[i] = z;
            self.prev[i] = z;
            if shadow {
                self.bg_rgb[3 * i..3 * i + 3].copy_from_slice(&rgb);
            }
        });
        self.seen = self.cfg.init_frames;
        Ok(())
    }

    /// Checks the frame size and (re)allocates the model on the first frame.
    fn prepare(&mut self, frame: &Frame) -> Result<(), DetectError> {
        let (w, h) = (frame.width(), frame.height());
        match self.size {
            Some((ew, eh)) if (ew, eh) != (w, h) => Err(DetectError::SizeChanged {
                expected_width: ew,
                expected_height: eh,
                width: w,
                height: h,
            }),
            Some(_) => Ok(()),
            None => {
                let n = w as usize * h as usize;
                self.size = Some((w, h));
                self.seen = 0;
                self.bg.clear();
                self.bg.resize(n, 0.0);
                self.bg_rgb.clear();
                if self.cfg.shadow.is_some() {
                    self.bg_rgb.resize(3 * n, 0.0);
                }
                self.prev.clear();
                self.prev.resize(n, 0.0);
                self.still.clear();
                self.still.resize(n, 0);
                self.diff.clear();
                self.diff.resize(n, 0);
                self.fg.clear();
                self.fg.resize(n, 0);
                Ok(())
            }
        }
    }

    /// Eq. 1: accumulate, and turn the sums into the mean on the last initial frame.
    fn accumulate(&mut self, frame: &Frame) {
        let shadow = self.cfg.shadow.is_some();
        let (bg, bg_rgb, prev) = (&mut self.bg, &mut self.bg_rgb, &mut self.prev);
        visit(frame, |i, z, rgb| {
            bg[i] += z;
            prev[i] = z;
            if shadow {
                for c in 0..3 {
                    bg_rgb[3 * i + c] += rgb[c];
                }
            }
        });
        self.seen += 1;
        if self.seen == self.cfg.init_frames {
            let k = 1.0 / self.cfg.init_frames as f32;
            self.bg.iter_mut().for_each(|v| *v *= k);
            self.bg_rgb.iter_mut().for_each(|v| *v *= k);
        }
    }

    /// Steps 2–3: classify against `B_{t−1}` and update the model, in one pass.
    fn classify_and_update(&mut self, frame: &Frame) {
        let (a_bg, a_fg) = match self.cfg.update {
            UpdatePolicy::All => (self.cfg.alpha, self.cfg.alpha),
            UpdatePolicy::Selective { foreground_alpha } => (self.cfg.alpha, foreground_alpha),
        };
        let rule = Rule {
            t: self.cfg.threshold,
            t_still: self.cfg.threshold / 2.0,
            absorb: if self.cfg.absorb_frames == 0 {
                u8::MAX as u16 + 1
            } else {
                self.cfg.absorb_frames as u16
            },
            a_bg,
            a_fg,
        };
        let st = State {
            bg: &mut self.bg,
            prev: &mut self.prev,
            still: &mut self.still,
            diff: &mut self.diff,
            fg: &mut self.fg,
        };
        match self.cfg.shadow {
            None => classify_rows(frame, st, rule),
            Some(s) => {
                let bg_rgb = &mut self.bg_rgb;
                let State {
                    bg,
                    prev,
                    still,
                    diff,
                    fg,
                } = st;
                visit(frame, |i, z, rgb| {
                    let b = bg[i];
                    let d = (z - b).abs();
                    let mut f = d > rule.t;
                    let br = &mut bg_rgb[3 * i..3 * i + 3];
                    if f && z < b {
                        let ratio = z / b.max(1e-3);
                        let (sz, sb) = (rgb[0] + rgb[1] + rgb[2], br[0] + br[1] + br[2]);
                        if ratio >= s.min_ratio && ratio <= s.max_ratio && sz > 0.0 && sb > 0.0 {
                            let chroma =
                                (rgb[0] / sz - br[0] / sb).abs() + (rgb[1] / sz - br[1] / sb).abs();
                            f = chroma > s.max_chroma;
                        }
                    }
                    let (a, n) = rule.rate(f, z, prev[i], still[i]);
                    still[i] = n;
                    prev[i] = z;
                    bg[i] = b + a * (z - b);
                    for c in 0..3 {
                        br[c] += a * (rgb[c] - br[c]);
                    }
                    diff[i] = d.min(255.0) as u8;
                    fg[i] = f as u8;
                });
            }
        }
    }
}

/// The per-pixel model buffers.
struct State<'a> {
    bg: &'a mut [f32],
    prev: &'a mut [f32],
    still: &'a mut [u8],
    diff: &'a mut [u8],
    fg: &'a mut [u8],
}

/// The per-pixel decision constants.
#[derive(Clone, Copy)]
struct Rule {
    t: f32,
    t_still: f32,
    absorb: u16,
    a_bg: f32,
    a_fg: f32,
}

impl Rule {
    /// Learning rate of a pixel and its new stillness count.
    #[inline(always)]
    fn rate(&self, is_fg: bool, z: f32, prev: f32, still: u8) -> (f32, u8) {
        // Non-short-circuit `&`/`|` and selects only: the loop stays branch-free and vectorises.
        let steady = (z - prev).abs() <= self.t_still;
        let n = if is_fg & steady {
            still.saturating_add(1)
        } else {
            0
        };
        let learn = !is_fg | (n as u16 >= self.absorb);
        (if learn { self.a_bg } else { self.a_fg }, n)
    }
}

/// Calls `f(pixel index, grey, [r, g, b])` for every pixel, row by row.
fn visit(frame: &Frame, mut f: impl FnMut(usize, f32, [f32; 3])) {
    let (w, h) = (frame.width() as usize, frame.height() as usize);
    let c = frame.format().channels();
    let data = frame.data();
    for y in 0..h {
        let row = &data[y * frame.stride()..y * frame.stride() + w * c];
        for (x, p) in row.chunks_exact(c).enumerate() {
            let rgb = [p[0] as f32, p[1] as f32, p[2] as f32];
            f(y * w + x, gray(p[0], p[1], p[2]), rgb);
        }
    }
}

/// Steps 2–3 for one row of grey levels `z` and the row's model buffers.
#[inline(always)]
fn update_row(z: &[f32], st: State, rule: Rule) {
    #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
    let (done, st) = {
        let mut st = st;
        (update_row_simd(z, &mut st, rule), st)
    };
    #[cfg(not(all(target_arch = "wasm32", target_feature = "simd128")))]
    let done = 0;
    let State {
        bg,
        prev,
        still,
        diff,
        fg,
    } = st;
    // The rest from `done` on (at most every length), as plain slices: a `skip` on the zipped
    // iterators could keep the native build's loop from vectorising.
    for (((((&z, b), pv), n), d), f) in z
        .get(done..)
        .unwrap_or_default()
        .iter()
        .zip(bg.get_mut(done..).unwrap_or_default())
        .zip(prev.get_mut(done..).unwrap_or_default())
        .zip(still.get_mut(done..).unwrap_or_default())
        .zip(diff.get_mut(done..).unwrap_or_default())
        .zip(fg.get_mut(done..).unwrap_or_default())
    {
        let dz = z - *b;
        let ad = dz.abs();
        let is_fg = ad > rule.t;
        let (a, cnt) = rule.rate(is_fg, z, *pv, *n);
        *n = cnt;
        *pv = z;
        *b += a * dz;
        *d = ad.min(255.0) as u8;
        *f = is_fg as u8;
    }
}

/// [`update_row`]'s pixels four at a time with wasm SIMD; returns how many it did (the row's
/// length rounded down to a multiple of 4; the caller does the rest). LLVM left the scalar
/// loop unvectorised in wasm (its mix of f32 and u8 buffers): with the grey conversion inlined
/// beside it, 78 % of a 1080p frame's detection samples in Node (the conversion ~1 ms of ~12). The same f32 operations in the same order as the scalar loop (wasm
/// SIMD has no fused multiply-add; no value is NaN: grey levels and the model are finite), and
/// `min(|dz|, 255)` truncated as `as u8` truncates, so every buffer gets the scalar loop's
/// values to the bit (`tests/detect_simd.rs` checks the model, the foreground and the
/// detections against the native build's digest).
#[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
fn update_row_simd(z: &[f32], st: &mut State, rule: Rule) -> usize {
    use core::arch::wasm32::{
        f32x4_abs, f32x4_add, f32x4_gt, f32x4_le, f32x4_min, f32x4_mul, f32x4_splat, f32x4_sub,
        i16x8_narrow_i32x4, i32x4_add, i32x4_splat, i32x4_trunc_sat_f32x4, u16x8_extend_low_u8x16,
        u32x4_extend_low_u16x8, u32x4_ge, u32x4_min, u8x16_narrow_i16x8, v128, v128_and,
        v128_bitselect, v128_load, v128_load32_zero, v128_not, v128_or, v128_store,
        v128_store32_lane,
    };
    let n = [
        z.len(),
        st.bg.len(),
        st.prev.len(),
        st.still.len(),
        st.diff.len(),
        st.fg.len(),
    ]
    .into_iter()
    .min()
    .unwrap_or(0)
        / 4
        * 4;
    let (t, t_still) = (f32x4_splat(rule.t), f32x4_splat(rule.t_still));
    let (a_bg, a_fg) = (f32x4_splat(rule.a_bg), f32x4_splat(rule.a_fg));
    let (one, max_count) = (i32x4_splat(1), i32x4_splat(255));
    let absorb = i32x4_splat(i32::from(rule.absorb));
    let cap = f32x4_splat(255.0);
    // Four i32 lanes (each 0..=255) as four bytes.
    let bytes = |v: v128| {
        let h = i16x8_narrow_i32x4(v, v);
        u8x16_narrow_i16x8(h, h)
    };
    let (zp, bp, pp) = (z.as_ptr(), st.bg.as_mut_ptr(), st.prev.as_mut_ptr());
    let (sp, dp, fp) = (
        st.still.as_mut_ptr(),
        st.diff.as_mut_ptr(),
        st.fg.as_mut_ptr(),
    );
    let mut i = 0;
    while i < n {
        // SAFETY: `i + 4 <= n`, and `n` is at most every buffer's length, so each load and
        // store stays inside its slice (unaligned access is allowed by wasm). The written
        // pointers come from `st`'s `&mut` slices, which nothing else can see during the call;
        // `z` is only read.
        unsafe {
            let zv = v128_load(zp.add(i) as *const v128);
            let bv = v128_load(bp.add(i) as *const v128);
            let pv = v128_load(pp.add(i) as *const v128);
            let sv = u32x4_extend_low_u16x8(u16x8_extend_low_u8x16(v128_load32_zero(
                sp.add(i) as *const u32
            )));
            let dz = f32x4_sub(zv, bv);
            let ad = f32x4_abs(dz);
            let is_fg = f32x4_gt(ad, t);
            let steady = f32x4_le(f32x4_abs(f32x4_sub(zv, pv)), t_still);
            let count = v128_and(
                u32x4_min(i32x4_add(sv, one), max_count),
                v128_and(is_fg, steady),
            );
            let learn = v128_or(v128_not(is_fg), u32x4_ge(count, absorb));
            let a = v128_bitselect(a_bg, a_fg, learn);
            v128_store(bp.add(i) as *mut v128, f32x4_add(bv, f32x4_mul(a, dz)));
            v128_store(pp.add(i) as *mut v128, zv);
            v128_store32_lane::<0>(bytes(count), sp.add(i) as *mut u32);
            let d = i32x4_trunc_sat_f32x4(f32x4_min(ad, cap));
            v128_store32_lane::<0>(bytes(d), dp.add(i) as *mut u32);
            v128_store32_lane::<0>(bytes(v128_and(is_fg, one)), fp.add(i) as *mut u32);
        }
        i += 4;
    }
    n
}

/// The hot loop without shadows, monomorphised per channel count so it vectorises.
fn classify_rows(frame: &Frame, st: State, rule: Rule) {
    fn rows<const C: usize>(frame: &Frame, st: State, rule: Rule) {
        let (w, h) = (frame.width() as usize, frame.height() as usize);
        let data = frame.data();
        let mut zrow = vec![0f32; w];
        for y in 0..h {
            let src = &data[y * frame.stride()..y * frame.stride() + w * C];
            let o = y * w..(y + 1) * w;
            // Two passes per row: the de-interleaving grey conversion, then the model update
            // on plain arrays, which vectorises where the fused loop did not.
            gray_row::<C>(src, &mut zrow);
            let row = State {
                bg: &mut st.bg[o.clone()],
                prev: &mut st.prev[o.clone()],
                still: &mut st.still[o.clone()],
                diff: &mut st.diff[o.clone()],
                fg: &mut st.fg[o],
            };
            update_row(&zrow, row, rule);
        }
    }
    match frame.format() {
        PixelFormat::Rgb8 => rows::<3>(frame, st, rule),
        PixelFormat::Rgba8 => rows::<4>(frame, st, rule),
    }
}

impl Detector for BackgroundSubtractor {
    fn detect(&mut self, frame: &Frame) -> Result<Vec<Detection>, DetectError> {
        self.prepare(frame)?;
        if self.seen < self.cfg.init_frames {
            self.accumulate(frame);
            return Ok(Vec::new());
        }
        let (w, h) = (frame.width(), frame.height());
        self.classify_and_update(frame);
        let (wu, hu) = (w as usize, h as usize);
        self.morph.open(&mut self.fg, wu, hu, self.cfg.open_radius);
        self.morph
            .close(&mut self.fg, wu, hu, self.cfg.close_radius);
        let n = self
            .comps
            .label(&self.fg, w, h, self.cfg.connectivity)?
            .len();
        let mut out = Vec::new();
        for i in 0..n {
            let blob = self.comps.blobs()[i];
            if blob.area < self.cfg.min_area {
                continue;
            }
            let mut sum = 0u64;
            for r in self.comps.runs(i) {
                let row = r.y as usize * wu;
                sum += self.diff[row + r.x0 as usize..row + r.x1 as usize]
                    .iter()
                    .map(|&v| v as u64)
                    .sum::<u64>();
            }
            let mean = sum as f64 / blob.area as f64;
            let score = (mean / (4.0 * self.cfg.threshold.max(1.0) as f64)).clamp(1e-3, 1.0);
            if let Some(mask) = self.comps.mask(i) {
                out.push(Detection::from_mask(mask, score));
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
#[path = "background_tests.rs"]
mod tests;
