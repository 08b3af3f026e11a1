//! COCO run-length encoding of binary masks, byte-compatible with pycocotools.
//!
//! Runs go down columns (Fortran order), start with a run of zeros (possibly empty) and
//! alternate. The compressed string form is pycocotools' `rleToString`: LEB128-like, 5 bits per
//! character offset by 48, with runs after the second stored as deltas to the run two back
//! (`i > 2`, a pycocotools quirk we keep for byte equality).

mod columns;

use crate::frame::{FrameError, Mask};
use crate::scratch::with_scratch;
use columns::CHANGES;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Errors decoding an RLE.
#[derive(Debug, Error, Clone, PartialEq, Eq)]
pub enum RleError {
    /// A character outside pycocotools' alphabet (ASCII 48..=111).
    #[error("invalid character {ch:?} at byte {pos} of the RLE string")]
    BadChar {
        /// The offending character.
        ch: char,
        /// Byte offset.
        pos: usize,
    },
    /// The string ends inside a multi-character number.
    #[error("RLE string ends in the middle of a run length")]
    Truncated,
    /// A decoded run is negative.
    #[error("RLE run {index} is negative ({value})")]
    NegativeRun {
        /// Run index.
        index: usize,
        /// Decoded value.
        value: i64,
    },
    /// Runs do not add up to `height·width`.
    #[error("RLE runs cover {covered} pixels but the mask is {height}x{width} = {expected}")]
    SizeMismatch {
        /// Pixels covered by the runs.
        covered: u64,
        /// Mask height.
        height: u32,
        /// Mask width.
        width: u32,
        /// `height·width`.
        expected: u64,
    },
}

/// A run-length encoded full-image binary mask (COCO layout).
#[derive(Debug, Clone, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Rle {
    /// Image height.
    pub height: u32,
    /// Image width.
    pub width: u32,
    /// Alternating run lengths, zeros first, column-major.
    pub counts: Vec<u32>,
}

/// Where the foreground of a bitmap stored as run lengths lies: runs alternate background /
/// foreground (background first) along lines of `line` pixels, `total` pixels in all (runs
/// past it are cut). Returns `(first line, first position in a line, last line, last
/// position)`, inclusive, or `None` when nothing is foreground. O(runs), no bitmap: COCO RLE
/// (lines are columns) and VOT masks (lines are rows) both find their crop with it.
pub(crate) fn runs_extent(
    runs: impl IntoIterator<Item = u64>,
    line: u64,
    total: u64,
) -> Option<(u64, u64, u64, u64)> {
    if line == 0 || total == 0 {
        return None;
    }
    let (mut l0, mut p0, mut l1, mut p1) = (u64::MAX, u64::MAX, 0u64, 0u64);
    let mut pos = 0u64;
    for (i, c) in runs.into_iter().enumerate() {
        let end = pos.saturating_add(c).min(total);
        if i % 2 == 1 && end > pos {
            let (la, lb) = (pos / line, (end - 1) / line);
            l0 = l0.min(la);
            l1 = l1.max(lb);
            // A run spanning several lines covers the end of the first, the start of the
            // last, and every position of those in between.
            if lb > la {
                p0 = 0;
                p1 = line - 1;
            } else {
                p0 = p0.min(pos % line);
                p1 = p1.max((end - 1) % line);
            }
        }
        pos = end;
    }
    (l0 != u64::MAX).then_some((l0, p0, l1, p1))
}

/// The run lengths of a sequence of pixel values: a run ends where the value changes, and the
/// first run is of zeros (empty when the first value is not 0). COCO RLE (down columns) and
/// CVAT's and VOT's masks (along rows) all count runs this way.
fn runs_of(values: impl IntoIterator<Item = u8>) -> Vec<u64> {
    let mut runs = Vec::new();
    let (mut cur, mut run) = (0u8, 0u64);
    for v in values {
        if v != cur {
            runs.push(run);
            run = 0;
            cur = v;
        }
        run += 1;
    }
    runs.push(run);
    runs
}

/// The run lengths of a row-major 0/1 bitmap, alternating background / foreground and
/// starting with background (0 when the first pixel is foreground). CVAT's `<mask rle>` and
/// VOT's `m…` masks store a mask's box this way; one encoder for both.
pub(crate) fn bitmap_runs(bitmap: &[u8]) -> Vec<u64> {
    runs_of(bitmap.iter().copied())
}

/// Calls `set(line, position)` for every foreground pixel of `runs` (background first, as
/// [`bitmap_runs`] writes them) laid along lines of `line` pixels: the decoder matching
/// [`bitmap_runs`], for CVAT and VOT masks. The caller has checked the runs sum to at most the
/// bitmap's size, so positions stay inside it.
pub(crate) fn for_each_run_pixel(runs: &[u64], line: u64, mut set: impl FnMut(u64, u64)) {
    let mut p = 0u64;
    for (i, &r) in runs.iter().enumerate() {
        if i % 2 == 1 {
            for q in p..p + r {
                set(q / line, q % line);
            }
        }
        p += r;
    }
}

/// An [`Rle`] kept in its compressed string form (pycocotools' `rleToString`, about one byte
/// per run instead of four) with its area: what a long video's history of masks is stored as
/// until the masks are read again.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct PackedRle {
    height: u32,
    width: u32,
    area: u64,
    compressed: Box<str>,
}

impl PackedRle {
    /// Packs `rle`.
    pub fn new(rle: &Rle) -> Self {
        Self {
            height: rle.height,
            width: rle.width,
            area: rle.area(),
            compressed: rle.to_compressed().into_boxed_str(),
        }
    }

    /// The mask as runs again.
    pub fn unpack(&self) -> Rle {
        // The string was written by `Rle::to_compressed`, which `from_compressed` reads back
        // exactly; an empty mask stands in should that ever not hold.
        Rle::from_compressed(&self.compressed, self.height, self.width)
            .unwrap_or_else(|_| Rle::empty(self.width, self.height))
    }

    /// Foreground pixel count (kept: no unpacking).
    pub fn area(&self) -> u64 {
        self.area
    }

    /// Image width and height.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The compressed string (what MOTS and COCO files hold).
    pub fn compressed(&self) -> &str {
        &self.compressed
    }
}

impl Rle {
    /// Encodes a row-major full-image bitmap (`width·height` bytes, non-zero = foreground).
    pub fn encode(width: u32, height: u32, bitmap: &[u8]) -> Result<Rle, FrameError> {
        let expected = crate::frame::pixel_count(width, height);
        if bitmap.len() != expected {
            return Err(FrameError::MaskSize {
                len: bitmap.len(),
                width,
                height,
                expected,
            });
        }
        let (w, h) = (width as usize, height as usize);
        let column_major = (0..w).flat_map(|x| (0..h).map(move |y| (bitmap[y * w + x] != 0) as u8));
        // COCO stores runs as u32; a bitmap of 2³² bytes is far beyond every cap (`limits`).
        let counts = runs_of(column_major)
            .into_iter()
            .map(|r| r as u32)
            .collect();
        Ok(Rle {
            height,
            width,
            counts,
        })
    }

    /// Encodes a [`Mask`] placed in an image of `width × height` (parts outside are clipped).
    ///
    /// Columns outside the mask's rectangle become single runs, so the cost is proportional to
    /// the image width plus the mask's area, not to the image's area (this runs for every shape
    /// of every exported frame).
    pub fn from_mask(mask: &Mask, width: u32, height: u32) -> Rle {
        let (w, h) = (width as i64, height as i64);
        let (mx0, my0) = (mask.x() as i64, mask.y() as i64);
        let (mx1, my1) = (mx0 + mask.width() as i64, my0 + mask.height() as i64);
        let (ya, yb) = (my0.clamp(0, h), my1.clamp(0, h));
        let (xa, xb) = if ya < yb {
            (mx0.clamp(0, w), mx1.clamp(0, w))
        } else {
            (w, w)
        };
        // About two runs a column for a solid shape (the background above and below meets
        // the next column's): reserved once rather than grown a push at a time.
        let mut counts = Vec::with_capacity(2 * (xb - xa) as usize + 2);
        let (mut prev, mut run) = (false, 0u32);
        let mut push = |v: bool, n: u32, prev: &mut bool, run: &mut u32| {
            if n == 0 {
                return;
            }
            if v != *prev {
                counts.push(*run);
                *run = 0;
                *prev = v;
            }
            *run += n;
        };
        // Whole columns left and right of the mask are one background run each side (an
        // image's pixel count fits u32: `io::limits`).
        push(false, height.saturating_mul(xa as u32), &mut prev, &mut run);
        // The mask's columns, from where each changes value down its rows: the rows are
        // compared with the row above a word of 8 pixels at a time (0/1 bytes: the XOR's set
        // bytes are the changes), and a counting sort groups the changes by column. Walking
        // each column down its pixels, a stride apart, was a twentieth of the page's tracker
        // time (issue 10), and most words of a row equal the row above.
        let (bits, stride) = (mask.data(), mask.width() as usize);
        let row0 = (ya - my0) as usize;
        let rows = (yb - ya) as usize;
        // No column of the mask in the image: (xa, xb) may then lie right of it.
        let (c0, c1) = if xa < xb {
            ((xa - mx0) as usize, (xb - mx0) as usize)
        } else {
            (0, 0)
        };
        with_scratch(&CHANGES, |changes| {
            changes.find(bits, stride, (row0, rows), (c0, c1));
            for col in 0..c1 - c0 {
                push(false, ya as u32, &mut prev, &mut run);
                // A column starts as background and flips at each change.
                let (mut v, mut r) = (false, 0usize);
                for &at in changes.of_column(col) {
                    push(v, (at - r) as u32, &mut prev, &mut run);
                    (v, r) = (!v, at);
                }
                push(v, (rows - r) as u32, &mut prev, &mut run);
                push(false, (h - yb) as u32, &mut prev, &mut run);
            }
        });
        push(
            false,
            height.saturating_mul((w - xb) as u32),
            &mut prev,
            &mut run,
        );
        counts.push(run);
        Rle {
            height,
            width,
            counts,
        }
    }

    /// An all-background mask.
    pub fn empty(width: u32, height: u32) -> Rle {
        Rle {
            height,
            width,
            counts: vec![width * height],
        }
    }

    /// Decodes to a row-major full-image bitmap of 0/1 bytes.
    pub fn decode(&self) -> Vec<u8> {
        let (w, h) = (self.width as usize, self.height as usize);
        let mut out = vec![0u8; w * h];
        let mut pos = 0usize;
        for (i, &c) in self.counts.iter().enumerate() {
            let end = (pos + c as usize).min(w * h);
            if i % 2 == 1 {
                for p in pos..end {
                    // column-major position p -> (x, y)
                    let (x, y) = (p / h, p % h);
                    out[y * w + x] = 1;
                }
            }
            pos = end;
        }
        out
    }

    /// The foreground's bounding rectangle `(x0, y0, x1, y1)` (inclusive pixel indices), from
    /// the runs alone; `None` when the mask is empty. O(runs), no bitmap.
    fn fg_rect(&self) -> Option<(u64, u64, u64, u64)> {
        // Column-major: a "line" is a column of `height` pixels.
        let (h, w) = (self.height as u64, self.width as u64);
        runs_extent(self.counts.iter().map(|&c| c as u64), h, h * w)
    }

    /// The foreground's tight box (empty box for an empty mask), like `to_mask().bbox()`
    /// but without decoding: a hostile size costs nothing.
    pub fn bbox(&self) -> crate::frame::BBox {
        match self.fg_rect() {
            Some((x0, y0, x1, y1)) => crate::frame::BBox::new(
                x0 as f64,
                y0 as f64,
                (x1 - x0 + 1) as f64,
                (y1 - y0 + 1) as f64,
            ),
            None => Mask::empty().bbox(),
        }
    }

    /// Decodes to a [`Mask`] cropped to its foreground, without a full-image bitmap: the web
    /// app decodes every shape of every frame it draws, and a 1280×720 scratch image per shape
    /// would cost more than the drawing. O(runs + mask area).
    pub fn to_mask(&self) -> Mask {
        let h = self.height as u64;
        let Some((x0, y0, x1, y1)) = self.fg_rect() else {
            return Mask::empty();
        };
        let total = h * self.width as u64;
        let (w, hh) = (x1 - x0 + 1, y1 - y0 + 1);
        let mut data = vec![0u8; (w * hh) as usize];
        // Pass 2: fill the runs, column by column (inside the rectangle by construction).
        let mut pos = 0u64;
        for (i, &c) in self.counts.iter().enumerate() {
            let end = (pos + c as u64).min(total);
            if i % 2 == 1 {
                for p in pos..end {
                    let (x, y) = (p / h - x0, p % h - y0);
                    if let Some(v) = data.get_mut((y * w + x) as usize) {
                        *v = 1;
                    }
                }
            }
            pos = end;
        }
        Mask::new(x0 as i32, y0 as i32, w as u32, hh as u32, data).unwrap_or_else(|_| Mask::empty())
    }

    /// Number of foreground pixels.
    pub fn area(&self) -> u64 {
        self.counts
            .iter()
            .skip(1)
            .step_by(2)
            .map(|&c| c as u64)
            .sum()
    }

    /// Foreground pixel count shared with `other` (same image size assumed; 0 otherwise).
    pub fn intersection(&self, other: &Rle) -> u64 {
        if self.width != other.width || self.height != other.height {
            return 0;
        }
        // Walk both run lists at once, as pycocotools' rleArea(rleMerge(..., intersect)).
        let (a, b) = (&self.counts, &other.counts);
        let (mut ia, mut ib) = (0usize, 0usize);
        let (mut ra, mut rb) = (
            a.first().copied().unwrap_or(0) as u64,
            b.first().copied().unwrap_or(0) as u64,
        );
        let mut total = 0u64;
        while ia < a.len() && ib < b.len() {
            let step = ra.min(rb);
            if ia % 2 == 1 && ib % 2 == 1 {
                total += step;
            }
            ra -= step;
            rb -= step;
            if ra == 0 {
                ia += 1;
                ra = a.get(ia).copied().unwrap_or(0) as u64;
            }
            if rb == 0 {
                ib += 1;
                rb = b.get(ib).copied().unwrap_or(0) as u64;
            }
        }
        total
    }

    /// Mask IoU as pycocotools' `iou(..., iscrowd=0)`: 0 when the union is empty.
    pub fn iou(&self, other: &Rle) -> f64 {
        let i = self.intersection(other);
        let u = self.area() + other.area() - i;
        if u == 0 {
            0.0
        } else {
            i as f64 / u as f64
        }
    }

    /// Union of two masks of the same size (pycocotools `merge(..., intersect=False)`).
    pub fn union(&self, other: &Rle) -> Rle {
        if self.width != other.width || self.height != other.height {
            return self.clone();
        }
        let a = self.decode();
        let b = other.decode();
        let m: Vec<u8> = a.iter().zip(&b).map(|(x, y)| x | y).collect();
        Rle::encode(self.width, self.height, &m).unwrap_or_else(|_| self.clone())
    }

    /// Compressed string form, identical to pycocotools' `rleToString`.
    pub fn to_compressed(&self) -> String {
        let mut s = String::with_capacity(self.counts.len() * 2);
        for i in 0..self.counts.len() {
            let mut x = self.counts[i] as i64;
            if i > 2 {
                x -= self.counts[i - 2] as i64;
            }
            loop {
                let mut c = (x & 0x1f) as u8;
                x >>= 5;
                let more = if c & 0x10 != 0 { x != -1 } else { x != 0 };
                if more {
                    c |= 0x20;
                }
                s.push((c + 48) as char);
                if !more {
                    break;
                }
            }
        }
        s
    }

    /// Parses pycocotools' compressed string for an image of `height × width`.
    pub fn from_compressed(s: &str, height: u32, width: u32) -> Result<Rle, RleError> {
        let bytes = s.as_bytes();
        let mut counts: Vec<u32> = Vec::new();
        let mut p = 0usize;
        while p < bytes.len() {
            let (mut x, mut k) = (0i64, 0u32);
            loop {
                let Some(&b) = bytes.get(p) else {
                    return Err(RleError::Truncated);
                };
                if !(48..=111).contains(&b) {
                    return Err(RleError::BadChar {
                        ch: b as char,
                        pos: p,
                    });
                }
                let c = (b - 48) as i64;
                if k < 13 {
                    x |= (c & 0x1f) << (5 * k);
                }
                let more = c & 0x20 != 0;
                p += 1;
                k += 1;
                if !more {
                    if c & 0x10 != 0 && k < 13 {
                        x |= -1i64 << (5 * k);
                    }
                    break;
                }
            }
            let m = counts.len();
            if m > 2 {
                x += counts[m - 2] as i64;
            }
            if !(0..=u32::MAX as i64).contains(&x) {
                return Err(RleError::NegativeRun { index: m, value: x });
            }
            counts.push(x as u32);
        }
        let covered: u64 = counts.iter().map(|&c| c as u64).sum();
        let expected = height as u64 * width as u64;
        if covered != expected {
            return Err(RleError::SizeMismatch {
                covered,
                height,
                width,
                expected,
            });
        }
        Ok(Rle {
            height,
            width,
            counts,
        })
    }
}

#[cfg(test)]
#[path = "rle_tests.rs"]
mod tests;
