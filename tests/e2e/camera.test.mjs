// The two live sources: a video file (made here with MediaRecorder from moving shapes drawn on
// a canvas, so no file ships with the tests) read frame by frame by seeking, and the webcam
// (Chromium's fake camera: a moving test pattern).

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { join } from 'node:path';
import { OUT, watchErrors, withApp } from './harness.mjs';

const PORT = 47395;


const app = withApp({ port: PORT, args: ['--use-fake-device-for-media-stream', '--use-fake-ui-for-media-stream'] });

test('a video file is read frame by frame and tracked', async () => {
  const page = await app.browser.context.newPage();
  const errors = watchErrors(page);
  await page.goto(`${app.server.url}?demo=0&speed=max`);
  await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
  // Record a WebM: 1.2 s of the empty textured background (the subtractor learns it from the
  // first 20 frames), then 2.5 s of two squares crossing it; open it as a file.
  await page.evaluate(async () => {
    const c = document.createElement('canvas');
    c.width = 320;
    c.height = 240;
    const ctx = /** @type {CanvasRenderingContext2D} */ (c.getContext('2d'));
    const rec = new MediaRecorder(c.captureStream(25), { mimeType: 'video/webm' });
    /** @type {Blob[]} */
    const parts = [];
    rec.ondataavailable = (e) => parts.push(e.data);
    const stopped = new Promise((r) => (rec.onstop = r));
    rec.start();
    const t0 = performance.now();
    await new Promise((resolve) => {
      const draw = () => {
        const t = (performance.now() - t0) / 1000;
        for (let y = 0; y < 240; y += 20)
          for (let x = 0; x < 320; x += 20) {
            ctx.fillStyle = (x + y) % 40 ? '#334' : '#445';
            ctx.fillRect(x, y, 20, 20);
          }
        const m = t - 1.2;
        if (m > 0) {
          ctx.fillStyle = '#f44';
          ctx.fillRect(20 + 90 * m, 60, 40, 40);
          ctx.fillStyle = '#4f4';
          ctx.fillRect(260 - 90 * m, 150, 40, 40);
        }
        if (t < 3.7) requestAnimationFrame(draw);
        else resolve(undefined);
      };
      draw();
    });
    rec.stop();
    await stopped;
    const file = new File(parts, 'squares.webm', { type: 'video/webm' });
    await /** @type {any} */ (window).__shapetrack.app.openVideo(file);
  });
  let st = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.state());
  assert.equal(st.source.kind, 'video');
  assert.deepEqual(st.size, [320, 240]);
  assert.ok(st.frames >= 40, `${st.frames} frames`);
  await page.keyboard.press('Space');
  await page.waitForFunction(() => {
    const s = /** @type {any} */ (window).__shapetrack.state();
    return !s.playing && s.processed === s.frames;
  }, undefined, { timeout: 60_000 });
  st = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.state());
  // Both squares are tracked from (nearly) their first frame to the end, each under one id.
  const records = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.records());
  assert.equal(new Set(records.map((/** @type {any} */ r) => r.id)).size, 2, 'one id per square');
  const first = Math.min(...records.map((/** @type {any} */ r) => r.frame));
  const perFrame = new Map();
  for (const r of records) perFrame.set(r.frame, (perFrame.get(r.frame) ?? 0) + 1);
  const span = st.frames - first + 1;
  const both = [...perFrame.values()].filter((n) => n === 2).length;
  assert.ok(both >= 0.9 * span, `two squares in ${both} of ${span} frames`);
  await page.screenshot({ path: join(OUT, 'video.png') });
  assert.deepEqual(errors, []);
  await page.close();
});

test('the webcam is tracked live', async () => {
  const page = await app.browser.context.newPage();
  const errors = watchErrors(page);
  await page.goto(`${app.server.url}?demo=0`);
  await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
  await page.click('#src-webcam');
  await page.waitForFunction(() => /** @type {any} */ (window).__shapetrack.state().processed >= 1);
  await page.keyboard.press('Space');
  await page.waitForFunction(() => /** @type {any} */ (window).__shapetrack.state().processed >= 40, undefined, { timeout: 60_000 });
  await page.keyboard.press('Space');
  const st = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.state());
  assert.equal(st.source.kind, 'webcam');
  assert.equal(st.frames, 0, 'a live source has no length');
  assert.deepEqual(errors, []);
  await page.close();
});

test('no request left localhost', () => {
  assert.deepEqual(app.browser.foreign, []);
});
