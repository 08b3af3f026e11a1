// "Follow this shape" (issue 12) in the app: in the demo scene, with no detector feeding the
// follower (it follows from the pixels alone; the demo's tracker has detected nothing yet), draw
// a box around an object on frame 1 and follow it for 100 frames; the followed masks must
// overlap the scene's own ground-truth masks (IoU ≥ 0.5 on ≥ 90 % of the frames, computed here
// from the RLEs the page holds). Then a corrected keyframe re-propagates only the frames after
// it, Undo restores the records exactly, Cancel stops a follow, and bad input is a clear error.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readdirSync, readFileSync } from 'node:fs';
import { join } from 'node:path';
import { OUT, ROOT, docShot, untilState, watchErrors, withApp } from './harness.mjs';

const PORT = 47398;
const FOLLOW_FRAMES = 100;

const app = withApp({ port: PORT });

/** @typedef {import('playwright-core').Page} Page */

/**
 * The scene's ground truth of frames `1..=last`, from the worker (which renders the scene):
 * frame → records. Leaves the worker's canvas on the last frame rendered.
 * @param {Page} page
 * @param {number} last
 * @returns {Promise<Record<number, any[]>>}
 */
function sceneTruth(page, last) {
  return page.evaluate(async (last) => {
    const a = /** @type {any} */ (window).__shapetrack.app;
    /** @type {Record<number, any[]>} */
    const out = {};
    for (let n = 1; n <= last; n++) out[n] = (await a.worker.render(n)).groundTruth;
    return out;
  }, last);
}

/**
 * Drags a box on the stage from image point `a` to image point `b`.
 * @param {Page} page
 * @param {{ x: number, y: number }} a
 * @param {{ x: number, y: number }} b
 */
async function dragBox(page, a, b) {
  const box = await page.locator('#overlay').boundingBox();
  assert.ok(box);
  const [w, h] = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.state().size);
  const at = (/** @type {{ x: number, y: number }} */ p) => [box.x + (p.x / w) * box.width, box.y + (p.y / h) * box.height];
  const [x0, y0] = at(a);
  const [x1, y1] = at(b);
  await page.mouse.move(x0, y0);
  await page.mouse.down();
  await page.mouse.move(x1, y1, { steps: 6 });
  await page.mouse.up();
}

/**
 * Mask IoU of track `id`'s records with the truth of object `gtId`, frame by frame, decoded by
 * the page's wasm core (`decodeMask`) and counted here in JS. A frame without a followed mask
 * scores 0.
 * @param {Page} page
 * @param {number} id
 * @param {Record<number, any[]>} truth
 * @param {number} gtId
 * @param {number[]} frames
 * @returns {Promise<number[]>}
 */
function ious(page, id, truth, gtId, frames) {
  return page.evaluate(
    ({ id, truth, gtId, frames }) => {
      const a = /** @type {any} */ (window).__shapetrack.app;
      const [W] = a.stage.width ? [a.stage.width] : [0];
      /** @param {any} rle */
      const pixels = (rle) => {
        const m = a.core.decodeMask(rle);
        const set = new Set();
        for (let y = 0; y < m.height; y++) for (let x = 0; x < m.width; x++) if (m.data[y * m.width + x]) set.add((m.y + y) * W + m.x + x);
        return set;
      };
      return frames.map((f) => {
        const r = a.model.table.get(f, id);
        const g = truth[f].find((/** @type {any} */ t) => t.id === gtId);
        if (!r?.mask || !g?.mask) return 0;
        const p = pixels(r.mask);
        const q = pixels(g.mask);
        let inter = 0;
        for (const k of p) if (q.has(k)) inter++;
        return inter / (p.size + q.size - inter);
      });
    },
    { id, truth, gtId, frames },
  );
}

/** Every record of track `id`, as plain data. @param {Page} page @param {number} id */
const trackRecords = (page, id) =>
  page.evaluate((id) => JSON.parse(JSON.stringify(/** @type {any} */ (window).__shapetrack.app.model.table.track(id))), id);

test('follow a shape for 100 frames, correct a keyframe, undo, cancel, and refuse bad input', async () => {
  const page = await app.browser.context.newPage();
  const errors = watchErrors(page);
  await page.goto(`${app.server.url}?demo=0`);
  await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
  await page.click('#src-demo');
  await untilState(page, (s) => s.phase === 'tracking' && s.processed === 1 && s.frame === 1 && !s.playing);
  const state = await untilState(page, (s) => s.source?.kind === 'synth');
  assert.equal(state.ids.length, 0, 'the background detector sees nothing on frame 1: no track to start from');

  // The object to follow: the largest one of frame 1 that stays in view for the whole run.
  const last = 1 + FOLLOW_FRAMES;
  // Truth beyond the run too: the follow is extended by 20 frames below.
  const truth = await sceneTruth(page, last + 20);
  const present = (/** @type {number} */ gid) => Object.values(truth).every((recs) => recs.some((r) => r.id === gid && r.mask));
  const target = truth[1].filter((r) => present(r.id)).sort((a, b) => b.bbox.w * b.bbox.h - a.bbox.w * a.bbox.h)[0];
  assert.ok(target, 'an object stays in view for 100 frames');
  await page.evaluate(() => /** @type {any} */ (window).__shapetrack.app.seek(1));

  // An empty box (a click) is refused with a clear message, and nothing changes.
  await page.keyboard.press('x');
  await untilState(page, (s) => s.tool === 'box');
  await dragBox(page, { x: 100, y: 100 }, { x: 100.2, y: 100.2 });
  const refused = await untilState(page, (s) => /empty/.test(s.status));
  assert.equal(refused.ids.length, 0);
  assert.equal(refused.canUndo, false);

  // Draw a box around the object: it is followed forward for 100 frames (the card's default).
  const b = target.bbox;
  await dragBox(page, { x: b.x, y: b.y }, { x: b.x + b.w, y: b.y + b.h });
  const followed = await untilState(page, (s) => !s.following && /followed/.test(s.status), 180_000);
  const id = followed.selection.a;
  assert.ok(id !== null, followed.status);
  // The box tool is put away once its box is followed (right after the status says so).
  await untilState(page, (s) => s.tool === null, 10_000);
  const first = await trackRecords(page, id);
  assert.deepEqual(first.map((/** @type {any} */ r) => r.frame), Array.from({ length: last }, (_, i) => i + 1), 'frames 1..101');
  assert.ok(first.every((/** @type {any} */ r) => r.source === 'follow'));
  assert.deepEqual(first.filter((/** @type {any} */ r) => r.keyframe).map((/** @type {any} */ r) => r.frame), [1]);
  const frames = first.slice(1).map((/** @type {any} */ r) => r.frame);
  const iou = await ious(page, id, truth, target.id, frames);
  const good = iou.filter((v) => v >= 0.5).length;
  const mean = iou.reduce((s, v) => s + v, 0) / iou.length;
  console.log(
    `followed scene object ${target.id} (${Math.round(b.w)}×${Math.round(b.h)} px) as track ${id}: mask IoU ≥ 0.5 on ${good}/${iou.length} frames, mean ${mean.toFixed(3)}, min ${Math.min(...iou).toFixed(3)}`,
  );
  assert.ok(good >= 0.9 * iou.length, `IoU ≥ 0.5 on ${good} of ${iou.length} frames`);

  // The timeline says which span was followed (its tooltip names the kind of each cell).
  await page.evaluate(() => /** @type {any} */ (window).__shapetrack.app.seek(51));
  await untilState(page, (s) => s.frame === 51);
  await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(() => r(undefined)))));
  await page.screenshot({ path: join(OUT, 'follow.png') });
  await docShot(page, 'follow');
  const cell = await page.evaluate(
    ({ id }) => {
      const tl = /** @type {any} */ (window).__shapetrack.app.timeline;
      const r = tl.last.table.get(1, id);
      return { keyframe: !!r?.keyframe, source: r?.source };
    },
    { id },
  );
  assert.deepEqual(cell, { keyframe: true, source: 'follow' });
  // The legend names the follow's marks.
  await page.click('#legend-open');
  assert.match((await page.locator('#legend li[data-legend="followed"]').textContent()) ?? '', /keyframe/);
  await page.keyboard.press('Escape');
  await page.waitForFunction(() => !document.querySelector('#help-dialog')?.hasAttribute('open'));

  // A corrected keyframe at frame 51 (the track stays selected): the box the truth gives there.
  const g51 = truth[51].find((r) => r.id === target.id);
  assert.ok(g51);
  const before = JSON.stringify(await page.evaluate(() => /** @type {any} */ (window).__shapetrack.records()));
  await page.keyboard.press('x'); // the box tool again (put away after the first follow)
  await untilState(page, (s) => s.tool === 'box' && s.selection.a === id);
  await dragBox(page, { x: g51.bbox.x, y: g51.bbox.y }, { x: g51.bbox.x + g51.bbox.w, y: g51.bbox.y + g51.bbox.h });
  await untilState(page, (s) => !s.following && /followed from frame 51/.test(s.status), 180_000);
  const second = await trackRecords(page, id);
  const byFrame = (/** @type {any[]} */ recs) => new Map(recs.map((r) => [r.frame, JSON.stringify(r)]));
  const [old, now] = [byFrame(first), byFrame(second)];
  for (let f = 1; f < 51; f++) assert.equal(now.get(f), old.get(f), `frame ${f} before the correction is untouched`);
  const k51 = second.find((/** @type {any} */ r) => r.frame === 51);
  assert.ok(k51?.keyframe, 'frame 51 is a keyframe');
  const changed = frames.filter((f) => f > 51 && now.get(f) !== old.get(f)).length;
  const reached = second.filter((/** @type {any} */ r) => r.frame > 51).length;
  const after = await ious(page, id, truth, target.id, frames.filter((f) => f > 51 && now.has(f)));
  console.log(
    `corrected at frame 51: ${changed} of the ${last - 51} records after it changed (${reached} followed again), ` +
      `mean IoU after it ${(after.reduce((s, v) => s + v, 0) / Math.max(1, after.length)).toFixed(3)}`,
  );
  // Every frame after the keyframe was followed again; started from a slightly different
  // shape, the follower's masks differ for a while, then settle on the same object's outline.
  assert.equal(reached, last - 51, 'followed again up to the end of the span');
  assert.ok(changed >= 10, `the records after the keyframe were followed again: ${changed} changed`);

  // Undo restores the records exactly; redo brings the correction back; undo again.
  await page.keyboard.press('Control+z');
  const undone = JSON.stringify(await page.evaluate(() => /** @type {any} */ (window).__shapetrack.records()));
  assert.equal(undone, before, 'undo restores every record as it was before the correction');
  await page.keyboard.press('Control+Shift+z');
  assert.deepEqual(await trackRecords(page, id), second);
  await page.keyboard.press('Control+z');

  // Moving a followed shape is a correction too: drag track's shape on frame 51 by 12 px to
  // the right (no tool: the box tool was put away when its box was followed).
  await untilState(page, (s) => s.tool === null && s.selection.a === id && s.frame === 51);
  const r51 = first.find((/** @type {any} */ r) => r.frame === 51);
  {
    const sc = await page.locator('#overlay').boundingBox();
    assert.ok(sc);
    const cx = sc.x + ((r51.bbox.x + r51.bbox.w / 2) / 1280) * sc.width;
    const cy = sc.y + ((r51.bbox.y + r51.bbox.h / 2) / 720) * sc.height;
    await page.mouse.move(cx, cy);
    await page.mouse.down();
    await page.mouse.move(cx + (12 / 1280) * sc.width, cy, { steps: 4 });
    await page.mouse.up();
  }
  await untilState(page, (s) => !s.following && /followed from frame 51/.test(s.status), 180_000);
  const moved = await trackRecords(page, id);
  const m51 = moved.find((/** @type {any} */ r) => r.frame === 51);
  assert.ok(m51.keyframe, 'the moved shape is a keyframe');
  assert.ok(Math.abs(m51.bbox.x - r51.bbox.x - 12) <= 1, `moved by 12 px: ${r51.bbox.x} -> ${m51.bbox.x}`);
  for (const r of moved) if (r.frame < 51) assert.equal(JSON.stringify(r), old.get(r.frame), `frame ${r.frame} untouched by the move`);
  console.log(`moved on frame 51: ${moved.filter((/** @type {any} */ r) => r.frame > 51 && JSON.stringify(r) !== old.get(r.frame)).length} of the records after it changed`);
  await page.keyboard.press('Control+z');
  assert.equal(JSON.stringify(await page.evaluate(() => /** @type {any} */ (window).__shapetrack.records())), before);

  /**
   * IoU figures of track `tid` over `fs` against the target, printed and checked (≥ 0.5 on
   * ≥ 90 % of the frames).
   * @param {string} what
   * @param {number} tid
   * @param {number[]} fs
   */
  const expectFollowed = async (what, tid, fs) => {
    const v = await ious(page, tid, truth, target.id, fs);
    const n = v.filter((x) => x >= 0.5).length;
    console.log(`${what}: IoU ≥ 0.5 on ${n}/${v.length} frames, mean ${(v.reduce((s, x) => s + x, 0) / v.length).toFixed(3)}`);
    assert.ok(n >= 0.9 * v.length, `${what}: IoU ≥ 0.5 on ${n} of ${v.length} frames`);
  };

  // Click the followed shape on frame 101 (no tool: a click selects) and press F: the follow
  // goes on for 20 frames from that shape, which becomes a keyframe.
  await page.evaluate(() => /** @type {any} */ (window).__shapetrack.app.seek(101));
  await untilState(page, (s) => s.frame === 101 && s.tool === null);
  const r101 = first.find((/** @type {any} */ r) => r.frame === 101);
  const screen = await page.locator('#overlay').boundingBox();
  assert.ok(screen && r101);
  await page.mouse.click(
    screen.x + ((r101.bbox.x + r101.bbox.w / 2) / 1280) * screen.width,
    screen.y + ((r101.bbox.y + r101.bbox.h / 2) / 720) * screen.height,
  );
  await untilState(page, (s) => s.selection.a === id);
  await page.fill('#fol-len', '20');
  await page.evaluate(() => /** @type {HTMLElement} */ (document.activeElement)?.blur());
  await page.keyboard.press('f');
  await untilState(page, (s) => !s.following && /20 frames followed from frame 101/.test(s.status), 180_000);
  const extended = await trackRecords(page, id);
  assert.equal(extended.length, last + 20);
  assert.deepEqual(extended.filter((/** @type {any} */ r) => r.keyframe).map((/** @type {any} */ r) => r.frame), [1, 101]);
  await expectFollowed('picked on frame 101, followed 20 frames on', id, Array.from({ length: 20 }, (_, i) => last + 1 + i));
  await page.keyboard.press('Control+z');

  // A polygon (the box's corners, clicked; Enter closes it) on frame 101 with nothing
  // selected is a new track, followed backward 30 frames.
  await page.keyboard.press('Escape'); // deselect
  await page.selectOption('#fol-dir', 'backward');
  await page.fill('#fol-len', '30');
  await page.evaluate(() => /** @type {HTMLElement} */ (document.activeElement)?.blur());
  await page.keyboard.press('p');
  await untilState(page, (s) => s.tool === 'polygon' && s.selection.a === null);
  const g = truth[last].find((r) => r.id === target.id);
  assert.ok(g);
  for (const [x, y] of [[g.bbox.x, g.bbox.y], [g.bbox.x + g.bbox.w, g.bbox.y], [g.bbox.x + g.bbox.w, g.bbox.y + g.bbox.h], [g.bbox.x, g.bbox.y + g.bbox.h]]) {
    await page.mouse.click(screen.x + (x / 1280) * screen.width, screen.y + (y / 720) * screen.height);
  }
  await page.keyboard.press('Enter');
  const back = await untilState(page, (s) => !s.following && /30 frames followed from frame 101/.test(s.status), 180_000);
  const backId = back.selection.a;
  assert.notEqual(backId, id);
  const backRecs = await trackRecords(page, backId);
  assert.deepEqual(backRecs.map((/** @type {any} */ r) => r.frame), Array.from({ length: 31 }, (_, i) => last - 30 + i));
  await expectFollowed('a polygon on frame 101, followed 30 frames back', backId, Array.from({ length: 30 }, (_, i) => last - 30 + i));
  await page.keyboard.press('Control+z');

  // Cancel: a long follow (300 frames, from frame 101 on) stops when asked, keeps what it
  // followed, and is one edit that undo takes back.
  await page.selectOption('#fol-dir', 'forward');
  await page.fill('#fol-len', '300');
  // Out of the field: shortcuts do not fire while typing in it.
  await page.evaluate(() => /** @type {HTMLElement} */ (document.activeElement)?.blur());
  await page.keyboard.press('Escape'); // deselect: the next box is a new track
  await page.keyboard.press('x');
  await untilState(page, (s) => s.frame === 101 && s.tool === 'box' && s.selection.a === null);
  const g101 = truth[101].find((r) => r.id === target.id);
  assert.ok(g101);
  const beforeCancel = JSON.stringify(await page.evaluate(() => /** @type {any} */ (window).__shapetrack.records()));
  await dragBox(page, { x: g101.bbox.x, y: g101.bbox.y }, { x: g101.bbox.x + g101.bbox.w, y: g101.bbox.y + g101.bbox.h });
  await untilState(page, (s) => s.following && /following .*\(\d+\/300\)/.test(s.status));
  await page.click('#fol-cancel');
  const cancelled = await untilState(page, (s) => !s.following && /cancelled/.test(s.status), 180_000);
  const kept = await trackRecords(page, cancelled.selection.a);
  assert.ok(kept.length >= 2 && kept.length < 301, `a cancelled follow keeps what it reached: ${kept.length} records`);
  await page.keyboard.press('Control+z');
  assert.equal(JSON.stringify(await page.evaluate(() => /** @type {any} */ (window).__shapetrack.records())), beforeCancel);

  // Bad input to the worker's follower is a typed error, not a trap: a frame outside the scene,
  // an empty mask; and the UI refuses a follow past the video's last frame.
  const bad = await page.evaluate(async (mask) => {
    const a = /** @type {any} */ (window).__shapetrack.app;
    const msg = (/** @type {Promise<unknown>} */ p) => p.then(() => 'no error', (e) => String(e.message));
    const empty = a.core.encodeMask(a.stage.width, a.stage.height, new Uint8Array(a.stage.width * a.stage.height));
    const out = {
      range: await msg(a.worker.followStart(100000, 100001, mask)),
      empty: await msg(a.worker.followStart(5, 6, empty)),
      past: await msg(a.followFrom(99, { frame: 600, id: 99, bbox: { x: 1, y: 1, w: 5, h: 5 }, mask }, [{ direction: 1, from: 600, to: 601 }])),
      stepless: await msg(a.worker.followStep(3)),
    };
    // The worker still works after all that.
    out.after = await msg(a.worker.followStart(5, 6, mask).then(() => a.worker.followEnd()));
    return out;
  }, target.mask);
  console.log(`bad input: ${JSON.stringify(bad)}`);
  assert.match(bad.range, /frame 100000/);
  assert.match(bad.empty, /empty/);
  assert.match(bad.past, /frame 601|outside/);
  assert.match(bad.stepless, /no follow under way/);
  assert.equal(bad.after, 'no error');
  assert.deepEqual(errors, []);
});

// An image sequence: the page grabs each frame (in either direction) and transfers it to the
// worker. VOT "bag", the first 40 frames: the bag's annotated polygon on frame 20, drawn as a
// polygon, followed 15 frames both ways. The bag deforms and turns; the figure is printed (box
// IoU with VOT's rotated-box truth), the check is that both legs ran over the right frames.
test('an image sequence: a polygon followed both ways through page-supplied frames', async () => {
  const bag = join(ROOT, '..', 'shared', 'data', 'vot-bag');
  const files = readdirSync(bag).filter((f) => f.endsWith('.jpg')).sort().slice(0, 40).map((f) => join(bag, f));
  const truth = readFileSync(join(bag, 'groundtruth.txt'), 'utf8').trim().split('\n').map((l) => l.split(',').map(Number));
  const page = await app.browser.context.newPage();
  const errors = watchErrors(page);
  await page.goto(`${app.server.url}?demo=0`);
  await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
  await page.setInputFiles('#file-images', files);
  await untilState(page, (s) => s.source?.kind === 'images' && s.processed >= 1 && !s.playing);
  await page.evaluate(() => /** @type {any} */ (window).__shapetrack.app.seek(1));
  await page.selectOption('#fol-dir', 'both');
  await page.fill('#fol-len', '15');
  await page.evaluate(() => /** @type {HTMLElement} */ (document.activeElement)?.blur());
  // Track on to frame 20 (→ nineteen times: seeks stop at the last tracked frame).
  await page.evaluate(async () => {
    const a = /** @type {any} */ (window).__shapetrack.app;
    while (a.cur < 20) await a.stepForward();
  });
  await untilState(page, (s) => s.frame === 20);
  await page.keyboard.press('p');
  const screen = await page.locator('#overlay').boundingBox();
  assert.ok(screen);
  const poly = truth[19];
  for (let i = 0; i < poly.length; i += 2) {
    await page.mouse.click(screen.x + (poly[i] / 480) * screen.width, screen.y + (poly[i + 1] / 360) * screen.height);
  }
  await page.keyboard.press('Enter');
  const done = await untilState(page, (s) => !s.following && /30 frames followed from frame 20/.test(s.status), 180_000);
  const recs = await trackRecords(page, done.selection.a);
  assert.deepEqual(recs.map((/** @type {any} */ r) => r.frame), Array.from({ length: 31 }, (_, i) => 5 + i));
  /** @param {number[]} p VOT polygon @returns {{ x: number, y: number, w: number, h: number }} */
  const boxOf = (p) => {
    const xs = p.filter((_, i) => i % 2 === 0);
    const ys = p.filter((_, i) => i % 2 === 1);
    return { x: Math.min(...xs), y: Math.min(...ys), w: Math.max(...xs) - Math.min(...xs), h: Math.max(...ys) - Math.min(...ys) };
  };
  /** @param {any} a @param {any} b */
  const boxIou = (a, b) => {
    const w = Math.max(0, Math.min(a.x + a.w, b.x + b.w) - Math.max(a.x, b.x));
    const h = Math.max(0, Math.min(a.y + a.h, b.y + b.h) - Math.max(a.y, b.y));
    return (w * h) / (a.w * a.h + b.w * b.h - w * h);
  };
  const v = recs.map((/** @type {any} */ r) => boxIou(r.bbox, boxOf(truth[r.frame - 1])));
  console.log(`vot-bag frames 5–35 from a polygon on frame 20: box IoU mean ${(v.reduce((s, x) => s + x, 0) / v.length).toFixed(3)}, ≥ 0.5 on ${v.filter((x) => x >= 0.5).length}/${v.length}`);
  assert.deepEqual(errors, []);
});

// A video file: the page seeks the <video> to each frame, forward and then backward. A red
// square crosses a textured background (3.6 px a frame); a box drawn around it on frame 1 is
// followed 15 frames on, then the followed shape on frame 16 is followed 15 frames back.
test('a video file: a box followed forward, then backward through seeks', async () => {
  const page = await app.browser.context.newPage();
  const errors = watchErrors(page);
  await page.goto(`${app.server.url}?demo=0`);
  await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
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
        ctx.fillStyle = '#f44';
        ctx.fillRect(20 + 90 * t, 60, 40, 40);
        if (t < 2) requestAnimationFrame(draw);
        else resolve(undefined);
      };
      draw();
    });
    rec.stop();
    await stopped;
    await /** @type {any} */ (window).__shapetrack.app.openVideo(new File(parts, 'square.webm', { type: 'video/webm' }));
  });
  const st = await untilState(page, (s) => s.source?.kind === 'video' && s.processed >= 1 && !s.playing);
  assert.ok(st.frames >= 20, `${st.frames} frames`);
  await page.fill('#fol-len', '15');
  await page.evaluate(() => /** @type {HTMLElement} */ (document.activeElement)?.blur());
  await page.keyboard.press('x');
  await dragBox(page, { x: 12, y: 52 }, { x: 72, y: 108 });
  const fwd = await untilState(page, (s) => !s.following && /15 frames followed from frame 1/.test(s.status), 120_000);
  const id = fwd.selection.a;
  const ahead = await trackRecords(page, id);
  assert.deepEqual(ahead.map((/** @type {any} */ r) => r.frame), Array.from({ length: 16 }, (_, i) => i + 1));
  const cx = (/** @type {any} */ r) => r.bbox.x + r.bbox.w / 2;
  // The square moved right about 54 px; the followed shape with it.
  const moved = cx(ahead[15]) - cx(ahead[0]);
  console.log(`video: the followed box moved ${moved.toFixed(1)} px right over 15 frames (the square: ~54)`);
  assert.ok(moved > 25, `followed box moved ${moved} px`);

  // Backward from frame 16: the same track, its shape there as the start; the follow stops
  // before the keyframe on frame 1 (a shape the labeller gave is never overwritten).
  await page.selectOption('#fol-dir', 'backward');
  await page.evaluate(() => /** @type {any} */ (window).__shapetrack.app.seek(16));
  await untilState(page, (s) => s.frame === 16 && s.tool === null && s.selection.a === id);
  await page.keyboard.press('f');
  await untilState(page, (s) => !s.following && /14 frames followed from frame 16/.test(s.status), 120_000);
  const back = await trackRecords(page, id);
  assert.deepEqual(back.map((/** @type {any} */ r) => r.frame), Array.from({ length: 16 }, (_, i) => i + 1));
  assert.deepEqual(back.filter((/** @type {any} */ r) => r.keyframe).map((/** @type {any} */ r) => r.frame), [1, 16]);
  // Frames 2..15 were followed again, backward (seeking the video back frame by frame).
  const backMoved = cx(back[15]) - cx(back[1]);
  console.log(`video, backward from frame 16: the box on frame 2 is ${backMoved.toFixed(1)} px left of frame 16's`);
  assert.ok(backMoved > 25, `followed back ${backMoved} px`);
  assert.deepEqual(errors, []);
});

test('no request left localhost', () => {
  assert.ok(app.browser.requests.length > 0);
  assert.deepEqual(app.browser.foreign, []);
});
