//! Spatial colour analyser and the colour cost C2 (thesis ch. 4.4, Alg. 6).
//!
//! 1. **Sampling** ([`ColorSample::from_mask`]): the RGB of a shape's pixels on a **uniform
//!    grid** over its mask, with a spacing chosen so that at most
//!    [`ColorConfig::max_samples`] pixels are kept (every pixel when the mask is small enough).
//!    A grid rather than a random subsample because the cost compares *locations*: a grid
//!    covers the shape evenly, so every point of A lies within `spacing·√2/2` of an A sample
//!    and an aligned B sample always finds its counterpart, whereas random subsamples leave
//!    holes (read as false non-overlap) and clumps. A grid also needs no seed and gives the
//!    same samples every time.
//! 2. **One shared palette** ([`joint_palette`]): k-means++ (linfa-clustering, `K = 10`,
//!    seeded [`Xoshiro256Plus`], bounded iterations) on the RGB of *both* shapes together, so
//!    that a colour gets the same label in both — the thesis' fix for repeatability.
//! 3. **Alignment**: B's sample positions are mapped into A's frame by the transform from the
//!    shape context fit, or, without one, by moving B's sample centroid onto A's.
//! 4. **C2** ([`color_cost`]): for every aligned B sample, A's sample nearest to it (within
//!    [`ColorConfig::overlap_radius`] × A's spacing) gives A's label at that place; C2 is the
//!    fraction of such overlapping samples whose palette colours differ (Alg. 6 steps 6–7:
//!    "non-zero magnitude" of the difference of the reconstructed colours — here: more than
//!    [`ColorConfig::color_tolerance`] apart), in `[0, 1]`.
//!    [`ColorMatch::overlap`] says which fraction of B landed on A at all: a low overlap means
//!    C2 rests on few samples.
//!
//! For re-identifying a lost track there is no alignment; [`palette_distance`] compares the two
//! shapes' label histograms over the shared palette (Hellinger distance) instead.
//!
//! **Per-view palettes** ([`view_palette`], [`color_cost_per_view`]): the same C2 with each
//! shape's own k-means palette, computed once per shape instead of once per compared pair;
//! two samples differ when their palettes' colours are more than `color_tolerance` apart,
//! the rule [`Palette::differ`] applies within one joint palette. What the joint palette buys
//! is repeatability (one colour, one label in both shapes); with the tolerance, two views'
//! palettes of the same colours agree as long as their centroids for a colour stay within it,
//! which they do for whole views of one shape, and not always for a sliver against a whole
//! view (see the tracker's use).
//!
//! k-means cost: `n_runs` k-means++ restarts (linfa's default is 10, ours 1) of up to
//! `max_iterations` Lloyd steps over `|A| + |B|` points; with 1500 + 1500 samples and `K = 10`
//! this is a few milliseconds per pair (see `benches/descriptors.rs`). One run is computed
//! here, step for step as linfa computes it (`plus_plus_seeds`, `lloyd`: the same centroids
//! and labels, without linfa's per-step rayon and `ndarray` overheads); several runs go
//! through linfa itself.

mod compare;
mod foreign;
mod palette;
#[cfg(test)]
mod tests;

pub use compare::{color_cost, color_cost_per_view, palette_distance, ColorAlignment, ColorMatch};
pub use foreign::{foreign_share, foreign_share_at_least, foreign_share_at_least_in, ViewReach};
pub use palette::{joint_palette, view_palette, Palette, ViewPalette};

use super::transform::CellIndex;
use crate::frame::{Frame, Mask, Point};
use serde::{Deserialize, Serialize};
use thiserror::Error;

#[cfg(doc)]
use rand_xoshiro::Xoshiro256Plus;

/// Errors from colour sampling and comparison.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ColorError {
    /// A shape has no colour sample (empty mask, or mask outside the frame).
    #[error("the {which} shape has no colour samples")]
    EmptySample {
        /// `"A"` or `"B"`.
        which: &'static str,
    },
    /// Positions and colours differ in length.
    #[error("{positions} positions but {rgb} colours")]
    LengthMismatch {
        /// Positions given.
        positions: usize,
        /// Colours given.
        rgb: usize,
    },
    /// A position or the spacing is NaN or infinite (or the spacing is not positive).
    #[error("sample {index} has a non-finite position")]
    NonFinite {
        /// Index of the offending sample (`usize::MAX` for the spacing).
        index: usize,
    },
    /// A configuration value is out of range.
    #[error("invalid configuration: {field} {reason}")]
    InvalidConfig {
        /// The field.
        field: &'static str,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// linfa's k-means failed.
    #[error("k-means failed: {reason}")]
    KMeans {
        /// linfa's message.
        reason: String,
    },
}

/// Settings of the colour analyser. `Default` gives the documented values.
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ColorConfig {
    /// Palette size K (default 10, as the thesis).
    pub clusters: usize,
    /// Lloyd iterations cap per k-means run (default 30).
    pub max_iterations: u64,
    /// Convergence threshold: total centroid movement between iterations, RGB units
    /// (default 0.5, i.e. below one grey level).
    pub tolerance: f64,
    /// k-means++ restarts, best inertia kept (default 1: the palette only needs to be shared,
    /// not optimal, and each restart costs a full run).
    pub n_runs: usize,
    /// Seed of the k-means RNG.
    pub seed: u64,
    /// Most samples [`ColorSample::from_mask`] keeps per shape (default 1500).
    pub max_samples: usize,
    /// Radius, in units of A's sample spacing, within which an aligned B sample finds A's
    /// label (default 1.0: interior points are always within `√2/2` of a grid sample, and one
    /// spacing tolerates a little misalignment at the border).
    pub overlap_radius: f64,
    /// Palette colours closer than this (Euclidean RGB distance) count as the same colour
    /// (default 20; 0 is the thesis' literal "non-zero difference"). With K larger than the
    /// number of colours an object really has, k-means splits a colour into shades along
    /// noise and shading, and the literal rule would count those shades as colour changes.
    pub color_tolerance: f64,
    /// For the tracker's aligned C2 (Alg. 6): each shape gets its own palette, once
    /// ([`view_palette`]), instead of one k-means per compared pair ([`joint_palette`]); two
    /// samples' colours are compared through their own palettes' colours with the same
    /// `color_tolerance` ([`color_cost_per_view`]). Default false here (the thesis' joint
    /// palette); the tracker's appearance settings turn it on
    /// (`track::AppearanceConfig::colour`, where the reason is given). The functions of this
    /// module take the palettes they are given and do not read it.
    #[serde(default)]
    pub per_view: bool,
}

impl Default for ColorConfig {
    fn default() -> Self {
        Self {
            clusters: 10,
            max_iterations: 30,
            tolerance: 0.5,
            n_runs: 1,
            seed: 0xc010_7000,
            max_samples: 1500,
            overlap_radius: 1.0,
            color_tolerance: 20.0,
            per_view: false,
        }
    }
}

impl ColorConfig {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), ColorError> {
        let bad = |field, reason| Err(ColorError::InvalidConfig { field, reason });
        if self.clusters == 0 || self.clusters > 256 {
            return bad("clusters", "must be in 1..=256");
        }
        if self.max_iterations == 0 {
            return bad("max_iterations", "must be ≥ 1");
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return bad("tolerance", "must be finite and > 0");
        }
        if self.n_runs == 0 {
            return bad("n_runs", "must be ≥ 1");
        }
        if self.max_samples == 0 {
            return bad("max_samples", "must be ≥ 1");
        }
        if !(self.overlap_radius.is_finite() && self.overlap_radius > 0.0) {
            return bad("overlap_radius", "must be finite and > 0");
        }
        if !(self.color_tolerance.is_finite() && self.color_tolerance >= 0.0) {
            return bad("color_tolerance", "must be finite and ≥ 0");
        }
        Ok(())
    }
}

/// Colour samples of one shape: pixel-centre positions (image coordinates) and their RGB.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ColorSample {
    /// Sample positions (pixel centres).
    pub positions: Vec<Point>,
    /// RGB at each position.
    pub rgb: Vec<[u8; 3]>,
    /// Grid spacing in pixels (≥ 1): the distance between neighbouring samples.
    pub spacing: f64,
}

impl Default for ColorSample {
    /// No samples, unit spacing.
    fn default() -> Self {
        Self {
            positions: Vec::new(),
            rgb: Vec::new(),
            spacing: 1.0,
        }
    }
}

impl ColorSample {
    /// The samples' positions in a [`CellIndex`] with cells one sample spacing wide: the
    /// look-up the colour costs make of A's samples under B's.
    pub fn index(&self) -> CellIndex {
        CellIndex::new(&self.positions, self.spacing)
    }

    /// Samples from explicit positions and colours, checked for equal lengths, finite
    /// positions and a finite spacing > 0.
    pub fn new(positions: Vec<Point>, rgb: Vec<[u8; 3]>, spacing: f64) -> Result<Self, ColorError> {
        if positions.len() != rgb.len() {
            return Err(ColorError::LengthMismatch {
                positions: positions.len(),
                rgb: rgb.len(),
            });
        }
        if let Some(index) = positions
            .iter()
            .position(|p| !(p.x.is_finite() && p.y.is_finite()))
        {
            return Err(ColorError::NonFinite { index });
        }
        if !(spacing.is_finite() && spacing > 0.0) {
            return Err(ColorError::NonFinite { index: usize::MAX });
        }
        Ok(Self {
            positions,
            rgb,
            spacing,
        })
    }

    /// Grid samples of `frame` inside `mask`: at most `max_samples` (see the module doc).
    /// Mask pixels outside the frame are skipped; an empty result is not an error here
    /// (comparing it is).
    pub fn from_mask(frame: &Frame<'_>, mask: &Mask, max_samples: usize) -> Self {
        let area = mask.area();
        let max_samples = max_samples.max(1);
        if area == 0 {
            return Self {
                spacing: 1.0,
                ..Self::default()
            };
        }
        let b = mask.bbox();
        let mut spacing = (area as f64 / max_samples as f64).sqrt().max(1.0);
        // The grid count is only ≈ area / spacing²; widen the grid until the bound holds,
        // sampling into the same buffers each time.
        let mut s = Self::default();
        for _ in 0..8 {
            grid_sample_into(frame, mask, (b.x, b.y, b.w, b.h), spacing, &mut s);
            if s.positions.len() <= max_samples {
                return s;
            }
            spacing *= (s.positions.len() as f64 / max_samples as f64).sqrt() * 1.01;
        }
        grid_sample_into(frame, mask, (b.x, b.y, b.w, b.h), spacing, &mut s);
        // Unreachable in practice; keep an evenly strided subset rather than panic or overflow.
        let stride = s.positions.len().div_ceil(max_samples).max(1);
        Self {
            positions: s.positions.iter().step_by(stride).copied().collect(),
            rgb: s.rgb.iter().step_by(stride).copied().collect(),
            spacing: spacing * (stride as f64).sqrt(),
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether there is no sample.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Mean sample position (`None` when empty).
    pub fn centroid(&self) -> Option<Point> {
        if self.positions.is_empty() {
            return None;
        }
        let s = self
            .positions
            .iter()
            .fold(Point::default(), |acc, p| acc + *p);
        Some(s * (1.0 / self.positions.len() as f64))
    }
}

/// The grid samples of `frame` inside `mask` over the box `(x0, y0, w, h)` at `spacing`, into
/// `out` (its buffers reused: [`ColorSample::from_mask`] may try several grids).
fn grid_sample_into(
    frame: &Frame<'_>,
    mask: &Mask,
    (x0, y0, w, h): (f64, f64, f64, f64),
    spacing: f64,
    out: &mut ColorSample,
) {
    let (nx, ny) = ((w / spacing).ceil() as usize, (h / spacing).ceil() as usize);
    // At most one sample per grid point and per foreground pixel.
    let cap = nx.saturating_mul(ny).min(mask.area() as usize);
    out.positions.clear();
    out.rgb.clear();
    out.positions.reserve(cap);
    out.rgb.reserve(cap);
    out.spacing = spacing;
    let ColorSample { positions, rgb, .. } = out;
    grid_points(frame, mask, (x0, y0, w, h), spacing, |px, py, c| {
        positions.push(Point::new(px + 0.5, py + 0.5));
        rgb.push(c);
    });
}

/// Calls `f(px, py, rgb)` for every grid point of the box `(x0, y0, w, h)` at `spacing`
/// (pixel `(px, py)`, floored) that lies in `mask` and in `frame`, row by row. Each column's
/// pixel and its offsets in the mask's and the frame's rows are computed once per grid, not
/// once per point (a floor is a libm call on baseline x86-64 and in wasm), and the points
/// read the two rows directly: the same points, in the same order, as testing
/// [`Mask::get`] and [`Frame::rgb_at`] at each one.
fn grid_points(
    frame: &Frame<'_>,
    mask: &Mask,
    (x0, y0, w, h): (f64, f64, f64, f64),
    spacing: f64,
    mut f: impl FnMut(f64, f64, [u8; 3]),
) {
    let (nx, ny) = ((w / spacing).ceil() as usize, (h / spacing).ceil() as usize);
    let (mw, mh) = (mask.width() as i64, mask.height() as i64);
    let (fw, fh) = (i64::from(frame.width()), i64::from(frame.height()));
    let channels = frame.format().channels();
    // Columns inside both the mask's bitmap and the frame: (pixel x, mask column, frame
    // byte offset). A column outside either takes no sample in any row. On the stack up to
    // `COLS` columns (a shape's budget of samples spans far fewer), so sampling allocates
    // only its output.
    const COLS: usize = 128;
    let column = |i: usize| {
        let px = (x0 + (i as f64 + 0.5) * spacing).floor();
        let xi = px as i64;
        let lx = xi - i64::from(mask.x());
        let inside = (0..mw).contains(&lx) && (0..fw).contains(&xi);
        inside.then(|| (px, lx as usize, xi as usize * channels))
    };
    let mut stack = [(0.0, 0usize, 0usize); COLS];
    let heap: Vec<(f64, usize, usize)>;
    let cols: &[(f64, usize, usize)] = if nx <= COLS {
        let mut n = 0;
        for c in (0..nx).filter_map(column) {
            stack[n] = c;
            n += 1;
        }
        &stack[..n]
    } else {
        heap = (0..nx).filter_map(column).collect();
        &heap
    };
    let (bits, data, stride) = (mask.data(), frame.data(), frame.stride());
    for j in 0..ny {
        let py = (y0 + (j as f64 + 0.5) * spacing).floor();
        let yi = py as i64;
        let ly = yi - i64::from(mask.y());
        if !((0..mh).contains(&ly) && (0..fh).contains(&yi)) {
            continue;
        }
        let Some(row) = bits.get(ly as usize * mw as usize..(ly as usize + 1) * mw as usize) else {
            continue;
        };
        let base = yi as usize * stride;
        for &(px, lx, off) in cols {
            if row.get(lx).is_some_and(|&b| b != 0) {
                if let Some(c) = data.get(base + off..base + off + 3) {
                    f(px, py, [c[0], c[1], c[2]]);
                }
            }
        }
    }
}

/// Re-validates a sample whose public fields may have been edited after construction.
fn checked(s: &ColorSample) -> Result<&ColorSample, ColorError> {
    if s.positions.len() != s.rgb.len() {
        return Err(ColorError::LengthMismatch {
            positions: s.positions.len(),
            rgb: s.rgb.len(),
        });
    }
    if let Some(index) = s
        .positions
        .iter()
        .position(|p| !(p.x.is_finite() && p.y.is_finite()))
    {
        return Err(ColorError::NonFinite { index });
    }
    if !(s.spacing.is_finite() && s.spacing > 0.0) {
        return Err(ColorError::NonFinite { index: usize::MAX });
    }
    Ok(s)
}
