//! Evaluation: MOT metrics (CLEAR, Identity, HOTA) equal to TrackEval's.
//!
//! The pipeline mirrors TrackEval: [`prepare`] turns ground-truth and tracker [`Record`]s into a
//! [`SequenceData`] (TrackEval's checks, preprocessing, box or mask IoU, id relabelling); the
//! metrics ([`clear()`], [`identity()`], [`hota()`]) only see per-frame ids and similarities;
//! [`evaluate`] runs everything over several sequences and combines them as TrackEval's
//! `combine_sequences` does. [`MotResults::summary`] gives the figures as TrackEval prints them
//! (percentages 0–100, counts as integers).
//!
//! ```
//! use shapetrack::eval::{evaluate, EvalConfig, SequenceInput};
//! use shapetrack::io::Record;
//! use shapetrack::BBox;
//!
//! let gt = vec![Record::from_box(1, 1, BBox::new(0.0, 0.0, 10.0, 10.0))];
//! let res = gt.clone();
//! let seqs = [SequenceInput::new("s", 1, gt, res)];
//! let r = evaluate(&seqs, &EvalConfig::default())?;
//! assert_eq!(r.summary().combined.hota, 100.0);
//! # Ok::<(), shapetrack::eval::EvalError>(())
//! ```
//!
//! [`Record`]: crate::io::Record

mod clear;
mod error;
mod hota;
mod identity;
mod masks;
mod preproc;
mod sequence;
pub mod vot;

pub use clear::{clear, Clear};
pub use error::{EvalError, Location, Problem, Side};
pub use hota::{alphas, hota, Hota, NUM_ALPHAS};
pub use identity::{identity, Identity};
pub use preproc::{
    prepare, EvalConfig, Origin, Preprocessing, SequenceInput, Similarity, MOTS_IGNORE_CLASS,
    MOTS_PEDESTRIAN,
};
pub use sequence::{FrameView, SequenceBuilder, SequenceData};

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Detection and id counts (TrackEval's `Count` metric).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Count {
    /// Tracker objects after preprocessing.
    pub dets: u64,
    /// Ground-truth objects after preprocessing.
    pub gt_dets: u64,
    /// Distinct tracker ids.
    pub ids: u64,
    /// Distinct ground-truth ids (summed over sequences when combined).
    pub gt_ids: u64,
}

/// All metrics of one sequence (or of the combination).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SequenceResult {
    /// Sequence name (`COMBINED` for the combination).
    pub name: String,
    /// HOTA family.
    pub hota: Hota,
    /// CLEAR MOT.
    pub clear: Clear,
    /// Identity.
    pub identity: Identity,
    /// Counts.
    pub count: Count,
}

/// Per-sequence results and their combination.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MotResults {
    /// One entry per sequence, in input order.
    pub sequences: Vec<SequenceResult>,
    /// All sequences combined (TrackEval's `COMBINED_SEQ`).
    pub combined: SequenceResult,
}

/// The figures TrackEval reports for one row: ratios in percent (0–100, HOTA-family values
/// averaged over α), counts as integers, field names as TrackEval's.
#[allow(missing_docs)]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    #[serde(rename = "HOTA")]
    pub hota: f64,
    #[serde(rename = "DetA")]
    pub det_a: f64,
    #[serde(rename = "AssA")]
    pub ass_a: f64,
    #[serde(rename = "LocA")]
    pub loc_a: f64,
    #[serde(rename = "DetRe")]
    pub det_re: f64,
    #[serde(rename = "DetPr")]
    pub det_pr: f64,
    #[serde(rename = "AssRe")]
    pub ass_re: f64,
    #[serde(rename = "AssPr")]
    pub ass_pr: f64,
    #[serde(rename = "OWTA")]
    pub owta: f64,
    #[serde(rename = "HOTA(0)")]
    pub hota0: f64,
    #[serde(rename = "LocA(0)")]
    pub loca0: f64,
    #[serde(rename = "HOTALocA(0)")]
    pub hotaloca0: f64,
    #[serde(rename = "MOTA")]
    pub mota: f64,
    #[serde(rename = "MOTP")]
    pub motp: f64,
    #[serde(rename = "MODA")]
    pub moda: f64,
    #[serde(rename = "sMOTA")]
    pub smota: f64,
    #[serde(rename = "MOTAL")]
    pub motal: f64,
    #[serde(rename = "CLR_Re")]
    pub clr_re: f64,
    #[serde(rename = "CLR_Pr")]
    pub clr_pr: f64,
    #[serde(rename = "CLR_F1")]
    pub clr_f1: f64,
    #[serde(rename = "MTR")]
    pub mtr: f64,
    #[serde(rename = "PTR")]
    pub ptr: f64,
    #[serde(rename = "MLR")]
    pub mlr: f64,
    /// False positives per frame (a rate, not a percentage).
    #[serde(rename = "FP_per_frame")]
    pub fp_per_frame: f64,
    #[serde(rename = "IDF1")]
    pub idf1: f64,
    #[serde(rename = "IDP")]
    pub idp: f64,
    #[serde(rename = "IDR")]
    pub idr: f64,
    #[serde(rename = "CLR_TP")]
    pub clr_tp: u64,
    #[serde(rename = "FN")]
    pub fn_: u64,
    #[serde(rename = "FP")]
    pub fp: u64,
    #[serde(rename = "IDSW")]
    pub idsw: u64,
    #[serde(rename = "Frag")]
    pub frag: u64,
    #[serde(rename = "MT")]
    pub mt: u64,
    #[serde(rename = "PT")]
    pub pt: u64,
    #[serde(rename = "ML")]
    pub ml: u64,
    #[serde(rename = "CLR_Frames")]
    pub clr_frames: u64,
    #[serde(rename = "IDTP")]
    pub idtp: u64,
    #[serde(rename = "IDFN")]
    pub idfn: u64,
    #[serde(rename = "IDFP")]
    pub idfp: u64,
    #[serde(rename = "Dets")]
    pub dets: u64,
    #[serde(rename = "GT_Dets")]
    pub gt_dets: u64,
    #[serde(rename = "IDs")]
    pub ids: u64,
    #[serde(rename = "GT_IDs")]
    pub gt_ids: u64,
}

/// [`MotResults`] as TrackEval's table: `{"sequences": {name: row}, "combined": row}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MotSummary {
    /// Rows by sequence name (sorted, as TrackEval prints them).
    pub sequences: BTreeMap<String, Summary>,
    /// The combined row.
    pub combined: Summary,
}

impl SequenceResult {
    /// This result as TrackEval reports it.
    pub fn summary(&self) -> Summary {
        let (h, c, i, n) = (&self.hota, &self.clear, &self.identity, &self.count);
        let pct = |v: f64| 100.0 * v;
        Summary {
            hota: pct(hota::mean(&h.hota)),
            det_a: pct(hota::mean(&h.det_a)),
            ass_a: pct(hota::mean(&h.ass_a)),
            loc_a: pct(hota::mean(&h.loc_a)),
            det_re: pct(hota::mean(&h.det_re)),
            det_pr: pct(hota::mean(&h.det_pr)),
            ass_re: pct(hota::mean(&h.ass_re)),
            ass_pr: pct(hota::mean(&h.ass_pr)),
            owta: pct(hota::mean(&h.owta)),
            hota0: pct(h.hota0),
            loca0: pct(h.loca0),
            hotaloca0: pct(h.hotaloca0),
            mota: pct(c.mota),
            motp: pct(c.motp),
            moda: pct(c.moda),
            smota: pct(c.smota),
            motal: pct(c.motal),
            clr_re: pct(c.clr_re),
            clr_pr: pct(c.clr_pr),
            clr_f1: pct(c.clr_f1),
            mtr: pct(c.mtr),
            ptr: pct(c.ptr),
            mlr: pct(c.mlr),
            fp_per_frame: c.fp_per_frame,
            idf1: pct(i.idf1),
            idp: pct(i.idp),
            idr: pct(i.idr),
            clr_tp: c.clr_tp,
            fn_: c.clr_fn,
            fp: c.clr_fp,
            idsw: c.idsw,
            frag: c.frag,
            mt: c.mt,
            pt: c.pt,
            ml: c.ml,
            clr_frames: c.clr_frames,
            idtp: i.idtp,
            idfn: i.idfn,
            idfp: i.idfp,
            dets: n.dets,
            gt_dets: n.gt_dets,
            ids: n.ids,
            gt_ids: n.gt_ids,
        }
    }
}

impl MotResults {
    /// Per-sequence and combined rows as TrackEval reports them.
    pub fn summary(&self) -> MotSummary {
        MotSummary {
            sequences: self
                .sequences
                .iter()
                .map(|s| (s.name.clone(), s.summary()))
                .collect(),
            combined: self.combined.summary(),
        }
    }

    /// The result of the sequence called `name`.
    pub fn sequence(&self, name: &str) -> Option<&SequenceResult> {
        self.sequences.iter().find(|s| s.name == name)
    }
}

/// Buffers shared by the metrics across sequences.
#[derive(Debug, Default)]
struct Scratch {
    clear: clear::ClearScratch,
    identity: identity::IdentityScratch,
    hota: hota::HotaScratch,
}

fn score(seq: &SequenceData, threshold: f64, s: &mut Scratch) -> Result<SequenceResult, EvalError> {
    Ok(SequenceResult {
        name: seq.name().to_string(),
        hota: hota::hota_with(seq, &mut s.hota)?,
        clear: clear::clear_with(seq, threshold, &mut s.clear)?,
        identity: identity::identity_with(seq, threshold, &mut s.identity)?,
        count: Count {
            dets: seq.num_tracker_dets() as u64,
            gt_dets: seq.num_gt_dets() as u64,
            ids: seq.num_tracker_ids() as u64,
            gt_ids: seq.num_gt_ids() as u64,
        },
    })
}

/// Combines per-sequence results as TrackEval's `combine_sequences`.
pub fn combine(results: &[SequenceResult]) -> SequenceResult {
    let mut count = Count::default();
    for r in results {
        count.dets += r.count.dets;
        count.gt_dets += r.count.gt_dets;
        count.ids += r.count.ids;
        count.gt_ids += r.count.gt_ids;
    }
    SequenceResult {
        name: "COMBINED".to_string(),
        hota: Hota::combine(results.iter().map(|r| &r.hota)),
        clear: Clear::combine(results.iter().map(|r| &r.clear)),
        identity: Identity::combine(results.iter().map(|r| &r.identity)),
        count,
    }
}

/// Scores already prepared sequences (any similarity) and combines them.
pub fn evaluate_prepared(seqs: &[SequenceData], threshold: f64) -> Result<MotResults, EvalError> {
    if seqs.is_empty() {
        return Err(EvalError::NoSequences);
    }
    check_unique_names(seqs.iter().map(|s| s.name()))?;
    let mut scratch = Scratch::default();
    let sequences = seqs
        .iter()
        .map(|s| score(s, threshold, &mut scratch))
        .collect::<Result<Vec<_>, _>>()?;
    let combined = combine(&sequences);
    Ok(MotResults {
        sequences,
        combined,
    })
}

/// Evaluates in-memory ground truth and results: checks, preprocessing, similarities, metrics,
/// combination. Errors name the file and line when the inputs carry an [`Origin`].
pub fn evaluate(inputs: &[SequenceInput], config: &EvalConfig) -> Result<MotResults, EvalError> {
    if inputs.is_empty() {
        return Err(EvalError::NoSequences);
    }
    check_unique_names(inputs.iter().map(|s| s.name.as_str()))?;
    let mut scratch = Scratch::default();
    let mut sequences = Vec::with_capacity(inputs.len());
    for input in inputs {
        let seq = prepare(input, config)?;
        sequences.push(score(&seq, config.threshold, &mut scratch)?);
    }
    let combined = combine(&sequences);
    Ok(MotResults {
        sequences,
        combined,
    })
}

fn check_unique_names<'a>(names: impl Iterator<Item = &'a str>) -> Result<(), EvalError> {
    let mut seen = std::collections::HashSet::new();
    for n in names {
        if !seen.insert(n) {
            return Err(EvalError::DuplicateSequence {
                name: n.to_string(),
            });
        }
    }
    Ok(())
}
