// The timeline's window rules (lib/viewport.js): zoom around a point, pan within the sequence,
// follow the playhead, scroll rows to a selected track, grow with a sequence shown whole.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { Viewport, MIN_SPAN } from '../src/lib/viewport.js';

test('a fresh window shows every frame and grows with the sequence while it does', () => {
  const v = new Viewport();
  v.resize(100, 5, 10);
  assert.deepEqual(v.frameRange(), [1, 100]);
  assert.equal(v.fit, true);
  v.resize(250, 5, 10);
  assert.deepEqual(v.frameRange(), [1, 250], 'tracking on: the whole sequence stays in view');
});

test('zoom keeps the frame under the pointer in place and stops at a minimum span', () => {
  const v = new Viewport();
  v.resize(1000, 0, 1);
  const at = 700;
  const before = v.shareOf(at);
  v.zoom(4, at);
  assert.equal(v.span, 250);
  assert.ok(Math.abs(v.shareOf(at) - before) < 1e-9, 'the pointer frame did not move on screen');
  assert.equal(v.fit, false);
  v.resize(1200, 0, 1);
  assert.equal(v.span, 250, 'a zoomed window does not grow with the sequence');
  for (let i = 0; i < 20; i++) v.zoom(4, at);
  assert.equal(v.span, MIN_SPAN);
  assert.ok(v.start <= at && at < v.start + v.span, 'the pointer frame is still in view');
  for (let i = 0; i < 20; i++) v.zoom(0.25, at);
  assert.equal(v.fit, true, 'zooming out all the way shows every frame again');
  assert.deepEqual(v.frameRange(), [1, 1200]);
});

test('zoom near an end keeps the window inside the sequence', () => {
  const v = new Viewport();
  v.resize(100, 0, 1);
  v.zoom(5, 99);
  assert.ok(v.start + v.span - 1 <= 100 + 1e-9);
  assert.ok(v.start >= 1);
  v.zoom(5, 1);
  assert.equal(v.start, 1);
});

test('pan moves the window and clamps it at both ends', () => {
  const v = new Viewport();
  v.resize(500, 0, 1);
  v.zoom(5, 1);
  assert.deepEqual(v.frameRange(), [1, 100]);
  v.pan(50);
  assert.deepEqual(v.frameRange(), [51, 150]);
  v.pan(10_000);
  assert.deepEqual(v.frameRange(), [401, 500]);
  v.pan(-10_000);
  assert.deepEqual(v.frameRange(), [1, 100]);
});

test('the playhead pages a zoomed window when it leaves it, and only then', () => {
  const v = new Viewport();
  v.resize(1000, 0, 1);
  v.zoom(10, 1);
  assert.equal(v.follow(50), false, 'in view: no move');
  assert.equal(v.follow(150), true);
  assert.ok(v.start <= 150 && 150 < v.start + v.span);
  assert.ok(v.shareOf(150) < 0.2, 'the playhead lands near the left edge to read on from');
  const whole = new Viewport();
  whole.resize(1000, 0, 1);
  assert.equal(whole.follow(999), false, 'a window showing everything never moves');
});

test('rows scroll within the table and a selected row out of view is brought to the middle', () => {
  const v = new Viewport();
  v.resize(10, 1000, 12);
  v.scroll(-5);
  assert.equal(v.top, 0);
  v.scroll(5000);
  assert.equal(v.top, 1000 - 12);
  v.top = 0;
  assert.equal(v.reveal(5), false, 'already in view');
  assert.equal(v.reveal(500), true);
  assert.ok(v.top <= 500 && 500 < v.top + v.visible);
  assert.equal(v.top, 500 - 6, 'the row lands in the middle');
  assert.equal(v.reveal(3), true);
  assert.equal(v.top, 0, 'near the top: clamped');
  assert.equal(v.reveal(999), true);
  assert.equal(v.top, 1000 - 12, 'near the end: clamped');
  assert.equal(v.reveal(-1), false, 'a row not in the table scrolls nothing');
  v.resize(10, 20, 12);
  assert.ok(v.top <= 8, 'fewer rows: the scroll position is clamped');
});

test('frameAt maps positions across the bars to frames in the window', () => {
  const v = new Viewport();
  v.resize(200, 0, 1);
  assert.equal(v.frameAt(0), 1);
  assert.equal(v.frameAt(0.999), 200);
  assert.equal(v.frameAt(1.5), 200, 'clamped');
  v.zoom(2, 1);
  assert.equal(v.frameAt(0.5), 51);
});
