//! How failures cross into JavaScript: core errors and the bindings' own argument checks
//! become JS `Error`s with a readable message, and settings objects are read strictly.

use serde::Serialize;
use tsify::{Ts, Tsify};
use wasm_bindgen::prelude::*;
use wasm_bindgen::JsCast;

/// Turns any core error into a JS `Error` whose message is the error and its sources.
///
/// The one place errors cross into JavaScript, so every function reports failures the same way.
pub(super) fn js_error<E: std::error::Error>(e: E) -> JsValue {
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
pub(super) enum BindingError {
    /// An input that cannot be read: a settings object (see `settings`), a mask too large.
    #[error("{0}")]
    Invalid(String),
    /// A frame size outside the caps (`frame::frame_size_ok`).
    #[error(
        "frame size {width}x{height} is outside 1..={} on each side or over {} pixels \
         (8192x8192): the detectors and the tracker could not hold it in wasm memory",
        super::frame::MAX_SIDE,
        crate::io::limits::MAX_PIXELS
    )]
    FrameSize {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
    },
    /// Frames must be tracked in order, each once.
    #[error("frames must be tracked in order: expected frame {expected}, got {got}")]
    FrameOrder {
        /// The next frame.
        expected: u32,
        /// The frame given.
        got: u32,
    },
    /// A tracker sees one video: its frame size cannot change.
    #[error("frame size changed from {expected:?} to {got:?}: start a new tracker")]
    SizeChanged {
        /// Size of the first frame.
        expected: (u32, u32),
        /// Size of this frame.
        got: (u32, u32),
    },
    /// A frame number outside the sequence.
    #[error("frame {frame} is outside 1..={frames}")]
    FrameRange {
        /// The frame asked for.
        frame: u32,
        /// Frames in the sequence.
        frames: u32,
    },
    /// `finish` on a tracker built without offline options.
    #[error("this tracker was built without offline options: create it with new Tracker(config, {{ fps }}) to run finish()")]
    NotOffline,
    /// The offline pass has run: the tracker's result is final.
    #[error("this tracker is finished (the offline pass has run): start a new tracker")]
    Finished,
    /// The tracker's kept history is full (`MAX_KEPT_SHAPES`): no frame is tracked, and
    /// nothing kept is lost.
    #[error(
        "the tracker keeps at most {cap} shapes and is full after {frames} frames: this frame \
         was not tracked; read or export tracks() (or run finish()), then start a new tracker"
    )]
    HistoryFull {
        /// Most shapes kept.
        cap: usize,
        /// Frames tracked.
        frames: u32,
    },
    /// The progress callback threw.
    #[error("progress callback threw: {message}")]
    Progress {
        /// The exception's message.
        message: String,
    },
    /// An option has a value the bindings do not accept.
    #[error("option {name}: {message}")]
    Option {
        /// The option.
        name: &'static str,
        /// What is wrong.
        message: String,
    },
}

/// Reads a typed JS argument into its Rust struct; a shape mismatch becomes a JS `Error`.
///
/// Deserialising inside the function (rather than in the ABI glue) keeps the failure an ordinary
/// `Result`, so nothing already converted leaks when the caller passes a bad value.
pub(super) fn rust<T>(v: Ts<T>) -> Result<T, JsValue>
where
    T: Tsify + serde::de::DeserializeOwned,
    T::JsType: Clone,
{
    v.to_rust().map_err(js_error)
}

/// Reads a settings object strictly: an unknown field is an error naming it.
///
/// serde-wasm-bindgen reads only the fields a struct declares, so `deny_unknown_fields` never
/// fires through it and a typo (`max_lots`) would silently keep the default. Settings are
/// small, so they go through a JSON value, which sees every key.
///
/// Before that, the JS value is walked without recursion: a nesting deeper than
/// [`MAX_SETTINGS_DEPTH`] (which would overflow the stack and leave the module broken), more
/// than [`MAX_SETTINGS_NODES`] values, a number that is not finite (JSON has no NaN, so it
/// would silently read as "default") and a non-object where an object belongs (serde would
/// read an array into a struct field by field) are errors naming the place.
pub(super) fn settings<T>(v: Ts<T>) -> Result<T, JsValue>
where
    T: Tsify + serde::de::DeserializeOwned,
    T::JsType: JsCast,
{
    let value = v.js_value();
    check_settings_value(&value)?;
    let json: serde_json::Value = serde_wasm_bindgen::from_value(value).map_err(js_error)?;
    serde_json::from_value(json).map_err(js_error)
}

/// Deepest nesting accepted in a settings object (the real ones nest 3 levels).
pub(super) const MAX_SETTINGS_DEPTH: usize = 32;

/// Most values accepted in a settings object.
pub(super) const MAX_SETTINGS_NODES: usize = 100_000;

/// The only settings fields that hold lists; an array anywhere else is an error.
pub(super) const SETTINGS_LISTS: &[&str] = &["labels"];

/// The walk of [`settings`]: depth, size and finite numbers.
pub(super) fn check_settings_value(root: &JsValue) -> Result<(), JsValue> {
    if !root.is_object() || js_sys::Array::is_array(root) {
        return Err(js_error(BindingError::Invalid(
            "settings must be a plain object".to_string(),
        )));
    }
    let mut stack: Vec<(JsValue, String, usize)> = vec![(root.clone(), "config".into(), 0)];
    let mut seen = 0usize;
    while let Some((v, path, depth)) = stack.pop() {
        seen += 1;
        if seen > MAX_SETTINGS_NODES {
            return Err(js_error(BindingError::Invalid(format!(
                "settings hold more than {MAX_SETTINGS_NODES} values"
            ))));
        }
        if let Some(x) = v.as_f64() {
            if !x.is_finite() {
                return Err(js_error(BindingError::Invalid(format!(
                    "{path} = {x}: must be a finite number"
                ))));
            }
        } else if v.is_object() {
            let key = path.rsplit('.').next().unwrap_or_default();
            if js_sys::Array::is_array(&v) && !SETTINGS_LISTS.contains(&key) {
                return Err(js_error(BindingError::Invalid(format!(
                    "{path} must be an object or a value, not an array"
                ))));
            }
            if depth >= MAX_SETTINGS_DEPTH {
                return Err(js_error(BindingError::Invalid(format!(
                    "{path}: nested deeper than {MAX_SETTINGS_DEPTH} levels"
                ))));
            }
            let obj: &js_sys::Object = v.unchecked_ref();
            for entry in js_sys::Object::entries(obj).iter() {
                let pair: js_sys::Array = entry.unchecked_into();
                let key = pair.get(0).as_string().unwrap_or_default();
                stack.push((pair.get(1), format!("{path}.{key}"), depth + 1));
            }
        }
    }
    Ok(())
}

/// Converts an output struct to its typed JS value.
pub(super) fn ts<T: Tsify + Serialize>(v: &T) -> Result<Ts<T>, JsValue> {
    v.into_ts().map_err(js_error)
}

/// A whole number from JS that fits `u32`. wasm-bindgen's own `u32` parameters wrap
/// (`2**32 + 1` arrives as 1, `-1` as 4294967295), so the entry points that take sizes and
/// frame numbers take `f64` and check it here.
pub(super) fn whole_u32(name: &'static str, v: f64) -> Result<u32, JsValue> {
    if v.fract() == 0.0 && (0.0..=u32::MAX as f64).contains(&v) {
        Ok(v as u32)
    } else {
        Err(js_error(BindingError::Option {
            name,
            message: format!("{v} (must be a whole number in 0..=4294967295)"),
        }))
    }
}

/// A JS exception's message (an `Error`'s message, else the value as text).
pub(super) fn thrown_message(v: &JsValue) -> String {
    if let Some(e) = v.dyn_ref::<js_sys::Error>() {
        return String::from(e.message());
    }
    if let Some(s) = v.as_string() {
        return s;
    }
    js_sys::JSON::stringify(v)
        .ok()
        .and_then(|s| s.as_string())
        .unwrap_or_else(|| format!("{v:?}"))
}
