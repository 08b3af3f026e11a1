// A labelling session with a thousand tracks: the timeline keeps rows readable (each carries its
// id) and scrolls, zooms and pans along time, follows a track selected elsewhere, and the track
// list is virtualised (a few dozen elements, not a thousand). Functional checks only: how fast a
// redraw is belongs to the bench page, not to a test.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { crowdTracks, docShot, watchErrors, withApp, untilState } from './harness.mjs';

const PORT = 47396;
const TRACKS = 1000;
const FRAMES = 600;
const CROWD = crowdTracks(TRACKS, FRAMES);
/** The last frame any track reaches (the timeline's length: an import has no other end). */
const LAST = CROWD.last;

const app = withApp({ port: PORT });

/** The timeline's range readout. @param {import('playwright-core').Page} page */
const readout = (page) => page.evaluate(() => document.getElementById('tl-range')?.textContent ?? '');

/** Waits one animation frame (the app draws once per frame). @param {import('playwright-core').Page} page */
const nextFrame = (page) => page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(() => r(undefined)))));

test('a thousand tracks: readable rows, scroll, zoom, pan, reveal, and a virtualised list', async () => {
  const page = await app.browser.context.newPage();
  const errors = watchErrors(page);
  await page.goto(`${app.server.url}?demo=0`);
  await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
  await page.setInputFiles('#file-import', { name: 'crowd.txt', mimeType: 'text/plain', buffer: Buffer.from(CROWD.text) });
  await untilState(page, (s) => s.ids.length === TRACKS);
  await nextFrame(page);

  // Rows stay readable: tall enough for an id label, so only some fit and the rest scroll.
  const tl0 = await page.evaluate(() => {
    const tl = /** @type {any} */ (window).__shapetrack.app.timeline;
    return { rowH: tl.rowH / (globalThis.devicePixelRatio || 1), top: tl.view.top, visible: tl.view.visible };
  });
  assert.ok(tl0.rowH >= 12, `rows are ${tl0.rowH} px: too small to read an id`);
  assert.ok(tl0.visible < TRACKS);
  assert.match(await readout(page), new RegExp(`^tracks 1–${tl0.visible} of ${TRACKS} · frames 1–${LAST}$`));

  // The wheel scrolls rows.
  const box = await page.locator('#timeline').boundingBox();
  assert.ok(box);
  await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
  await page.mouse.wheel(0, 100);
  await nextFrame(page);
  assert.match(await readout(page), new RegExp(`^tracks 4–${tl0.visible + 3} of ${TRACKS}`));

  // Ctrl+wheel zooms the frame axis around the pointer; Shift+wheel pans; "All frames" resets.
  await page.keyboard.down('Control');
  for (let i = 0; i < 4; i++) await page.mouse.wheel(0, -100);
  await page.keyboard.up('Control');
  await nextFrame(page);
  const zoomed = (await readout(page)).match(/frames (\d+)–(\d+) of (\d+)/);
  assert.ok(zoomed, `zoomed readout: ${await readout(page)}`);
  const [a, b] = [Number(zoomed[1]), Number(zoomed[2])];
  assert.ok(b - a + 1 < LAST / 2, `four notches show fewer frames: ${a}–${b}`);
  assert.ok(a <= LAST / 2 && LAST / 2 <= b, 'the frame under the pointer (the middle) stays in view');
  await page.keyboard.down('Shift');
  await page.mouse.wheel(0, 100);
  await page.keyboard.up('Shift');
  await nextFrame(page);
  const panned = (await readout(page)).match(/frames (\d+)–(\d+)/);
  assert.ok(panned && Number(panned[1]) > a, `Shift+wheel pans later: ${await readout(page)}`);
  await page.click('#tl-all');
  await nextFrame(page);
  assert.match(await readout(page), new RegExp(`frames 1–${LAST}$`));

  // A track selected elsewhere (here: through the app, as the stage or the list would) is
  // scrolled into view on the timeline; a click on its bar selects it and seeks there.
  const target = 900;
  await page.evaluate((id) => /** @type {any} */ (window).__shapetrack.app.select(id, false), target);
  await nextFrame(page);
  const span = await page.evaluate((id) => /** @type {any} */ (window).__shapetrack.app.model.table.span(id), target);
  const frame = Math.round((span[0] + span[1]) / 2);
  const cell = await page.evaluate(([id, f]) => /** @type {any} */ (window).__shapetrack.app.timeline.cellAt(id, f), [target, frame]);
  assert.ok(cell, `track ${target} was scrolled into view`);
  await docShot(page, 'timeline-1000', page.locator('.stage-wrap'));
  await page.evaluate(() => /** @type {any} */ (window).__shapetrack.app.deselect());
  await page.mouse.click(cell.x, cell.y);
  await page.waitForFunction((f) => /** @type {any} */ (window).__shapetrack.state().frame === f, frame);
  const st = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.state());
  assert.deepEqual(st.selection, { a: target, b: null });

  // The track list holds the rows in view, not a thousand elements, and still reaches the end.
  assert.equal(await page.textContent('#track-count'), String(TRACKS));
  const items = await page.locator('#track-list li[data-id]').count();
  assert.ok(items > 5 && items < 100, `${items} list elements for ${TRACKS} tracks`);
  assert.equal(await page.locator(`#track-list li.sel[data-id="${target}"]`).count(), 1, 'the selected track is in the list');
  await page.evaluate(() => {
    const el = /** @type {HTMLElement} */ (document.getElementById('track-list'));
    el.scrollTop = el.scrollHeight;
  });
  await page.waitForSelector(`#track-list li[data-id="${TRACKS}"]`);
  await page.click(`#track-list li[data-id="${TRACKS}"]`);
  await untilState(page, (s) => s.selection.a === TRACKS);

  // Compact rows show many more tracks at once (ids then live in the tooltip).
  await page.click('#tl-rows');
  await nextFrame(page);
  const compact = await page.evaluate(() => /** @type {any} */ (window).__shapetrack.app.timeline.view.visible);
  assert.ok(compact > 3 * tl0.visible, `compact rows: ${compact} in view vs ${tl0.visible}`);
  assert.deepEqual(errors, []);
});
