// Live scoring's throttle and inputs (model/scoring.js), on a fake clock.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { Scorer, scoreInputs } from '../src/model/scoring.js';
import { TrackTable } from '../src/model/tracks.js';

function fakeClock() {
  let t = 0;
  /** @type {Array<{ at: number, fn: () => void }>} */
  const timers = [];
  return {
    now: () => t,
    later: (/** @type {() => void} */ fn, /** @type {number} */ ms) => timers.push({ at: t + ms, fn }),
    /** @param {number} ms */
    advance(ms) {
      t += ms;
      for (const timer of timers.splice(0).sort((a, b) => a.at - b.at)) {
        if (timer.at <= t) timer.fn();
        else timers.push(timer);
      }
    },
    pending: () => timers.length,
  };
}

test('requests inside the interval collapse into one, run at its end', () => {
  const clock = fakeClock();
  let runs = 0;
  const s = new Scorer(() => runs++, { interval: 500, now: clock.now, later: clock.later });
  s.request();
  assert.equal(runs, 1, 'the first request scores at once');
  clock.advance(100);
  s.request();
  s.request();
  s.request();
  assert.equal(runs, 1, 'inside the interval: deferred');
  assert.equal(clock.pending(), 1, 'one deferred run, not three');
  clock.advance(399);
  assert.equal(runs, 1);
  clock.advance(1);
  assert.equal(runs, 2, 'the deferred run lands at the interval end');
  clock.advance(1000);
  s.request();
  assert.equal(runs, 3, 'after a quiet interval: at once again');
  s.request(true);
  assert.equal(runs, 4, 'immediate requests are never deferred');
});

test('scoring covers the frames tracked so far only', () => {
  const r = (/** @type {number} */ frame, /** @type {number} */ id) => ({ frame, id, bbox: { x: 0, y: 0, w: 1, h: 1 } });
  const gt = new TrackTable([r(1, 1), r(2, 1), r(3, 1)]);
  const res = new TrackTable([r(1, 5), r(2, 5)]);
  const inp = scoreInputs(gt, res, 2);
  assert.ok(inp);
  assert.deepEqual(inp.gt.map((x) => x.frame), [1, 2]);
  assert.deepEqual(inp.res.map((x) => x.frame), [1, 2]);
  assert.equal(scoreInputs(gt, res, 0), null, 'nothing tracked: nothing to score');
  assert.equal(scoreInputs(new TrackTable(), res, 3), null, 'no ground truth: nothing to score');
});
