//! The pair-cost terms of the association and their weights ([`Terms`]), part of the
//! tracker's [`super::Config`].

use serde::{Deserialize, Serialize};

/// Weight and gate of one pair-cost term.
///
/// A term's cost is in `[0, 1]` (0 = surely the same object). A term with weight 0 is not
/// computed at all. When a term has no data for a pair (no mask, no image), it drops out and
/// the remaining weights renormalise (thesis eq. 39 generalised).
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TermConfig {
    /// Weight in the combined cost; 0 disables the term.
    pub weight: f64,
    /// A pair whose cost for this term exceeds the gate is never matched, whatever the other
    /// terms say. `None`: no gate.
    pub gate: Option<f64>,
    /// Term-specific scale (documented on each field of [`Terms`]); ignored by terms without one.
    pub scale: f64,
}

impl Default for TermConfig {
    fn default() -> Self {
        Self {
            weight: 0.0,
            gate: None,
            scale: 1.0,
        }
    }
}

impl TermConfig {
    /// A term with `weight`, no gate, scale 1.
    pub const fn weighted(weight: f64) -> Self {
        Self {
            weight,
            gate: None,
            scale: 1.0,
        }
    }
}

/// The pair-cost terms and their weights (unless said otherwise, a term's default weight is 0,
/// i.e. off: on MOT15 boxes, adding centre distance, GIoU, size or Mahalanobis terms to IoU
/// lowered HOTA). Geometry and motion terms are built in; the
/// appearance terms (shape context, colour, SIFT) are registered by their modules with the
/// weights given here, and drop out for pairs they have no data for (box mode).
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Terms {
    /// `1 − IoU` between the Kalman-predicted box and the detection. `scale` is a buffer: both
    /// boxes are grown by `(scale − 1)/2` of their size on each side before the IoU (C-BIoU),
    /// which keeps fast or low-frame-rate motion overlapping; 1 = plain IoU. Default weight 1,
    /// scale 1 (buffering lowered HOTA on MOT15).
    pub iou: TermConfig,
    /// `1 − IoU` between the track's last observed box and the detection (OC-SORT's
    /// observation-centric recovery): finds a lost track where it was last seen.
    pub last_iou: TermConfig,
    /// `(1 − GIoU)/2` between the predicted box and the detection: like IoU, but still graded
    /// when the boxes do not overlap.
    pub giou: TermConfig,
    /// `1 − |D ∩ P| / |D|`: how much of the detection's box `D` lies outside the predicted box
    /// `P` grown by `(scale − 1)/2` of its size on each side. A partly hidden shape (a sliver
    /// emerging from behind an occluder) lies inside its whole predicted box even though their
    /// IoU is small. Default weight 0.
    pub ioa: TermConfig,
    /// Centre distance over `scale` times the predicted box's diagonal, clipped to 1.
    pub centre: TermConfig,
    /// Size change `|ln(w'/w)| + |ln(h'/h)|` over `scale`, clipped to 1.
    pub size: TermConfig,
    /// Squared Mahalanobis distance under the Kalman innovation covariance, over `scale`
    /// (χ² units; 9.4877 is the 95 % point for 4 degrees of freedom), clipped to 1.
    pub mahalanobis: TermConfig,
    /// `1 − mask IoU` between the track's last mask moved by its predicted motion and the
    /// detection's mask; no data in box mode. Default weight 1.
    pub mask_iou: TermConfig,
    /// Thesis C1, the shape context cost (w_a = 0.5, eq. 39). Registered by the shape context
    /// module.
    pub shape_context: TermConfig,
    /// Thesis C2, the spatial colour cost (w_b = 0.5, eq. 39). Registered by the colour module.
    pub colour: TermConfig,
    /// SIFT match cost (fraction of unmatched keypoints). Registered by the SIFT module.
    pub sift: TermConfig,
}

impl Default for Terms {
    fn default() -> Self {
        Self {
            iou: TermConfig {
                weight: 1.0,
                gate: None,
                scale: 1.0,
            },
            last_iou: TermConfig::weighted(0.0),
            giou: TermConfig::weighted(0.0),
            ioa: TermConfig::weighted(0.0),
            centre: TermConfig {
                weight: 0.0,
                gate: None,
                scale: 1.0,
            },
            size: TermConfig {
                weight: 0.0,
                gate: None,
                scale: 1.0,
            },
            mahalanobis: TermConfig {
                weight: 0.0,
                gate: None,
                scale: crate::motion::CHI2_95_4DOF,
            },
            mask_iou: TermConfig::weighted(1.0),
            shape_context: TermConfig::weighted(0.5),
            colour: TermConfig::weighted(0.5),
            sift: TermConfig::weighted(0.0),
        }
    }
}

impl Terms {
    /// Default terms of the re-identification stage: IoU with the track's last observed box
    /// (OC-SORT's recovery), and appearance when available. Centre-distance and size terms
    /// exist but are off: on MOT15 they re-identified the wrong person more often than the
    /// right one.
    pub fn reid_default() -> Self {
        Self {
            iou: TermConfig::weighted(0.0),
            last_iou: TermConfig::weighted(1.0),
            mask_iou: TermConfig::weighted(0.0),
            ..Self::default()
        }
    }

    /// Every term with its name, in a fixed order.
    pub fn named(&self) -> [(&'static str, &TermConfig); 11] {
        [
            ("iou", &self.iou),
            ("last_iou", &self.last_iou),
            ("giou", &self.giou),
            ("ioa", &self.ioa),
            ("centre", &self.centre),
            ("size", &self.size),
            ("mahalanobis", &self.mahalanobis),
            ("mask_iou", &self.mask_iou),
            ("shape_context", &self.shape_context),
            ("colour", &self.colour),
            ("sift", &self.sift),
        ]
    }
}
