//! Association as a list of stages (ByteTrack's cascade, generalised): each [`Stage`] offers
//! the tracks and detections no earlier stage took, filtered by track state and detection
//! confidence, keeps the pairs whose cost passes the stage's threshold, and solves them
//! optimally. [`stages`] builds the list from a [`Config`]; the tracker runs it in turn.

use super::config::Config;
use super::cost::{Candidate, CheapTerms, CostModel, PairScore};
use super::lifecycle::Track;
use super::prepare::Prepared;
use super::regions::Regions;
use crate::assign::{self, AssignError, Unmatched};
use crate::frame::TrackState;

/// An allowed pair: track index, prepared-detection index, the cost the assignment
/// minimises, and the cost thresholds compare (see [`super::cost::PairScore`]).
pub(crate) type Edge = (usize, usize, f64, f64);

/// A match decided by a stage: track index, prepared-detection index, cost.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Pair {
    pub(crate) track: usize,
    pub(crate) det: usize,
    pub(crate) cost: f64,
}

/// Which tracks and detections the stages have taken so far.
pub(crate) struct Used {
    pub(crate) tracks: Vec<bool>,
    pub(crate) dets: Vec<bool>,
}

impl Used {
    /// Nothing taken yet.
    pub(crate) fn new(tracks: usize, dets: usize) -> Self {
        Self {
            tracks: vec![false; tracks],
            dets: vec![false; dets],
        }
    }
}

/// The tracks a stage offers, by lifecycle state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StageTracks {
    /// Confirmed tracks (matched in the previous frame).
    Confirmed,
    /// Confirmed tracks, and lost ones last seen whole and missed for at most this many
    /// frames (see [`Config::lost_main_frames`]).
    Recent(u32),
    /// Lost tracks (unmatched for a frame or more, still searchable).
    Lost,
    /// Confirmed and lost tracks together, in one assignment.
    Active,
    /// Tentative tracks (not yet confirmed).
    Tentative,
    /// Confirmed, lost and tentative tracks together.
    All,
    /// Confirmed tracks, and tentative ones matched in the previous frame (see
    /// [`Config::low_extends_tentative`]).
    Seen,
}

impl StageTracks {
    /// Whether this stage offers `track` (by its state, and for [`StageTracks::Recent`] its
    /// misses).
    pub(crate) fn accepts_track(self, track: &Track) -> bool {
        let state = track.state();
        match self {
            StageTracks::Confirmed => state == TrackState::Confirmed,
            StageTracks::Recent(n) => {
                state == TrackState::Confirmed
                    || (state == TrackState::Lost && track.misses() <= n && track.last_seen_whole())
            }
            StageTracks::Lost => state == TrackState::Lost,
            StageTracks::Active => matches!(state, TrackState::Confirmed | TrackState::Lost),
            StageTracks::Tentative => state == TrackState::Tentative,
            StageTracks::All => state != TrackState::Removed,
            StageTracks::Seen => {
                state == TrackState::Confirmed
                    || (state == TrackState::Tentative && track.misses() == 0)
            }
        }
    }
}

/// The detections a stage offers, by confidence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StageDetections {
    /// High-confidence detections (see [`Config::high_score`]).
    High,
    /// Low-confidence detections: they only extend tracks, never start them.
    Low,
}

/// Which pair costs a stage reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StageCosts {
    /// The main association's terms ([`Config::terms`]), scored once per frame.
    Main,
    /// The re-identification terms ([`Config::reid_terms`]), scored when the stage runs, on
    /// the pairs still free then (their detections described first when appearance is needed).
    Reid,
}

/// One association stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stage {
    /// A name for diagnostics.
    pub name: &'static str,
    /// Tracks offered.
    pub tracks: StageTracks,
    /// Detections offered.
    pub detections: StageDetections,
    /// Costs read.
    pub costs: StageCosts,
    /// Highest cost (the threshold-compared one) a match may have.
    pub max_cost: f64,
    /// The margin by which a tentative track's cheaper pair takes a detection away from this
    /// stage's tracks (see [`Config::defer_to_tentative`]); `None` for every stage but the
    /// main one.
    pub defer: Option<f64>,
}

/// Matches a tentative track needs, the last in the previous frame, before a confirmed track
/// defers to it ([`Config::defer_to_tentative`]): a shape found twice in a row, not a piece
/// split off for one frame.
const DEFER_MIN_HITS: u32 = 2;

/// The tracks the main association offers under [`Config::lost_reid_only`]: the confirmed
/// ones, and the lost ones within [`Config::lost_main_frames`].
fn main_tracks(config: &Config) -> StageTracks {
    match config.lost_main_frames {
        0 => StageTracks::Confirmed,
        n => StageTracks::Recent(config.frames(n)),
    }
}

/// Whether `track` takes part in the main association under `config`: all but the lost
/// tracks that re-identification alone looks for (see [`Config::lost_reid_only`]).
pub(crate) fn in_main(config: &Config, track: &Track) -> bool {
    !config.lost_reid_only
        || track.state() != TrackState::Lost
        || main_tracks(config).accepts_track(track)
}

/// The stages of a config for frames with their image, and of its
/// [`Config::without_frames`] rules for frames without (no appearance to re-identify by).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct StagePlan {
    with_frames: Vec<Stage>,
    without_frames: Vec<Stage>,
}

impl StagePlan {
    pub(crate) fn new(config: &Config) -> Self {
        Self {
            with_frames: stages(config),
            without_frames: stages(&config.without_frames()),
        }
    }

    /// The stages that run on a frame given with its image (`has_frame`) or without.
    pub(crate) fn for_frame(&self, has_frame: bool) -> &[Stage] {
        if has_frame {
            &self.with_frames
        } else {
            &self.without_frames
        }
    }
}

/// The stages `config` describes, in the order they run:
///
/// 1. tracks seen in the previous frame × high detections (with lost tracks in the same
///    assignment, after it with [`Config::lost_second`], or not at all with
///    [`Config::lost_reid_only`]), up to [`Config::main_max_cost`]; with
///    [`Config::defer_to_tentative`] its tracks leave a detection to a tentative track that
///    matches it clearly better (see [`Stage::defer`]);
/// 2. tracks seen in the previous frame × low detections, up to [`Config::max_cost_low`]
///    (ByteTrack's second association): confirmed tracks, and tentative ones too with
///    [`Config::low_extends_tentative`];
/// 3. tentative tracks × high detections, up to [`Config::max_cost_tentative`], and the
///    re-identification of lost tracks × high detections, up to [`Config::reid_max_cost`]
///    (re-identification first with `lost_reid_only`, so a reappearing shape goes back to its
///    lost track before a tentative one takes it).
pub fn stages(config: &Config) -> Vec<Stage> {
    let main = |name, tracks, detections, max_cost| Stage {
        name,
        tracks,
        detections,
        costs: StageCosts::Main,
        max_cost,
        defer: None,
    };
    use StageDetections::{High, Low};
    let mut out = Vec::new();
    let gate = config.main_max_cost();
    if config.lost_reid_only {
        out.push(main("confirmed", main_tracks(config), High, gate));
    } else if config.lost_second {
        out.push(main("confirmed", StageTracks::Confirmed, High, gate));
        out.push(main("lost", StageTracks::Lost, High, gate));
    } else if config.tentative_first {
        out.push(main("all", StageTracks::All, High, gate));
    } else {
        out.push(main("active", StageTracks::Active, High, gate));
    }
    out[0].defer = config.defer_to_tentative;
    out.push(main(
        "low",
        if config.low_extends_tentative {
            StageTracks::Seen
        } else {
            StageTracks::Confirmed
        },
        Low,
        config.max_cost_low,
    ));
    let tentative = main(
        "tentative",
        StageTracks::Tentative,
        High,
        config.max_cost_tentative,
    );
    let reid = Stage {
        name: "reid",
        tracks: StageTracks::Lost,
        detections: High,
        costs: StageCosts::Reid,
        max_cost: config.reid_max_cost,
        defer: None,
    };
    if config.lost_reid_only {
        out.extend([reid, tentative]);
    } else {
        out.extend([tentative, reid]);
    }
    out
}

impl Stage {
    /// Whether track `t` and detection `d`, both still free, are offered by this stage.
    pub(crate) fn offers(&self, t: &Track, d: &Prepared<'_>) -> bool {
        self.tracks.accepts_track(t) && self.offers_detection(d)
    }

    /// Whether this stage offers detection `d` (by its confidence).
    fn offers_detection(&self, d: &Prepared<'_>) -> bool {
        match self.detections {
            StageDetections::High => d.high,
            StageDetections::Low => !d.high,
        }
    }

    /// Runs the stage over `edges`: the free pairs it offers costing at most its
    /// `max_cost`, solved optimally under `policy`; the matches are marked used and appended
    /// to `out`.
    pub(crate) fn run(
        &self,
        tracks: &[Track],
        dets: &[Prepared<'_>],
        edges: &[Edge],
        policy: Unmatched,
        used: &mut Used,
        out: &mut Vec<Pair>,
    ) -> Result<(), AssignError> {
        let free = |t: usize, d: usize, gate: f64| {
            gate <= self.max_cost && !used.tracks[t] && !used.dets[d]
        };
        let deferred = self.deferred(tracks, dets, edges, &free);
        let costs: Vec<(usize, usize, f64)> = edges
            .iter()
            .filter(|&&(t, d, c, gate)| {
                free(t, d, gate)
                    && self.offers(&tracks[t], &dets[d])
                    && deferred
                        .get(d)
                        .is_none_or(|&x| c.partial_cmp(&x) != Some(std::cmp::Ordering::Greater))
            })
            .map(|&(t, d, c, _)| (t, d, c))
            .collect();
        if costs.is_empty() {
            return Ok(());
        }
        for m in assign::solve_sparse(tracks.len(), dets.len(), &costs, policy)?.matches {
            let (t, d) = (m.row, m.col);
            used.tracks[t] = true;
            used.dets[d] = true;
            out.push(Pair {
                track: t,
                det: d,
                cost: m.cost,
            });
        }
        Ok(())
    }

    /// Per detection, the cost above which this stage's tracks give it up to a tentative
    /// track (infinite where none claims it): the cheapest free pair, passing this stage's
    /// gate, of a tentative track matched in the previous frame with at least
    /// [`DEFER_MIN_HITS`] matches, plus the [`Stage::defer`] margin. Empty (nothing
    /// allocated) when the stage does not defer, as every stage but the mask preset's main
    /// one.
    ///
    /// The tentative tracks' stage runs after the main one, so without this a confirmed
    /// track that slides behind a new shape (its own view hidden, its prediction still near)
    /// takes the new shape's detection, and the two swap when they part. On the mask cells
    /// of the robustness grid: crossing s101 kept both identities, mean HOTA +0.1 online and
    /// offline (`tests/data/quality/README.md`).
    fn deferred(
        &self,
        tracks: &[Track],
        dets: &[Prepared<'_>],
        edges: &[Edge],
        free: &impl Fn(usize, usize, f64) -> bool,
    ) -> Vec<f64> {
        let Some(margin) = self.defer else {
            return Vec::new();
        };
        let mut out = vec![f64::INFINITY; dets.len()];
        for &(t, d, c, gate) in edges {
            let tr = &tracks[t];
            let claims = tr.state() == TrackState::Tentative
                && tr.misses() == 0
                && tr.hits() >= DEFER_MIN_HITS
                && free(t, d, gate)
                && self.offers_detection(&dets[d]);
            if claims {
                out[d] = out[d].min(c + margin);
            }
        }
        out
    }
}

/// The combined cost under `model` of the candidate pairs of `regions` (between `tracks`
/// and `dets`) that `keep` accepts (sparse: a track only has the few candidates its region estimate found).
pub(crate) fn score_edges(
    model: &CostModel,
    tracks: &[Track],
    regions: &Regions,
    dets: &[Prepared<'_>],
    keep: impl Fn(&(usize, usize)) -> bool,
) -> Vec<Edge> {
    score_edges_reusing(
        model,
        tracks,
        regions,
        dets,
        keep,
        &mut CheapTerms::default(),
    )
}

/// [`score_edges`], with the cheap terms of the kept pairs read from (or left in) `cheap`
/// ([`CostModel::score_pairs_reusing`]).
pub(crate) fn score_edges_reusing(
    model: &CostModel,
    tracks: &[Track],
    regions: &Regions,
    dets: &[Prepared<'_>],
    keep: impl Fn(&(usize, usize)) -> bool,
    cheap: &mut CheapTerms,
) -> Vec<Edge> {
    let cands: Vec<Candidate<'_>> = dets.iter().map(Prepared::candidate).collect();
    // Tracks of different known classes never match (MOTS: cars are not pedestrians).
    let same_class = |t: usize, d: usize| {
        let (tc, dc) = (tracks[t].last_detection().class, dets[d].det.class);
        tc < 0 || dc < 0 || tc == dc
    };
    let kept: Vec<usize> = (0..regions.pairs.len())
        .filter(|&k| keep(&regions.pairs[k]))
        .collect();
    let sub;
    let regions = if kept.len() == regions.pairs.len() {
        regions
    } else {
        sub = Regions {
            pairs: kept.iter().map(|&k| regions.pairs[k]).collect(),
            pair_cluster: kept.iter().map(|&k| regions.pair_cluster[k]).collect(),
            clusters: std::sync::Arc::clone(&regions.clusters),
        };
        &sub
    };
    let scores = model.score_pairs_reusing(tracks, &cands, regions, cheap);
    regions
        .pairs
        .iter()
        .zip(scores)
        .filter_map(|(&(t, d), s): (&(usize, usize), Option<PairScore>)| {
            let s = s.filter(|_| same_class(t, d))?;
            Some((t, d, s.cost, s.absolute))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::track::lifecycle::HitView;

    #[test]
    fn the_main_stage_gate_follows_the_frame_rate() {
        let at = |fps| {
            stages(&Config {
                frame_rate: Some(fps),
                ..Config::masks()
            })
        };
        assert!((at(30.0)[0].max_cost - 0.54).abs() < 1e-12);
        assert_eq!(at(5.0)[0].max_cost, Config::masks().max_cost);
        // The second (low) and tentative stages keep their own gates.
        let (s, m) = (at(30.0), Config::masks());
        let gate = |name| s.iter().find(|st| st.name == name).map(|st| st.max_cost);
        assert_eq!(gate("low"), Some(m.max_cost_low));
        assert_eq!(gate("tentative"), Some(m.max_cost_tentative));
        assert_eq!(gate("reid"), Some(m.reid_max_cost));
    }

    #[test]
    fn stage_order_follows_the_config() {
        let names = |c: &Config| stages(c).iter().map(|s| s.name).collect::<Vec<_>>();
        let d = Config::default();
        assert_eq!(names(&d), ["active", "low", "tentative", "reid"]);
        let second = Config {
            lost_second: true,
            ..Config::default()
        };
        assert_eq!(
            names(&second),
            ["confirmed", "lost", "low", "tentative", "reid"]
        );
        let m = Config::masks();
        assert_eq!(names(&m), ["confirmed", "low", "reid", "tentative"]);
        // Without frames (no appearance) lost mask tracks are matched as box mode's are.
        assert_eq!(names(&m.without_frames()), names(&d));
        let s = stages(&m);
        // Lost mask tracks join the main association while their gap is short.
        assert_eq!(s[0].tracks, StageTracks::Recent(m.lost_main_frames));
        assert!(m.lost_main_frames > 0);
        let none = Config {
            lost_main_frames: 0,
            ..Config::masks()
        };
        assert_eq!(stages(&none)[0].tracks, StageTracks::Confirmed);
        assert_eq!(s[1].max_cost, m.max_cost_low);
        // Low detections extend tentative tracks seen in the previous frame too, unless asked
        // not to.
        assert_eq!(s[1].tracks, StageTracks::Seen);
        let confirmed_only = Config {
            low_extends_tentative: false,
            ..Config::default()
        };
        assert_eq!(stages(&confirmed_only)[1].tracks, StageTracks::Confirmed);
        assert_eq!(s[2].costs, StageCosts::Reid);
        assert_eq!(s[2].max_cost, m.reid_max_cost);
    }

    /// A confirmed track and a tentative one (matched `hits` times, the last in the previous
    /// frame) both want one detection; the main stage of `config` runs over the pairs
    /// `(confirmed, cost)` and `(tentative, cost)`, the tentative pair's gated cost `gate`
    /// (its cost when `None`). Returns whether the confirmed track took it.
    fn confirmed_takes(
        config: &Config,
        hits: u32,
        confirmed: f64,
        (tentative, gate): (f64, Option<f64>),
    ) -> bool {
        use crate::frame::{BBox, Detection};
        use crate::motion::BoxKalman;
        use crate::track::estimate::NoiseFit;
        use crate::track::features::Features;
        use std::borrow::Cow;
        let det = Detection::from_box(BBox::new(0.0, 0.0, 40.0, 80.0), 1.0);
        let track = || {
            let motion = Box::new(BoxKalman::new(&det.bbox, config.motion_params()).unwrap());
            Track::born(&det, &Features::default(), motion, None, 1, false, false)
        };
        let mut a = track();
        a.confirm(1);
        let mut t = track();
        for frame in 2..=hits {
            let fit = &mut NoiseFit::default();
            t.hit(
                &det,
                &Features::default(),
                frame,
                config,
                HitView::default(),
                fit,
            )
            .unwrap();
        }
        assert_eq!((t.hits(), t.misses()), (hits, 0));
        let tracks = [a, t];
        let dets = [Prepared {
            index: 0,
            det: Cow::Borrowed(&det),
            features: Features::default(),
            high: true,
        }];
        let gate = gate.unwrap_or(tentative);
        let edges = [(0, 0, confirmed, confirmed), (1, 0, tentative, gate)];
        let (mut used, mut out) = (Used::new(2, 1), Vec::new());
        stages(config)[0]
            .run(
                &tracks,
                &dets,
                &edges,
                Unmatched::MaxMatches,
                &mut used,
                &mut out,
            )
            .unwrap();
        assert!(
            out.iter().all(|p| p.track == 0),
            "the main stage offers no tentative track"
        );
        !out.is_empty()
    }

    #[test]
    fn a_confirmed_track_defers_to_a_clearly_better_tentative_one() {
        let m = Config::masks();
        assert_eq!(m.defer_to_tentative, Some(0.1));
        // The tentative track's pair is cheaper by more than the margin: the detection waits
        // for the tentative stage.
        assert!(!confirmed_takes(&m, 2, 0.4, (0.1, None)));
        // Not by more than the margin; a track seen once; deferring off (the box defaults).
        assert!(confirmed_takes(&m, 2, 0.4, (0.35, None)));
        assert!(confirmed_takes(&m, 1, 0.4, (0.1, None)));
        assert!(confirmed_takes(&Config::default(), 2, 0.4, (0.1, None)));
        // The tentative pair must pass the stage's gate itself.
        let gate = stages(&m)[0].max_cost;
        assert!(!confirmed_takes(&m, 2, 0.4, (0.1, Some(gate))));
        assert!(confirmed_takes(&m, 2, 0.4, (0.1, Some(gate + 0.01))));
    }
}
