//! Estimating how much of each box is visible when the ground truth has no visibility of its
//! own: the occlusion a miss model reacts to, judged from the boxes in front.

use crate::frame::BBox;

/// The visible fraction of each box: the share of a coarse grid of points inside it not
/// covered by a box in front (in front = lower bottom edge, nearer the camera).
pub fn estimate_visibility(boxes: &[BBox]) -> Vec<f64> {
    const N: usize = 8;
    boxes
        .iter()
        .enumerate()
        .map(|(i, b)| {
            if !(b.w > 0.0 && b.h > 0.0) {
                return 1.0;
            }
            let front: Vec<&BBox> = boxes
                .iter()
                .enumerate()
                .filter(|&(j, o)| j != i && o.y2() > b.y2() && o.overlaps(b))
                .map(|(_, o)| o)
                .collect();
            if front.is_empty() {
                return 1.0;
            }
            let mut covered = 0;
            for gy in 0..N {
                for gx in 0..N {
                    let x = b.x + b.w * (gx as f64 + 0.5) / N as f64;
                    let y = b.y + b.h * (gy as f64 + 0.5) / N as f64;
                    if front
                        .iter()
                        .any(|o| x >= o.x && x < o.x2() && y >= o.y && y < o.y2())
                    {
                        covered += 1;
                    }
                }
            }
            1.0 - covered as f64 / (N * N) as f64
        })
        .collect()
}
