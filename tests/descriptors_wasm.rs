//! The descriptors on wasm32: linfa's k-means uses rayon, which must fall back to the calling
//! thread there instead of panicking. Run with
//! `CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUNNER=wasm-bindgen-test-runner \
//!  cargo test --target wasm32-unknown-unknown --no-default-features --test descriptors_wasm`.
#![cfg(target_arch = "wasm32")]

use shapetrack::features::color::{color_cost, ColorConfig, ColorSample};
use shapetrack::features::shape_context::{shape_cost, ShapeContextConfig};
use shapetrack::Point;
use wasm_bindgen_test::wasm_bindgen_test;

#[wasm_bindgen_test]
fn colour_cost_runs_kmeans_on_wasm() {
    let positions: Vec<Point> = (0..400)
        .map(|i| Point::new((i % 20) as f64, (i / 20) as f64))
        .collect();
    let rgb: Vec<[u8; 3]> = (0..400)
        .map(|i| {
            if i % 20 < 10 {
                [200, 20, 20]
            } else {
                [20, 20, 200]
            }
        })
        .collect();
    let a = ColorSample::new(positions, rgb, 1.0).unwrap();
    let m = color_cost(&a, &a, None, &ColorConfig::default()).unwrap();
    assert_eq!(m.cost, 0.0);
    assert_eq!(m.overlap, 1.0);
}

#[wasm_bindgen_test]
fn shape_cost_runs_on_wasm() {
    let sq = [
        Point::new(0.0, 0.0),
        Point::new(40.0, 0.0),
        Point::new(40.0, 40.0),
        Point::new(0.0, 40.0),
    ];
    let moved: Vec<Point> = sq
        .iter()
        .map(|p| Point::new(p.x + 5.0, p.y + 3.0))
        .collect();
    let m = shape_cost(&sq, &moved, &ShapeContextConfig::default()).unwrap();
    assert!(m.cost < 1e-6 && m.fitted);
}
