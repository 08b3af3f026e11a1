// Browser benchmark: the embedded demo (synthetic 1280×720 scene, background subtractor, mask
// preset) in headless Chromium, at full speed; prints the tracking rate and the worker's
// per-frame times, and writes them to target/e2e/fps.txt. A benchmark, not a test: the figure
// depends on how busy the machine is, so nothing here fails on a slow run unless asked to
// with `--min FPS` (for a quiet machine, e.g. a release check).
//
//   npm run build && node scripts/bench-browser.mjs [--frames N] [--min FPS]

import { mkdirSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { DIST, OUT, launch, serve, untilState } from '../tests/e2e/harness.mjs';

const arg = (/** @type {string} */ name, /** @type {number} */ fallback) => {
  const i = process.argv.indexOf(name);
  return i >= 0 ? Number(process.argv[i + 1]) : fallback;
};
const FRAMES = arg('--frames', 300);
const MIN = arg('--min', 0);
// Unusual, and not the e2e suite's ports: the two may run side by side.
const PORT = 47411;

const server = await serve(DIST, PORT);
const browser = await launch();
try {
  const page = await browser.context.newPage();
  const until = (/** @type {(s: any) => boolean} */ pred) => untilState(page, pred, 300_000);
  await page.goto(`${server.url}?speed=max`);
  // The first frames warm the wasm and the background model up: not measured.
  const s0 = await until((s) => s.processed >= 30);
  const t0 = Date.now();
  const s1 = await until((s) => s.processed >= 30 + FRAMES || (!s.playing && s.processed === s.frames));
  const fps = ((s1.processed - s0.processed) * 1000) / (Date.now() - t0);
  const [w, h] = s1.size;
  const line =
    `demo tracking rate at ${w}x${h}: ${fps.toFixed(1)} fps over frames ${s0.processed}-${s1.processed} ` +
    `(worker ms/frame: detect ${s1.timings.detect.toFixed(1)}, track ${s1.timings.track.toFixed(1)}, total ${s1.timings.total.toFixed(1)})`;
  console.log(line);
  mkdirSync(OUT, { recursive: true });
  writeFileSync(join(OUT, 'fps.txt'), `${line}\n`);
  if (MIN > 0 && fps < MIN) {
    console.error(`${fps.toFixed(1)} fps < ${MIN}`);
    process.exitCode = 1;
  }
} finally {
  await browser.close();
  await server.close();
}
