//! GJK (parry2d and the thesis' Algorithm 2) against a brute-force polygon intersection test.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

mod common;

use std::cell::RefCell;
use std::collections::HashMap;

use common::*;
use proptest::prelude::*;
use proptest::test_runner::TestRunner;
use shapetrack::geometry::{intersects_thesis, ConvexShell, PreparedShell};

/// Runs `check` on generated pairs and returns how many cases of each kind were decided
/// outside the touching band (so the test proves it covered every configuration).
fn run_pairs(
    cases: u32,
    band: f64,
    check: impl Fn(&ConvexShell, &ConvexShell) -> bool,
) -> HashMap<(PairKind, bool), usize> {
    let decided = RefCell::new(HashMap::new());
    TestRunner::new(config(cases))
        .run(&shell_pair(), |(kind, a, b)| {
            let sd = signed_distance(&a, &b);
            if sd.abs() <= band {
                return Ok(()); // touching within tolerance: either answer is right
            }
            let want = sd < 0.0;
            prop_assert_eq!(
                check(&a, &b),
                want,
                "kind {:?} sd {} a {:?} b {:?}",
                kind,
                sd,
                a,
                b
            );
            prop_assert_eq!(check(&b, &a), want, "swapped, kind {:?} sd {}", kind, sd);
            *decided.borrow_mut().entry((kind, want)).or_insert(0) += 1;
            Ok(())
        })
        .unwrap();
    decided.into_inner()
}

fn assert_coverage(decided: &HashMap<(PairKind, bool), usize>) {
    for kind in [
        PairKind::Random,
        PairKind::Nested,
        PairKind::EdgeTouch,
        PairKind::VertexTouch,
    ] {
        for want in [true, false] {
            if kind == PairKind::Nested && !want {
                continue; // nested shapes always intersect
            }
            assert!(
                decided.get(&(kind, want)).copied().unwrap_or(0) >= 5,
                "too few {kind:?} cases with intersect = {want}: {decided:?}"
            );
        }
    }
}

/// parry2d's GJK (through `ConvexShell::intersects`, with the local-origin f32 conversion)
/// agrees with the brute-force test whenever the shells are more than `PARRY_BAND` (1e-3 px)
/// apart or overlap by more than that, including nested, edge- and vertex-touching pairs and
/// pairs millions of pixels from the origin.
#[test]
fn parry_gjk_agrees_with_brute_force() {
    let decided = run_pairs(3000, PARRY_BAND, |a, b| a.intersects(b));
    assert_coverage(&decided);
}

/// The raw GJK call without the bounding-box early-out agrees too (so the early-out is not
/// what makes the test pass).
#[test]
fn parry_gjk_without_aabb_agrees_with_brute_force() {
    run_pairs(1500, PARRY_BAND, |a, b| {
        PreparedShell::new(a).intersects_gjk(&PreparedShell::new(b))
    });
}

/// The region estimator's test (a deep-inside fast accept, then GJK) agrees with the
/// brute-force test outside the band, and with GJK alone on every pair, touching ones
/// included (a point 0.01 px inside both shells is an overlap no rounding band hides).
#[test]
fn fast_accept_then_gjk_is_gjk() {
    let decided = run_pairs(3000, PARRY_BAND, |a, b| {
        PreparedShell::new(a).intersects_fast(&PreparedShell::new(b))
    });
    assert_coverage(&decided);
    TestRunner::new(config(1500))
        .run(&shell_pair(), |(kind, a, b)| {
            let (pa, pb) = (PreparedShell::new(&a), PreparedShell::new(&b));
            prop_assert_eq!(
                pa.intersects_fast(&pb),
                pa.intersects_gjk(&pb),
                "kind {:?} a {:?} b {:?}",
                kind,
                a,
                b
            );
            Ok(())
        })
        .unwrap();
}

/// The thesis' GJK (f64) agrees with the brute-force test outside a 1e-6 px band.
#[test]
fn thesis_gjk_agrees_with_brute_force() {
    let decided = run_pairs(3000, THESIS_BAND, intersects_thesis);
    assert_coverage(&decided);
}

/// parry2d's distance matches the brute-force separation for disjoint shells and is zero for
/// clearly overlapping ones. parry's GJK stops once its bounds agree to `sqrt(10·ε_f32)` ≈
/// 0.35% relative, so that is the tolerance (plenty for gating).
#[test]
fn parry_distance_matches_brute_force() {
    TestRunner::new(config(1500))
        .run(&shell_pair(), |(_, a, b)| {
            let sd = signed_distance(&a, &b);
            let d = a.distance(&b);
            if sd < -PARRY_BAND {
                prop_assert_eq!(d, 0.0);
            } else if sd > PARRY_BAND {
                prop_assert!(
                    (d - sd).abs() <= 1e-3 + 3.5e-3 * sd,
                    "parry {} brute {}",
                    d,
                    sd
                );
            }
            Ok(())
        })
        .unwrap();
}

/// Exactly touching boxes (shared edge, shared corner) count as intersecting with both tests,
/// as Algorithm 2 needs for pixel-adjacent shapes.
#[test]
fn exact_touching_boxes_intersect() {
    use shapetrack::BBox;
    let a = ConvexShell::from_bbox(&BBox::new(0.0, 0.0, 10.0, 10.0)).unwrap();
    for b in [
        BBox::new(10.0, 0.0, 5.0, 5.0),
        BBox::new(10.0, 10.0, 5.0, 5.0),
        BBox::new(-5.0, 10.0, 5.0, 5.0),
        BBox::new(3.0, -4.0, 2.0, 4.0),
    ] {
        let b = ConvexShell::from_bbox(&b).unwrap();
        assert!(brute_intersects(&a, &b));
        assert!(a.intersects(&b), "{b:?}");
        assert!(intersects_thesis(&a, &b), "{b:?}");
    }
}
