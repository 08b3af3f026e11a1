// Browser benchmark: the embedded demo (synthetic 1280×720 scene, background subtractor, mask
// preset) in headless Chromium, at full speed; prints the tracking rate and the worker's
// per-frame times, and writes them to target/e2e/fps.txt. Then a labelling session of 1,000
// imported tracks: the page's redraw time (timeline, track list, overlay) while scrolling,
// zooming and stepping through frames, to target/e2e/timeline.txt. A benchmark, not a test: the figure
// depends on how busy the machine is, so nothing here fails on a slow run unless asked to
// with `--min FPS` (for a quiet machine, e.g. a release check).
//
// With `--detectors NAMES` (comma-separated) it benchmarks detectors instead, on real
// moving-camera video: the DAVIS 2016 JPEGs of one sequence (`bus` unless `--sequence`, 854×480;
// `--size WxH` rescales them in the page, as createImageBitmap's resize does), decoded in the
// page and sent frame by frame, as transferred ImageBitmaps, to the app's own tracker worker
// from www/dist (the same bundle, wasm and detector registry the app runs, opened as the app
// opens an image sequence). Only the detect call is timed (the worker's `timings.detect`),
// after the detector's warm-up (the frames its model learns from, see `warmup` in
// www/src/worker/detectors.js) and 5 more, none of them counted; frames run back and forth when
// `--frames` exceeds the sequence (a jump back to the first frame is a cut, after which the
// moving-camera detector learns the scene again). One line per detector goes to the console
// and is appended to target/e2e/fps.txt; it also gives the worker's whole frame (loading the
// bitmap into wasm, detecting, tracking) as the app would run at full speed. Names: the app's
// (`moving`, `background`, `auto`, `ssd`, `ssd-moving`, `moving-ssd`), `moving-coarse`: the
// moving-camera detector without its box → mask refinement (`refine: null`), whose difference
// to `moving` is what refinement costs, and `ssd-moving-filled`: the SSD's boxes unrefined
// (`refine: false`), whose difference to `ssd-moving` is what refining its boxes costs.
// `refine` alone (oracle boxes → masks, as `shapetrack detect-eval --methods refine`) needs
// the ground truth's boxes, which no app detector has, so it is skipped with a note. Not run by default: decoding the sequence and a hundred frames of the
// moving-camera detector take a minute on this machine, on top of the demo's.
//
// With `--page SIZES` (comma-separated WxH, e.g. `1280x720,1920x1080`) it runs the app's bench
// page (www/bench.html: the demo scene rendered at each size, the `--detector` given or the
// background subtractor, the frame painted by the worker and the boxes drawn by the page, the
// tracker offline-capable as the app opens the demo unless `--online-only`) and prints its row
// per size (fps and median per-frame times), appended to target/e2e/fps.txt.
//
//   npm run build && node scripts/bench-browser.mjs [--frames N] [--min FPS] [--port P]
//   npm run build && node scripts/bench-browser.mjs --page 1280x720,1920x1080 [--detector NAME] \
//     [--online-only] [--frames N] [--min FPS] [--port P]
//   npm run build && node scripts/bench-browser.mjs --detectors moving,moving-coarse,background \
//     [--size 854x480] [--frames N] [--sequence bus] [--min FPS] [--port P]
//
// `--frames`: the demo's measured frames (default 300) or each detector's (default 100).
// `--min FPS`: fail below this tracking rate (demo) or detect rate (each detector).
// The DAVIS folder is `data/davis2016-moving` under `$SHAPETRACK_SHARED`, else `../shared`
// beside the repository, else /work/shared (as the CLI's grid finds it).

import { appendFileSync, existsSync, mkdirSync, readFileSync, readdirSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { DIST, OUT, ROOT, crowdTracks, installWorkerClient, launch, serve, untilState, watchErrors } from '../tests/e2e/harness.mjs';

const arg = (/** @type {string} */ name, /** @type {number} */ fallback) => {
  const i = process.argv.indexOf(name);
  return i >= 0 ? Number(process.argv[i + 1]) : fallback;
};
const text = (/** @type {string} */ name) => {
  const i = process.argv.indexOf(name);
  return i >= 0 ? process.argv[i + 1] : undefined;
};
const DETECTORS = text('--detectors')?.split(',').filter(Boolean) ?? null;
const PAGE = text('--page')?.split(',').filter(Boolean) ?? null;
const FRAMES = arg('--frames', DETECTORS ? 100 : 300);
const MIN = arg('--min', 0);
// Unusual, and not the e2e suite's ports: the two may run side by side. `--port` for a second
// bench beside a first.
const PORT = arg('--port', 47411);

/**
 * Bench names that are an app detector with options rather than one of its own.
 * @type {Record<string, { detector: string, options: Record<string, unknown> }>}
 */
const VARIANTS = {
  // No refinement: the coarse blobs, upscaled (MovingConfig's `refine: None`).
  'moving-coarse': { detector: 'moving', options: { refine: null } },
  // The SSD's boxes as filled rectangles (no BoxRefiner).
  'ssd-moving-filled': { detector: 'ssd-moving', options: { refine: false } },
};

const server = await serve(DIST, PORT);
const browser = await launch();
try {
  if (DETECTORS) await benchDetectors(DETECTORS);
  else if (PAGE) await benchPage(PAGE);
  else await benchDemo();
} finally {
  await browser.close();
  await server.close();
}

/**
 * The bench page at each size: one run each, in a fresh page.
 * @param {string[]} sizes
 */
async function benchPage(sizes) {
  const detector = text('--detector') ?? 'background';
  mkdirSync(OUT, { recursive: true });
  for (const size of sizes) {
    const page = await browser.context.newPage();
    const errors = watchErrors(page);
    const offline = process.argv.includes('--online-only') ? '&offline=0' : '';
    await page.goto(`${server.url}bench.html?size=${size}&detector=${detector}&frames=${FRAMES}${offline}&run=1`);
    /** @type {any} */
    let b;
    for (;;) {
      b = await page.evaluate(() => /** @type {any} */ (window).__bench);
      if (b && (b.results.length || b.error)) break;
      await new Promise((r) => setTimeout(r, 200));
    }
    if (b.error || errors.length) throw new Error(`bench page, ${size}: ${b.error ?? errors.join('; ')}`);
    const r = b.results[0];
    const line =
      `bench page ${r.size}, ${r.detector}${r.offline ? ', offline-capable' : ', online only'}: ${r.fps.toFixed(1)} fps over ${r.frames} frames ` +
      `(median ms/frame: detect ${r.detect.toFixed(1)}, track ${r.track.toFixed(1)}, worker ${r.worker.toFixed(1)}, page ${r.page.toFixed(2)})`;
    console.log(line);
    appendFileSync(join(OUT, 'fps.txt'), `${line}\n`);
    if (MIN > 0 && r.fps < MIN) {
      console.error(`${size}: ${r.fps.toFixed(1)} fps < ${MIN}`);
      process.exitCode = 1;
    }
    await page.close();
  }
}

async function benchDemo() {
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
}

/**
 * The DAVIS 2016 folder (DAVIS/JPEGImages/480p/SEQUENCE/*.jpg), found as the CLI's grid finds
 * the shared data (src/grid/datasets.rs `shared_dir`).
 */
function davisDir() {
  const beside = join(ROOT, '..', 'shared');
  const shared = process.env.SHAPETRACK_SHARED ?? (existsSync(beside) ? beside : '/work/shared');
  return join(shared, 'data', 'davis2016-moving', 'DAVIS');
}

/**
 * Times each detector's detect calls on real frames in the app's tracker worker (see the
 * header).
 * @param {string[]} names
 */
async function benchDetectors(names) {
  const sequence = text('--sequence') ?? 'bus';
  const dir = join(davisDir(), 'JPEGImages', '480p', sequence);
  if (!existsSync(dir)) throw new Error(`${dir} is missing: the DAVIS 2016 frames (see the header)`);
  const files = readdirSync(dir).filter((f) => f.endsWith('.jpg')).sort();
  // The worker's bundle name carries a content hash: the one the app's page would load.
  const worker = readdirSync(join(DIST, 'assets')).find((f) => /^worker-.*\.js$/.test(f));
  if (!worker) throw new Error(`no worker bundle in ${DIST}/assets: build the app first (npm run build)`);
  const size = text('--size')?.split('x').map(Number) ?? null;
  if (size && (size.length !== 2 || !size.every((v) => v > 0))) throw new Error(`--size WxH, not ${text('--size')}`);

  const page = await browser.context.newPage();
  const errors = watchErrors(page);
  // A blank page of the app's origin (its worker is a same-origin module) and the frames,
  // answered from here: the app's own page would run its demo beside the bench.
  await page.route(`${server.url}bench/**`, (route) => {
    const name = new URL(route.request().url()).pathname.slice('/bench/'.length);
    if (name === '') return route.fulfill({ contentType: 'text/html', body: '<!doctype html><title>detector bench</title>' });
    if (!files.includes(name)) return route.fulfill({ status: 404, body: 'not found' });
    return route.fulfill({ contentType: 'image/jpeg', body: readFileSync(join(dir, name)) });
  });
  await page.goto(`${server.url}bench/`);
  await installWorkerClient(page);
  // Decoded (and rescaled) once, outside any timing.
  const [width, height] = await page.evaluate(
    async ({ files, size }) => {
      /** @type {ImageBitmap[]} */
      const frames = [];
      for (const f of files) {
        const blob = await (await fetch(f)).blob();
        frames.push(
          await createImageBitmap(blob, size ? { resizeWidth: size[0], resizeHeight: size[1], resizeQuality: 'high' } : {}),
        );
      }
      /** @type {any} */ (window).__frames = frames;
      return [frames[0].width, frames[0].height];
    },
    { files, size },
  );

  mkdirSync(OUT, { recursive: true });
  for (const name of names) {
    if (name === 'refine') {
      const note =
        'detector refine: skipped (it refines the ground truth\'s boxes, which no app detector has; ' +
        'moving vs moving-coarse and ssd-moving vs ssd-moving-filled give refinement\'s cost)';
      console.log(note);
      continue;
    }
    const { detector, options } = VARIANTS[name] ?? { detector: name, options: {} };
    const r = await page.evaluate(
      async ({ url, detector, options, frames: measured, width, height }) => {
        const frames = /** @type {ImageBitmap[]} */ (/** @type {any} */ (window).__frames);
        const worker = /** @type {any} */ (window).__openWorker(url);
        const request = worker.request;
        // As the app opens an image sequence (www/src/app.js `openSource`): its size, 25 fps,
        // the offline pass possible.
        await request({ type: 'open', source: { kind: 'frames', width, height, fps: 25 }, detector, detectorOptions: options, offline: true });
        const n = frames.length;
        // Back and forth: frame k of 0, 1, …, n−1, n−2, …, 1, 0, 1, …
        const at = (/** @type {number} */ k) => {
          const p = k % (2 * n - 2);
          return p < n ? p : 2 * n - 2 - p;
        };
        const step = async (/** @type {number} */ k) => {
          // A copy per step: the worker takes (and closes) the bitmap it is sent, as the app's.
          const bitmap = await createImageBitmap(frames[at(k)]);
          return request({ type: 'step', frame: k + 1, bitmap, display: false }, [bitmap]);
        };
        const WARM = 5;
        let k = 0;
        for (let after = 0; after < WARM; k++) {
          const s = await step(k);
          if (!s.warmup || s.warmup.seen >= s.warmup.total) after++;
        }
        const warm = k;
        /** @type {number[]} */
        const detect = [];
        let total = 0;
        let detections = 0;
        let learning = 0;
        for (let i = 0; i < measured; i++, k++) {
          const s = await step(k);
          detect.push(s.timings.detect);
          total += s.timings.total;
          detections += s.detections;
          if (s.warmup && s.warmup.seen < s.warmup.total) learning++;
        }
        await request({ type: 'close' });
        worker.terminate();
        const mean = detect.reduce((a, b) => a + b, 0) / detect.length;
        detect.sort((a, b) => a - b);
        return {
          mean,
          median: detect[detect.length >> 1],
          total: total / measured,
          detections: detections / measured,
          learning,
          warm,
        };
      },
      { url: `/assets/${worker}`, detector, options, frames: FRAMES, width, height },
    );
    if (errors.length) throw new Error(errors.join('\n'));
    const fps = 1000 / r.mean;
    const line =
      `detector ${name} at ${width}x${height}: ${fps.toFixed(1)} fps (${r.mean.toFixed(1)} ms/frame, median ` +
      `${r.median.toFixed(1)}) over ${FRAMES} frames of DAVIS ${sequence}, detect calls only ` +
      `(worker frame with loading and tracking: ${(1000 / r.total).toFixed(1)} fps, ${r.total.toFixed(1)} ms; ` +
      `${r.detections.toFixed(2)} detections/frame; ${r.warm} warm-up frames not counted` +
      `${r.learning ? `; ${r.learning} counted frames relearning after a cut` : ''})`;
    console.log(line);
    appendFileSync(join(OUT, 'fps.txt'), `${line}\n`);
    if (MIN > 0 && fps < MIN) {
      console.error(`${name}: ${fps.toFixed(1)} fps < ${MIN}`);
      process.exitCode = 1;
    }
  }
  await page.close();
}
