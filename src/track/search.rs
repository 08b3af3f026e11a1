//! Which (track, detection) pairs a frame compares at all: the region estimate (thesis Alg. 2)
//! over the tracks and detections each association needs, in the indices of the frame's
//! lists. Box mode meets the predicted boxes grown by a margin with the detections' boxes
//! ([`super::regions::estimate_regions`]); with masks, each track's search shell
//! (`Track::search_shell`) meets the detections' shells by GJK
//! ([`crate::region::region_clusters`]).
//!
//! The frame's regions leave out the lost tracks that only re-identification looks for
//! ([`in_frame_regions`]); the re-identification stage estimates theirs when its turn comes,
//! against the detections still free then ([`reid_regions`]).

use std::borrow::Cow;

use super::associate::in_main;
use super::config::Config;
use super::lifecycle::Track;
use super::prepare::Prepared;
use super::regions::{estimate_regions, Regions};
use crate::frame::{BBox, TrackState};
use crate::geometry::ConvexShell;
use crate::region::region_clusters;

/// Margin factor of a track's search region: grows while it is unmatched.
fn margin_factor(config: &Config, t: &Track) -> f64 {
    config.region_margin + config.region_margin_per_miss * t.misses() as f64
}

/// Whether the frame's regions ([`frame_regions`]) take `track` in: every track but the lost
/// ones only re-identification looks for ([`Config::lost_reid_only`], on a frame given with
/// its image), whose regions the reid stage estimates against the detections still free
/// when its turn comes ([`reid_regions`]).
///
/// Why (issue 10): a lost track's search region widens with every missed frame
/// ([`Config::region_margin_per_miss`]), and in a crowd the lost tracks' pairs were most of
/// the frame's (on the 200-shape bench, 2,500 of 3,800 pairs after 100 frames), each one a
/// GJK test and the main association's geometric costs, though no main stage offers these
/// tracks. Only a detection that the main association leaves free can be re-identified.
pub(crate) fn in_frame_regions(config: &Config, track: &Track, has_frame: bool) -> bool {
    !has_frame || in_main(config, track)
}

/// The frame's regions: the tracks [`in_frame_regions`] takes in, every detection.
pub(crate) fn frame_regions(
    config: &Config,
    tracks: &[Track],
    dets: &[Prepared<'_>],
    has_frame: bool,
) -> Regions {
    let ti: Vec<usize> = (0..tracks.len())
        .filter(|&i| in_frame_regions(config, &tracks[i], has_frame))
        .collect();
    let di: Vec<usize> = (0..dets.len()).collect();
    regions_of(config, tracks, dets, &ti, &di)
}

/// The re-identification stage's regions: the lost tracks no stage has taken (`used_tracks`)
/// and the high detections still free (`used_dets`); `None` when either set is empty (no
/// region estimate, nothing allocated).
pub(crate) fn reid_regions(
    config: &Config,
    tracks: &[Track],
    dets: &[Prepared<'_>],
    used_tracks: &[bool],
    used_dets: &[bool],
) -> Option<Regions> {
    let taken = |used: &[bool], i: usize| used.get(i).copied().unwrap_or(true);
    let lost_free = |i: usize| tracks[i].state() == TrackState::Lost && !taken(used_tracks, i);
    let free_high = |j: usize| dets[j].high && !taken(used_dets, j);
    if !(0..tracks.len()).any(lost_free) || !(0..dets.len()).any(free_high) {
        return None;
    }
    let ti: Vec<usize> = (0..tracks.len()).filter(|&i| lost_free(i)).collect();
    let di: Vec<usize> = (0..dets.len()).filter(|&j| free_high(j)).collect();
    Some(regions_of(config, tracks, dets, &ti, &di))
}

/// Which pairs are close enough to compare (thesis Alg. 2) between the tracks `ti` and the
/// detections `di` (ascending indices), in the indices of the full lists: boxes in box mode,
/// shells by GJK as soon as a detection or a track has a shell.
fn regions_of(
    config: &Config,
    tracks: &[Track],
    dets: &[Prepared<'_>],
    ti: &[usize],
    di: &[usize],
) -> Regions {
    let everything = ti.len() == tracks.len() && di.len() == dets.len();
    let shells_mode = dets.iter().any(|d| d.features.shell.is_some())
        || tracks
            .iter()
            .any(|t| t.features().is_some_and(|f| f.shell.is_some()));
    let regions = if !shells_mode {
        let shells: Vec<BBox> = ti
            .iter()
            .map(|&i| {
                let t = &tracks[i];
                let f = margin_factor(config, t);
                let p = t.predicted_box();
                BBox::from_center(p.center(), p.w * (1.0 + 2.0 * f), p.h * (1.0 + 2.0 * f))
            })
            .collect();
        let det_shells: Vec<BBox> = di.iter().map(|&j| dets[j].det.bbox).collect();
        estimate_regions(&shells, &det_shells)
    } else {
        let track_shells: Vec<ConvexShell> = ti
            .iter()
            .map(|&i| tracks[i].search_shell(margin_factor(config, &tracks[i])))
            .collect();
        // Borrowed where the detection has its shell (no copy per detection and frame).
        let det_shells: Vec<Cow<'_, ConvexShell>> = di
            .iter()
            .map(|&j| match &dets[j].features.shell {
                Some(s) => Cow::Borrowed(s.as_ref()),
                None => Cow::Owned(ConvexShell::from_bbox(&dets[j].det.bbox).unwrap_or_default()),
            })
            .collect();
        Regions::from(region_clusters(&track_shells, &det_shells))
    };
    if everything {
        regions
    } else {
        regions.remapped(ti, di)
    }
}
