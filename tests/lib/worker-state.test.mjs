// Issue 65, class 4: the library's worker (lib/tracker-worker.js) keeps a consistent state. A
// rejected `start` leaves the previous tracker working (or none, cleanly, freeing what it had
// built), every `start` frees everything the previous one made (tracker, detector, frame
// buffer), and a frame buffer that could not be built leaves the previous one in use. On the
// page side (lib/worker.js), a rejected `TrackerWorker.start` stops the worker it started.
//
// The worker's module runs here in Node as it runs in a Web Worker: beside lib/index.js and the
// built package (www/pkg, `node scripts/build-wasm.mjs`), with a `self` that receives requests
// and collects replies. The wasm classes' `free` is counted to see what each step releases.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { copyFileSync, mkdtempSync, rmSync, symlinkSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { fileURLToPath, pathToFileURL } from 'node:url';

const ROOT = fileURLToPath(new URL('../..', import.meta.url));
const stage = mkdtempSync(join(tmpdir(), 'shapetrack-worker-'));
process.on('exit', () => rmSync(stage, { recursive: true, force: true }));
for (const f of ['index.js', 'tracker-worker.js']) copyFileSync(join(ROOT, 'lib', f), join(stage, f));
symlinkSync(join(ROOT, 'www', 'pkg'), join(stage, 'pkg'), 'dir');

/** @type {((e: { data: any }) => void)[]} */
const listeners = [];
/** @type {Map<number, (reply: any) => void>} */
const waiting = new Map();
Object.assign(globalThis, {
  self: {
    addEventListener: (/** @type {string} */ type, /** @type {(e: { data: any }) => void} */ f) => {
      if (type === 'message') listeners.push(f);
    },
    postMessage: (/** @type {any} */ reply) => waiting.get(reply.id)?.(reply),
  },
});
const st = await import(pathToFileURL(join(stage, 'index.js')).href);
await import(pathToFileURL(join(stage, 'tracker-worker.js')).href);

let next = 1;
/** A request as `TrackerWorker` sends it; resolves with the worker's reply. @param {Record<string, unknown>} msg */
function request(msg) {
  const id = next++;
  return new Promise((resolve) => {
    waiting.set(id, resolve);
    for (const f of listeners) f({ data: { ...msg, id } });
  });
}

/** `free()` calls per wasm class since the last `reset`. */
const freed = { Tracker: 0, BackgroundDetector: 0, FrameBuffer: 0 };
for (const name of /** @type {(keyof typeof freed)[]} */ (Object.keys(freed))) {
  const proto = st[name].prototype;
  const free = proto.free;
  proto.free = function () {
    freed[name] += 1;
    return free.call(this);
  };
}
const reset = () => Object.keys(freed).forEach((k) => (freed[/** @type {keyof typeof freed} */ (k)] = 0));

/** A 64×48 grey frame. */
const frame = (w = 64, h = 48) => ({ width: w, height: h, data: new Uint8ClampedArray(w * h * 4).fill(128) });
/** One box detection at `x`. */
const box = (/** @type {number} */ x) => ({ boxes: [{ bbox: { x, y: 10, w: 12, h: 20 }, score: 0.9 }] });

/** Tracks `n` frames with one box each; returns the replies' frames. @param {number} n @param {number} from */
async function trackBoxes(n, from) {
  const frames = [];
  for (let k = 0; k < n; k++) {
    const r = await request({ type: 'track', image: frame(), detections: box(2 + from + k) });
    assert.ok(r.ok, r.error);
    frames.push(...r.value.map((/** @type {{ frame: number }} */ s) => s.frame));
  }
  return frames;
}

test('a rejected start leaves the previous tracker working', async () => {
  assert.ok((await request({ type: 'start', options: { detector: 'none', tracker: { min_hits: 1 } } })).ok);
  await trackBoxes(3, 0);
  reset();
  // The tracker's settings are refused: before, the previous tracker was freed first, and every
  // later request failed with "null pointer passed to rust".
  const bad = await request({ type: 'start', options: { detector: 'none', tracker: { min_hits: 'three' } } });
  assert.equal(bad.ok, false);
  assert.deepEqual(freed, { Tracker: 0, BackgroundDetector: 0, FrameBuffer: 0 }, 'nothing of the running tracker is freed');
  // The detector's settings are refused after the new tracker was built: that one is freed.
  const badDetector = await request({ type: 'start', options: { background: { no_such_field: 1 } } });
  assert.equal(badDetector.ok, false);
  assert.deepEqual(freed, { Tracker: 1, BackgroundDetector: 0, FrameBuffer: 0 }, 'the half-built tracker is freed');
  // The previous tracker goes on where it was.
  assert.deepEqual(await trackBoxes(2, 3), [4, 5]);
  const all = await request({ type: 'tracks' });
  assert.ok(all.ok, all.error);
  assert.deepEqual(
    all.value.map((/** @type {{ frame: number }} */ r) => r.frame),
    [1, 2, 3, 4, 5],
  );
});

test('every start frees everything the previous one made', async () => {
  assert.ok((await request({ type: 'start', options: {} })).ok);
  const r = await request({ type: 'track', image: frame() });
  assert.ok(r.ok, r.error);
  reset();
  assert.ok((await request({ type: 'start', options: { detector: 'none' } })).ok);
  assert.deepEqual(freed, { Tracker: 1, BackgroundDetector: 1, FrameBuffer: 1 }, 'tracker, detector and frame buffer');
  reset();
  assert.ok((await request({ type: 'start', options: { detector: 'none' } })).ok);
  assert.deepEqual(freed, { Tracker: 1, BackgroundDetector: 0, FrameBuffer: 0 });
});

test('a rejected first start leaves no tracker, and frees what it built', async () => {
  // A second instance of the worker's module is a fresh worker (same wasm instance).
  listeners.length = 0;
  await import(`${pathToFileURL(join(stage, 'tracker-worker.js')).href}?fresh`);
  reset();
  const bad = await request({ type: 'start', options: { detector: 'background', background: { init_frames: 'x' } } });
  assert.equal(bad.ok, false);
  assert.deepEqual(freed, { Tracker: 1, BackgroundDetector: 0, FrameBuffer: 0 }, 'the tracker it built is freed');
  const none = await request({ type: 'track', image: frame(), detections: box(5) });
  assert.equal(none.ok, false);
  assert.match(none.error, /not started/);
  assert.ok((await request({ type: 'start', options: { detector: 'none' } })).ok);
  const t = await request({ type: 'track', image: frame(), detections: box(5) });
  assert.ok(t.ok, t.error);
});

test('a frame buffer that cannot be built leaves the previous one in use', async () => {
  assert.ok((await request({ type: 'start', options: { detector: 'none', tracker: { min_hits: 1 } } })).ok);
  await trackBoxes(1, 0);
  // A frame of a size no FrameBuffer takes: before, the old buffer was freed first and kept,
  // and the next frame failed on it with "null pointer passed to rust".
  const huge = await request({ type: 'track', image: { width: 70000, height: 70000, data: new Uint8Array(4) }, detections: box(3) });
  assert.equal(huge.ok, false);
  assert.match(huge.error, /frame size/);
  assert.deepEqual(await trackBoxes(1, 1), [2]);
});

test('TrackerWorker.start stops its worker when the start is rejected', async () => {
  // The page side (lib/worker.js) with a stand-in Worker that refuses the start as the worker
  // does for bad settings. Before, the rejected start left the worker thread and its wasm
  // instance running, unreachable.
  copyFileSync(join(ROOT, 'lib', 'worker.js'), join(stage, 'worker.js'));
  /** @type {{ terminated: boolean }[]} */
  const made = [];
  class FakeWorker extends EventTarget {
    constructor() {
      super();
      this.terminated = false;
      made.push(this);
    }
    /** @param {any} msg */
    postMessage(msg) {
      const reply = msg.options?.tracker?.min_hits === 'three' ? { id: msg.id, ok: false, error: 'min_hits: not a number' } : { id: msg.id, ok: true, value: null };
      queueMicrotask(() => this.dispatchEvent(Object.assign(new Event('message'), { data: reply })));
    }
    terminate() {
      this.terminated = true;
    }
  }
  const saved = globalThis.Worker;
  Object.assign(globalThis, { Worker: FakeWorker });
  try {
    const { TrackerWorker } = await import(pathToFileURL(join(stage, 'worker.js')).href);
    await assert.rejects(TrackerWorker.start({ tracker: { min_hits: 'three' } }), /min_hits/);
    assert.equal(made.length, 1);
    assert.ok(made[0].terminated, 'the rejected worker is stopped');
    const ok = await TrackerWorker.start({ tracker: { min_hits: 2 } });
    assert.equal(made[1].terminated, false, 'a started worker runs');
    ok.terminate();
    assert.ok(made[1].terminated);
  } finally {
    Object.assign(globalThis, { Worker: saved });
  }
});
