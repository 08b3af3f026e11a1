//! The region estimator in box mode (thesis ch. 3.3, Alg. 2): which (track, detection) pairs
//! are close enough to be compared at all, and the clusters they form.
//!
//! The thesis tests every pair of convex shells with GJK and groups intersecting pairs into
//! region clusters (the connected components of the bipartite "intersects" graph). For
//! axis-aligned boxes the GJK test *is* the interval-overlap test, so in box mode the shells are
//! the tracks' predicted boxes grown by a margin and the detections' boxes, and a sort-and-sweep
//! broad phase on x keeps the search O((n + m) log m + pairs) instead of O(n·m).
//!
//! The mask pipeline swaps [`estimate_regions`] for [`crate::region::region_clusters`] on
//! convex shells (converted with `Regions::from`); the tracker only depends on [`Regions`].

use std::sync::Arc;

use crate::frame::BBox;
use crate::region::cap_candidates;
pub use crate::region::MAX_CANDIDATES;

/// A region cluster: tracks and detections connected through intersecting shells.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Cluster {
    /// Track indices, ascending.
    pub tracks: Vec<usize>,
    /// Detection indices, ascending.
    pub dets: Vec<usize>,
}

/// The candidate pairs and their clusters.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Regions {
    /// `(track, detection)` pairs whose shells intersect, sorted.
    pub pairs: Vec<(usize, usize)>,
    /// The cluster index of each pair (same order as `pairs`).
    pub pair_cluster: Vec<usize>,
    /// Clusters with at least one pair, ordered by their smallest track index. Shared: the
    /// association's subsets of the pairs keep the clusters, and a copy was two allocations
    /// per cluster and frame (issue 10).
    pub clusters: Arc<[Cluster]>,
}

impl From<crate::region::RegionEstimate> for Regions {
    /// The region clusters of the mask pipeline (GJK on convex shells) in the tracker's form.
    fn from(e: crate::region::RegionEstimate) -> Self {
        let n = e.pairs.iter().map(|p| p.0 + 1).max().unwrap_or(0);
        let mut cluster_of_track = vec![usize::MAX; n];
        for (k, c) in e.clusters.iter().enumerate() {
            for &t in &c.tracks {
                if let Some(slot) = cluster_of_track.get_mut(t) {
                    *slot = k;
                }
            }
        }
        // Every pair's track belongs to exactly one cluster (clusters partition the graph).
        let pair_cluster = e
            .pairs
            .iter()
            .map(|&(t, _)| cluster_of_track.get(t).copied().unwrap_or(0))
            .collect();
        Regions {
            pairs: e.pairs,
            pair_cluster,
            clusters: e
                .clusters
                .into_iter()
                .map(|c| Cluster {
                    tracks: c.tracks,
                    dets: c.detections,
                })
                .collect::<Vec<_>>()
                .into(),
        }
    }
}

impl Regions {
    /// These regions, estimated on subsets of the tracks and detections (indices into
    /// `tracks` and `dets`, each ascending), in the indices of the full lists: the pairs stay
    /// sorted and the clusters in the order of their smallest track. In place: no allocation
    /// (the clusters were just built, so nothing else shares them).
    pub(crate) fn remapped(mut self, tracks: &[usize], dets: &[usize]) -> Self {
        let t = |i: usize| tracks.get(i).copied().unwrap_or(usize::MAX);
        let d = |j: usize| dets.get(j).copied().unwrap_or(usize::MAX);
        for p in &mut self.pairs {
            *p = (t(p.0), d(p.1));
        }
        let remap = |c: &mut Cluster| {
            c.tracks.iter_mut().for_each(|i| *i = t(*i));
            c.dets.iter_mut().for_each(|j| *j = d(*j));
        };
        match Arc::get_mut(&mut self.clusters) {
            Some(clusters) => clusters.iter_mut().for_each(remap),
            None => {
                let mut clusters = self.clusters.to_vec();
                clusters.iter_mut().for_each(remap);
                self.clusters = clusters.into();
            }
        }
        self
    }
}

/// Strict overlap of two boxes with positive area; zero-size shells meet nothing.
fn meets(a: &BBox, b: &BBox) -> bool {
    a.overlaps(b)
}

/// Finds the pairs of intersecting shells between `track_shells` (predicted boxes, already grown
/// by their margin) and `det_shells`, and groups them into region clusters.
pub fn estimate_regions(track_shells: &[BBox], det_shells: &[BBox]) -> Regions {
    // Sort detections by left edge; a track can only meet detections whose left edge lies in
    // [track.x − widest detection, track.x2), found by two binary searches.
    let mut order: Vec<usize> = (0..det_shells.len())
        .filter(|&i| det_shells[i].is_valid())
        .collect();
    order.sort_by(|&a, &b| det_shells[a].x.total_cmp(&det_shells[b].x));
    let lefts: Vec<f64> = order.iter().map(|&i| det_shells[i].x).collect();
    let widest = order.iter().map(|&i| det_shells[i].w).fold(0.0, f64::max);

    let mut pairs = Vec::new();
    let mut cands = Vec::new();
    for (ti, t) in track_shells.iter().enumerate() {
        if !t.is_valid() {
            continue;
        }
        let lo = lefts.partition_point(|&x| x < t.x - widest);
        let hi = lefts.partition_point(|&x| x < t.x2());
        cands.clear();
        cands.extend(
            order[lo..hi.max(lo)]
                .iter()
                .copied()
                .filter(|&di| meets(t, &det_shells[di])),
        );
        cap_candidates(&mut cands, t.center(), |i| det_shells[i].center());
        pairs.extend(cands.iter().map(|&di| (ti, di)));
    }
    pairs.sort_unstable();

    // Connected components over tracks 0..n and detections n..n+m.
    let n = track_shells.len();
    let mut parent: Vec<usize> = (0..n + det_shells.len()).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    for &(t, d) in &pairs {
        let (a, b) = (find(&mut parent, t), find(&mut parent, n + d));
        if a != b {
            parent[a] = b;
        }
    }
    let mut cluster_of_root = vec![usize::MAX; parent.len()];
    let mut clusters: Vec<Cluster> = Vec::new();
    let mut pair_cluster = Vec::with_capacity(pairs.len());
    for &(t, _) in &pairs {
        let r = find(&mut parent, t);
        if cluster_of_root[r] == usize::MAX {
            cluster_of_root[r] = clusters.len();
            clusters.push(Cluster::default());
        }
        pair_cluster.push(cluster_of_root[r]);
    }
    for i in 0..parent.len() {
        let r = find(&mut parent, i);
        let k = cluster_of_root[r];
        if let Some(c) = clusters.get_mut(k) {
            if i < n {
                c.tracks.push(i);
            } else {
                c.dets.push(i - n);
            }
        }
    }
    Regions {
        pairs,
        pair_cluster,
        clusters: clusters.into(),
    }
}

// proptest does not build for wasm32 (`wasm-pack test` builds unit tests there too).
#[cfg(all(test, not(target_arch = "wasm32")))]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn brute(tracks: &[BBox], dets: &[BBox]) -> Vec<(usize, usize)> {
        let mut v = Vec::new();
        for (i, t) in tracks.iter().enumerate() {
            for (j, d) in dets.iter().enumerate() {
                if t.overlaps(d) {
                    v.push((i, j));
                }
            }
        }
        v
    }

    fn boxes(n: usize) -> impl Strategy<Value = Vec<BBox>> {
        proptest::collection::vec(
            (0.0f64..100.0, 0.0f64..100.0, 0.0f64..30.0, 0.0f64..30.0)
                .prop_map(|(x, y, w, h)| BBox::new(x, y, w, h)),
            0..n,
        )
    }

    proptest! {
        #[test]
        fn sweep_finds_exactly_the_overlapping_pairs(t in boxes(12), d in boxes(12)) {
            let r = estimate_regions(&t, &d);
            prop_assert_eq!(&r.pairs, &brute(&t, &d));
            // Every pair lies in its cluster, and clusters are disjoint.
            let mut seen_t = vec![false; t.len()];
            let mut seen_d = vec![false; d.len()];
            for c in r.clusters.iter() {
                for &i in &c.tracks { prop_assert!(!seen_t[i]); seen_t[i] = true; }
                for &j in &c.dets { prop_assert!(!seen_d[j]); seen_d[j] = true; }
            }
            for (&(ti, di), &k) in r.pairs.iter().zip(&r.pair_cluster) {
                prop_assert!(r.clusters[k].tracks.contains(&ti));
                prop_assert!(r.clusters[k].dets.contains(&di));
            }
        }
    }

    #[test]
    fn a_track_meets_at_most_the_nearest_candidates() {
        let t = [BBox::new(0.0, 0.0, 1000.0, 1000.0)];
        let d: Vec<BBox> = (0..200)
            .map(|k| BBox::new(500.0 + k as f64, 500.0, 10.0, 10.0))
            .collect();
        let r = estimate_regions(&t, &d);
        assert_eq!(r.pairs.len(), MAX_CANDIDATES);
        // The nearest to the track's centre (500, 500): detection centres 505, 506, ….
        assert!(r.pairs.iter().all(|&(_, j)| j < MAX_CANDIDATES));
    }

    #[test]
    fn chains_form_one_cluster() {
        let t = [
            BBox::new(0.0, 0.0, 10.0, 10.0),
            BBox::new(15.0, 0.0, 10.0, 10.0),
        ];
        let d = [
            BBox::new(8.0, 0.0, 10.0, 10.0),
            BBox::new(100.0, 0.0, 5.0, 5.0),
        ];
        let r = estimate_regions(&t, &d);
        assert_eq!(r.pairs, vec![(0, 0), (1, 0)]);
        assert_eq!(
            r.clusters[..],
            [Cluster {
                tracks: vec![0, 1],
                dets: vec![0]
            }]
        );
        let nan = [BBox::new(f64::NAN, 0.0, 1.0, 1.0)];
        assert!(estimate_regions(&nan, &d).pairs.is_empty());
    }
}
