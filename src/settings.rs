//! Settings as people write them: a partial JSON object laid over a complete config.
//!
//! Every config type of the core (the tracker's [`crate::track::Config`], the offline pass',
//! the follower's, the background detector's, the evaluation's) is one Rust type with every
//! field set. Partial input — a CLI `--config` file, a JS settings object in the browser, a
//! line of a grid's config list — is a JSON object naming only the fields it changes, and
//! [`overlay`] applies it over a base (the defaults or a preset) in one place, for all of
//! them. So there is no second, all-`Option` copy of any config to keep in step, and the
//! browser's TypeScript types are derived from these same types (tsify, on wasm32 only).
//!
//! Errors name the field: `terms.iou.weight: invalid type: string "x", expected f64`.

use serde::de::DeserializeOwned;
use serde::Serialize;
use serde_json::Value;

/// A number as error messages print it: what the person wrote, not binary noise.
///
/// A setting is often an `f32` (the detectors'), and `0.3_f32 as f64` prints as
/// `0.30000001192092896`; a computed value as `0.30000000000000004`. Neither is what the person
/// wrote, and both hide the point of the message. A value that is exactly an `f32` prints as
/// the shortest text that reads back to that `f32` (`0.3`, and `1.0000001` stays itself, so
/// a value just outside a range never prints as its bound); any other is rounded to 15
/// significant digits, the precision an `f64` holds for any decimal. Integers print whole,
/// very large and very small values with an exponent (`1e300`, not three hundred digits).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Short(pub f64);

impl Short {
    /// `Short` of a borrowed value (for error attributes, which see fields by reference).
    pub fn of(v: &f64) -> Short {
        Short(*v)
    }
}

impl std::fmt::Display for Short {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let v = self.0;
        if !v.is_finite() || v == 0.0 {
            return write!(f, "{v}");
        }
        if v.fract() == 0.0 && v.abs() < 1e15 {
            return write!(f, "{}", v as i64);
        }
        let plain = (1e-4..1e15).contains(&v.abs());
        let single = v as f32;
        if f64::from(single) == v {
            return if plain {
                write!(f, "{single}")
            } else {
                write!(f, "{single:e}")
            };
        }
        let r: f64 = format!("{v:.14e}").parse().unwrap_or(v);
        if plain {
            write!(f, "{r}")
        } else {
            write!(f, "{r:e}")
        }
    }
}

/// `patch` merged into `base`: objects field by field, anything else replaced (`null`
/// included, which turns an optional section off).
pub fn merge(base: &mut Value, patch: &Value) {
    match (base, patch) {
        (Value::Object(a), Value::Object(b)) => {
            for (k, v) in b {
                match a.get_mut(k) {
                    Some(slot) => merge(slot, v),
                    None => {
                        a.insert(k.clone(), v.clone());
                    }
                }
            }
        }
        (a, b) => *a = b.clone(),
    }
}

/// Checks that `v` has no array where `template` (a serialised config) has an object: serde
/// would read a JSON array into a struct field by field (`[1, 2, 3]` silently setting the
/// first three fields). The root must be an object. `path` names the place in errors. Any
/// other mismatch (a string where a struct belongs) is left to serde, which refuses it with
/// the field's path — and a string may be right there, for an enum whose other variants
/// carry data (`"all"` where the default is `{"selective": {…}}`).
pub fn check_shape(v: &Value, template: &Value, path: &str) -> Result<(), serde_json::Error> {
    use serde::de::Error as _;
    match (template, v) {
        (Value::Object(t), Value::Object(o)) => {
            for (k, x) in o {
                if let Some(tk) = t.get(k) {
                    check_shape(x, tk, &format!("{path}.{k}"))?;
                }
            }
            Ok(())
        }
        (Value::Object(_), Value::Array(_)) => Err(serde_json::Error::custom(format!(
            "{path} must be a JSON object, not an array"
        ))),
        (_, v) if path == "config" && !v.is_object() => {
            Err(serde_json::Error::custom("config must be a JSON object"))
        }
        _ => Ok(()),
    }
}

/// Reads a complete config from JSON, the error naming the field that failed
/// (`terms.iou.weight: invalid type: …`); unknown fields are errors wherever the type denies
/// them.
pub fn from_value<T: DeserializeOwned>(v: Value) -> Result<T, serde_json::Error> {
    use serde::de::Error as _;
    serde_path_to_error::deserialize(v).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        if path == "." {
            inner
        } else {
            serde_json::Error::custom(format!("{path}: {inner}"))
        }
    })
}

/// `base` with the fields a JSON object names replaced, nested objects merged field by field
/// (`{"terms": {"iou": {"weight": 2}}}` changes one weight and keeps the rest of `base`).
/// `patch` must be an object; unknown fields are errors where the type denies them, and every
/// error names its field.
pub fn overlay<T: Serialize + DeserializeOwned>(
    base: &T,
    patch: &Value,
) -> Result<T, serde_json::Error> {
    let mut value = serde_json::to_value(base)?;
    check_shape(patch, &value, "config")?;
    merge(&mut value, patch);
    from_value(value)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, PartialEq, Serialize, Deserialize, Default)]
    #[serde(default, deny_unknown_fields)]
    struct Inner {
        a: f64,
        b: Option<u32>,
    }

    #[derive(Debug, PartialEq, Serialize, Deserialize, Default)]
    #[serde(default, deny_unknown_fields)]
    struct Outer {
        x: u32,
        inner: Inner,
    }

    #[test]
    fn numbers_print_short() {
        let p = |v: f64| Short(v).to_string();
        assert_eq!(p(0.3_f32 as f64), "0.3");
        assert_eq!(p(0.1 + 0.2), "0.3");
        assert_eq!(p(1.3_f32 as f64), "1.3");
        // Just outside a range stays outside it in the message.
        assert_eq!(p(1.0000001_f32 as f64), "1.0000001");
        assert_eq!(p(0.123456789), "0.123456789");
        assert_eq!(p(1000.0000001), "1000.0000001");
        assert_eq!(p(1048577.0), "1048577");
        assert_eq!(p(-2.5), "-2.5");
        assert_eq!(p(1e300), "1e300");
        assert_eq!(p(1.5e-7), "1.5e-7");
        assert_eq!(p(f64::NAN), "NaN");
        assert_eq!(p(f64::NEG_INFINITY), "-inf");
        assert_eq!(p(0.0), "0");
    }

    #[test]
    fn overlay_changes_only_the_named_fields() {
        let base = Outer {
            x: 3,
            inner: Inner { a: 1.5, b: Some(2) },
        };
        let out = overlay(&base, &serde_json::json!({"inner": {"a": 4.0}})).unwrap();
        assert_eq!(out.x, 3);
        assert_eq!(out.inner, Inner { a: 4.0, b: Some(2) });
        // null turns an optional field off rather than keeping the base's value.
        let out = overlay(&base, &serde_json::json!({"inner": {"b": null}})).unwrap();
        assert_eq!(out.inner.b, None);
    }

    #[test]
    fn errors_name_the_field() {
        let base = Outer::default();
        let e = overlay(&base, &serde_json::json!({"inner": {"a": "x"}})).unwrap_err();
        assert!(e.to_string().starts_with("inner.a: invalid type"), "{e}");
        let e = overlay(&base, &serde_json::json!({"inner": {"c": 1}})).unwrap_err();
        assert!(
            e.to_string().contains("inner") && e.to_string().contains("`c`"),
            "{e}"
        );
        let e = overlay(&base, &serde_json::json!({"inner": [1, 2]})).unwrap_err();
        assert!(
            e.to_string().contains("config.inner must be a JSON object"),
            "{e}"
        );
        assert!(overlay(&base, &serde_json::json!([1])).is_err());
    }

    #[test]
    fn bad_tracker_settings_name_their_field() {
        let err = |v: serde_json::Value| {
            crate::track::Config::from_settings(crate::track::Preset::Default, &v)
                .unwrap_err()
                .to_string()
        };
        assert!(err(serde_json::json!({ "preset": "mask" })).starts_with("preset:"));
        let e = err(serde_json::json!({ "terms": { "iou": { "weight": "x" } } }));
        assert!(e.starts_with("terms.iou.weight: invalid type"), "{e}");
        let e = err(serde_json::json!({ "appearance": { "lazzy": true } }));
        assert!(e.contains("appearance") && e.contains("lazzy"), "{e}");
        let e = err(serde_json::json!({ "sift_matching": { "ratios": 0.7 } }));
        assert!(e.contains("sift_matching") && e.contains("ratios"), "{e}");
        assert!(err(serde_json::json!([1])).contains("object"));
    }
}
