// The automatic detector on a real moving-camera clip (issue 11): DAVIS-2016 car-shadow, 40
// JPEG frames of a car filmed by a panning camera, made into a WebM in the page (MediaRecorder,
// each frame drawn for a fixed time: no video file ships with the tests) and opened the way a
// user opens a video. With nothing chosen, the app judges the camera from the first frames,
// says it moves, tracks with the moving-camera detector, and one track's mask covers the car
// (mask IoU against the DAVIS ground truth, per frame, computed here).

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readdirSync, readFileSync } from 'node:fs';
import { join } from 'node:path';
import { OUT, ROOT, watchErrors, withApp } from './harness.mjs';

const PORT = 47413;
const DAVIS = join(ROOT, '..', 'shared', 'data', 'davis-car-shadow', 'DAVIS');
const JPEG = join(DAVIS, 'JPEGImages', '480p', 'car-shadow');
const MASKS = join(DAVIS, 'Annotations', '480p', 'car-shadow');
/** How long each JPEG stays on the recorded canvas (ms): a 5 fps video, one frame per JPEG. */
const HOLD_MS = 200;
/** The car's track has mask IoU ≥ this on most of the video's frames (issue 11's acceptance). */
const IOU = 0.6;
/**
 * Measured with the dense-flow cue (2026-12-01): 34 of 39 frames on a quiet machine and 28 of
 * 33 with two CPU hogs beside Chromium (the page's realtime VP8 encoder then records fewer,
 * lower-quality frames); the first four frames are the automatic choice's (the camera is
 * judged on five). With the background-model cue it had been 19–25 of 40 quiet and 7 of 40
 * loaded, so the test asked only for 5 then. `shapetrack detect-eval` on the JPEGs
 * themselves: car-shadow J 0.751.
 */
const MOST = 0.5;
/**
 * The car's outline, not its box: the mask fills less than this share of its own box on most
 * frames where it covers the car (a filled rectangle fills all of it; the car, about 0.8).
 */
const FILL = 0.95;
/**
 * Id changes on the car allowed: none (issue 11's acceptance, one id). Before the page's
 * tracker knew the video's frame rate (it got `fps` only for the offline pass, so its online
 * counts stayed at 30 fps: a lost track kept in the main association for 8 frames, 1.6 s of
 * this 5 fps clip, and coasted as long), it handed the car from id 1 to a track lost three
 * frames earlier at frame 35 of 40 on a quiet machine, while the CLI (`--fps 5`) kept one id.
 * Measured since: one id on 3 of 3 runs of this test (the machine lightly loaded), and on a
 * recording at 400 kbit/s instead of 8 Mbit/s (blurrier frames, as a loaded machine records).
 */
const SWITCHES = 0;

const app = withApp({ port: PORT });

/** @param {string} dir @param {string} ext base64 of the folder's files, in name order */
const files = (dir, ext) =>
  readdirSync(dir)
    .filter((f) => f.endsWith(ext))
    .sort()
    .map((f) => readFileSync(join(dir, f)).toString('base64'));

test('the car-shadow clip opened as a video gets the moving-camera detector on its own and one track covers the car', async () => {
  const page = await app.browser.context.newPage();
  const errors = watchErrors(page);
  await page.goto(`${app.server.url}?demo=0&speed=max`);
  await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
  assert.equal(await page.inputValue('#detector'), 'auto', 'the automatic choice is the default');

  const jpegs = files(JPEG, '.jpg');
  const pngs = files(MASKS, '.png');
  assert.equal(jpegs.length, 40);
  assert.equal(pngs.length, 40);

  // Record the WebM: every JPEG drawn once and handed to the recorder as one frame
  // (captureStream(0) + requestFrame), then held for HOLD_MS.
  await page.evaluate(
    async ({ jpegs, hold }) => {
      const w = /** @type {any} */ (window);
      const images = await Promise.all(
        jpegs.map((b64) => createImageBitmap(new Blob([Uint8Array.from(atob(b64), (c) => c.charCodeAt(0))], { type: 'image/jpeg' }))),
      );
      const c = document.createElement('canvas');
      c.width = images[0].width;
      c.height = images[0].height;
      const ctx = /** @type {CanvasRenderingContext2D} */ (c.getContext('2d'));
      const stream = c.captureStream(0);
      const track = /** @type {any} */ (stream.getVideoTracks()[0]);
      const rec = new MediaRecorder(stream, { mimeType: 'video/webm', videoBitsPerSecond: 8_000_000 });
      /** @type {Blob[]} */
      const parts = [];
      rec.ondataavailable = (e) => parts.push(e.data);
      const stopped = new Promise((r) => (rec.onstop = r));
      rec.start();
      for (const img of [...images, images[images.length - 1]]) {
        ctx.drawImage(img, 0, 0);
        track.requestFrame();
        await new Promise((r) => setTimeout(r, hold));
      }
      rec.stop();
      await stopped;
      w.__clip = new File(parts, 'car-shadow.webm', { type: 'video/webm' });
      w.__images = images;
      await w.__shapetrack.app.openVideo(w.__clip);
    },
    { jpegs, hold: HOLD_MS },
  );
  let st = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.state());
  assert.equal(st.source.kind, 'video');
  assert.deepEqual(st.size, [854, 480]);
  await page.keyboard.press('Space');
  await page.waitForFunction(
    () => {
      const s = /** @type {any} */ (window).__shapetrack.state();
      return !s.playing && s.processed === s.frames;
    },
    undefined,
    { timeout: 600_000 },
  );
  st = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.state());
  assert.equal(st.detector, 'auto');
  assert.equal(st.detectorChoice, 'moving', `the camera pans: ${st.status}`);

  // Per frame of the video: which JPEG it shows (the recording's timing is the browser's, so
  // frames are matched by content, on 107×60 copies), and each track's mask IoU with that
  // JPEG's ground truth.
  /** @type {{ frames: number[], ious: Record<string, number[]>, fills: Record<string, number[]> }} */
  const m = await page.evaluate(async (pngs) => {
    const w = /** @type {any} */ (window);
    const a = w.__shapetrack.app;
    const [W, H] = [854, 480];
    const small = /** @type {OffscreenCanvasRenderingContext2D} */ (new OffscreenCanvas(107, 60).getContext('2d', { willReadFrequently: true }));
    /** @param {CanvasImageSource} img */
    const thumb = (img) => {
      small.drawImage(img, 0, 0, 107, 60);
      return small.getImageData(0, 0, 107, 60).data;
    };
    const thumbs = w.__images.map(thumb);
    /** @type {number[]} index of the JPEG each video frame shows */
    const frames = [];
    for (let n = 1; n <= a.session.frames; n++) {
      const bmp = await a.source.frameAt(n);
      const t = thumb(bmp);
      bmp.close();
      let best = { k: -1, d: Infinity };
      thumbs.forEach((/** @type {Uint8ClampedArray} */ u, /** @type {number} */ k) => {
        let d = 0;
        for (let i = 0; i < u.length; i += 4) d += Math.abs(u[i] - t[i]) + Math.abs(u[i + 1] - t[i + 1]) + Math.abs(u[i + 2] - t[i + 2]);
        if (d < best.d) best = { k, d };
      });
      frames.push(best.k);
    }
    /** @type {Uint8Array[]} */
    const truth = [];
    for (const b64 of pngs) {
      const bmp = await createImageBitmap(new Blob([Uint8Array.from(atob(b64), (c) => c.charCodeAt(0))], { type: 'image/png' }));
      const ctx = /** @type {OffscreenCanvasRenderingContext2D} */ (new OffscreenCanvas(W, H).getContext('2d'));
      ctx.drawImage(bmp, 0, 0);
      const d = ctx.getImageData(0, 0, W, H).data;
      const bits = new Uint8Array(W * H);
      for (let i = 0; i < bits.length; i++) bits[i] = d[4 * i] > 127 ? 1 : 0;
      truth.push(bits);
    }
    /** @type {Record<string, number[]>} */
    const ious = {};
    /** @type {Record<string, number[]>} share of its own tight box each mask fills */
    const fills = {};
    for (const id of a.model.table.ids()) {
      fills[id] = [];
      ious[id] = frames.map((k, i) => {
        const r = a.model.table.get(i + 1, id);
        if (!r?.mask) return 0;
        const mk = a.core.decodeMask(r.mask);
        let [x0, y0, x1, y1, on] = [Infinity, Infinity, -1, -1, 0];
        for (let y = 0; y < mk.height; y++)
          for (let x = 0; x < mk.width; x++)
            if (mk.data[y * mk.width + x]) {
              on++;
              x0 = Math.min(x0, x);
              x1 = Math.max(x1, x);
              y0 = Math.min(y0, y);
              y1 = Math.max(y1, y);
            }
        fills[id].push(on ? on / ((x1 - x0 + 1) * (y1 - y0 + 1)) : 1);
        const g = truth[k];
        let inter = 0;
        let area = 0;
        for (let y = 0; y < mk.height; y++)
          for (let x = 0; x < mk.width; x++)
            if (mk.data[y * mk.width + x]) {
              area++;
              inter += g[(mk.y + y) * W + mk.x + x];
            }
        let gArea = 0;
        for (let j = 0; j < g.length; j++) gArea += g[j];
        return inter / (area + gArea - inter);
      });
    }
    return { frames, ious, fills };
  }, pngs);

  const n = m.frames.length;
  console.log(`car-shadow: ${n} video frames at ${st.fps ?? '?'} fps show JPEGs ${m.frames.map((k) => k + 1).join(' ')}`);
  // The video's length comes from the app's measured frame rate, which follows the
  // recorder's timing (39 or 40 frames have been seen): the frames must show the clip in
  // order, whatever their number.
  assert.ok(m.frames.every((k, i) => i === 0 || k >= m.frames[i - 1]), 'frames in clip order');
  // The realtime recorder drops frames when both cores are busy: 39–40 distinct JPEGs on a
  // quiet machine, 32 while a wasm build and its tests ran beside this one (2026-11-29), 23
  // with two evaluation runs and two builds beside it (2026-12-06); the check is that the
  // video is the clip (in order, at least half of its frames), not how well this machine
  // recorded it: the checks below are shares of the frames it holds.
  assert.ok(new Set(m.frames).size >= 20, `the video shows the clip: ${new Set(m.frames).size} distinct JPEGs`);
  const ids = Object.keys(m.ious);
  assert.ok(ids.length > 0, 'something was tracked');
  // The car's track: the one whose masks overlap the car most over the clip.
  const total = (/** @type {string} */ id) => m.ious[id].reduce((s, v) => s + v, 0);
  const car = ids.reduce((a, b) => (total(b) > total(a) ? b : a));
  const carIous = m.ious[car];
  const line = carIous.map((v) => v.toFixed(2)).join(' ');
  for (const id of ids) console.log(`id ${id}: ${m.ious[id].map((v) => v.toFixed(2)).join(' ')}`);
  console.log(`car-shadow: detector ${st.detectorChoice}, ${ids.length} ids, car = id ${car}; mask IoU per frame: ${line}`);
  // Identity: the id covering the car (IoU ≥ 0.5) per frame; it never changes (see
  // SWITCHES) and two ids never cover the car at once.
  /** @type {string[]} */
  const owners = [];
  m.frames.forEach((_, i) => {
    const on = ids.filter((id) => m.ious[id][i] >= 0.5);
    assert.ok(on.length <= 1, `frame ${i + 1}: ids ${on.join(', ')} all cover the car`);
    if (on.length === 1 && owners[owners.length - 1] !== on[0]) owners.push(on[0]);
  });
  const switches = Math.max(0, owners.length - 1);
  console.log(`car-shadow: ids covering the car in turn: ${owners.join(' → ')} (${switches} switches)`);
  assert.ok(switches <= SWITCHES, `the car changed id ${switches} times: ${owners.join(' → ')}`);
  const good = carIous.filter((v) => v >= IOU).length;
  console.log(`car-shadow: mask IoU ≥ ${IOU} on ${good} of ${n} frames`);
  assert.ok(good > MOST * n, `mask IoU ≥ ${IOU} on ${good} of ${n} frames: ${line}`);
  const fills = m.fills[car];
  const outlined = fills.filter((v) => v < FILL).length;
  console.log(`car-shadow: the car's mask fills < ${FILL} of its box on ${outlined} of ${fills.length} masks (${fills.map((v) => v.toFixed(2)).join(' ')})`);
  assert.ok(outlined > MOST * fills.length, `the car's outline, not its box: ${fills.map((v) => v.toFixed(2)).join(' ')}`);
  await page.screenshot({ path: join(OUT, 'moving-car-shadow.png') });
  assert.deepEqual(errors, []);
  await page.close();
});

test('no request left localhost', () => {
  assert.deepEqual(app.browser.foreign, []);
});
