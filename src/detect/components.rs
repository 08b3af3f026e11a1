//! Connected components of a binary image, labelled by runs.
//!
//! Each row is cut into runs of foreground pixels; a run is joined (union–find) to the runs of
//! the previous row it touches (overlapping columns for 4-connectivity, also diagonal neighbours
//! for 8-connectivity). Work is proportional to the number of runs, not pixels, plus one scan of
//! the bitmap. Components are numbered in raster order of their first pixel, so the output is
//! deterministic.

use super::DetectError;
use crate::frame::{BBox, Mask};
use crate::runs::{first_nonzero, first_zero};

/// Which neighbours make pixels connected. In settings it is written as the neighbour count,
/// `4` or `8`, as image-processing libraries name it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "u8", into = "u8")]
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(type = "4 | 8"))]
pub enum Connectivity {
    /// Left, right, up, down.
    Four,
    /// The four plus the diagonals.
    #[default]
    Eight,
}

impl TryFrom<u8> for Connectivity {
    type Error = String;
    fn try_from(n: u8) -> Result<Self, String> {
        match n {
            4 => Ok(Connectivity::Four),
            8 => Ok(Connectivity::Eight),
            n => Err(format!("connectivity {n}: expected 4 or 8")),
        }
    }
}

impl From<Connectivity> for u8 {
    fn from(c: Connectivity) -> u8 {
        match c {
            Connectivity::Four => 4,
            Connectivity::Eight => 8,
        }
    }
}

/// A horizontal run of foreground pixels `[x0, x1)` on row `y`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Run {
    /// Row.
    pub y: u32,
    /// First column.
    pub x0: u32,
    /// One past the last column.
    pub x1: u32,
}

/// One connected component: its pixel count and bounding rectangle `[x0, x1) × [y0, y1)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Blob {
    /// Number of pixels.
    pub area: u64,
    /// Left column.
    pub x0: u32,
    /// Top row.
    pub y0: u32,
    /// One past the right column.
    pub x1: u32,
    /// One past the bottom row.
    pub y1: u32,
}

impl Blob {
    /// The bounding rectangle as a box.
    pub fn bbox(&self) -> BBox {
        BBox::new(
            self.x0 as f64,
            self.y0 as f64,
            (self.x1 - self.x0) as f64,
            (self.y1 - self.y0) as f64,
        )
    }
}

/// A connected-component labeller that keeps its buffers between calls.
#[derive(Debug, Default, Clone)]
pub struct Components {
    runs: Vec<Run>,
    parent: Vec<u32>,
    run_blob: Vec<u32>,
    blobs: Vec<Blob>,
    /// Runs sorted by blob: blob `i` owns `order[start[i]..start[i+1]]`.
    order: Vec<u32>,
    start: Vec<u32>,
}

fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        // Path halving keeps the trees flat without recursion.
        let p = parent[i as usize];
        parent[i as usize] = parent[p as usize];
        i = parent[i as usize];
    }
    i
}

impl Components {
    /// An empty labeller.
    pub fn new() -> Self {
        Self::default()
    }

    /// Labels `bits` (`width·height` bytes, row-major, non-zero = foreground) and returns the
    /// components in raster order of their first pixel.
    pub fn label(
        &mut self,
        bits: &[u8],
        width: u32,
        height: u32,
        connectivity: Connectivity,
    ) -> Result<&[Blob], DetectError> {
        let (w, h) = (width as usize, height as usize);
        if bits.len() != w * h {
            return Err(DetectError::BitmapSize {
                len: bits.len(),
                width,
                height,
            });
        }
        self.runs.clear();
        self.parent.clear();
        // 8-connectivity also joins runs that only touch diagonally: widen by one column.
        let reach = (connectivity == Connectivity::Eight) as u32;
        let mut prev_start = 0usize;
        for (y, row) in bits.chunks_exact(w.max(1)).take(h).enumerate() {
            let row_start = self.runs.len();
            let mut x = 0usize;
            while x < w {
                // Skip background quickly.
                match first_nonzero(&row[x..]) {
                    Some(p) => x += p,
                    None => break,
                }
                let end = x + first_zero(&row[x..]);
                self.runs.push(Run {
                    y: y as u32,
                    x0: x as u32,
                    x1: end as u32,
                });
                self.parent.push((self.runs.len() - 1) as u32);
                x = end;
            }
            // Join with the previous row's runs: both lists are sorted by x, so sweep.
            let (mut i, mut j) = (prev_start, row_start);
            let prev_end = row_start;
            while i < prev_end && j < self.runs.len() {
                let (a, b) = (self.runs[i], self.runs[j]);
                if a.x0 < b.x1 + reach && b.x0 < a.x1 + reach {
                    let (ra, rb) = (
                        find(&mut self.parent, i as u32),
                        find(&mut self.parent, j as u32),
                    );
                    if ra != rb {
                        // The older root wins, so roots stay the raster-first run.
                        let (lo, hi) = (ra.min(rb), ra.max(rb));
                        self.parent[hi as usize] = lo;
                    }
                }
                if a.x1 < b.x1 {
                    i += 1;
                } else {
                    j += 1;
                }
            }
            prev_start = row_start;
        }
        self.blobs.clear();
        self.run_blob.clear();
        self.run_blob.resize(self.runs.len(), u32::MAX);
        for k in 0..self.runs.len() {
            let root = find(&mut self.parent, k as u32) as usize;
            // Roots come before their members, so the root's blob already exists.
            let b = if root == k {
                self.blobs.push(Blob {
                    area: 0,
                    x0: u32::MAX,
                    y0: u32::MAX,
                    x1: 0,
                    y1: 0,
                });
                (self.blobs.len() - 1) as u32
            } else {
                self.run_blob[root]
            };
            self.run_blob[k] = b;
            let r = self.runs[k];
            let blob = &mut self.blobs[b as usize];
            blob.area += (r.x1 - r.x0) as u64;
            blob.x0 = blob.x0.min(r.x0);
            blob.x1 = blob.x1.max(r.x1);
            blob.y0 = blob.y0.min(r.y);
            blob.y1 = blob.y1.max(r.y + 1);
        }
        // Counting sort of runs by blob.
        self.start.clear();
        self.start.resize(self.blobs.len() + 1, 0);
        for &b in &self.run_blob {
            self.start[b as usize + 1] += 1;
        }
        for i in 0..self.blobs.len() {
            self.start[i + 1] += self.start[i];
        }
        self.order.clear();
        self.order.resize(self.runs.len(), 0);
        let mut fill = self.start.clone();
        for (k, &b) in self.run_blob.iter().enumerate() {
            self.order[fill[b as usize] as usize] = k as u32;
            fill[b as usize] += 1;
        }
        Ok(&self.blobs)
    }

    /// The components of the last [`Components::label`] call.
    pub fn blobs(&self) -> &[Blob] {
        &self.blobs
    }

    /// The runs of component `i` (empty for an unknown index), top to bottom.
    pub fn runs(&self, i: usize) -> impl Iterator<Item = Run> + '_ {
        let (a, b) = match (self.start.get(i), self.start.get(i + 1)) {
            (Some(&a), Some(&b)) => (a as usize, b as usize),
            _ => (0, 0),
        };
        self.order[a..b].iter().map(|&k| self.runs[k as usize])
    }

    /// Component `i` as a mask cropped to its bounding rectangle (`None` for an unknown index).
    pub fn mask(&self, i: usize) -> Option<Mask> {
        let b = self.blobs.get(i)?;
        let (w, h) = ((b.x1 - b.x0) as usize, (b.y1 - b.y0) as usize);
        let mut data = vec![0u8; w * h];
        for r in self.runs(i) {
            let row = (r.y - b.y0) as usize * w;
            data[row + (r.x0 - b.x0) as usize..row + (r.x1 - b.x0) as usize].fill(1);
        }
        Mask::new(b.x0 as i32, b.y0 as i32, w as u32, h as u32, data).ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Flood-fill reference labelling.
    fn reference(bits: &[u8], w: usize, h: usize, eight: bool) -> Vec<Vec<(usize, usize)>> {
        let mut seen = vec![false; w * h];
        let mut out = Vec::new();
        for y in 0..h {
            for x in 0..w {
                if bits[y * w + x] == 0 || seen[y * w + x] {
                    continue;
                }
                let mut comp = Vec::new();
                let mut stack = vec![(x, y)];
                seen[y * w + x] = true;
                while let Some((cx, cy)) = stack.pop() {
                    comp.push((cx, cy));
                    for dy in -1i64..=1 {
                        for dx in -1i64..=1 {
                            if (dx == 0 && dy == 0) || (!eight && dx != 0 && dy != 0) {
                                continue;
                            }
                            let (nx, ny) = (cx as i64 + dx, cy as i64 + dy);
                            if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                                continue;
                            }
                            let k = ny as usize * w + nx as usize;
                            if bits[k] != 0 && !seen[k] {
                                seen[k] = true;
                                stack.push((nx as usize, ny as usize));
                            }
                        }
                    }
                }
                comp.sort_by_key(|&(x, y)| (y, x));
                out.push(comp);
            }
        }
        out
    }

    #[test]
    fn agrees_with_flood_fill() {
        let mut s = 99u32;
        let mut c = Components::new();
        for (w, h) in [(1, 1), (9, 1), (1, 9), (17, 13), (64, 48)] {
            for density in [2u32, 3, 5] {
                let bits: Vec<u8> = (0..w * h)
                    .map(|_| {
                        s = s.wrapping_mul(1_103_515_245).wrapping_add(12345);
                        ((s >> 16) % density == 0) as u8
                    })
                    .collect();
                for conn in [Connectivity::Four, Connectivity::Eight] {
                    let want = reference(&bits, w, h, conn == Connectivity::Eight);
                    let n = c.label(&bits, w as u32, h as u32, conn).unwrap().len();
                    assert_eq!(n, want.len(), "{w}x{h} {conn:?}");
                    for (i, comp) in want.iter().enumerate() {
                        let m = c.mask(i).unwrap();
                        let mut got: Vec<(usize, usize)> =
                            m.pixels().map(|(x, y)| (x as usize, y as usize)).collect();
                        got.sort_by_key(|&(x, y)| (y, x));
                        assert_eq!(&got, comp);
                        assert_eq!(c.blobs()[i].area, comp.len() as u64);
                    }
                }
            }
        }
    }

    #[test]
    fn diagonal_touch_depends_on_connectivity() {
        let bits = [1, 0, 0, 1];
        let mut c = Components::new();
        assert_eq!(c.label(&bits, 2, 2, Connectivity::Eight).unwrap().len(), 1);
        assert_eq!(c.label(&bits, 2, 2, Connectivity::Four).unwrap().len(), 2);
        assert!(matches!(
            c.label(&bits, 3, 2, Connectivity::Four),
            Err(DetectError::BitmapSize { .. })
        ));
        assert!(c.mask(5).is_none());
    }
}
