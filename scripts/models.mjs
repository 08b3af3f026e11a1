#!/usr/bin/env node
// The SSD detector's weights and runtime, taken from npm packages at build time (never from a
// CDN or a model hub at run time, never committed):
//
// - @mediapipe/objectron (Apache-2.0) packs MediaPipe's SSD-MobileNetV2 Open Images detector
//   (object_detection_ssd_mobilenetv2_oidv4_fp16.tflite) and its 24-line label list into one
//   Emscripten data file, objectron_solution_packed_assets.data; the loader script next to it
//   holds the byte ranges. We read the ranges from the loader, check the TFLite flatbuffer
//   magic, the labels and the model's SHA-256 (MediaPipe's published hash of that file), and
//   refuse a package whose licence is not Apache-2.0.
// - @tensorflow/tfjs-tflite (Apache-2.0) ships the TFLite wasm runtime; the non-threaded builds
//   (plain and SIMD) are served next to each other, as its loader expects.
//
// `ssdModel()` is the Vite plugin that serves all of it: the module `virtual:shapetrack-ssd`
// (URLs + the tfjs-tflite functions) for the tracker worker. In a build every file only the
// SSD detector uses — the model, its labels, the TFLite runtime and the worker's chunk of
// tfjs-tflite, ~19 MB — goes under `ssd/` (SSD_DIR): the service worker does not precache
// that folder at install, it caches each file when the detector first fetches it.
//
//   node scripts/models.mjs             check the packages, print offsets, labels, hash, licence
//   node scripts/models.mjs --out DIR   also write model.tflite and labels.txt into DIR

import { createHash } from 'node:crypto';
import { existsSync, mkdirSync, readFileSync, writeFileSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

const ROOT = join(dirname(fileURLToPath(import.meta.url)), '..');
export const OBJECTRON = join(ROOT, 'node_modules', '@mediapipe', 'objectron');
export const TFLITE = join(ROOT, 'node_modules', '@tensorflow', 'tfjs-tflite');

const PACK = 'objectron_solution_packed_assets.data';
const LOADER = 'objectron_solution_packed_assets_loader.js';
export const MODEL_FILE = '/third_party/mediapipe/modules/objectron/object_detection_ssd_mobilenetv2_oidv4_fp16.tflite';
export const LABELS_FILE = '/object_detection_oidv4_labelmap.txt';
/** SHA-256 of object_detection_ssd_mobilenetv2_oidv4_fp16.tflite as MediaPipe publishes it. */
export const MODEL_SHA256 = 'd0a5255bf8c4f5a0bc4240741a76c41d5e939f7655078f945f50ab53a9375da6';
export const NUM_CLASSES = 24;
/** The TFLite runtime builds served: the threaded ones need a cross-origin isolated page. */
export const RUNTIME_FILES = ['tflite_web_api_cc.js', 'tflite_web_api_cc.wasm', 'tflite_web_api_cc_simd.js', 'tflite_web_api_cc_simd.wasm'];
/** The build folder of everything only the SSD detector loads (cached on first use, not precached). */
export const SSD_DIR = 'ssd/';
/** tfjs-tflite's ES module build (its `module` entry imports a file the package lacks). */
export const TFLITE_ENTRY = '@tensorflow/tfjs-tflite/dist/tf-tflite.fesm.js';

/**
 * The file table of an Emscripten packed-assets loader: the JSON argument of `loadPackage(...)`.
 * @param {string} loaderJs
 * @returns {{ files: Array<{ filename: string, start: number, end: number }>, remote_package_size: number }}
 */
export function packedIndex(loaderJs) {
  const m = /loadPackage\((\{"files":.*?\})\)/s.exec(loaderJs);
  if (!m) throw new Error('packed-assets loader: no loadPackage({...}) file table');
  const index = JSON.parse(m[1]);
  if (!Array.isArray(index.files)) throw new Error('packed-assets loader: "files" is not a list');
  return index;
}

/**
 * The model and labels cut out of a packed-assets file, checked.
 * @param {Uint8Array} data the .data file
 * @param {string} loaderJs its loader script
 * @param {{ sha256?: string | null }} [opts] expected model hash (null: do not check)
 */
export function unpackSsd(data, loaderJs, { sha256 = MODEL_SHA256 } = {}) {
  const index = packedIndex(loaderJs);
  if (index.remote_package_size !== data.length) {
    throw new Error(`packed assets: ${data.length} bytes, the loader expects ${index.remote_package_size}`);
  }
  const entry = (/** @type {string} */ name) => {
    const f = index.files.find((e) => e.filename === name);
    if (!f) throw new Error(`packed assets: no ${name}`);
    if (!(Number.isInteger(f.start) && Number.isInteger(f.end) && 0 <= f.start && f.start < f.end && f.end <= data.length)) {
      throw new Error(`packed assets: bad range ${f.start}…${f.end} for ${name}`);
    }
    return { start: f.start, end: f.end };
  };
  const modelRange = entry(MODEL_FILE);
  const labelsRange = entry(LABELS_FILE);
  const model = data.subarray(modelRange.start, modelRange.end);
  // A TFLite flatbuffer: the root-table offset (4 bytes), then the file identifier "TFL3".
  const magic = String.fromCharCode(...model.subarray(4, 8));
  if (magic !== 'TFL3') throw new Error(`packed assets: the model has no TFL3 identifier (found ${JSON.stringify(magic)})`);
  const hash = createHash('sha256').update(model).digest('hex');
  if (sha256 && hash !== sha256) throw new Error(`packed assets: model SHA-256 ${hash}, expected ${sha256}`);
  const labelsText = new TextDecoder().decode(data.subarray(labelsRange.start, labelsRange.end));
  const labels = labelsText.replace(/\r\n?/g, '\n').split('\n');
  if (labels.at(-1) === '') labels.pop();
  if (labels.length !== NUM_CLASSES || labels[0] !== '???') {
    throw new Error(`packed assets: expected ${NUM_CLASSES} labels starting with the background "???", got ${labels.length}`);
  }
  return { model, modelRange, labelsText, labels, labelsRange, sha256: hash };
}

/** The licence field of an installed package (the weights ship under it: no separate licence). */
export function packageLicense(dir) {
  return JSON.parse(readFileSync(join(dir, 'package.json'), 'utf8')).license;
}

/** The SSD model and labels from the installed @mediapipe/objectron, checked (licence too). */
export function extractSsd(dir = OBJECTRON) {
  if (!existsSync(join(dir, PACK))) {
    throw new Error(`${join(dir, PACK)} is missing: run npm install (the SSD detector's weights come from @mediapipe/objectron)`);
  }
  const license = packageLicense(dir);
  if (license !== 'Apache-2.0') throw new Error(`@mediapipe/objectron is licensed ${JSON.stringify(license)}: its weights stay out`);
  const ssd = unpackSsd(readFileSync(join(dir, PACK)), readFileSync(join(dir, LOADER), 'utf8'));
  return { ...ssd, license };
}

const VIRTUAL = 'virtual:shapetrack-ssd';
const RESOLVED = `\0${VIRTUAL}`;
const DEV_PREFIX = '/@shapetrack-ssd/';

/**
 * The Vite plugin serving the SSD detector's files to the tracker worker.
 *
 * Use one instance in `plugins` (dev server) and one with `{ worker: true }` in
 * `worker.plugins`. In a build only the worker's instance emits the files and loads tfjs-tflite;
 * the page's copy of the module is a stub (the page lists the detector, never runs it), so the
 * runtime is bundled once, under SSD_DIR with the rest.
 * @param {{ worker?: boolean }} [opts]
 * @returns {import('vite').Plugin}
 */
export function ssdModel({ worker = false } = {}) {
  let command = 'serve';
  /** @type {ReturnType<typeof extractSsd> | null} */
  let ssd = null;
  const load = () => (ssd ??= extractSsd());
  return {
    name: 'shapetrack-ssd-model',
    configResolved(config) {
      command = config.command;
    },
    resolveId(id) {
      return id === VIRTUAL ? RESOLVED : null;
    },
    // The worker's chunk of this module (tfjs-tflite and tfjs-core, ~1.3 MB) goes with the
    // other SSD files.
    outputOptions(opts) {
      if (!worker || command !== 'build') return null;
      const given = opts.chunkFileNames;
      return {
        ...opts,
        chunkFileNames: (chunk) => {
          if (chunk.facadeModuleId === RESOLVED) return `${SSD_DIR}runtime-[hash].js`;
          if (typeof given === 'function') return given(chunk);
          return given ?? 'assets/[name]-[hash].js';
        },
      };
    },
    // tfjs-tflite's Closure bundle carries a `goog.loadModuleFromSource` with a direct eval it
    // never reaches here; the bundler's warning about it is noise.
    onLog(_level, log) {
      if (log.code === 'EVAL' && (log.id ?? '').includes('tfjs-tflite')) return false;
      return undefined;
    },
    load(id) {
      if (id !== RESOLVED) return null;
      const api = `export { setWasmPath, getWasmFeatures, loadTFLiteModel } from ${JSON.stringify(TFLITE_ENTRY)};\n`;
      if (command === 'serve') {
        return (
          api +
          `export const modelUrl = ${JSON.stringify(`${DEV_PREFIX}model.tflite`)};\n` +
          `export const labelsUrl = ${JSON.stringify(`${DEV_PREFIX}labels.txt`)};\n` +
          `export const runtimeUrl = ${JSON.stringify(`${DEV_PREFIX}tflite/`)};\n`
        );
      }
      if (!worker) {
        const stub = `() => { throw new Error('the SSD runtime runs in the tracker worker only'); }`;
        return (
          `export const modelUrl = '';\nexport const labelsUrl = '';\nexport const runtimeUrl = '';\n` +
          `export const setWasmPath = ${stub};\nexport const getWasmFeatures = ${stub};\nexport const loadTFLiteModel = ${stub};\n`
        );
      }
      const s = load();
      const short = (/** @type {Uint8Array | string} */ b) => createHash('sha256').update(b).digest('hex').slice(0, 10);
      const model = this.emitFile({ type: 'asset', fileName: `${SSD_DIR}ssd-mobilenetv2-oidv4-${short(s.model)}.tflite`, source: s.model });
      const labels = this.emitFile({ type: 'asset', fileName: `${SSD_DIR}ssd-oidv4-labels-${short(s.labelsText)}.txt`, source: s.labelsText });
      // Fixed names in one folder: the runtime's loader builds the file names itself.
      const runtime = RUNTIME_FILES.map((f) =>
        this.emitFile({ type: 'asset', fileName: `${SSD_DIR}tflite/${f}`, source: readFileSync(join(TFLITE, 'wasm', f)) }),
      );
      return (
        api +
        `export const modelUrl = import.meta.ROLLUP_FILE_URL_${model};\n` +
        `export const labelsUrl = import.meta.ROLLUP_FILE_URL_${labels};\n` +
        `export const runtimeUrl = new URL('./', import.meta.ROLLUP_FILE_URL_${runtime[0]}).href;\n`
      );
    },
    configureServer(server) {
      server.middlewares.use((req, res, next) => {
        const path = (req.url ?? '').split('?')[0];
        if (!path.startsWith(DEV_PREFIX)) return next();
        const name = path.slice(DEV_PREFIX.length);
        /** @type {Uint8Array | string | null} */
        let body = null;
        let type = 'application/octet-stream';
        try {
          if (name === 'model.tflite') body = load().model;
          else if (name === 'labels.txt') {
            body = load().labelsText;
            type = 'text/plain; charset=utf-8';
          } else if (name.startsWith('tflite/') && RUNTIME_FILES.includes(name.slice('tflite/'.length))) {
            body = readFileSync(join(TFLITE, 'wasm', name.slice('tflite/'.length)));
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
    const s = extractSsd();
    const tfl = packageLicense(TFLITE);
    console.log(`@mediapipe/objectron ${JSON.parse(readFileSync(join(OBJECTRON, 'package.json'), 'utf8')).version} (${s.license}), ${PACK}:`);
    console.log(`  labels  bytes ${s.labelsRange.start}…${s.labelsRange.end}: ${s.labels.length} classes (${s.labels.slice(1).join(', ')})`);
    console.log(`  model   bytes ${s.modelRange.start}…${s.modelRange.end} (${s.model.length} bytes, TFL3, sha256 ${s.sha256})`);
    console.log(`@tensorflow/tfjs-tflite (${tfl}): runtime ${RUNTIME_FILES.join(', ')}`);
    const at = process.argv.indexOf('--out');
    if (at > 0) {
      const out = process.argv[at + 1];
      if (!out) throw new Error('--out needs a folder');
      mkdirSync(out, { recursive: true });
      writeFileSync(join(out, 'model.tflite'), s.model);
      writeFileSync(join(out, 'labels.txt'), s.labelsText);
      console.log(`wrote ${join(out, 'model.tflite')} and labels.txt`);
    }
  } catch (e) {
    console.error(`models: ${e instanceof Error ? e.message : e}`);
    process.exit(1);
  }
}
