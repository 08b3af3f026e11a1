//! The data every stage shares: frames, boxes, masks, detections and tracked shapes.
//!
//! Coordinates are pixels with the origin at the top-left corner, x to the right and y down.
//! A pixel `(x, y)` covers the unit square `[x, x+1) × [y, y+1)`; its centre is `(x+0.5, y+0.5)`.
//! Boxes follow MOTChallenge: top-left corner plus width and height, in `f64` so that metrics
//! computed on them equal the reference evaluators' (which use double precision).

use crate::runs::{first_nonzero, last_nonzero};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Errors raised when building the shared data types from user-provided buffers or values.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum FrameError {
    /// The pixel buffer is shorter than `height` rows of `stride` bytes need.
    #[error(
        "frame buffer has {len} bytes but {width}x{height} with stride {stride} needs {needed}"
    )]
    BufferTooSmall {
        /// Buffer length in bytes.
        len: usize,
        /// Frame width in pixels.
        width: u32,
        /// Frame height in pixels.
        height: u32,
        /// Bytes per row.
        stride: usize,
        /// Bytes needed.
        needed: usize,
    },
    /// The stride is smaller than one row of pixels.
    #[error("stride {stride} is smaller than a row of {width} pixels ({row_bytes} bytes)")]
    StrideTooSmall {
        /// Bytes per row given.
        stride: usize,
        /// Frame width in pixels.
        width: u32,
        /// Bytes a row of pixels needs.
        row_bytes: usize,
    },
    /// Width or height is zero.
    #[error("frame size {width}x{height} is empty")]
    Empty {
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
    },
    /// A mask's bitmap does not have `width * height` entries.
    #[error("mask bitmap has {len} entries, expected {width}x{height} = {expected}")]
    MaskSize {
        /// Entries given.
        len: usize,
        /// Mask width.
        width: u32,
        /// Mask height.
        height: u32,
        /// Entries expected.
        expected: usize,
    },
    /// A box has a non-finite coordinate or a negative size.
    #[error("invalid box x={x} y={y} w={w} h={h}: {reason}")]
    InvalidBox {
        /// Left.
        x: f64,
        /// Top.
        y: f64,
        /// Width.
        w: f64,
        /// Height.
        h: f64,
        /// What is wrong.
        reason: &'static str,
    },
}

/// A 2-D point in pixel coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Point {
    /// Horizontal coordinate, growing to the right.
    pub x: f64,
    /// Vertical coordinate, growing downwards.
    pub y: f64,
}

impl Point {
    /// A point at `(x, y)`.
    pub const fn new(x: f64, y: f64) -> Self {
        Self { x, y }
    }

    /// Euclidean distance to `other`.
    pub fn dist(self, other: Point) -> f64 {
        (self.x - other.x).hypot(self.y - other.y)
    }

    /// Squared Euclidean distance to `other`.
    pub fn dist2(self, other: Point) -> f64 {
        let (dx, dy) = (self.x - other.x, self.y - other.y);
        dx * dx + dy * dy
    }
}

impl std::ops::Add for Point {
    type Output = Point;
    fn add(self, o: Point) -> Point {
        Point::new(self.x + o.x, self.y + o.y)
    }
}

impl std::ops::Sub for Point {
    type Output = Point;
    fn sub(self, o: Point) -> Point {
        Point::new(self.x - o.x, self.y - o.y)
    }
}

impl std::ops::Mul<f64> for Point {
    type Output = Point;
    fn mul(self, k: f64) -> Point {
        Point::new(self.x * k, self.y * k)
    }
}

/// An axis-aligned box: top-left corner `(x, y)`, width `w`, height `h` (MOTChallenge layout).
///
/// The box covers `[x, x+w) × [y, y+h)`. Its area is `w·h` and IoU is computed without the
/// `+1` pixel convention, exactly as TrackEval does.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct BBox {
    /// Left edge.
    pub x: f64,
    /// Top edge.
    pub y: f64,
    /// Width (≥ 0).
    pub w: f64,
    /// Height (≥ 0).
    pub h: f64,
}

impl BBox {
    /// A box from its top-left corner and size, without validation.
    pub const fn new(x: f64, y: f64, w: f64, h: f64) -> Self {
        Self { x, y, w, h }
    }

    /// A box from its top-left corner and size, rejecting non-finite values and negative sizes.
    pub fn checked(x: f64, y: f64, w: f64, h: f64) -> Result<Self, FrameError> {
        if !(x.is_finite() && y.is_finite() && w.is_finite() && h.is_finite()) {
            return Err(FrameError::InvalidBox {
                x,
                y,
                w,
                h,
                reason: "non-finite value",
            });
        }
        if w < 0.0 || h < 0.0 {
            return Err(FrameError::InvalidBox {
                x,
                y,
                w,
                h,
                reason: "negative size",
            });
        }
        Ok(Self { x, y, w, h })
    }

    /// A box from two corners `(x1, y1)` (top-left) and `(x2, y2)` (bottom-right).
    pub fn from_xyxy(x1: f64, y1: f64, x2: f64, y2: f64) -> Self {
        Self {
            x: x1,
            y: y1,
            w: x2 - x1,
            h: y2 - y1,
        }
    }

    /// A box of size `w × h` centred on `c`.
    pub fn from_center(c: Point, w: f64, h: f64) -> Self {
        Self {
            x: c.x - w / 2.0,
            y: c.y - h / 2.0,
            w,
            h,
        }
    }

    /// Right edge.
    pub fn x2(&self) -> f64 {
        self.x + self.w
    }

    /// Bottom edge.
    pub fn y2(&self) -> f64 {
        self.y + self.h
    }

    /// Centre point.
    pub fn center(&self) -> Point {
        Point::new(self.x + self.w / 2.0, self.y + self.h / 2.0)
    }

    /// Area `w·h` (0 for degenerate boxes).
    pub fn area(&self) -> f64 {
        self.w.max(0.0) * self.h.max(0.0)
    }

    /// The part of the box inside a `img_w`×`img_h` image (a box of no size when it lies
    /// outside): what to rasterise, so that a box of any size costs at most the image.
    pub fn clipped(&self, img_w: u32, img_h: u32) -> BBox {
        let (x0, y0) = (self.x.max(0.0), self.y.max(0.0));
        let (x1, y1) = (
            self.x2().min(f64::from(img_w)),
            self.y2().min(f64::from(img_h)),
        );
        BBox::new(x0, y0, (x1 - x0).max(0.0), (y1 - y0).max(0.0))
    }

    /// Area of the intersection with `other` (0 when disjoint).
    pub fn intersection_area(&self, other: &BBox) -> f64 {
        let iw = (self.x2().min(other.x2()) - self.x.max(other.x)).max(0.0);
        let ih = (self.y2().min(other.y2()) - self.y.max(other.y)).max(0.0);
        iw * ih
    }

    /// Intersection over union, in `[0, 1]`, computed the way TrackEval's
    /// `_calculate_box_ious` does (degenerate boxes score 0).
    pub fn iou(&self, other: &BBox) -> f64 {
        let eps = f64::EPSILON;
        let a1 = (self.x2() - self.x) * (self.y2() - self.y);
        let a2 = (other.x2() - other.x) * (other.y2() - other.y);
        let inter = self.intersection_area(other);
        let union = a1 + a2 - inter;
        if a1 <= eps || a2 <= eps || union <= eps {
            return 0.0;
        }
        inter / union
    }

    /// Intersection over the area of `self` (how much of `self` lies inside `other`).
    pub fn ioa(&self, other: &BBox) -> f64 {
        let a = self.area();
        if a <= f64::EPSILON {
            return 0.0;
        }
        self.intersection_area(other) / a
    }

    /// The box moved by `(dx, dy)`.
    pub fn translated(&self, dx: f64, dy: f64) -> BBox {
        BBox::new(self.x + dx, self.y + dy, self.w, self.h)
    }

    /// The box grown by `m` on every side (shrunk when `m < 0`, never below zero size).
    pub fn expanded(&self, m: f64) -> BBox {
        let w = (self.w + 2.0 * m).max(0.0);
        let h = (self.h + 2.0 * m).max(0.0);
        BBox::from_center(self.center(), w, h)
    }

    /// The smallest box containing both.
    pub fn union(&self, other: &BBox) -> BBox {
        BBox::from_xyxy(
            self.x.min(other.x),
            self.y.min(other.y),
            self.x2().max(other.x2()),
            self.y2().max(other.y2()),
        )
    }

    /// Whether both boxes overlap with positive area.
    pub fn overlaps(&self, other: &BBox) -> bool {
        self.x < other.x2() && other.x < self.x2() && self.y < other.y2() && other.y < self.y2()
    }

    /// The four corners, clockwise in image coordinates from the top-left.
    pub fn corners(&self) -> [Point; 4] {
        [
            Point::new(self.x, self.y),
            Point::new(self.x2(), self.y),
            Point::new(self.x2(), self.y2()),
            Point::new(self.x, self.y2()),
        ]
    }

    /// Whether every coordinate is finite and the size non-negative.
    pub fn is_valid(&self) -> bool {
        self.x.is_finite()
            && self.y.is_finite()
            && self.w.is_finite()
            && self.h.is_finite()
            && self.w >= 0.0
            && self.h >= 0.0
    }
}

/// Pixel layout of a [`Frame`] buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum PixelFormat {
    /// 3 bytes per pixel: red, green, blue.
    Rgb8,
    /// 4 bytes per pixel: red, green, blue, alpha (what a browser canvas gives; alpha ignored).
    Rgba8,
}

impl PixelFormat {
    /// Bytes per pixel.
    pub const fn channels(self) -> usize {
        match self {
            PixelFormat::Rgb8 => 3,
            PixelFormat::Rgba8 => 4,
        }
    }
}

/// `width · height` as a byte count, `usize::MAX` when it does not fit (on wasm32 `usize` is
/// 32 bits: 65536 × 65536 would wrap to 0 and match an empty buffer).
pub(crate) fn pixel_count(width: u32, height: u32) -> usize {
    usize::try_from(width as u64 * height as u64).unwrap_or(usize::MAX)
}

/// A borrowed view of one video frame: no pixels are copied to build it.
///
/// In the browser the bytes live in a buffer the wasm module owns and JavaScript writes into;
/// natively they come from a decoded image.
#[derive(Debug, Clone, Copy)]
pub struct Frame<'a> {
    data: &'a [u8],
    width: u32,
    height: u32,
    stride: usize,
    format: PixelFormat,
}

impl<'a> Frame<'a> {
    /// A view on `data`, `height` rows of `stride` bytes each. Checks every size first.
    pub fn new(
        data: &'a [u8],
        width: u32,
        height: u32,
        stride: usize,
        format: PixelFormat,
    ) -> Result<Self, FrameError> {
        if width == 0 || height == 0 {
            return Err(FrameError::Empty { width, height });
        }
        // Checked: on wasm32 `usize` is 32 bits, and a hostile size must not wrap around to
        // a small buffer requirement.
        let row_bytes = (width as usize).saturating_mul(format.channels());
        if stride < row_bytes {
            return Err(FrameError::StrideTooSmall {
                stride,
                width,
                row_bytes,
            });
        }
        let needed = stride
            .checked_mul(height as usize - 1)
            .and_then(|n| n.checked_add(row_bytes))
            .unwrap_or(usize::MAX);
        if data.len() < needed {
            return Err(FrameError::BufferTooSmall {
                len: data.len(),
                width,
                height,
                stride,
                needed,
            });
        }
        Ok(Self {
            data,
            width,
            height,
            stride,
            format,
        })
    }

    /// A tightly packed RGB8 view (`stride = 3·width`).
    pub fn rgb(data: &'a [u8], width: u32, height: u32) -> Result<Self, FrameError> {
        let stride = (width as usize).saturating_mul(3);
        Self::new(data, width, height, stride, PixelFormat::Rgb8)
    }

    /// A tightly packed RGBA8 view (`stride = 4·width`).
    pub fn rgba(data: &'a [u8], width: u32, height: u32) -> Result<Self, FrameError> {
        let stride = (width as usize).saturating_mul(4);
        Self::new(data, width, height, stride, PixelFormat::Rgba8)
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Bytes per row.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// Pixel layout.
    pub fn format(&self) -> PixelFormat {
        self.format
    }

    /// The underlying bytes.
    pub fn data(&self) -> &'a [u8] {
        self.data
    }

    /// RGB of the pixel at `(x, y)`; `None` outside the frame.
    #[inline]
    pub fn rgb_at(&self, x: u32, y: u32) -> Option<[u8; 3]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = y as usize * self.stride + x as usize * self.format.channels();
        Some([self.data[i], self.data[i + 1], self.data[i + 2]])
    }

    /// Luma (ITU-R BT.601, as OpenCV's `COLOR_RGB2GRAY`) of the pixel at `(x, y)`, in `[0, 255]`.
    #[inline]
    pub fn gray_at(&self, x: u32, y: u32) -> Option<f32> {
        self.rgb_at(x, y)
            .map(|[r, g, b]| 0.299 * r as f32 + 0.587 * g as f32 + 0.114 * b as f32)
    }

    /// The grey-level image of the region `rect` (clipped to the frame), as an 8-bit image.
    /// Returns the clipped rectangle actually used, `(x0, y0, w, h)`, with the image.
    pub fn gray_crop(&self, rect: &BBox) -> Option<((u32, u32, u32, u32), image::GrayImage)> {
        let (x0, y0, w, h) = self.clip(rect)?;
        let c = self.format.channels();
        let (a, len) = (x0 as usize * c, w as usize * c);
        let mut buf = Vec::with_capacity(w as usize * h as usize);
        for y in y0..y0 + h {
            let start = y as usize * self.stride + a;
            let row = self.data.get(start..start + len)?;
            buf.extend(row.chunks_exact(c).map(|p| {
                round_u8(0.299 * p[0] as f32 + 0.587 * p[1] as f32 + 0.114 * p[2] as f32)
            }));
        }
        image::GrayImage::from_raw(w, h, buf).map(|img| ((x0, y0, w, h), img))
    }

    /// The pixel rectangle `(x0, y0, w, h)` covering `rect`, clipped to the frame; `None` when
    /// nothing is left.
    fn clip(&self, rect: &BBox) -> Option<PixelRect> {
        let x0 = rect.x.floor().max(0.0) as i64;
        let y0 = rect.y.floor().max(0.0) as i64;
        let x1 = (rect.x2().ceil() as i64).min(self.width as i64);
        let y1 = (rect.y2().ceil() as i64).min(self.height as i64);
        if x1 <= x0 || y1 <= y0 {
            return None;
        }
        Some((x0 as u32, y0 as u32, (x1 - x0) as u32, (y1 - y0) as u32))
    }

    /// The region `rect` (clipped to the frame, as [`Frame::gray_crop`] clips it) copied out
    /// in the frame's pixel layout, rows packed: the clipped rectangle and the bytes. A
    /// [`Frame`] over the bytes (`width` w, stride w × channels) is that part of this frame.
    pub fn crop(&self, rect: &BBox) -> Option<(PixelRect, Vec<u8>)> {
        let (x0, y0, w, h) = self.clip(rect)?;
        let c = self.format.channels();
        let (a, len) = (x0 as usize * c, w as usize * c);
        let mut buf = Vec::with_capacity(len * h as usize);
        for y in y0..y0 + h {
            let start = y as usize * self.stride + a;
            buf.extend_from_slice(self.data.get(start..start + len)?);
        }
        Some(((x0, y0, w, h), buf))
    }

    /// The whole frame as an 8-bit grey image.
    pub fn to_gray(&self) -> image::GrayImage {
        let full = BBox::new(0.0, 0.0, self.width as f64, self.height as f64);
        match self.gray_crop(&full) {
            Some((_, img)) => img,
            // Unreachable for a validated frame, but never panic on it.
            None => image::GrayImage::new(self.width, self.height),
        }
    }
}

/// Foreground pixels of a 0/1 bitmap. Bytes are added as bytes in blocks of 255 (a block's
/// count fits one), which vectorises 16 or more at a time; the tracker takes two mask areas
/// per scored pair, and widening each byte first was most of the pair's time (issue 10).
fn count_ones(bits: &[u8]) -> u64 {
    bits.chunks(255)
        .map(|c| u64::from(c.iter().fold(0u8, |n, &v| n.wrapping_add(v))))
        .sum()
}

/// Pixels foreground in both of two equally long rows of 0/1 bitmaps ([`count_ones`] of
/// their intersection).
fn count_common(a: &[u8], b: &[u8]) -> u64 {
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

/// A rectangle of whole pixels, `(x0, y0, width, height)`.
pub type PixelRect = (u32, u32, u32, u32);

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

/// One object found in a frame by a detector: a box, optionally a mask, a score and a class.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Detection {
    /// Bounding box (for mask detections, the mask's tight box).
    pub bbox: BBox,
    /// Instance mask, when the detector gives one.
    pub mask: Option<Mask>,
    /// Detector confidence (any scale; higher is more confident).
    pub score: f64,
    /// Class label (-1 when unknown).
    pub class: i32,
}

impl Detection {
    /// A box-only detection.
    pub fn from_box(bbox: BBox, score: f64) -> Self {
        Self {
            bbox,
            mask: None,
            score,
            class: -1,
        }
    }

    /// A mask detection; its box is the mask's tight bounding box.
    pub fn from_mask(mask: Mask, score: f64) -> Self {
        Self {
            bbox: mask.bbox(),
            mask: Some(mask),
            score,
            class: -1,
        }
    }

    /// The detection's centroid: the mask's (moments) when there is one, else the box centre.
    pub fn centroid(&self) -> Point {
        self.mask
            .as_ref()
            .and_then(Mask::centroid)
            .unwrap_or_else(|| self.bbox.center())
    }
}

/// The lifecycle state of a track.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TrackState {
    /// Seen in too few frames to be reported yet.
    Tentative,
    /// Matched in the current frame (or recently enough to be trusted).
    Confirmed,
    /// Not matched this frame; kept and searchable for re-identification.
    Lost,
    /// Gone for good; its id is never reused.
    Removed,
}

/// `v.round().clamp(0.0, 255.0) as u8` for `v ≥ 0`, bit for bit, without `f32::round`: in
/// wasm that is a call into libm per pixel (wasm's own rounding instruction rounds half to
/// even), and it was most of a grey crop's time. Truncation and the exact fractional part
/// (`v − trunc(v)` is exact below 2²³) round half away from zero as `round` does.
#[inline(always)]
pub(crate) fn round_u8(v: f32) -> u8 {
    let t = v as u32;
    (t + u32::from(v - t as f32 >= 0.5)).min(255) as u8
}

/// One track's shape in one frame, as the tracker reports it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrackedShape {
    /// Track identity, unique within one tracker (starts at 1).
    pub id: u64,
    /// Frame number (1-based, as MOTChallenge).
    pub frame: u32,
    /// Bounding box.
    pub bbox: BBox,
    /// Instance mask when known.
    pub mask: Option<Mask>,
    /// Centroid (mask moments or box centre).
    pub centroid: Point,
    /// Lifecycle state at this frame.
    pub state: TrackState,
    /// Detection score (or the track's when interpolated).
    pub score: f64,
    /// Class label (-1 when unknown).
    pub class: i32,
    /// Matching cost that attached the detection to the track (0 for a new track).
    pub cost: f64,
    /// Index of the detection in this frame's input, `None` when filled in (interpolated).
    pub det_index: Option<usize>,
    /// Whether this shape was filled in by the offline pass rather than detected.
    pub interpolated: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `round_u8` is `f32::round` then the clamp, on every luma a pixel can have, on the
    /// values next to every half (where `floor(v + 0.5)` would differ), and past 255.
    #[test]
    fn round_u8_is_round() {
        let want = |v: f32| v.round().clamp(0.0, 255.0) as u8;
        for r in (0..=255u32).step_by(5) {
            for g in 0..=255u32 {
                for b in (0..=255u32).step_by(3) {
                    let v = 0.299 * r as f32 + 0.587 * g as f32 + 0.114 * b as f32;
                    assert_eq!(round_u8(v), want(v), "{v}");
                }
            }
        }
        for k in 0..=256u32 {
            let half = k as f32 + 0.5;
            for v in [
                half,
                f32::from_bits(half.to_bits() - 1),
                f32::from_bits(half.to_bits() + 1),
                k as f32,
            ] {
                assert_eq!(round_u8(v), want(v), "{v}");
            }
        }
        assert_eq!(round_u8(0.49999997), 0);
        assert_eq!(round_u8(300.0), 255);
    }

    #[test]
    fn frame_checks_sizes() {
        let buf = vec![0u8; 10];
        assert!(matches!(
            Frame::rgb(&buf, 2, 2),
            Err(FrameError::BufferTooSmall { .. })
        ));
        assert!(matches!(
            Frame::new(&buf, 2, 1, 5, PixelFormat::Rgb8),
            Err(FrameError::StrideTooSmall { .. })
        ));
        assert!(matches!(
            Frame::rgb(&buf, 0, 1),
            Err(FrameError::Empty { .. })
        ));
        let buf = vec![7u8; 16];
        let f = Frame::rgba(&buf, 2, 2).unwrap();
        assert_eq!(f.rgb_at(1, 1), Some([7, 7, 7]));
        assert_eq!(f.rgb_at(2, 0), None);
    }

    #[test]
    fn bbox_iou_matches_hand_computation() {
        let a = BBox::new(0.0, 0.0, 10.0, 10.0);
        let b = BBox::new(5.0, 5.0, 10.0, 10.0);
        assert!((a.iou(&b) - 25.0 / 175.0).abs() < 1e-12);
        assert_eq!(a.iou(&BBox::new(20.0, 0.0, 5.0, 5.0)), 0.0);
        assert_eq!(a.iou(&BBox::new(0.0, 0.0, 0.0, 5.0)), 0.0);
        assert!((a.iou(&a) - 1.0).abs() < 1e-12);
    }

    /// The area and box are counted when a mask is built; every way of building one must
    /// agree with a recount of its bitmap, and a stored mask must check its bitmap.
    #[test]
    fn cached_area_and_box_match_a_recount_and_stored_masks_are_checked() {
        let recount = |m: &Mask| {
            let full = m.to_full(40, 30);
            let again = Mask::from_full(40, 30, &full).unwrap();
            (full.iter().map(|&v| v as u64).sum::<u64>(), again.bbox())
        };
        let mut full = vec![0u8; 40 * 30];
        for (x, y) in [(12, 11), (13, 11), (13, 12), (15, 14), (20, 20)] {
            full[y * 40 + x] = 1;
        }
        let a = Mask::from_full(40, 30, &full).unwrap();
        let sparse = Mask::new(
            3,
            4,
            5,
            3,
            vec![0, 0, 0, 0, 0, 0, 1, 0, 7, 0, 0, 0, 0, 0, 0],
        )
        .unwrap();
        let masks = [
            a.clone(),
            a.translated(-3, 5),
            a.translated(30, 0).clipped(40, 30),
            sparse.clone(),
            sparse.tight(),
            Mask::from_bbox(&BBox::new(2.2, 3.7, 6.0, 4.1)),
            Mask::empty().translated(4, 4),
        ];
        for m in &masks {
            let (area, bbox) = recount(m);
            assert_eq!(m.area(), area);
            assert_eq!(m.is_empty(), area == 0);
            if area > 0 {
                assert_eq!(m.bbox(), bbox);
            } else {
                assert_eq!(m.bbox(), BBox::default());
            }
            let json = serde_json::to_string(m).unwrap();
            assert_eq!(&serde_json::from_str::<Mask>(&json).unwrap(), m);
        }
        assert_eq!(sparse.bbox(), BBox::new(4.0, 5.0, 3.0, 1.0));
        let short = r#"{"x":0,"y":0,"width":3,"height":3,"data":[1,1]}"#;
        assert!(serde_json::from_str::<Mask>(short).is_err());
    }

    #[test]
    fn mask_roundtrips_through_full_bitmap() {
        let mut full = vec![0u8; 8 * 6];
        for (x, y) in [(2, 1), (3, 1), (3, 2), (5, 4)] {
            full[y * 8 + x] = 255;
        }
        let m = Mask::from_full(8, 6, &full).unwrap();
        assert_eq!((m.x(), m.y(), m.width(), m.height()), (2, 1, 4, 4));
        assert_eq!(m.area(), 4);
        assert_eq!(
            m.to_full(8, 6),
            full.iter().map(|&v| (v != 0) as u8).collect::<Vec<_>>()
        );
        assert_eq!(m.bbox(), BBox::new(2.0, 1.0, 4.0, 4.0));
        let c = m.centroid().unwrap();
        assert!((c.x - (2.0 + 3.0 + 3.0 + 5.0) / 4.0 - 0.5).abs() < 1e-12);
        assert!((m.iou(&m) - 1.0).abs() < 1e-12);
        assert_eq!(m.iou(&m.translated(10, 0)), 0.0);
        // Shifting in place equals copying the mask moved, for every offset around it.
        let other = Mask::from_bbox(&BBox::new(1.0, 0.0, 5.0, 3.0));
        for dx in -6..=6 {
            for dy in -5..=5 {
                let moved = m.translated(dx, dy);
                assert_eq!(
                    m.intersection_shifted(dx, dy, &other),
                    moved.intersection(&other)
                );
                assert_eq!(m.iou_shifted(dx, dy, &other), moved.iou(&other));
                // Against a pixel-by-pixel count on full images (a 20 × 20 canvas offset so
                // every shift stays inside).
                let (fa, fb) = (
                    moved.translated(7, 7).to_full(20, 20),
                    other.translated(7, 7).to_full(20, 20),
                );
                let want = fa.iter().zip(&fb).filter(|(a, b)| **a & **b != 0).count();
                assert_eq!(m.intersection_shifted(dx, dy, &other), want as u64);
            }
        }
    }

    /// Byte-block counting equals a plain count, across block boundaries and on all-ones
    /// runs longer than a block (where a byte counter would wrap).
    #[test]
    fn bitmap_counts_are_exact() {
        let mut s = 99u64;
        for len in [0usize, 1, 254, 255, 256, 511, 1000, 4099] {
            let mut bit = || {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1);
                ((s >> 33) % 3 != 0) as u8
            };
            let (a, b): (Vec<u8>, Vec<u8>) = (0..len).map(|_| (bit(), bit())).unzip();
            let naive = |v: &[u8]| v.iter().filter(|&&x| x != 0).count() as u64;
            assert_eq!(count_ones(&a), naive(&a), "len {len}");
            let both: Vec<u8> = a.iter().zip(&b).map(|(x, y)| x & y).collect();
            assert_eq!(count_common(&a, &b), naive(&both), "len {len}");
            let ones = vec![1u8; len];
            assert_eq!(count_ones(&ones), len as u64);
            assert_eq!(count_common(&ones, &ones), len as u64);
        }
    }

    #[test]
    fn mask_from_bbox_covers_pixel_centres() {
        let m = Mask::from_bbox(&BBox::new(1.0, 2.0, 3.0, 2.0));
        assert_eq!(
            (m.x(), m.y(), m.width(), m.height(), m.area()),
            (1, 2, 3, 2, 6)
        );
        assert!(Mask::from_bbox(&BBox::new(1.0, 1.0, 0.2, 0.2)).is_empty());
    }

    #[test]
    fn a_box_clipped_to_the_image_keeps_only_its_part_inside() {
        let b = BBox::new(-1e9, 5.0, 3e9, 4.0).clipped(640, 480);
        assert_eq!((b.x, b.y, b.w, b.h), (0.0, 5.0, 640.0, 4.0));
        let outside = BBox::new(700.0, 10.0, 20.0, 20.0).clipped(640, 480);
        assert_eq!(outside.area(), 0.0);
        assert!(Mask::from_bbox(&outside).is_empty());
        let inside = BBox::new(1.5, 2.5, 3.0, 4.0);
        assert_eq!(inside.clipped(640, 480), inside);
    }
}
