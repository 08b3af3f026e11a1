// A real image sequence (VOT "bag", JPEG frames) through the page's video path: frames are
// decoded on the page, transferred to the worker as ImageBitmaps, written into wasm memory,
// detected and tracked; stepping back shows the right frame again; the result exports in all
// four formats and reads back through the core.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readdirSync, readFileSync } from 'node:fs';
import { join } from 'node:path';
import { OUT, ROOT, watchErrors, withApp } from './harness.mjs';

const PORT = 47394;
const BAG = join(ROOT, '..', 'shared', 'data', 'vot-bag');
const FRAMES = 60;


const app = withApp({ port: PORT });

test('an image sequence is tracked, stepped and exported in every format', async () => {
  const page = await app.browser.context.newPage();
  const errors = watchErrors(page);
  await page.goto(`${app.server.url}?demo=0&speed=max`);
  await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
  const files = readdirSync(BAG)
    .filter((f) => f.endsWith('.jpg'))
    .sort()
    .slice(0, FRAMES)
    .map((f) => join(BAG, f));
  assert.equal(files.length, FRAMES);
  await page.setInputFiles('#file-images', files);
  await page.waitForFunction(() => /** @type {any} */ (window).__shapetrack.state().processed >= 1);
  let st = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.state());
  assert.deepEqual(st.size, [480, 360]);
  assert.equal(st.frames, FRAMES);
  assert.equal(st.source.kind, 'images');

  await page.keyboard.press('Space');
  await page.waitForFunction((n) => /** @type {any} */ (window).__shapetrack.state().processed === n, FRAMES, { timeout: 60_000 });
  st = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.state());
  assert.equal(st.processed, FRAMES);
  // The end of the run is said, with what there is.
  await page.waitForFunction((n) => new RegExp(`^done: ${n} frames tracked, \\d+ tracks?`).test(/** @type {any} */ (window).__shapetrack.state().status), FRAMES);
  assert.ok(st.ids.length > 0, 'the background subtractor found the moving bag');

  // Step back with the keyboard: the frame shown follows.
  await page.keyboard.press('Home');
  await page.keyboard.press('ArrowRight');
  await page.keyboard.press('ArrowRight');
  await page.waitForFunction(() => /** @type {any} */ (window).__shapetrack.state().frame === 3);
  await page.screenshot({ path: join(OUT, 'images.png') });

  // Export in every format through the UI, and read each file back through the core.
  const records = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.records());
  const formats = await page.$$eval('#export-format option', (os) => os.map((o) => /** @type {HTMLOptionElement} */ (o).value));
  assert.deepEqual(formats, ['mot', 'mots', 'coco-video', 'cvat', 'scalabel', 'label-studio', 'yolo']);
  for (const format of formats) {
    await page.selectOption('#export-format', format);
    const [download] = await Promise.all([page.waitForEvent('download'), page.click('#export')]);
    // Named after the sequence, not its first file (`00000001.mot.txt` before).
    assert.match(download.suggestedFilename(), /^images\./, format);
    const text = readFileSync(await download.path(), 'utf8');
    const back = await page.evaluate(
      ([f, t]) => {
        const a = /** @type {any} */ (window).__shapetrack.app.parse(`x.${f}`, t);
        return a.records.map((/** @type {any} */ r) => [r.frame, r.id, r.bbox.x, r.bbox.y, r.bbox.w, r.bbox.h, r.interpolated ? 1 : 0]);
      },
      [format, text],
    );
    const masksOnly = ['mots', 'coco-video', 'cvat'].includes(format);
    const want = records
      .filter((/** @type {any} */ r) => !masksOnly || r.mask)
      .map((/** @type {any} */ r) => [r.frame, r.id, r.bbox.x, r.bbox.y, r.bbox.w, r.bbox.h, r.interpolated ? 1 : 0]);
    const sortKey = (/** @type {number[]} */ a, /** @type {number[]} */ b) => a[0] - b[0] || a[1] - b[1];
    back.sort(sortKey);
    want.sort(sortKey);
    // Label Studio and YOLO store boxes relative to the frame: equal up to float rounding.
    // Label Studio keeps no per-frame flag: a shape the tracker only predicted (coasted,
    // interpolated) is left to Label Studio's own interpolation between keyframes, so only
    // its presence comes back.
    assert.equal(back.length, want.length, format);
    back.forEach((/** @type {number[]} */ b, /** @type {number} */ i) => {
      const w = want[i];
      assert.deepEqual(b.slice(0, 2), w.slice(0, 2), `${format}: frame and id`);
      // The formats that can say a shape was not observed say so (Label Studio through its
      // keyframes: not for the last frame of a run, which must be a keyframe to end it).
      const runEnd = !want.some((/** @type {number[]} */ o) => o[1] === w[1] && o[0] === w[0] + 1);
      const flags = ['coco-video', 'cvat'].includes(format) || (format === 'label-studio' && !runEnd);
      if (flags) assert.equal(b[6], w[6], `${format}: frame ${w[0]} id ${w[1]} interpolated`);
      if (format === 'label-studio' && w[6]) return;
      for (let k = 2; k < 6; k++) assert.ok(Math.abs(b[k] - w[k]) < 1e-6, `${format}: frame ${w[0]} id ${w[1]}: ${b} vs ${w}`);
    });
  }
  assert.deepEqual(errors, []);
  await page.close();
});

test('offline mode tracks the whole sequence with a progress bar, then the offline pass', async (t) => {
  const page = await app.browser.context.newPage();
  const errors = watchErrors(page);
  await page.goto(`${app.server.url}?demo=0&mode=offline`);
  await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
  const files = readdirSync(BAG)
    .filter((f) => f.endsWith('.jpg'))
    .sort()
    .slice(0, FRAMES)
    .map((f) => join(BAG, f));
  await page.setInputFiles('#file-images', files);
  await page.waitForFunction(() => /** @type {any} */ (window).__shapetrack.state().processed >= 1);
  // The button shows "Run" once the first frame is in (the next render): wait for it.
  await page.locator('#play .run').waitFor({ state: 'visible', timeout: 30_000 });
  await page.click('#play');
  await page.waitForFunction(() => /** @type {any} */ (window).__shapetrack.state().finished, undefined, { timeout: 60_000 });
  const st = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.state());
  assert.equal(st.processed, FRAMES);
  assert.match(st.status, /tracks/);
  // The offline pass ran on the real frames: it never adds identities, and what it filled in
  // is in the table, flagged.
  assert.ok(st.offline, 'the offline pass ran');
  assert.ok(st.offline.ids <= st.offline.onlineIds);
  const records = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.records());
  // (The online pass coasts over single missed detections, flagging those shapes too.)
  assert.equal(records.filter((/** @type {any} */ r) => r.interpolated).length, st.offline.onlineInterpolated + st.offline.filled);
  t.diagnostic(
    `VOT bag, ${FRAMES} frames: ids ${st.offline.onlineIds} online → ${st.offline.ids} offline ` +
      `(${st.offline.joins} joins, ${st.offline.filled} filled); finish() ${st.offline.ms.toFixed(0)} ms`,
  );
  // The progress bar went to the end (frames, then the re-linker's phases) and is put away.
  const progress = await page.evaluate(() => {
    const p = /** @type {HTMLProgressElement} */ (document.getElementById('progress'));
    return { hidden: p.hidden, value: p.value, max: p.max, phase: p.dataset.phase };
  });
  assert.deepEqual(progress, { hidden: true, value: 1, max: 1, phase: 'done' });
  assert.ok(!(await page.locator('#play .run').isVisible()), 'after the run the button plays');
  // Then it plays back what was tracked.
  await page.keyboard.press('Home');
  await page.keyboard.press('Space');
  await page.waitForFunction(() => /** @type {any} */ (window).__shapetrack.state().frame > 5);
  await page.keyboard.press('Space');
  assert.deepEqual(errors, []);
  await page.close();
});

test('the demo\'s scores leave with the demo: opening one\'s own frames clears the Scores card', async () => {
  const page = await app.browser.context.newPage();
  const errors = watchErrors(page);
  await page.goto(`${app.server.url}?speed=max`);
  // The demo plays and is scored against its scene's ground truth.
  await page.waitForFunction(() => document.querySelector('#metrics-body [data-metric="MOTA"] .v')?.textContent?.match(/\d/), undefined, { timeout: 60_000 });
  assert.match(await page.locator('#metrics-src').textContent(), /scene ground truth/);
  const files = readdirSync(BAG)
    .filter((f) => f.endsWith('.jpg'))
    .sort()
    .slice(0, 5)
    .map((f) => join(BAG, f));
  await page.setInputFiles('#file-images', files);
  await page.waitForFunction(() => /** @type {any} */ (window).__shapetrack.state().source?.kind === 'images');
  await page.waitForFunction(() => /** @type {any} */ (window).__shapetrack.state().processed >= 1);
  // No ground truth for these frames: no figures, no "vs scene ground truth".
  assert.equal(await page.locator('#metrics-body [data-metric]').count(), 0, 'no scores left from the demo');
  assert.equal(await page.locator('#metrics-src').textContent(), '');
  assert.deepEqual(errors, []);
  await page.close();
});

test('a folder pick opens the folder\'s frames and names the exports after it', async () => {
  const page = await app.browser.context.newPage();
  const errors = watchErrors(page);
  await page.goto(`${app.server.url}?demo=0&speed=max`);
  await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
  assert.ok(await page.locator('#src-folder').isVisible(), 'Chromium has folder picks: the button shows');
  // The whole folder: its frames, and files that are not frames (groundtruth.txt, …), skipped.
  await page.setInputFiles('#file-folder', BAG);
  await page.waitForFunction(() => /** @type {any} */ (window).__shapetrack.state().processed >= 1);
  const st = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.state());
  assert.equal(st.source.kind, 'images');
  assert.equal(st.frames, readdirSync(BAG).filter((f) => f.endsWith('.jpg')).length);
  await page.selectOption('#export-format', 'mot');
  const [download] = await Promise.all([page.waitForEvent('download'), page.click('#export')]);
  assert.match(download.suggestedFilename(), /^vot-bag\./, 'the export is named after the folder, not "images"');
  assert.deepEqual(errors, []);
  await page.close();
});

test('at speed 1× the first play-through is paced at the source\'s frame rate', async () => {
  const page = await app.browser.context.newPage();
  const errors = watchErrors(page);
  await page.goto(`${app.server.url}?demo=0`);
  await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
  const files = readdirSync(BAG)
    .filter((f) => f.endsWith('.jpg'))
    .sort()
    .slice(0, FRAMES)
    .map((f) => join(BAG, f));
  await page.setInputFiles('#file-images', files);
  await page.waitForFunction(() => /** @type {any} */ (window).__shapetrack.state().processed >= 1);
  assert.equal(await page.inputValue('#speed'), 'realtime');
  // A slow source (a 3 fps time-lapse): any machine tracks these small frames faster than
  // that, so an unpaced first play-through shows up at any load.
  const fps = 3;
  await page.evaluate((r) => {
    /** @type {any} */ (window).__shapetrack.app.source.fps = r;
  }, fps);
  await page.keyboard.press('Space');
  await page.waitForFunction(() => /** @type {any} */ (window).__shapetrack.state().processed >= 3);
  // An upper bound on the rate (a busy machine only makes it slower: it cannot fail for want
  // of speed).
  const [a, t1] = await page.evaluate(() => [/** @type {any} */ (window).__shapetrack.state().processed, performance.now()]);
  await new Promise((r) => setTimeout(r, 2000));
  const [b, t2] = await page.evaluate(() => [/** @type {any} */ (window).__shapetrack.state().processed, performance.now()]);
  const rate = ((b - a) * 1000) / (t2 - t1);
  console.log(`paced: ${b - a} frames in ${(t2 - t1).toFixed(0)} ms (${rate.toFixed(1)} fps) from a ${fps} fps source`);
  assert.ok(b - a <= ((t2 - t1) / 1000) * fps * 1.2 + 2, `${b - a} frames in ${(t2 - t1).toFixed(0)} ms (${rate.toFixed(1)} fps) from a ${fps} fps source`);
  await page.keyboard.press('Space');
  assert.deepEqual(errors, []);
  await page.close();
});

test('no request left localhost', () => {
  assert.deepEqual(app.browser.foreign, []);
});
