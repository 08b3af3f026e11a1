//! Documented caps on what an annotation or detection file may describe, checked before
//! anything is allocated from it.
//!
//! A few bytes of text can declare a 65536 × 65536 mask, frame 4,294,967,295 or an
//! interpolation span of a million frames; read naively, each becomes gigabytes of memory or
//! hours of work (in wasm, a trap that kills the page's tracker). Every reader checks sizes,
//! counts and frame numbers against these caps (and against what the file itself says, e.g.
//! a mask must fit its frame) and answers with a typed error naming the file, line and cap.
//! The caps are far above any real video: 2²⁰ frames is 9.7 hours at 30 fps; 2²⁶ pixels is
//! 8192 × 8192 (8K UHD is 7680 × 4320).

/// Highest frame number a file may use (frames are counted from 0 or 1).
pub const MAX_FRAME: u32 = 1 << 20;

/// Longest side of an image or mask, in pixels.
pub const MAX_SIDE: u32 = 1 << 16;

/// Most pixels of one image or decoded mask (8192 × 8192).
pub const MAX_PIXELS: u64 = 1 << 26;

/// Most mask pixels one file may decode into bitmaps in total (256 MB of bitmaps).
pub const MAX_TOTAL_PIXELS: u64 = 1 << 28;

/// Most records (shapes) one file may expand into by interpolating between keyframes (a
/// hundred tracks over 5,000 frames; a record costs ~100 bytes natively, ~500 in the app).
pub const MAX_RECORDS: u64 = 1 << 19;

/// Most RLE run lengths the records read from one file may hold in total (128 MB).
pub const MAX_TOTAL_RUNS: u64 = 1 << 25;

/// Whether `width × height` is an image size the readers accept (both sides ≥ 1, within
/// [`MAX_SIDE`] and [`MAX_PIXELS`]).
pub fn image_size_ok(width: u64, height: u64) -> bool {
    (1..=MAX_SIDE as u64).contains(&width)
        && (1..=MAX_SIDE as u64).contains(&height)
        && width * height <= MAX_PIXELS
}

/// Largest track id (in magnitude) a file may use: 2⁵³. A JSON number is a double to
/// JavaScript (the browser app, the npm library) and to many JSON tools, and above 2⁵³ a double
/// cannot hold every integer: id 2⁵³ + 1 would come back as 2⁵³, silently merging two tracks.
pub const MAX_ID: i64 = 1 << 53;

/// Whether `id` is a track id the readers accept (within ±[`MAX_ID`]).
pub fn id_ok(id: i64) -> bool {
    id.unsigned_abs() <= MAX_ID as u64
}

/// What a reader expected where it found a track id beyond ±[`MAX_ID`].
pub const ID_EXPECTED: &str =
    "a track id within ±2^53 (beyond 2^53 a JSON or JavaScript number cannot hold it exactly)";

/// The error message for a track id beyond ±[`MAX_ID`], `id` as the file wrote it.
pub fn id_message(id: &str) -> String {
    format!(
        "track id {id} is beyond 2^53: a JSON or JavaScript number cannot hold it exactly (it \
         would be read back as another id)"
    )
}

/// Most per-frame slots a COCO-video writer lays out for one video: the format lists every
/// track's boxes frame by frame (`null` where absent), so a track costs the video's length
/// whatever it holds. 2²⁶ slots is 64 tracks over 2²⁰ frames (9.7 hours at 30 fps) or 13,000
/// tracks over 5,000 frames, about 300 MB of JSON even when empty.
pub const MAX_SLOTS: u64 = 1 << 26;

/// Most vertices of one VOT polygon region. The exact overlap sweeps every edge at every
/// vertex and crossing, so its work grows with the cube of the vertices; VOT's polygons are
/// rotated boxes (4 vertices), and a mask traced to a polygon has a few hundred.
pub const MAX_POLYGON_VERTICES: usize = 1024;

/// Most vertices of a VOT polygon that crosses itself. A self-crossing polygon of `n`
/// vertices can cross itself `n²/2` times, each crossing a sweep event over every edge;
/// above this a polygon must be simple (a bow-tie of 4 vertices is still read).
pub const MAX_SELF_CROSSING_VERTICES: usize = 64;

/// Most boxes (records) of one side in one frame that `eval` and `refine` take, and the
/// tracker's own cap (`track::MAX_DETECTIONS` is this constant): a frame's similarity matrix
/// is ground truth × tracker boxes and its matching cubic in them, and no detector (YOLO's
/// `max_det` is 300) or annotation (a MOT20 frame holds ~250 people) holds that many objects in
/// one frame.
pub const MAX_BOXES_PER_FRAME: usize = 2_000;

/// Longest text file a reader takes whole (1 GiB; MOT20's largest ground truth is ~50 MB): a
/// device such as `/dev/zero`, or a binary file given by mistake, is refused instead of read
/// until memory runs out.
pub const MAX_TEXT_BYTES: u64 = 1 << 30;

/// Longest line a line-by-line reader takes (64 MiB: a MOTS line of an 8192×8192 mask's RLE
/// stays far below), so that a file without line breaks is refused after 64 MiB, not 1 GiB.
pub const MAX_LINE_BYTES: u64 = 1 << 26;
