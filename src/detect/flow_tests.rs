//! Unit tests of `detect::flow` (a file of their own: the module's code is long enough).

use super::*;

/// A smooth random-looking texture (sum of sines), sampled at `(x + dx, y + dy)`.
fn texture(w: usize, h: usize, dx: f32, dy: f32) -> Vec<f32> {
    let mut v = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let (fx, fy) = (x as f32 + dx, y as f32 + dy);
            let t = (0.31 * fx).sin() * 40.0
                + (0.17 * fy + 0.4).sin() * 35.0
                + (0.23 * (fx + fy)).cos() * 25.0
                + (0.11 * fx - 0.29 * fy).sin() * 30.0;
            v.push(128.0 + t);
        }
    }
    v
}

fn mean_error(f: &FlowField, u: f32, v: f32, margin: usize) -> f32 {
    let mut s = 0.0;
    let mut n = 0;
    for y in margin..f.height - margin {
        for x in margin..f.width - margin {
            let i = y * f.width + x;
            s += (f.u[i] - u).hypot(f.v[i] - v);
            n += 1;
        }
    }
    s / n as f32
}

#[test]
fn a_translated_texture_gives_its_shift_everywhere() {
    let (w, h) = (160, 96);
    // i1 shows the scene moved by (+3.4, −1.7): a pixel of i0 is found at x + 3.4.
    let i0 = texture(w, h, 0.0, 0.0);
    let i1 = texture(w, h, -3.4, 1.7);
    let mut flow = DenseFlow::new(FlowConfig::default());
    let mut out = FlowField::default();
    flow.compute(&i0, &i1, w, h, &mut out);
    let e = mean_error(&out, 3.4, -1.7, 10);
    assert!(e < 0.15, "mean end-point error {e}");
}

#[test]
fn a_moving_square_stands_out_of_a_still_background() {
    let (w, h) = (160, 96);
    let bg = texture(w, h, 0.0, 0.0);
    // A checkered square whose left edge is at `x0`; its pattern moves with it.
    let with_square = |x0: usize| {
        let mut img = bg.clone();
        for y in 30..60usize {
            for x in x0..x0 + 40 {
                img[y * w + x] = 60.0 + 90.0 * ((((x - x0) / 4) + (y / 4)) % 2) as f32;
            }
        }
        img
    };
    // The square moved 4 px right from the previous frame to the current one.
    let (cur, prev) = (with_square(54), with_square(50));
    let mut flow = DenseFlow::new(FlowConfig::default());
    let mut out = FlowField::default();
    flow.compute(&cur, &prev, w, h, &mut out);
    // Inside the square (current frame) the flow points back 4 px; far from it, zero.
    let at = |x: usize, y: usize| (out.u[y * w + x], out.v[y * w + x]);
    let (u, v) = at(74, 45);
    assert!((u + 4.0).abs() < 0.5 && v.abs() < 0.5, "inside: ({u}, {v})");
    let (u, v) = at(20, 80);
    assert!(u.abs() < 0.3 && v.abs() < 0.3, "outside: ({u}, {v})");
}

#[test]
fn tiny_or_flat_images_give_zero_flow_without_panicking() {
    let mut flow = DenseFlow::new(FlowConfig::default());
    let mut out = FlowField::default();
    flow.compute(&[1.0; 12], &[2.0; 12], 4, 3, &mut out);
    assert_eq!(out.u, vec![0.0; 12]);
    let flat = vec![100.0; 64 * 48];
    flow.compute(&flat, &flat, 64, 48, &mut out);
    assert!(out
        .u
        .iter()
        .chain(&out.v)
        .all(|x| x.is_finite() && x.abs() < 1e-3));
}

#[test]
fn other_patch_sizes_find_the_shift_too() {
    // The patch search sums per patch column (up to 32): sizes other than the default 8,
    // odd ones and the largest allowed included.
    let (w, h) = (160, 96);
    let i0 = texture(w, h, 0.0, 0.0);
    let i1 = texture(w, h, -2.6, 1.2);
    for (patch_size, patch_stride) in [(5, 3), (12, 6), (32, 16)] {
        let mut flow = DenseFlow::new(FlowConfig {
            patch_size,
            patch_stride,
            ..FlowConfig::default()
        });
        let mut out = FlowField::default();
        flow.compute(&i0, &i1, w, h, &mut out);
        let e = mean_error(&out, 2.6, -1.2, 20);
        assert!(e < 0.3, "patch {patch_size}: mean end-point error {e}");
    }
}

#[test]
fn refused_settings_give_zero_flow_without_panicking() {
    // `DenseFlow::new` takes any settings; those `FlowConfig::check` refuses (a patch wider
    // than the search's 32 columns, none at all) must not reach the search.
    let (w, h) = (96, 64);
    let (i0, i1) = (texture(w, h, 0.0, 0.0), texture(w, h, -2.0, 0.0));
    for patch_size in [0, 40] {
        let cfg = FlowConfig {
            patch_size,
            ..FlowConfig::default()
        };
        assert!(cfg.check().is_err());
        let mut flow = DenseFlow::new(cfg);
        let mut out = FlowField::default();
        flow.compute(&i0, &i1, w, h, &mut out);
        assert!(
            out.u.iter().chain(&out.v).all(|&x| x == 0.0),
            "patch {patch_size}"
        );
    }
}
