//! Heap allocations per tracked frame (issue 10: "no allocation per frame in the hot path").
//! In wasm each allocation and free is a call into the module's allocator (dlmalloc's were
//! ~13 % of the browser build's tracker time; talc's, `src/wasm/mod.rs`, cost less). This
//! counts them on fixed synthetic scenes — a deterministic count, not a timing — so a change
//! that brings back per-track or per-pair allocations fails here.
//!
//! What still allocates per frame, by design: each detection's mask, shell and appearance (new
//! data), each track's search shell, the clusters' member lists, a few small tables per
//! appearance comparison, and the outputs.

#![cfg(not(target_arch = "wasm32"))]

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use shapetrack::synth::{Scene, SynthConfig};
use shapetrack::track::{Config, Tracker};

/// The system allocator, counting the allocations (and reallocations) made on a thread while
/// its counter is on; other test threads are not counted.
struct Counting;

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static COUNT: Cell<u64> = const { Cell::new(0) };
}

fn note() {
    // `try_with`: the thread-locals may be gone while a thread shuts down.
    let _ = COUNTING.try_with(|on| {
        if on.get() {
            let _ = COUNT.try_with(|c| c.set(c.get() + 1));
        }
    });
}

// SAFETY: every call is forwarded to `System` unchanged; the counting touches only
// const-initialised thread-locals, which never allocate.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note();
        // SAFETY: the caller's contract is passed on as is.
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note();
        // SAFETY: as above.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: as above.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note();
        // SAFETY: as above.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Allocations per frame and per detection over frames 51.. of `cfg` tracked with the mask
/// preset (the first 50 let tracks be born and confirmed).
fn per_frame(cfg: SynthConfig) -> (f64, f64) {
    let frames: Vec<_> = Scene::new(cfg).expect("scene").collect();
    let mut tracker = Tracker::new(Config::masks()).expect("tracker");
    let (mut dets, mut counted) = (0usize, 0usize);
    COUNT.with(|c| c.set(0));
    for (i, f) in frames.iter().enumerate() {
        let frame = f.frame().expect("frame");
        let on = i >= 50;
        if on {
            dets += f.detections.len();
            counted += 1;
        }
        COUNTING.with(|c| c.set(on));
        let out = tracker.update(Some(&frame), &f.detections);
        COUNTING.with(|c| c.set(false));
        assert!(out.is_ok(), "frame {}: {:?}", i + 1, out.err());
    }
    let n = COUNT.with(|c| c.get()) as f64;
    (n / counted.max(1) as f64, n / dets.max(1) as f64)
}

#[test]
fn steady_frames_allocate_a_bounded_number_of_times_per_detection() {
    // Bounds ~15 % above the counts when they were set (default scene 44.3 per detection,
    // occlusion 42.3; before the search shells, the assignment's lone pairs, the ambiguity
    // groups, the pixel hull, the broad phase and the clusters' copy stopped allocating per
    // step: 77.0 and 70.4, which fail). Since the lost tracks that only re-identification
    // looks for get their regions at its stage (a second, smaller region estimate on the
    // frames with something to re-identify): 46.3 and 42.3.
    for (name, cfg, bound) in [
        ("default", SynthConfig::default(), 51.0),
        ("occlusion", SynthConfig::occlusion_scene(0), 49.0),
    ] {
        let (frame, det) = per_frame(cfg);
        println!("{name}: {frame:.1} allocations per frame, {det:.1} per detection");
        assert!(
            det <= bound,
            "{name}: {det:.1} allocations per detection and frame (bound {bound})"
        );
    }
}
