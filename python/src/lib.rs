//! `shapetrack._native`: the Rust core as a CPython extension module (PyO3, abi3).
//!
//! This layer is thin on purpose: it turns bytes into the core's types, calls the same library
//! functions the CLI calls, and turns the results back into bytes. The pure-Python package
//! around it (`python/shapetrack/`) checks shapes and dtypes, names the argument at fault, and
//! makes numpy arrays of the bytes. Arrays cross as `bytes` rather than through the `numpy`
//! crate so the abi3 wheel depends on no numpy C ABI (one copy each way, small next to the
//! tracking itself).
//!
//! Every call that does work releases the GIL and runs inside a one-thread rayon pool of its
//! own calling thread, as the CLI does (`src/bin/shapetrack/main.rs`): linfa's k-means calls
//! rayon for small jobs, and from inside a pool those run inline instead of being handed off.

use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

mod detect;
mod files;
mod tracker;

thread_local! {
    /// The calling thread's one-thread pool (built on first use; `None` if the OS refused a
    /// thread, and then work runs on the calling thread, with the same results).
    static POOL: Option<rayon::ThreadPool> = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .stack_size(8 << 20)
        .build()
        .ok();
}

/// Runs `f` inside the calling thread's one-thread pool.
pub(crate) fn in_pool<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    POOL.with(|p| match p {
        Some(pool) => pool.install(f),
        None => f(),
    })
}

/// A `ValueError` with the core's message (which names the field, file or line at fault).
pub(crate) fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// The error of a second thread using an object while a first one's call has released the
/// GIL: refused rather than waited for (waiting while holding the GIL could deadlock).
pub(crate) fn busy(what: &str) -> PyErr {
    PyRuntimeError::new_err(format!(
        "this {what} is in use by another thread: give each thread its own"
    ))
}

/// The extension module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<tracker::NativeTracker>()?;
    m.add_class::<tracker::NativeOfflineTracker>()?;
    m.add_class::<detect::NativeDetector>()?;
    m.add_function(wrap_pyfunction!(files::track_files, m)?)?;
    m.add_function(wrap_pyfunction!(files::evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(files::check_config, m)?)?;
    m.add_function(wrap_pyfunction!(detect::image_files, m)?)?;
    m.add_function(wrap_pyfunction!(detect::read_frame, m)?)?;
    m.add_function(wrap_pyfunction!(detect::detect_files, m)?)?;
    m.add_function(wrap_pyfunction!(detect::follow_frames, m)?)?;
    Ok(())
}
