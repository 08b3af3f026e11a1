#!/usr/bin/env node
// Two (or more) builds of the wasm core against each other, in one Node process: each tracks
// the same synthetic app scene (masks with frames, the mask preset) in passes that alternate
// between the builds, first one order then the other, so both meet the same busy and quiet
// spells of a shared machine. Separate runs of each build differ by more than most changes
// do (this machine's run-to-run spread is a third; two passes of one build in one process
// differ by ~2 %). A benchmark, not a test: it prints each build's median and fastest
// milliseconds per frame of `Tracker.update` (the call into wasm and the shapes coming back).
//
//   node scripts/build-wasm.mjs && cp -r www/pkg /tmp/pkg-new
//   git stash && node scripts/build-wasm.mjs && cp -r www/pkg /tmp/pkg-old && git stash pop
//   node scripts/bench-wasm-ab.mjs --scene demo --rounds 16 /tmp/pkg-old /tmp/pkg-new

import { readFileSync } from 'node:fs';
import { resolve } from 'node:path';
import { pathToFileURL } from 'node:url';
import { trackPass } from './wasm-pass.mjs';

/** @param {string} flag @param {string} fallback */
const arg = (flag, fallback) => {
  const i = process.argv.indexOf(flag);
  return i >= 0 && i + 1 < process.argv.length ? process.argv[i + 1] : fallback;
};
const scene = /** @type {import('../www/pkg/shapetrack.js').ScenePreset} */ (arg('--scene', 'demo'));
const rounds = Number(arg('--rounds', '16'));
const flagged = new Set(['--scene', '--rounds']);
const dirs = process.argv
  .slice(2)
  .filter((a, i, all) => !a.startsWith('--') && !flagged.has(all[i - 1] ?? ''))
  .map((d) => resolve(d));
if (dirs.length < 2 || !(Number.isInteger(rounds) && rounds >= 1)) {
  console.error('usage: bench-wasm-ab.mjs [--scene demo|default|occlusion] [--rounds N] PKG_A PKG_B [...]');
  process.exit(2);
}

const builds = [];
for (const dir of dirs) {
  // A query per directory: each build is its own module instance with its own memory.
  /** @type {typeof import('../www/pkg/shapetrack.js')} */
  const st = await import(`${pathToFileURL(resolve(dir, 'shapetrack.js')).href}?${encodeURIComponent(dir)}`);
  st.initSync({ module: readFileSync(resolve(dir, 'shapetrack_bg.wasm')) });
  const sc = new st.SynthScene(scene);
  builds.push({ dir, st, sc, buf: new st.FrameBuffer(sc.width, sc.height), times: /** @type {number[]} */ ([]) });
}

/** One pass over the scene with a new tracker: milliseconds per frame inside `update`. */
function pass(/** @type {typeof builds[number]} */ b) {
  const { ms, tracker } = trackPass(b.st, b.sc, b.buf);
  tracker.free();
  return ms / b.sc.frames;
}

// Two warm-up passes each: V8 compiles hot functions during the first (scripts/bench-wasm.mjs).
for (const b of builds) for (let k = 0; k < 2; k++) pass(b);
for (let r = 0; r < rounds; r++) {
  const order = r % 2 ? [...builds].reverse() : builds;
  for (const b of order) b.times.push(pass(b));
}
const median = (/** @type {number[]} */ xs) => [...xs].sort((a, b) => a - b)[xs.length >> 1];
for (const b of builds) {
  console.log(`${b.dir}: median ${median(b.times).toFixed(4)} ms/frame, fastest ${Math.min(...b.times).toFixed(4)} (${scene}, ${rounds} passes)`);
}
