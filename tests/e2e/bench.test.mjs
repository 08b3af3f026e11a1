// The bench page (bench.html) end to end in headless Chromium: a run at a chosen resolution
// and detector, started from the URL, reports a result row (frames per second and per-frame
// times, all finite and positive) and draws frames of that size; a second run from the form
// adds a second row; a size or detector the page cannot measure is reported as an error, not
// a crash. No speed is checked here (that is what the page measures: `node
// scripts/bench-browser.mjs --page`).

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { watchErrors, withApp } from './harness.mjs';

const PORT = 47419;

const app = withApp({ port: PORT });

/** @param {import('playwright-core').Page} page */
const bench = (page) => page.evaluate(() => /** @type {any} */ (window).__bench);

/** @param {import('playwright-core').Page} page @param {(b: any) => boolean} pred */
async function until(page, pred, timeout = 240_000) {
  const t0 = Date.now();
  for (;;) {
    const b = await bench(page);
    if (b && pred(b)) return b;
    if (Date.now() - t0 > timeout) throw new Error(`timed out; bench state: ${JSON.stringify(b)}`);
    await new Promise((r) => setTimeout(r, 100));
  }
}

test('a run from the URL reports fps and per-frame times at the size asked for', async () => {
  const page = await app.browser.context.newPage();
  const errors = watchErrors(page);
  await page.goto(`${app.server.url}bench.html?size=320x180&detector=background&frames=20&offline=0&run=1`);
  const b = await until(page, (s) => s.results.length === 1 || s.error);
  assert.equal(b.error, null);
  const r = b.results[0];
  assert.equal(r.size, '320x180');
  assert.equal(r.detector, 'background');
  assert.equal(r.frames, 20);
  assert.equal(r.offline, false);
  // Browsers coarsen performance.now() (to 0.1 ms in a page that is not cross-origin isolated),
  // so a short stage at 320x180 can have a median of exactly 0 (the page's few rectangles did,
  // in CI): the stages must be measured (finite, not negative); the whole frame and the rate
  // must be positive.
  for (const k of ['fps', 'worker']) {
    assert.ok(Number.isFinite(r[k]) && r[k] > 0, `${k} = ${r[k]}`);
  }
  for (const k of ['detect', 'track', 'page']) {
    assert.ok(Number.isFinite(r[k]) && r[k] >= 0, `${k} = ${r[k]}`);
  }
  // The worker's time holds its detect and track times.
  assert.ok(r.worker >= r.detect && r.worker >= r.track, JSON.stringify(r));
  // The frame the worker painted has the size asked for (the scene was rendered at it).
  const size = await page.evaluate(() => {
    const c = /** @type {HTMLCanvasElement} */ (document.getElementById('bench-frame'));
    return [c.width, c.height];
  });
  assert.deepEqual(size, [320, 180]);
  assert.equal(await page.locator('#bench-results tbody tr').count(), 1);

  // A second run from the form, another size: a second row.
  await page.selectOption('#bench-size', '640x480');
  await page.fill('#bench-frames', '10');
  await page.check('#bench-offline');
  await page.click('#bench-run');
  const b2 = await until(page, (s) => s.results.length === 2 || s.error);
  assert.equal(b2.error, null);
  assert.equal(b2.results[1].size, '640x480');
  assert.equal(b2.results[1].offline, true);
  assert.equal(await page.locator('#bench-results tbody tr').count(), 2);
  assert.deepEqual(errors, []);
});

test('a size or a detector the page cannot measure is an error on the page', async () => {
  const page = await app.browser.context.newPage();
  const errors = watchErrors(page);
  await page.goto(`${app.server.url}bench.html?size=8x8&frames=10&run=1`);
  const b = await until(page, (s) => s.error !== null);
  assert.match(b.error, /16\.\.=8192/);
  assert.match(await page.locator('#bench-status').innerText(), /Failed: .*8x8/);
  await page.goto(`${app.server.url}bench.html?detector=nosuch&run=1`);
  const c = await until(page, (s) => s.error !== null);
  assert.match(c.error, /unknown detector "nosuch"/);
  assert.equal(c.results.length, 0);
  assert.deepEqual(errors, []);
});
