//! Unit tests of [`super`] (the tracker config: validation, serde, settings and presets),
//! in their own file to keep `config.rs` within the track modules' length limit
//! (`tests/track_modules.rs`).

use super::*;

#[test]
fn settings_apply_over_a_preset_field_by_field() {
    let v = serde_json::json!({
        "preset": "masks", "high_score": 0.25, "reid_terms": { "colour": { "gate": 0.4 } }
    });
    let cfg = Config::from_settings(Preset::Default, &v).unwrap();
    let masks = Config::masks();
    assert_eq!(cfg.high_score, 0.25);
    assert_eq!(cfg.reid_terms.colour.gate, Some(0.4));
    // Nested fields not named keep the preset's values, not the defaults'.
    assert_eq!(cfg.reid_terms.colour.weight, masks.reid_terms.colour.weight);
    assert_eq!(cfg.max_lost, masks.max_lost);
    assert_ne!(cfg.max_lost, Config::default().max_lost);
    // Without "preset" the caller's preset is the base; `{}` is that preset exactly.
    let empty = serde_json::json!({});
    assert_eq!(Config::from_settings(Preset::Masks, &empty).unwrap(), masks);
    assert_eq!(
        Config::from_settings(Preset::Default, &empty).unwrap(),
        Config::default()
    );
    // Every field of both presets, named in full, reads back as the preset.
    for p in [Preset::Default, Preset::Masks] {
        let full = serde_json::to_value(p.config()).unwrap();
        assert_eq!(
            Config::from_settings(Preset::Default, &full).unwrap(),
            p.config()
        );
    }
}

#[test]
fn the_main_gate_scales_with_the_frame_interval() {
    let at = |fps: Option<f64>| {
        let c = Config {
            frame_rate: fps,
            ..Config::masks()
        };
        c.main_max_cost()
    };
    let m = Config::masks();
    assert!((at(Some(30.0)) - 0.54).abs() < 1e-12);
    assert!((at(Some(25.0)) - 0.648).abs() < 1e-12);
    assert_eq!(at(Some(5.0)), m.max_cost, "capped at max_cost");
    assert_eq!(at(None), m.max_cost, "unknown rate: max_cost");
    let boxes = Config {
        frame_rate: Some(30.0),
        ..Config::default()
    };
    assert_eq!(boxes.main_max_cost(), boxes.max_cost, "box mode: off");
    let bad = Config {
        reference_max_cost: Some(f64::NAN),
        ..Config::masks()
    };
    assert!(bad.validate().is_err());
}

#[test]
fn arrays_are_not_read_into_structs() {
    let base = Config::default();
    let e = base.overlay_json("[1, 2, 3]").unwrap_err().to_string();
    assert!(e.contains("config must be a JSON object"), "{e}");
    let e = base
        .overlay_json(r#"{"motion": [0.1, 0.2, 0.3]}"#)
        .unwrap_err()
        .to_string();
    assert!(e.contains("config.motion must be a JSON object"), "{e}");
    assert!(Config::from_json("[5, 1]").is_err());
    assert!(base
        .overlay_json(r#"{"motion": {"std_measurement": 0.2}}"#)
        .is_ok());
}

#[test]
fn default_is_valid_and_roundtrips() {
    let c = Config::default();
    c.validate().unwrap();
    let s = serde_json::to_string(&c).unwrap();
    assert_eq!(Config::from_json(&s).unwrap(), c);
    let partial =
        Config::from_json(r#"{"max_lost": 7, "terms": {"iou": {"weight": 2.0}}}"#).unwrap();
    assert_eq!(partial.max_lost, 7);
    assert_eq!(partial.terms.iou.weight, 2.0);
    assert_eq!(partial.terms.iou.scale, 1.0);
    assert_eq!(partial.min_hits, c.min_hits);
    assert!(Config::from_json(r#"{"max_lots": 7}"#).is_err());
}

#[test]
fn rejects_out_of_range_values() {
    let bad = |c: Config| c.validate().is_err();
    assert!(bad(Config {
        min_hits: 0,
        ..Config::default()
    }));
    assert!(bad(Config {
        max_cost: f64::NAN,
        ..Config::default()
    }));
    assert!(bad(Config {
        lost_velocity_decay: 1.5,
        ..Config::default()
    }));
    let mut c = Config::default();
    c.terms.centre.scale = 0.0;
    assert!(bad(c));
}
