// The detector's learned keyframes (www/src/worker/learned.js) without wasm: a stand-in for the
// core's Detections list. A keyframe's learned mask is carried to a later frame shifted by its
// detection's displacement and takes that detection's place; a proposed region no detection
// matches is added for a while; one that disagrees with the detection's own mask is not
// taken; masks expire some frames after they arrive; a frame with
// nothing to carry goes through untouched; shifted masks are clipped to the frame.

import { after, test } from 'node:test';
import assert from 'node:assert/strict';
import { AGREE_IOU, IDLE_THREADS, KEYFRAME_DUTY, KEYFRAME_EVERY, KEYFRAME_MIN_GAP, KeyframeSchedule, LearnedKeyframes, REGION_FRAMES, REPLACE_AGE, maskIou, shiftMask, wantedThreads } from '../src/worker/learned.js';

/**
 * @typedef {{ bbox: { x: number, y: number, w: number, h: number }, mask?: any, score: number, class: number }} Det
 */

/** A stand-in for the core: Detections lists held in JS. */
function fakeCore() {
  class Detections {
    /** @param {Det[]} list */
    constructor(list) {
      this.list = list;
      this.freed = false;
    }
    get len() {
      return this.list.length;
    }
    toList() {
      return this.list;
    }
    free() {
      this.freed = true;
    }
    /** @param {Detections} other @param {number} covered */
    addUncovered(other, covered) {
      let n = 0;
      for (const d of other.list) {
        const hit = this.list.some((e) => {
          const ix = Math.max(0, Math.min(e.bbox.x + e.bbox.w, d.bbox.x + d.bbox.w) - Math.max(e.bbox.x, d.bbox.x));
          const iy = Math.max(0, Math.min(e.bbox.y + e.bbox.h, d.bbox.y + d.bbox.h) - Math.max(e.bbox.y, d.bbox.y));
          return (ix * iy) / (d.bbox.w * d.bbox.h) >= covered;
        });
        if (!hit) {
          this.list.push(d);
          n++;
        }
      }
      return n;
    }
    /** @param {{ masks?: any[], boxes?: any[] }} lists */
    static fromLists({ masks = [], boxes = [] }) {
      return new Detections([
        ...masks.map((m) => ({ bbox: { x: m.x, y: m.y, w: m.width, h: m.height }, mask: m, score: m.score ?? 1, class: m.class ?? -1 })),
        ...boxes.map((b) => ({ bbox: b.bbox, score: b.score ?? 1, class: b.class ?? -1 })),
      ]);
    }
  }
  return /** @type {any} */ ({ Detections });
}

/** @param {number} x @param {number} y @param {number} w @param {number} h */
const full = (x, y, w, h) => ({ x, y, width: w, height: h, data: new Uint8Array(w * h).fill(1) });
/** @param {number} x @param {number} y @param {number} w @param {number} h */
const det = (x, y, w, h) => ({ bbox: { x, y, w, h }, mask: full(x, y, w, h), score: 0.9, class: -1 });

test('a learned mask is carried shifted by its detection\'s displacement and takes its place', () => {
  const core = fakeCore();
  const lk = new LearnedKeyframes(core, 200, 100);
  after(() => lk.dispose());
  // Keyframe 10: a detection at (20, 20, 40, 30); the net's outline of it is smaller.
  const learned = { bbox: { x: 25, y: 22, w: 30, h: 26 }, mask: full(25, 22, 30, 26), score: 0.8, class: -1 };
  lk.result = { frame: 10, arrived: -1, inputs: [{ x: 20, y: 20, w: 40, h: 30 }], learned: [learned] };
  // Frame 12: the object has moved 10 px right, 5 down.
  const now = core.Detections.fromLists({ masks: [{ ...full(30, 25, 40, 30), score: 0.7, class: 3 }] });
  const { dets, use } = lk.apply(10 + REPLACE_AGE, now);
  assert.deepEqual(use, { used: 1, added: 0, from: 10 });
  assert.ok(now.freed, 'the detector\'s list is consumed');
  const [d] = dets.toList();
  assert.deepEqual([d.mask.x, d.mask.y, d.mask.width, d.mask.height], [35, 27, 30, 26]);
  assert.equal(d.class, 3, 'the detection keeps its class and score');
  assert.equal(d.score, 0.7);
});

test('a proposed region no detection matches is added for a while after it arrives; a detection\'s learned mask only while fresh', () => {
  const core = fakeCore();
  const lk = new LearnedKeyframes(core, 200, 100);
  after(() => lk.dispose());
  const region = { bbox: { x: 150, y: 10, w: 20, h: 20 }, mask: full(150, 10, 20, 20), score: 0.6, class: -1 };
  lk.result = { frame: 5, arrived: -1, inputs: [], learned: [region] };
  const a = lk.apply(40, core.Detections.fromLists({ masks: [full(10, 10, 20, 20)] }));
  assert.deepEqual(a.use, { used: 0, added: 1, from: 5 });
  assert.equal(a.dets.len, 2);
  // Past REGION_FRAMES after arrival: not added any more.
  const late = core.Detections.fromLists({ masks: [full(10, 10, 20, 20)] });
  const b = lk.apply(40 + REGION_FRAMES + 1, late);
  assert.equal(b.use, null);
  assert.equal(b.dets, late, 'untouched');
  // A detection's learned mask replaces its mask only up to REPLACE_AGE frames after its
  // keyframe's own frame, however late it arrived.
  lk.result = { frame: 100, arrived: -1, inputs: [{ x: 10, y: 10, w: 20, h: 20 }], learned: [det(12, 12, 16, 16)] };
  assert.equal(lk.apply(100 + REPLACE_AGE, core.Detections.fromLists({ masks: [full(10, 10, 20, 20)] })).use?.used, 1);
  const old = core.Detections.fromLists({ masks: [full(10, 10, 20, 20)] });
  assert.equal(lk.apply(101 + REPLACE_AGE, old).dets, old, 'stale: the detector\'s own mask stays');
  lk.result = { frame: 200, arrived: -1, inputs: [{ x: 10, y: 10, w: 20, h: 20 }], learned: [det(12, 12, 16, 16)] };
  const tardy = core.Detections.fromLists({ masks: [full(10, 10, 20, 20)] });
  assert.equal(lk.apply(200 + REPLACE_AGE + 1, tardy).dets, tardy, 'first applied after its age: not taken');
});

test('a carried mask that disagrees with the detection\'s own (IoU < AGREE_IOU) is not taken', () => {
  const core = fakeCore();
  const lk = new LearnedKeyframes(core, 200, 100);
  after(() => lk.dispose());
  // The learned outline covers under half of the detection's mask: stale, or another object.
  lk.result = { frame: 1, arrived: -1, inputs: [{ x: 0, y: 0, w: 40, h: 40 }], learned: [det(0, 0, 28, 28)] };
  const now = core.Detections.fromLists({ masks: [full(0, 0, 40, 40)] });
  const r = lk.apply(5, now);
  assert.equal(r.use, null);
  assert.equal(r.dets, now);
  assert.ok(maskIou(full(0, 0, 28, 28), full(0, 0, 40, 40)) < AGREE_IOU);
  assert.equal(maskIou(full(0, 0, 20, 20), full(10, 0, 20, 20)), 1 / 3);
});

test('no keyframe result: the detections go through untouched', () => {
  const core = fakeCore();
  const lk = new LearnedKeyframes(core, 200, 100);
  after(() => lk.dispose());
  const d = core.Detections.fromLists({ masks: [full(0, 0, 4, 4)] });
  const r = lk.apply(1, d);
  assert.equal(r.dets, d);
  assert.equal(r.use, null);
  assert.equal(d.freed, false);
});

test('a shifted mask is clipped to the frame, or gone when it leaves it', () => {
  const m = { x: 0, y: 0, width: 3, height: 2, data: Uint8Array.from([1, 2, 3, 4, 5, 6]) };
  const s = shiftMask(m, -1, 0, 10, 10);
  assert.deepEqual(s && [s.x, s.y, s.width, s.height, [...s.data]], [0, 0, 2, 2, [2, 3, 5, 6]]);
  const t = shiftMask(m, 8, 9, 10, 10);
  assert.deepEqual(t && [t.x, t.y, t.width, t.height, [...t.data]], [8, 9, 2, 1, [1, 2]]);
  assert.equal(shiftMask(m, 20, 0, 10, 10), null);
  const u = shiftMask(m, 2, 3, 10, 10);
  assert.equal(u?.data, m.data, 'inside the frame: the same bytes, moved');
});

test('the net has every core while only drawn boxes use it, one thread while keyframes run beside the tracker', () => {
  assert.equal(IDLE_THREADS, 2);
  assert.equal(wantedThreads(), IDLE_THREADS, 'no keyframes: a drawn box is all the worker does');
  const core = /** @type {any} */ (fakeCore());
  const a = new LearnedKeyframes(core, 64, 48);
  const b = new LearnedKeyframes(core, 64, 48);
  assert.equal(wantedThreads(), 1);
  a.dispose();
  a.dispose(); // twice: counted once
  assert.equal(wantedThreads(), 1, 'one stage still runs');
  b.dispose();
  assert.equal(wantedThreads(), IDLE_THREADS);
});

test('keyframes every KEYFRAME_EVERY frames, sooner when the detections change, never while the net is owed rest', () => {
  const s = new KeyframeSchedule();
  assert.ok(s.due(1, 2, 0), 'the first frame is a keyframe');
  s.started(1, 2);
  s.finished(0, 0);
  assert.ok(!s.due(1 + KEYFRAME_EVERY - 1, 2, 0), 'same detections: not before KEYFRAME_EVERY frames');
  assert.ok(s.due(1 + KEYFRAME_EVERY, 2, 0));
  assert.ok(!s.due(1 + KEYFRAME_MIN_GAP - 1, 3, 0), 'a new detection: not before KEYFRAME_MIN_GAP frames');
  assert.ok(s.due(1 + KEYFRAME_MIN_GAP, 3, 0));
  // A keyframe whose inferences took 2 s, ending at t = 10 s: the net rests until its busy
  // share is KEYFRAME_DUTY, whatever the frame count says.
  s.started(100, 3);
  s.finished(2000, 10_000);
  const rest = 2000 * (1 / KEYFRAME_DUTY - 1);
  assert.ok(rest > 0);
  assert.ok(!s.due(100 + KEYFRAME_EVERY, 3, 10_000 + rest - 1), 'owed rest: no keyframe');
  assert.ok(!s.due(100 + KEYFRAME_EVERY, 5, 10_000 + rest - 1), 'not even for a new detection');
  assert.ok(s.due(100 + KEYFRAME_EVERY, 3, 10_000 + rest));
  // The busy share over a keyframe and its rest is KEYFRAME_DUTY.
  assert.ok(Math.abs(2000 / (2000 + rest) - KEYFRAME_DUTY) < 1e-12);
});
