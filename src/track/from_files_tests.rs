//! Unit tests of the sequence runner (`shapetrack track`).

use super::*;

#[test]
fn json_config_overrides_only_its_fields() {
    let base = Config::masks();
    let c = base
        .overlay_json(r#"{"max_lost": 7, "terms": {"iou": {"weight": 2.0}}}"#)
        .unwrap();
    assert_eq!(c.max_lost, 7);
    assert_eq!(c.terms.iou.weight, 2.0);
    assert_eq!(c.terms.ioa, base.terms.ioa);
    assert_eq!(c.coast_frames, base.coast_frames);
    assert!(base.overlay_json(r#"{"max_lots": 7}"#).is_err());
    assert!(base.overlay_json("not json").is_err());
}
