//! The colour screen: the share of a shape's samples whose colour a view does not have
//! ([`foreign_share`]), over the view's own palette, without alignment.

use super::palette::{closest_two, distance2};
use super::{checked, ColorConfig, ColorError, ColorSample, ViewPalette};

#[cfg(doc)]
use super::view_palette;

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
