// The production build served the way the README serves it (`vite preview` with the repo's
// config, the server's own headers: it answers with `Vary: Origin`, and the page asks for its
// module script and CSS with an Origin header), not the test server of the other suites (which
// sends no Vary). After one visit, the app must come up styled and working with the network
// off (issue 66: the service worker's lookup missed on Vary, and the page came up unstyled and
// dead; a second online visit hid it).

import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { spawn } from 'node:child_process';
import { existsSync, mkdirSync } from 'node:fs';
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
