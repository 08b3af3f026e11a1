//! Region clusters (thesis §3.3, Algorithm 2): which tracks and which new detections are close
//! enough to be compared at all.
//!
//! Each track's shell (moved by its predicted motion and grown by a margin, see
//! [`predicted_shell`]) is intersected with each detection's shell. Intersecting pairs are the
//! edges of a bipartite graph; its connected components are the region clusters, and only pairs
//! inside a cluster are scored and assigned.
//!
//! Beyond the thesis, whose double loop runs GJK on all `n·m` pairs, a sort-and-sweep broad
//! phase over the shells' bounding boxes sends only box-overlapping pairs to GJK; the result is
//! identical (a pair whose boxes are apart by more than [`TOUCH_TOLERANCE`] cannot intersect).

use std::borrow::Borrow;

use serde::{Deserialize, Serialize};

use crate::geometry::{overlapping_box_pairs, ConvexShell, PreparedShell, TOUCH_TOLERANCE};

/// One connected component of the track–detection intersection graph with at least one edge.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct RegionCluster {
    /// Track indices, ascending.
    pub tracks: Vec<usize>,
    /// Detection indices, ascending.
    pub detections: Vec<usize>,
    /// The intersecting `(track, detection)` pairs inside the cluster, sorted.
    pub pairs: Vec<(usize, usize)>,
}

/// The output of the region estimator.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct RegionEstimate {
    /// Clusters, ordered by their smallest track index.
    pub clusters: Vec<RegionCluster>,
    /// Every intersecting `(track, detection)` pair, sorted.
    pub pairs: Vec<(usize, usize)>,
    /// Tracks whose shell meets no detection, ascending.
    pub lone_tracks: Vec<usize>,
    /// Detections whose shell meets no track, ascending.
    pub lone_detections: Vec<usize>,
}

/// How candidate pairs are chosen before the GJK test.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum BroadPhase {
    /// Sort-and-sweep on bounding boxes; GJK on box-overlapping pairs only.
    #[default]
    SortAndSweep,
    /// GJK on every pair, as the thesis' Algorithm 2 (kept for comparison and benchmarks).
    AllPairs,
}

/// A track's search shell for the next frame: its last shell moved by the predicted
/// displacement `(dx, dy)` and grown by `margin`, so that a shape that moved a little more
/// than predicted, or a small shape whose shells would otherwise just miss, still meets its
/// next detection.
pub fn predicted_shell(shell: &ConvexShell, dx: f64, dy: f64, margin: f64) -> ConvexShell {
    shell.translated(dx, dy).grown(margin)
}

/// Like [`predicted_shell`], but covering the whole straight path from the last position to the
/// predicted one: for shapes that move more than their own size per frame, whose moved shell
/// would not overlap a detection found part-way.
pub fn swept_shell(shell: &ConvexShell, dx: f64, dy: f64, margin: f64) -> ConvexShell {
    shell.swept(dx, dy).grown(margin)
}

/// The region clusters of `tracks` (shells already predicted and grown) against `dets`, with
/// the sort-and-sweep broad phase. Deterministic: all lists are sorted as documented.
///
/// The shells may be owned or borrowed (`ConvexShell`, `&ConvexShell`, `Cow`): the tracker
/// passes its detections' shells without copying them.
pub fn region_clusters<T: Borrow<ConvexShell>, D: Borrow<ConvexShell>>(
    tracks: &[T],
    dets: &[D],
) -> RegionEstimate {
    region_clusters_with(tracks, dets, BroadPhase::SortAndSweep)
}

/// Most detections one track is compared with in a frame: the nearest ones (by centre) when
/// more shells meet its search region. Real scenes stay far below it (a crowd of 200 similar
/// shapes gives a handful per track); without it, thousands of stacked detections would make
/// tracks × detections pairs (gigabytes).
pub const MAX_CANDIDATES: usize = 64;

/// Keeps, of one track's candidate detections `cands`, the [`MAX_CANDIDATES`] whose centres
/// are nearest `centre` (ascending index order, so the result is as if only those had met).
pub(crate) fn cap_candidates(
    cands: &mut Vec<usize>,
    centre: crate::frame::Point,
    det_centre: impl Fn(usize) -> crate::frame::Point,
) {
    if cands.len() <= MAX_CANDIDATES {
        return;
    }
    let d2 = |i: usize| {
        let c = det_centre(i);
        (c.x - centre.x).powi(2) + (c.y - centre.y).powi(2)
    };
    cands.sort_by(|&a, &b| d2(a).total_cmp(&d2(b)).then(a.cmp(&b)));
    cands.truncate(MAX_CANDIDATES);
    cands.sort_unstable();
}

/// [`region_clusters`] with a chosen broad phase (both give the same result).
pub fn region_clusters_with<T: Borrow<ConvexShell>, D: Borrow<ConvexShell>>(
    tracks: &[T],
    dets: &[D],
    phase: BroadPhase,
) -> RegionEstimate {
    let pairs = intersecting_pairs(tracks, dets, phase);
    clusters_from_pairs(tracks.len(), dets.len(), &pairs)
}

/// The sorted `(track, detection)` pairs whose shells intersect (parry2d GJK).
pub fn intersecting_pairs<T: Borrow<ConvexShell>, D: Borrow<ConvexShell>>(
    tracks: &[T],
    dets: &[D],
    phase: BroadPhase,
) -> Vec<(usize, usize)> {
    let pt: Vec<PreparedShell> = tracks
        .iter()
        .map(|s| PreparedShell::new(s.borrow()))
        .collect();
    let pd: Vec<PreparedShell> = dets
        .iter()
        .map(|s| PreparedShell::new(s.borrow()))
        .collect();
    let candidates: Vec<(usize, usize)> = match phase {
        BroadPhase::SortAndSweep => {
            // Empty shells have a zero box at the origin; keep them out of the sweep.
            let boxes = |p: &[PreparedShell]| {
                p.iter()
                    .map(|s| {
                        if s.shell().is_empty() {
                            crate::frame::BBox::new(f64::NAN, f64::NAN, 0.0, 0.0)
                        } else {
                            s.aabb()
                        }
                    })
                    .collect::<Vec<_>>()
            };
            overlapping_box_pairs(&boxes(&pt), &boxes(&pd), TOUCH_TOLERANCE)
        }
        BroadPhase::AllPairs => (0..pt.len())
            .flat_map(|i| (0..pd.len()).map(move |j| (i, j)))
            .collect(),
    };
    // Per track, at most the nearest MAX_CANDIDATES, before GJK.
    let mut out = Vec::new();
    let mut cands = Vec::new();
    for group in candidates.chunk_by(|a, b| a.0 == b.0) {
        let i = group[0].0;
        cands.clear();
        cands.extend(group.iter().map(|&(_, j)| j));
        let centre = pt[i].aabb().center();
        cap_candidates(&mut cands, centre, |j| pd[j].aabb().center());
        out.extend(
            cands
                .iter()
                .filter(|&&j| pt[i].intersects_fast(&pd[j]))
                .map(|&j| (i, j)),
        );
    }
    out
}

/// Connected components of the bipartite graph with `n_tracks + n_dets` nodes and the given
/// `(track, detection)` edges. Out-of-range and duplicate pairs are ignored.
pub fn clusters_from_pairs(
    n_tracks: usize,
    n_dets: usize,
    pairs: &[(usize, usize)],
) -> RegionEstimate {
    let mut pairs: Vec<(usize, usize)> = pairs
        .iter()
        .copied()
        .filter(|&(t, d)| t < n_tracks && d < n_dets)
        .collect();
    pairs.sort_unstable();
    pairs.dedup();

    // Union–find over tracks 0..n_tracks then detections n_tracks..n_tracks+n_dets.
    let mut parent: Vec<usize> = (0..n_tracks + n_dets).collect();
    fn find(parent: &mut [usize], mut x: usize) -> usize {
        while parent[x] != x {
            parent[x] = parent[parent[x]];
            x = parent[x];
        }
        x
    }
    for &(t, d) in &pairs {
        let a = find(&mut parent, t);
        let b = find(&mut parent, n_tracks + d);
        if a != b {
            // Smaller root wins, so a component's root is its smallest node: its smallest
            // track (every component with an edge has one).
            let (lo, hi) = if a < b { (a, b) } else { (b, a) };
            parent[hi] = lo;
        }
    }

    let mut has_edge = vec![false; n_tracks + n_dets];
    for &(t, d) in &pairs {
        has_edge[t] = true;
        has_edge[n_tracks + d] = true;
    }
    // Map each root to its cluster index in order of first appearance over ascending tracks,
    // which is ascending smallest track.
    let mut cluster_of_root = vec![usize::MAX; n_tracks + n_dets];
    let mut clusters: Vec<RegionCluster> = Vec::new();
    let mut lone_tracks = Vec::new();
    for (t, &edge) in has_edge.iter().enumerate().take(n_tracks) {
        if !edge {
            lone_tracks.push(t);
            continue;
        }
        let r = find(&mut parent, t);
        if cluster_of_root[r] == usize::MAX {
            cluster_of_root[r] = clusters.len();
            clusters.push(RegionCluster::default());
        }
        clusters[cluster_of_root[r]].tracks.push(t);
    }
    let mut lone_detections = Vec::new();
    for d in 0..n_dets {
        if !has_edge[n_tracks + d] {
            lone_detections.push(d);
            continue;
        }
        let r = find(&mut parent, n_tracks + d);
        // Every detection with an edge shares its root with a track seen above.
        if let Some(c) = clusters.get_mut(cluster_of_root[r]) {
            c.detections.push(d);
        }
    }
    for &(t, d) in &pairs {
        let r = find(&mut parent, t);
        if let Some(c) = clusters.get_mut(cluster_of_root[r]) {
            c.pairs.push((t, d));
        }
    }
    RegionEstimate {
        clusters,
        pairs,
        lone_tracks,
        lone_detections,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::BBox;

    #[test]
    fn components_of_hand_made_pairs() {
        // Tracks 0..5, detections 0..6.
        // {t0, t2, d1, d3} via t0-d1, t2-d1, t2-d3; {t1, d0}; {t4, d4, d5}; lone t3, d2.
        let pairs = [
            (2, 3),
            (0, 1),
            (4, 5),
            (1, 0),
            (2, 1),
            (4, 4),
            (4, 4),
            (9, 0),
        ];
        let e = clusters_from_pairs(5, 6, &pairs);
        assert_eq!(
            e.pairs,
            vec![(0, 1), (1, 0), (2, 1), (2, 3), (4, 4), (4, 5)]
        );
        assert_eq!(
            e.clusters,
            vec![
                RegionCluster {
                    tracks: vec![0, 2],
                    detections: vec![1, 3],
                    pairs: vec![(0, 1), (2, 1), (2, 3)],
                },
                RegionCluster {
                    tracks: vec![1],
                    detections: vec![0],
                    pairs: vec![(1, 0)],
                },
                RegionCluster {
                    tracks: vec![4],
                    detections: vec![4, 5],
                    pairs: vec![(4, 4), (4, 5)],
                },
            ]
        );
        assert_eq!(e.lone_tracks, vec![3]);
        assert_eq!(e.lone_detections, vec![2]);
    }

    #[test]
    fn chain_through_detections_merges_tracks() {
        // t0-d0, t1-d0 → one cluster even though t0 and t1 never meet.
        let e = clusters_from_pairs(2, 1, &[(1, 0), (0, 0)]);
        assert_eq!(e.clusters.len(), 1);
        assert_eq!(e.clusters[0].tracks, vec![0, 1]);
        assert!(clusters_from_pairs(0, 0, &[]).clusters.is_empty());
    }

    #[test]
    fn shells_to_clusters() {
        let sq = |x: f64, y: f64| ConvexShell::from_bbox(&BBox::new(x, y, 10.0, 10.0)).unwrap();
        let tracks = [
            sq(0.0, 0.0),
            sq(100.0, 0.0),
            sq(200.0, 0.0),
            ConvexShell::empty(),
        ];
        let dets = [sq(105.0, 5.0), sq(3.0, 3.0), sq(500.0, 0.0), sq(195.0, 0.0)];
        for phase in [BroadPhase::SortAndSweep, BroadPhase::AllPairs] {
            let e = region_clusters_with(&tracks, &dets, phase);
            assert_eq!(e.pairs, vec![(0, 1), (1, 0), (2, 3)]);
            assert_eq!(e.clusters.len(), 3);
            assert_eq!(e.lone_tracks, vec![3]);
            assert_eq!(e.lone_detections, vec![2]);
        }
        // A track that moved 20 px right meets nothing unless predicted.
        let t = [predicted_shell(&sq(0.0, 50.0), 20.0, 0.0, 1.0)];
        let d = [sq(21.0, 50.0)];
        assert_eq!(region_clusters(&t, &d).pairs, vec![(0, 0)]);
        let s = [swept_shell(&sq(0.0, 50.0), 60.0, 0.0, 0.0)];
        assert_eq!(region_clusters(&s, &d).pairs, vec![(0, 0)]);
    }
}
