//! [`Mask`]: a binary mask as a bitmap inside its bounding rectangle, with its area and
//! foreground box counted once when it is built, and the overlap counts the tracker scores
//! pairs with.

use super::{pixel_count, BBox, FrameError, Point};
use crate::runs::{first_nonzero, last_nonzero};
use serde::{Deserialize, Serialize};

/// Foreground pixels of a 0/1 bitmap. Bytes are added as bytes in blocks of 255 (a block's
/// count fits one), which vectorises 16 or more at a time; the tracker takes two mask areas
/// per scored pair, and widening each byte first was most of the pair's time (issue 10).
pub(super) fn count_ones(bits: &[u8]) -> u64 {
    bits.chunks(255)
        .map(|c| u64::from(c.iter().fold(0u8, |n, &v| n.wrapping_add(v))))
        .sum()
}

/// Pixels foreground in both of two equally long rows of 0/1 bitmaps ([`count_ones`] of
/// their intersection).
pub(super) fn count_common(a: &[u8], b: &[u8]) -> u64 {
    a.chunks(255)
        .zip(b.chunks(255))
        .map(|(a, b)| {
            u64::from(
                a.iter()
                    .zip(b)
                    .fold(0u8, |n, (&x, &y)| n.wrapping_add(x & y)),
            )
        })
        .sum()
}

/// A binary mask stored as a bitmap inside its bounding rectangle.
///
/// `(x, y)` is the image position of the bitmap's top-left pixel; `data` holds `width·height`
/// bytes, row-major, 1 for foreground and 0 for background.
///
/// A mask never changes once built, so its area and foreground box are counted once, when it
/// is built: the tracker asks for them for every pair it scores (recounting the bitmap per
/// pair was about a tenth of the tracking time with 200 shapes).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawMask", into = "RawMask")]
pub struct Mask {
    x: i32,
    y: i32,
    width: u32,
    height: u32,
    data: Vec<u8>,
    /// Foreground pixels.
    area: u64,
    /// Tight box of the foreground (the zero box when empty).
    fg_box: BBox,
}

/// A mask as it is serialised: the bitmap and its place, nothing derived from them (the same
/// fields as before the counts were cached, so stored masks still read).
#[derive(Serialize, Deserialize)]
struct RawMask {
    x: i32,
    y: i32,
    width: u32,
    height: u32,
    data: Vec<u8>,
}

impl TryFrom<RawMask> for Mask {
    type Error = FrameError;
    /// Checks the bitmap's length, as [`Mask::new`] does: a stored mask with a short bitmap is
    /// an error, not a mask that panics when read.
    fn try_from(r: RawMask) -> Result<Self, FrameError> {
        Mask::new(r.x, r.y, r.width, r.height, r.data)
    }
}

impl From<Mask> for RawMask {
    fn from(m: Mask) -> Self {
        RawMask {
            x: m.x,
            y: m.y,
            width: m.width,
            height: m.height,
            data: m.data,
        }
    }
}

/// The tight box of the foreground of a `width`-wide 0/1 bitmap placed at `(x, y)` (the zero
/// box when empty).
fn foreground_box(x: i32, y: i32, width: u32, data: &[u8]) -> BBox {
    if width == 0 {
        return BBox::default();
    }
    let (mut x0, mut y0, mut x1, mut y1) = (i64::MAX, i64::MAX, i64::MIN, i64::MIN);
    for (ly, row) in data.chunks_exact(width as usize).enumerate() {
        // A word at a time: every mask built is scanned here (issue 10).
        if let (Some(a), Some(b)) = (first_nonzero(row), last_nonzero(row)) {
            x0 = x0.min(a as i64);
            x1 = x1.max(b as i64);
            y0 = y0.min(ly as i64);
            y1 = y1.max(ly as i64);
        }
    }
    if x0 == i64::MAX {
        return BBox::default();
    }
    BBox::new(
        (x as i64 + x0) as f64,
        (y as i64 + y0) as f64,
        (x1 - x0 + 1) as f64,
        (y1 - y0 + 1) as f64,
    )
}

impl Mask {
    /// Every constructor ends here: `data` holds `width·height` bytes of 0/1 (checked by the
    /// callers), and the counts are taken once.
    fn from_parts(x: i32, y: i32, width: u32, height: u32, data: Vec<u8>) -> Self {
        debug_assert_eq!(data.len(), pixel_count(width, height));
        Self {
            x,
            y,
            width,
            height,
            area: count_ones(&data),
            fg_box: foreground_box(x, y, width, &data),
            data,
        }
    }

    /// A mask whose bitmap (any non-zero byte = foreground) starts at image position `(x, y)`.
    pub fn new(x: i32, y: i32, width: u32, height: u32, data: Vec<u8>) -> Result<Self, FrameError> {
        let expected = pixel_count(width, height);
        if data.len() != expected {
            return Err(FrameError::MaskSize {
                len: data.len(),
                width,
                height,
                expected,
            });
        }
        let data = data.into_iter().map(|v| (v != 0) as u8).collect();
        Ok(Self::from_parts(x, y, width, height, data))
    }

    /// An empty mask (no pixels).
    pub fn empty() -> Self {
        Self::from_parts(0, 0, 0, 0, Vec::new())
    }

    /// A mask from a full-image bitmap (`img_w·img_h` bytes, row-major), cropped to its
    /// foreground's bounding rectangle.
    pub fn from_full(img_w: u32, img_h: u32, full: &[u8]) -> Result<Self, FrameError> {
        let expected = pixel_count(img_w, img_h);
        if full.len() != expected {
            return Err(FrameError::MaskSize {
                len: full.len(),
                width: img_w,
                height: img_h,
                expected,
            });
        }
        let (mut x0, mut y0, mut x1, mut y1) = (u32::MAX, u32::MAX, 0u32, 0u32);
        for (y, row) in (0u32..).zip(full.chunks_exact(img_w.max(1) as usize)) {
            if let (Some(a), Some(b)) = (first_nonzero(row), last_nonzero(row)) {
                x0 = x0.min(a as u32);
                x1 = x1.max(b as u32);
                y0 = y0.min(y);
                y1 = y1.max(y);
            }
        }
        if x0 == u32::MAX {
            return Ok(Self::empty());
        }
        let (w, h) = (x1 - x0 + 1, y1 - y0 + 1);
        let mut data = Vec::with_capacity((w * h) as usize);
        for y in y0..=y1 {
            for x in x0..=x1 {
                data.push((full[(y * img_w + x) as usize] != 0) as u8);
            }
        }
        Ok(Self::from_parts(x0 as i32, y0 as i32, w, h, data))
    }

    /// A filled rectangle covering the pixels whose centres lie inside `b`.
    pub fn from_bbox(b: &BBox) -> Self {
        let x0 = (b.x - 0.5).ceil() as i32;
        let y0 = (b.y - 0.5).ceil() as i32;
        let x1 = (b.x2() - 0.5).ceil() as i32; // exclusive
        let y1 = (b.y2() - 0.5).ceil() as i32;
        if x1 <= x0 || y1 <= y0 {
            return Self::empty();
        }
        let (w, h) = ((x1 - x0) as u32, (y1 - y0) as u32);
        Self::from_parts(x0, y0, w, h, vec![1; (w * h) as usize])
    }

    /// Image x of the bitmap's left column.
    pub fn x(&self) -> i32 {
        self.x
    }

    /// Image y of the bitmap's top row.
    pub fn y(&self) -> i32 {
        self.y
    }

    /// Bitmap width.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Bitmap height.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The bitmap, row-major, 0/1 bytes.
    pub fn data(&self) -> &[u8] {
        &self.data
    }

    /// Whether the image pixel `(x, y)` is foreground.
    #[inline]
    pub fn get(&self, x: i32, y: i32) -> bool {
        let (lx, ly) = (x - self.x, y - self.y);
        if lx < 0 || ly < 0 || lx >= self.width as i32 || ly >= self.height as i32 {
            return false;
        }
        self.data[ly as usize * self.width as usize + lx as usize] != 0
    }

    /// Number of foreground pixels.
    pub fn area(&self) -> u64 {
        self.area
    }

    /// Whether the mask has no foreground pixel.
    pub fn is_empty(&self) -> bool {
        self.area == 0
    }

    /// The bitmap's rectangle as a box (`x, y, width, height`), which may include background.
    pub fn rect(&self) -> BBox {
        BBox::new(
            self.x as f64,
            self.y as f64,
            self.width as f64,
            self.height as f64,
        )
    }

    /// The tight bounding box of the foreground pixels (zero box when empty).
    pub fn bbox(&self) -> BBox {
        self.fg_box
    }

    /// Centroid of the foreground from the image moments `M10/M00`, `M01/M00` (thesis eq. 10),
    /// using pixel centres. `None` when empty.
    pub fn centroid(&self) -> Option<Point> {
        let (mut m00, mut m10, mut m01) = (0u64, 0f64, 0f64);
        for ly in 0..self.height as usize {
            for lx in 0..self.width as usize {
                if self.data[ly * self.width as usize + lx] != 0 {
                    m00 += 1;
                    m10 += lx as f64;
                    m01 += ly as f64;
                }
            }
        }
        if m00 == 0 {
            return None;
        }
        let n = m00 as f64;
        Some(Point::new(
            self.x as f64 + m10 / n + 0.5,
            self.y as f64 + m01 / n + 0.5,
        ))
    }

    /// Number of pixels foreground in both masks.
    pub fn intersection(&self, other: &Mask) -> u64 {
        self.intersection_shifted(0, 0, other)
    }

    /// Number of pixels foreground both in this mask moved by `(dx, dy)` whole pixels and in
    /// `other`: `self.translated(dx, dy).intersection(other)` without copying the bitmap.
    pub fn intersection_shifted(&self, dx: i32, dy: i32, other: &Mask) -> u64 {
        let (sx, sy) = (self.x + dx, self.y + dy);
        let x0 = sx.max(other.x);
        let y0 = sy.max(other.y);
        let x1 = (sx + self.width as i32).min(other.x + other.width as i32);
        let y1 = (sy + self.height as i32).min(other.y + other.height as i32);
        if x1 <= x0 {
            return 0;
        }
        let len = (x1 - x0) as usize;
        let mut n = 0u64;
        for y in y0..y1 {
            let ra = (y - sy) as usize * self.width as usize + (x0 - sx) as usize;
            let rb = (y - other.y) as usize * other.width as usize + (x0 - other.x) as usize;
            // Row slices, so the count vectorises (the tracker scores every pair this way).
            n += count_common(&self.data[ra..ra + len], &other.data[rb..rb + len]);
        }
        n
    }

    /// Mask intersection over union in `[0, 1]` (0 when both are empty).
    pub fn iou(&self, other: &Mask) -> f64 {
        self.iou_shifted(0, 0, other)
    }

    /// [`Mask::iou`] of this mask moved by `(dx, dy)` whole pixels with `other`, without
    /// copying the bitmap (the tracker scores every pair this way).
    pub fn iou_shifted(&self, dx: i32, dy: i32, other: &Mask) -> f64 {
        let i = self.intersection_shifted(dx, dy, other);
        let u = self.area() + other.area() - i;
        if u == 0 {
            0.0
        } else {
            i as f64 / u as f64
        }
    }

    /// The same mask moved by whole pixels.
    pub fn translated(&self, dx: i32, dy: i32) -> Mask {
        Mask {
            x: self.x + dx,
            y: self.y + dy,
            // An empty mask's box stays the zero box, as `bbox` promises.
            fg_box: if self.area == 0 {
                BBox::default()
            } else {
                self.fg_box.translated(dx as f64, dy as f64)
            },
            ..self.clone()
        }
    }

    /// The mask clipped to an image of `img_w × img_h` and cropped to its foreground.
    pub fn clipped(&self, img_w: u32, img_h: u32) -> Mask {
        let x0 = self.x.max(0);
        let y0 = self.y.max(0);
        let x1 = (self.x + self.width as i32).min(img_w as i32);
        let y1 = (self.y + self.height as i32).min(img_h as i32);
        if x1 <= x0 || y1 <= y0 {
            return Mask::empty();
        }
        let (w, h) = ((x1 - x0) as u32, (y1 - y0) as u32);
        let mut data = Vec::with_capacity((w * h) as usize);
        for y in y0..y1 {
            for x in x0..x1 {
                data.push(self.get(x, y) as u8);
            }
        }
        let m = Self::from_parts(x0, y0, w, h, data);
        m.tight()
    }

    /// The same foreground in the smallest bitmap that holds it.
    pub fn tight(&self) -> Mask {
        let b = self.bbox();
        if b.area() == 0.0 {
            return Mask::empty();
        }
        let (x0, y0, w, h) = (b.x as i32, b.y as i32, b.w as u32, b.h as u32);
        if x0 == self.x && y0 == self.y && w == self.width && h == self.height {
            return self.clone();
        }
        let mut data = Vec::with_capacity((w * h) as usize);
        for y in y0..y0 + h as i32 {
            for x in x0..x0 + w as i32 {
                data.push(self.get(x, y) as u8);
            }
        }
        Self::from_parts(x0, y0, w, h, data)
    }

    /// The foreground as a full-image bitmap of `img_w × img_h` bytes (0/1), clipped.
    pub fn to_full(&self, img_w: u32, img_h: u32) -> Vec<u8> {
        let mut full = vec![0u8; img_w as usize * img_h as usize];
        for ly in 0..self.height as i32 {
            let y = self.y + ly;
            if y < 0 || y >= img_h as i32 {
                continue;
            }
            for lx in 0..self.width as i32 {
                let x = self.x + lx;
                if x < 0 || x >= img_w as i32 {
                    continue;
                }
                if self.data[(ly * self.width as i32 + lx) as usize] != 0 {
                    full[y as usize * img_w as usize + x as usize] = 1;
                }
            }
        }
        full
    }

    /// Iterates over the image coordinates of foreground pixels, row by row.
    pub fn pixels(&self) -> impl Iterator<Item = (i32, i32)> + '_ {
        let w = self.width as usize;
        self.data
            .iter()
            .enumerate()
            .filter(|(_, &v)| v != 0)
            .map(move |(i, _)| (self.x + (i % w) as i32, self.y + (i / w) as i32))
    }
}
