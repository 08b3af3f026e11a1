//! The colour palettes: k-means++ on shapes' sample colours, one palette shared by two
//! shapes ([`joint_palette`]) or one per shape ([`view_palette`]), computed as linfa computes
//! it (`plus_plus_seeds`, `lloyd`).

use super::{checked, ColorConfig, ColorError, ColorSample};
use linfa::traits::{Fit, Predict};
use linfa::DatasetBase;
use linfa_clustering::{KMeans, KMeansInit};
use ndarray::Array2;
use rand::distributions::{Distribution, Uniform};
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256Plus;
use serde::{Deserialize, Serialize};

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
pub(super) fn kmeans<'a>(
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
pub(super) fn closest_two(centroids: &[[f64; 3]], p: &[f64; 3]) -> (usize, f64, f64) {
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
    pub(super) fn histogram(&self) -> Vec<f64> {
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
pub(super) fn distance2(a: &[f64; 3], b: &[f64; 3]) -> f64 {
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
