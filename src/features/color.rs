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

use super::transform::{CellIndex, Transform, Translation};
use crate::frame::{Frame, Mask, Point};
use linfa::traits::{Fit, Predict};
use linfa::DatasetBase;
use linfa_clustering::{KMeans, KMeansInit};
use ndarray::Array2;
use rand::distributions::{Distribution, Uniform};
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256Plus;
use serde::{Deserialize, Serialize};
use thiserror::Error;

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

/// A palette shared by two shapes and every sample's label in it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Palette {
    /// Palette colours (k-means centroids), RGB in `[0, 255]`. At most K; fewer when the two
    /// shapes have fewer samples than K.
    pub centroids: Vec<[f64; 3]>,
    /// Label of each A sample (index into `centroids`).
    pub labels_a: Vec<usize>,
    /// Label of each B sample.
    pub labels_b: Vec<usize>,
}

impl Palette {
    /// Normalised label histograms of A and B over the palette.
    pub fn histograms(&self) -> (Vec<f64>, Vec<f64>) {
        let k = self.centroids.len();
        (
            label_histogram(&self.labels_a, k),
            label_histogram(&self.labels_b, k),
        )
    }

    /// Whether labels `i` and `j` reconstruct to colours more than `tolerance` apart
    /// (Euclidean RGB distance; at least 1e-6, because k-means++ may pick the same colour
    /// twice when there are fewer distinct colours than K).
    pub fn differ(&self, i: usize, j: usize, tolerance: f64) -> bool {
        if i == j {
            return false;
        }
        match (self.centroids.get(i), self.centroids.get(j)) {
            (Some(a), Some(b)) => distance2(a, b).sqrt() > tolerance.max(1e-6),
            _ => true,
        }
    }
}

/// Runs k-means++ on the RGB of both shapes' samples together and labels every sample.
pub fn joint_palette(
    a: &ColorSample,
    b: &ColorSample,
    cfg: &ColorConfig,
) -> Result<Palette, ColorError> {
    cfg.validate()?;
    for (s, which) in [(a, "A"), (b, "B")] {
        if s.rgb.is_empty() {
            return Err(ColorError::EmptySample { which });
        }
    }
    let (centroids, labels) = kmeans(a.rgb.iter().chain(&b.rgb), a.rgb.len() + b.rgb.len(), cfg)?;
    let (la, lb) = labels.split_at(a.rgb.len().min(labels.len()));
    Ok(Palette {
        centroids,
        labels_a: la.to_vec(),
        labels_b: lb.to_vec(),
    })
}

/// k-means++ (linfa) on `n` colours: the centroids and each colour's label.
fn kmeans<'a>(
    rgb: impl Iterator<Item = &'a [u8; 3]>,
    n: usize,
    cfg: &ColorConfig,
) -> Result<(Vec<[f64; 3]>, Vec<usize>), ColorError> {
    let mut data: Vec<[f64; 3]> = rgb.take(n).map(|c| c.map(f64::from)).collect();
    data.resize(n, [0.0; 3]);
    let k = cfg.clusters.min(n);
    let mut rng = Xoshiro256Plus::seed_from_u64(cfg.seed);
    // One run (the tracker's setting): linfa's k-means, step for step, without its per-call
    // overheads (see `plus_plus_seeds` and `lloyd`).
    if cfg.n_runs == 1 && k > 0 {
        let seeds = plus_plus_seeds(&data, k, &mut rng)?;
        return Ok(lloyd(&data, seeds, cfg.max_iterations, cfg.tolerance));
    }
    let mut array = Array2::<f64>::zeros((n, 3));
    for (mut row, c) in array.rows_mut().into_iter().zip(&data) {
        row.iter_mut().zip(c).for_each(|(v, &c)| *v = c);
    }
    let dataset = DatasetBase::from(array);
    let model = KMeans::params_with_rng(k, rng)
        .init_method(KMeansInit::KMeansPlusPlus)
        .n_runs(cfg.n_runs)
        .max_n_iterations(cfg.max_iterations)
        .tolerance(cfg.tolerance)
        .fit(&dataset)
        .map_err(|e| ColorError::KMeans {
            reason: e.to_string(),
        })?;
    let labels = model.predict(dataset.records());
    let centroids = model
        .centroids()
        .rows()
        .into_iter()
        .map(|r| [r[0], r[1], r[2]])
        .collect();
    Ok((centroids, labels.to_vec()))
}

/// linfa's squared distance (`L2Dist::rdistance`): `(a − b)²` summed over the channels in
/// order, from 0.
fn linfa_sq(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let mut r = 0.0;
    for (x, y) in a.iter().zip(b) {
        let d = x - y;
        r += d * d;
    }
    r
}

/// linfa's k-means++ seeding (`KMeansInit::KMeansPlusPlus`), draw for draw: the first seed
/// uniformly, each next one with probability proportional to the squared distance to the
/// nearest seed so far, by the same draws from the same generator as linfa's `WeightedIndex`
/// (see [`weighted_draw`]), over distances computed in the same order; the seeds, and so the
/// palette, are bit for bit linfa's (`tests::kmeans_is_linfas`). Why not linfa's own: it
/// recomputes every point's distance to every seed for each new seed, on rayon's parallel
/// iterators, and on the tracker's 150–300 colours per call that was three quarters of the
/// k-means time (issue 10's profile); here each new seed updates the distances once.
fn plus_plus_seeds(
    data: &[[f64; 3]],
    k: usize,
    rng: &mut Xoshiro256Plus,
) -> Result<Vec<[f64; 3]>, ColorError> {
    let n = data.len();
    if k == 0 || n == 0 {
        return Ok(vec![[0.0; 3]; k]);
    }
    // `WeightedIndex` over n weights of 1: the total is n exactly, its prefix sums are the
    // integers 1..n, so the first prefix above the draw is the draw's floor.
    let first = (Uniform::new(0.0, n as f64).sample(rng) as usize).min(n - 1);
    let mut seeds = Vec::with_capacity(k);
    seeds.push(data[first]);
    let mut dists = vec![f64::INFINITY; n];
    for _ in 1..k {
        let last = seeds[seeds.len() - 1];
        // The total summed as `WeightedIndex::new` sums it: in order, from the first weight.
        let (mut total, mut valid) = (0.0f64, true);
        for (d, point) in dists.iter_mut().zip(data) {
            *d = d.min(linfa_sq(&last, point));
            valid &= *d >= 0.0;
            total += *d;
        }
        // All distances 0: every point is a seed already; linfa then takes point 0.
        let next = if valid && total > 0.0 {
            weighted_draw(&dists, total, rng)
        } else {
            0
        };
        seeds.push(data[next]);
    }
    Ok(seeds)
}

/// `WeightedIndex::new(weights).sample(rng)` (rand 0.8) without building its table of prefix
/// sums for one draw: the same uniform draw in `[0, total)`, then the first index whose
/// prefix sum, summed in the same order, exceeds it (the last index when none does). The
/// k-means++ seeding draws once per seed from a new table, and its allocations were 5–8 % of
/// the 200-shape bench (issue 10). `total` must be the weights' sum in order and positive.
fn weighted_draw(weights: &[f64], total: f64, rng: &mut Xoshiro256Plus) -> usize {
    let chosen = Uniform::new(0.0, total).sample(rng);
    let mut prefix = 0.0;
    for (i, w) in weights
        .iter()
        .enumerate()
        .take(weights.len().saturating_sub(1))
    {
        prefix += w;
        if prefix > chosen {
            return i;
        }
    }
    weights.len().saturating_sub(1)
}

/// The index of the centroid nearest to `p`, as linfa's `closest_centroid` picks it (the
/// first of equally near ones), its squared distance, and the squared distance to the
/// nearest other one (infinite with one centroid).
fn closest_two(centroids: &[[f64; 3]], p: &[f64; 3]) -> (usize, f64, f64) {
    let (mut best, mut d1, mut d2) = (0, f64::INFINITY, f64::INFINITY);
    for (i, c) in centroids.iter().enumerate() {
        let d = linfa_sq(c, p);
        if d < d1 || i == 0 {
            d2 = d1;
            (best, d1) = (i, d);
        } else {
            d2 = d2.min(d);
        }
    }
    (best, d1, d2)
}

/// linfa's Lloyd iterations for one run (`KMeansValidParams::fit`), step for step, then its
/// `predict`: memberships by [`closest_two`]; each new centroid is the mean of its members *and
/// the old centroid* (linfa's "m_k-means", which keeps empty clusters where they were), summed
/// in input order; stop when the centroids moved less than `tolerance` (the Euclidean norm
/// over all of them) or after `max_iterations`; labels against the final centroids. Written
/// here because linfa runs each step on rayon's parallel iterators over `ndarray` rows, which
/// on the tracker's few hundred colours per call cost several times the arithmetic (issue
/// 10); `tests::kmeans_is_linfas` checks centroids and labels are linfa's bit for bit.
///
/// Memberships skip the points whose centroid cannot have changed (Hamerly, "Making k-means
/// even faster", SDM 2010): each point keeps an upper bound on its distance to its own
/// centroid and a lower bound on its distance to every other, moved by how far the centroids
/// moved; while the upper bound is below the lower one its own centroid is strictly the
/// nearest, which is what [`closest_two`] would answer. The bounds keep a margin far above the
/// rounding of the distances, so a point near a tie is always recomputed and the labels stay
/// linfa's. After the first steps most points keep their colour (on the 200-shape bench,
/// Lloyd was a tenth of the frame).
fn lloyd(
    data: &[[f64; 3]],
    mut centroids: Vec<[f64; 3]>,
    max_iterations: u64,
    tolerance: f64,
) -> (Vec<[f64; 3]>, Vec<usize>) {
    let k = centroids.len();
    let mut labels = vec![0usize; data.len()];
    // Bounds on Euclidean distances (not squared: the triangle inequality moves them).
    let mut upper = vec![f64::INFINITY; data.len()];
    let mut lower = vec![0.0f64; data.len()];
    let assign =
        |centroids: &[[f64; 3]], labels: &mut [usize], upper: &mut [f64], lower: &mut [f64]| {
            for (((l, p), u), lo) in labels.iter_mut().zip(data).zip(upper).zip(lower) {
                // Colours are in [0, 255]: distances below ~450, rounding below 1e-12.
                if *u + 1e-6 < *lo {
                    continue;
                }
                let (best, d1, d2) = closest_two(centroids, p);
                (*l, *u, *lo) = (best, d1.sqrt(), d2.sqrt());
            }
        };
    let mut shift = vec![0.0f64; k];
    let mut n_iter = 0u64;
    loop {
        assign(&centroids, &mut labels, &mut upper, &mut lower);
        let mut next = vec![[0.0f64; 3]; k];
        let mut counts = vec![1usize; k];
        for (p, &l) in data.iter().zip(&labels) {
            for (s, v) in next[l].iter_mut().zip(p) {
                *s += v;
            }
            counts[l] += 1;
        }
        for ((c, old), &count) in next.iter_mut().zip(&centroids).zip(&counts) {
            for (s, o) in c.iter_mut().zip(old) {
                *s = (*s + o) / count as f64;
            }
        }
        let moved = centroids
            .iter()
            .zip(&next)
            .fold(0.0, |acc, (a, b)| {
                let mut acc = acc;
                for (x, y) in a.iter().zip(b) {
                    let d = x - y;
                    acc += d * d;
                }
                acc
            })
            .sqrt();
        for ((s, a), b) in shift.iter_mut().zip(&centroids).zip(&next) {
            *s = distance2(a, b).sqrt();
        }
        // The two largest moves: a point's other centroids moved at most the largest move
        // among those that are not its own.
        let (mut m1, mut m2, mut arg) = (0.0f64, 0.0f64, usize::MAX);
        for (j, &s) in shift.iter().enumerate() {
            if s > m1 {
                (m2, m1, arg) = (m1, s, j);
            } else {
                m2 = m2.max(s);
            }
        }
        for ((&l, u), lo) in labels.iter().zip(&mut upper).zip(&mut lower) {
            *u += shift[l];
            *lo -= if l == arg { m2 } else { m1 };
        }
        centroids = next;
        n_iter += 1;
        if moved < tolerance || n_iter == max_iterations {
            break;
        }
    }
    assign(&centroids, &mut labels, &mut upper, &mut lower);
    (centroids, labels)
}

/// The share of `b`'s samples whose colour the view `a` does not have, over `a`'s own palette
/// `pa` ([`view_palette`]): each `b` sample takes the nearest of `a`'s palette colours, and is
/// foreign when that colour is rare in `a` (under `rare` of its samples) or when the sample
/// lies farther from it than `a`'s own farthest sample of that colour plus
/// `cfg.color_tolerance` (a colour `a`'s samples never came near). In `[0, 1]`.
///
/// A cheap relative of the containment a joint palette measures (the share of `b`'s samples
/// whose joint label is rare in `a`): `a`'s k-means runs once per view and each comparison is
/// one nearest-colour pass over `b`'s samples. It is not the same measure (a joint k-means can
/// split a colour `a` has into a shade only `b` has, and can merge a rare colour of `a` into a
/// common one), so the tracker uses it only to screen out pairs it finds almost wholly foreign
/// (`track::ColourCost`).
pub fn foreign_share(
    (a, pa): (&ColorSample, &ViewPalette),
    b: &ColorSample,
    rare: f64,
    cfg: &ColorConfig,
) -> Result<f64, ColorError> {
    cfg.validate()?;
    let view = ViewReach::new(a, pa)?;
    let foreign = count_foreign(&view, b, rare, cfg, |_, _| false)?;
    Ok(foreign as f64 / b.rgb.len() as f64)
}

/// Whether [`foreign_share`] is at least `min_share`, decided as soon as the samples counted
/// so far settle it: in a crowd of look-alike shapes the screen
/// (`track::ColourCost`) meets pairs that share their colours, and a tenth of a detection's
/// samples found at home already says no. Exactly `foreign_share(…)? >= min_share`.
pub fn foreign_share_at_least(
    (a, pa): (&ColorSample, &ViewPalette),
    b: &ColorSample,
    rare: f64,
    min_share: f64,
    cfg: &ColorConfig,
) -> Result<bool, ColorError> {
    cfg.validate()?;
    let view = ViewReach::new(a, pa)?;
    foreign_share_at_least_in(&view, b, rare, min_share, cfg)
}

/// [`foreign_share_at_least`] against a view's [`ViewReach`], built once per view: a lost
/// track's reference view meets every free detection in reach, frame after frame, and
/// rebuilding the view's side per pair was two thirds of each comparison (issue 10). The
/// same answer as [`foreign_share_at_least`] with the view and palette it was built from.
pub fn foreign_share_at_least_in(
    view: &ViewReach,
    b: &ColorSample,
    rare: f64,
    min_share: f64,
    cfg: &ColorConfig,
) -> Result<bool, ColorError> {
    let n = b.rgb.len();
    let share = |k: usize| k as f64 / n as f64;
    // `foreign` only grows and `foreign + unseen` only shrinks, so each bound, once past
    // `min_share`, stays past it: the final share lies between them.
    let foreign = count_foreign(view, b, rare, cfg, |foreign, seen| {
        share(foreign) >= min_share || share(foreign + (n - seen)) < min_share
    })?;
    Ok(share(foreign) >= min_share)
}

/// What [`foreign_share`] reads of the view `a` besides its samples: its palette's colours,
/// each colour's share of the view's samples, and each colour's reach (the distance from it to
/// the farthest of the view's samples it labels).
#[derive(Debug, Clone, PartialEq)]
pub struct ViewReach {
    centroids: Vec<[f64; 3]>,
    share: Vec<f64>,
    reach: Vec<f64>,
}

impl ViewReach {
    /// The view `a` with its own palette `pa` ([`view_palette`]).
    pub fn new(a: &ColorSample, pa: &ViewPalette) -> Result<Self, ColorError> {
        let a = checked(a)?;
        if pa.labels.len() != a.len() || pa.centroids.is_empty() {
            return Err(ColorError::LengthMismatch {
                positions: a.len(),
                rgb: pa.labels.len(),
            });
        }
        // Each palette colour's reach, from the view's own samples: a colour k-means fitted
        // to a broad spread of shades covers a wider neighbourhood than a tight one. Kept
        // squared and rooted once per colour: the root is monotone, so the root of the
        // largest square is the largest root, bit for bit.
        let k = pa.centroids.len();
        let mut reach = vec![0.0f64; k];
        for (c, &l) in a.rgb.iter().zip(&pa.labels) {
            if let (Some(r), Some(centroid)) = (reach.get_mut(l), pa.centroids.get(l)) {
                *r = r.max(distance2(&c.map(f64::from), centroid));
            }
        }
        reach.iter_mut().for_each(|r| *r = r.sqrt());
        Ok(Self {
            centroids: pa.centroids.clone(),
            share: pa.histogram(),
            reach,
        })
    }
}

/// The number of `b`'s samples foreign to the view (see [`foreign_share`]), counting in
/// order and stopping early once `stop(foreign so far, samples seen)` says so.
fn count_foreign(
    view: &ViewReach,
    b: &ColorSample,
    rare: f64,
    cfg: &ColorConfig,
    stop: impl Fn(usize, usize) -> bool,
) -> Result<usize, ColorError> {
    cfg.validate()?;
    let b = checked(b)?;
    if b.rgb.is_empty() {
        return Err(ColorError::EmptySample { which: "B" });
    }
    let (share, reach) = (&view.share, &view.reach);
    let mut foreign = 0;
    for (seen, c) in b.rgb.iter().enumerate() {
        let (l, d2, _) = closest_two(&view.centroids, &c.map(f64::from));
        let common = share.get(l).is_some_and(|&h| h >= rare);
        let near = reach
            .get(l)
            .is_some_and(|&r| d2.sqrt() <= r + cfg.color_tolerance);
        if !(common && near) {
            foreign += 1;
        }
        if stop(foreign, seen + 1) {
            break;
        }
    }
    Ok(foreign)
}

/// One shape's own palette ([`view_palette`]) and its samples' labels in it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ViewPalette {
    /// Palette colours (k-means centroids), RGB in `[0, 255]`; at most K.
    pub centroids: Vec<[f64; 3]>,
    /// Label of each sample (index into `centroids`).
    pub labels: Vec<usize>,
}

impl ViewPalette {
    /// Normalised label histogram.
    fn histogram(&self) -> Vec<f64> {
        label_histogram(&self.labels, self.centroids.len())
    }
}

/// The normalised histogram of `labels` over `k` palette colours (labels ≥ `k` are not
/// counted in a bin, but count in the total).
fn label_histogram(labels: &[usize], k: usize) -> Vec<f64> {
    let mut h = vec![0.0; k];
    for &l in labels {
        if let Some(v) = h.get_mut(l) {
            *v += 1.0;
        }
    }
    let n = labels.len().max(1) as f64;
    h.iter_mut().for_each(|v| *v /= n);
    h
}

/// Squared Euclidean distance between two palette colours.
fn distance2(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// k-means++ on one shape's samples alone ([`ColorConfig::per_view`]): computed once per
/// shape, where [`joint_palette`] runs once per compared pair. In a crowd a shape is compared
/// with several candidates, and the per-pair k-means made the colour cost grow with the
/// square of the crowd (issue 10).
pub fn view_palette(s: &ColorSample, cfg: &ColorConfig) -> Result<ViewPalette, ColorError> {
    cfg.validate()?;
    let s = checked(s)?;
    if s.rgb.is_empty() {
        return Err(ColorError::EmptySample { which: "A" });
    }
    let (centroids, labels) = kmeans(s.rgb.iter(), s.rgb.len(), cfg)?;
    Ok(ViewPalette { centroids, labels })
}

/// Whether each pair of palette colours (`a`'s `i`, `b`'s `j`, at `i · |b| + j`) lies more
/// than `tolerance` apart: [`Palette::differ`] across two palettes.
fn differ_across(a: &ViewPalette, b: &ViewPalette, tolerance: f64) -> Vec<bool> {
    let t2 = tolerance.max(1e-6).powi(2);
    a.centroids
        .iter()
        .flat_map(|ca| b.centroids.iter().map(move |cb| distance2(ca, cb) > t2))
        .collect()
}

/// C2 (Alg. 6) with each shape's own palette ([`ColorConfig::per_view`]): as
/// [`color_cost`], except that an aligned B sample and A's sample under it differ when their
/// palettes' colours are more than `color_tolerance` apart (with one joint palette: their
/// shared labels' colours). `palette_distance` is the share of the two shapes' colour mass
/// that cannot be paired with a colour of the other within the tolerance (each palette's
/// shades of one colour split differently, so label histograms are not compared bin by bin).
/// `index` is A's sample positions' [`CellIndex`] ([`ColorSample::index`]), built once per shape by the caller (a
/// shape is compared with several candidates; building it per pair was a fifth of the
/// comparison's time); an index of other points gives a meaningless cost, not an error.
pub fn color_cost_per_view(
    (a, pa, index): (&ColorSample, &ViewPalette, &CellIndex),
    (b, pb): (&ColorSample, &ViewPalette),
    b_to_a: Option<&Transform>,
    cfg: &ColorConfig,
) -> Result<ColorMatch, ColorError> {
    cfg.validate()?;
    let a = checked(a)?;
    let b = checked(b)?;
    if pa.labels.len() != a.len() || pb.labels.len() != b.len() {
        return Err(ColorError::LengthMismatch {
            positions: a.len() + b.len(),
            rgb: pa.labels.len() + pb.labels.len(),
        });
    }
    let (transform, alignment) = align(a, b, b_to_a)?;
    let kb = pb.centroids.len();
    let differ = differ_across(pa, pb, cfg.color_tolerance);
    let radius = cfg.overlap_radius * a.spacing;
    let (mut compared, mut differing) = (0usize, 0usize);
    for (p, &lb) in b.positions.iter().zip(&pb.labels) {
        let Some((i, d)) = index.nearest_within(transform.apply(*p), radius) else {
            continue;
        };
        if d > radius {
            continue;
        }
        let Some(&la) = pa.labels.get(i) else {
            continue;
        };
        compared += 1;
        if differ.get(la * kb + lb).copied().unwrap_or(true) {
            differing += 1;
        }
    }
    let cost = if compared == 0 {
        1.0
    } else {
        differing as f64 / compared as f64
    };
    // The share of colour mass that cannot be paired with a colour of the other shape within
    // the tolerance: greedy transport between the two label histograms, closest colours first.
    let (mut ha, mut hb) = (pa.histogram(), pb.histogram());
    let mut close: Vec<(f64, usize, usize)> = Vec::new();
    for (i, ca) in pa.centroids.iter().enumerate() {
        for (j, cb) in pb.centroids.iter().enumerate() {
            if !differ.get(i * kb + j).copied().unwrap_or(true) {
                close.push((distance2(ca, cb), i, j));
            }
        }
    }
    close.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut paired = 0.0;
    for (_, i, j) in close {
        let m = ha[i].min(hb[j]);
        ha[i] -= m;
        hb[j] -= m;
        paired += m;
    }
    Ok(ColorMatch {
        cost,
        overlap: compared as f64 / b.len() as f64,
        compared,
        differing,
        palette_distance: (1.0 - paired).clamp(0.0, 1.0),
        alignment,
    })
}

/// How B was brought into A's frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ColorAlignment {
    /// By the given transform.
    Transform,
    /// By moving B's sample centroid onto A's (no transform given).
    Centroid,
}

/// The result of comparing two shapes' spatial colour.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ColorMatch {
    /// C2: the fraction of overlapping aligned samples whose palette colours differ, in
    /// `[0, 1]`. 1 when nothing overlaps (no evidence of a match is treated as the worst
    /// case; check `overlap`).
    pub cost: f64,
    /// Fraction of B's samples that landed on A after alignment, in `[0, 1]`.
    pub overlap: f64,
    /// Overlapping samples compared.
    pub compared: usize,
    /// Of those, samples whose colours differ.
    pub differing: usize,
    /// Alignment-free [`palette_distance`] of the same pair, in `[0, 1]`.
    pub palette_distance: f64,
    /// How B was aligned.
    pub alignment: ColorAlignment,
}

/// Hellinger distance `√(1 − Σ √(p·q))` between two normalised histograms, in `[0, 1]`.
fn hellinger(p: &[f64], q: &[f64]) -> f64 {
    let bc: f64 = p.iter().zip(q).map(|(x, y)| (x * y).sqrt()).sum();
    (1.0 - bc).max(0.0).sqrt().min(1.0)
}

/// C2 between shapes A and B (Alg. 6), with B aligned onto A by `b_to_a` (the shape context
/// transform from B's frame into A's) or, when `None`, by their sample centroids.
pub fn color_cost(
    a: &ColorSample,
    b: &ColorSample,
    b_to_a: Option<&Transform>,
    cfg: &ColorConfig,
) -> Result<ColorMatch, ColorError> {
    cfg.validate()?;
    let a = checked(a)?;
    let b = checked(b)?;
    let palette = joint_palette(a, b, cfg)?;
    let (transform, alignment) = align(a, b, b_to_a)?;
    let k = palette.centroids.len();
    let differ: Vec<bool> = (0..k * k)
        .map(|ij| palette.differ(ij / k, ij % k, cfg.color_tolerance))
        .collect();
    let index = a.index();
    let radius = cfg.overlap_radius * a.spacing;
    let (mut compared, mut differing) = (0usize, 0usize);
    for (p, &lb) in b.positions.iter().zip(&palette.labels_b) {
        let Some((i, d)) = index.nearest_within(transform.apply(*p), radius) else {
            continue;
        };
        if d > radius {
            continue;
        }
        let Some(&la) = palette.labels_a.get(i) else {
            continue;
        };
        compared += 1;
        if differ.get(la * k + lb).copied().unwrap_or(true) {
            differing += 1;
        }
    }
    let (ha, hb) = palette.histograms();
    let cost = if compared == 0 {
        1.0
    } else {
        differing as f64 / compared as f64
    };
    Ok(ColorMatch {
        cost,
        overlap: compared as f64 / b.len() as f64,
        compared,
        differing,
        palette_distance: hellinger(&ha, &hb),
        alignment,
    })
}

/// The transform bringing B into A's frame: `b_to_a`, else the one moving B's sample centroid
/// onto A's.
fn align(
    a: &ColorSample,
    b: &ColorSample,
    b_to_a: Option<&Transform>,
) -> Result<(Transform, ColorAlignment), ColorError> {
    if let Some(t) = b_to_a {
        return Ok((*t, ColorAlignment::Transform));
    }
    let (ca, cb) = match (a.centroid(), b.centroid()) {
        (Some(ca), Some(cb)) => (ca, cb),
        (None, _) => return Err(ColorError::EmptySample { which: "A" }),
        (_, None) => return Err(ColorError::EmptySample { which: "B" }),
    };
    Ok((
        Transform::Translation(Translation {
            dx: ca.x - cb.x,
            dy: ca.y - cb.y,
        }),
        ColorAlignment::Centroid,
    ))
}

/// Alignment-free colour distance for re-identification: the Hellinger distance between the
/// two shapes' label histograms over their shared palette, in `[0, 1]` (0: same colour mix).
pub fn palette_distance(
    a: &ColorSample,
    b: &ColorSample,
    cfg: &ColorConfig,
) -> Result<f64, ColorError> {
    let a = checked(a)?;
    let b = checked(b)?;
    let palette = joint_palette(a, b, cfg)?;
    let (ha, hb) = palette.histograms();
    Ok(hellinger(&ha, &hb))
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_sampling_is_bounded_and_inside_the_mask() {
        let (w, h) = (120u32, 90u32);
        let buf: Vec<u8> = (0..w * h * 3).map(|i| (i % 251) as u8).collect();
        let frame = Frame::rgb(&buf, w, h).unwrap();
        let mask = Mask::from_bbox(&crate::frame::BBox::new(10.0, 5.0, 100.0, 80.0));
        for max in [1usize, 7, 100, 1500, 10_000] {
            let s = ColorSample::from_mask(&frame, &mask, max);
            assert!(!s.is_empty() && s.len() <= max, "{max}: {}", s.len());
            for p in &s.positions {
                assert!(mask.get(p.x.floor() as i32, p.y.floor() as i32));
            }
        }
        // Small enough to keep every pixel.
        assert_eq!(ColorSample::from_mask(&frame, &mask, 8000).len(), 8000);
        assert!(ColorSample::from_mask(&frame, &Mask::empty(), 10).is_empty());
    }

    /// The grid's samples are those of testing every grid point with `Mask::get` and
    /// `Frame::rgb_at` (the per-point form the row reads replaced), for masks partly outside
    /// the frame on every side, RGB and RGBA frames, and spacings above and below a pixel.
    #[test]
    fn grid_sampling_reads_the_points_the_per_point_tests_would() {
        let reference = |frame: &Frame<'_>, mask: &Mask, spacing: f64| {
            let b = mask.bbox();
            let (nx, ny) = (
                (b.w / spacing).ceil() as usize,
                (b.h / spacing).ceil() as usize,
            );
            let mut out = Vec::new();
            for j in 0..ny {
                let py = (b.y + (j as f64 + 0.5) * spacing).floor();
                for i in 0..nx {
                    let px = (b.x + (i as f64 + 0.5) * spacing).floor();
                    let (xi, yi) = (px as i64, py as i64);
                    if !mask.get(xi as i32, yi as i32) || xi < 0 || yi < 0 {
                        continue;
                    }
                    if let Some(c) = frame.rgb_at(xi as u32, yi as u32) {
                        out.push((Point::new(px + 0.5, py + 0.5), c));
                    }
                }
            }
            out
        };
        let (w, h) = (64u32, 48u32);
        let rgb: Vec<u8> = (0..w * h * 3).map(|i| (i * 7 % 253) as u8).collect();
        let rgba: Vec<u8> = (0..w * h * 4).map(|i| (i * 5 % 251) as u8).collect();
        let frames = [
            Frame::rgb(&rgb, w, h).unwrap(),
            Frame::rgba(&rgba, w, h).unwrap(),
        ];
        let mut seed = 17u32;
        let mut next = |n: u32| {
            seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12_345);
            (seed >> 8) % n
        };
        for case in 0..200 {
            let (mw, mh) = (1 + next(40), 1 + next(40));
            let (mx, my) = (next(w + 30) as i32 - 20, next(h + 30) as i32 - 20);
            let bits: Vec<u8> = (0..mw * mh).map(|_| u8::from(next(3) > 0)).collect();
            let mask = Mask::new(mx, my, mw, mh, bits).unwrap();
            if mask.area() == 0 {
                continue;
            }
            let spacing = [0.7, 1.0, 1.6, 3.3][case % 4];
            let frame = &frames[case % 2];
            let mut got = ColorSample::default();
            let bb = mask.bbox();
            grid_sample_into(frame, &mask, (bb.x, bb.y, bb.w, bb.h), spacing, &mut got);
            let got: Vec<(Point, [u8; 3])> = got
                .positions
                .iter()
                .copied()
                .zip(got.rgb.iter().copied())
                .collect();
            assert_eq!(got, reference(frame, &mask, spacing), "case {case}");
        }
    }

    /// The screen's early decision is the full share compared with the threshold, for
    /// views and candidates of mixed colours and thresholds across the range.
    #[test]
    fn the_screen_decides_as_the_full_share_does() {
        let cfg = ColorConfig::default();
        let colours = [
            [200, 20, 20],
            [20, 20, 200],
            [20, 200, 20],
            [220, 220, 0],
            [90, 90, 90],
        ];
        let mut seed = 5u32;
        let mut next = |n: u32| {
            seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12_345);
            ((seed >> 8) % n) as usize
        };
        let mut decided = [0usize; 2];
        for case in 0..300 {
            let mix = |next: &mut dyn FnMut(u32) -> usize| {
                let parts: Vec<ColorSample> = (0..1 + next(3))
                    .map(|_| samples(1 + next(40), colours[next(5)]))
                    .collect();
                joined(&parts)
            };
            let a = mix(&mut next);
            let pa = view_palette(&a, &cfg).unwrap();
            // One view's reach, built once and read by several detections, as the
            // re-identification screen reads a lost track's.
            let view = ViewReach::new(&a, &pa).unwrap();
            for probe in 0..3 {
                let b = mix(&mut next);
                let min_share = [0.0, 0.1, 0.5, 0.9, 1.0][(case + probe) % 5];
                let full = foreign_share((&a, &pa), &b, 0.03, &cfg).unwrap();
                let early = foreign_share_at_least((&a, &pa), &b, 0.03, min_share, &cfg).unwrap();
                let cached = foreign_share_at_least_in(&view, &b, 0.03, min_share, &cfg).unwrap();
                assert_eq!(
                    early,
                    full >= min_share,
                    "case {case}: share {full}, at {min_share}"
                );
                assert_eq!(
                    cached, early,
                    "case {case}.{probe}: the cached view disagrees"
                );
                decided[usize::from(early)] += 1;
            }
        }
        assert!(decided[0] > 30 && decided[1] > 30, "{decided:?}");
    }

    #[test]
    fn kmeans_is_linfas() {
        use rand::Rng;
        let mut gen = Xoshiro256Plus::seed_from_u64(5);
        for case in 0..240u64 {
            let n = 1 + (case as usize * 7) % 300;
            // Few distinct colours in some cases: repeated points and all-zero distances.
            let levels = [2u32, 5, 256][case as usize % 3];
            let rgb: Vec<[u8; 3]> = (0..n)
                .map(|_| [0; 3].map(|_: u8| (gen.gen_range(0..levels) * 255 / levels) as u8))
                .collect();
            let cfg = ColorConfig {
                seed: case,
                clusters: 1 + case as usize % 12,
                // Runs stopped by the iteration cap and by the tolerance, loose and tight.
                max_iterations: [30, 1, 3, 100][case as usize % 4],
                tolerance: [0.5, 1e-3, 5.0][case as usize % 3],
                ..ColorConfig::default()
            };
            let ours = kmeans(rgb.iter(), n, &cfg).unwrap();
            // linfa's own k-means on the same colours and generator.
            let mut data = Array2::<f64>::zeros((n, 3));
            for (mut row, c) in data.rows_mut().into_iter().zip(&rgb) {
                row.iter_mut().zip(c).for_each(|(v, &c)| *v = c as f64);
            }
            let k = cfg.clusters.min(n);
            let model = KMeans::params_with_rng(k, Xoshiro256Plus::seed_from_u64(case))
                .init_method(KMeansInit::KMeansPlusPlus)
                .n_runs(1)
                .max_n_iterations(cfg.max_iterations)
                .tolerance(cfg.tolerance)
                .fit(&DatasetBase::from(data.clone()))
                .unwrap();
            let labels = model.predict(&data).to_vec();
            let centroids: Vec<[f64; 3]> = model
                .centroids()
                .rows()
                .into_iter()
                .map(|r| [r[0], r[1], r[2]])
                .collect();
            assert_eq!(ours.0, centroids, "case {case}");
            assert_eq!(ours.1, labels, "case {case}");
        }
    }

    /// `n` samples on a row, one pixel apart, each `colour` with a small deterministic jitter.
    fn samples(n: usize, colour: [u8; 3]) -> ColorSample {
        let positions = (0..n).map(|i| Point::new(i as f64 + 0.5, 0.5)).collect();
        let rgb = (0..n)
            .map(|i| colour.map(|c| c.saturating_add((i % 5) as u8)))
            .collect();
        ColorSample::new(positions, rgb, 1.0).unwrap()
    }

    fn joined(parts: &[ColorSample]) -> ColorSample {
        let rgb: Vec<[u8; 3]> = parts.iter().flat_map(|p| p.rgb.clone()).collect();
        let positions = (0..rgb.len())
            .map(|i| Point::new(i as f64 + 0.5, 0.5))
            .collect();
        ColorSample::new(positions, rgb, 1.0).unwrap()
    }

    #[test]
    fn foreign_share_counts_the_colours_a_view_does_not_have() {
        let cfg = ColorConfig::default();
        let (red, blue, green, yellow) =
            ([200, 20, 20], [20, 20, 200], [20, 200, 20], [220, 220, 0]);
        // A whole view: red and blue, and a speck of yellow (2 of 102 samples).
        let a = joined(&[samples(60, red), samples(40, blue), samples(2, yellow)]);
        let pa = view_palette(&a, &cfg).unwrap();
        let share = |b: &ColorSample| foreign_share((&a, &pa), b, 0.03, &cfg).unwrap();
        // A sliver showing one of its colours has nothing foreign.
        assert_eq!(share(&samples(20, red)), 0.0);
        assert_eq!(share(&joined(&[samples(10, red), samples(10, blue)])), 0.0);
        // A colour it never had, and one it had too little of, are foreign.
        assert_eq!(share(&samples(20, green)), 1.0);
        assert_eq!(share(&samples(20, yellow)), 1.0);
        assert_eq!(share(&joined(&[samples(10, red), samples(10, green)])), 0.5);
        // Nothing to compare is an error, not a share.
        assert!(foreign_share((&a, &pa), &ColorSample::default(), 0.03, &cfg).is_err());
        let other = view_palette(&samples(5, red), &cfg).unwrap();
        assert!(foreign_share((&a, &other), &samples(3, red), 0.03, &cfg).is_err());
        // The cached view checks the same: a palette of another view, and an empty detection.
        assert!(ViewReach::new(&a, &other).is_err());
        let view = ViewReach::new(&a, &pa).unwrap();
        let empty = ColorSample::default();
        assert!(foreign_share_at_least_in(&view, &empty, 0.03, 0.5, &cfg).is_err());
    }

    #[test]
    fn hellinger_bounds() {
        assert_eq!(hellinger(&[0.5, 0.5], &[0.5, 0.5]), 0.0);
        assert!((hellinger(&[1.0, 0.0], &[0.0, 1.0]) - 1.0).abs() < 1e-12);
    }
}
