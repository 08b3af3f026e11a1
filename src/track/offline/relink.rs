//! The Kalman trajectory re-linker: which track continues which (thesis ch. 5, Alg. 7).
//!
//! For every master (a track that starts after frame 1) the candidate slaves are the tracks
//! that end before it starts, at most `max_gap_seconds` earlier, whose two ends pass the size
//! gate and whose motion gate cost is at most 1. Of these the `max_slaves` most recently ended
//! are kept (the thesis' "up to 5", applied after the gates so that a crowd of tracks ending
//! far away cannot crowd out the right one), then the `appearance_keep` with the most SIFT
//! connections (the thesis' "up to 2", when both ends have snapshots).
//!
//! The cost of a pair is the distance between where the slave's constant-acceleration filter,
//! rolled out over the gap, puts the centroid and where the master starts — averaged with the
//! reverse (the master rolled back to the slave's end) when `bidirectional` — divided by a gate
//! radius `size · (gate_base + gate_per_second · gap)` that grows with the gap, `size` being
//! the geometric mean of both ends' `sqrt(w·h)`. A pair is allowed when its cost is at most 1.
//!
//! Both ends are estimated from a short centroid history (`history_seconds`): position,
//! velocity and acceleration by least squares over the time stamps (`p + v·t + ½·a·t²`, `t` in
//! seconds, `Δt = 1/fps`). For evenly spaced points on an exact parabola that acceleration is
//! the thesis' mean acceleration (the mean of the second differences); on noisy points it is
//! its least-squares version, and it also copes with the frames a track was lost in.

use super::appearance::FeatureCache;
use super::config::{JoinSolver, RelinkConfig};
use super::{OfflineError, Phase, Progress, SequenceInfo};
use crate::frame::{BBox, Point, TrackedShape};
use crate::motion::{ConstantAcceleration, MotionError};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// The motion of a track at one of its ends, estimated from its centroid history.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EndState {
    /// Frame of the end (the track's last frame for a slave, its first for a master).
    pub frame: u32,
    /// Fitted centroid at that frame (pixels).
    pub position: Point,
    /// Fitted velocity (pixels per second, forward in time).
    pub velocity: Point,
    /// Fitted acceleration (pixels per second²).
    pub acceleration: Point,
    /// The shape's size `sqrt(w·h)` near this end (median over the history), in pixels.
    pub size: f64,
}

/// Least-squares fit of `p(t) = p₀ + v·t + ½·a·t²` to `(frame, centroid)` points, with
/// `t = (frame − anchor)/fps`. Falls back to a line when fewer than three distinct frames (or
/// a degenerate system) are given, and to the mean point with zero motion for one frame.
/// `points` must not be empty; `fps` must be positive (both checked by the callers).
pub fn fit_motion(points: &[(u32, Point)], anchor: u32, fps: f64) -> EndState {
    let t_of = |f: u32| (f64::from(f) - f64::from(anchor)) / fps;
    let mut distinct: Vec<u32> = points.iter().map(|p| p.0).collect();
    distinct.sort_unstable();
    distinct.dedup();
    let n = points.len().max(1) as f64;
    let mean = points.iter().fold(Point::default(), |acc, p| acc + p.1) * (1.0 / n);
    let still = EndState {
        frame: anchor,
        position: mean,
        velocity: Point::default(),
        acceleration: Point::default(),
        size: 0.0,
    };
    if distinct.len() >= 3 {
        // Normal equations of the basis [1, t, t²/2].
        let mut ata = Matrix3::<f64>::zeros();
        let (mut bx, mut by) = (Vector3::<f64>::zeros(), Vector3::<f64>::zeros());
        for &(f, p) in points {
            let t = t_of(f);
            let phi = Vector3::new(1.0, t, 0.5 * t * t);
            ata += phi * phi.transpose();
            bx += phi * p.x;
            by += phi * p.y;
        }
        if let Some(chol) = ata.cholesky() {
            let (cx, cy) = (chol.solve(&bx), chol.solve(&by));
            if cx.iter().chain(cy.iter()).all(|v| v.is_finite()) {
                return EndState {
                    frame: anchor,
                    position: Point::new(cx[0], cy[0]),
                    velocity: Point::new(cx[1], cy[1]),
                    acceleration: Point::new(cx[2], cy[2]),
                    size: 0.0,
                };
            }
        }
    }
    if distinct.len() >= 2 {
        let tm = points.iter().map(|p| t_of(p.0)).sum::<f64>() / n;
        let (mut stt, mut stx, mut sty) = (0.0, 0.0, 0.0);
        for &(f, p) in points {
            let dt = t_of(f) - tm;
            stt += dt * dt;
            stx += dt * (p.x - mean.x);
            sty += dt * (p.y - mean.y);
        }
        if stt > 0.0 {
            let v = Point::new(stx / stt, sty / stt);
            return EndState {
                frame: anchor,
                // The line's value at t = 0 (the anchor).
                position: mean - v * tm,
                velocity: v,
                acceleration: Point::default(),
                size: 0.0,
            };
        }
    }
    still
}

/// The centroids predicted `steps` frames after `end` (forward) by the constant-acceleration
/// filter of eq. 44–52, with the acceleration scaled by `accel_weight`; one point per frame.
pub fn rollout_forward(
    end: &EndState,
    steps: u32,
    fps: f64,
    accel_weight: f64,
) -> Result<Vec<Point>, MotionError> {
    let f = ConstantAcceleration::new(
        end.position,
        end.velocity,
        end.acceleration * accel_weight,
        fps,
    )?;
    Ok(f.rollout(steps as usize))
}

/// The centroids predicted `steps` frames before `start` (time reversed: the velocity changes
/// sign, the acceleration does not); element `k` is `k + 1` frames earlier.
pub fn rollout_backward(
    start: &EndState,
    steps: u32,
    fps: f64,
    accel_weight: f64,
) -> Result<Vec<Point>, MotionError> {
    let f = ConstantAcceleration::new(
        start.position,
        start.velocity * -1.0,
        start.acceleration * accel_weight,
        fps,
    )?;
    Ok(f.rollout(steps as usize))
}

/// One track of the online output: an id and its shapes (indices, by increasing frame).
#[derive(Debug, Clone)]
pub(crate) struct Piece {
    pub(crate) id: u64,
    pub(crate) idx: Vec<usize>,
    pub(crate) first: u32,
    pub(crate) last: u32,
}

/// Groups shapes by id (the groups in increasing id), each group sorted by frame. Shapes must
/// be valid and unique per (frame, id) (checked by the caller).
pub(crate) fn pieces(shapes: &[TrackedShape]) -> Vec<Piece> {
    let mut by_id: std::collections::BTreeMap<u64, Vec<usize>> = Default::default();
    for (i, s) in shapes.iter().enumerate() {
        by_id.entry(s.id).or_default().push(i);
    }
    by_id
        .into_iter()
        .filter_map(|(id, mut idx)| {
            idx.sort_by_key(|&i| shapes[i].frame);
            let first = shapes[*idx.first()?].frame;
            let last = shapes[*idx.last()?].frame;
            Some(Piece {
                id,
                idx,
                first,
                last,
            })
        })
        .collect()
}

/// Frames of history used at a track's end: at least 3 points when the track has them.
pub(crate) fn history_frames(cfg: &RelinkConfig, fps: f64) -> u32 {
    ((cfg.history_seconds * fps).round() as u32).max(3)
}

/// Which end of a track.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Side {
    /// The last frames (a slave's end).
    End,
    /// The first frames (a master's start).
    Start,
}

/// The motion at one end of the shapes `idx` (sorted by frame), from the shapes within
/// `history` frames of that end.
///
/// A shape going behind an occluder (or coming out) is seen shrinking, and its visible centroid
/// lags behind the object: such frames would bend the velocity and put the end in the wrong
/// place. So shapes smaller than `reliable` × the window's median size are left out, and the
/// end is anchored at the outermost shape that is kept; the returned `frame` is that anchor.
pub(crate) fn track_end(
    shapes: &[TrackedShape],
    idx: &[usize],
    side: Side,
    history: u32,
    reliable: f64,
    fps: f64,
) -> Option<EndState> {
    let edge = match side {
        Side::End => shapes[*idx.last()?].frame,
        Side::Start => shapes[*idx.first()?].frame,
    };
    let near = |&i: &usize| shapes[i].frame.abs_diff(edge) < history;
    let window: Vec<usize> = match side {
        Side::End => idx.iter().rev().copied().take_while(near).collect(),
        Side::Start => idx.iter().copied().take_while(near).collect(),
    };
    let mut sizes: Vec<f64> = window.iter().map(|&i| size(&shapes[i].bbox)).collect();
    sizes.sort_by(f64::total_cmp);
    let median = *sizes.get(sizes.len() / 2)?;
    let pts: Vec<(u32, Point)> = window
        .iter()
        .filter(|&&i| size(&shapes[i].bbox) >= reliable * median)
        .map(|&i| (shapes[i].frame, shapes[i].centroid))
        .collect();
    // `window` runs outwards from the edge, so the first kept point is the anchor.
    let &(anchor, _) = pts.first()?;
    let mut e = fit_motion(&pts, anchor, fps);
    e.size = median;
    Some(e)
}

fn size(b: &BBox) -> f64 {
    (b.w.max(0.0) * b.h.max(0.0)).sqrt()
}

/// One join decided by the re-linker: the master continues the slave.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Join {
    /// Id (in the online output) of the track that ended.
    pub slave: u64,
    /// Id (in the online output) of the track that continues it.
    pub master: u64,
    /// The slave's last frame.
    pub slave_last: u32,
    /// The master's first frame.
    pub master_first: u32,
    /// The pair's gate-normalised cost in `[0, 1]`.
    pub cost: f64,
    /// SIFT connections between the two ends, when both had snapshots.
    pub connections: Option<usize>,
}

/// A candidate pair: slave piece, master piece, cost, connections.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    slave: usize,
    master: usize,
    cost: f64,
    connections: Option<usize>,
}

/// The gate radius for continuing `end` by `start` (module docs) before any calibration:
/// `size · (gate_base + gate_per_second · gap)`, `size` the geometric mean of both ends'.
fn gate_radius(end: &EndState, start: &EndState, cfg: &RelinkConfig, fps: f64) -> f64 {
    let gap = start.frame.saturating_sub(end.frame);
    (end.size * start.size).sqrt() * (cfg.gate_base + cfg.gate_per_second * f64::from(gap) / fps)
}

/// How far the rollout from `end` over the gap lands from `start` (averaged with the reverse
/// rollout when `bidirectional`), `None` when a rollout leaves the image `bounds`: the object
/// went out of view, and whoever starts later is not it (the thesis treats out-of-view as a
/// challenge of its own).
fn rollout_error(
    end: &EndState,
    start: &EndState,
    cfg: &RelinkConfig,
    fps: f64,
    bounds: Option<(u32, u32)>,
) -> Result<Option<f64>, MotionError> {
    let inside = |p: &Point| match bounds {
        Some((w, h)) => p.x >= 0.0 && p.y >= 0.0 && p.x <= f64::from(w) && p.y <= f64::from(h),
        None => true,
    };
    let gap = start.frame.saturating_sub(end.frame);
    if gap > ROLLOUT_FRAMES {
        return Ok(long_gap_error(end, start, cfg, fps, bounds));
    }
    let fwd = rollout_forward(end, gap, fps, cfg.acceleration)?;
    let Some(&pf) = fwd.last() else {
        return Ok(None);
    };
    if !fwd.iter().all(inside) {
        return Ok(None);
    }
    let mut err = pf.dist(start.position);
    if cfg.bidirectional {
        let bwd = rollout_backward(start, gap, fps, cfg.acceleration)?;
        if !bwd.iter().all(inside) {
            return Ok(None);
        }
        if let Some(&pb) = bwd.last() {
            err = 0.5 * (err + pb.dist(end.position));
        }
    }
    Ok(Some(err))
}

/// Gaps up to this many frames are rolled out a frame at a time through the filter, longer
/// ones in closed form ([`long_gap_error`]). A rollout costs a filter step per frame of the gap
/// for every candidate pair, so a wide `max_gap_seconds` over a long, sparse input asked for
/// minutes of work (a 29 KB file of 100 short tracks 10,000 frames apart, `max_gap_seconds`
/// 10⁵: 4 min 24 s; the default's 0.17 s). With the default 5 s no gap reaches this at any
/// frame rate up to 819 fps, so the defaults' joins are the filter's own, bit for bit.
const ROLLOUT_FRAMES: u32 = 4096;

/// [`rollout_error`] of a gap over [`ROLLOUT_FRAMES`], in closed form: the filter's predictions
/// are the path `p + v·t + ½·a·t²` (`t = k/fps`, `k = 1…gap`), its end is that at the gap, and
/// the bounds are checked on the continuous path, whose extremes on each axis lie at its ends
/// or where it turns (`t = −v/a`).
fn long_gap_error(
    end: &EndState,
    start: &EndState,
    cfg: &RelinkConfig,
    fps: f64,
    bounds: Option<(u32, u32)>,
) -> Option<f64> {
    let gap = start.frame.saturating_sub(end.frame);
    let (t1, tn) = (1.0 / fps, f64::from(gap) / fps);
    // Where the path from `p` is at the gap's end, `None` if it leaves the frame on the way.
    let path_end = |p: Point, v: Point, a: Point| -> Option<Point> {
        let at = |x: f64, vx: f64, ax: f64, t: f64| x + vx * t + 0.5 * ax * t * t;
        if let Some((w, h)) = bounds {
            for (x, vx, ax, size) in [(p.x, v.x, a.x, f64::from(w)), (p.y, v.y, a.y, f64::from(h))]
            {
                let (a1, an) = (at(x, vx, ax, t1), at(x, vx, ax, tn));
                let (mut lo, mut hi) = (a1.min(an), a1.max(an));
                let turn = -vx / ax;
                if ax != 0.0 && turn > t1 && turn < tn {
                    let xt = at(x, vx, ax, turn);
                    (lo, hi) = (lo.min(xt), hi.max(xt));
                }
                if !(lo >= 0.0 && hi <= size) {
                    return None;
                }
            }
        }
        Some(Point::new(at(p.x, v.x, a.x, tn), at(p.y, v.y, a.y, tn)))
    };
    let k = cfg.acceleration;
    let pf = path_end(end.position, end.velocity, end.acceleration * k)?;
    let mut err = pf.dist(start.position);
    if cfg.bidirectional {
        let pb = path_end(
            start.position,
            start.velocity * -1.0,
            start.acceleration * k,
        )?;
        err = 0.5 * (err + pb.dist(end.position));
    }
    err.is_finite().then_some(err)
}

/// `err` over `radius`: the gate-normalised cost (0 for a perfect continuation under a zero
/// gate, `None` for any other under it).
fn normalised(err: f64, radius: f64) -> Option<f64> {
    if radius.is_nan() || radius <= 0.0 {
        return (err == 0.0).then_some(0.0);
    }
    Some(err / radius)
}

/// The gate-normalised cost of joining `slave` to `master` (module docs), `None` when a gate
/// refuses the pair. `gate_scale` multiplies the radius (see [`calibrated_gate`]).
fn pair_cost(
    slave: (&Piece, &EndState),
    master: (&Piece, &EndState),
    cfg: &RelinkConfig,
    fps: f64,
    bounds: Option<(u32, u32)>,
    gate_scale: f64,
) -> Result<Option<f64>, MotionError> {
    let (sp, se) = slave;
    let (mp, ms) = master;
    if sp.last >= mp.first || se.frame >= ms.frame {
        return Ok(None);
    }
    let gap = ms.frame - se.frame;
    let (s1, s2) = (se.size, ms.size);
    if !(s1 > 0.0 && s2 > 0.0) || s1.max(s2) > cfg.max_size_ratio * s1.min(s2) {
        return Ok(None);
    }
    let radius = gate_scale * gate_radius(se, ms, cfg, fps);
    // Exact pruning before the rollouts: a prediction moves the end by the closed-form
    // displacement `v·t + ½·a·t²`, so the error is at least the ends' distance minus that.
    let t = f64::from(gap) / fps;
    let shift =
        |v: Point, a: Point| (v * t + a * (0.5 * cfg.acceleration * t * t)).dist(Point::default());
    let d = se.position.dist(ms.position);
    let lb_fwd = (d - shift(se.velocity, se.acceleration)).max(0.0);
    let lb = if cfg.bidirectional {
        0.5 * (lb_fwd + (d - shift(ms.velocity * -1.0, ms.acceleration)).max(0.0))
    } else {
        lb_fwd
    };
    if lb > radius * (1.0 + 1e-9) {
        return Ok(None);
    }
    let Some(err) = rollout_error(se, ms, cfg, fps, bounds)? else {
        return Ok(None);
    };
    Ok(normalised(err, radius).filter(|c| c.is_finite() && *c <= 1.0))
}

/// Artificial gaps cut per piece and gap length, at most.
const CUTS_PER_PIECE: usize = 8;

/// The gate multiplier under which a fraction `q` of this sequence's own continuations pass:
/// every piece long enough is cut at a few places with an artificial gap (a fifth of a second
/// up to two seconds, within `max_gap`), both sides' ends are estimated as for a real pair,
/// and the quantile `q` of their rollout errors over the gate radius is the multiplier,
/// clamped to `[1, GATE_SCALE_MAX]` (1 when fewer than [`MIN_CUTS`] cuts were made). Objects
/// that turn and change pace (players) then get a wider gate than pedestrians, whose motion
/// the configured gate fits; the gate is never made narrower than configured (a narrower one
/// lost joins on MOT15 and BDD100K, whose tracks break where motion is hardest to predict).
/// A cut is a true continuation, so no size or view gate applies to it.
fn calibrated_gate(
    shapes: &[TrackedShape],
    pieces: &[Piece],
    cfg: &RelinkConfig,
    fps: f64,
    history: u32,
    max_gap: u32,
    q: f64,
) -> Result<f64, MotionError> {
    let r = cfg.reliable_size;
    let mut ratios = Vec::new();
    let gaps: Vec<u32> = [0.2, 0.5, 1.0, 2.0]
        .iter()
        .map(|s| ((s * fps).round() as u32).max(1))
        .filter(|&g| g <= max_gap)
        .collect();
    for p in pieces {
        for &g in &gaps {
            let need = 2 * history + g;
            if p.last - p.first < need {
                continue;
            }
            let span = p.last - p.first - need;
            let cuts = (span / history.max(1) + 1).min(CUTS_PER_PIECE as u32);
            for k in 0..cuts {
                let f0 = p.first + history + k * span / cuts.max(1);
                // `idx` runs by frame: the shapes up to the cut, and from the gap's end.
                let before = &p.idx[..p.idx.partition_point(|&i| shapes[i].frame <= f0)];
                let after = &p.idx[p.idx.partition_point(|&i| shapes[i].frame < f0 + g)..];
                let (Some(se), Some(ms)) = (
                    track_end(shapes, before, Side::End, history, r, fps),
                    track_end(shapes, after, Side::Start, history, r, fps),
                ) else {
                    continue;
                };
                if se.frame >= ms.frame || !(se.size > 0.0 && ms.size > 0.0) {
                    continue;
                }
                if let Some(err) = rollout_error(&se, &ms, cfg, fps, None)? {
                    let ratio = normalised(err, gate_radius(&se, &ms, cfg, fps));
                    ratios.extend(ratio.filter(|c| c.is_finite()));
                }
            }
        }
    }
    if ratios.len() < MIN_CUTS {
        return Ok(1.0);
    }
    ratios.sort_by(f64::total_cmp);
    let i = ((q * (ratios.len() - 1) as f64).round() as usize).min(ratios.len() - 1);
    Ok(ratios[i].clamp(1.0, GATE_SCALE_MAX))
}

/// Fewest artificial gaps the gate is calibrated from: with fewer, the configured gate holds.
const MIN_CUTS: usize = 20;
/// Largest calibrated gate multiplier: a sequence whose tracks were cut where motion is
/// erratic must not open the gate to every track in the frame.
const GATE_SCALE_MAX: f64 = 4.0;

/// Finds the joins among the online output's tracks (module docs). `features` is the SIFT
/// cache when frames were available.
pub(crate) fn find_joins(
    shapes: &[TrackedShape],
    pieces: &[Piece],
    features: Option<&mut FeatureCache<'_>>,
    cfg: &RelinkConfig,
    seq: &SequenceInfo,
    progress: &mut dyn FnMut(Progress),
) -> Result<Vec<Join>, OfflineError> {
    let fps = seq.fps;
    let bounds = if cfg.stay_in_view {
        seq.image_size
    } else {
        None
    };
    let history = history_frames(cfg, fps);
    let r = cfg.reliable_size;
    let ends: Vec<Option<EndState>> = pieces
        .iter()
        .map(|p| track_end(shapes, &p.idx, Side::End, history, r, fps))
        .collect();
    let starts: Vec<Option<EndState>> = pieces
        .iter()
        .map(|p| track_end(shapes, &p.idx, Side::Start, history, r, fps))
        .collect();
    let max_gap = (cfg.max_gap_seconds * fps).floor().max(0.0) as u32;
    let seq_first = pieces.iter().map(|p| p.first).min().unwrap_or(1);
    let gate = match cfg.calibrate {
        Some(q) => calibrated_gate(shapes, pieces, cfg, fps, history, max_gap, q)?,
        None => 1.0,
    };

    // Pieces by last frame, to find each master's window by binary search.
    let mut by_last: Vec<usize> = (0..pieces.len()).collect();
    by_last.sort_by_key(|&i| (pieces[i].last, pieces[i].id));

    // Phase 1: gated candidates per master, the most recently ended first.
    let mut per_master: Vec<Vec<Candidate>> = Vec::new();
    let n = pieces.len().max(1);
    for (m, mp) in pieces.iter().enumerate() {
        if m % 64 == 0 {
            progress(Progress {
                phase: Phase::Candidates,
                fraction: m as f64 / n as f64,
            });
        }
        if mp.first <= seq_first {
            continue;
        }
        let Some(ms) = starts[m].as_ref() else {
            continue;
        };
        let lo = mp.first.saturating_sub(max_gap);
        let from = by_last.partition_point(|&i| pieces[i].last < lo);
        let to = by_last.partition_point(|&i| pieces[i].last < mp.first);
        let mut mine: Vec<Candidate> = Vec::new();
        for &s in &by_last[from..to] {
            let sp = &pieces[s];
            let Some(se) = ends[s].as_ref() else {
                continue;
            };
            if s == m || sp.last >= mp.first {
                continue;
            }
            if let Some(cost) = pair_cost((sp, se), (mp, ms), cfg, fps, bounds, gate)? {
                mine.push(Candidate {
                    slave: s,
                    master: m,
                    cost,
                    connections: None,
                });
            }
        }
        // The most recently ended first (ties: cheaper first).
        mine.sort_by(|a, b| {
            pieces[b.slave]
                .last
                .cmp(&pieces[a.slave].last)
                .then(a.cost.total_cmp(&b.cost))
        });
        mine.truncate(cfg.max_slaves);
        if !mine.is_empty() {
            per_master.push(mine);
        }
    }

    // Phase 2: SIFT connections; keep the best-connected slaves of each master.
    if let Some(cache) = features {
        let nm = per_master.len().max(1);
        for (k, mine) in per_master.iter_mut().enumerate() {
            if k % 16 == 0 {
                progress(Progress {
                    phase: Phase::Appearance,
                    fraction: k as f64 / nm as f64,
                });
            }
            for c in mine.iter_mut() {
                c.connections = cache.connections(pieces[c.slave].id, pieces[c.master].id)?;
            }
            if mine.iter().any(|c| c.connections.is_some()) {
                mine.sort_by(|a, b| {
                    b.connections
                        .unwrap_or(0)
                        .cmp(&a.connections.unwrap_or(0))
                        .then(a.cost.total_cmp(&b.cost))
                });
                mine.truncate(cfg.appearance_keep);
            }
        }
        progress(Progress {
            phase: Phase::Appearance,
            fraction: 1.0,
        });
    }
    let cands: Vec<Candidate> = per_master.into_iter().flatten().collect();

    // Phase 3: choose the joins.
    progress(Progress {
        phase: Phase::Matching,
        fraction: 0.0,
    });
    let chosen: Vec<Candidate> = match cfg.solver {
        JoinSolver::Global => {
            let edges: Vec<(usize, usize, f64)> =
                cands.iter().map(|c| (c.slave, c.master, c.cost)).collect();
            let time: Vec<u32> = cands.iter().map(|c| pieces[c.master].first).collect();
            // In blocks of bounded size: a crowd's one giant component is cut in time.
            let pairs = super::blocks::solve_in_blocks(pieces.len(), &edges, &time)?;
            let by_pair: std::collections::BTreeMap<(usize, usize), Candidate> =
                cands.iter().map(|c| ((c.slave, c.master), *c)).collect();
            pairs
                .iter()
                .filter_map(|p| by_pair.get(p).copied())
                .collect()
        }
        JoinSolver::Greedy => {
            let mut order: Vec<usize> = (0..pieces.len()).collect();
            order.sort_by(|&a, &b| {
                pieces[b]
                    .first
                    .cmp(&pieces[a].first)
                    .then(pieces[b].id.cmp(&pieces[a].id))
            });
            let mut used = vec![false; pieces.len()];
            let mut out = Vec::new();
            for m in order {
                let best = cands
                    .iter()
                    .filter(|c| c.master == m && !used[c.slave])
                    .min_by(|a, b| a.cost.total_cmp(&b.cost));
                if let Some(c) = best {
                    used[c.slave] = true;
                    out.push(*c);
                }
            }
            out
        }
    };
    progress(Progress {
        phase: Phase::Matching,
        fraction: 1.0,
    });
    let mut joins: Vec<Join> = chosen
        .iter()
        .map(|c| Join {
            slave: pieces[c.slave].id,
            master: pieces[c.master].id,
            slave_last: pieces[c.slave].last,
            master_first: pieces[c.master].first,
            cost: c.cost,
            connections: c.connections,
        })
        .collect();
    joins.sort_by_key(|j| (j.master_first, j.master));
    Ok(joins)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9 * (1.0 + a.abs().max(b.abs()))
    }

    /// The frame-by-frame rollout error, as [`rollout_error`] computes it under the threshold.
    fn stepped_error(
        end: &EndState,
        start: &EndState,
        cfg: &RelinkConfig,
        fps: f64,
        bounds: Option<(u32, u32)>,
    ) -> Option<f64> {
        let inside = |p: &Point| match bounds {
            Some((w, h)) => p.x >= 0.0 && p.y >= 0.0 && p.x <= f64::from(w) && p.y <= f64::from(h),
            None => true,
        };
        let gap = start.frame - end.frame;
        let fwd = rollout_forward(end, gap, fps, cfg.acceleration).unwrap();
        let bwd = rollout_backward(start, gap, fps, cfg.acceleration).unwrap();
        if !fwd.iter().all(inside) || !bwd.iter().all(inside) {
            return None;
        }
        let (pf, pb) = (fwd.last()?, bwd.last()?);
        Some(0.5 * (pf.dist(start.position) + pb.dist(end.position)))
    }

    fn state(frame: u32, p: (f64, f64), v: (f64, f64), a: (f64, f64)) -> EndState {
        EndState {
            frame,
            position: Point::new(p.0, p.1),
            velocity: Point::new(v.0, v.1),
            acceleration: Point::new(a.0, a.1),
            size: 40.0,
        }
    }

    #[test]
    fn a_long_gap_in_closed_form_is_the_filters_rollout() {
        let cfg = RelinkConfig {
            bidirectional: true,
            ..RelinkConfig::default()
        };
        let fps = 25.0;
        let gap = ROLLOUT_FRAMES + 904;
        let bounds = Some((20_000, 20_000));
        let end = state(10, (5_000.0, 9_000.0), (12.0, -3.0), (0.02, 0.01));
        let start = state(10 + gap, (7_000.0, 8_400.0), (9.0, 1.0), (-0.01, 0.0));
        let stepped = stepped_error(&end, &start, &cfg, fps, bounds).unwrap();
        let closed = long_gap_error(&end, &start, &cfg, fps, bounds).unwrap();
        assert!(
            (stepped - closed).abs() < 1e-6 * stepped,
            "{stepped} vs {closed}"
        );
        assert_eq!(
            rollout_error(&end, &start, &cfg, fps, bounds).unwrap(),
            Some(closed)
        );
        // A path that leaves the frame on the way and comes back is refused both ways: x goes
        // 100 → −2,400 (turning at t = 100 s) → 100 over 200 s.
        let gap = 5_000;
        let end = state(1, (100.0, 500.0), (-50.0, 0.0), (0.5, 0.0));
        let start = state(1 + gap, (100.0, 500.0), (50.0, 0.0), (0.5, 0.0));
        let frame = Some((1_000, 1_000));
        assert_eq!(stepped_error(&end, &start, &cfg, fps, frame), None);
        assert_eq!(long_gap_error(&end, &start, &cfg, fps, frame), None);
        // Without bounds both reach the same end.
        let stepped = stepped_error(&end, &start, &cfg, fps, None).unwrap();
        let closed = long_gap_error(&end, &start, &cfg, fps, None).unwrap();
        assert!(
            (stepped - closed).abs() < 1e-6 * (1.0 + stepped),
            "{stepped} vs {closed}"
        );
    }

    #[test]
    fn fit_recovers_an_exact_parabola() {
        let fps = 10.0;
        let pts: Vec<(u32, Point)> = (1..=8u32)
            .map(|f| {
                let t = (f64::from(f) - 8.0) / fps;
                (
                    f,
                    Point::new(3.0 + 5.0 * t + 0.5 * 2.0 * t * t, -1.0 - 4.0 * t),
                )
            })
            .collect();
        let e = fit_motion(&pts, 8, fps);
        assert!(
            close(e.position.x, 3.0) && close(e.position.y, -1.0),
            "{e:?}"
        );
        assert!(
            close(e.velocity.x, 5.0) && close(e.velocity.y, -4.0),
            "{e:?}"
        );
        assert!(close(e.acceleration.x, 2.0) && e.acceleration.y.abs() < 1e-9);
        // The fit's acceleration equals the thesis' mean second difference on such data.
        let hist: Vec<Point> = pts.iter().map(|p| p.1).collect();
        let mean = crate::motion::mean_acceleration(&hist, fps);
        assert!(close(mean.x, e.acceleration.x));
    }

    #[test]
    fn fit_falls_back_to_a_line_and_to_a_point() {
        let fps = 5.0;
        let e = fit_motion(
            &[(4, Point::new(0.0, 0.0)), (6, Point::new(4.0, 2.0))],
            6,
            fps,
        );
        // 4 px over 2 frames = 0.4 s: 10 px/s, ending at the last point.
        assert!(close(e.velocity.x, 10.0) && close(e.velocity.y, 5.0));
        assert!(close(e.position.x, 4.0) && close(e.position.y, 2.0));
        assert_eq!(e.acceleration, Point::default());
        let e = fit_motion(&[(3, Point::new(7.0, 8.0))], 3, fps);
        assert_eq!(e.position, Point::new(7.0, 8.0));
        assert_eq!(e.velocity, Point::default());
    }
}
