//! The presets: [`Config::masks`] for instance masks with frames (the defaults,
//! [`Config::default`], are for boxes).

use super::config::{Config, TermConfig, Terms};
use super::features::AppearanceConfig;

impl Config {
    /// The preset for instance masks with frames (synthetic scenes, MOTS, DAVIS): the
    /// defaults with the changes below, chosen on the mask cells of the robustness grid (the
    /// synthetic families under clean and ragged masks, and BDD100K's model masks; see
    /// `tests/data/quality/README.md`).
    ///
    /// - Geometry and motion: box IoU (weight 1) and IoA (0.5) with the (amodal) predicted
    ///   box, and mask IoU (1) with the last mask moved by the predicted motion; in groups of
    ///   competing pairs geometry cannot decide, colour C2 joins them (weight 0.5, thesis
    ///   eq. 39). Shape context C1 is off in the association: on the grid's clean-mask cells
    ///   it decides nothing (identical scores), on ragged masks it gains 0.3–1.6 HOTA on four
    ///   families but costs 2.1 on non-rigid deformation, whose changing outline it reads as
    ///   another shape — the family where masks must beat box mode and keep one id per shape
    ///   (the ablation in `tests/data/quality/README.md`).
    /// - A detection is taken as partly hidden only below 0.4 of the track's reference area
    ///   (`appearance.whole_ratio`): shapes that deform change area by up to ±50 % while in
    ///   full view, and 0.85 read that as occlusion (and split them into several identities).
    /// - Lost tracks are matched only by re-identification (`lost_reid_only`), except in
    ///   the 8 frames after a whole view (`lost_main_frames`, the coasting span; mask cells:
    ///   mean HOTA 71.92 → 72.30, ragged crowds +3.0, ragged occluders −2.2): the detection
    ///   must lie inside the lost track's predicted box (grown by a quarter of its size on
    ///   each side, more with every missed frame: IoA gate 0.5), and its colours must be the
    ///   track's (reference view, gate 0.35); SIFT matches count too. At confirmation a new
    ///   track is checked against the lost ones (`reid_at_confirmation`). The colour gate was
    ///   0.5: a lost track then took a detector's false shape near its predicted place, hopped
    ///   from one stray detection to the next and coasted after each (mask cells, mean HOTA
    ///   73.21 → 73.74; chosen in every leave-one-family-out fold, held-out +0.53).
    /// - A view whose box is over 1.6 times the track's predicted box and covers most of an
    ///   unmatched neighbour's predicted box is the two shapes merged by the detector
    ///   (`appearance.merged_ratio`): it keeps the track alive without moving its filter.
    ///   Shapes deform by up to ±50 % and a merged pair of similar shapes is about twice one,
    ///   hence 1.6. Mask cells: mean HOTA +0.24 online and offline, ragged deformation +2.2 /
    ///   +2.6 (where the merged masks of touching shapes had swapped their identities),
    ///   ragged crowds, occluders and entering/leaving +0.3 to +0.7, ragged crossing −0.7 /
    ///   −0.9, the clean cells (no merged masks) unchanged. Box mode keeps it off: a box that
    ///   covers a neighbour's is usually an occlusion, not a merge (box grid −0.1).
    /// - Shapes hide behind occluders for up to ~2 s: `max_lost` 60 (at 30 fps). Masks given
    ///   without their frames have no colours to re-identify a shape by after so long: there
    ///   lost tracks follow box mode's rules (`max_lost_without_frames` = the defaults' 38, and
    ///   `lost_reid_only` off; see [`Config::without_frames`]).
    /// - Detector-split masks are merged (`merge_fragments`); missed detections right after a
    ///   whole view are coasted over for 8 frames (`coast_frames`, always: a mask seen whole
    ///   does not vanish).
    /// - Confirmed after 8 matches (by evidence, as the defaults: up to 16 frames of low
    ///   scores), tolerating up to 5 frames in a row without a match while tentative (at 30
    ///   fps; 2 at 10 fps, 1 at 5 fps, see [`Config::max_tentative_misses`]). With the
    ///   defaults' single miss, a shape entering through a detector that misses it every few
    ///   frames started over at each double miss and was never confirmed (a clean crossing
    ///   sequence: one shape untracked for its last 40 frames). Mask cells: mean HOTA +0.15
    ///   online, +0.28 offline, BDD100K's 5 fps masks unchanged; leave one family out over 1–8
    ///   misses: 5 or 6 chosen in 6 of 7 folds, held-out +0.11. Box mode keeps 1 (3 or 5
    ///   there: MOT15 −0.2 to −0.5, SportsMOT −0.3 to −0.9). Until then a tentative track
    ///   waits for its own stage, except that a confirmed track defers to it for a detection
    ///   it matches more cheaply by over 0.1 (`defer_to_tentative`): a shape sliding behind a
    ///   new one no longer takes the new one's view and swaps with it (mask cells: mean HOTA
    ///   +0.11 online and offline, chosen in 6 of 7 leave-one-dataset-out folds, held-out
    ///   +0.09; box cells keep it off).
    /// - The main gate scales with the frame interval: 0.54 at 30 fps (0.65 at 25 fps), the
    ///   defaults' 0.75 from 22 fps down (`reference_max_cost`). A gate of 0.75 lets a track
    ///   whose ragged 25 fps mask was missed take a split piece or a neighbour (mask cells,
    ///   mean HOTA 72.41 → 73.19, ragged crossing +4.1 online), while at 5 fps (BDD100K's
    ///   masks) true matches cost more and a fixed 0.65 lost 1.9 HOTA.
    pub fn masks() -> Self {
        let base = Self::default();
        Self {
            high_score: 0.3,
            new_track_score: 0.5,
            min_hits: 8,
            appearance: AppearanceConfig {
                whole_ratio: 0.4,
                merged_ratio: Some(1.6),
                ..AppearanceConfig::default()
            },
            max_tentative_misses: 5,
            max_lost: 60,
            max_lost_without_frames: Some(base.max_lost),
            reference_max_cost: Some(0.54),
            // Masks with frames: the gate from the sequence's own matches changes the grid's
            // mask cells by −0.14 to +0.03 HOTA (tests/data/quality/README.md); the fixed gate
            // stays.
            adaptive_gate: None,
            coast_frames: 8,
            coasting: None,
            reid_at_confirmation: true,
            merge_fragments: true,
            lost_reid_only: true,
            lost_main_frames: 8,
            defer_to_tentative: Some(0.1),
            // Chosen without it; on the mask cells it gains on ragged masks and loses
            // BDD100K's real masks to ByteTrack (59.8 vs 60.4), so the preset keeps it off.
            reupdate_after_gap: false,
            terms: Terms {
                iou: TermConfig::weighted(1.0),
                ioa: TermConfig::weighted(0.5),
                mask_iou: TermConfig::weighted(1.0),
                shape_context: TermConfig::weighted(0.0),
                colour: TermConfig::weighted(0.5),
                ..Terms::default()
            },
            reid_terms: Terms {
                iou: TermConfig::weighted(0.0),
                mask_iou: TermConfig::weighted(0.0),
                ioa: TermConfig {
                    weight: 1.0,
                    gate: Some(0.5),
                    scale: 1.5,
                },
                shape_context: TermConfig::weighted(0.0),
                colour: TermConfig {
                    weight: 1.0,
                    gate: Some(0.35),
                    scale: 1.0,
                },
                sift: TermConfig::weighted(0.5),
                ..Terms::default()
            },
            ..base
        }
    }
}
