//! Evaluation: the core's MOT metrics over records from JS.

use super::*;
use crate::eval::{self, SequenceInput, Summary};
use serde::Serialize;
use tsify::{Ts, Tsify};
use wasm_bindgen::prelude::*;

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
    options: Option<EvalSettings>,
) -> Result<Ts<Scores>, JsValue> {
    let cfg = settings::eval_config(options.as_ref())?;
    let gt = to_core_records(rust(gt)?)?;
    let res = to_core_records(rust(results)?)?;
    let input = [SequenceInput::new("sequence", frames, gt, res)];
    let r = eval::evaluate(&input, &cfg).map_err(js_error)?;
    ts(&Scores::from(&r.summary().combined))
}
