//! VOT overlap and protocol speed on the real "bag" sequence: exact sweep vs toolkit raster.

use criterion::{criterion_group, criterion_main, Criterion};
use shapetrack::eval::vot::{
    anchor_frames, anchors_every, evaluate_anchor_sequence, overlap, AnchorParams, OverlapMethod,
};
use shapetrack::io::vot::{read_regions, Region};
use shapetrack::Point;
use std::hint::black_box;

fn bag() -> Vec<Region> {
    read_regions(
        &std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../shared/data/vot-bag/groundtruth.txt"),
    )
    .expect("bag ground truth")
}

fn shifted(r: &Region) -> Region {
    match r {
        Region::Polygon(p) => Region::Polygon(
            p.iter()
                .map(|q| Point::new(q.x + 13.0, q.y - 7.0))
                .collect(),
        ),
        o => o.clone(),
    }
}

fn bench(c: &mut Criterion) {
    let gt = bag();
    let other: Vec<Region> = gt.iter().map(shifted).collect();
    for (name, method) in [
        ("exact", OverlapMethod::Exact),
        ("toolkit", OverlapMethod::Toolkit),
    ] {
        c.bench_function(&format!("vot_overlap_196_polygon_pairs_{name}"), |b| {
            b.iter(|| {
                let s: f64 = gt
                    .iter()
                    .zip(&other)
                    .map(|(x, y)| overlap(x, y, Some((480, 360)), method))
                    .sum();
                black_box(s)
            })
        });
    }
    let anchors = anchors_every(gt.len(), 50);
    let runs: Vec<Vec<Region>> = anchors
        .iter()
        .map(|a| {
            anchor_frames(a, gt.len())
                .iter()
                .map(|&f| other[f].clone())
                .collect()
        })
        .collect();
    for (name, params) in [
        (
            "exact",
            AnchorParams {
                bounds: Some((480, 360)),
                ..AnchorParams::default()
            },
        ),
        ("toolkit", AnchorParams::toolkit(Some((480, 360)))),
    ] {
        c.bench_function(&format!("vot_anchor_eval_bag_{name}"), |b| {
            b.iter(|| {
                black_box(
                    evaluate_anchor_sequence(&gt, &anchors, &runs, &params).map(|s| s.accuracy),
                )
            })
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
