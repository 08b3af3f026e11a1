//! Frames in wasm memory and the small shapes every binding shares: boxes, points, masks
//! (RLE and cropped bitmaps).

use super::*;
use crate::frame::{BBox, Frame, Mask, Point};
use crate::io::Rle;
use serde::{Deserialize, Serialize};
use tsify::{Ts, Tsify};
use wasm_bindgen::prelude::*;

/// The largest frame side accepted (a 16k canvas is already beyond every browser's limit).
pub(super) const MAX_SIDE: u32 = 16384;

/// Whether frames of `width × height` can be tracked: each side in `1..=MAX_SIDE` and at
/// most `io::limits::MAX_PIXELS` (8192 × 8192) pixels, the readers' cap. Every detector and
/// the tracker allocate several planes of the frame's size: at 16384 × 16384 (1 GiB of
/// RGBA, accepted before) the background detector sat within a few MB of wasm32's 4 GiB.
pub(super) fn frame_size_ok(width: u32, height: u32) -> bool {
    width <= MAX_SIDE
        && height <= MAX_SIDE
        && crate::io::limits::image_size_ok(width.into(), height.into())
}

/// An RGBA frame that lives in wasm memory; JavaScript writes pixels into it in place.
///
/// `ptr()`/`len()` locate the bytes in `memory.buffer`. A view on that buffer is invalidated
/// when wasm memory grows, so JS should build the `Uint8ClampedArray` view right before each
/// write rather than keep it.
#[wasm_bindgen]
pub struct FrameBuffer {
    data: Vec<u8>,
    width: u32,
    height: u32,
}

#[wasm_bindgen]
impl FrameBuffer {
    /// Allocates `width·height·4` zeroed bytes; an allocation the browser refuses is an
    /// error, not a trap. A size the detectors cannot process (each side in 1..=16384, at most
    /// 2²⁶ pixels, 8192 × 8192) is refused here with an `Error`, before anything is built,
    /// rather than trapping later in a detector out of memory.
    #[wasm_bindgen(constructor)]
    pub fn new(width: f64, height: f64) -> Result<FrameBuffer, JsValue> {
        let (width, height) = (whole_u32("width", width)?, whole_u32("height", height)?);
        if !frame_size_ok(width, height) {
            return Err(js_error(BindingError::FrameSize { width, height }));
        }
        let n = width as usize * height as usize * 4;
        let mut data = Vec::new();
        data.try_reserve_exact(n).map_err(|_| {
            js_error(BindingError::Invalid(format!(
                "could not allocate a {width}x{height} frame ({n} bytes): out of memory"
            )))
        })?;
        data.resize(n, 0);
        Ok(FrameBuffer {
            data,
            width,
            height,
        })
    }

    /// Byte offset of the first pixel in `memory.buffer`.
    pub fn ptr(&self) -> *const u8 {
        self.data.as_ptr()
    }

    /// Number of bytes (`width·height·4`).
    #[allow(clippy::len_without_is_empty)] // never empty: the constructor rejects 0 sizes
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// Frame width in pixels.
    #[wasm_bindgen(getter)]
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Frame height in pixels.
    #[wasm_bindgen(getter)]
    pub fn height(&self) -> u32 {
        self.height
    }
}

impl FrameBuffer {
    /// The pixels as a core frame view (no copy).
    pub(super) fn frame(&self) -> Result<Frame<'_>, JsValue> {
        Frame::rgba(&self.data, self.width, self.height).map_err(js_error)
    }

    /// Mutable pixels, for producers that live in wasm (the synthetic scene).
    pub(super) fn bytes_mut(&mut self) -> &mut [u8] {
        &mut self.data
    }
}

/// A box in pixels: top-left corner and size (MOTChallenge layout).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Tsify)]
pub struct BoxJs {
    /// Left edge.
    pub x: f64,
    /// Top edge.
    pub y: f64,
    /// Width.
    pub w: f64,
    /// Height.
    pub h: f64,
}

impl From<BBox> for BoxJs {
    fn from(b: BBox) -> Self {
        BoxJs {
            x: b.x,
            y: b.y,
            w: b.w,
            h: b.h,
        }
    }
}

impl From<BoxJs> for BBox {
    fn from(b: BoxJs) -> Self {
        BBox::new(b.x, b.y, b.w, b.h)
    }
}

/// A point in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Tsify)]
pub struct PointJs {
    /// Horizontal coordinate.
    pub x: f64,
    /// Vertical coordinate.
    pub y: f64,
}

impl From<Point> for PointJs {
    fn from(p: Point) -> Self {
        PointJs { x: p.x, y: p.y }
    }
}

/// A full-image mask in COCO's compressed RLE form (what MOTS and COCO files store).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Tsify)]
pub struct RleJs {
    /// `[height, width]` of the image, COCO order.
    pub size: [u32; 2],
    /// pycocotools' compressed counts string.
    pub counts: String,
}

impl From<&Rle> for RleJs {
    fn from(r: &Rle) -> Self {
        RleJs {
            size: [r.height, r.width],
            counts: r.to_compressed(),
        }
    }
}

impl RleJs {
    pub(super) fn to_rle(&self) -> Result<Rle, JsValue> {
        let [h, w] = self.size;
        // The readers' cap (see `io::limits`): a mask must be decodable in wasm's memory.
        if !crate::io::limits::image_size_ok(w as u64, h as u64) {
            return Err(js_error(BindingError::Invalid(format!(
                "RLE size {h}x{w} is outside 1..={} per side or over {} pixels",
                crate::io::limits::MAX_SIDE,
                crate::io::limits::MAX_PIXELS
            ))));
        }
        Rle::from_compressed(&self.counts, h, w).map_err(js_error)
    }
}

pub(super) fn minus_one() -> f64 {
    -1.0
}
pub(super) fn minus_one_i32() -> i32 {
    -1
}
pub(super) fn one() -> f64 {
    1.0
}

/// A mask cropped to its foreground: `data` holds `width·height` bytes (0/1), row-major, for
/// the rectangle whose top-left pixel is `(x, y)`.
#[derive(Debug, Clone, PartialEq, Serialize, Tsify)]
pub struct MaskBitmap {
    /// Image x of the left column.
    pub x: i32,
    /// Image y of the top row.
    pub y: i32,
    /// Bitmap width.
    pub width: u32,
    /// Bitmap height.
    pub height: u32,
    /// 0/1 bytes, row-major.
    #[serde(with = "serde_bytes")]
    #[tsify(type = "Uint8Array")]
    pub data: Vec<u8>,
}

impl From<&Mask> for MaskBitmap {
    fn from(m: &Mask) -> Self {
        MaskBitmap {
            x: m.x(),
            y: m.y(),
            width: m.width(),
            height: m.height(),
            data: m.data().to_vec(),
        }
    }
}

/// Decodes a compressed RLE into a bitmap cropped to its foreground, for drawing overlays.
#[wasm_bindgen(js_name = decodeMask)]
pub fn decode_mask(rle: Ts<RleJs>) -> Result<Ts<MaskBitmap>, JsValue> {
    let rle = rust(rle)?.to_rle()?;
    ts(&MaskBitmap::from(&rle.to_mask()))
}

/// Encodes a full-image bitmap (`width·height` bytes, non-zero = foreground) as compressed RLE.
#[wasm_bindgen(js_name = encodeMask)]
pub fn encode_mask(width: f64, height: f64, bitmap: &[u8]) -> Result<Ts<RleJs>, JsValue> {
    let (width, height) = (whole_u32("width", width)?, whole_u32("height", height)?);
    let rle = Rle::encode(width, height, bitmap).map_err(js_error)?;
    ts(&RleJs::from(&rle))
}
