// The session state machine (model/session.js): which transitions are allowed, and the
// questions the app asks of it (track this frame? how far may a seek go? run the offline pass?).

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { Session, SessionError } from '../src/model/session.js';

test('idle → tracking → finishing → finished, with the questions answered on the way', () => {
  const s = new Session();
  assert.equal(s.phase, 'idle');
  assert.equal(s.needsTracking(1), false, 'nothing open: nothing to track');
  s.open({ frames: 3, offlineCapable: true });
  assert.equal(s.phase, 'tracking');
  assert.equal(s.offlinePending, true);
  assert.equal(s.needsTracking(1), true);
  assert.throws(() => s.beginFinishing(), SessionError, 'the offline pass needs every frame');
  s.trackedFrame(1);
  s.trackedFrame(2);
  assert.equal(s.lastShown(3), 2, 'a seek stops at the last tracked frame');
  assert.equal(s.needsTracking(2), false);
  assert.equal(s.needsTracking(3), true);
  assert.equal(s.needsTracking(4), false, 'past the end there is nothing to track');
  s.trackedFrame(3);
  assert.equal(s.allTracked, true);
  s.beginFinishing();
  assert.equal(s.phase, 'finishing');
  assert.equal(s.offlinePending, false);
  assert.equal(s.needsTracking(4), false);
  assert.throws(() => s.trackedFrame(4), SessionError, 'no tracking while finishing');
  const report = { onlineIds: 5, onlineInterpolated: 0, ids: 3, joins: 2, filled: 4, ms: 1 };
  s.finish(report);
  assert.equal(s.phase, 'finished');
  assert.deepEqual(s.report, report);
  assert.equal(s.lastShown(3), 3);
  assert.throws(() => s.finish(report), SessionError, 'a session finishes once');
  assert.throws(() => s.beginFinishing(), SessionError);
});

test('frames are tracked in order and never past the end', () => {
  const s = new Session();
  s.open({ frames: 2, offlineCapable: true });
  assert.throws(() => s.trackedFrame(2), /frame 2 tracked after 0/);
  s.trackedFrame(1);
  assert.throws(() => s.trackedFrame(1), SessionError, 'no frame twice');
  s.trackedFrame(2);
  assert.throws(() => s.trackedFrame(3), /past the end/);
});

test('a live source (no end) tracks on and never starts the offline pass', () => {
  const s = new Session();
  s.open({ frames: 0, offlineCapable: false });
  for (let n = 1; n <= 100; n++) s.trackedFrame(n);
  assert.equal(s.needsTracking(101), true);
  assert.equal(s.allTracked, false);
  assert.throws(() => s.beginFinishing(), /no end/);
});

test('an aborted offline pass goes back to tracking and can run again', () => {
  const s = new Session();
  s.open({ frames: 1, offlineCapable: true });
  s.trackedFrame(1);
  s.beginFinishing();
  s.abortFinishing();
  assert.equal(s.phase, 'tracking');
  assert.equal(s.offlinePending, true);
  s.beginFinishing();
  s.abortFinishing();
  assert.throws(() => s.abortFinishing(), SessionError, 'nothing to abort');
});

test('imported tracks are final: nothing to track, seeks reach the import\'s end, reopening starts over', () => {
  const s = new Session();
  s.imported(40);
  assert.equal(s.phase, 'finished');
  assert.equal(s.tracked, false);
  assert.equal(s.frames, 40);
  assert.equal(s.needsTracking(1), false);
  assert.equal(s.lastShown(40), 40);
  assert.equal(s.offlinePending, false);
  // Importing over a tracking session stops it.
  s.open({ frames: 10, offlineCapable: true });
  s.trackedFrame(1);
  s.imported(5);
  assert.equal(s.phase, 'finished');
  assert.equal(s.frames, 10, 'the open source keeps its length');
  assert.equal(s.needsTracking(2), false);
  s.open({ frames: 7, offlineCapable: false });
  assert.equal(s.processed, 0);
  assert.equal(s.report, null);
  assert.equal(s.tracked, true);
});
