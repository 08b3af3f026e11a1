import { test } from 'node:test';
import assert from 'node:assert/strict';
import { sequenceName, snapFps } from '../src/sources/sources.js';

test('measured frame rates snap to the common ones when close', () => {
  assert.equal(snapFps(29.96), 29.97);
  assert.equal(snapFps(25.2), 25);
  assert.equal(snapFps(23.98), 23.976);
  assert.equal(snapFps(59.5), 59.94);
  // Far from every common rate: kept, rounded to 1/1000.
  assert.equal(snapFps(27.7777), 27.778);
  assert.equal(snapFps(12.5), 12.5);
});

test('image sequences are named after their folder or shared prefix, not their first file', () => {
  assert.equal(sequenceName(['00000.jpg', '00001.jpg'], 'car-shadow'), 'car-shadow');
  assert.equal(sequenceName(['00000.jpg', '00001.jpg', '00002.jpg']), 'images');
  assert.equal(sequenceName(['frame_0001.png', 'frame_0002.png', 'frame_0100.png']), 'frame');
  assert.equal(sequenceName(['street 1.jpg', 'street 2.jpg']), 'street');
  assert.equal(sequenceName(['only.png']), 'only');
});
