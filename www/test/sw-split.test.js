// What the service worker installs and what it caches on first use (scripts/vite-sw.mjs): the
// SSD and segmenter folders stay out of the install, and each set's version (each lazy
// folder's too) follows only its own files.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { splitBundle } from '../../scripts/vite-sw.mjs';
import { SSD_DIR } from '../../scripts/models.mjs';
import { SEG_DIR } from '../../scripts/segmenter-model.mjs';

/** @param {Record<string, string>} files name → content @returns {any} */
const bundle = (files) =>
  Object.fromEntries(
    Object.entries(files).map(([name, text]) =>
      name.endsWith('.js') ? [name, { type: 'chunk', code: text }] : [name, { type: 'asset', source: new TextEncoder().encode(text) }],
    ),
  );

const APP = {
  'index.html': '<html>',
  'assets/index-a.js': 'app',
  'assets/worker-b.js': 'worker',
  'assets/shapetrack_bg-c.wasm': 'wasm',
  'assets/index-a.js.map': 'map',
  [`${SSD_DIR}model-d.tflite`]: 'weights',
  [`${SSD_DIR}runtime-e.js`]: 'tflite js',
  [`${SSD_DIR}tflite/tflite_web_api_cc.wasm`]: 'runtime',
};

test('the SSD folder is cached on demand, the rest precached (source maps neither)', () => {
  const s = splitBundle(bundle(APP), [SSD_DIR]);
  assert.deepEqual(s.precache, ['assets/index-a.js', 'assets/shapetrack_bg-c.wasm', 'assets/worker-b.js', 'index.html']);
  assert.deepEqual(s.onDemand, [`${SSD_DIR}model-d.tflite`, `${SSD_DIR}runtime-e.js`, `${SSD_DIR}tflite/tflite_web_api_cc.wasm`]);
  assert.match(s.version, /^[0-9a-f]{12}$/);
  assert.notEqual(s.version, s.lazyVersion);
});

test('an app change keeps the SSD cache; a runtime change (fixed name, new bytes) replaces it', () => {
  const base = splitBundle(bundle(APP), [SSD_DIR]);
  const app = splitBundle(bundle({ ...APP, 'assets/index-a.js': 'app v2' }), [SSD_DIR]);
  assert.notEqual(app.version, base.version);
  assert.equal(app.lazyVersion, base.lazyVersion);
  const rt = splitBundle(bundle({ ...APP, [`${SSD_DIR}tflite/tflite_web_api_cc.wasm`]: 'runtime v2' }), [SSD_DIR]);
  assert.equal(rt.version, base.version);
  assert.notEqual(rt.lazyVersion, base.lazyVersion);
});

test('each lazy folder has its own version: a new segmenter model keeps the SSD cache', () => {
  const files = { ...APP, [`${SEG_DIR}u2netp-f.onnx`]: 'seg weights', [`${SEG_DIR}ort-g.wasm`]: 'ort' };
  const base = splitBundle(bundle(files), [SSD_DIR, SEG_DIR]);
  assert.deepEqual(base.onDemand.filter((f) => f.startsWith(SEG_DIR)), [`${SEG_DIR}ort-g.wasm`, `${SEG_DIR}u2netp-f.onnx`]);
  assert.ok(!base.precache.some((f) => f.startsWith(SEG_DIR)));
  assert.deepEqual(Object.keys(base.lazyVersions), [SSD_DIR, SEG_DIR]);
  assert.notEqual(base.lazyVersions[SSD_DIR], base.lazyVersions[SEG_DIR]);
  const seg = splitBundle(bundle({ ...files, [`${SEG_DIR}u2netp-f.onnx`]: 'seg weights v2' }), [SSD_DIR, SEG_DIR]);
  assert.equal(seg.version, base.version);
  assert.equal(seg.lazyVersions[SSD_DIR], base.lazyVersions[SSD_DIR]);
  assert.notEqual(seg.lazyVersions[SEG_DIR], base.lazyVersions[SEG_DIR]);
  // The SSD's folder alone versions as before the segmenter's existed.
  assert.equal(base.lazyVersions[SSD_DIR], splitBundle(bundle(APP), [SSD_DIR]).lazyVersion);
});
