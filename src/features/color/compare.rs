//! Comparing two shapes' spatial colour: C2 over aligned samples ([`color_cost`],
//! [`color_cost_per_view`]) and the alignment-free [`palette_distance`].

use super::palette::distance2;
use super::{checked, joint_palette, ColorConfig, ColorError, ColorSample, ViewPalette};
use crate::features::transform::{CellIndex, Transform, Translation};
use serde::{Deserialize, Serialize};

#[cfg(doc)]
use super::Palette;

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
pub(super) fn hellinger(p: &[f64], q: &[f64]) -> f64 {
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
