#!/usr/bin/env node
// Benchmark: how long a drawn box takes to become a mask in the page (issue 63's "≤ 1.5 s on
// the 2-core machine"), through the app's own path (`App.boxMask`: the tracker worker cuts the
// crop, the segmenter worker runs U²-Net-p, the core turns its map into the mask), on the first
// frame of DAVIS-2016 car-shadow (854×480) in headless Chromium, from www/dist (build first:
// `npm run build`). A benchmark, not a test: nothing fails on a slow run.
//
// Reported, in the page (box given → bitmap back) and in the worker:
// - the first box of a visit that never used the net (its files fetched from the server);
// - the first box after a reload (the net loaded again, from the service worker's cache: what
//   a returning labeller waits for once per visit);
// - the same, the box tool picked `--warm-ms` (default 6000) before the box is given: the app
//   loads the net and runs it once on zeros meanwhile;
// - later boxes (the net loaded: one inference), median of `--runs`;
// - one inference at 320×320 and at 256×256 alternating (a given box's crop runs at 256);
// - the weights-free refinement of the same box, for comparison.
//
//   npm run build && node scripts/bench-learned-box.mjs [--runs N] [--warm-ms MS] [--port P]

import { readdirSync, readFileSync } from 'node:fs';
import { join } from 'node:path';
import { DIST, ROOT, launch, serve, watchErrors } from '../tests/e2e/harness.mjs';

const text = (/** @type {string} */ name) => {
  const i = process.argv.indexOf(name);
  return i >= 0 ? process.argv[i + 1] : undefined;
};
const RUNS = Number(text('--runs') ?? 7);
const PORT = Number(text('--port') ?? 47434);
/** How long the labeller takes to draw the box after picking the tool (ms). */
const WARM_MS = Number(text('--warm-ms') ?? 6000);
const JPEG = join(ROOT, '..', 'shared', 'data', 'davis-car-shadow', 'DAVIS', 'JPEGImages', '480p', 'car-shadow');
const GT = join(ROOT, '..', 'shared', 'data', 'davis-car-shadow', 'DAVIS', 'Annotations', '480p', 'car-shadow', '00000.png');

/** @param {number[]} xs */
const median = (xs) => {
  const s = [...xs].sort((a, b) => a - b);
  return s.length % 2 ? s[(s.length - 1) / 2] : (s[s.length / 2 - 1] + s[s.length / 2]) / 2;
};
const f0 = (/** @type {number} */ x) => x.toFixed(0);

/**
 * A box a little larger than the car on frame 1: its ground truth's box grown by 8 % a side
 * (decoded by the browser).
 * @param {import('playwright-core').Page} page
 * @returns {Promise<{ x: number, y: number, w: number, h: number }>}
 */
function carBox(page) {
  return page.evaluate(async (b64) => {
    const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
    const bmp = await createImageBitmap(new Blob([bytes], { type: 'image/png' }));
    const ctx = /** @type {OffscreenCanvasRenderingContext2D} */ (new OffscreenCanvas(bmp.width, bmp.height).getContext('2d'));
    ctx.drawImage(bmp, 0, 0);
    const { data, width, height } = ctx.getImageData(0, 0, bmp.width, bmp.height);
    let [x0, y0, x1, y1] = [Infinity, Infinity, -1, -1];
    for (let i = 0; i < width * height; i++) {
      if (data[4 * i] <= 127) continue;
      const x = i % width;
      const y = (i - x) / width;
      [x0, x1, y0, y1] = [Math.min(x0, x), Math.max(x1, x), Math.min(y0, y), Math.max(y1, y)];
    }
    const [w, h] = [x1 - x0 + 1, y1 - y0 + 1];
    const x = Math.max(0, x0 - 0.08 * w);
    const y = Math.max(0, y0 - 0.08 * h);
    return { x, y, w: Math.min(width, x0 + 1.08 * w) - x, h: Math.min(height, y0 + 1.08 * h) - y };
  }, readFileSync(GT).toString('base64'));
}

/** @type {{ x: number, y: number, w: number, h: number }} */
let BOX;

/**
 * @param {import('playwright-core').Page} page
 * @param {boolean} learned
 */
function boxOnce(page, learned) {
  return page.evaluate(
    async ({ box, learned }) => {
      const w = /** @type {any} */ (window);
      /** @type {HTMLInputElement} */ (document.getElementById('fol-learned')).checked = learned;
      const t0 = performance.now();
      await w.__shapetrack.app.boxMask(box);
      return { page: performance.now() - t0, ...w.__shapetrack.app.lastBoxMask };
    },
    { box: BOX, learned },
  );
}

/**
 * @param {import('playwright-core').Page} page
 * @param {string} url
 */
async function openCar(page, url) {
  await page.goto(`${url}?demo=0`);
  await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
  const files = readdirSync(JPEG).filter((f) => f.endsWith('.jpg')).sort().slice(0, 2).map((f) => join(JPEG, f));
  await page.setInputFiles('#file-images', files);
  await page.waitForFunction(() => {
    const s = /** @type {any} */ (window).__shapetrack.state();
    return s.processed >= 1 && s.frame === 1 && !s.playing;
  }, undefined, { timeout: 120_000 });
}

const server = await serve(DIST, PORT);
const browser = await launch();
try {
  const page = await browser.context.newPage();
  const errors = watchErrors(page);
  await openCar(page, server.url);
  await page.evaluate(async () => {
    await navigator.serviceWorker.ready;
    if (!navigator.serviceWorker.controller) {
      await new Promise((r) => navigator.serviceWorker.addEventListener('controllerchange', r, { once: true }));
    }
  });
  BOX = await carBox(page);
  const line = (/** @type {string} */ what, /** @type {{ page: number, ms: number, how: string }} */ r) =>
    console.log(`${what}: ${f0(r.page)} ms in the page, ${f0(r.ms)} ms in the worker (${r.how})`);
  line('first box, net fetched from the server', await boxOnce(page, true));
  await page.reload();
  await openCar(page, server.url);
  line("first box after a reload, net from the service worker's cache", await boxOnce(page, true));
  // As the app is used: the box tool picked (X) starts the net's load and a first inference
  // while the box is drawn; a box drawn WARM_MS later.
  await page.reload();
  await openCar(page, server.url);
  await page.evaluate(() => /** @type {any} */ (window).__shapetrack.app.useTool('box'));
  await new Promise((r) => setTimeout(r, WARM_MS));
  line(`first box after a reload, box tool picked ${WARM_MS / 1000} s before (net loaded and run once meanwhile)`, await boxOnce(page, true));
  const later = [];
  for (let k = 0; k < RUNS; k++) later.push(await boxOnce(page, true));
  console.log(
    `later boxes (net loaded): ${f0(median(later.map((r) => r.page)))} ms in the page (median of ${RUNS}; min ${f0(Math.min(...later.map((r) => r.page)))}, max ${f0(Math.max(...later.map((r) => r.page)))}), ${f0(median(later.map((r) => r.ms)))} ms in the worker`,
  );
  // The side's share, paired in this run: one net (a segmenter of its own, two threads as the
  // app's while keyframes are off), inferences at 320 (the whole frame's) and at 256 (a given
  // box's, what the boxes above ran at) alternating.
  const sides = await page.evaluate(async (runs) => {
    const seg = await /** @type {any} */ (window).__shapetrack.segmenter({ threads: 2 });
    try {
      await seg.start();
      /** @type {Record<number, number[]>} */
      const ms = { 320: [], 256: [] };
      for (let k = 0; k <= runs; k++) {
        for (const side of [320, 256]) {
          const input = new Float32Array(3 * side * side).map((_, i) => Math.sin(i / 97));
          const t0 = performance.now();
          await seg.run(input, { transfer: true });
          // The first of each side makes its session: left out.
          if (k > 0) ms[side].push(performance.now() - t0);
        }
      }
      return ms;
    } finally {
      seg.dispose();
    }
  }, RUNS);
  const [m320, m256] = [median(sides[320]), median(sides[256])];
  console.log(`one inference, alternating (median of ${RUNS}): 320×320 ${f0(m320)} ms, 256×256 ${f0(m256)} ms (×${(m256 / m320).toFixed(2)})`);
  const free = [];
  for (let k = 0; k < RUNS; k++) free.push(await boxOnce(page, false));
  console.log(`weights-free: ${f0(median(free.map((r) => r.page)))} ms in the page (median of ${RUNS})`);
  console.log(`Chromium ${browser.context.browser()?.version() ?? ''}, ${await page.evaluate(() => navigator.hardwareConcurrency)} cores, load average ${(await import('node:os')).loadavg().map((x) => x.toFixed(2)).join(' ')}`);
  if (errors.length) console.log(`page errors: ${errors.join('; ')}`);
} finally {
  await browser.close();
  await server.close();
}
