// The packed npm library from a plain HTML page (examples/embed-browser.html, no bundler): the
// tarball `npm run pack:lib` writes is installed offline next to the page, an import map names
// its entry points, and the page tracks two squares crossing in a Web Worker (background
// detector + tracker + offline pass) and prints the ids it got.

import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { spawnSync } from 'node:child_process';
import { copyFileSync, mkdirSync, readdirSync, rmSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { OUT, ROOT, launch, serve, watchErrors } from './harness.mjs';

const PORT = 47397;
const SITE = join(OUT, 'lib-site');

/** @type {Awaited<ReturnType<typeof serve>>} */
let server;
/** @type {Awaited<ReturnType<typeof launch>>} */
let browser;

/** @param {string} cmd @param {string[]} args @param {string} cwd @param {Record<string, string>} [env] */
function sh(cmd, args, cwd, env = {}) {
  const r = spawnSync(cmd, args, { cwd, encoding: 'utf8', env: { ...process.env, ...env } });
  if (r.status !== 0) throw new Error(`${cmd} ${args.join(' ')}: ${r.stderr || r.stdout}`);
}

before(async () => {
  rmSync(SITE, { recursive: true, force: true });
  mkdirSync(SITE, { recursive: true });
  // The app's build step already built the wasm: pack it as it is.
  sh(process.execPath, ['scripts/pack-lib.mjs', join(SITE, 'dist')], ROOT, { SHAPETRACK_SKIP_WASM_BUILD: '1' });
  const [tgz] = readdirSync(join(SITE, 'dist'));
  writeFileSync(join(SITE, 'package.json'), JSON.stringify({ name: 'embed-page', private: true }));
  sh('npm', ['install', '--offline', '--no-audit', '--no-fund', join(SITE, 'dist', tgz)], SITE);
  copyFileSync(join(ROOT, 'examples', 'embed-browser.html'), join(SITE, 'index.html'));
  server = await serve(SITE, PORT);
  browser = await launch();
});

after(async () => {
  await browser?.close();
  await server?.close();
});

test('a plain page tracks in a Web Worker with the packed library', async () => {
  const page = await browser.context.newPage();
  const errors = watchErrors(page);
  await page.goto(server.url);
  await page.waitForFunction(() => document.getElementById('out')?.textContent?.startsWith('{'), undefined, { timeout: 120_000 });
  const out = JSON.parse((await page.textContent('#out')) ?? '{}');
  assert.equal(out.ids.length, 2, `two squares, two ids: ${JSON.stringify(out)}`);
  assert.ok(out.shapes > 40, `most frames have both squares: ${out.shapes} shapes`);
  assert.deepEqual(errors, []);
  assert.ok(server.log.some((p) => p.endsWith('/tracker-worker.js')), 'the tracker ran in the worker');
  assert.ok(server.log.some((p) => p.endsWith('/shapetrack_bg.wasm')), 'the wasm came from the package');
  assert.deepEqual(browser.foreign, [], 'no request left localhost');
});
