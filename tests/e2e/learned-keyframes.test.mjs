// The automatic detector with the learned stage (issue 63, `?learned=keyframes`) on a
// moving-camera clip, DAVIS-2016 camel (854×480, 90 frames, played twice over), with the network off after a
// first visit: the segmenter's files come from the service worker's cache, keyframes are
// segmented in the background while the frames go on, and their learned masks replace the
// detector's on the next frames (the page counts them). Nothing reaches the server offline.
// The frames are stepped one at a time, waiting while a keyframe runs, until the first lands,
// then played: a keyframe takes several seconds on this 2-core machine, longer than the whole
// clip takes to track, and its masks are taken only a frame or two after their own.
// Speed is not judged here (scripts/bench-segmenter.mjs --tracker measures fps per policy).

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync, readdirSync } from 'node:fs';
import { join } from 'node:path';
import { ROOT, untilState, watchErrors, withApp } from './harness.mjs';

const PORT = 47435;
const JPEG = join(ROOT, '..', 'shared', 'data', 'davis2016-moving', 'DAVIS', 'JPEGImages', '480p', 'camel');

const app = withApp({ port: PORT });

/**
 * The clip played twice over as one sequence (a cut at the restart): room for a slow
 * keyframe on a busy machine before the frames run out.
 */
const frames = () => {
  const one = readdirSync(JPEG)
    .filter((f) => f.endsWith('.jpg'))
    .sort()
    .map((f) => readFileSync(join(JPEG, f)));
  return [0, 1].flatMap((k) => one.map((buffer, i) => ({ name: `${k}-${String(i).padStart(5, '0')}.jpg`, mimeType: 'image/jpeg', buffer })));
};

/**
 * Opens the clip in `page` with the learned stage on; frame 1 tracked, paused.
 * @param {import('playwright-core').Page} page
 */
async function openClip(page) {
  await page.goto(`${app.server.url}?demo=0&speed=max&learned=keyframes`);
  await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
  assert.equal(await page.isChecked('#det-learned'), true);
  await page.setInputFiles('#file-images', frames());
  await untilState(page, (s) => s.processed >= 1 && !s.playing, 120_000);
}

/**
 * Steps frame by frame (a pause between frames) until a keyframe's result is in, then plays
 * to the end; returns the final state.
 * @param {import('playwright-core').Page} page
 */
async function trackWithKeyframe(page) {
  const deadline = Date.now() + 240_000;
  for (;;) {
    const s = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.state());
    assert.equal(s.learned.failed, null, 'the learned stage runs');
    if (s.learned.keyframes >= 1) break;
    assert.ok(s.processed < s.frames - 20, `a keyframe landed before frame ${s.frames - 20} (state ${JSON.stringify(s.learned)})`);
    assert.ok(Date.now() < deadline, 'a keyframe within 4 minutes');
    // While a keyframe runs (as of the last frame) the clip waits for it before the next
    // frame: its masks replace the detector's only a frame or two after their own
    // (`REPLACE_AGE`), and on this machine one takes seconds.
    await page.waitForTimeout(s.learned.running ? 6000 : 400);
    await page.evaluate(() => /** @type {any} */ (window).__shapetrack.app.stepForward());
  }
  await page.keyboard.press('Space');
  return untilState(page, (s) => s.processed === s.frames && !s.playing, 180_000);
}

test('a moving-camera clip gets learned masks with the network off after a first visit', async () => {
  // First visit, online: the service worker takes control; the learned stage fetches the
  // segmenter's files (cached by the service worker on their way).
  const first = await app.browser.context.newPage();
  const errors = watchErrors(first);
  await openClip(first);
  await first.evaluate(async () => {
    await navigator.serviceWorker.ready;
    if (!navigator.serviceWorker.controller) {
      await new Promise((r) => navigator.serviceWorker.addEventListener('controllerchange', r, { once: true }));
    }
  });
  const online = await trackWithKeyframe(first);
  console.log(`online: ${JSON.stringify(online.learned)}`);
  const cached = await first.evaluate(async () => {
    for (const name of await caches.keys()) {
      for (const r of await (await caches.open(name)).keys()) if (r.url.endsWith('.onnx')) return true;
    }
    return false;
  });
  assert.ok(cached, 'the model is in the service worker cache');
  await first.close();

  // Offline: a new visit loads the app, the net and the clip from the cache and the disk.
  await app.browser.context.setOffline(true);
  const page = await app.browser.context.newPage();
  watchErrors(page).forEach((e) => errors.push(e));
  try {
    const served = app.server.log.length;
    await openClip(page);
    const done = await trackWithKeyframe(page);
    console.log(`offline: ${JSON.stringify(done.learned)}, detector ${done.detectorChoice}, ${done.ids.length} ids`);
    assert.equal(done.detectorChoice, 'moving', 'the camera moves');
    assert.ok(done.learned.keyframes >= 1);
    assert.ok(done.learned.frames > 0 && done.learned.used + done.learned.added > 0, `frames took learned masks: ${JSON.stringify(done.learned)}`);
    assert.deepEqual(app.server.appRequests(served), [], 'nothing reached the server while offline');
  } finally {
    await app.browser.context.setOffline(false);
  }
  assert.deepEqual(errors, []);
  await page.close();
});
