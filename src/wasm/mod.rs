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
//!
//! One module per area, each small (a test keeps every file under 500 lines); everything
//! public is re-exported here, so the JS API and `shapetrack::wasm::*` are one flat namespace:
//! `frame` (frame buffers, boxes, masks), `annotations` (file formats), `detect` (detections,
//! background and moving-camera detectors, camera judge; `region`, not exported, is the pixels
//! its overlap tests compare), `settings` (settings objects: partial JSON over the core's config
//! types, typed from them), `offline` (the offline pass' progress and result), `tracker`, `synth` (the demo scene), `eval` (metrics), `follow` (following one given shape, keyframe interpolation), and `error` (how
//! failures become JS `Error`s; not exported).

mod annotations;
mod detect;
mod error;
mod eval;
mod follow;
mod frame;
mod offline;
mod region;
mod segment;
mod settings;
mod synth;
mod tracker;

pub use annotations::*;
pub use detect::*;
pub use eval::*;
pub use follow::*;
pub use frame::*;
pub use offline::*;
pub use segment::*;
pub use settings::{
    BackgroundSettings, EvalSettings, FollowSettings, MovingSettings, OfflineSettings,
    RefineSettings, SegmentSettings, TrackerSettings,
};
pub use synth::*;
pub use tracker::*;
// The helpers every binding shares (not part of the JS API).
use error::*;

// The module's allocator: talc instead of the standard library's dlmalloc (issue 10). A tracked
// frame allocates for each detection's mask, shell and appearance, and in the Node profile of
// the `demo` scene dlmalloc's malloc, free and realloc were about a tenth of `Tracker.update`
// (README, speed table, for what talc saves). The calls stay calls: talc's code inlined into
// every drop and push by fat LTO made the module 32 KiB larger.
#[global_allocator]
static ALLOCATOR: Allocator = Allocator(talc::wasm::new_wasm_dynamic_allocator());

/// Talc behind calls that are never inlined (see [`ALLOCATOR`]).
struct Allocator(talc::wasm::WasmDynamicTalc);

// SAFETY: each method passes its caller's arguments unchanged to talc's `GlobalAlloc`, whose
// contract is the same; `#[inline(never)]` changes code placement only.
unsafe impl std::alloc::GlobalAlloc for Allocator {
    #[inline(never)]
    unsafe fn alloc(&self, layout: std::alloc::Layout) -> *mut u8 {
        // SAFETY: the caller's contract is passed on as is.
        unsafe { self.0.alloc(layout) }
    }
    #[inline(never)]
    unsafe fn alloc_zeroed(&self, layout: std::alloc::Layout) -> *mut u8 {
        // SAFETY: as above.
        unsafe { self.0.alloc_zeroed(layout) }
    }
    #[inline(never)]
    unsafe fn dealloc(&self, ptr: *mut u8, layout: std::alloc::Layout) {
        // SAFETY: as above.
        unsafe { self.0.dealloc(ptr, layout) }
    }
    #[inline(never)]
    unsafe fn realloc(&self, ptr: *mut u8, layout: std::alloc::Layout, new_size: usize) -> *mut u8 {
        // SAFETY: as above.
        unsafe { self.0.realloc(ptr, layout, new_size) }
    }
}

use wasm_bindgen::prelude::*;

/// Installs the panic hook. Runs once, when the module is instantiated.
#[wasm_bindgen(start)]
pub fn start() {
    console_error_panic_hook::set_once();
}

/// The crate version, shown in the app's footer and checked by the tests.
#[wasm_bindgen]
pub fn version() -> String {
    env!("CARGO_PKG_VERSION").to_string()
}
