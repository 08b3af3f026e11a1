//! From ground-truth and tracker [`Record`]s to a [`SequenceData`]: TrackEval's checks and
//! preprocessing (`mot_challenge_2d_box.py`, `mots_challenge.py`), then similarities.

use super::error::{EvalError, Location, Problem, Side};
use super::masks;
use super::sequence::{Assigner, SequenceBuilder, SequenceData};
use crate::io::limits::MAX_BOXES_PER_FRAME;
pub use crate::io::sequence::{Origin, SequenceInput};
use crate::io::{Record, Rle};
use serde::{Deserialize, Serialize};

const EPS: f64 = f64::EPSILON;

/// MOTChallenge class ids (`mot_challenge_2d_box.py`): 1 pedestrian … 13 crowd.
const MOT_PEDESTRIAN: i32 = 1;
const MOT_DISTRACTORS: [i32; 4] = [2, 7, 8, 12];
const MOT20_EXTRA_DISTRACTOR: i32 = 6;
/// MOTS class of ignore regions.
pub const MOTS_IGNORE_CLASS: i32 = 10;
/// MOTS pedestrian class.
pub const MOTS_PEDESTRIAN: i32 = 2;

/// How records are filtered before scoring, as TrackEval's dataset classes do.
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase", deny_unknown_fields)]
pub enum Preprocessing {
    /// Score every record as given (no filtering, no class checks).
    None,
    /// MOT15, or TrackEval with `DO_PREPROC` off: drop zero-marked gt rows (`int(conf) == 0`);
    /// tracker rows must not have a class above 1.
    Mot15,
    /// MOT16/MOT17: additionally remove tracker boxes matched (IoU ≥ 0.5) to distractor gt
    /// (person on vehicle, static person, distractor, reflection), keep only pedestrian gt, and
    /// refuse gt classes outside 1..=13.
    Mot17,
    /// MOT20: as [`Preprocessing::Mot17`] with non-MOT vehicles also distractors.
    Mot20,
    /// MOTSChallenge: keep gt and tracker masks of `class` only; unmatched tracker masks more
    /// than half inside the frame's class-10 ignore region are removed; masks must not overlap.
    Mots {
        /// Class evaluated (2 = pedestrian in MOTS20, 1 = car in KITTI-MOTS).
        class: i32,
    },
}

impl Preprocessing {
    /// TrackEval's choice for a benchmark name: MOTS (or `masks`) → MOTS pedestrians, MOT15 →
    /// zero-marked only, MOT20 → MOT20, anything else → MOT16/17 rules (as TrackEval treats
    /// every benchmark other than MOT15).
    pub fn for_benchmark(benchmark: &str, masks: bool) -> Preprocessing {
        let b = benchmark.to_ascii_uppercase();
        if masks || b.starts_with("MOTS") {
            Preprocessing::Mots {
                class: MOTS_PEDESTRIAN,
            }
        } else if b == "MOT15" {
            Preprocessing::Mot15
        } else if b == "MOT20" {
            Preprocessing::Mot20
        } else {
            Preprocessing::Mot17
        }
    }
}

/// Which similarity scores a gt/tracker pair.
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Similarity {
    /// Box IoU (`Record::bbox`), as TrackEval's `_calculate_box_ious`. In settings: `"box"`.
    #[serde(rename = "box")]
    BoxIou,
    /// Mask IoU (`Record::mask`), as pycocotools' `iou`. In settings: `"mask"`.
    #[serde(rename = "mask")]
    MaskIou,
}

/// Evaluation settings.
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EvalConfig {
    /// Filtering before scoring.
    pub preprocessing: Preprocessing,
    /// Pair similarity.
    pub similarity: Similarity,
    /// Similarity a CLEAR or Identity match needs (TrackEval: 0.5).
    pub threshold: f64,
}

impl Default for EvalConfig {
    /// Box IoU, MOT15 preprocessing (zero-marked gt dropped), threshold 0.5.
    fn default() -> Self {
        EvalConfig {
            preprocessing: Preprocessing::Mot15,
            similarity: Similarity::BoxIou,
            threshold: 0.5,
        }
    }
}

impl EvalConfig {
    /// Every record scored as given (no preprocessing): records that did not come from a
    /// benchmark's files, such as a labelling session's, with box IoU at 0.5.
    pub fn unfiltered() -> EvalConfig {
        EvalConfig {
            preprocessing: Preprocessing::None,
            ..EvalConfig::default()
        }
    }

    /// TrackEval's settings for a benchmark; `masks` selects MOTS with mask IoU.
    pub fn for_benchmark(benchmark: &str, masks: bool) -> EvalConfig {
        let preprocessing = Preprocessing::for_benchmark(benchmark, masks);
        let similarity = if matches!(preprocessing, Preprocessing::Mots { .. }) {
            Similarity::MaskIou
        } else {
            Similarity::BoxIou
        };
        EvalConfig {
            preprocessing,
            similarity,
            threshold: 0.5,
        }
    }
}

impl SequenceInput {
    /// An in-memory sequence (errors name records by index).
    pub fn new(
        name: impl Into<String>,
        num_frames: u32,
        gt: Vec<Record>,
        results: Vec<Record>,
    ) -> SequenceInput {
        SequenceInput {
            name: name.into(),
            num_frames,
            gt,
            results,
            gt_origin: None,
            results_origin: None,
        }
    }

    fn records(&self, side: Side) -> &[Record] {
        match side {
            Side::Gt => &self.gt,
            Side::Tracker => &self.results,
        }
    }

    fn error(&self, side: Side, record: usize, problem: Problem) -> EvalError {
        let origin = match side {
            Side::Gt => self.gt_origin.as_ref(),
            Side::Tracker => self.results_origin.as_ref(),
        };
        EvalError::Data {
            location: Location {
                seq: self.name.clone(),
                side,
                record,
                file: origin.map(|o| o.file.clone()),
                line: origin
                    .and_then(|o| o.lines.get(record).copied())
                    .unwrap_or(0),
            },
            problem,
        }
    }
}

/// Record indices grouped by frame, for the frames that have records (order kept in a frame).
struct ByFrame {
    frames: Vec<u32>,
    gt_idx: Vec<usize>,
    tr_idx: Vec<usize>,
    gt: Vec<(usize, usize)>,
    tr: Vec<(usize, usize)>,
}

impl ByFrame {
    fn new(gt: &[Record], tr: &[Record]) -> ByFrame {
        let order = |rs: &[Record]| {
            let mut v: Vec<usize> = (0..rs.len()).collect();
            v.sort_by_key(|&k| rs[k].frame);
            v
        };
        let (gt_idx, tr_idx) = (order(gt), order(tr));
        let mut frames: Vec<u32> = gt.iter().chain(tr).map(|r| r.frame).collect();
        frames.sort_unstable();
        frames.dedup();
        let ranges = |rs: &[Record], idx: &[usize]| {
            let mut out = Vec::with_capacity(frames.len());
            let mut pos = 0;
            for &f in &frames {
                let start = pos;
                while pos < idx.len() && rs[idx[pos]].frame == f {
                    pos += 1;
                }
                out.push((start, pos));
            }
            out
        };
        let (g, t) = (ranges(gt, &gt_idx), ranges(tr, &tr_idx));
        ByFrame {
            frames,
            gt_idx,
            tr_idx,
            gt: g,
            tr: t,
        }
    }

    fn side(&self, side: Side, i: usize) -> &[usize] {
        match side {
            Side::Gt => &self.gt_idx[self.gt[i].0..self.gt[i].1],
            Side::Tracker => &self.tr_idx[self.tr[i].0..self.tr[i].1],
        }
    }
}

/// Applies TrackEval's checks and preprocessing and computes similarities.
pub fn prepare(input: &SequenceInput, config: &EvalConfig) -> Result<SequenceData, EvalError> {
    let n = input.num_frames as usize;
    let mots_class = match config.preprocessing {
        Preprocessing::Mots { class } => Some(class),
        _ => None,
    };
    let need_masks = mots_class.is_some() || config.similarity == Similarity::MaskIou;

    // Loading checks, in TrackEval's order: gt file, then tracker file.
    let mut mask_size: Option<(u32, u32)> = None;
    for side in [Side::Gt, Side::Tracker] {
        for (k, r) in input.records(side).iter().enumerate() {
            if r.frame < 1 || r.frame > input.num_frames {
                return Err(input.error(
                    side,
                    k,
                    Problem::InvalidTimestep {
                        frame: r.frame,
                        num_frames: input.num_frames,
                    },
                ));
            }
            if need_masks {
                let Some(m) = &r.mask else {
                    return Err(input.error(side, k, Problem::MissingMask { frame: r.frame }));
                };
                let (eh, ew) = *mask_size.get_or_insert((m.height, m.width));
                if (m.height, m.width) != (eh, ew) {
                    return Err(input.error(
                        side,
                        k,
                        Problem::MaskSize {
                            frame: r.frame,
                            height: m.height,
                            width: m.width,
                            expected_height: eh,
                            expected_width: ew,
                        },
                    ));
                }
            } else if ![r.bbox.x, r.bbox.y, r.bbox.w, r.bbox.h]
                .iter()
                .all(|v| v.is_finite())
            {
                return Err(input.error(side, k, Problem::InvalidBox { frame: r.frame }));
            }
        }
    }
    let by = ByFrame::new(&input.gt, &input.results);
    // Before any per-frame work: the matrices and matchings below grow with these counts.
    for (i, &frame) in by.frames.iter().enumerate() {
        for side in [Side::Gt, Side::Tracker] {
            let idx = by.side(side, i);
            if idx.len() > MAX_BOXES_PER_FRAME {
                let problem = Problem::TooManyBoxes {
                    frame,
                    count: idx.len(),
                    max: MAX_BOXES_PER_FRAME,
                };
                return Err(input.error(side, idx[MAX_BOXES_PER_FRAME], problem));
            }
        }
    }
    let (mask_w, mask_h) = mask_size.map(|(h, w)| (w, h)).unwrap_or((0, 0));

    // MOTS: masks of a frame must not overlap (gt objects and the merged ignore region count as
    // one set, tracker masks as another).
    if mots_class.is_some() {
        let mut owners: Vec<usize> = Vec::new();
        let mut ignore_idx: Vec<usize> = Vec::new();
        for (i, &f) in by.frames.iter().enumerate() {
            for side in [Side::Gt, Side::Tracker] {
                let recs = input.records(side);
                let idx = by.side(side, i);
                owners.clear();
                ignore_idx.clear();
                for &k in idx {
                    if side == Side::Gt && recs[k].class == MOTS_IGNORE_CLASS {
                        ignore_idx.push(k);
                    } else {
                        owners.push(k);
                    }
                }
                let merged = (!ignore_idx.is_empty()).then(|| {
                    let parts: Vec<&Rle> = ignore_idx
                        .iter()
                        .filter_map(|&k| recs[k].mask.as_ref())
                        .collect();
                    masks::union(&parts, mask_w, mask_h)
                });
                let mut ms: Vec<&Rle> = owners
                    .iter()
                    .filter_map(|&k| recs[k].mask.as_ref())
                    .collect();
                if let (Some(m), Some(&k)) = (&merged, ignore_idx.first()) {
                    ms.push(m);
                    owners.push(k);
                }
                if let Some(p) = masks::first_overlap(&ms) {
                    return Err(input.error(
                        side,
                        owners[p],
                        Problem::OverlappingMasks { frame: f },
                    ));
                }
            }
        }
    }

    // Ids must be unique per frame (TrackEval checks tracker before gt, frame by frame). MOTS
    // ignore regions are not objects and may share ids.
    let mut scratch: Vec<(i64, usize)> = Vec::new();
    for (i, &f) in by.frames.iter().enumerate() {
        for side in [Side::Tracker, Side::Gt] {
            let recs = input.records(side);
            let idx = by.side(side, i);
            scratch.clear();
            scratch.extend(
                idx.iter()
                    .filter(|&&k| {
                        !(side == Side::Gt
                            && mots_class.is_some()
                            && recs[k].class == MOTS_IGNORE_CLASS)
                    })
                    .map(|&k| (recs[k].id, k)),
            );
            if scratch.len() > 1 {
                scratch.sort_unstable();
                if let Some(w) = scratch.windows(2).find(|w| w[0].0 == w[1].0) {
                    return Err(input.error(
                        side,
                        w[1].1,
                        Problem::DuplicateId {
                            frame: f,
                            id: w[0].0,
                        },
                    ));
                }
            }
        }
    }

    let mut p = FramePrep::default();
    let mut builder = SequenceBuilder::new(input.name.clone());
    let mut done = 0usize;
    for (i, &f) in by.frames.iter().enumerate() {
        let f = f as usize;
        builder.push_empty_frames(f - 1 - done);
        p.frame(
            input,
            config,
            f,
            by.side(Side::Gt, i),
            by.side(Side::Tracker, i),
            (mask_w, mask_h),
        )?;
        builder.push_frame(&p.gt_ids, &p.tr_ids, &p.sim)?;
        done = f;
    }
    builder.push_empty_frames(n - done);
    Ok(builder.finish())
}

/// Per-frame buffers, reused across frames.
#[derive(Default)]
struct FramePrep {
    gt_rows: Vec<usize>,
    tr_cols: Vec<usize>,
    raw: Vec<f64>,
    keep_gt: Vec<bool>,
    keep_tr: Vec<bool>,
    gt_ids: Vec<i64>,
    tr_ids: Vec<i64>,
    sim: Vec<f64>,
    assign: Assigner,
    ignore: Vec<usize>,
    matched: Vec<bool>,
}

impl FramePrep {
    fn frame(
        &mut self,
        input: &SequenceInput,
        config: &EvalConfig,
        f: usize,
        gt_idx: &[usize],
        tr_idx: &[usize],
        (mask_w, mask_h): (u32, u32),
    ) -> Result<(), EvalError> {
        let (gt, tr) = (&input.gt, &input.results);
        let frame = f as u32;
        self.gt_rows.clear();
        self.tr_cols.clear();
        self.ignore.clear();
        let mots_class = match config.preprocessing {
            Preprocessing::Mots { class } => Some(class),
            _ => None,
        };
        // Candidate rows/columns: MOTS filters by class before matching; MOTChallenge matches
        // against every gt class (distractors included).
        for &k in gt_idx {
            match mots_class {
                Some(_) if gt[k].class == MOTS_IGNORE_CLASS => self.ignore.push(k),
                Some(c) if gt[k].class != c => {}
                _ => self.gt_rows.push(k),
            }
        }
        for &k in tr_idx {
            match mots_class {
                Some(c) if tr[k].class != c => {}
                _ => self.tr_cols.push(k),
            }
        }
        let (ng, nt) = (self.gt_rows.len(), self.tr_cols.len());
        self.raw.clear();
        for &gk in &self.gt_rows {
            for &tk in &self.tr_cols {
                self.raw
                    .push(similarity(&gt[gk], &tr[tk], config.similarity));
            }
        }
        self.keep_gt.clear();
        self.keep_gt.resize(ng, true);
        self.keep_tr.clear();
        self.keep_tr.resize(nt, true);

        match config.preprocessing {
            Preprocessing::None => {}
            Preprocessing::Mot15 | Preprocessing::Mot17 | Preprocessing::Mot20 => {
                if let Some(&k) = self.tr_cols.iter().find(|&&k| tr[k].class > 1) {
                    return Err(input.error(
                        Side::Tracker,
                        k,
                        Problem::NonPedestrianClass {
                            frame,
                            class: tr[k].class,
                        },
                    ));
                }
                let full = config.preprocessing != Preprocessing::Mot15;
                if full && ng > 0 && nt > 0 {
                    if let Some(&k) = self
                        .gt_rows
                        .iter()
                        .find(|&&k| !(1..=13).contains(&gt[k].class))
                    {
                        return Err(input.error(
                            Side::Gt,
                            k,
                            Problem::InvalidGtClass {
                                frame,
                                class: gt[k].class,
                            },
                        ));
                    }
                    let cost = self.assign.reset(ng, nt);
                    for (c, &v) in cost.iter_mut().zip(&self.raw) {
                        *c = if v < 0.5 - EPS { 0.0 } else { -v };
                    }
                    self.solve(input, ng, nt)?;
                    let mot20 = config.preprocessing == Preprocessing::Mot20;
                    for (&i, &j) in self.assign.rows.iter().zip(&self.assign.cols) {
                        let v = self.raw[i * nt + j];
                        let score = if v < 0.5 - EPS { 0.0 } else { v };
                        let class = gt[self.gt_rows[i]].class;
                        let distractor = MOT_DISTRACTORS.contains(&class)
                            || (mot20 && class == MOT20_EXTRA_DISTRACTOR);
                        if score > EPS && distractor {
                            self.keep_tr[j] = false;
                        }
                    }
                }
                for (i, &k) in self.gt_rows.iter().enumerate() {
                    // TrackEval reads the flag with `astype(int)`: 0.5 counts as zero-marked.
                    let marked = gt[k].score.trunc() != 0.0;
                    self.keep_gt[i] = marked && (!full || gt[k].class == MOT_PEDESTRIAN);
                }
            }
            Preprocessing::Mots { .. } => {
                if nt > 0 {
                    let cost = self.assign.reset(ng, nt);
                    for (c, &v) in cost.iter_mut().zip(&self.raw) {
                        *c = if v < 0.5 - EPS { 10000.0 } else { -v };
                    }
                    self.solve(input, ng, nt)?;
                    self.matched.clear();
                    self.matched.resize(nt, false);
                    for (&i, &j) in self.assign.rows.iter().zip(&self.assign.cols) {
                        if -self.assign.cost()[i * nt + j] > EPS {
                            self.matched[j] = true;
                        }
                    }
                    // Unmatched tracker masks more than half inside the ignore region go.
                    if !self.ignore.is_empty() {
                        let parts: Vec<&Rle> = self
                            .ignore
                            .iter()
                            .filter_map(|&k| gt[k].mask.as_ref())
                            .collect();
                        let region = masks::union(&parts, mask_w, mask_h);
                        for (j, &k) in self.tr_cols.iter().enumerate() {
                            if self.matched[j] {
                                continue;
                            }
                            if let Some(m) = &tr[k].mask {
                                if masks::ioa(m, &region) > 0.5 + EPS {
                                    self.keep_tr[j] = false;
                                }
                            }
                        }
                    }
                }
            }
        }

        self.gt_ids.clear();
        self.tr_ids.clear();
        self.sim.clear();
        for (i, &k) in self.gt_rows.iter().enumerate() {
            if self.keep_gt[i] {
                self.gt_ids.push(gt[k].id);
            }
        }
        for (j, &k) in self.tr_cols.iter().enumerate() {
            if self.keep_tr[j] {
                self.tr_ids.push(tr[k].id);
            }
        }
        for i in 0..ng {
            if !self.keep_gt[i] {
                continue;
            }
            for j in 0..nt {
                if self.keep_tr[j] {
                    self.sim.push(self.raw[i * nt + j]);
                }
            }
        }
        Ok(())
    }

    fn solve(&mut self, input: &SequenceInput, ng: usize, nt: usize) -> Result<(), EvalError> {
        if self.assign.solve(ng, nt) {
            Ok(())
        } else {
            Err(EvalError::Assignment {
                seq: input.name.clone(),
                rows: ng,
                cols: nt,
            })
        }
    }
}

fn similarity(gt: &Record, tr: &Record, kind: Similarity) -> f64 {
    match kind {
        Similarity::BoxIou => gt.bbox.iou(&tr.bbox),
        Similarity::MaskIou => match (&gt.mask, &tr.mask) {
            (Some(a), Some(b)) => a.iou(b),
            _ => 0.0,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::BBox;

    fn rec(frame: u32, id: i64, x: f64, score: f64, class: i32) -> Record {
        Record {
            score,
            class,
            ..Record::from_box(frame, id, BBox::new(x, 0.0, 10.0, 10.0))
        }
    }

    fn cfg(p: Preprocessing) -> EvalConfig {
        EvalConfig {
            preprocessing: p,
            ..EvalConfig::default()
        }
    }

    #[test]
    fn zero_marked_uses_integer_truncation() {
        // conf 0.5 reads as 0 in TrackEval (astype(int)), so that row is dropped; -1.5 is kept.
        let gt = vec![
            rec(1, 1, 0.0, 0.5, 1),
            rec(1, 2, 50.0, -1.5, 1),
            rec(1, 3, 90.0, 1.0, 1),
        ];
        let input = SequenceInput::new("z", 1, gt, vec![]);
        let s = prepare(&input, &cfg(Preprocessing::Mot15)).unwrap();
        assert_eq!(s.num_gt_dets(), 2);
        let s = prepare(&input, &cfg(Preprocessing::None)).unwrap();
        assert_eq!(s.num_gt_dets(), 3);
    }

    #[test]
    fn mot17_removes_tracker_boxes_on_distractors_only() {
        // gt: pedestrian at x=0, static person (7) at x=50, car (3) at x=100.
        let gt = vec![
            rec(1, 1, 0.0, 1.0, 1),
            rec(1, 2, 50.0, 1.0, 7),
            rec(1, 3, 100.0, 1.0, 3),
        ];
        let tr = vec![
            rec(1, 1, 1.0, 1.0, -1),
            rec(1, 2, 51.0, 1.0, -1),
            rec(1, 3, 101.0, 1.0, 1),
        ];
        let input = SequenceInput::new("d", 1, gt, tr);
        let s = prepare(&input, &cfg(Preprocessing::Mot17)).unwrap();
        // Only the pedestrian gt stays; the box on the static person goes, the one on the car
        // stays (a false positive).
        assert_eq!((s.num_gt_dets(), s.num_tracker_dets()), (1, 2));
        let s = prepare(&input, &cfg(Preprocessing::Mot15)).unwrap();
        assert_eq!((s.num_gt_dets(), s.num_tracker_dets()), (3, 3));
    }

    #[test]
    fn mot20_adds_non_mot_vehicle_distractor() {
        let gt = vec![rec(1, 1, 0.0, 1.0, 6)];
        let tr = vec![rec(1, 1, 1.0, 1.0, -1)];
        let input = SequenceInput::new("v", 1, gt, tr);
        assert_eq!(
            prepare(&input, &cfg(Preprocessing::Mot17))
                .unwrap()
                .num_tracker_dets(),
            1
        );
        assert_eq!(
            prepare(&input, &cfg(Preprocessing::Mot20))
                .unwrap()
                .num_tracker_dets(),
            0
        );
    }

    fn mask(w: u32, h: u32, x0: usize, x1: usize) -> Rle {
        let mut m = vec![0u8; (w * h) as usize];
        for y in 0..h as usize {
            for x in x0..x1 {
                m[y * w as usize + x] = 1;
            }
        }
        Rle::encode(w, h, &m).unwrap()
    }

    fn mrec(id: i64, class: i32, m: Rle) -> Record {
        Record {
            class,
            mask: Some(m),
            ..Record::from_box(1, id, BBox::default())
        }
    }

    #[test]
    fn mots_ignore_region_removes_unmatched_masks_inside_it() {
        // 10x2 image: pedestrian at x 0..3, ignore region at x 6..10, a car at x 3..5.
        let gt = vec![
            mrec(2001, 2, mask(10, 2, 0, 3)),
            mrec(1001, 1, mask(10, 2, 3, 5)),
            mrec(10000, 10, mask(10, 2, 6, 10)),
        ];
        let tr = vec![
            mrec(1, 2, mask(10, 2, 0, 3)),  // matches the pedestrian
            mrec(2, 2, mask(10, 2, 5, 9)),  // 3/4 inside the ignore region: removed
            mrec(3, 2, mask(10, 2, 3, 5)),  // on the car (not evaluated): a false positive
            mrec(4, 1, mask(10, 2, 9, 10)), // a car: filtered out by class
        ];
        let input = SequenceInput::new("m", 1, gt, tr);
        let c = EvalConfig::for_benchmark("MOTS", true);
        let s = prepare(&input, &c).unwrap();
        assert_eq!((s.num_gt_dets(), s.num_tracker_dets()), (1, 2));
        let f = s.frame(0).unwrap();
        assert_eq!(f.similarity, &[1.0, 0.0]);
    }

    #[test]
    fn huge_seq_length_costs_nothing() {
        // Only frames with objects are stored; CLR_Frames still counts every timestep.
        let gt = vec![rec(1, 1, 0.0, 1.0, 1), rec(u32::MAX, 1, 0.0, 1.0, 1)];
        let input = SequenceInput::new("h", u32::MAX, gt.clone(), gt);
        let r = crate::eval::evaluate(&[input], &EvalConfig::default()).unwrap();
        assert_eq!(r.combined.clear.clr_frames, u32::MAX as u64);
        assert_eq!(r.combined.clear.clr_tp, 2);
    }
}
