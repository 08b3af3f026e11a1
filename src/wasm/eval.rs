//! Evaluation: the core's MOT metrics over records from JS.

use super::*;
use crate::eval::{self, EvalConfig, Preprocessing, SequenceInput, Similarity, Summary};
use serde::{Deserialize, Serialize};
use tsify::{Ts, Tsify};
use wasm_bindgen::prelude::*;

/// How to score: which similarity, threshold and preprocessing (defaults: box IoU, 0.5, none).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, Tsify)]
#[serde(default, deny_unknown_fields)]
pub struct EvalOptions {
    /// Pair similarity: box IoU or mask IoU.
    #[tsify(optional, type = "\"box\" | \"mask\"")]
    pub similarity: Option<String>,
    /// Similarity a CLEAR or Identity match needs.
    #[tsify(optional)]
    pub threshold: Option<f64>,
    /// TrackEval's preprocessing of a benchmark: "mot15", "mot17", "mot20", "mots"; absent:
    /// score every record as given.
    #[tsify(optional, type = "\"mot15\" | \"mot17\" | \"mot20\" | \"mots\"")]
    pub benchmark: Option<String>,
}

impl EvalOptions {
    fn to_core(&self) -> Result<EvalConfig, JsValue> {
        let masks = match self.similarity.as_deref() {
            None | Some("box") => false,
            Some("mask") => true,
            Some(other) => {
                return Err(js_error(BindingError::Option {
                    name: "similarity",
                    message: format!("{other:?} (expected \"box\" or \"mask\")"),
                }))
            }
        };
        let mut cfg = match self.benchmark.as_deref() {
            None => EvalConfig {
                preprocessing: Preprocessing::None,
                ..EvalConfig::default()
            },
            Some(b @ ("mot15" | "mot17" | "mot20" | "mots")) => EvalConfig::for_benchmark(b, masks),
            Some(other) => {
                return Err(js_error(BindingError::Option {
                    name: "benchmark",
                    message: format!("{other:?} (expected mot15, mot17, mot20 or mots)"),
                }))
            }
        };
        cfg.similarity = if masks {
            Similarity::MaskIou
        } else {
            Similarity::BoxIou
        };
        if let Some(t) = self.threshold {
            cfg.threshold = t;
        }
        Ok(cfg)
    }
}

/// The headline MOT metrics, as TrackEval prints them (percentages 0–100, counts).
#[derive(Debug, Clone, PartialEq, Serialize, Tsify)]
pub struct Scores {
    /// HOTA.
    pub hota: f64,
    /// Detection accuracy (HOTA's).
    pub deta: f64,
    /// Association accuracy (HOTA's).
    pub assa: f64,
    /// Localisation accuracy (HOTA's).
    pub loca: f64,
    /// MOTA.
    pub mota: f64,
    /// MOTP.
    pub motp: f64,
    /// IDF1.
    pub idf1: f64,
    /// Identity precision.
    pub idp: f64,
    /// Identity recall.
    pub idr: f64,
    /// Identity switches.
    pub idsw: u64,
    /// False positives.
    pub fp: u64,
    /// False negatives (misses).
    #[serde(rename = "fn")]
    pub fn_: u64,
    /// Fragmentations.
    pub frag: u64,
    /// Mostly tracked ground-truth tracks.
    pub mt: u64,
    /// Partly tracked.
    pub pt: u64,
    /// Mostly lost.
    pub ml: u64,
    /// Ground-truth tracks.
    pub gt_ids: u64,
    /// Tracker tracks.
    pub ids: u64,
}

impl From<&Summary> for Scores {
    fn from(s: &Summary) -> Self {
        Scores {
            hota: s.hota,
            deta: s.det_a,
            assa: s.ass_a,
            loca: s.loc_a,
            mota: s.mota,
            motp: s.motp,
            idf1: s.idf1,
            idp: s.idp,
            idr: s.idr,
            idsw: s.idsw,
            fp: s.fp,
            fn_: s.fn_,
            frag: s.frag,
            mt: s.mt,
            pt: s.pt,
            ml: s.ml,
            gt_ids: s.gt_ids,
            ids: s.ids,
        }
    }
}

/// Scores `results` against `gt` over frames `1..=frames` with the core's evaluator (the same
/// numbers as TrackEval).
#[wasm_bindgen]
pub fn evaluate(
    gt: Ts<Records>,
    results: Ts<Records>,
    frames: u32,
    options: Option<Ts<EvalOptions>>,
) -> Result<Ts<Scores>, JsValue> {
    let cfg = match options {
        Some(o) => settings(o)?.to_core()?,
        None => EvalOptions::default().to_core()?,
    };
    let gt = to_core_records(rust(gt)?)?;
    let res = to_core_records(rust(results)?)?;
    let input = [SequenceInput::new("sequence", frames, gt, res)];
    let r = eval::evaluate(&input, &cfg).map_err(js_error)?;
    ts(&Scores::from(&r.summary().combined))
}
