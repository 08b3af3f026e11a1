//! The grid's named detector models ([`profiles`]): fixed test conditions, each documented
//! with the real-world detector behaviour it imitates. Kept apart from the model's mechanics
//! because it is data, not code.

use super::{DetectorModel, FalsePositives, MaskNoise, MissModel, ScoreModel};

/// The grid's detector models (module docs): six for boxes, two for masks. Each line says
/// what it imitates; the numbers are test conditions, fixed before any tuning.
pub fn profiles() -> Vec<DetectorModel> {
    let base = |name: &str, scores| DetectorModel {
        scores,
        ..DetectorModel::exact(name)
    };
    vec![
        // A two-stage CNN detector on pedestrians, like MOT15's det.txt: confident scores,
        // misses in runs and under occlusion, moderate clutter, rare duplicates.
        DetectorModel {
            misses: MissModel {
                random: 0.10,
                burst: 4.0,
                occlusion: 0.6,
                small: 0.3,
                small_below: 0.5,
            },
            jitter: 0.04,
            false_positives: FalsePositives {
                far: 0.6,
                near: 0.3,
                persist: 0.5,
            },
            duplicate: 0.02,
            split: 0.01,
            ..base("mot15like", ScoreModel::HighNarrow)
        },
        // A single-stage detector with poorly separated scores and more clutter.
        DetectorModel {
            misses: MissModel {
                random: 0.10,
                burst: 3.0,
                occlusion: 0.5,
                small: 0.2,
                small_below: 0.5,
            },
            jitter: 0.05,
            false_positives: FalsePositives {
                far: 1.0,
                near: 0.4,
                persist: 0.3,
            },
            duplicate: 0.03,
            split: 0.02,
            ..base("wide", ScoreModel::Wide)
        },
        // A detector thresholded before the tracker (the browser's): every box scores 1,
        // small objects are often missed, clutter persists.
        DetectorModel {
            misses: MissModel {
                random: 0.12,
                burst: 5.0,
                occlusion: 0.5,
                small: 0.5,
                small_below: 0.5,
            },
            jitter: 0.06,
            false_positives: FalsePositives {
                far: 0.4,
                near: 0.2,
                persist: 0.7,
            },
            duplicate: 0.05,
            split: 0.02,
            ..base("const", ScoreModel::Constant(1.0))
        },
        // Low-calibrated scores (objectness × class probability) and much low-score clutter.
        DetectorModel {
            misses: MissModel {
                random: 0.10,
                burst: 3.0,
                occlusion: 0.5,
                small: 0.3,
                small_below: 0.5,
            },
            jitter: 0.05,
            false_positives: FalsePositives {
                far: 1.5,
                near: 0.5,
                persist: 0.3,
            },
            duplicate: 0.02,
            split: 0.02,
            ..base("low", ScoreModel::Low)
        },
        // Crowds: occluded and small people mostly missed, duplicates and split boxes where
        // people overlap (no effective non-maximum suppression).
        DetectorModel {
            misses: MissModel {
                random: 0.05,
                burst: 3.0,
                occlusion: 0.9,
                small: 0.6,
                small_below: 0.6,
            },
            jitter: 0.06,
            false_positives: FalsePositives {
                far: 0.3,
                near: 0.3,
                persist: 0.3,
            },
            duplicate: 0.10,
            split: 0.05,
            ..base("crowd", ScoreModel::Wide)
        },
        // A fast, imprecise detector on a low-resolution input: loose boxes and long runs of
        // misses (motion blur), boxes beside the object.
        DetectorModel {
            misses: MissModel {
                random: 0.20,
                burst: 8.0,
                occlusion: 0.3,
                small: 0.2,
                small_below: 0.5,
            },
            jitter: 0.12,
            false_positives: FalsePositives {
                far: 0.3,
                near: 0.6,
                persist: 0.2,
            },
            duplicate: 0.02,
            split: 0.0,
            ..base("jitter", ScoreModel::HighNarrow)
        },
        // An instance-segmentation model on clean footage: outlines off by a pixel or two,
        // few misses.
        DetectorModel {
            misses: MissModel {
                random: 0.05,
                burst: 2.0,
                occlusion: 0.3,
                ..MissModel::default()
            },
            false_positives: FalsePositives {
                far: 0.2,
                near: 0.0,
                persist: 0.3,
            },
            masks: Some(MaskNoise {
                morph: 0.3,
                morph_max: 2,
                ..MaskNoise::default()
            }),
            ..base("masks-clean", ScoreModel::Wide)
        },
        // A weak segmenter (or the background subtractor): ragged outlines, masks split at
        // thin parts and merged where objects touch, dropped frames, more misses.
        DetectorModel {
            misses: MissModel {
                random: 0.10,
                burst: 3.0,
                occlusion: 0.5,
                ..MissModel::default()
            },
            false_positives: FalsePositives {
                far: 0.5,
                near: 0.2,
                persist: 0.5,
            },
            masks: Some(MaskNoise {
                morph: 0.4,
                morph_max: 3,
                ragged: 0.5,
                split: 0.05,
                merge: 0.3,
            }),
            drop_frame: 0.03,
            ..base("masks-ragged", ScoreModel::HighNarrow)
        },
    ]
}

/// The profile named `name`.
pub fn profile(name: &str) -> Option<DetectorModel> {
    profiles().into_iter().find(|p| p.name == name)
}
