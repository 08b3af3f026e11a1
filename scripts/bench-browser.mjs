// Browser benchmark: the embedded demo (synthetic 1280×720 scene, background subtractor, mask
// preset) in headless Chromium, at full speed; prints the tracking rate and the worker's
// per-frame times, and writes them to target/e2e/fps.txt. Then a labelling session of 1,000
// imported tracks: the page's redraw time (timeline, track list, overlay) while scrolling,
// zooming and stepping through frames, to target/e2e/timeline.txt. A benchmark, not a test: the figure
// depends on how busy the machine is, so nothing here fails on a slow run unless asked to
// with `--min FPS` (for a quiet machine, e.g. a release check).
//
//   npm run build && node scripts/bench-browser.mjs [--frames N] [--min FPS]

import { mkdirSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { DIST, OUT, crowdTracks, launch, serve, untilState } from '../tests/e2e/harness.mjs';

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

  // A thousand tracks over 2,000 frames: every redraw is timed (the page draws once per
  // animation frame; 16.7 ms is the budget at 60 Hz).
  const crowd = await browser.context.newPage();
  await crowd.goto(`${server.url}?demo=0`);
  await crowd.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
  const { text } = crowdTracks(1000, 2000);
  await crowd.setInputFiles('#file-import', { name: 'crowd.txt', mimeType: 'text/plain', buffer: Buffer.from(text) });
  await untilState(crowd, (s) => s.ids.length === 1000, 300_000);
  const ms = await crowd.evaluate(async () => {
    const app = /** @type {any} */ (window).__shapetrack.app;
    const tl = app.timeline;
    const list = /** @type {HTMLElement} */ (document.getElementById('track-list'));
    /** @type {number[]} */
    const times = [];
    const frame = () => new Promise((r) => requestAnimationFrame(() => r(undefined)));
    for (let i = 0; i < 300; i++) {
      // Scroll rows and the list, zoom in and out, step a frame, select a track far away.
      if (i % 3 === 0) tl.view.scroll(7);
      if (i % 3 === 1) tl.zoomBy(i % 6 === 1 ? 1.5 : 1 / 1.5);
      if (i % 3 === 2) await app.seek((app.cur % 1900) + 7);
      if (i % 10 === 0) app.select(1 + ((i * 97) % 1000), false);
      list.scrollTop = (i * 200) % Math.max(1, list.scrollHeight);
      tl.key = '';
      const t0 = performance.now();
      app.renderNow();
      times.push(performance.now() - t0);
      await frame();
    }
    times.sort((a, b) => a - b);
    return { median: times[times.length >> 1], p95: times[Math.floor(times.length * 0.95)], max: times[times.length - 1] };
  });
  const tline =
    `1,000 tracks over 2,000 frames: page redraw (timeline bars redrawn, track list, overlay) ` +
    `median ${ms.median.toFixed(2)} ms, p95 ${ms.p95.toFixed(2)} ms, max ${ms.max.toFixed(2)} ms over 300 scroll/zoom/seek steps`;
  console.log(tline);
  writeFileSync(join(OUT, 'timeline.txt'), `${tline}\n`);
} finally {
  await browser.close();
  await server.close();
}
