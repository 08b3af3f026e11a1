//! The prepare phase: a frame's detections checked (typed errors before any state changes),
//! clipped to the frame, filtered, split into high and low confidence, and given their cheap
//! [`Features`] once.

use std::borrow::Cow;

use super::cost::Candidate;
use super::features::{FeatureExtractor, Features};
use super::TrackError;
use crate::frame::{Detection, Frame, TrackState, TrackedShape};

/// Largest box coordinate or size accepted (pixels): far beyond any image, far below overflow
/// (squaring 1e300 in an area or a covariance would overflow).
const MAX_COORDINATE: f64 = 1e9;

/// A detection that survived the prepare phase (its mask clipped to the frame when needed).
pub(crate) struct Prepared<'a> {
    /// Index in the frame's input slice.
    pub(crate) index: usize,
    /// The detection (borrowed unless clipping or fragment merging changed it).
    pub(crate) det: Cow<'a, Detection>,
    /// Its cheap features, and its appearance once described.
    pub(crate) features: Features,
    /// Whether it counts as a high-confidence detection (see
    /// [`Config::high_score`](super::Config::high_score)).
    pub(crate) high: bool,
}

impl Prepared<'_> {
    /// The detection as the pair-cost terms see it.
    pub(crate) fn candidate(&self) -> Candidate<'_> {
        Candidate {
            index: self.index,
            detection: &self.det,
            features: Some(&self.features),
        }
    }
}

/// Checks every detection: finite boxes within ±[`MAX_COORDINATE`], sizes ≥ 0, finite scores.
pub(crate) fn validate(detections: &[Detection]) -> Result<(), TrackError> {
    if detections.len() > super::MAX_DETECTIONS {
        return Err(TrackError::TooManyDetections {
            count: detections.len(),
            max: super::MAX_DETECTIONS,
        });
    }
    for (index, det) in detections.iter().enumerate() {
        let b = det.bbox;
        for (field, value) in [
            ("bbox.x", b.x),
            ("bbox.y", b.y),
            ("bbox.w", b.w),
            ("bbox.h", b.h),
        ] {
            if !(value.is_finite() && value.abs() <= MAX_COORDINATE) {
                return Err(TrackError::InvalidDetection {
                    index,
                    field,
                    value,
                    expected: "a finite number within ±1e9",
                });
            }
        }
        for (field, value) in [("bbox.w", b.w), ("bbox.h", b.h)] {
            if value < 0.0 {
                return Err(TrackError::InvalidDetection {
                    index,
                    field,
                    value,
                    expected: "a size ≥ 0",
                });
            }
        }
        if !det.score.is_finite() {
            return Err(TrackError::InvalidDetection {
                index,
                field: "score",
                value: det.score,
                expected: "a finite number",
            });
        }
    }
    Ok(())
}

/// A frame of another size than the earlier ones (`expected`) is an error.
pub(crate) fn check_frame_size(
    frame: Option<&Frame<'_>>,
    expected: Option<(u32, u32)>,
) -> Result<(), TrackError> {
    let size = frame.map(|f| (f.width(), f.height()));
    if let (Some((width, height)), Some((expected_width, expected_height))) = (size, expected) {
        if (width, height) != (expected_width, expected_height) {
            return Err(TrackError::FrameSize {
                width,
                height,
                expected_width,
                expected_height,
            });
        }
    }
    Ok(())
}

/// Whether a valid detection takes part at all: it scores at least `min_score` and has an
/// area (zero-area boxes carry no overlap information: they are skipped, not errors).
pub(crate) fn kept(det: &Detection, min_score: f64) -> bool {
    det.score >= min_score && det.bbox.w > 0.0 && det.bbox.h > 0.0
}

/// The detections of a frame, already [`validate`]d, that are [`kept`], clipped to the frame
/// (empty masks dropped), with their cheap features; those scoring at least `high_score` are
/// high.
pub(crate) fn prepare<'a>(
    detections: &'a [Detection],
    frame: Option<&Frame<'_>>,
    min_score: f64,
    high_score: f64,
    extractor: &dyn FeatureExtractor,
) -> Result<Vec<Prepared<'a>>, TrackError> {
    let mut out = Vec::with_capacity(detections.len());
    for (index, det) in detections.iter().enumerate() {
        if !kept(det, min_score) {
            continue;
        }
        let Some(det) = clip_to_frame(det, frame) else {
            continue;
        };
        let features = extractor
            .extract(frame, &det)
            .map_err(|message| TrackError::Features { index, message })?;
        let high = det.score >= high_score;
        out.push(Prepared {
            index,
            det,
            features,
            high,
        });
    }
    Ok(out)
}

/// A mask detection reaching outside the frame, clipped to it (`None` when nothing is left);
/// detections inside the frame, box detections and frame-less calls are passed through.
/// An empty mask is dropped: it carries no shape.
fn clip_to_frame<'a>(det: &'a Detection, frame: Option<&Frame<'_>>) -> Option<Cow<'a, Detection>> {
    let Some(m) = det.mask.as_ref() else {
        return Some(Cow::Borrowed(det));
    };
    if m.is_empty() {
        return None;
    }
    let Some(f) = frame else {
        return Some(Cow::Borrowed(det));
    };
    let (w, h) = (f.width() as i64, f.height() as i64);
    let inside = m.x() >= 0
        && m.y() >= 0
        && m.x() as i64 + m.width() as i64 <= w
        && m.y() as i64 + m.height() as i64 <= h;
    if inside {
        return Some(Cow::Borrowed(det));
    }
    let clipped = m.clipped(f.width(), f.height());
    if clipped.is_empty() {
        return None;
    }
    Some(Cow::Owned(Detection {
        bbox: clipped.bbox(),
        mask: Some(clipped),
        score: det.score,
        class: det.class,
    }))
}

/// The shape reported for detection `d` matched to track `id` in tracker frame `frame`.
pub(super) fn shape_of(
    frame: u32,
    id: u64,
    state: TrackState,
    d: &Prepared<'_>,
    cost: f64,
) -> TrackedShape {
    TrackedShape {
        id,
        frame,
        bbox: d.det.bbox,
        mask: d.det.mask.clone(),
        centroid: d.features.centroid,
        state,
        score: d.det.score,
        class: d.det.class,
        cost,
        det_index: Some(d.index),
        interpolated: false,
    }
}
