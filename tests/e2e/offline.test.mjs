// Offline: after one visit the service worker serves the whole app (shell, JS, worker, wasm)
// with the network off, and the app still works: it imports, draws masks and exports through
// the wasm core. MOTS masks also round-trip byte for byte. The install precaches the app, not the
// SSD detector's 19 MB nor the learned segmenter's 19 MB (cached on first use instead, see
// ssd.test.mjs and segmenter.test.mjs). The page is cross-origin isolated online and offline.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync, readdirSync, statSync } from 'node:fs';
import { join } from 'node:path';
import { DIST, OUT, watchErrors, withApp } from './harness.mjs';

const PORT = 47392;


const app = withApp({ port: PORT });

/**
 * COCO RLE of a full-image bitmap, compressed as pycocotools' rleToString — written here from
 * the format's definition so the test does not trust the code it checks.
 * @param {number} w
 * @param {number} h
 * @param {(x: number, y: number) => boolean} inside
 */
function cocoRle(w, h, inside) {
  const counts = [];
  let prev = false;
  let run = 0;
  for (let x = 0; x < w; x++) {
    for (let y = 0; y < h; y++) {
      const v = inside(x, y);
      if (v !== prev) {
        counts.push(run);
        run = 0;
        prev = v;
      }
      run++;
    }
  }
  counts.push(run);
  let s = '';
  for (let i = 0; i < counts.length; i++) {
    let x = counts[i];
    if (i > 2) x -= counts[i - 2];
    for (;;) {
      let c = x & 0x1f;
      x >>= 5;
      const more = c & 0x10 ? x !== -1 : x !== 0;
      if (more) c |= 0x20;
      s += String.fromCharCode(c + 48);
      if (!more) break;
    }
  }
  return s;
}

/** A MOTS file: two discs moving right over 5 frames of 160×120. */
function motsFile() {
  const [w, h] = [160, 120];
  const lines = [];
  for (let f = 1; f <= 5; f++) {
    for (const [id, cy] of [
      [1, 40],
      [2, 85],
    ]) {
      const cx = 20 + f * 10 + id * 30;
      const rle = cocoRle(w, h, (x, y) => (x - cx) ** 2 + (y - cy) ** 2 <= 12 ** 2);
      lines.push(`${f} ${id} 2 ${h} ${w} ${rle}`);
    }
  }
  return lines.join('\n') + '\n';
}

test('after one visit the app loads, imports, draws and exports with the network off', async () => {
  const page = await app.browser.context.newPage();
  const errors = watchErrors(page);
  await page.goto(`${app.server.url}?demo=0`);
  await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
  // The first visit installs the service worker; wait until it controls the page.
  await page.evaluate(async () => {
    await navigator.serviceWorker.ready;
    if (!navigator.serviceWorker.controller) {
      await new Promise((r) => navigator.serviceWorker.addEventListener('controllerchange', r, { once: true }));
    }
  });
  await app.server.quiet();
  const served = app.server.log.length;
  await app.browser.context.setOffline(true);
  try {
    await page.reload();
    await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
    assert.deepEqual(app.server.appRequests(served), [], 'nothing reached the server while offline');
    // The shell came from the cache with the headers it was fetched with.
    assert.equal(await page.evaluate(() => crossOriginIsolated), true, 'cross-origin isolated offline');

    const mots = motsFile();
    await page.setInputFiles('#file-import', { name: 'discs.txt', mimeType: 'text/plain', buffer: Buffer.from(mots) });
    await page.waitForFunction(() => /** @type {any} */ (window).__shapetrack.state().ids.length === 2);
    const st = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.state());
    assert.deepEqual(st.ids, [1, 2]);
    assert.equal(st.source, null);

    // The masks are drawn (views redraw on the next animation frame): the overlay is coloured
    // at a disc centre and clear far from both.
    await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => r(undefined))));
    const px = await page.evaluate(() => {
      const c = /** @type {HTMLCanvasElement} */ (document.getElementById('overlay'));
      const ctx = /** @type {CanvasRenderingContext2D} */ (c.getContext('2d'));
      // The overlay has screen resolution: map image pixels through its scale (160 wide).
      const k = c.width / 160;
      const at = (/** @type {number} */ x, /** @type {number} */ y) => [...ctx.getImageData(Math.round(x * k), Math.round(y * k), 1, 1).data];
      // Frame 1: disc 1 centred at (60, 40).
      return { on: at(60, 40), off: at(150, 110) };
    });
    assert.ok(px.on[3] > 0, `mask pixel drawn (${px.on})`);
    assert.equal(px.off[3], 0);

    await page.selectOption('#export-format', 'mots');
    const [download] = await Promise.all([page.waitForEvent('download'), page.click('#export')]);
    assert.equal(readFileSync(await download.path(), 'utf8'), mots, 'MOTS round-trips byte for byte');
    await page.screenshot({ path: join(OUT, 'offline.png') });
  } finally {
    await app.browser.context.setOffline(false);
  }
  assert.deepEqual(errors, []);
  await page.close();
});

test('the install precaches the app shell, the bench page and the wasm, not the SSD detector\'s or the segmenter\'s files', () => {
  const code = readFileSync(join(DIST, 'sw.js'), 'utf8');
  const list = (/** @type {string} */ name) => {
    const m = new RegExp(`const ${name} = .*?JSON\\.parse\\((".*?")\\)`).exec(code);
    assert.ok(m, `${name} in sw.js`);
    return /** @type {string[]} */ (JSON.parse(JSON.parse(m[1])));
  };
  const precache = list('PRECACHE');
  assert.deepEqual(list('LAZY'), ['ssd/', 'seg/']);
  for (const want of [/^\.\/$/, /^assets\/index-.+\.js$/, /^assets\/worker-.+\.js$/, /^assets\/shapetrack_bg-.+\.wasm$/, /^bench\.html$/, /^assets\/bench-.+\.js$/]) {
    assert.ok(precache.some((f) => want.test(f)), `${want} precached: ${precache}`);
  }
  assert.ok(!precache.some((f) => f.startsWith('ssd/') || f.endsWith('.tflite') || f.includes('tflite_web_api')), `${precache}`);
  assert.ok(!precache.some((f) => f.startsWith('seg/') || f.endsWith('.onnx') || f.includes('ort-wasm')), `${precache}`);
  // The build does have the SSD files, under ssd/: left out, not missing.
  const ssd = readdirSync(join(DIST, 'ssd'), { recursive: true }).map(String);
  assert.ok(ssd.some((f) => f.endsWith('.tflite')) && ssd.some((f) => f.endsWith('.wasm')), `${ssd}`);
  const seg = readdirSync(join(DIST, 'seg')).map(String);
  assert.ok(seg.some((f) => f.endsWith('.onnx')) && seg.some((f) => f.endsWith('.wasm')) && seg.some((f) => f.endsWith('.mjs')), `${seg}`);
  const bytes = precache.filter((f) => f !== './').reduce((n, f) => n + statSync(join(DIST, f)).size, 0);
  assert.ok(bytes < 3_000_000, `install downloads ${bytes} bytes`);
});

test('no request left localhost', () => {
  assert.deepEqual(app.browser.foreign, []);
});
