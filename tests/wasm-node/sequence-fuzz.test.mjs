// The wasm API under random sequences of calls (issue 65, class 8: "the worker's message
// sequence"), in Node, from the built package (www/pkg): trackers, frame buffers, detections
// and the three detectors are made, used, finished and freed in a seeded random order, with
// sizes, frame numbers and settings that are often wrong. Every failure must be a thrown
// `Error`, never a trap (`WebAssembly.RuntimeError`: in the browser it kills the page's
// tracker and poisons the module), and the module must keep working: each live object still
// answers or cleanly refuses, and a fresh tracker tracks afterwards.
//
// `SEQ_FUZZ_STEPS` sets the calls per sequence (default 1,000), `SEQ_FUZZ_SEEDS` how many
// sequences (default 10), `SEQ_FUZZ_SEED` the first seed.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import * as st from '../../www/pkg/shapetrack.js';

const wasm = st.initSync({
  module: readFileSync(new URL('../../www/pkg/shapetrack_bg.wasm', import.meta.url)),
});

const STEPS = Number(process.env.SEQ_FUZZ_STEPS ?? 1000);
const SEEDS = Number(process.env.SEQ_FUZZ_SEEDS ?? 10);
const FIRST = Number(process.env.SEQ_FUZZ_SEED ?? 65);

/** mulberry32: a small seeded PRNG, floats in [0, 1). */
function prng(seed) {
  let a = seed >>> 0;
  return () => {
    a = (a + 0x6d2b79f5) >>> 0;
    let t = a;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}

const SIDES = [1, 2, 7, 16, 24, 33, 48, 0, -1, 2.5, NaN, 16385, 2 ** 32 + 8, '8', undefined];
const FRAMES = [0, -1, 1.5, NaN, 2 ** 32 + 1, 2 ** 53, Infinity, '2', undefined];
const NUMBERS = [0, 1, 2, 3, -1, 0.5, 1e300, -1e300, NaN, Infinity, 2 ** 32, 255, 256, 20];

function run(seed) {
  const rnd = prng(seed);
  const pick = (xs) => xs[Math.floor(rnd() * xs.length)];
  const chance = (p) => rnd() < p;
  const num = () => (chance(0.7) ? Math.floor(rnd() * 6) : pick(NUMBERS));

  // Live objects by kind; a freed one is kept sometimes (calls on it must be errors too).
  const pool = { tracker: [], buf: [], dets: [], bg: [], moving: [], refiner: [] };
  const any = (kind) => pool[kind][Math.floor(rnd() * pool[kind].length)];
  const keep = (kind, o) => {
    pool[kind].push(o);
    if (pool[kind].length > 6) {
      const old = pool[kind].shift();
      try {
        old.free();
      } catch (e) {
        check(e, `free ${kind}`);
      }
    }
  };
  const log = [];
  const stats = {};

  function check(e, what) {
    assert.ok(!(e instanceof WebAssembly.RuntimeError), `seed ${seed}: trap in ${what}: ${e}\n${log.slice(-12).join('\n')}`);
    assert.ok(e instanceof Error, `seed ${seed}: ${what} threw a non-Error ${typeof e}: ${String(e)}`);
  }

  const settings = {
    tracker: () =>
      pick([
        undefined,
        {},
        { min_hits: num() },
        { max_lost: num(), max_cost: pick(NUMBERS) },
        { terms: { iou: { weight: pick(NUMBERS) } } },
        { nonsense: 1 },
        [1, 2],
        { motion: { std_measurement: pick(NUMBERS) } },
      ]),
    offline: () => pick([undefined, null, {}, { fps: 30 }, { fps: 25 }, { fps: pick(NUMBERS) }, { fps: 30, bogus: true }, 7]),
    bg: () =>
      pick([undefined, {}, { init_frames: num() }, { alpha: pick(NUMBERS), threshold: pick(NUMBERS) }, { min_area: num(), open_radius: num() }, { shadow: {} }, { x: 1 }]),
    moving: () =>
      pick([undefined, {}, { work_side: pick([8, 16, 32, 0, 1e9, NaN]) }, { cue: pick(['background', 'flow', 'x']), min_age: num() }, { refine: null }, { flow: { patch_size: num() } }]),
    refiner: () =>
      pick([undefined, {}, { max_side: pick([8, 16, 7, 513, NaN]) }, { clusters: num(), iterations: num() }, { seed: -1 }]),
  };

  const lists = () => {
    const masks = [];
    const boxes = [];
    for (let k = Math.floor(rnd() * 4); k > 0; k--) {
      const w = chance(0.8) ? 1 + Math.floor(rnd() * 8) : pick(SIDES);
      const h = chance(0.8) ? 1 + Math.floor(rnd() * 8) : pick(SIDES);
      const n = chance(0.8) && Number.isInteger(w * h) && w * h > 0 ? w * h : Math.floor(rnd() * 10);
      masks.push({ x: num(), y: num(), width: w, height: h, data: new Uint8Array(n).fill(1), score: chance(0.8) ? 1 : pick(NUMBERS), class: -1 });
    }
    for (let k = Math.floor(rnd() * 4); k > 0; k--) {
      boxes.push({ bbox: { x: num() * 4, y: num() * 4, w: chance(0.8) ? 1 + num() * 3 : pick(NUMBERS), h: 1 + num() * 3 }, score: chance(0.9) ? 0.9 : pick(NUMBERS) });
    }
    return chance(0.95) ? { masks, boxes } : pick([{ masks: 3 }, null, [], { boxes: [{}] }]);
  };

  const fill = (buf) => {
    const bytes = new Uint8Array(wasm.memory.buffer, buf.ptr(), buf.len());
    const t = Math.floor(rnd() * 8);
    for (let i = 0; i < bytes.length; i += 4) {
      const x = (i / 4) % buf.width;
      const y = Math.floor(i / 4 / buf.width);
      const inside = x >= 2 + t && x < 8 + t && y >= 2 && y < 8;
      bytes[i] = inside ? 230 : 40 + ((x * 3 + y * 2) % 60);
      bytes[i + 1] = bytes[i];
      bytes[i + 2] = 255 - bytes[i];
      bytes[i + 3] = 255;
    }
  };

  const nextFrame = (t) => (chance(0.85) ? t.frame + 1 : chance(0.5) ? t.frame + Math.floor(rnd() * 3) : pick(FRAMES));

  const ops = [
    ['new Tracker', () => keep('tracker', new st.Tracker(settings.tracker(), chance(0.6) ? settings.offline() : undefined))],
    ['new FrameBuffer', () => {
      const w = chance(0.85) ? 8 + Math.floor(rnd() * 40) : pick(SIDES);
      const h = chance(0.85) ? 8 + Math.floor(rnd() * 30) : pick(SIDES);
      const b = new st.FrameBuffer(w, h);
      fill(b);
      keep('buf', b);
    }],
    ['fill', () => pool.buf.length && fill(any('buf'))],
    ['Detections.fromLists', () => keep('dets', st.Detections.fromLists(lists()))],
    ['new BackgroundDetector', () => keep('bg', new st.BackgroundDetector(settings.bg()))],
    ['new MovingDetector', () => keep('moving', new st.MovingDetector(settings.moving()))],
    ['new BoxRefiner', () => keep('refiner', new st.BoxRefiner(settings.refiner()))],
    ['detect', () => {
      const kind = pick(['bg', 'moving']);
      if (pool[kind].length && pool.buf.length) keep('dets', any(kind).detect(any('buf')));
    }],
    ['reset', () => {
      const kind = pick(['bg', 'moving']);
      if (pool[kind].length) any(kind).reset();
    }],
    ['refine', () => {
      if (pool.refiner.length && pool.buf.length && pool.dets.length) any('refiner').refine(any('buf'), any('dets'), pick([undefined, 0, 1, 2, 2 ** 32, -1]));
    }],
    ['update', () => {
      if (pool.tracker.length && pool.buf.length && pool.dets.length) {
        const t = any('tracker');
        t.update(nextFrame(t), any('buf'), any('dets'));
      }
    }],
    ['updateDetections', () => {
      if (pool.tracker.length && pool.dets.length) {
        const t = any('tracker');
        t.updateDetections(nextFrame(t), any('dets'));
      }
    }],
    ['finish', () => {
      if (!pool.tracker.length) return;
      const t = any('tracker');
      const mode = Math.floor(rnd() * 4);
      t.finish(
        mode === 0
          ? undefined
          : () => {
              if (mode === 1) throw new Error('stop');
              if (mode === 2) t.free();
            },
      );
    }],
    ['tracks', () => pool.tracker.length && any('tracker').tracks()],
    ['getters', () => {
      if (pool.tracker.length) {
        const t = any('tracker');
        void [t.frame, t.finished, t.keptShapes, t.maxKeptShapes, t.offline];
      }
      if (pool.moving.length) {
        const m = any('moving');
        void [m.learning, m.resets, m.warmupSeen, m.warmupFrames, m.cameraShift];
      }
      if (pool.dets.length) {
        const d = any('dets');
        void [d.len, d.isEmpty, d.toList()];
      }
    }],
    ['addUncovered', () => pool.dets.length > 1 && any('dets').addUncovered(any('dets'), pick([0, 0.5, 1, NaN, -1]))],
    ['free', () => {
      const kind = pick(Object.keys(pool));
      if (!pool[kind].length) return;
      const i = Math.floor(rnd() * pool[kind].length);
      const o = pool[kind][i];
      o.free();
      // Kept a while sometimes: every later call on it must be an Error.
      if (chance(0.7)) pool[kind].splice(i, 1);
    }],
  ];

  for (let step = 0; step < STEPS; step++) {
    const [name, op] = pick(ops);
    log.push(`${step}: ${name}`);
    try {
      op();
      stats[name] = (stats[name] ?? 0) + 1;
    } catch (e) {
      check(e, name);
      stats[`${name} (error)`] = (stats[`${name} (error)`] ?? 0) + 1;
    }
  }
  if (process.env.SEQ_FUZZ_STATS) console.log(seed, stats);

  // Every object still answers or cleanly refuses, then everything is freed.
  for (const [kind, objs] of Object.entries(pool)) {
    for (const o of objs) {
      try {
        if (kind === 'tracker') void [o.frame, o.tracks()];
        if (kind === 'dets') void o.len;
        if (kind === 'buf') void o.len();
      } catch (e) {
        check(e, `${kind} after the sequence`);
      }
      try {
        o.free();
      } catch (e) {
        check(e, `free ${kind}`);
      }
    }
  }

  // A fresh tracker still tracks a frame with a detector's output.
  const t = new st.Tracker({ min_hits: 1 }, { fps: 30 });
  const buf = new st.FrameBuffer(32, 24);
  fill(buf);
  const dets = st.Detections.fromLists({ masks: [], boxes: [{ bbox: { x: 2, y: 2, w: 8, h: 8 }, score: 1 }] });
  const shapes = t.update(1, buf, dets);
  assert.equal(shapes.length, 1, `seed ${seed}: a fresh tracker after the sequence`);
  t.finish();
  for (const o of [t, buf, dets]) o.free();
}

for (let k = 0; k < SEEDS; k++) {
  test(`random call sequence ${FIRST + k}: errors, never traps`, () => run(FIRST + k));
}
