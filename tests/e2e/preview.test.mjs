// The production build served the way the README serves it (`vite preview` with the repo's
// config, the server's own headers: it answers with `Vary: Origin`, and the page asks for its
// module script and CSS with an Origin header), not the test server of the other suites (which
// sends no Vary). After one visit, the app must come up styled and working with the network
// off (issue 66: the service worker's lookup missed on Vary, and the page came up unstyled and
// dead; a second online visit hid it).

import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { spawn } from 'node:child_process';
import { existsSync, mkdirSync, readFileSync, readdirSync } from 'node:fs';
import { join } from 'node:path';
import { DIST, OUT, ROOT, launch, watchErrors } from './harness.mjs';

const PORT = 47451;
const URL_ = `http://127.0.0.1:${PORT}/`;

/** @type {import('node:child_process').ChildProcess | undefined} */
let server;
/** @type {Awaited<ReturnType<typeof launch>> | undefined} */
let browser;

/** Resolves once the preview server answers (it takes a moment to start), or rejects. */
async function ready() {
  const deadline = Date.now() + 60_000;
  for (;;) {
    if (server?.exitCode != null) throw new Error(`vite preview exited with ${server.exitCode}`);
    try {
      const res = await fetch(URL_);
      if (res.ok) return res;
    } catch {
      // Not listening yet.
    }
    if (Date.now() > deadline) throw new Error('vite preview did not answer within 60 s');
    await new Promise((r) => setTimeout(r, 200));
  }
}

before(async () => {
  if (!existsSync(join(DIST, 'index.html'))) throw new Error(`${DIST}/index.html is missing: build the app first (npm run build)`);
  mkdirSync(OUT, { recursive: true });
  const vite = join(ROOT, 'node_modules', 'vite', 'bin', 'vite.js');
  server = spawn(process.execPath, [vite, 'preview', '--config', 'www/vite.config.js', '--port', String(PORT), '--strictPort'], {
    cwd: ROOT,
    stdio: ['ignore', 'ignore', 'inherit'],
  });
  await ready();
  browser = await launch();
});

after(async () => {
  await browser?.close();
  server?.kill();
});

test('the preview server sends Vary and the isolation headers (what the offline test below relies on)', async () => {
  const html = await (await fetch(URL_)).text();
  const script = /<script type="module" crossorigin src="([^"]+)"/.exec(html);
  assert.ok(script, 'the page loads a module script');
  const res = await fetch(new URL(script[1], URL_), { headers: { origin: URL_.replace(/\/$/, '') } });
  assert.equal(res.status, 200);
  assert.match(res.headers.get('vary') ?? '', /origin/i, 'the server answers with Vary: Origin');
  assert.equal(res.headers.get('cross-origin-opener-policy'), 'same-origin');
});

test('after one visit to the preview server the app comes up styled and working offline', async () => {
  assert.ok(browser);
  const page = await browser.context.newPage();
  const errors = watchErrors(page);
  await page.goto(`${URL_}?demo=0`);
  await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack));
  await page.evaluate(async () => {
    await navigator.serviceWorker.ready;
    if (!navigator.serviceWorker.controller) {
      await new Promise((r) => navigator.serviceWorker.addEventListener('controllerchange', r, { once: true }));
    }
  });
  const styled = () => page.evaluate(() => [...document.styleSheets].some((s) => s.href !== null && s.cssRules.length > 0));
  assert.equal(await styled(), true, 'styled online');
  await browser.context.setOffline(true);
  try {
    await page.reload();
    await page.waitForFunction(() => !!(/** @type {any} */ (window).__shapetrack), null, { timeout: 30_000 });
    assert.equal(await styled(), true, 'the stylesheet came from the cache');
    assert.equal(await page.evaluate(() => crossOriginIsolated), true, 'cross-origin isolated offline');
    // The app works: a MOTChallenge file imports through the wasm core.
    const mot = '1,1,10,10,20,30,1,-1,-1,-1\n2,1,12,10,20,30,1,-1,-1,-1\n';
    await page.setInputFiles('#file-import', { name: 'boxes.txt', mimeType: 'text/plain', buffer: Buffer.from(mot) });
    await page.waitForFunction(() => /** @type {any} */ (window).__shapetrack.state().ids.length === 1);
    await page.screenshot({ path: join(OUT, 'preview-offline.png') });
  } finally {
    await browser.context.setOffline(false);
  }
  assert.deepEqual(errors, []);
  await page.close();
});

/** The scripted walk-through's screenshots, for review (target/e2e/walkthrough/). */
const WALK = join(OUT, 'walkthrough');
const BAG = join(ROOT, '..', 'shared', 'data', 'vot-bag');

test('a newcomer\'s walk through www/README.md "How to label a video", on the production build', async () => {
  assert.ok(browser);
  mkdirSync(WALK, { recursive: true });
  const page = await browser.context.newPage();
  await page.setViewportSize({ width: 1280, height: 720 });
  const errors = watchErrors(page);
  const state = () => page.evaluate(() => /** @type {any} */ (window).__shapetrack.state());
  const shot = (/** @type {string} */ name) => page.screenshot({ path: join(WALK, `${name}.png`) });

  // The page opens on the demo, which plays.
  await page.goto(URL_);
  await page.waitForFunction(() => /** @type {any} */ (window).__shapetrack?.state().processed >= 10, undefined, { timeout: 60_000 });
  await shot('01-demo');

  // 1. Leave the detector on Automatic, the mode Online; open a folder of frames and play it.
  assert.equal(await page.inputValue('#detector'), 'auto');
  await page.selectOption('#speed', 'max');
  await page.setInputFiles('#file-folder', BAG);
  await page.waitForFunction(() => /** @type {any} */ (window).__shapetrack.state().source?.kind === 'images', undefined, { timeout: 60_000 });
  await page.waitForFunction(() => /** @type {any} */ (window).__shapetrack.state().processed >= 1);
  assert.equal((await state()).source.name, 'vot-bag');
  await shot('02-folder-opened');
  await page.keyboard.press('Space');
  const frames = readdirSync(BAG).filter((f) => f.endsWith('.jpg')).length;
  await page.waitForFunction((n) => /** @type {any} */ (window).__shapetrack.state().status.startsWith(`done: ${n} frames tracked`), frames, { timeout: 300_000 });
  await shot('03-tracked');

  // 2. The timeline has a row per track; 3. select one in the track list and renumber it (N).
  const ids = (await state()).ids;
  assert.ok(ids.length >= 1, 'the bag was tracked');
  await page.click('#track-list li[data-id]');
  const picked = (await state()).selection.a;
  assert.ok(picked !== null, 'a click on a row selects its track');
  await page.keyboard.press('n');
  await page.fill('#renumber-input', '500');
  await page.press('#renumber-input', 'Enter');
  assert.ok((await state()).ids.includes(500));
  await shot('04-renumbered');

  // 4. ? shows the shortcuts and the legend.
  await page.keyboard.press('?');
  assert.ok(await page.locator('#help-title').isVisible());
  await shot('05-help');
  await page.keyboard.press('Escape');

  // 5. Export MOT: the file is named after the folder and holds the renumbered track.
  await page.selectOption('#export-format', 'mot');
  const [download] = await Promise.all([page.waitForEvent('download'), page.click('#export')]);
  assert.match(download.suggestedFilename(), /^vot-bag\./);
  const text = readFileSync(await download.path(), 'utf8');
  assert.ok(text.split('\n').some((l) => l.split(',')[1] === '500'), 'track 500 is in the export');
  await shot('06-exported');
  assert.deepEqual(errors, []);
  await page.close();
});
