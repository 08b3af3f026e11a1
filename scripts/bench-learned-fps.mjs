#!/usr/bin/env node
// Benchmark: the app's tracking rate on real moving-camera video at 854×480 (DAVIS-2016 clips
// from ../shared/data/davis2016-moving, opened as an image sequence, played at full speed with
// the automatic detector) per learned-stage policy (issue 63): `off` (the weights-free masks)
// and `keyframes` (worker/learned.js: the segmenter runs in the background on a keyframe
// whenever it is free; the tracker never waits for it). Headless Chromium from www/dist (build
// first: `npm run build`). A first visit caches the segmenter's files (as a returning user has
// them); each run opens its clip in a fresh page (the net loads from the service worker's
// cache as the clip opens, as in the app); each clip is played `--repeat` times over (default
// 3) in one sequence, so the keyframes have time to land. fps = frames tracked / wall time from Play to the
// last frame. Also mean J: per tracked frame, the best mask IoU of the app's records with the
// ground truth (the tracker's output, not the detector's: what a labeller gets). And where a
// frame's time goes (medians): the worker's detect (with the learned stage's bookkeeping) and
// track, its whole step, and the page's taking in and drawing of a result. A benchmark, not a
// test: nothing fails on a slow run.
//
//   npm run build && node scripts/bench-learned-fps.mjs [--clips bus,camel] [--policies off,keyframes]
//     [--repeat N] [--port P]

import { readFileSync, readdirSync } from 'node:fs';
import { join } from 'node:path';
import { DIST, ROOT, launch, serve, watchErrors } from '../tests/e2e/harness.mjs';

const text = (/** @type {string} */ name) => {
  const i = process.argv.indexOf(name);
  return i >= 0 ? process.argv[i + 1] : undefined;
};
const CLIPS = (text('--clips') ?? 'bus,camel,car-roundabout,dog').split(',');
const POLICIES = (text('--policies') ?? 'off,keyframes').split(',');
const PORT = Number(text('--port') ?? 47436);
/**
 * Times each clip is played in one sequence (a cut at each restart): a DAVIS clip is 3 to 4
 * seconds of tracking, shorter than the segmenter's load and first keyframe.
 */
const REPEAT = Number(text('--repeat') ?? 3);
const DAVIS = join(ROOT, '..', 'shared', 'data', 'davis2016-moving', 'DAVIS', 'JPEGImages', '480p');
const GT = join(ROOT, '..', 'shared', 'data', 'davis2016-moving', 'DAVIS', 'Annotations', '480p');

/**
 * Mean J over the tracked frames: per frame, the best mask IoU of any record with the clip's
 * ground-truth mask (DAVIS 2016 has one object; a frame with no record scores 0). Decoded and
 * counted in the page.
 * @param {import('playwright-core').Page} page
 * @param {string} clip
 */
function meanJ(page, clip) {
  const pngs = readdirSync(join(GT, clip))
    .filter((f) => f.endsWith('.png'))
    .sort()
    .map((f) => readFileSync(join(GT, clip, f)).toString('base64'));
  return page.evaluate(async (pngs) => {
    const a = /** @type {any} */ (window).__shapetrack.app;
    const W = a.stage.width;
    /** @type {Uint8Array[]} */
    const gts = [];
    for (const b64 of pngs) {
      const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
      const bmp = await createImageBitmap(new Blob([bytes], { type: 'image/png' }));
      const ctx = /** @type {OffscreenCanvasRenderingContext2D} */ (new OffscreenCanvas(bmp.width, bmp.height).getContext('2d'));
      ctx.drawImage(bmp, 0, 0);
      const { data } = ctx.getImageData(0, 0, bmp.width, bmp.height);
      const g = new Uint8Array(bmp.width * bmp.height);
      for (let i = 0; i < g.length; i++) g[i] = data[4 * i] > 127 ? 1 : 0;
      gts.push(g);
    }
    const area = gts.map((g) => g.reduce((n, v) => n + v, 0));
    let sum = 0;
    const frames = a.session.frames;
    for (let f = 1; f <= frames; f++) {
      const k = (f - 1) % gts.length;
      const g = gts[k];
      let best = 0;
      for (const r of a.model.table.at(f)) {
        if (!r.mask) continue;
        const m = a.core.decodeMask(r.mask);
        let inter = 0;
        let n = 0;
        for (let y = 0; y < m.height; y++) {
          for (let x = 0; x < m.width; x++) {
            if (!m.data[y * m.width + x]) continue;
            n++;
            inter += g[(m.y + y) * W + m.x + x];
          }
        }
        best = Math.max(best, inter / (n + area[k] - inter));
      }
      sum += best;
    }
    return sum / frames;
  }, pngs);
}

/** @param {number[]} xs */
const median = (xs) => {
  const s = [...xs].sort((a, b) => a - b);
  return s.length ? s[Math.floor(s.length / 2)] : NaN;
};

/**
 * @typedef {{ at: number, detect: number, track: number, total: number, accept: number, render: number, running: boolean }} LogEntry
 *   one result: when the page took it, the worker's timings, the page's, and whether a
 *   keyframe was under way as the worker finished the frame
 */

/**
 * Medians (ms) of a run's per-frame log: the wall time between two results, the worker's
 * step (its detect, incl. the learned stage's bookkeeping, and track; `total` adds taking
 * the frame's pixels in), and the page's taking in and drawing of a result; and the worker's
 * step on the frames a keyframe ran beside (`busy`, with their share) and the others
 * (`idle`): what the net's inference costs the tracker while it runs.
 * @param {LogEntry[]} log
 */
function split(log) {
  const wall = log.slice(1).map((e, i) => e.at - log[i].at);
  const pick = (/** @type {'detect' | 'track' | 'total' | 'accept' | 'render'} */ k, l = log) => median(l.map((e) => e[k]));
  const busy = log.filter((e) => e.running);
  return {
    wall: median(wall),
    detect: pick('detect'),
    track: pick('track'),
    worker: pick('total'),
    accept: pick('accept'),
    render: pick('render'),
    busyShare: log.length ? busy.length / log.length : 0,
    busy: pick('total', busy),
    idle: pick('total', log.filter((e) => !e.running)),
  };
}

/** @param {ReturnType<typeof split>} s */
const showSplit = (s) =>
  `median ms: frame ${s.wall.toFixed(1)}, worker ${s.worker.toFixed(1)} (detect ${s.detect.toFixed(1)}, track ${s.track.toFixed(1)}), page ${(s.accept + s.render).toFixed(1)} (take ${s.accept.toFixed(1)}, draw ${s.render.toFixed(1)})` +
  (s.busyShare > 0 ? `; worker beside a keyframe ${s.busy.toFixed(1)} (${(100 * s.busyShare).toFixed(0)} % of frames), without ${s.idle.toFixed(1)}` : '');

/** @param {string} clip */
const frames = (clip) =>
  readdirSync(join(DAVIS, clip))
    .filter((f) => f.endsWith('.jpg'))
    .sort()
    .map((f) => join(DAVIS, clip, f));

/**
 * @param {import('playwright-core').Page} page
 * @param {(s: any) => boolean} pred
 */
async function until(page, pred) {
  for (;;) {
    const s = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.state());
    if (pred(s)) return s;
    await page.waitForTimeout(50);
  }
}

/**
 * @param {{ context: import('playwright-core').BrowserContext }} browser
 * @param {string} url
 * @param {string} clip
 * @param {string} policy
 */
async function run(browser, url, clip, policy) {
  const page = await browser.context.newPage();
  const errors = watchErrors(page);
  try {
    await page.goto(`${url}?demo=0&speed=max&learned=${policy}`);
    await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
    await page.evaluate(async () => {
      await navigator.serviceWorker.ready;
      if (!navigator.serviceWorker.controller) {
        await new Promise((r) => navigator.serviceWorker.addEventListener('controllerchange', r, { once: true }));
      }
    });
    const one = frames(clip).map((f) => readFileSync(f));
    const files = Array.from({ length: REPEAT }, (_, k) =>
      one.map((buffer, i) => ({ name: `${k}-${String(i).padStart(5, '0')}.jpg`, mimeType: 'image/jpeg', buffer })),
    ).flat();
    await page.setInputFiles('#file-images', files);
    const s0 = await until(page, (s) => s.processed >= 1 && !s.playing);
    // Where a frame's time goes: the worker's own timings per step, and the page's share
    // (taking a result into the table, drawing the overlay), measured by wrapping the app's
    // methods (app.js lets them be wrapped from outside).
    await page.evaluate(() => {
      const a = /** @type {any} */ (window).__shapetrack.app;
      /** @type {object[]} */
      const log = [];
      /** @type {any} */ (window).__benchLog = log;
      const accept = a.accept.bind(a);
      const render = a.render.bind(a);
      a.accept = (/** @type {any} */ res) => {
        const t = performance.now();
        const r = accept(res);
        log.push({ at: t, ...res.timings, accept: performance.now() - t, render: 0, running: !!res.learned?.running });
        return r;
      };
      a.render = (/** @type {any[]} */ ...args) => {
        const t = performance.now();
        const r = render(...args);
        const last = log.at(-1);
        if (last) last.render += performance.now() - t;
        return r;
      };
    });
    const t0 = Date.now();
    await page.keyboard.press('Space');
    const s1 = await until(page, (s) => s.processed === s.frames && !s.playing);
    const secs = (Date.now() - t0) / 1000;
    const j = await meanJ(page, clip);
    const log = await page.evaluate(() => /** @type {any} */ (window).__benchLog);
    return { clip, policy, frames: s1.processed - s0.processed, fps: (s1.processed - s0.processed) / secs, j, learned: s1.learned, choice: s1.detectorChoice, errors, split: split(log) };
  } finally {
    await page.close();
  }
}

const server = await serve(DIST, PORT);
const browser = await launch();
try {
  // The first visit: the segmenter's files fetched once and cached by the service worker.
  await run(browser, server.url, CLIPS[0], 'keyframes');
  /** @type {Record<string, number[]>} */
  const byPolicy = {};
  /** @type {Record<string, number[]>} */
  const jByPolicy = {};
  for (const clip of CLIPS) {
    for (const policy of POLICIES) {
      const r = await run(browser, server.url, clip, policy);
      (byPolicy[policy] ??= []).push(r.fps);
      (jByPolicy[policy] ??= []).push(r.j);
      const l = r.learned;
      console.log(
        `${clip} (${r.frames} frames, ${r.choice}), learned ${policy}: ${r.fps.toFixed(1)} fps, J ${r.j.toFixed(3)}` +
          (policy === 'keyframes' ? `; keyframes done ${l.keyframes}${l.keyframes ? ` (last ${(l.ms / 1000).toFixed(1)} s)` : ''}, frames with learned masks ${l.frames} (replaced ${l.used}, added ${l.added})${l.failed ? `, failed: ${l.failed}` : ''}` : '') +
          `; ${showSplit(r.split)}` +
          (r.errors.length ? `; page errors: ${r.errors.join('; ')}` : ''),
      );
    }
  }
  for (const [policy, fps] of Object.entries(byPolicy)) {
    const mean = (/** @type {number[]} */ xs) => xs.reduce((a, b) => a + b, 0) / xs.length;
    console.log(`mean over ${fps.length} clips, learned ${policy}: ${mean(fps).toFixed(1)} fps, J ${mean(jByPolicy[policy]).toFixed(3)}`);
  }
  console.log(`Chromium ${browser.context.browser()?.version() ?? ''}, 854×480, load average ${(await import('node:os')).loadavg().map((x) => x.toFixed(2)).join(' ')}`);
} finally {
  await browser.close();
  await server.close();
}
