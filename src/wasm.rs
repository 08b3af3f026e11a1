//! Browser bindings: the only module that knows wasm-bindgen.
//!
//! Everything here is thin on purpose. JavaScript values are turned into the core's plain
//! structs (serde-wasm-bindgen, with TypeScript types derived by `tsify` from the same structs,
//! so the generated `.d.ts` cannot drift from the code), the core does the work, and results go
//! back as serialisable output structs built with `From`. Every core error becomes a JS `Error`
//! carrying its message through [`js_error`]; a panic hook is installed when the module starts,
//! so a bug shows up as a readable message in the console instead of a bare `unreachable`.
//!
//! Frames do not cross the boundary as copies: JS allocates a [`FrameBuffer`] once, writes RGBA
//! pixels straight into wasm memory through `new Uint8ClampedArray(memory.buffer, buf.ptr(),
//! buf.len())`, and hands the buffer handle to the tracker or detector, which read it in place.

use crate::frame::{BBox, Frame, Mask, Point};
use crate::io::{self, Record, RecordFlags, Rle};
use serde::{Deserialize, Serialize};
use tsify::{Ts, Tsify};
use wasm_bindgen::prelude::*;

/// Installs the panic hook. Runs once, when the module is instantiated.
#[wasm_bindgen(start)]
pub fn start() {
    console_error_panic_hook::set_once();
}

/// Turns any core error into a JS `Error` whose message is the error and its sources.
///
/// The one place errors cross into JavaScript, so every function reports failures the same way.
fn js_error<E: std::error::Error>(e: E) -> JsValue {
    let mut msg = e.to_string();
    let mut src = e.source();
    while let Some(s) = src {
        let part = s.to_string();
        // Some messages already embed their source; do not repeat it.
        if !msg.contains(&part) {
            msg.push_str(": ");
            msg.push_str(&part);
        }
        src = s.source();
    }
    js_sys::Error::new(&msg).into()
}

/// An error raised by the bindings themselves (argument checks), as opposed to the core's.
#[derive(Debug, thiserror::Error)]
enum BindingError {
    /// A frame size outside what a browser canvas can hold.
    #[error("frame size {width}x{height} is outside 1..={max} on each side")]
    FrameSize {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
        /// Largest side accepted.
        max: u32,
    },
}

/// Reads a typed JS argument into its Rust struct; a shape mismatch becomes a JS `Error`.
///
/// Deserialising inside the function (rather than in the ABI glue) keeps the failure an ordinary
/// `Result`, so nothing already converted leaks when the caller passes a bad value.
fn rust<T>(v: Ts<T>) -> Result<T, JsValue>
where
    T: Tsify + serde::de::DeserializeOwned,
    T::JsType: Clone,
{
    v.to_rust().map_err(js_error)
}

/// Converts an output struct to its typed JS value.
fn ts<T: Tsify + Serialize>(v: &T) -> Result<Ts<T>, JsValue> {
    v.into_ts().map_err(js_error)
}

/// The largest frame side accepted (a 16k canvas is already beyond every browser's limit).
const MAX_SIDE: u32 = 16384;

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
    /// Allocates `width·height·4` zeroed bytes.
    #[wasm_bindgen(constructor)]
    pub fn new(width: u32, height: u32) -> Result<FrameBuffer, JsValue> {
        if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
            return Err(js_error(BindingError::FrameSize {
                width,
                height,
                max: MAX_SIDE,
            }));
        }
        Ok(FrameBuffer {
            data: vec![0; width as usize * height as usize * 4],
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
    #[allow(dead_code)] // used by the tracker and detector bindings
    fn frame(&self) -> Result<Frame<'_>, JsValue> {
        Frame::rgba(&self.data, self.width, self.height).map_err(js_error)
    }

    /// Mutable pixels, for producers that live in wasm (the synthetic scene).
    #[allow(dead_code)] // used by the synthetic scene binding
    fn bytes_mut(&mut self) -> &mut [u8] {
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
    fn to_rle(&self) -> Result<Rle, JsValue> {
        Rle::from_compressed(&self.counts, self.size[0], self.size[1]).map_err(js_error)
    }
}

fn minus_one() -> f64 {
    -1.0
}
fn minus_one_i32() -> i32 {
    -1
}
fn one() -> f64 {
    1.0
}

/// One object in one frame: the row of every track table, import and export.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Tsify)]
pub struct RecordJs {
    /// 1-based frame number.
    pub frame: u32,
    /// Track id (-1 for an unlinked detection).
    pub id: i64,
    /// Bounding box.
    pub bbox: BoxJs,
    /// Confidence, or the MOTChallenge gt "consider" flag (0 = ignore). Defaults to 1.
    #[serde(default = "one")]
    #[tsify(optional)]
    pub score: f64,
    /// Class label, -1 when unknown (the default).
    #[serde(default = "minus_one_i32")]
    #[tsify(optional)]
    pub class: i32,
    /// Visibility ratio, -1 when unknown (the default).
    #[serde(default = "minus_one")]
    #[tsify(optional)]
    pub visibility: f64,
    /// Instance mask, for mask formats.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[tsify(optional)]
    pub mask: Option<RleJs>,
    /// Filled in by interpolation rather than detected or drawn.
    #[serde(default)]
    #[tsify(optional)]
    pub interpolated: bool,
    /// Marked occluded by an annotator.
    #[serde(default)]
    #[tsify(optional)]
    pub occluded: bool,
}

impl From<&Record> for RecordJs {
    fn from(r: &Record) -> Self {
        RecordJs {
            frame: r.frame,
            id: r.id,
            bbox: r.bbox.into(),
            score: r.score,
            class: r.class,
            visibility: r.visibility,
            mask: r.mask.as_ref().map(RleJs::from),
            interpolated: r.flags.interpolated,
            occluded: r.flags.occluded,
        }
    }
}

impl RecordJs {
    fn to_record(&self) -> Result<Record, JsValue> {
        let bbox =
            BBox::checked(self.bbox.x, self.bbox.y, self.bbox.w, self.bbox.h).map_err(js_error)?;
        Ok(Record {
            frame: self.frame,
            id: self.id,
            bbox,
            score: self.score,
            class: self.class,
            visibility: self.visibility,
            mask: self.mask.as_ref().map(RleJs::to_rle).transpose()?,
            flags: RecordFlags {
                interpolated: self.interpolated,
                occluded: self.occluded,
            },
        })
    }
}

/// A list of records (what readers return and writers take).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Tsify)]
#[serde(transparent)]
pub struct Records(pub Vec<RecordJs>);

fn to_core_records(records: Records) -> Result<Vec<Record>, JsValue> {
    records.0.iter().map(RecordJs::to_record).collect()
}

fn from_core_records(records: &[Record]) -> Records {
    Records(records.iter().map(RecordJs::from).collect())
}

/// The annotation and result formats the app reads and writes (all through the Rust core).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Tsify)]
#[serde(rename_all = "kebab-case")]
pub enum Format {
    /// MOTChallenge txt: `frame,id,x,y,w,h,conf,...` per line.
    Mot,
    /// MOTS txt: `frame id class height width rle` per line.
    Mots,
}

/// Parses an annotation or result file. `name` names the file in error messages.
#[wasm_bindgen(js_name = parseRecords)]
pub fn parse_records(format: Ts<Format>, text: &str, name: &str) -> Result<Ts<Records>, JsValue> {
    let records = match rust(format)? {
        Format::Mot => io::motchallenge::parse_mot(text, name),
        Format::Mots => io::motchallenge::parse_mots(text, name),
    }
    .map_err(js_error)?;
    ts(&from_core_records(&records))
}

/// Writes records in `format`. MOTS skips records without a mask, as the format requires.
#[wasm_bindgen(js_name = writeRecords)]
pub fn write_records(format: Ts<Format>, records: Ts<Records>) -> Result<String, JsValue> {
    let records = to_core_records(rust(records)?)?;
    Ok(match rust(format)? {
        Format::Mot => io::motchallenge::write_mot(&records),
        Format::Mots => io::motchallenge::write_mots(&records),
    })
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
    ts(&MaskBitmap::from(&rust(rle)?.to_rle()?.to_mask()))
}

/// Encodes a full-image bitmap (`width·height` bytes, non-zero = foreground) as compressed RLE.
#[wasm_bindgen(js_name = encodeMask)]
pub fn encode_mask(width: u32, height: u32, bitmap: &[u8]) -> Result<Ts<RleJs>, JsValue> {
    let rle = Rle::encode(width, height, bitmap).map_err(js_error)?;
    ts(&RleJs::from(&rle))
}

/// The crate version, shown in the app's footer and checked by the tests.
#[wasm_bindgen]
pub fn version() -> String {
    env!("CARGO_PKG_VERSION").to_string()
}
