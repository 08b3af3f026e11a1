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

test("tfjs-tflite's feature check sees no SharedArrayBuffer (the app is cross-origin isolated, its threaded runtime not shipped), and only during the call", async () => {
  const { singleThreadedFeatures } = await import('../src/worker/detectors/ssd.js');
  /** @type {unknown[]} */
  const seen = [];
  const features = await singleThreadedFeatures(async () => {
    // What tfjs-tflite's check does first, synchronously: try to make one.
    let multiThreading = true;
    try {
      new SharedArrayBuffer(1);
    } catch {
      multiThreading = false;
    }
    seen.push(typeof globalThis.SharedArrayBuffer);
    await null;
    seen.push(typeof globalThis.SharedArrayBuffer);
    return { simd: true, multiThreading };
  });
  assert.deepEqual(features, { simd: true, multiThreading: false });
  assert.deepEqual(seen, ['undefined', 'function'], 'hidden for the synchronous step, back after it');
  assert.equal(typeof SharedArrayBuffer, 'function');
  // A throwing check puts it back too.
  assert.throws(() =>
    singleThreadedFeatures(() => {
      throw new Error('boom');
    }),
  );
  assert.equal(typeof SharedArrayBuffer, 'function');
});
