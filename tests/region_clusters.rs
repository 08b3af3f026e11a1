//! The region estimator: broad phase + GJK equals all-pairs GJK, and clusters are exactly the
//! connected components of the pair graph.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

mod common;

use common::*;
use proptest::prelude::*;
use shapetrack::geometry::ConvexShell;
use shapetrack::region::{
    clusters_from_pairs, intersecting_pairs, predicted_shell, region_clusters,
    region_clusters_with, BroadPhase, RegionEstimate,
};
use shapetrack::Point;

/// Many shells scattered over a `span`-sized field at an offset, some grown (as the tracker
/// does), some empty.
fn scene(max: usize) -> impl Strategy<Value = Vec<ConvexShell>> {
    (offset(), 20.0..400.0f64).prop_flat_map(move |(o, span)| {
        prop::collection::vec(((0.0..1.0f64, 0.0..1.0f64), 0.0..4.0f64, 0u8..20), 0..max)
            .prop_flat_map(move |v| {
                v.into_iter()
                    .map(|((fx, fy), m, kind)| {
                        shell_near(Point::new(o.x + fx * span, o.y + fy * span)).prop_map(
                            move |s| {
                                if kind == 0 {
                                    ConvexShell::empty()
                                } else if kind < 8 {
                                    s.grown(m)
                                } else {
                                    s
                                }
                            },
                        )
                    })
                    .collect::<Vec<_>>()
            })
    })
}

/// Reference components by breadth-first search over an adjacency list.
fn bfs_components(nt: usize, nd: usize, pairs: &[(usize, usize)]) -> Vec<(Vec<usize>, Vec<usize>)> {
    let mut adj = vec![Vec::new(); nt + nd];
    for &(t, d) in pairs {
        adj[t].push(nt + d);
        adj[nt + d].push(t);
    }
    let mut seen = vec![false; nt + nd];
    let mut comps = Vec::new();
    for s in 0..nt + nd {
        if seen[s] || adj[s].is_empty() {
            continue;
        }
        let (mut ts, mut ds) = (Vec::new(), Vec::new());
        let mut queue = vec![s];
        seen[s] = true;
        while let Some(u) = queue.pop() {
            if u < nt {
                ts.push(u);
            } else {
                ds.push(u - nt);
            }
            for &v in &adj[u] {
                if !seen[v] {
                    seen[v] = true;
                    queue.push(v);
                }
            }
        }
        ts.sort();
        ds.sort();
        comps.push((ts, ds));
    }
    comps.sort();
    comps
}

fn check_estimate(nt: usize, nd: usize, e: &RegionEstimate) -> Result<(), TestCaseError> {
    let mut got: Vec<(Vec<usize>, Vec<usize>)> = e
        .clusters
        .iter()
        .map(|c| (c.tracks.clone(), c.detections.clone()))
        .collect();
    // Deterministic order: by smallest track; members ascending; pairs partitioned.
    let firsts: Vec<usize> = e.clusters.iter().map(|c| c.tracks[0]).collect();
    prop_assert!(firsts.windows(2).all(|w| w[0] < w[1]));
    for c in &e.clusters {
        prop_assert!(c.tracks.windows(2).all(|w| w[0] < w[1]));
        prop_assert!(c.detections.windows(2).all(|w| w[0] < w[1]));
        for &(t, d) in &c.pairs {
            prop_assert!(c.tracks.contains(&t) && c.detections.contains(&d));
        }
    }
    let n_pairs: usize = e.clusters.iter().map(|c| c.pairs.len()).sum();
    prop_assert_eq!(n_pairs, e.pairs.len());
    got.sort();
    prop_assert_eq!(got, bfs_components(nt, nd, &e.pairs));
    let in_t: usize = e.clusters.iter().map(|c| c.tracks.len()).sum();
    let in_d: usize = e.clusters.iter().map(|c| c.detections.len()).sum();
    prop_assert_eq!(in_t + e.lone_tracks.len(), nt);
    prop_assert_eq!(in_d + e.lone_detections.len(), nd);
    Ok(())
}

proptest! {
    #![proptest_config(config(400))]

    /// Sort-and-sweep + GJK finds exactly the pairs that GJK on all pairs finds, and both agree
    /// with the brute-force polygon test outside the touching band.
    #[test]
    fn broad_phase_gives_same_pairs_as_all_pairs(tracks in scene(40), dets in scene(40)) {
        let sweep = intersecting_pairs(&tracks, &dets, BroadPhase::SortAndSweep);
        let all = intersecting_pairs(&tracks, &dets, BroadPhase::AllPairs);
        prop_assert_eq!(&sweep, &all);
        for (i, t) in tracks.iter().enumerate() {
            for (j, d) in dets.iter().enumerate() {
                let sd = signed_distance(t, d);
                if t.is_empty() || d.is_empty() || sd > PARRY_BAND {
                    prop_assert!(sweep.binary_search(&(i, j)).is_err());
                } else if sd < -PARRY_BAND {
                    prop_assert!(sweep.binary_search(&(i, j)).is_ok());
                }
            }
        }
        let e = region_clusters(&tracks, &dets);
        prop_assert_eq!(&e, &region_clusters_with(&tracks, &dets, BroadPhase::AllPairs));
        prop_assert_eq!(&e.pairs, &sweep);
        check_estimate(tracks.len(), dets.len(), &e)?;
    }

    /// On arbitrary (possibly out-of-range, duplicated) pair lists, clusters are the connected
    /// components found by BFS, in the documented order.
    #[test]
    fn clusters_are_connected_components(
        nt in 0usize..30,
        nd in 0usize..30,
        pairs in prop::collection::vec((0usize..35, 0usize..35), 0..60),
    ) {
        let e = clusters_from_pairs(nt, nd, &pairs);
        let valid: Vec<(usize, usize)> = pairs.iter().copied().filter(|&(t, d)| t < nt && d < nd).collect();
        let mut sorted = valid.clone();
        sorted.sort();
        sorted.dedup();
        prop_assert_eq!(&e.pairs, &sorted);
        check_estimate(nt, nd, &e)?;
    }
}

/// The thesis scenario: shapes that moved by a few pixels between frames meet their own next
/// detection and nothing else, once the track shells are moved by the prediction.
#[test]
fn moved_shapes_cluster_with_their_detection() {
    let sq =
        |x: f64, y: f64| ConvexShell::from_bbox(&shapetrack::BBox::new(x, y, 8.0, 8.0)).unwrap();
    let mut tracks = Vec::new();
    let mut dets = Vec::new();
    for k in 0..10 {
        let (x, y) = (k as f64 * 30.0, (k % 3) as f64 * 30.0);
        tracks.push(predicted_shell(&sq(x, y), 12.0, 0.0, 1.0));
        dets.push(sq(x + 12.5, y + 0.5));
    }
    let e = region_clusters(&tracks, &dets);
    assert_eq!(e.pairs, (0..10).map(|k| (k, k)).collect::<Vec<_>>());
    assert_eq!(e.clusters.len(), 10);
    // Without prediction the shapes (moved more than their width) meet nothing of their own.
    let raw: Vec<ConvexShell> = (0..10)
        .map(|k| sq(k as f64 * 30.0, (k % 3) as f64 * 30.0))
        .collect();
    assert!(region_clusters(&raw, &dets)
        .pairs
        .iter()
        .all(|&(t, d)| t != d));
}
