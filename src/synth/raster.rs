//! Scanline polygon filling at pixel centres.
//!
//! A pixel `(x, y)` belongs to a polygon when its centre `(x+0.5, y+0.5)` lies inside it under
//! the even–odd rule, with half-open edges (a centre exactly on a left/top edge is in, on a
//! right/bottom edge is out). So two polygons sharing an edge never both own a pixel, and an
//! axis-aligned square with integer corners covers exactly the pixels it geometrically covers.

/// Reusable scratch space for [`Rasterizer::spans`], so filling allocates nothing per frame.
#[derive(Debug, Default, Clone)]
pub(crate) struct Rasterizer {
    xs: Vec<f64>,
}

impl Rasterizer {
    /// Calls `span(y, x0, x1)` for every row `y` in `rows` and every run of pixels `x0..x1`
    /// (unclipped in x) whose centres are inside `poly`. Rows outside `rows` are skipped.
    pub(crate) fn spans(
        &mut self,
        poly: &[[f64; 2]],
        rows: std::ops::Range<i32>,
        mut span: impl FnMut(i32, i32, i32),
    ) {
        if poly.len() < 3 {
            return;
        }
        let (mut ymin, mut ymax) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in poly {
            ymin = ymin.min(p[1]);
            ymax = ymax.max(p[1]);
        }
        if !(ymin.is_finite() && ymax.is_finite()) {
            return;
        }
        let y0 = ((ymin - 0.5).ceil() as i32).max(rows.start);
        let y1 = ((ymax - 0.5).ceil() as i32).min(rows.end);
        for y in y0..y1 {
            let yc = y as f64 + 0.5;
            self.xs.clear();
            let mut prev = poly[poly.len() - 1];
            for &p in poly {
                // Half-open crossing test: counts a vertex on the scanline exactly once.
                if (prev[1] <= yc) != (p[1] <= yc) {
                    let t = (yc - prev[1]) / (p[1] - prev[1]);
                    self.xs.push(prev[0] + t * (p[0] - prev[0]));
                }
                prev = p;
            }
            // Few crossings per row (2 for convex shapes): insertion sort beats sort_by here.
            for i in 1..self.xs.len() {
                let mut j = i;
                while j > 0 && self.xs[j - 1] > self.xs[j] {
                    self.xs.swap(j - 1, j);
                    j -= 1;
                }
            }
            for pair in self.xs.chunks_exact(2) {
                let xa = (pair[0] - 0.5).ceil() as i32;
                let xb = (pair[1] - 0.5).ceil() as i32;
                if xb > xa {
                    span(y, xa, xb);
                }
            }
        }
    }

    /// Number of pixels `poly` covers, without clipping (its full silhouette).
    pub(crate) fn area(&mut self, poly: &[[f64; 2]]) -> u64 {
        let mut n = 0u64;
        self.spans(poly, i32::MIN..i32::MAX, |_, a, b| n += (b - a) as u64);
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integer_square_covers_exact_pixels() {
        let mut r = Rasterizer::default();
        let sq = [[90.0, 40.0], [110.0, 40.0], [110.0, 60.0], [90.0, 60.0]];
        let mut rows = Vec::new();
        r.spans(&sq, 0..1000, |y, a, b| rows.push((y, a, b)));
        assert_eq!(rows.len(), 20);
        assert!(rows.iter().all(|&(_, a, b)| (a, b) == (90, 110)));
        assert_eq!((rows[0].0, rows[19].0), (40, 59));
        assert_eq!(r.area(&sq), 400);
    }

    #[test]
    fn shared_edge_pixels_belong_to_one_polygon() {
        let mut r = Rasterizer::default();
        let a = [[0.0, 0.0], [10.3, 0.0], [5.7, 10.0]];
        let b = [[10.3, 0.0], [15.0, 10.0], [5.7, 10.0]];
        let mut grid = vec![0u8; 20 * 20];
        for poly in [&a[..], &b[..]] {
            r.spans(poly, 0..20, |y, x0, x1| {
                for x in x0..x1 {
                    grid[y as usize * 20 + x as usize] += 1;
                }
            });
        }
        assert!(grid.iter().all(|&v| v <= 1));
    }

    #[test]
    fn non_convex_polygon_has_two_spans_per_row() {
        // A "U": the gap between the arms must stay empty.
        let u = [
            [0.0, 0.0],
            [3.0, 0.0],
            [3.0, 6.0],
            [7.0, 6.0],
            [7.0, 0.0],
            [10.0, 0.0],
            [10.0, 10.0],
            [0.0, 10.0],
        ];
        let mut r = Rasterizer::default();
        let mut spans = Vec::new();
        r.spans(&u, 0..3, |y, a, b| spans.push((y, a, b)));
        assert_eq!(
            spans,
            vec![
                (0, 0, 3),
                (0, 7, 10),
                (1, 0, 3),
                (1, 7, 10),
                (2, 0, 3),
                (2, 7, 10)
            ]
        );
        assert_eq!(r.area(&u), 100 - 24);
    }
}
