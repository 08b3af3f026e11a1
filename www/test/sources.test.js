import { test } from 'node:test';
import assert from 'node:assert/strict';
import { snapFps } from '../src/sources/sources.js';

test('measured frame rates snap to the common ones when close', () => {
  assert.equal(snapFps(29.96), 29.97);
  assert.equal(snapFps(25.2), 25);
  assert.equal(snapFps(23.98), 23.976);
  assert.equal(snapFps(59.5), 59.94);
  // Far from every common rate: kept, rounded to 1/1000.
  assert.equal(snapFps(27.7777), 27.778);
  assert.equal(snapFps(12.5), 12.5);
});
