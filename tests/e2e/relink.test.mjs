// The offline pass in the app: the synthetic occlusion scene (8 shapes bouncing behind two
// bars) tracked online, then the same scene in offline mode, where the core's trajectory
// re-linker joins the tracks the bars broke and fills the gaps. Checked from the page state:
// fewer ids than online, interpolated records, better identity scores against the scene's
// ground truth, the page's table equal to the tracker's result; the progress bar through the
// re-linker's phases; filled spans hatched on the timeline and dashed on the overlay; the
// interpolated flag in a CVAT export read back; and merge/undo on the re-linked ids (undo
// goes back to the online result).
//
// The tracker runs with the box-mode defaults (`?preset=default`): there the online pass breaks
// tracks at the bars and the re-linker has joining to do. With the app's mask preset the online
// pass already re-identifies most of them by colour and SIFT (occlusion seed 0: 11 ids, IDSW 6
// online, the same offline; `cargo run --release --example demo_presets`).

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { OUT, docShot, watchErrors, withApp } from './harness.mjs';

const PORT = 47397;
const FRAMES = 300;


const app = withApp({ port: PORT });

/** @typedef {{ frame: number, id: number, bbox: { x: number, y: number, w: number, h: number }, interpolated?: boolean }} Rec */

/** @param {import('playwright-core').Page} page */
const state = (page) => page.evaluate(() => /** @type {any} */ (window).__shapetrack.state());
/** @param {import('playwright-core').Page} page @returns {Promise<Rec[]>} */
const records = (page) => page.evaluate(() => /** @type {any} */ (window).__shapetrack.records());

/**
 * Box scores of the page's table against the scene's ground truth, by the core's evaluator.
 * @param {import('playwright-core').Page} page
 */
const scores = (page) =>
  page.evaluate((frames) => {
    const st = /** @type {any} */ (window).__shapetrack;
    return st.app.core.evaluate(st.groundTruth(), st.records(), frames, { similarity: 'box' });
  }, FRAMES);

/** @param {Rec[]} rs */
const idsOf = (rs) => new Set(rs.map((r) => r.id)).size;
/** @param {Rec} r */
const key = (r) => `${r.frame}:${r.id}`;

/**
 * Loads the occlusion scene, which starts tracking right away, and waits for the end.
 * @param {import('playwright-core').Page} page
 * @param {'online' | 'offline'} mode
 */
async function runScene(page, mode) {
  // Record the progress bar's phase and value from the start (the run starts on load).
  await page.addInitScript(() => {
    const w = /** @type {any} */ (window);
    w.__progress = [];
    document.addEventListener('DOMContentLoaded', () => {
      const p = /** @type {HTMLProgressElement} */ (document.getElementById('progress'));
      new MutationObserver(() => w.__progress.push([p.dataset.phase ?? '', p.value, p.hidden])).observe(p, {
        attributes: true,
        attributeFilter: ['data-phase', 'value', 'hidden'],
      });
    });
  });
  // Gaps of up to 15 frames filled (the default fills 10; the occlusion scene's bars hide
  // shapes longer): the page's `?offline=` settings reach the core's pass.
  const offline = encodeURIComponent(JSON.stringify({ fill: { max_gap: 15 } }));
  await page.goto(`${app.server.url}?scene=occlusion&speed=max&mode=${mode}&preset=default&offline=${offline}`);
  await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
  await page.waitForFunction(
    ([n, m]) => {
      const s = /** @type {any} */ (window).__shapetrack.state();
      return s.processed === n && !s.playing && (m === 'online' || s.finished);
    },
    [FRAMES, mode],
    { timeout: 120_000 },
  );
}

/**
 * The pixels of the timeline row of track `id` over frames `a..=b` (middle of the row).
 * @param {import('playwright-core').Page} page
 */
function timelineRow(page, id, a, b) {
  return page.evaluate(
    ([id, a, b]) => {
      const tl = /** @type {any} */ (window).__shapetrack.app.timeline;
      const c = /** @type {HTMLCanvasElement} */ (document.getElementById('timeline'));
      const ctx = /** @type {CanvasRenderingContext2D} */ (c.getContext('2d'));
      const first = tl.cellAt(id, a);
      const lastCell = tl.cellAt(id, b);
      if (!first || !lastCell) return { row: -1, rowH: tl.rowH, pixels: [] };
      const row = tl.ids.indexOf(id) - tl.view.top;
      const x0 = Math.ceil(first.canvas.x0) + 1;
      const x1 = Math.floor(lastCell.canvas.x1) - 1;
      // Two rows inside the bar, so a diagonal stripe is crossed whatever its phase.
      const out = [];
      for (const dy of [0.35, 0.65]) {
        const y = Math.floor(first.canvas.y0 + dy * first.canvas.h);
        const d = ctx.getImageData(x0, y, Math.max(1, x1 - x0), 1).data;
        for (let i = 0; i < d.length; i += 4) out.push(`${d[i]},${d[i + 1]},${d[i + 2]}`);
      }
      return { row, rowH: tl.rowH, pixels: out };
    },
    [id, a, b],
  );
}

/**
 * Share of painted overlay pixels along the line just below a box's bottom edge.
 * @param {import('playwright-core').Page} page
 * @param {Rec['bbox']} box
 */
function edgeCoverage(page, box) {
  return page.evaluate((b) => {
    const c = /** @type {HTMLCanvasElement} */ (document.getElementById('overlay'));
    const ctx = /** @type {CanvasRenderingContext2D} */ (c.getContext('2d'));
    const k = c.width / /** @type {any} */ (window).__shapetrack.app.stage.width;
    const y = Math.floor((b.y + b.h) * k);
    const x0 = Math.ceil(b.x * k) + 2;
    const x1 = Math.floor((b.x + b.w) * k) - 2;
    const d = ctx.getImageData(x0, y, x1 - x0, 1).data;
    let on = 0;
    // Half-opaque or more: anti-aliased fringes at the dash ends do not count.
    for (let i = 3; i < d.length; i += 4) if (d[i] >= 128) on++;
    return on / (d.length / 4);
  }, box);
}

test('offline mode re-links the occlusion scene: fewer ids, filled gaps, shown and exported', async (t) => {
  // Online first: the same scene, the same detector.
  const onlinePage = await app.browser.context.newPage();
  const onlineErrors = watchErrors(onlinePage);
  await runScene(onlinePage, 'online');
  const online = await records(onlinePage);
  const onlineScores = await scores(onlinePage);
  // The online pass reports confirmed tracks through short misses (coasted, interpolated).
  // Known by frame and box: a coasted record keeps both through the offline pass (joins
  // change its id only).
  const place = (/** @type {Rec} */ r) => `${r.frame}:${r.bbox.x}:${r.bbox.y}:${r.bbox.w}:${r.bbox.h}`;
  const coasted = new Set(online.filter((r) => r.interpolated).map(place));
  assert.deepEqual(onlineErrors, []);
  await onlinePage.close();

  const page = await app.browser.context.newPage();
  const errors = watchErrors(page);
  const t0 = Date.now();
  await runScene(page, 'offline');
  const wallMs = Date.now() - t0;
  const st = await state(page);
  const offline = await records(page);
  // Interpolated offline: the online pass's coasted records plus the gaps this pass filled.
  const filled = offline.filter((r) => r.interpolated && !coasted.has(place(r)));

  // The page state says what the pass did, and the table agrees with it.
  assert.ok(st.offline, 'the offline pass ran');
  assert.equal(st.offline.onlineIds, idsOf(online), 'the online pass in offline mode is the online result');
  assert.equal(st.offline.ids, idsOf(offline));
  assert.ok(st.offline.ids < st.offline.onlineIds, `fewer ids offline: ${st.offline.ids} vs ${st.offline.onlineIds} online`);
  assert.ok(st.offline.joins > 0);
  assert.equal(st.offline.filled, filled.length);
  assert.ok(filled.length > 0, 'gaps were filled');
  assert.ok(filled.every((r) => r.bbox.w > 0 && r.bbox.h > 0 && /** @type {any} */ (r).mask), 'filled shapes carry boxes and masks');
  assert.match(st.status, new RegExp(`${st.offline.onlineIds} → ${st.offline.ids} tracks`));
  // Every online record is still there (under its joined id), plus the filled ones.
  assert.equal(offline.length, online.length + filled.length);
  // The page's table is exactly the tracker's offline result.
  const tracker = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.trackerRecords());
  assert.deepEqual(
    offline.map((r) => [key(r), !!r.interpolated, r.bbox]),
    tracker.map((/** @type {Rec} */ r) => [key(r), !!r.interpolated, r.bbox]),
  );
  // The joins are right, not just fewer ids: identity scores improve against the truth.
  const offlineScores = await scores(page);
  assert.ok(offlineScores.idsw < onlineScores.idsw, `IDSW ${onlineScores.idsw} → ${offlineScores.idsw}`);
  assert.ok(offlineScores.idf1 > onlineScores.idf1, `IDF1 ${onlineScores.idf1} → ${offlineScores.idf1}`);
  assert.ok(offlineScores.hota >= onlineScores.hota, `HOTA ${onlineScores.hota} → ${offlineScores.hota}`);
  t.diagnostic(
    `occlusion scene, ${FRAMES} frames, background detector: ids ${st.offline.onlineIds} online → ${st.offline.ids} offline ` +
      `(${st.offline.joins} joins, ${filled.length} records filled); IDSW ${onlineScores.idsw} → ${offlineScores.idsw}, ` +
      `IDF1 ${onlineScores.idf1.toFixed(1)} → ${offlineScores.idf1.toFixed(1)}, HOTA ${onlineScores.hota.toFixed(1)} → ${offlineScores.hota.toFixed(1)}; ` +
      `finish() ${st.offline.ms.toFixed(0)} ms in the worker; whole offline run ${(wallMs / 1000).toFixed(1)} s`,
  );

  // The progress bar went through the frames, then the re-linker's phases in order, to the end.
  const progress = /** @type {Array<[string, number, boolean]>} */ (await page.evaluate(() => /** @type {any} */ (window).__progress));
  const phases = progress.map(([p]) => p).filter((p, i, a) => p && p !== a[i - 1]);
  assert.deepEqual(phases, ['online', 'candidates', 'appearance', 'matching', 'filling', 'done'], JSON.stringify(phases));
  const values = progress.map(([, v]) => v);
  assert.ok(values.every((v, i) => i === 0 || v >= values[i - 1] || v === 0), `progress never goes back: ${values}`);
  assert.equal(values.at(-1), 1);
  assert.ok(values.some((v) => v > 0.2 && v < 0.9), 'the online pass moves the bar');
  assert.equal(await page.evaluate(() => /** @type {HTMLProgressElement} */ (document.getElementById('progress')).hidden), true);

  // The timeline hatches a filled span (stripes over a wash: several colours) and draws an
  // observed span solid (one colour).
  const gap = filled[0];
  const run = filled.filter((r) => r.id === gap.id && r.frame >= gap.frame);
  let end = gap.frame;
  while (run.some((r) => r.frame === end + 1)) end++;
  const observed = offline.filter((r) => r.id === gap.id && !r.interpolated);
  const before = observed.filter((r) => r.frame < gap.frame).map((r) => r.frame);
  await page.evaluate((id) => /** @type {any} */ (window).__shapetrack.app.select(id, false), gap.id);
  await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => r(undefined))));
  const hatched = await timelineRow(page, gap.id, gap.frame, end);
  // The inside of the track's longest run of observed frames before the gap (the online pass
  // may have coasted over frames nearby: those are hatched too; a run's edge pixels blend).
  const beforeSet = new Set(before);
  let [first, last] = [before[0], before[0]];
  for (const f of before) {
    if (beforeSet.has(f - 1)) continue;
    let e = f;
    while (beforeSet.has(e + 1)) e++;
    if (e - f > last - first) [first, last] = [f, e];
  }
  if (last - first >= 4) [first, last] = [first + 1, last - 1];
  const solid = await timelineRow(page, gap.id, first, last);
  assert.ok(hatched.row >= 0, 'the track is in view on the timeline');
  assert.ok(new Set(hatched.pixels).size >= 2, `filled span hatched: ${[...new Set(hatched.pixels)]}`);
  // One colour, but for the current-frame cursor's line when it crosses the span.
  const counts = new Map();
  for (const px of solid.pixels) counts.set(String(px), (counts.get(String(px)) ?? 0) + 1);
  const dominant = Math.max(...counts.values());
  assert.ok(counts.size <= 2 && dominant >= 0.8 * solid.pixels.length, `observed span solid: ${[...counts]}`);

  // The overlay draws a filled shape dashed: gaps along its outline, unlike a detected one.
  // The overlay draws a filled shape dashed: gaps along its outline, unlike a detected one.
  // Filled shapes are mostly where objects cross (the background subtractor merges touching
  // objects, so their detections go missing there), under other outlines; so the other
  // records of the frame are deleted first (undoable edits, undone right after), and masks and
  // trails hidden, leaving only the outline measured along the box's bottom edge.
  /**
   * Share of the bottom edge of `id`'s box painted in frame `f`, drawn alone.
   * @param {number} f
   * @param {number} id
   */
  const aloneCoverage = async (f, id) => {
    // (Page functions run in the browser: each reaches the app through `window` itself.)
    await page.evaluate((f) => /** @type {any} */ (window).__shapetrack.app.seek(f), f);
    await page.waitForFunction((f) => /** @type {any} */ (window).__shapetrack.state().frame === f, f);
    const others = [...new Set(offline.filter((o) => o.frame === f && o.id !== id).map((o) => o.id))];
    for (const o of others) {
      await page.evaluate((o) => {
        const app = /** @type {any} */ (window).__shapetrack.app;
        app.select(o, false);
        app.action('deleteRecord');
      }, o);
    }
    await page.evaluate(() => /** @type {any} */ (window).__shapetrack.app.deselect());
    await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => r(undefined))));
    const box = offline.find((o) => o.frame === f && o.id === id)?.bbox;
    assert.ok(box);
    const cover = await edgeCoverage(page, box);
    for (const _ of others) await page.evaluate(() => /** @type {any} */ (window).__shapetrack.app.action('undo'));
    return cover;
  };
  await page.evaluate(() => Object.assign(/** @type {any} */ (window).__shapetrack.app.options, { masks: false, trails: false }));
  const dashed = filled.reduce((a, b) => (b.bbox.w > a.bbox.w ? b : a));
  const seen = offline.filter((r) => r.id === dashed.id && !r.interpolated).reduce((a, b) => (Math.abs(b.frame - dashed.frame) < Math.abs(a.frame - dashed.frame) ? b : a));
  const dashedCover = await aloneCoverage(dashed.frame, dashed.id);
  const solidCover = await aloneCoverage(seen.frame, seen.id);
  await page.evaluate(() => Object.assign(/** @type {any} */ (window).__shapetrack.app.options, { masks: true, trails: true }));
  assert.deepEqual((await records(page)).map(key), offline.map(key), 'the deletions were undone');
  assert.ok(dashedCover > 0.2 && dashedCover < 0.85, `dashed outline: ${dashedCover.toFixed(2)} of its edge painted`);
  assert.ok(solidCover > 0.95, `solid outline: ${solidCover.toFixed(2)} of its edge painted`);
  t.diagnostic(`outline painted: filled ${dashedCover.toFixed(2)}, detected ${solidCover.toFixed(2)}`);
  await page.screenshot({ path: join(OUT, 'relink.png') });
  await docShot(page, 'offline-pass');

  // The CVAT export carries the interpolated flag (keyframe="0"), and reads back the same.
  await page.selectOption('#export-format', 'cvat');
  const [download] = await Promise.all([page.waitForEvent('download'), page.click('#export')]);
  const xml = readFileSync(await download.path(), 'utf8');
  assert.ok(xml.includes('keyframe="0"'), 'filled shapes are not keyframes');
  const back = /** @type {Rec[]} */ (
    await page.evaluate((text) => /** @type {any} */ (window).__shapetrack.app.parse('x.xml', text).records, xml)
  );
  assert.equal(idsOf(back), st.offline.ids, 'the export has the re-linked ids');
  assert.deepEqual(
    back.filter((r) => r.interpolated).map(key).sort(),
    offline.filter((r) => r.interpolated).map(key).sort(),
    'exactly the interpolated records (coasted online, filled offline) come back interpolated',
  );
  // COCO-video says it too.
  const coco = JSON.parse(await page.evaluate(() => /** @type {any} */ (window).__shapetrack.app.exportText('coco-video')));
  const flagged = coco.annotations.reduce((/** @type {number} */ n, /** @type {any} */ a) => n + (a.interpolated ?? []).filter(Boolean).length, 0);
  assert.equal(flagged, offline.filter((r) => r.interpolated).length, 'COCO-video interpolated lists');

  // Labelling holds on the re-linked ids: merge two tracks, undo it, then undo the pass. The
  // two are never both seen in one frame (the app refuses to merge two objects).
  /** @type {Map<number, Set<number>>} */
  const seenAt = new Map();
  for (const r of offline) if (!r.interpolated) seenAt.set(r.id, (seenAt.get(r.id) ?? new Set()).add(r.frame));
  const apart = (/** @type {number} */ x, /** @type {number} */ y) => ![...(seenAt.get(x) ?? [])].some((f) => seenAt.get(y)?.has(f));
  const pair = st.ids.flatMap((/** @type {number} */ x) => st.ids.filter((/** @type {number} */ y) => y !== x && apart(x, y)).map((/** @type {number} */ y) => [x, y]))[0];
  assert.ok(pair, 'two re-linked tracks never seen in the same frame');
  const [a, b] = pair;
  await page.evaluate(([x, y]) => {
    const app = /** @type {any} */ (window).__shapetrack.app;
    app.select(x, false);
    app.select(y, true);
  }, [a, b]);
  await page.keyboard.press('m');
  await page.waitForFunction((n) => /** @type {any} */ (window).__shapetrack.state().ids.length === n, st.offline.ids - 1);
  assert.ok(!(await state(page)).ids.includes(b));
  await page.keyboard.press('Control+z');
  await page.waitForFunction((n) => /** @type {any} */ (window).__shapetrack.state().ids.length === n, st.offline.ids);
  assert.deepEqual((await records(page)).map(key), offline.map(key), 'undo restores the re-linked table');
  await page.keyboard.press('Control+z');
  await page.waitForFunction((n) => /** @type {any} */ (window).__shapetrack.state().ids.length === n, st.offline.onlineIds);
  const undone = await records(page);
  assert.deepEqual(undone.map(key).sort(), online.map(key).sort(), 'undoing the pass gives the online result back');
  await page.keyboard.press('Control+Shift+z');
  await page.waitForFunction((n) => /** @type {any} */ (window).__shapetrack.state().ids.length === n, st.offline.ids);
  assert.equal(
    (await records(page)).filter((r) => r.interpolated).length,
    offline.filter((r) => r.interpolated).length,
    'redo brings the filled records back (beside the coasted ones)',
  );

  assert.deepEqual(errors, []);
  await page.close();
});

test('no request left localhost', () => {
  assert.deepEqual(app.browser.foreign, []);
});
