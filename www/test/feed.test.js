// The tracker worker's scene feed (www/src/worker/feed.js) against a stand-in for the feeder
// worker: frames in order are asked for ahead, each frame is rendered once, a seek renders
// only what it needs and recycles what was asked for ahead, buffers go back to the feeder,
// and any failure of the feeder fails the frames waited for (the worker then renders them).

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { AHEAD, SceneFeed } from '../src/worker/feed.js';

const SIZE = 4 * 3 * 2;

/**
 * A feeder stand-in: answers `open` and `render` after a microtask, as a worker would (in
 * order), and records what it was asked.
 * @param {{ frames?: number, failOn?: number, width?: number }} [opts]
 */
function fakeFeeder({ frames = 10, failOn = -1, width = 3 } = {}) {
  /** @type {Array<(e: any) => void>} */
  const listeners = [];
  const port = {
    /** @type {number[]} frames rendered, in order */
    rendered: [],
    /** @type {number} buffers sent back with a render request */
    reused: 0,
    terminated: false,
    /** @param {any} msg */
    postMessage(msg) {
      queueMicrotask(() => {
        if (port.terminated) return;
        let reply;
        if (msg.type === 'open') reply = { type: 'opened', width, height: 2, frames };
        else if (msg.frame === failOn) reply = { type: 'error', frame: msg.frame, message: 'boom' };
        else {
          port.rendered.push(msg.frame);
          if (msg.buffer) port.reused++;
          const pixels = msg.buffer ?? new ArrayBuffer(SIZE);
          new Uint8Array(pixels).fill(msg.frame);
          reply = { type: 'frame', frame: msg.frame, pixels, groundTruth: [{ frame: msg.frame }] };
        }
        for (const l of listeners) l({ data: reply });
      });
    },
    /** @param {string} type @param {(e: any) => void} l */
    addEventListener(type, l) {
      if (type === 'message') listeners.push(l);
    },
    terminate() {
      port.terminated = true;
    },
  };
  return port;
}

const EXPECT = { width: 3, height: 2, frames: 10 };
const settle = () => new Promise((r) => setTimeout(r, 0));

test('frames in order are rendered once each, ahead of the one taken', async () => {
  const port = fakeFeeder();
  const feed = new SceneFeed(port, { preset: 'demo' }, EXPECT);
  for (let n = 1; n <= 10; n++) {
    const f = await feed.take(n);
    assert.equal(f.frame, n);
    assert.equal(new Uint8Array(f.pixels)[0], n);
    assert.deepEqual(f.groundTruth, [{ frame: n }]);
    feed.recycle(f.pixels);
    await settle();
    // Asked for ahead: the next AHEAD frames (within the scene) are already rendered.
    assert.deepEqual(port.rendered, Array.from({ length: Math.min(n + AHEAD, 10) }, (_, i) => i + 1));
  }
  // No frame twice, none past the end; buffers went back to the feeder.
  assert.deepEqual(port.rendered, [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]);
  assert.ok(port.reused >= 5, `buffers reused: ${port.reused}`);
});

test('a seek renders the frame asked for, not the ones ahead, and recycles those', async () => {
  const port = fakeFeeder();
  const feed = new SceneFeed(port, { preset: 'demo' }, EXPECT);
  feed.recycle((await feed.take(1)).pixels);
  await settle();
  // Frames 2 and 3 were asked for ahead; a jump to 7 no longer wants them.
  const f = await feed.take(7);
  assert.equal(f.frame, 7);
  assert.equal(new Uint8Array(f.pixels)[0], 7);
  await settle();
  // Out of order: nothing asked for ahead of 7 yet; back in order from 8 on.
  assert.deepEqual(port.rendered, [1, 2, 3, 7]);
  assert.equal((await feed.take(8)).frame, 8);
  await settle();
  assert.deepEqual(port.rendered, [1, 2, 3, 7, 8, 9, 10]);
  // Backwards (a backward leg): each frame on its own.
  assert.equal((await feed.take(4)).frame, 4);
  assert.equal((await feed.take(3)).frame, 3);
});

test('a failure in the feeder fails the frame waited for and every later one', async () => {
  const port = fakeFeeder({ failOn: 3 });
  const feed = new SceneFeed(port, { preset: 'demo' }, EXPECT);
  assert.equal((await feed.take(1)).frame, 1);
  // Frame 3 was asked for ahead of 1 and failed: frame 2 (waited for next) fails with it.
  await assert.rejects(feed.take(2), /scene feeder failed on frame 3: boom/);
  await assert.rejects(feed.take(5), /boom/);
  assert.ok(port.terminated);
});

test('a feeder whose scene differs from the worker\'s own is not used', async () => {
  const port = fakeFeeder({ width: 4 });
  const feed = new SceneFeed(port, { preset: 'demo' }, EXPECT);
  await assert.rejects(feed.take(1), /4×2, 10 frames; expected 3×2, 10/);
  assert.ok(port.terminated);
});
