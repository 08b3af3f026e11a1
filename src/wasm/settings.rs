//! Settings objects from JS. There is no binding-side copy of any config: a settings object
//! is a partial JSON object over one of the core's config types, applied by the core's
//! [`crate::settings::overlay`] (the same code the CLI's `--config` files go through), and
//! its TypeScript type is `DeepPartial` of the type tsify derives from the core struct.

use super::*;
use crate::detect::background::BackgroundConfig;
use crate::detect::{MovingConfig, RefineConfig};
use crate::eval::EvalConfig;
use crate::follow::FollowConfig;
use crate::segment::SegmentConfig;
use crate::track::offline::OfflineConfig;
use crate::track::{Config as TrackConfig, Preset};
use serde::de::DeserializeOwned;
use serde::Serialize;
use wasm_bindgen::prelude::*;

#[wasm_bindgen(typescript_custom_section)]
const SETTINGS_TS: &'static str = r#"
/** `T` with every field optional, all the way down: a settings object names only the fields
 * it changes, and the rest keep the base config's values. */
export type DeepPartial<T> = T extends readonly unknown[]
  ? T
  : T extends object
    ? { [K in keyof T]?: DeepPartial<T[K]> }
    : T;
/** The tracker's settings: any fields of `TrackConfig` over a preset (`"default"` unless
 * given). Unknown fields are errors naming them. */
export type TrackerSettings = DeepPartial<TrackConfig> & { preset?: Preset };
/** What the offline pass at the end needs: the video's frame rate (its gates are in seconds;
 * it is the online tracker's `frame_rate` too, unless the tracker's settings give one), the
 * image size for box-only tracking, and any fields of `OfflineConfig` except `online`
 * (that is the tracker's own settings) over its defaults. */
export type OfflineSettings = { fps: number; width?: number; height?: number } & DeepPartial<
  Omit<OfflineConfig, "online">
>;
/** The background detector's settings over `BackgroundConfig`'s defaults. */
export type BackgroundSettings = DeepPartial<BackgroundConfig>;
/** The moving-camera detector's settings over `MovingConfig`'s defaults. */
export type MovingSettings = DeepPartial<MovingConfig>;
/** The box → mask refinement's settings over `RefineConfig`'s defaults. */
export type RefineSettings = DeepPartial<RefineConfig>;
/** The follower's settings over `FollowConfig`'s defaults. */
export type FollowSettings = DeepPartial<FollowConfig>;
/** The learned segmentation's settings over `SegmentConfig`'s defaults. */
export type SegmentSettings = DeepPartial<SegmentConfig>;
/** How `evaluate` scores, over its defaults: box IoU at 0.5, every record as given
 * (`preprocessing: "none"`; `"mot15"`, `"mot17"`, `"mot20"` or `{ mots: { class } }` apply
 * TrackEval's benchmark rules). */
export type EvalSettings = DeepPartial<EvalConfig>;
"#;

#[wasm_bindgen]
extern "C" {
    /// The tracker's settings (`TrackerSettings` in TypeScript).
    #[wasm_bindgen(typescript_type = "TrackerSettings")]
    pub type TrackerSettings;
    /// The offline pass' settings (`OfflineSettings`).
    #[wasm_bindgen(typescript_type = "OfflineSettings")]
    pub type OfflineSettings;
    /// The background detector's settings (`BackgroundSettings`).
    #[wasm_bindgen(typescript_type = "BackgroundSettings")]
    pub type BackgroundSettings;
    /// The moving-camera detector's settings (`MovingSettings`).
    #[wasm_bindgen(typescript_type = "MovingSettings")]
    pub type MovingSettings;
    /// The box → mask refinement's settings (`RefineSettings`).
    #[wasm_bindgen(typescript_type = "RefineSettings")]
    pub type RefineSettings;
    /// The follower's settings (`FollowSettings`).
    #[wasm_bindgen(typescript_type = "FollowSettings")]
    pub type FollowSettings;
    /// The evaluation's settings (`EvalSettings`).
    #[wasm_bindgen(typescript_type = "EvalSettings")]
    pub type EvalSettings;
    /// The learned segmentation's settings (`SegmentSettings`).
    #[wasm_bindgen(typescript_type = "SegmentSettings")]
    pub type SegmentSettings;
}

/// A settings object as a JSON value, after [`check_settings_value`] (depth, size, finite
/// numbers, no arrays where objects belong).
///
/// It goes through `JSON.stringify` rather than straight into the struct: serde-wasm-bindgen
/// reads only the fields a struct declares, so `deny_unknown_fields` would never fire and a
/// typo (`max_lots`) would silently keep the default; and JSON drops keys whose value is
/// `undefined`, so `{ max_lost: undefined }` means "not given", as it does in JS, while
/// `null` turns an optional setting off.
fn value(v: &JsValue) -> Result<serde_json::Value, JsValue> {
    check_settings_value(v)?;
    let text = js_sys::JSON::stringify(v)
        .map_err(|e| {
            js_error(BindingError::Invalid(format!(
                "settings are not JSON: {}",
                thrown_message(&e)
            )))
        })?
        .as_string()
        .unwrap_or_default();
    serde_json::from_str(&text).map_err(js_error)
}

/// `base` with the fields of the settings object `v` over it (`None`: `base` unchanged).
pub(super) fn overlay<T: Serialize + DeserializeOwned>(
    base: T,
    v: Option<&JsValue>,
) -> Result<T, JsValue> {
    match v {
        None => Ok(base),
        Some(v) => crate::settings::overlay(&base, &value(v)?).map_err(js_error),
    }
}

/// The tracker's config from its settings object (`None`: the core's defaults).
pub(super) fn track_config(v: Option<&TrackerSettings>) -> Result<TrackConfig, JsValue> {
    match v {
        None => Ok(TrackConfig::default()),
        Some(v) => TrackConfig::from_settings(Preset::Default, &value(v)?).map_err(js_error),
    }
}

/// What the offline settings hold besides the core's [`OfflineConfig`].
pub(super) struct Offline {
    /// The complete offline config, `online` being the tracker's.
    pub config: OfflineConfig,
    /// Frames per second.
    pub fps: f64,
    /// Image size for box-only tracking.
    pub size: Option<(u32, u32)>,
}

/// The offline pass' config from its settings object, around the tracker's `online` config.
pub(super) fn offline_config(v: &OfflineSettings, online: TrackConfig) -> Result<Offline, JsValue> {
    let mut v = value(v)?;
    let map = v.as_object_mut().ok_or_else(|| {
        js_error(BindingError::Invalid(
            "settings must be a plain object".into(),
        ))
    })?;
    let fps = match map.remove("fps") {
        Some(serde_json::Value::Number(n)) => n.as_f64().unwrap_or(f64::NAN),
        other => {
            return Err(js_error(BindingError::Option {
                name: "fps",
                message: format!("{} (must be a number)", other.unwrap_or_default()),
            }))
        }
    };
    if !(fps.is_finite() && fps > 0.0) {
        return Err(js_error(BindingError::Option {
            name: "fps",
            message: format!("{fps} (must be a finite number > 0)"),
        }));
    }
    let side = |name: &'static str, v: Option<serde_json::Value>| -> Result<Option<u32>, JsValue> {
        v.map(|v| {
            v.as_f64()
                .ok_or_else(|| {
                    js_error(BindingError::Option {
                        name,
                        message: format!("{v} (must be a number)"),
                    })
                })
                .and_then(|x| whole_u32(name, x))
        })
        .transpose()
    };
    let size = match (
        side("width", map.remove("width"))?,
        side("height", map.remove("height"))?,
    ) {
        // Masks are encoded as RLE over this size: 0 × 0 encoded every mask as empty and
        // sides past the caps wrapped the run counts, both silently; refused here, like a
        // frame of that size (`FrameBuffer`).
        (Some(w), Some(h)) if !frame_size_ok(w, h) => {
            return Err(js_error(BindingError::FrameSize {
                width: w,
                height: h,
            }))
        }
        (Some(w), Some(h)) => Some((w, h)),
        (None, None) => None,
        _ => {
            return Err(js_error(BindingError::Option {
                name: "width/height",
                message: "give both or neither".to_string(),
            }))
        }
    };
    if map.contains_key("online") {
        return Err(js_error(BindingError::Option {
            name: "online",
            message: "the online pass takes the tracker's settings (the first argument)".into(),
        }));
    }
    let base = OfflineConfig {
        online,
        ..OfflineConfig::default()
    };
    let config = crate::settings::overlay(&base, &v).map_err(js_error)?;
    config.validate().map_err(js_error)?;
    Ok(Offline { config, fps, size })
}

/// The background detector's config from its settings object.
pub(super) fn background_config(
    v: Option<&BackgroundSettings>,
) -> Result<BackgroundConfig, JsValue> {
    overlay(BackgroundConfig::default(), v.map(|v| v.as_ref()))
}

/// The moving-camera detector's config from its settings object.
pub(super) fn moving_config(v: Option<&MovingSettings>) -> Result<MovingConfig, JsValue> {
    overlay(MovingConfig::default(), v.map(|v| v.as_ref()))
}

/// The box → mask refinement's config from its settings object (the core's `BoxRefiner`
/// validates it).
pub(super) fn refine_config(v: Option<&RefineSettings>) -> Result<RefineConfig, JsValue> {
    overlay(RefineConfig::default(), v.map(|v| v.as_ref()))
}

/// The follower's config from its settings object.
pub(super) fn follow_config(v: Option<&FollowSettings>) -> Result<FollowConfig, JsValue> {
    overlay(FollowConfig::default(), v.map(|v| v.as_ref()))
}

/// The learned segmentation's config from its settings object.
pub(super) fn segment_config(v: Option<&SegmentSettings>) -> Result<SegmentConfig, JsValue> {
    let c = overlay(SegmentConfig::default(), v.map(|v| v.as_ref()))?;
    c.validate().map_err(js_error)?;
    Ok(c)
}

/// The evaluation's config from its settings object, over [`EvalConfig::unfiltered`].
pub(super) fn eval_config(v: Option<&EvalSettings>) -> Result<EvalConfig, JsValue> {
    overlay(EvalConfig::unfiltered(), v.map(|v| v.as_ref()))
}
