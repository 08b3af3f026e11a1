// What the service worker installs and what it caches on first use (scripts/vite-sw.mjs): the
// SSD folder stays out of the install, and each set's version follows only its own files.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { splitBundle } from '../../scripts/vite-sw.mjs';
import { SSD_DIR } from '../../scripts/models.mjs';

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
