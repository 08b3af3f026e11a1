//! Measured statistics of a scene ([`SceneStats`]): how crowded it is, how visible its
//! objects are, and how long the detector loses them. They compare a synthetic family with
//! the real scene it imitates (the dense-crowd family with issue 64's crowd) and let tests
//! hold a family to its description.

use super::{Scene, SynthConfig, SynthError};
use serde::Serialize;
use std::collections::BTreeMap;

/// Statistics of a scene's amodal ground truth ([`super::SynthFrame::silhouettes`]: every
/// object in view, hidden or not) and of its own detections
/// ([`super::SynthFrame::detection_sources`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SceneStats {
    /// Frames measured.
    pub frames: u32,
    /// Objects in view per frame, mean.
    pub objects_mean: f64,
    /// Objects in view per frame, median.
    pub objects_median: f64,
    /// Visibility over every object in every frame: 10th, 25th, 50th, 75th and 90th
    /// percentiles.
    pub visibility_quantiles: [f64; 5],
    /// Share of object-frames with visibility 0 (fully hidden), in (0, 0.25), [0.25, 0.5),
    /// [0.5, 0.75) and [0.75, 1].
    pub visibility_histogram: [f64; 5],
    /// Share of object-frames in which the object is fully hidden.
    pub hidden_fraction: f64,
    /// Share of object-frames without a detection of the object.
    pub missed_fraction: f64,
    /// Share missed among object-frames of visibility < 0.35, [0.35, 0.7) and ≥ 0.7.
    pub missed_by_visibility: [f64; 3],
    /// Runs of consecutive frames without a detection between two detections of the same
    /// object: how many.
    pub gaps: usize,
    /// Their median length (frames).
    pub gap_median: f64,
    /// Their 90th percentile length (frames).
    pub gap_p90: f64,
    /// Frames each object is in view, median.
    pub track_length_median: f64,
}

/// The `q`-quantile (nearest rank) of sorted values; 0 for none.
fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let k = ((q * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
    sorted[k - 1]
}

fn share(n: usize, of: usize) -> f64 {
    if of == 0 {
        0.0
    } else {
        n as f64 / of as f64
    }
}

impl SceneStats {
    /// Renders the scene of `cfg` and measures it.
    pub fn measure(cfg: &SynthConfig) -> Result<SceneStats, SynthError> {
        let scene = Scene::new(cfg.clone())?;
        let mut counts = Vec::new();
        let mut vis = Vec::new();
        // Per object: frames in view, and whether it was detected in each.
        let mut seen: BTreeMap<u64, Vec<bool>> = BTreeMap::new();
        let (mut missed, mut by_vis) = (0usize, [(0usize, 0usize); 3]);
        for f in scene {
            counts.push(f.silhouettes.len() as f64);
            for s in &f.silhouettes {
                let detected = f.detection_sources.contains(&Some(s.id));
                vis.push(s.visibility);
                missed += usize::from(!detected);
                let bin = match s.visibility {
                    v if v < 0.35 => 0,
                    v if v < 0.7 => 1,
                    _ => 2,
                };
                by_vis[bin].0 += usize::from(!detected);
                by_vis[bin].1 += 1;
                seen.entry(s.id).or_default().push(detected);
            }
        }
        let n = vis.len();
        vis.sort_by(f64::total_cmp);
        let mut sorted_counts = counts.clone();
        sorted_counts.sort_by(f64::total_cmp);
        let mut hist = [0usize; 5];
        for &v in &vis {
            let bin = if v <= 0.0 {
                0
            } else {
                1 + ((v / 0.25) as usize).min(3)
            };
            hist[bin] += 1;
        }
        let mut gaps = Vec::new();
        let mut lengths = Vec::new();
        for frames in seen.values() {
            lengths.push(frames.len() as f64);
            let (mut run, mut started) = (0usize, false);
            for &d in frames {
                if d {
                    if started && run > 0 {
                        gaps.push(run as f64);
                    }
                    started = true;
                    run = 0;
                } else {
                    run += 1;
                }
            }
        }
        gaps.sort_by(f64::total_cmp);
        lengths.sort_by(f64::total_cmp);
        Ok(SceneStats {
            frames: counts.len() as u32,
            objects_mean: counts.iter().sum::<f64>() / counts.len().max(1) as f64,
            objects_median: quantile(&sorted_counts, 0.5),
            visibility_quantiles: [0.1, 0.25, 0.5, 0.75, 0.9].map(|q| quantile(&vis, q)),
            visibility_histogram: hist.map(|k| share(k, n)),
            hidden_fraction: share(hist[0], n),
            missed_fraction: share(missed, n),
            missed_by_visibility: by_vis.map(|(m, of)| share(m, of)),
            gaps: gaps.len(),
            gap_median: quantile(&gaps, 0.5),
            gap_p90: quantile(&gaps, 0.9),
            track_length_median: quantile(&lengths, 0.5),
        })
    }
}
