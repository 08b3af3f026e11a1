//! The data every stage shares: frames, boxes, masks, detections and tracked shapes.
//!
//! Coordinates are pixels with the origin at the top-left corner, x to the right and y down.
//! A pixel `(x, y)` covers the unit square `[x, x+1) × [y, y+1)`; its centre is `(x+0.5, y+0.5)`.
//! Boxes follow MOTChallenge: top-left corner plus width and height, in `f64` so that metrics
//! computed on them equal the reference evaluators' (which use double precision).

mod mask;

use serde::{Deserialize, Serialize};
use thiserror::Error;

pub use mask::Mask;

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

/// A rectangle of whole pixels, `(x0, y0, width, height)`.
pub type PixelRect = (u32, u32, u32, u32);

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
#[path = "frame_tests.rs"]
mod tests;
