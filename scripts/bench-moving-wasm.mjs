#!/usr/bin/env node
// Benchmark: the moving-camera detector's `detect` (the app's automatic detector on a moving
// camera) in the browser build of the core (opt-level 3, SIMD, wasm-opt), in Node, on real
// frames. Frames are raw RGBA files (width·height·4 bytes per frame, concatenated), so that no
// image decoder is timed: e.g. DAVIS-2016 `bus` and `camel` at 854×480, written by any
// decoder. With several builds (`--pkg` repeated) each has its own detector and they take
// turns frame by frame, the order alternating, so all meet the same busy and quiet moments of
// a shared machine (separate runs of one build here differ by up to ×2). Prints, per file and
// build, the median and fastest ms per call after one warm-up pass (V8 tiers wasm up while
// it runs), and against the first build the median of the per-frame time ratios. A
// benchmark, not a test.
//
//   node scripts/bench-moving-wasm.mjs FILE.rgba... [--size 854x480] [--passes N] [--pkg DIR]...
//   (default build: www/pkg; `node scripts/build-wasm.mjs --profiling` writes one with
//   function names for `node --cpu-prof`, target/pkg-profiling)

import { readFileSync } from 'node:fs';
import { basename, resolve } from 'node:path';
import { fileURLToPath, pathToFileURL } from 'node:url';

const argv = process.argv.slice(2);
/** @param {string} flag @returns {string[]} */
const all = (flag) => argv.flatMap((a, i) => (a === flag && i + 1 < argv.length ? [argv[i + 1]] : []));
const valued = new Set(['--size', '--passes', '--pkg']);
const files = argv.filter((a, i) => !a.startsWith('--') && !valued.has(argv[i - 1] ?? ''));
const [W, H] = (all('--size')[0] ?? '854x480').split('x').map(Number);
const PASSES = Number(all('--passes')[0] ?? '3');
const pkgs = all('--pkg').map((d) => resolve(d));
if (!pkgs.length) pkgs.push(fileURLToPath(new URL('../www/pkg', import.meta.url)));
if (!files.length || !(PASSES >= 1) || !(W > 0 && H > 0)) {
  console.error('usage: bench-moving-wasm.mjs FILE.rgba... [--size WxH] [--passes N] [--pkg DIR]...');
  process.exit(2);
}

const builds = [];
for (const dir of pkgs) {
  // A query per directory: each build is its own module instance with its own memory.
  /** @type {typeof import('../www/pkg/shapetrack.js')} */
  const st = await import(`${pathToFileURL(resolve(dir, 'shapetrack.js')).href}?${encodeURIComponent(dir)}`);
  const { memory } = st.initSync({ module: readFileSync(resolve(dir, 'shapetrack_bg.wasm')) });
  builds.push({ dir, st, memory, buf: new st.FrameBuffer(W, H) });
}
const size = W * H * 4;
/** @param {number[]} xs @param {number} q */
const quantile = (xs, q) => {
  const s = [...xs].sort((a, b) => a - b);
  return s[Math.floor(q * (s.length - 1))];
};
for (const file of files) {
  const raw = readFileSync(file);
  const n = Math.floor(raw.length / size);
  /** @type {number[][]} ms per build, per timed frame */
  const times = builds.map(() => []);
  for (let p = 0; p <= PASSES; p++) {
    const dets = builds.map((b) => new b.st.MovingDetector());
    for (let f = 0; f < n; f++) {
      const order = builds.map((_, i) => i);
      if ((f + p) % 2) order.reverse();
      for (const i of order) {
        const b = builds[i];
        new Uint8Array(b.memory.buffer, b.buf.ptr(), size).set(raw.subarray(f * size, (f + 1) * size));
        const t = performance.now();
        const d = dets[i].detect(b.buf);
        const ms = performance.now() - t;
        d.free();
        // The first frame only starts the flow; the first pass warms V8's tiers up.
        if (p > 0 && f > 0) times[i].push(ms);
      }
    }
    for (const d of dets) d.free();
  }
  builds.forEach((b, i) => {
    const ratio = i ? `, per-frame ratio to the first build: median ×${quantile(times[i].map((t, k) => t / times[0][k]), 0.5).toFixed(3)}` : '';
    console.log(`${basename(file)} [${basename(b.dir)}]: ${times[i].length} calls, detect median ${quantile(times[i], 0.5).toFixed(1)} ms, fastest ${quantile(times[i], 0).toFixed(1)} ms${ratio}`);
  });
}
