//! The exact polygon overlap of eval-vot is bounded at the reader (issue 65, class 2): a
//! polygon of more vertices than the cap, or a large self-intersecting one (whose overlap
//! sweep grows with the square of its crossings), is refused naming file and line.
// A native suite (`cargo test`); for wasm32 it compiles to nothing.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::io::limits::{MAX_POLYGON_VERTICES, MAX_SELF_CROSSING_VERTICES};
use shapetrack::io::vot::{parse_regions, Region};

fn polygon_line(points: &[(f64, f64)]) -> String {
    let v: Vec<String> = points.iter().map(|(x, y)| format!("{x},{y}")).collect();
    v.join(",")
}

/// `n` points on a circle, visited `step` at a time: a simple polygon for `step` 1, a star
/// crossing itself everywhere for larger steps coprime with `n`.
fn star(n: usize, step: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|k| {
            let a = std::f64::consts::TAU * ((k * step) % n) as f64 / n as f64;
            (500.0 + 400.0 * a.cos(), 500.0 + 400.0 * a.sin())
        })
        .collect()
}

#[test]
fn a_polygon_beyond_the_vertex_cap_is_refused_with_its_line() {
    let text = format!(
        "1,2,3,4\n{}\n",
        polygon_line(&star(MAX_POLYGON_VERTICES + 1, 1))
    );
    let e = parse_regions(&text, "big.txt").unwrap_err().to_string();
    assert!(e.contains("big.txt") && e.contains('2'), "{e}");
    assert!(e.contains("vertices"), "{e}");
}

#[test]
fn a_large_self_intersecting_polygon_is_refused() {
    let n = MAX_SELF_CROSSING_VERTICES + 3; // odd, so step 2 visits every point
    let text = format!("{}\n", polygon_line(&star(n, 2)));
    let e = parse_regions(&text, "star.txt").unwrap_err().to_string();
    assert!(e.contains("star.txt") && e.contains("itself"), "{e}");
}

#[test]
fn large_simple_polygons_and_small_bowties_are_read() {
    let simple = polygon_line(&star(MAX_POLYGON_VERTICES, 1));
    let bowtie = polygon_line(&[(0.0, 0.0), (10.0, 10.0), (10.0, 0.0), (0.0, 10.0)]);
    let r = parse_regions(&format!("{simple}\n{bowtie}\n"), "ok.txt").unwrap();
    assert!(matches!(&r[0], Region::Polygon(p) if p.len() == MAX_POLYGON_VERTICES));
    assert!(matches!(&r[1], Region::Polygon(p) if p.len() == 4));
}
