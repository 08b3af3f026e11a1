//! Whether a configuration's pair-cost terms can score any pair with the data a run has.
//!
//! [`Config::validate`] refuses a configuration whose every weight is 0. A term with a weight
//! can still be silent: the mask and appearance terms drop out of a pair they have no data for
//! (see [`crate::track::cost`]), so a run of boxes whose only weighted terms are `mask_iou`,
//! `shape_context` or `colour` scores no pair, matches nothing and ends with no track and no
//! error. [`Config::validate_for`] refuses that, naming the geometry weights at 0.

use super::config::{Config, ShapeVariant};
use super::TrackError;

/// The data a run gives the pair-cost terms.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunData {
    /// The detections carry masks (MOTS, Scalabel RLE); boxes otherwise.
    pub masks: bool,
    /// Frames are given (colour, SIFT and the SIFT shape variant read their pixels).
    pub images: bool,
}

/// The geometry terms: every pair of boxes gives them data.
const GEOMETRY: &str = "terms.{iou, last_iou, giou, ioa, centre, size, mahalanobis}.weight";

impl Config {
    /// Whether some term of the main association with a weight can score a pair given
    /// `data`.
    fn scores_with(&self, data: RunData) -> bool {
        let terms = &self.terms;
        let on = |t: &super::config::TermConfig| t.weight > 0.0;
        let geometry = [
            &terms.iou,
            &terms.last_iou,
            &terms.giou,
            &terms.ioa,
            &terms.centre,
            &terms.size,
            &terms.mahalanobis,
        ];
        let shape_images = self.shape_variant != ShapeVariant::Sift || data.images;
        geometry.into_iter().any(on)
            || (data.masks && on(&terms.mask_iou))
            || (data.masks && shape_images && on(&terms.shape_context))
            || (data.masks && data.images && (on(&terms.colour) || on(&terms.sift)))
    }

    /// [`Config::validate`], and a refusal when no weighted term of the main association
    /// has data in a run given `data`: every geometry term at 0 with boxes (the mask and
    /// appearance terms need masks), or with masks but no frames only colour or SIFT weighted.
    pub fn validate_for(&self, data: RunData) -> Result<(), TrackError> {
        self.validate()?;
        if self.scores_with(data) {
            return Ok(());
        }
        Err(TrackError::InvalidConfig {
            field: GEOMETRY.to_string(),
            value: 0.0,
            reason: if data.masks {
                "all 0, and the other weighted terms (colour, sift) read the frames, which this \
                 run has not: no track could ever be matched (give --frames or a geometry or \
                 mask term a weight > 0)"
            } else {
                "all 0, and the other weighted terms (mask_iou, shape_context, colour, sift) \
                 need masks, which these box detections have not: no track could ever be \
                 matched (give a geometry term a weight > 0)"
            },
        })
    }
}
