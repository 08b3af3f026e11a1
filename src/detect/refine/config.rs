//! [`RefineConfig`], the settings of the box refinement, and their check.

use crate::detect::DetectError;
use serde::{Deserialize, Serialize};

/// Settings of the box refinement.
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RefineConfig {
    /// Longest side of the working crop in pixels, ring included (the per-box cost bound).
    /// Default `80`.
    pub max_side: u32,
    /// Width of the background ring around the box, as a fraction of the box's longer side
    /// (at least 2 working pixels). Default `0.08`.
    pub ring: f64,
    /// Palette size of the k-means that starts the colour models. Default `8`.
    pub clusters: usize,
    /// Cut → refit rounds. Default `2` (further rounds gained < 0.005 J on DAVIS).
    pub iterations: u32,
    /// GrabCut's smoothness weight `γ` (per unit of neighbour distance). Default `10`:
    /// GrabCut's 50 emptied tight boxes around objects coloured like their surroundings
    /// (mean J 0.28 against 0.73 on the 8 DAVIS moving-camera sequences, oracle boxes).
    pub smoothness: f64,
    /// Foreground bonus at the box centre (log-likelihood units), falling linearly to 0 at the
    /// box border: detectors centre their boxes on the object. Default `1.0`.
    pub centre_prior: f64,
    /// How much the foreground model trusts the box centre over its border: a box pixel's
    /// weight in the foreground colour model is `1 − centre_weight·r` (`r` = 0 at the centre,
    /// 1 on the box border; at least 0.05). Default `1.0`.
    pub centre_weight: f64,
    /// Components smaller than this fraction of the largest are dropped. Default `0.2`.
    pub keep_fraction: f64,
    /// Most crop pixels the k-means fits its palette on (an even stride through the ring's
    /// and the box's pixels); every pixel then takes its nearest palette colour. `0`: all
    /// pixels. Default `1024` (a 6,400-pixel crop's k-means was about a sixth of the
    /// moving-camera detector's time; the palette only starts the colour models, which the
    /// cut → refit rounds then fit on every pixel).
    pub palette_samples: usize,
    /// Seed of the k-means.
    pub seed: u64,
    /// The outline at the frame's resolution: how strongly the upsampled working-crop label
    /// counts against the last round's colour models on the frame's own pixels near the cut.
    /// A frame pixel whose bilinear label `v` lies strictly between 0 and 1 (within one
    /// working pixel of the cut) is foreground when
    /// `cost_bg − cost_fg + boundary_prior·(2v − 1) > 0`, the costs being the unary costs of
    /// the cut (centre prior included). `0`: colour alone decides there; negative: the plain
    /// bilinear threshold. Default `2.0` (mean J on the 8 DAVIS moving-camera sequences from
    /// oracle boxes 0.734 → 0.743: a large box's working pixel spans several frame pixels,
    /// so the bilinear outline cut across the object's edges).
    pub boundary_prior: f64,
    /// Scale of the texture feature the colour models see beside RGB: a working pixel's
    /// mean absolute luma step between neighbouring frame pixels (foliage, fences and gravel
    /// step a lot, car bodies and coats little). The mixtures' covariances adapt to any
    /// scale; it matters only against the noise floor of each Gaussian. `0`: colour alone.
    /// Default `1.0` (mean J from oracle boxes 0.743 → 0.752, car-shadow 0.753 → 0.805; the
    /// moving-camera detector turns it off, see
    /// [`MovingConfig`](crate::detect::MovingConfig)).
    pub texture: f64,
}

impl Default for RefineConfig {
    fn default() -> Self {
        Self {
            max_side: 80,
            ring: 0.08,
            clusters: 8,
            iterations: 2,
            smoothness: 10.0,
            centre_prior: 1.0,
            centre_weight: 1.0,
            keep_fraction: 0.2,
            palette_samples: 1024,
            seed: 0x9ab_c07,
            boundary_prior: 2.0,
            texture: 1.0,
        }
    }
}

impl RefineConfig {
    /// Checks every setting.
    pub fn validate(&self) -> Result<(), DetectError> {
        let bad = |field: &'static str, value: f64, reason: &'static str| {
            Err(DetectError::InvalidConfig {
                field,
                value,
                reason,
            })
        };
        if !(8..=512).contains(&self.max_side) {
            return bad("max_side", self.max_side as f64, "must be in 8..=512");
        }
        if !(self.ring.is_finite() && (0.0..=1.0).contains(&self.ring)) {
            return bad("ring", self.ring, "must be in [0, 1]");
        }
        if !(2..=32).contains(&self.clusters) {
            return bad("clusters", self.clusters as f64, "must be in 2..=32");
        }
        if !(1..=20).contains(&self.iterations) {
            return bad("iterations", self.iterations as f64, "must be in 1..=20");
        }
        if !(self.smoothness.is_finite() && (0.0..=1000.0).contains(&self.smoothness)) {
            return bad("smoothness", self.smoothness, "must be in [0, 1000]");
        }
        if !(self.centre_prior.is_finite() && (0.0..=100.0).contains(&self.centre_prior)) {
            return bad("centre_prior", self.centre_prior, "must be in [0, 100]");
        }
        if !(self.centre_weight.is_finite() && (0.0..=1.0).contains(&self.centre_weight)) {
            return bad("centre_weight", self.centre_weight, "must be in [0, 1]");
        }
        if !(self.keep_fraction.is_finite() && (0.0..=1.0).contains(&self.keep_fraction)) {
            return bad("keep_fraction", self.keep_fraction, "must be in [0, 1]");
        }
        if !(self.boundary_prior.is_finite() && self.boundary_prior <= 1000.0) {
            return bad(
                "boundary_prior",
                self.boundary_prior,
                "must be finite, at most 1000",
            );
        }
        if !(self.texture.is_finite() && (0.0..=100.0).contains(&self.texture)) {
            return bad("texture", self.texture, "must be in [0, 100]");
        }
        Ok(())
    }
}
