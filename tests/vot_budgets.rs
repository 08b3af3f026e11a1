//! VOT's budgets (issue 65, class 2): the exact polygon overlap of eval-vot is bounded at the
//! reader (a polygon of more vertices than the cap, or a large self-intersecting one, whose
//! overlap sweep grows with the square of its crossings, is refused naming file and line), and
//! `shapetrack vot` streams its frames instead of holding the sequence decoded.
// A native suite (`cargo test`); for wasm32 it compiles to nothing.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::io::limits::{MAX_POLYGON_VERTICES, MAX_SELF_CROSSING_VERTICES};
use shapetrack::io::vot::{parse_regions, Region};
use std::path::PathBuf;
use std::process::Command;

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

/// A VOT sequence of `n` frames of `w × h` JPEGs: a textured square crossing a smooth
/// gradient (small files, large decoded frames), with its ground-truth rectangles.
fn vot_sequence(name: &str, n: u32, w: u32, h: u32) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let side = 160;
    let mut gt = String::new();
    for k in 0..n {
        let x0 = 100 + k * 2;
        let y0 = h / 2 - side / 2;
        let img = image::RgbImage::from_fn(w, h, |x, y| {
            if (x0..x0 + side).contains(&x) && (y0..y0 + side).contains(&y) {
                // A checkerboard with a diagonal: corners and edges SIFT can match.
                let (u, v) = ((x - x0) / 20, (y - y0) / 20);
                let c = if (u + v) % 2 == 0 { 230 } else { 30 };
                image::Rgb([c, if x - x0 == y - y0 { 0 } else { c }, 255 - c])
            } else {
                image::Rgb([(x * 120 / w) as u8 + 60, (y * 120 / h) as u8 + 60, 128])
            }
        });
        img.save(d.join(format!("{:08}.jpg", k + 1))).unwrap();
        gt.push_str(&format!("{x0},{y0},{side},{side}\n"));
    }
    std::fs::write(d.join("groundtruth.txt"), gt).unwrap();
    d
}

#[test]
fn vot_streams_its_frames_instead_of_holding_the_sequence() {
    // 120 frames of 1280×720: 332 MB decoded, a few MB as files.
    let (n, w, h) = (120u32, 1280u32, 720u32);
    let seq = vot_sequence("vot_streams", n, w, h);
    let out = seq.with_extension("out");
    let run = Command::new(env!("CARGO_BIN_EXE_shapetrack"))
        .args(["vot", "--protocol", "reset", "--model", "none", "--seq"])
        .arg(&seq)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{err}");
    let peak_kb: u64 = err
        .split("peak_mem_kb=")
        .nth(1)
        .and_then(|t| t.split(|c: char| !c.is_ascii_digit()).next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("no peak_mem_kb in {err}"));
    let decoded_kb = u64::from(n) * u64::from(w) * u64::from(h) * 3 / 1024;
    // Held, the frames alone are 324,000 kB; streamed, a few frames and the follower's state.
    assert!(
        peak_kb * 3 < decoded_kb,
        "peak {peak_kb} kB against {decoded_kb} kB of decoded frames: {err}"
    );
    // The run did its work: a region for every frame.
    let results = std::fs::read_to_string(out.join("vot_streams_001.txt")).unwrap();
    assert_eq!(results.lines().count(), n as usize);
}

#[test]
fn vot_takes_the_followers_settings_and_checks_them() {
    let seq = vot_sequence("vot_config", 12, 400, 240);
    let run = |name: &str, config: Option<&str>| {
        let out = seq.with_extension(name);
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_shapetrack"));
        cmd.args(["vot", "--protocol", "reset", "--model", "none", "--seq"])
            .arg(&seq)
            .arg("--out")
            .arg(&out);
        if let Some(c) = config {
            cmd.args(["--config", c]);
        }
        let r = cmd.output().unwrap();
        (r, out.join("vot_config_001.txt"))
    };
    let (r, default) = run("default", None);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    // A follower that counts itself lost on every frame and stops at once: its regions are
    // empty from the second frame, so the reset protocol's output differs.
    let (r, stopping) = run(
        "stopping",
        Some(r#"{"lost_confidence": 1.0, "max_lost": 0}"#),
    );
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert_ne!(
        std::fs::read_to_string(&default).unwrap(),
        std::fs::read_to_string(&stopping).unwrap()
    );
    // Out-of-range settings fail before anything is written.
    let (r, bad) = run("bad", Some(r#"{"max_side": 3}"#));
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(!r.status.success() && err.contains("max_side"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(!bad.exists());
}
