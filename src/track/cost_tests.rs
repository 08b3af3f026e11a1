//! Unit tests of [`super`] (the cost model and its terms), in their own file to keep
//! `cost.rs` within the track modules' length limit (`tests/track_modules.rs`).

use super::*;

#[test]
fn giou_matches_hand_computation() {
    let a = BBox::new(0.0, 0.0, 2.0, 2.0);
    let b = BBox::new(3.0, 0.0, 2.0, 2.0);
    // Disjoint: IoU 0, enclosing 5×2 = 10, union 8 → GIoU = −2/10.
    assert!((giou(&a, &b) + 0.2).abs() < 1e-12);
    assert!((giou(&a, &a) - 1.0).abs() < 1e-12);
    let c = BBox::new(1.0, 0.0, 2.0, 2.0);
    // IoU = 2/6, enclosing 3×2 = 6 = union → GIoU = IoU.
    assert!((giou(&a, &c) - 1.0 / 3.0).abs() < 1e-12);
}

struct Fixed(Option<f64>);
impl PairCost for Fixed {
    fn name(&self) -> &str {
        "fixed"
    }
    fn cost(&self, _: &Track, _: &Candidate<'_>) -> Option<f64> {
        self.0
    }
}

#[test]
fn weights_renormalise_when_a_term_has_no_data() {
    let mut m = CostModel::default();
    m.push(Box::new(Fixed(None)), 1.0, None);
    m.push(Box::new(Fixed(None)), 0.5, None);
    m.push(Box::new(Fixed(None)), 0.5, Some(0.4));
    // Thesis Table 7: C1 = 0.1, C2 = 0.15 → OC = 0.125 with w_a = w_b = 0.5 (term 0 absent).
    assert_eq!(m.combine(&[None, Some(0.1), Some(0.15)]), Some(0.125));
    // Only the first term has data: its own cost, whatever its weight.
    assert_eq!(m.combine(&[Some(0.3), None, None]), Some(0.3));
    // All three: (1·0.2 + 0.5·0.4 + 0.5·0.0) / 2.
    assert_eq!(m.combine(&[Some(0.2), Some(0.4), Some(0.0)]), Some(0.2));
    // No data at all: no evidence, no match.
    assert_eq!(m.combine(&[None, None, None]), None);
    // A gate rejects regardless of the other terms; NaN counts as no data.
    assert_eq!(m.combine(&[Some(0.0), Some(0.0), Some(0.5)]), None);
    assert_eq!(m.combine(&[Some(f64::NAN), Some(0.5), None]), Some(0.5));
    // Zero weight disables a term entirely.
    m.push(Box::new(Fixed(Some(1.0))), 0.0, None);
    assert_eq!(m.terms().len(), 3);
}

/// An expensive term that counts its calls.
struct Counting(std::sync::Arc<std::sync::atomic::AtomicUsize>);
impl PairCost for Counting {
    fn name(&self) -> &str {
        "counting"
    }
    fn cost(&self, _: &Track, _: &Candidate<'_>) -> Option<f64> {
        self.0.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        Some(0.0)
    }
    fn expensive(&self) -> bool {
        true
    }
}

/// A cluster-normalised expensive term (an appearance cost) that counts its calls.
struct CountingNormalised(std::sync::Arc<std::sync::atomic::AtomicUsize>);
impl PairCost for CountingNormalised {
    fn name(&self) -> &str {
        "counting normalised"
    }
    fn cost(&self, _: &Track, _: &Candidate<'_>) -> Option<f64> {
        self.0.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        Some(0.5)
    }
    fn expensive(&self) -> bool {
        true
    }
    fn normalise_in_cluster(&self) -> bool {
        true
    }
}

/// A track born on a 40×80 box at `x`.
fn track_at_x(x: f64) -> Track {
    use crate::motion::BoxKalman;
    use crate::track::Config;
    let b = BBox::new(x, 0.0, 40.0, 80.0);
    let motion = Box::new(BoxKalman::new(&b, Config::default().motion_params()).unwrap());
    let det = Detection::from_box(b, 1.0);
    Track::born(&det, &Features::default(), motion, None, 1, false, false)
}

/// The candidates of `dets`, without features.
fn candidates(dets: &[Detection]) -> Vec<Candidate<'_>> {
    dets.iter()
        .enumerate()
        .map(|(index, detection)| Candidate {
            index,
            detection,
            features: None,
        })
        .collect()
}

/// `pairs` of tracks 0 and 1 and detections 0 to 2, all in one cluster (as in a crowd).
fn one_cluster(pairs: Vec<(usize, usize)>) -> Regions {
    use crate::track::regions::Cluster;
    Regions {
        pair_cluster: vec![0; pairs.len()],
        pairs,
        clusters: vec![Cluster {
            tracks: vec![0, 1],
            dets: vec![0, 1, 2],
        }]
        .into(),
    }
}

#[test]
fn appearance_is_compared_only_where_it_could_change_a_preference() {
    let tracks = [track_at_x(0.0), track_at_x(200.0)];
    // d0 on track 0, d1 on track 1, d2 overlapping track 0 (IoU 0.6: cost 0.4).
    let dets = [0.0, 200.0, 10.0].map(|x| Detection::from_box(BBox::new(x, 0.0, 40.0, 80.0), 1.0));
    let cands = candidates(&dets);
    // One cluster holding every cross pair, as in a crowd.
    let regions = one_cluster(vec![(0, 0), (0, 1), (0, 2), (1, 0), (1, 1)]);
    let calls = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let mut m = CostModel::default();
    m.push(Box::new(IouCost { buffer: 1.0 }), 1.0, None);
    m.push(Box::new(CountingNormalised(calls.clone())), 0.5, None);
    let s = m.score_pairs(&tracks, &cands, &regions);
    // Reach of the appearance term: 0.5 / 1. (0, 1) and (1, 0) have IoU cost 1, a full
    // 1 behind both their track's best and their detection's best: not compared. (0, 2)
    // is 0.4 behind track 0's best: compared, as are the two best pairs.
    assert_eq!(calls.load(std::sync::atomic::Ordering::Relaxed), 3);
    let cost = |k: usize| s[k].unwrap().cost;
    // Compared pairs: 0.5 normalised by the cluster's largest value, 1 (the pairs not
    // compared take the worst value, and count in the normalisation).
    assert!((cost(0) - 0.5 / 1.5 * 0.5).abs() < 1e-12, "{}", cost(0));
    assert!((cost(1) - 1.0).abs() < 1e-12, "{}", cost(1));
    assert!((cost(3) - 1.0).abs() < 1e-12, "{}", cost(3));
    // Every preference is the one full comparison gives: track 0 prefers d0 over d2 and
    // d1, track 1 prefers d1, d0 prefers track 0.
    assert!(cost(0) < cost(2) && cost(2) < cost(1));
    assert!(cost(4) < cost(3) && cost(0) < cost(3));
    // The thresholded cost ignores the normalised term.
    assert!((s[2].unwrap().absolute - 0.4).abs() < 1e-12);
}

#[test]
fn prefilter_skips_the_expensive_terms_of_pairs_that_cannot_match() {
    use crate::motion::BoxKalman;
    use crate::track::regions::Cluster;
    use crate::track::Config;
    let b = BBox::new(0.0, 0.0, 40.0, 80.0);
    let motion = Box::new(BoxKalman::new(&b, Config::default().motion_params()).unwrap());
    let det = Detection::from_box(b, 1.0);
    let track = Track::born(&det, &Features::default(), motion, None, 1, false, false);
    // One detection where the track is, one beside it (IoU 0), one overlapping by half.
    let dets = [0.0, 200.0, 20.0].map(|x| Detection::from_box(BBox::new(x, 0.0, 40.0, 80.0), 1.0));
    let cands: Vec<Candidate<'_>> = dets
        .iter()
        .enumerate()
        .map(|(index, detection)| Candidate {
            index,
            detection,
            features: None,
        })
        .collect();
    let regions = Regions {
        pairs: vec![(0, 0), (0, 1), (0, 2)],
        pair_cluster: vec![0, 0, 0],
        clusters: vec![Cluster {
            tracks: vec![0],
            dets: vec![0, 1, 2],
        }]
        .into(),
    };
    let calls = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let model = |prefilter: Option<f64>| {
        let mut m = CostModel::default();
        m.push(Box::new(IouCost { buffer: 1.0 }), 1.0, None);
        m.push(Box::new(Counting(calls.clone())), 1.0, None);
        match prefilter {
            Some(p) => m.with_prefilter(p),
            None => m,
        }
    };
    let tracks = [track];
    let all = model(None).score_pairs(&tracks, &cands, &regions);
    assert_eq!(calls.swap(0, std::sync::atomic::Ordering::Relaxed), 3);
    let some = model(Some(0.8)).score_pairs(&tracks, &cands, &regions);
    // The far pair: IoU cost 1, so even an expensive cost of 0 leaves (1 + 0) / 2 = 0.5,
    // within 0.8: computed. At 0.4 it is hopeless and skipped; the half-overlap pair
    // (IoU 1/3: cost 2/3, bound 1/3) is still computed.
    assert_eq!(calls.swap(0, std::sync::atomic::Ordering::Relaxed), 3);
    assert_eq!(all, some);
    let strict = model(Some(0.4)).score_pairs(&tracks, &cands, &regions);
    assert_eq!(calls.swap(0, std::sync::atomic::Ordering::Relaxed), 2);
    // The skipped pair keeps its cheap cost, above the threshold: no stage takes it.
    let far = strict[1].unwrap();
    assert!(far.absolute > 0.4, "{far:?}");
    assert_eq!(strict[0], all[0]);
    assert_eq!(strict[2], all[2]);
}

/// A term with a fixed cost, cheap or expensive, counting its calls.
struct FixedCounted(
    Option<f64>,
    bool,
    std::sync::Arc<std::sync::atomic::AtomicUsize>,
);
impl PairCost for FixedCounted {
    fn name(&self) -> &str {
        "fixed"
    }
    fn cost(&self, _: &Track, _: &Candidate<'_>) -> Option<f64> {
        self.2.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.0
    }
    fn expensive(&self) -> bool {
        self.1
    }
}

/// `cost_within` answers what full evaluation filtered by the limits answers, for
/// random term values (some missing), weights, gates and limits, and skips expensive
/// terms in some of them.
#[test]
fn cost_within_is_the_filtered_full_cost() {
    use crate::motion::BoxKalman;
    use crate::track::Config;
    use std::sync::atomic::{AtomicUsize, Ordering};
    let b = BBox::new(0.0, 0.0, 40.0, 80.0);
    let motion = Box::new(BoxKalman::new(&b, Config::default().motion_params()).unwrap());
    let det = Detection::from_box(b, 1.0);
    let track = Track::born(&det, &Features::default(), motion, None, 1, false, false);
    let cand = Candidate {
        index: 0,
        detection: &det,
        features: None,
    };
    let mut s = 4242u64;
    let mut next = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    let calls = std::sync::Arc::new(AtomicUsize::new(0));
    let (mut skipped, mut found) = (0, 0);
    for case in 0..2000 {
        let mut m = CostModel::default();
        // Expensive terms first in the list: `cost_within` still takes the cheap first.
        for k in 0..4 {
            let value = (next() > 0.15).then(&mut next);
            let gate = (next() > 0.7).then(|| 0.3 + 0.7 * next());
            let expensive = k < 2;
            m.push(
                Box::new(FixedCounted(value, expensive, calls.clone())),
                0.25 + next(),
                gate,
            );
        }
        let max_cost = next();
        let beat = (next() > 0.5).then(&mut next);
        let full: Vec<Option<f64>> = m
            .terms()
            .iter()
            .map(|w| w.term.cost(&track, &cand).filter(|c| c.is_finite()))
            .collect();
        let want = m
            .combine(&full)
            .filter(|&c| c <= max_cost && beat.is_none_or(|b| c < b));
        calls.store(0, Ordering::Relaxed);
        let got = m.cost_within(&track, &cand, max_cost, beat);
        assert_eq!(got, want, "case {case}");
        skipped += usize::from(calls.load(Ordering::Relaxed) < 4);
        found += usize::from(got.is_some());
    }
    assert!(skipped > 200 && found > 100, "{skipped} {found}");
}

/// A pair that an expensive term's gate rejects does not compute the expensive terms
/// after it (unless cluster-normalised), and scores as full evaluation does.
#[test]
fn a_gated_pair_skips_its_remaining_appearance() {
    use crate::motion::BoxKalman;
    use crate::track::regions::Cluster;
    use crate::track::Config;
    use std::sync::atomic::{AtomicUsize, Ordering};
    let b = BBox::new(0.0, 0.0, 40.0, 80.0);
    let motion = Box::new(BoxKalman::new(&b, Config::default().motion_params()).unwrap());
    let det = Detection::from_box(b, 1.0);
    let tracks = [Track::born(
        &det,
        &Features::default(),
        motion,
        None,
        1,
        false,
        false,
    )];
    let cands = [Candidate {
        index: 0,
        detection: &det,
        features: None,
    }];
    let regions = Regions {
        pairs: vec![(0, 0)],
        pair_cluster: vec![0],
        clusters: vec![Cluster {
            tracks: vec![0],
            dets: vec![0],
        }]
        .into(),
    };
    let (first, second) = (
        std::sync::Arc::new(AtomicUsize::new(0)),
        std::sync::Arc::new(AtomicUsize::new(0)),
    );
    for (value, gate, later_calls) in [(0.6, 0.5, 0), (0.4, 0.5, 1)] {
        let mut m = CostModel::default();
        m.push(Box::new(IouCost { buffer: 1.0 }), 1.0, None);
        m.push(
            Box::new(FixedCounted(Some(value), true, first.clone())),
            1.0,
            Some(gate),
        );
        m.push(
            Box::new(FixedCounted(Some(0.1), true, second.clone())),
            1.0,
            None,
        );
        second.store(0, Ordering::Relaxed);
        let s = m.score_pairs(&tracks, &cands, &regions);
        assert_eq!(second.load(Ordering::Relaxed), later_calls, "value {value}");
        assert_eq!(s[0].is_none(), value > gate);
    }
}

/// A second scoring of the same pairs reads their cheap terms from the first one's
/// [`CheapTerms`] (not computing them again) and scores exactly as a scoring from scratch;
/// other pairs are not read from it.
#[test]
fn a_second_scoring_reuses_the_cheap_terms_and_scores_alike() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    let tracks = [track_at_x(0.0), track_at_x(30.0)];
    let dets = [0.0, 25.0, 60.0].map(|x| Detection::from_box(BBox::new(x, 0.0, 40.0, 80.0), 1.0));
    let cands = candidates(&dets);
    let regions = one_cluster(vec![(0, 0), (0, 1), (1, 1), (1, 2)]);
    let (cheap_calls, dear_calls) = (
        std::sync::Arc::new(AtomicUsize::new(0)),
        std::sync::Arc::new(AtomicUsize::new(0)),
    );
    let mut m = CostModel::default();
    m.push(Box::new(IouCost { buffer: 1.0 }), 1.0, None);
    m.push(
        Box::new(FixedCounted(Some(0.2), false, cheap_calls.clone())),
        0.5,
        None,
    );
    m.push(Box::new(CountingNormalised(dear_calls.clone())), 0.5, None);
    let fresh = m.score_pairs(&tracks, &cands, &regions);
    assert_eq!(cheap_calls.swap(0, Ordering::Relaxed), 4);
    let mut cache = CheapTerms::default();
    let first = m.score_pairs_reusing(&tracks, &cands, &regions, &mut cache);
    assert_eq!(cheap_calls.swap(0, Ordering::Relaxed), 4);
    let dear_before = dear_calls.load(Ordering::Relaxed);
    let second = m.score_pairs_reusing(&tracks, &cands, &regions, &mut cache);
    // The cheap term is not asked again; the expensive one is, as before.
    assert_eq!(cheap_calls.swap(0, Ordering::Relaxed), 0);
    assert!(dear_calls.load(Ordering::Relaxed) > dear_before);
    assert_eq!(first, fresh);
    assert_eq!(second, fresh);
    // Other pairs: computed, not read from the cache.
    let fewer = Regions {
        pairs: regions.pairs[..3].to_vec(),
        pair_cluster: vec![0; 3],
        clusters: regions.clusters.clone(),
    };
    let third = m.score_pairs_reusing(&tracks, &cands, &fewer, &mut cache);
    assert_eq!(cheap_calls.swap(0, Ordering::Relaxed), 3);
    assert_eq!(third, m.score_pairs(&tracks, &cands, &fewer));
}
