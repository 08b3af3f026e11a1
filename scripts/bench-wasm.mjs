#!/usr/bin/env node
// The wasm half of `shapetrack bench --wasm SCENE`: tracks one of the synthetic scenes the app
// offers (the same SynthConfig as the native side renders) with the browser build of the core
// (www/pkg: opt-level 3, SIMD, wasm-opt) in Node, masks with frames and the mask preset, and prints
// one JSON line with the tracker's milliseconds per frame. Rendering is not timed; the call into
// wasm and the shapes coming back to JS are.
//
//   node scripts/bench-wasm.mjs --scene default

import { readFileSync } from 'node:fs';
import * as st from '../www/pkg/shapetrack.js';

const i = process.argv.indexOf('--scene');
const name = /** @type {st.ScenePreset} */ (i >= 0 ? process.argv[i + 1] : 'default');
st.initSync({ module: readFileSync(new URL('../www/pkg/shapetrack_bg.wasm', import.meta.url)) });
const scene = new st.SynthScene(name);
const buf = new st.FrameBuffer(scene.width, scene.height);
const tracker = new st.Tracker({ preset: 'masks' });
let ms = 0;
let detections = 0;
for (let n = 1; n <= scene.frames; n++) {
  const frame = scene.render(n, buf);
  const dets = frame.detections();
  detections += dets.len;
  const t0 = performance.now();
  tracker.update(n, buf, dets);
  ms += performance.now() - t0;
  dets.free();
  frame.free();
}
console.log(JSON.stringify({ scene: name, width: scene.width, height: scene.height, frames: scene.frames, detections_per_frame: detections / scene.frames, ms_per_frame: ms / scene.frames }));
