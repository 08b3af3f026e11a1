#!/usr/bin/env node
// Benchmark of the learned segmenter's net (issue 63: U²-Net-p, onnxruntime-web): milliseconds
// per 320×320 inference in headless Chromium, through the app's own segmenter worker from
// www/dist (built beforehand: `npm run build`; nothing is built here), and in Node through
// onnxruntime-web's Node build, for comparison. A benchmark, not a test: the figures depend on
// how busy this shared 2-core machine is, and nothing here fails on a slow run.
//
// Chromium: a fresh profile; for each thread count the page's `__shapetrack.segmenter()` (a
// SegmenterClient spawned from the page) starts a new segmenter worker and loads the net — the
// first load fetches the model and runtime from the server (first use), later ones from the
// service worker's cache — then runs once (reported apart: the first run allocates and tiers
// up the wasm) and `--runs` more, whose median is the figure. Threads above 1 take effect only
// in a cross-origin isolated page; the line says what the net ran with.
//
// `--backend auto|wasm|webgpu` (default auto: WebGPU on a hardware adapter, else the CPU);
// `--swiftshader` gives Chromium SwiftShader's software WebGPU adapter, on which `--backend
// webgpu` checks the WebGPU path works at all (minutes per inference: not a speed figure).
//
// `--tracker SIZE` (e.g. 854x480) also measures what the segmenter costs the tracker: the
// app's bench page (www/bench.html, the demo scene at SIZE with `--detector`, default `auto`)
// alone, then beside a segmenter running inferences back to back with each thread count.
//
//   npm run build && node scripts/bench-segmenter.mjs [--runs N] [--threads 1,2] [--no-node]
//     [--backend auto|wasm|webgpu] [--swiftshader] [--tracker 854x480 [--detector auto] [--frames N]] [--port P]

import { spawnSync } from 'node:child_process';
import { readFileSync, readdirSync, statSync } from 'node:fs';
import { join } from 'node:path';
import { fileURLToPath, pathToFileURL } from 'node:url';
import { DIST, launch, serve, watchErrors } from '../tests/e2e/harness.mjs';
import { ORT, REMBG, SEG_DIR, SEG_MODEL_PATH } from './segmenter-model.mjs';

const text = (/** @type {string} */ name) => {
  const i = process.argv.indexOf(name);
  return i >= 0 ? process.argv[i + 1] : undefined;
};
const RUNS = Number(text('--runs') ?? 9);
const THREADS = (text('--threads') ?? '1,2').split(',').map(Number);
const TRACKER = text('--tracker');
const BACKEND = text('--backend') ?? 'auto';
const SWIFTSHADER = process.argv.includes('--swiftshader') ? ['--enable-unsafe-webgpu', '--use-webgpu-adapter=swiftshader', '--enable-features=Vulkan'] : [];
const DETECTOR = text('--detector') ?? 'auto';
const FRAMES = Number(text('--frames') ?? 300);
// Unusual, and not the e2e suite's or the other benches' ports.
const PORT = Number(text('--port') ?? 47431);

/** @param {number[]} xs */
const median = (xs) => {
  const s = [...xs].sort((a, b) => a - b);
  return s.length % 2 ? s[(s.length - 1) / 2] : (s[s.length / 2 - 1] + s[s.length / 2]) / 2;
};
const f0 = (/** @type {number} */ v) => v.toFixed(0);

/** A 320×320 input: a red disc on a textured blue-grey ground, normalised as U²-Net's training was. */
function input() {
  const S = 320;
  const mean = [0.485, 0.456, 0.406];
  const std = [0.229, 0.224, 0.225];
  const x = new Float32Array(3 * S * S);
  for (let y = 0; y < S; y++) {
    for (let k = 0; k < S; k++) {
      const rgb = (k - 160) ** 2 + (y - 150) ** 2 < 70 ** 2 ? [0.9, 0.35, 0.2] : [0.25 + 0.05 * Math.sin(k / 9), 0.3, 0.35 + 0.05 * Math.cos(y / 7)];
      for (let c = 0; c < 3; c++) x[c * S * S + y * S + k] = (rgb[c] - mean[c]) / std[c];
    }
  }
  return x;
}

/** Sizes of what the build ships for the segmenter. */
function shipped() {
  const dir = join(DIST, SEG_DIR);
  const files = readdirSync(dir).map((f) => `${f} ${statSync(join(dir, f)).size.toLocaleString('en')} B`);
  const worker = readdirSync(join(DIST, 'assets')).filter((f) => /^segmenter-worker-.*\.js$/.test(f));
  const w = worker.map((f) => `assets/${f} ${statSync(join(DIST, 'assets', f)).size.toLocaleString('en')} B`);
  return `shipped: ${SEG_DIR} ${files.join(', ')}; ${w.join(', ') || 'no segmenter worker chunk'}`;
}

async function chromiumBench() {
  const server = await serve(DIST, PORT);
  const browser = await launch({ args: SWIFTSHADER });
  try {
    const page = await browser.context.newPage();
    const errors = watchErrors(page);
    await page.goto(`${server.url}?demo=0`);
    await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
    // The service worker in control first, so later loads come from its cache.
    await page.evaluate(async () => {
      await navigator.serviceWorker.ready;
      if (!navigator.serviceWorker.controller) {
        await new Promise((r) => navigator.serviceWorker.addEventListener('controllerchange', r, { once: true }));
      }
    });
    const isolated = await page.evaluate(() => crossOriginIsolated);
    console.log(`Chromium ${browser.context.browser()?.version() ?? ''}, page cross-origin isolated: ${isolated}, ${await page.evaluate(() => navigator.hardwareConcurrency)} cores`);
    console.log(shipped());
    let first = true;
    for (const threads of THREADS) {
      const r = await page.evaluate(
        async ({ threads, runs, data, backend }) => {
          const seg = await /** @type {any} */ (window).__shapetrack.segmenter({ threads, backend });
          const x = new Float32Array(data);
          try {
            const t0 = performance.now();
            const info = await seg.start();
            const load = performance.now() - t0;
            const t1 = performance.now();
            await seg.run(x);
            const firstRun = performance.now() - t1;
            const times = [];
            for (let k = 0; k < runs; k++) {
              const t = performance.now();
              await seg.run(x);
              times.push(performance.now() - t);
            }
            return { ...info, load, firstRun, times };
          } finally {
            seg.dispose();
          }
        },
        { threads, runs: RUNS, data: Array.from(input()), backend: BACKEND },
      );
      console.log(
        `chromium ${r.backend}${r.gpuSkipped ? ` (not WebGPU: ${r.gpuSkipped})` : ''}, ${threads} thread${threads > 1 ? 's' : ''} asked, ${r.threads} used: ` +
          `${f0(median(r.times))} ms per inference (median of ${RUNS}; min ${f0(Math.min(...r.times))}, max ${f0(Math.max(...r.times))}), ` +
          `first run ${f0(r.firstRun)} ms, load ${f0(r.load)} ms (${first ? 'first use: from the server' : "from the service worker's cache"})`,
      );
      first = false;
    }
    if (TRACKER) await trackerBench(browser, server, page);
    if (errors.length) console.log(`page errors: ${errors.join('; ')}`);
  } finally {
    await browser.close();
    await server.close();
  }
}

/**
 * The bench page's fps alone, then beside a segmenter inferring back to back.
 * @param {Awaited<ReturnType<typeof launch>>} browser
 * @param {Awaited<ReturnType<typeof serve>>} server
 * @param {import('playwright-core').Page} app the app's page (hosts the segmenter)
 */
async function trackerBench(browser, server, app) {
  const fps = async (/** @type {string} */ what) => {
    const page = await browser.context.newPage();
    await page.goto(`${server.url}bench.html?size=${TRACKER}&detector=${DETECTOR}&frames=${FRAMES}&run=1`);
    /** @type {any} */
    let b;
    for (;;) {
      b = await page.evaluate(() => /** @type {any} */ (window).__bench);
      if (b && (b.results.length || b.error)) break;
      await new Promise((r) => setTimeout(r, 200));
    }
    await page.close();
    if (b.error) throw new Error(`bench page: ${b.error}`);
    const r = b.results[0];
    console.log(`bench page ${r.size}, ${r.detector}, ${what}: ${r.fps.toFixed(1)} fps (median ms/frame: detect ${r.detect.toFixed(1)}, track ${r.track.toFixed(1)})`);
  };
  await fps('alone');
  for (const threads of THREADS) {
    await app.evaluate(
      async ({ threads, data, backend }) => {
        const w = /** @type {any} */ (window);
        const seg = await w.__shapetrack.segmenter({ threads, backend });
        await seg.start();
        const x = new Float32Array(data);
        w.__segLoop = { seg, stop: false, runs: 0 };
        (async () => {
          while (!w.__segLoop.stop) {
            await seg.run(x);
            w.__segLoop.runs++;
          }
        })();
      },
      { threads, data: Array.from(input()), backend: BACKEND },
    );
    const t0 = Date.now();
    await fps(`beside a segmenter with ${threads} thread${threads > 1 ? 's' : ''} inferring back to back`);
    const runs = await app.evaluate(() => {
      const w = /** @type {any} */ (window);
      w.__segLoop.stop = true;
      w.__segLoop.seg.dispose();
      return w.__segLoop.runs;
    });
    console.log(`  the segmenter meanwhile: ${runs} inferences in ${((Date.now() - t0) / 1000).toFixed(1)} s`);
  }
}

/**
 * One thread count in Node (`--node-child THREADS`, in a process of its own: the runtime reads
 * numThreads once, at its first session, and its thread workers take this file's own flags,
 * which an eval'd script's `--input-type` would break). Prints one JSON line.
 * @param {number} threads
 */
async function nodeChild(threads) {
  const ort = await import(pathToFileURL(join(ORT, 'dist', 'ort.node.min.mjs')).href);
  ort.env.wasm.numThreads = threads;
  ort.env.logLevel = 'error';
  const t0 = performance.now();
  const s = await ort.InferenceSession.create(readFileSync(join(REMBG, SEG_MODEL_PATH)), { executionProviders: ['wasm'], graphOptimizationLevel: 'all' });
  const load = performance.now() - t0;
  const x = input();
  const run = async () => {
    const t = performance.now();
    await s.run({ 'input.1': new ort.Tensor('float32', x, [1, 3, 320, 320]) }, [s.outputNames[0]]);
    return performance.now() - t;
  };
  const firstRun = await run();
  const times = [];
  for (let k = 0; k < RUNS; k++) times.push(await run());
  console.log(JSON.stringify({ load, firstRun, times }));
  await s.release();
  // The runtime's thread workers would keep the process alive.
  process.exit(0);
}

async function nodeBench() {
  for (const threads of THREADS) {
    const r = spawnSync(process.execPath, [fileURLToPath(import.meta.url), '--node-child', String(threads), '--runs', String(RUNS)], { encoding: 'utf8' });
    if (r.status !== 0) {
      console.log(`node wasm, ${threads} thread(s): failed: ${r.stderr.trim().split('\n').slice(-3).join(' ')}`);
      continue;
    }
    const o = JSON.parse(r.stdout.trim().split('\n').at(-1) ?? '{}');
    console.log(
      `node ${process.version} onnxruntime-web wasm, numThreads ${threads}: ${f0(median(o.times))} ms per inference (median of ${RUNS}; min ${f0(Math.min(...o.times))}, max ${f0(Math.max(...o.times))}), ` +
        `first run ${f0(o.firstRun)} ms, session ${f0(o.load)} ms`,
    );
  }
}

const child = text('--node-child');
if (child) {
  await nodeChild(Number(child));
} else {
  await chromiumBench();
  if (!process.argv.includes('--no-node')) await nodeBench();
}
