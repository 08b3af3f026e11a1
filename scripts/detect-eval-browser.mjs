#!/usr/bin/env node
// Mask quality (J) of the app's detectors in the browser, as `shapetrack detect-eval` measures
// the core's natively (issue 11): for each DAVIS-layout sequence, J = mean over frames (those
// with a non-empty ground-truth mask) of the IoU between the ground-truth mask and the best
// matching detected mask, 0 where nothing matches. The detectors run in headless Chromium in
// the app's own tracker worker from www/dist (the bundle, wasm and detector registry the app
// runs), fed the sequence's JPEGs as the app feeds an image sequence; the worker hands back the
// detector's own output beside the tracker's (`detections: true` on each step), so J is the
// detector's, not the tracker's. The SSD detector (a TFLite model) runs only here, which is why
// this script exists beside the native one.
//
//   npm run build && node scripts/detect-eval-browser.mjs \
//     [--detectors moving,ssd-moving-filled,ssd-moving,moving-ssd] [--sequences bus,dog] [--port P] [--out FILE]
//
// Names: the app's detectors (`moving`, `background`, `auto`, `ssd`, `ssd-moving`) and
// `ssd-moving-filled`, the SSD boxes as filled rectangles (`refine: false`: what the app gave
// before the boxes were refined). The folders are `data/davis2016-moving` and
// `data/davis-car-shadow` under `$SHAPETRACK_SHARED`, else `../shared` beside the repository,
// else /work/shared. Prints a markdown table (mean of the 8 moving-camera sequences; car-shadow
// apart, as the native table does) and writes it to target/e2e/detect-eval-browser.md.

import { existsSync, mkdirSync, readFileSync, readdirSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { DIST, OUT, ROOT, installWorkerClient, launch, serve, watchErrors } from '../tests/e2e/harness.mjs';

const text = (/** @type {string} */ name) => {
  const i = process.argv.indexOf(name);
  return i >= 0 ? process.argv[i + 1] : undefined;
};
const DETECTORS = (text('--detectors') ?? 'moving,ssd-moving-filled,ssd-moving,moving-ssd').split(',').filter(Boolean);
const ONLY = text('--sequences')?.split(',').filter(Boolean) ?? null;
const PORT = Number(text('--port') ?? 47413);
const OUT_FILE = text('--out') ?? join(OUT, 'detect-eval-browser.md');

/** @type {Record<string, { detector: string, options: Record<string, unknown> }>} */
const VARIANTS = {
  'ssd-moving-filled': { detector: 'ssd-moving', options: { refine: false } },
};

const shared = process.env.SHAPETRACK_SHARED ?? (existsSync(join(ROOT, '..', 'shared')) ? join(ROOT, '..', 'shared') : '/work/shared');
/** The sequences: name → { jpeg dir, mask dir, in the mean of 8 }. */
const sequences = [];
for (const [folder, inMean] of /** @type {const} */ ([
  ['davis2016-moving', true],
  ['davis-car-shadow', false],
])) {
  const davis = join(shared, 'data', folder, 'DAVIS');
  const jpegs = join(davis, 'JPEGImages', '480p');
  if (!existsSync(jpegs)) throw new Error(`${jpegs} is missing (see the header)`);
  for (const name of readdirSync(jpegs).sort()) {
    if (ONLY && !ONLY.includes(name)) continue;
    sequences.push({ name, jpeg: join(jpegs, name), masks: join(davis, 'Annotations', '480p', name), inMean });
  }
}
const worker = readdirSync(join(DIST, 'assets')).find((f) => /^worker-.*\.js$/.test(f));
if (!worker) throw new Error(`no worker bundle in ${DIST}/assets: build the app first (npm run build)`);

const server = await serve(DIST, PORT);
const browser = await launch();
/** @type {Record<string, Record<string, { j: number, frames: number, fps: number }>>} detector → sequence → result */
const results = {};
try {
  const page = await browser.context.newPage();
  const errors = watchErrors(page);
  // A blank page of the app's origin (its worker is a same-origin module) and the files,
  // answered from here.
  await page.route(`${server.url}eval/**`, (route) => {
    const [seq, kind, file] = new URL(route.request().url()).pathname.slice('/eval/'.length).split('/');
    if (seq === '' || seq === undefined) return route.fulfill({ contentType: 'text/html', body: '<!doctype html><title>detector eval</title>' });
    const s = sequences.find((x) => x.name === seq);
    const dir = s && (kind === 'jpeg' ? s.jpeg : kind === 'masks' ? s.masks : null);
    if (!dir || !file || file.includes('..') || !existsSync(join(dir, file))) return route.fulfill({ status: 404, body: 'not found' });
    return route.fulfill({ contentType: kind === 'jpeg' ? 'image/jpeg' : 'image/png', body: readFileSync(join(dir, file)) });
  });
  await page.goto(`${server.url}eval/`);
  await installWorkerClient(page);
  for (const s of sequences) {
    const jpegs = readdirSync(s.jpeg).filter((f) => f.endsWith('.jpg')).sort();
    const pngs = jpegs.map((f) => f.replace(/\.jpg$/, '.png'));
    for (const name of DETECTORS) {
      const { detector, options } = VARIANTS[name] ?? { detector: name, options: {} };
      const r = await page.evaluate(evaluate, { url: `/assets/${worker}`, seq: s.name, jpegs, pngs, detector, options });
      if (errors.length) throw new Error(errors.join('\n'));
      (results[name] ??= {})[s.name] = r;
      console.log(`${name} ${s.name}: J ${r.j.toFixed(3)} over ${r.frames} frames, ${r.fps.toFixed(1)} detect calls/s`);
    }
  }
  await page.close();
} finally {
  await browser.close();
  await server.close();
}

// The table: one column per detector.
const head = `| sequence | frames | ${DETECTORS.join(' | ')} |\n|---|---|${DETECTORS.map(() => '---|').join('')}`;
const rows = sequences.map((s) => `| ${s.name} | ${results[DETECTORS[0]][s.name].frames} | ${DETECTORS.map((d) => results[d][s.name].j.toFixed(3)).join(' | ')} |`);
const inMean = sequences.filter((s) => s.inMean);
if (inMean.length) {
  const mean = (/** @type {string} */ d) => inMean.reduce((a, s) => a + results[d][s.name].j, 0) / inMean.length;
  rows.push(`| mean of ${inMean.length} | | ${DETECTORS.map((d) => `**${mean(d).toFixed(3)}**`).join(' | ')} |`);
}
const fps = `detect calls per second (whole sequences, first frames included): ${DETECTORS.map(
  (d) => `${d} ${(sequences.reduce((a, s) => a + results[d][s.name].fps, 0) / sequences.length).toFixed(1)}`,
).join(', ')}`;
const table = `${head}\n${rows.join('\n')}\n\n${fps}\n`;
console.log(`\n${table}`);
mkdirSync(OUT, { recursive: true });
writeFileSync(OUT_FILE, table);

/**
 * Runs in the page: one detector over one sequence in a fresh tracker worker; J and the
 * detect calls' rate.
 * @param {{ url: string, seq: string, jpegs: string[], pngs: string[], detector: string, options: Record<string, unknown> }} a
 */
async function evaluate({ url, seq, jpegs, pngs, detector, options }) {
  /** Ground truth as 0/1 bytes (the PNGs' red channel), decoded by the browser. */
  const truth = [];
  for (const f of pngs) {
    const bmp = await createImageBitmap(await (await fetch(`/eval/${seq}/masks/${f}`)).blob());
    const ctx = /** @type {OffscreenCanvasRenderingContext2D} */ (new OffscreenCanvas(bmp.width, bmp.height).getContext('2d'));
    ctx.drawImage(bmp, 0, 0);
    const { data } = ctx.getImageData(0, 0, bmp.width, bmp.height);
    const m = new Uint8Array(bmp.width * bmp.height);
    let area = 0;
    for (let i = 0; i < m.length; i++) {
      m[i] = data[4 * i] > 127 ? 1 : 0;
      area += m[i];
    }
    truth.push({ m, area, width: bmp.width, height: bmp.height });
    bmp.close();
  }
  const frames = [];
  for (const f of jpegs) frames.push(await createImageBitmap(await (await fetch(`/eval/${seq}/jpeg/${f}`)).blob()));
  const { width, height } = frames[0];

  const w = /** @type {any} */ (window).__openWorker(url);
  const request = w.request;
  await request({ type: 'open', source: { kind: 'frames', width, height, fps: 25 }, detector, detectorOptions: options, offline: false });
  let sum = 0;
  let counted = 0;
  let detectMs = 0;
  for (let k = 0; k < frames.length; k++) {
    const s = await request({ type: 'step', frame: k + 1, bitmap: frames[k], display: false, detections: true }, [frames[k]]);
    detectMs += s.timings.detect;
    const gt = truth[k];
    if (!gt || gt.area === 0) continue;
    let best = 0;
    for (const d of s.detected ?? []) {
      const mk = d.mask;
      if (!mk) continue;
      let inter = 0;
      let area = 0;
      for (let y = 0; y < mk.height; y++) {
        const gy = mk.y + y;
        for (let x = 0; x < mk.width; x++) {
          if (!mk.data[y * mk.width + x]) continue;
          area++;
          const gx = mk.x + x;
          if (gy >= 0 && gy < gt.height && gx >= 0 && gx < gt.width && gt.m[gy * gt.width + gx]) inter++;
        }
      }
      const union = gt.area + area - inter;
      if (union > 0) best = Math.max(best, inter / union);
    }
    sum += best;
    counted++;
  }
  await request({ type: 'close' });
  w.terminate();
  return { j: counted ? sum / counted : 0, frames: counted, fps: (1000 * frames.length) / detectMs };
}
