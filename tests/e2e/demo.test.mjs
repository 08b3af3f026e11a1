// The embedded demo, end to end in headless Chromium: the synthetic 1280×720 scene is rendered,
// detected (background subtractor) and tracked in the worker's wasm; the test reads the page
// state to check the pipeline keeps identities, merges two
// fragments of one object with mouse and keyboard, exports MOT and compares it with the
// expectation computed here, then reloads with the network off and tracks again. The tracking
// rate is a benchmark, not checked here: `node scripts/bench-browser.mjs`.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { OUT, pageState, untilState, watchErrors, withApp } from './harness.mjs';

const PORT = 47393;

/** @type {import('playwright-core').Page} */
let page;
/** @type {string[]} */
let errors;

const app = withApp({
  port: PORT,
  setup: async (a) => {
    page = a.keep(await a.browser.context.newPage());
    errors = watchErrors(page);
  },
});

const state = () => pageState(page);

/** @param {(s: any) => boolean} pred @param {number} [timeout] */
const until = (pred, timeout) => untilState(page, pred, timeout);

/** @param {{ x: number, y: number, w: number, h: number }} a @param {{ x: number, y: number, w: number, h: number }} b */
function iou(a, b) {
  const iw = Math.max(0, Math.min(a.x + a.w, b.x + b.w) - Math.max(a.x, b.x));
  const ih = Math.max(0, Math.min(a.y + a.h, b.y + b.h) - Math.max(a.y, b.y));
  const i = iw * ih;
  const u = a.w * a.h + b.w * b.h - i;
  return u > 0 ? i / u : 0;
}

/**
 * For every ground-truth object, the track matched to it in each frame (greedy by IoU ≥ 0.5;
 * synthetic masks never overlap, so greedy equals optimal here).
 * @param {any[]} gt
 * @param {any[]} tracks
 * @returns {Map<number, Map<number, number>>} gt id → frame → track id
 */
function matchTracks(gt, tracks) {
  /** @type {Map<number, any[]>} */
  const byFrame = new Map();
  for (const r of tracks) byFrame.set(r.frame, [...(byFrame.get(r.frame) ?? []), r]);
  /** @type {Map<number, Map<number, number>>} */
  const out = new Map();
  /** @type {Map<number, any[]>} */
  const gtByFrame = new Map();
  for (const g of gt) gtByFrame.set(g.frame, [...(gtByFrame.get(g.frame) ?? []), g]);
  for (const [f, gs] of gtByFrame) {
    const pairs = [];
    for (const g of gs) for (const t of byFrame.get(f) ?? []) {
      const v = iou(g.bbox, t.bbox);
      if (v >= 0.5) pairs.push({ g: g.id, t: t.id, v });
    }
    pairs.sort((a, b) => b.v - a.v);
    const usedG = new Set();
    const usedT = new Set();
    for (const p of pairs) {
      if (usedG.has(p.g) || usedT.has(p.t)) continue;
      usedG.add(p.g);
      usedT.add(p.t);
      if (!out.has(p.g)) out.set(p.g, new Map());
      /** @type {Map<number, number>} */ (out.get(p.g)).set(f, p.t);
    }
  }
  return out;
}

/** MOTChallenge lines, formatted here from the format's definition. @param {any[]} records */
function motLines(records) {
  return (
    [...records]
      .sort((a, b) => a.frame - b.frame || a.id - b.id)
      .map((r) => [r.frame, r.id, r.bbox.x, r.bbox.y, r.bbox.w, r.bbox.h, r.score ?? 1, r.class ?? -1, r.visibility ?? -1, -1].join(','))
      .join('\n') + '\n'
  );
}

test('the demo tracks 1280×720 and the page keeps the tracker’s identities', async () => {
  await page.goto(`${app.server.url}?speed=max`);
  // The Tracks card's count follows the table at every redraw, as the timeline's rows do
  // (it used to wait for the list's rebuild, a few times a second, and lag behind births).
  await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
  await page.evaluate(() => {
    const w = /** @type {any} */ (window);
    const a = w.__shapetrack.app;
    // renderNow draws every view (render() asks for it at the next display frame).
    const render = a.renderNow.bind(a);
    w.__countChecks = { renders: 0, stale: 0, example: '' };
    a.renderNow = () => {
      const out = render();
      const c = w.__countChecks;
      const shown = document.getElementById('track-count')?.textContent;
      const held = String(a.model.table.ids().length);
      c.renders++;
      if (shown !== held) {
        c.stale++;
        c.example ||= `frame ${a.cur}: shown ${shown}, table ${held}`;
      }
      return out;
    };
  });
  const s0 = await until((s) => s.processed >= 30);
  assert.deepEqual(s0.size, [1280, 720]);
  assert.equal(s0.source.kind, 'synth');
  // The Detector menu says what Automatic runs on the demo (its still camera's background
  // detector), not just "Automatic".
  assert.equal(await page.inputValue('#detector'), 'auto');
  assert.match((await page.locator('#detector option[value="auto"]').textContent()) ?? '', /the demo: .*background/i);

  const done = await until((s) => !s.playing && s.processed === s.frames);
  assert.equal(done.frames, 600);
  const counts = await page.evaluate(() => /** @type {any} */ (window).__countChecks);
  assert.ok(counts.renders >= 100, `${counts.renders} redraws watched`);
  assert.equal(counts.stale, 0, `the Tracks count behind the table in ${counts.stale} of ${counts.renders} redraws (${counts.example})`);
  const records = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.records());
  const gt = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.groundTruth());
  assert.ok(gt.length > 1000, 'the scene’s ground truth reached the page');

  // The page's table is exactly what the tracker reported (nothing lost or relabelled).
  const reported = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.trackerRecords());
  const key = (/** @type {any} */ r) => `${r.frame}/${r.id}/${r.bbox.x},${r.bbox.y},${r.bbox.w},${r.bbox.h}`;
  assert.deepEqual(records.map(key).sort(), reported.map(key).sort());

  // Identities are stable: while an object stays matched from one frame to the next, its
  // track id stays the same (occlusions and re-identification are the tracker's tests).
  const matched = matchTracks(gt, records);
  let pairs = 0;
  let kept = 0;
  for (const frames of matched.values()) {
    for (const [f, t] of frames) {
      const next = frames.get(f + 1);
      if (next === undefined) continue;
      pairs++;
      if (next === t) kept++;
    }
  }
  console.log(`id kept between consecutive matched frames: ${kept}/${pairs}`);
  assert.ok(pairs > 3000, `${pairs} consecutive matched pairs`);
  assert.ok(kept / pairs >= 0.98, `ids kept in ${kept}/${pairs} consecutive frames`);
  const st = await state();
  assert.ok(st.scores && st.scores.mota > 50, `live scores shown: ${JSON.stringify(st.scores)}`);
  assert.deepEqual(errors, []);
});

test('merge two fragments of one object with mouse and keyboard, then export MOT', async () => {
  const before = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.records());
  const gt = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.groundTruth());
  // An object the tracker gave two ids that never coexist: the labeller's everyday merge.
  const matched = matchTracks(gt, before);
  const span = (/** @type {number} */ id) => {
    const fs = before.filter((/** @type {any} */ r) => r.id === id).map((/** @type {any} */ r) => r.frame);
    return [Math.min(...fs), Math.max(...fs)];
  };
  let pick = null;
  for (const frames of matched.values()) {
    const ids = [...new Set(frames.values())];
    for (let i = 0; i < ids.length && !pick; i++)
      for (let j = 0; j < ids.length && !pick; j++) {
        const [a0, a1] = span(ids[i]);
        const [b0] = span(ids[j]);
        if (a1 < b0) pick = { a: ids[i], b: ids[j], fa: a0 + Math.floor((a1 - a0) / 2), fb: b0 };
      }
    if (pick) break;
  }
  assert.ok(pick, 'some object was tracked in two pieces');

  /** Clicks the middle of track `id`'s mask in frame `f` (found from the record's RLE box). */
  const clickTrack = async (/** @type {number} */ id, /** @type {number} */ f, /** @type {boolean} */ shift) => {
    await page.evaluate((fr) => /** @type {any} */ (window).__shapetrack.app.seek(fr), f);
    const p = await page.evaluate(
      ([tid, fr]) => {
        const st = /** @type {any} */ (window).__shapetrack;
        const r = st.app.model.table.get(fr, tid);
        const bm = st.app.stage.mask(r)?.bitmap;
        // A foreground pixel of the mask nearest its box centre.
        let best = { x: r.bbox.x + r.bbox.w / 2, y: r.bbox.y + r.bbox.h / 2, d: Infinity };
        if (bm) {
          const c = { x: r.bbox.x + r.bbox.w / 2, y: r.bbox.y + r.bbox.h / 2 };
          for (let y = 0; y < bm.height; y++)
            for (let x = 0; x < bm.width; x++) {
              if (!bm.data[y * bm.width + x]) continue;
              const px = bm.x + x + 0.5;
              const py = bm.y + y + 0.5;
              const d = (px - c.x) ** 2 + (py - c.y) ** 2;
              if (d < best.d) best = { x: px, y: py, d };
            }
        }
        return best;
      },
      [id, f],
    );
    const box = await page.locator('#overlay').boundingBox();
    assert.ok(box);
    if (shift) await page.keyboard.down('Shift');
    await page.mouse.click(box.x + (p.x / 1280) * box.width, box.y + (p.y / 720) * box.height);
    if (shift) await page.keyboard.up('Shift');
  };
  await clickTrack(pick.a, pick.fa, false);
  await clickTrack(pick.b, pick.fb, true);
  assert.deepEqual((await state()).selection, { a: pick.a, b: pick.b });
  await page.keyboard.press('m');
  const after = await state();
  assert.ok(!after.ids.includes(pick.b));
  await page.screenshot({ path: join(OUT, 'demo.png') });

  await page.selectOption('#export-format', 'mot');
  const [download] = await Promise.all([page.waitForEvent('download'), page.click('#export')]);
  const exported = readFileSync(await download.path(), 'utf8');
  const expected = motLines(before.map((/** @type {any} */ r) => (r.id === pick.b ? { ...r, id: pick.a } : r)));
  assert.equal(exported, expected);
  assert.deepEqual(errors, []);
});

test('with the network off the app reloads from the service worker and tracks', async () => {
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
    await until((s) => s.processed >= 20, 60_000);
    assert.deepEqual(app.server.appRequests(served), [], 'nothing reached the server while offline');
    await page.screenshot({ path: join(OUT, 'demo-offline.png') });
  } finally {
    await app.browser.context.setOffline(false);
  }
  assert.deepEqual(errors, []);
});

test('no request left localhost', () => {
  assert.ok(app.browser.requests.length > 0);
  assert.deepEqual(app.browser.foreign, []);
});
