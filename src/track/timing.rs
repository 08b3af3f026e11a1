//! Where a tracker's time goes: one wrapper times every phase of [`Tracker::update`], with a
//! clock the caller supplies (the core never reads the time itself: `std::time::Instant`
//! panics on wasm32-unknown-unknown).
//!
//! Phases nest: appearance described while assigning (re-identification) or updating (refresh,
//! new tracks) counts as [`PhaseTimes::features`], not as the phase that asked for it, and
//! re-identification scoring inside the assignment counts as [`PhaseTimes::costs`]. Each phase
//! is charged its own time minus the time of the phases nested in it, so the phases partition
//! the time of `update`.
//!
//! [`Tracker::update`]: super::Tracker::update

use std::cell::RefCell;

/// A monotonic clock in seconds, supplied by the caller.
pub(crate) type Clock = Box<dyn Fn() -> f64 + Send>;

/// Where a tracker's time went, accumulated over the frames since timing started (see
/// [`Tracker::with_clock`](super::Tracker::with_clock)), in seconds. The phases partition
/// [`Tracker::update`](super::Tracker::update)'s time.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct PhaseTimes {
    /// Frames timed.
    pub frames: u64,
    /// Per-detection features: validation, centroids and shells, and every appearance
    /// description (SIFT, contour descriptor, colour sample), wherever it was asked for.
    pub features: f64,
    /// Motion prediction and region estimation (shells, broad phase, GJK, clusters).
    pub regions: f64,
    /// Pair costs: the ambiguity test, the main association's and re-identification's terms.
    pub costs: f64,
    /// The assignment stages (optimal assignment per stage).
    pub assignment: f64,
    /// Track updates: fragments, filters, lifecycle, coasting, spawning.
    pub update: f64,
}

impl PhaseTimes {
    /// Total time over the frames.
    pub fn total(&self) -> f64 {
        self.features + self.regions + self.costs + self.assignment + self.update
    }

    fn slot(&mut self, phase: Phase) -> &mut f64 {
        match phase {
            Phase::Features => &mut self.features,
            Phase::Regions => &mut self.regions,
            Phase::Costs => &mut self.costs,
            Phase::Assignment => &mut self.assignment,
            Phase::Update => &mut self.update,
        }
    }
}

/// The phases time is charged to (the fields of [`PhaseTimes`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Phase {
    Features,
    Regions,
    Costs,
    Assignment,
    Update,
}

/// A phase being timed: its phase, start time, and the time of the phases nested in it.
struct Open {
    phase: Phase,
    start: f64,
    nested: f64,
}

/// Times nested phases with the caller's clock; does nothing without one. Interior mutability
/// lets phases that only read the tracker (describing appearance) be timed too.
#[derive(Default)]
pub(crate) struct Timer {
    clock: Option<Clock>,
    times: RefCell<PhaseTimes>,
    open: RefCell<Vec<Open>>,
}

impl Timer {
    /// A timer reading `clock`.
    pub(crate) fn with_clock(clock: Clock) -> Self {
        Self {
            clock: Some(clock),
            ..Self::default()
        }
    }

    /// Starts timing `phase` (nested in the phase currently timed, if any).
    pub(crate) fn enter(&self, phase: Phase) {
        if let Some(c) = &self.clock {
            self.open.borrow_mut().push(Open {
                phase,
                start: c(),
                nested: 0.0,
            });
        }
    }

    /// Stops timing the innermost phase: it is charged its time minus its nested phases'.
    pub(crate) fn exit(&self) {
        let Some(c) = &self.clock else {
            return;
        };
        let now = c();
        let mut open = self.open.borrow_mut();
        let Some(o) = open.pop() else {
            return;
        };
        let total = now - o.start;
        *self.times.borrow_mut().slot(o.phase) += (total - o.nested).max(0.0);
        if let Some(parent) = open.last_mut() {
            parent.nested += total;
        }
    }

    /// Runs `f` as phase `phase`.
    pub(crate) fn time<T>(&self, phase: Phase, f: impl FnOnce() -> T) -> T {
        self.enter(phase);
        let r = f();
        self.exit();
        r
    }

    /// Counts one more frame timed.
    pub(crate) fn frame_done(&self) {
        if self.clock.is_some() {
            self.times.borrow_mut().frames += 1;
        }
    }

    /// The times so far.
    pub(crate) fn times(&self) -> PhaseTimes {
        *self.times.borrow()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicU64, Ordering};
    use std::sync::Arc;

    #[test]
    fn nested_phases_are_charged_their_own_time() {
        // A clock that advances by one second per reading.
        let ticks = Arc::new(AtomicU64::new(0));
        let t = ticks.clone();
        let timer = Timer::with_clock(Box::new(move || t.fetch_add(1, Ordering::SeqCst) as f64));
        timer.time(Phase::Assignment, || {
            // reads: assignment start 0, features 1..2, costs 3..4, assignment end 5
            timer.time(Phase::Features, || ());
            timer.time(Phase::Costs, || ());
        });
        timer.frame_done();
        let p = timer.times();
        assert_eq!((p.features, p.costs, p.assignment), (1.0, 1.0, 3.0));
        assert_eq!(p.total(), 5.0);
        assert_eq!(p.frames, 1);
        // Without a clock nothing is recorded.
        let off = Timer::default();
        off.time(Phase::Update, || ());
        off.frame_done();
        assert_eq!(off.times(), PhaseTimes::default());
    }
}
