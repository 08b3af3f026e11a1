//! Run-level mask operations for MOTS preprocessing, without decoding to bitmaps.
//!
//! A COCO RLE lists alternating background/foreground runs in column-major pixel order, so the
//! foreground is a sorted list of half-open intervals of pixel indices. Union and overlap tests
//! become interval sweeps: linear in the number of runs instead of the image size.

use crate::io::Rle;

/// Foreground intervals `[start, end)` of `rle`, in increasing order.
pub(crate) fn intervals(rle: &Rle) -> impl Iterator<Item = (u64, u64)> + '_ {
    let mut pos = 0u64;
    rle.counts.iter().enumerate().filter_map(move |(k, &c)| {
        let start = pos;
        pos += c as u64;
        (k % 2 == 1 && c > 0).then_some((start, pos))
    })
}

/// Union of masks of the same size (`width × height`), as pycocotools' `merge(intersect=False)`.
pub(crate) fn union(masks: &[&Rle], width: u32, height: u32) -> Rle {
    let mut iv: Vec<(u64, u64)> = masks.iter().flat_map(|m| intervals(m)).collect();
    iv.sort_unstable();
    let total = width as u64 * height as u64;
    let mut counts = Vec::with_capacity(iv.len() * 2 + 1);
    let mut pos = 0u64;
    let mut cur: Option<(u64, u64)> = None;
    let emit = |(s, e): (u64, u64), counts: &mut Vec<u32>, pos: &mut u64| {
        counts.push((s - *pos) as u32);
        counts.push((e - s) as u32);
        *pos = e;
    };
    for (s, e) in iv {
        cur = match cur {
            Some((cs, ce)) if s <= ce => Some((cs, ce.max(e))),
            Some(run) => {
                emit(run, &mut counts, &mut pos);
                Some((s, e))
            }
            None => Some((s, e)),
        };
    }
    if let Some(run) = cur {
        emit(run, &mut counts, &mut pos);
    }
    // Like pycocotools, no trailing empty run after foreground that reaches the last pixel.
    if total > pos || counts.is_empty() {
        counts.push(total.saturating_sub(pos) as u32);
    }
    Rle {
        height,
        width,
        counts,
    }
}

/// Index (into `masks`) of a mask that overlaps an earlier one, if any: sweeps all intervals
/// sorted by start and reports the later-listed mask of the first overlapping pair found.
pub(crate) fn first_overlap(masks: &[&Rle]) -> Option<usize> {
    let mut iv: Vec<(u64, u64, usize)> = masks
        .iter()
        .enumerate()
        .flat_map(|(k, m)| intervals(m).map(move |(s, e)| (s, e, k)))
        .collect();
    iv.sort_unstable();
    let mut reach: Option<(u64, usize)> = None;
    for (s, e, k) in iv {
        if let Some((end, owner)) = reach {
            if s < end {
                return Some(k.max(owner));
            }
            if e > end {
                reach = Some((e, k));
            }
        } else {
            reach = Some((e, k));
        }
    }
    None
}

/// Intersection over the area of `det` (pycocotools `iou(.., iscrowd=1)`); 0 for an empty mask.
pub(crate) fn ioa(det: &Rle, region: &Rle) -> f64 {
    let area = det.area();
    if area == 0 {
        return 0.0;
    }
    det.intersection(region) as f64 / area as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rle(w: u32, h: u32, on: &[(usize, usize)]) -> Rle {
        let mut m = vec![0u8; (w * h) as usize];
        for &(x, y) in on {
            m[y * w as usize + x] = 1;
        }
        Rle::encode(w, h, &m).unwrap()
    }

    #[test]
    fn union_and_overlap_match_bitmaps() {
        let a = rle(4, 3, &[(0, 0), (0, 1), (2, 2)]);
        let b = rle(4, 3, &[(0, 1), (1, 0), (3, 2)]);
        let c = rle(4, 3, &[(3, 0)]);
        let u = union(&[&a, &b, &c], 4, 3);
        assert_eq!(u, a.union(&b).union(&c));
        assert_eq!(first_overlap(&[&a, &c]), None);
        assert_eq!(first_overlap(&[&a, &c, &b]), Some(2));
        assert_eq!(union(&[], 4, 3), Rle::empty(4, 3));
        assert!((ioa(&b, &a) - 1.0 / 3.0).abs() < 1e-15);
        assert_eq!(ioa(&Rle::empty(4, 3), &a), 0.0);
    }
}
