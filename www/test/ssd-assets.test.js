// Where the SSD detector's weights come from: the file table of @mediapipe/objectron's packed
// assets, the checks made while cutting the model and labels out (on a synthetic pack), and the
// installed package itself (offsets, TFL3 identifier, hash, labels, licence).

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { createHash } from 'node:crypto';
import { existsSync } from 'node:fs';
import { join } from 'node:path';
import {
  LABELS_FILE,
  MODEL_FILE,
  MODEL_SHA256,
  OBJECTRON,
  RUNTIME_FILES,
  TFLITE,
  extractSsd,
  packageLicense,
  packedIndex,
  unpackSsd,
} from '../../scripts/models.mjs';

const LABELS = ['???', ...Array.from({ length: 23 }, (_, i) => `class${i + 1}`)].join('\n') + '\n';

/** A packed-assets file and its loader: labels first, then a fake flatbuffer. */
function pack({ magic = 'TFL3', labels = LABELS, size = 0 } = {}) {
  const l = Buffer.from(labels);
  const m = Buffer.concat([Buffer.from([0x18, 0, 0, 0]), Buffer.from(magic), Buffer.alloc(24, 7)]);
  const data = Buffer.concat([l, m]);
  const table = {
    files: [
      { filename: LABELS_FILE, start: 0, end: l.length },
      { filename: MODEL_FILE, start: l.length, end: data.length },
    ],
    remote_package_size: size || data.length,
  };
  const loader = `var Module;(function(){function loadPackage(metadata){}\nloadPackage(${JSON.stringify(table)})})();`;
  return { data, loader, model: m, sha: createHash('sha256').update(m).digest('hex') };
}

test('packedIndex reads the loader file table', () => {
  const { loader } = pack();
  const index = packedIndex(loader);
  assert.deepEqual(
    index.files.map((f) => f.filename),
    [LABELS_FILE, MODEL_FILE],
  );
  assert.throws(() => packedIndex('nothing here'), /no loadPackage/);
});

test('unpackSsd cuts out the model and labels and checks them', () => {
  const p = pack();
  const s = unpackSsd(p.data, p.loader, { sha256: p.sha });
  assert.deepEqual(Buffer.from(s.model), p.model);
  assert.equal(s.labels.length, 24);
  assert.equal(s.labels[23], 'class23');
  assert.deepEqual(s.modelRange, { start: LABELS.length, end: p.data.length });
  assert.throws(() => unpackSsd(p.data, p.loader), /SHA-256/, 'the pinned hash is checked by default');
  const bad = pack({ magic: 'TFL2' });
  assert.throws(() => unpackSsd(bad.data, bad.loader, { sha256: null }), /TFL3/);
  const short = pack({ labels: '???\nCar\n' });
  assert.throws(() => unpackSsd(short.data, short.loader, { sha256: null }), /24 labels/);
  const sized = pack({ size: 5 });
  assert.throws(() => unpackSsd(sized.data, sized.loader, { sha256: null }), /loader expects 5/);
});

test('the installed @mediapipe/objectron: labels at 0…184, the model at 184…9,987,912, Apache-2.0', (t) => {
  // Throws "... is missing: run npm install" when the package is not installed.
  const s = extractSsd(OBJECTRON);
  assert.deepEqual(s.labelsRange, { start: 0, end: 184 });
  assert.deepEqual(s.modelRange, { start: 184, end: 9_987_912 });
  assert.equal(s.sha256, MODEL_SHA256);
  assert.equal(s.license, 'Apache-2.0');
  assert.deepEqual(
    ['Person', 'Car', 'Bicycle', 'Dog'].map((n) => s.labels.indexOf(n)),
    [4, 23, 1, 20],
  );
  assert.equal(packageLicense(TFLITE), 'Apache-2.0');
  for (const f of RUNTIME_FILES) assert.ok(existsSync(join(TFLITE, 'wasm', f)), f);
  t.diagnostic(`model ${s.model.length} bytes, sha256 ${s.sha256}`);
});

test("tfjs-tflite's feature check and load see no SharedArrayBuffer (the app is cross-origin isolated, its threaded runtime not shipped), and only while they run", async () => {
  const { withoutSharedMemory } = await import('../src/worker/detectors/ssd.js');
  /** @type {unknown[]} */
  const seen = [];
  /** What tfjs-tflite's check does, synchronously, at any point of the load. */
  const threaded = () => {
    try {
      new SharedArrayBuffer(1);
      return true;
    } catch {
      return false;
    }
  };
  const features = await withoutSharedMemory(async () => {
    seen.push(threaded());
    await null;
    // A later check (the loader's own, after awaits) sees the same.
    await new Promise((r) => setTimeout(r, 5));
    seen.push(threaded());
    return { simd: true, multiThreading: threaded() };
  });
  assert.deepEqual(features, { simd: true, multiThreading: false });
  assert.deepEqual(seen, [false, false], 'hidden across the awaits of the load');
  assert.equal(typeof SharedArrayBuffer, 'function', 'back once it settled');
  // A failing load puts it back too.
  await assert.rejects(
    withoutSharedMemory(async () => {
      await null;
      throw new Error('boom');
    }),
    /boom/,
  );
  assert.equal(typeof SharedArrayBuffer, 'function');
});

test("the TFLite loader's importScripts stand-in runs the fetched script, for its threaded name too, and reports its own failure over the loader's", async () => {
  const { withImportScripts } = await import('../src/worker/detectors/ssd.js');
  const g = /** @type {any} */ (globalThis);
  const hadSelf = 'self' in g;
  if (!hadSelf) g.self = { location: { href: 'http://app.test/assets/worker.js' } };
  try {
    const url = 'http://app.test/ssd/tflite/tflite_web_api_cc_simd.js';
    const code = 'exports.tflite_web_api_ModuleFactory = () => "runtime";';
    for (const asked of [url, '../ssd/tflite/tflite_web_api_cc_simd_threaded.js']) {
      const factory = await withImportScripts(url, code, async () => {
        g.importScripts(asked);
        return g.tflite_web_api_ModuleFactory();
      });
      assert.equal(factory, 'runtime', asked);
      assert.equal(typeof g.importScripts, 'undefined', 'the stand-in is gone after the load');
      delete g.tflite_web_api_ModuleFactory;
    }
    // Another script: refused, and the loader's later failure reported as the stand-in's.
    await assert.rejects(
      withImportScripts(url, code, async () => {
        try {
          g.importScripts('http://app.test/elsewhere.js');
        } catch {
          // tfjs-tflite swallows it and fails later on `undefined._malloc`
        }
        throw new TypeError("Cannot read properties of undefined (reading '_malloc')");
      }),
      /SSD detector: its runtime script did not load: importScripts\(http:\/\/app.test\/elsewhere.js\): not the TFLite runtime/,
    );
  } finally {
    if (!hadSelf) delete g.self;
  }
});

test('a failure to fetch the SSD files is said plainly; other failures pass unchanged', async () => {
  const { plainLoadError } = await import('../src/worker/detectors/ssd.js');
  const raw = new TypeError('Failed to fetch dynamically imported module: http://127.0.0.1/assets/ssd-runtime-x.js');
  const plain = /** @type {Error} */ (plainLoadError(raw));
  assert.match(plain.message, /could not fetch its files .*only once it has run online/);
  assert.equal(plain.cause, raw);
  for (const m of ['Failed to fetch', 'NetworkError when attempting to fetch resource.', 'http://x/ssd/model.tflite: HTTP 504']) {
    assert.notEqual(plainLoadError(new Error(m)), undefined);
    assert.match(/** @type {Error} */ (plainLoadError(new Error(m))).message, /only once it has run online/, m);
  }
  const other = new Error('SSD detector: unexpected model input 1,300,300,3 uint8');
  assert.equal(plainLoadError(other), other);
});

test('the SSD class filter: names in any case, none means all, an unknown name is an error naming it', async () => {
  const { keptClasses } = await import('../src/worker/detectors/ssd.js');
  const labels = ['', 'Person', 'Car', 'Footwear'];
  assert.equal(keptClasses(labels, undefined), null);
  assert.equal(keptClasses(labels, [' ', '']), null);
  assert.deepEqual([...(keptClasses(labels, ['person', ' CAR ']) ?? [])].sort(), [1, 2]);
  assert.throws(() => keptClasses(labels, ['unicorn']), /no class "unicorn"/);
});

test('withMinFrames sets the tracker\'s confirmation count at any frame rate, and refuses what it cannot take', async () => {
  const { withMinFrames, SSD_TRACKER, MAX_MIN_FRAMES } = await import('../src/worker/detectors/ssd.js');
  assert.equal(withMinFrames(SSD_TRACKER, undefined), SSD_TRACKER, 'unset: the detector\'s own settings');
  assert.deepEqual(withMinFrames(SSD_TRACKER, 12), { ...SSD_TRACKER, min_hits: 12, min_hits_floor: 12 });
  assert.deepEqual(withMinFrames({ preset: 'masks' }, 1), { preset: 'masks', min_hits: 1, min_hits_floor: 1 });
  for (const bad of [0, -3, 2.5, Number.NaN, MAX_MIN_FRAMES + 1]) {
    assert.throws(() => withMinFrames(SSD_TRACKER, bad), /minFrames must be a whole number from 1 to 1000/, String(bad));
  }
});
