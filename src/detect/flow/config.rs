//! [`FlowConfig`], the settings of the dense flow, and their check.

use serde::{Deserialize, Serialize};

/// Largest [`FlowConfig::patch_size`]: the patch search keeps a running sum per patch column,
/// in arrays of this length.
pub(in crate::detect) const MAX_PATCH: usize = 32;

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
        if !(4..=MAX_PATCH as u32).contains(&self.patch_size) {
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
