// End-to-end harness: a static server for the built app on an unusual localhost port, and
// Debian's Chromium driven by playwright-core (never a browser Playwright downloads), with a
// fresh profile per run and a log of every request so a test can prove none left localhost.

import { createServer } from 'node:http';
import { after, afterEach, before } from 'node:test';
import { appendFileSync, existsSync, mkdirSync, mkdtempSync, readFileSync, rmSync, statSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { extname, join, normalize, resolve, sep } from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';
import { ISOLATION_HEADERS } from '../../scripts/vite-isolation.mjs';

export const ROOT = resolve(fileURLToPath(new URL('../..', import.meta.url)));
export const DIST = join(ROOT, 'www', 'dist');
export const OUT = join(ROOT, 'target', 'e2e');
export const CHROMIUM = process.env.CHROMIUM_PATH || '/usr/bin/chromium';
/** Screenshots that www/README.md shows: `node scripts/doc-shots.mjs` copies them to www/docs. */
export const SHOTS = join(OUT, 'docs');

const MIME = {
  '.html': 'text/html; charset=utf-8',
  '.js': 'text/javascript; charset=utf-8',
  '.mjs': 'text/javascript; charset=utf-8',
  '.css': 'text/css; charset=utf-8',
  '.wasm': 'application/wasm',
  '.json': 'application/json',
  '.txt': 'text/plain; charset=utf-8',
  '.svg': 'image/svg+xml',
  '.png': 'image/png',
  '.ico': 'image/x-icon',
};

/**
 * Serves `dir` on 127.0.0.1:`port` and logs every request path. Every answer carries the
 * cross-origin isolation headers, as the app is served everywhere (scripts/vite-isolation.mjs).
 * @param {string} dir
 * @param {number} port
 */
export async function serve(dir, port) {
  if (!existsSync(join(dir, 'index.html'))) {
    throw new Error(`${dir}/index.html is missing: build the app first (npm run build)`);
  }
  /** @type {string[]} */
  const log = [];
  let last = Date.now();
  const server = createServer((req, res) => {
    const url = new URL(req.url ?? '/', `http://127.0.0.1:${port}`);
    log.push(url.pathname);
    last = Date.now();
    let path = normalize(join(dir, decodeURIComponent(url.pathname)));
    if (!path.startsWith(dir + sep) && path !== dir) {
      res.writeHead(403, ISOLATION_HEADERS).end();
      return;
    }
    if (existsSync(path) && statSync(path).isDirectory()) path = join(path, 'index.html');
    if (!existsSync(path)) {
      res.writeHead(404, ISOLATION_HEADERS).end('not found');
      return;
    }
    const type = MIME[/** @type {keyof typeof MIME} */ (extname(path))] ?? 'application/octet-stream';
    // No HTTP caching: the offline test must be served by the service worker, not the cache.
    res.writeHead(200, { 'content-type': type, 'cache-control': 'no-store', ...ISOLATION_HEADERS });
    res.end(readFileSync(path));
  });
  await new Promise((ok, fail) => {
    server.once('error', fail);
    server.listen(port, '127.0.0.1', () => ok(undefined));
  });
  return {
    url: `http://127.0.0.1:${port}/`,
    log,
    /**
     * The requests since the `from`-th that the app made: the service worker's script is left
     * out. On every navigation the browser itself checks `sw.js` for an update, and Chromium's
     * offline emulation does not cover that check (a really offline browser's check fails,
     * harmlessly); whether it lands before or after a test's assertion is timing — the
     * flaky "14 !== 13" of the demo's offline reload.
     * @param {number} from
     */
    appRequests(from) {
      return log.slice(from).filter((p) => p !== '/sw.js');
    },
    /**
     * Resolves once no request has arrived for `ms` milliseconds: a count of requests taken
     * while the first visit's last fetches are still on their way would be off by one (the
     * flaky "36 !== 35" of the offline tests). A settling wait, not a timed assertion.
     * @param {number} [ms]
     */
    async quiet(ms = 500) {
      while (Date.now() - last < ms) await new Promise((r) => setTimeout(r, 50));
    },
    close: () => new Promise((ok) => server.close(() => ok(undefined))),
  };
}

/** Whether a URL stays on this machine. */
export function isLocal(url) {
  const u = new URL(url);
  if (u.protocol === 'data:' || u.protocol === 'blob:' || u.protocol === 'about:') return true;
  return ['127.0.0.1', 'localhost', '[::1]'].includes(u.hostname);
}

/**
 * Launches Debian's Chromium headless with a throwaway profile. Every request of every page
 * and worker is recorded in `requests`; `foreign` lists those that left localhost.
 * @param {{ args?: string[] }} [opts] extra Chromium flags (e.g. a fake webcam)
 */
export async function launch({ args = [] } = {}) {
  if (!existsSync(CHROMIUM)) throw new Error(`${CHROMIUM} is missing: run node scripts/setup.mjs --e2e`);
  const profile = mkdtempSync(join(tmpdir(), 'shapetrack-e2e-'));
  const context = await chromium.launchPersistentContext(profile, {
    executablePath: CHROMIUM,
    headless: true,
    args: [
      '--headless',
      '--no-sandbox',
      '--disable-gpu',
      '--disable-quic',
      '--no-first-run',
      '--disable-background-networking',
      '--disable-component-update',
      '--disable-sync',
      // A safety net under the assertion: names other than localhost do not resolve.
      '--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE localhost, EXCLUDE 127.0.0.1',
      ...args,
    ],
    viewport: { width: 1600, height: 1000 },
    acceptDownloads: true,
  });
  /** @type {string[]} */
  const requests = [];
  /** @type {string[]} */
  const foreign = [];
  context.on('request', (req) => {
    const url = req.url();
    requests.push(url);
    if (!isLocal(url)) foreign.push(url);
  });
  return {
    context,
    requests,
    foreign,
    async close() {
      await context.close();
      rmSync(profile, { recursive: true, force: true });
    },
  };
}

/**
 * Collects page errors and console errors, which fail a test.
 * @param {import('playwright-core').Page} page
 */
export function watchErrors(page) {
  /** @type {string[]} */
  const errors = [];
  page.on('pageerror', (e) => errors.push(`pageerror: ${e.message}`));
  page.on('console', (m) => {
    if (m.type() === 'error') errors.push(`console: ${m.text()}`);
    // E2E_CONSOLE=FILE: every console line of the page appended to FILE (a hung step's last words).
    if (process.env.E2E_CONSOLE) appendFileSync(process.env.E2E_CONSOLE, `${new Date().toISOString()} [console ${m.type()}] ${m.text()}\n`);
  });
  if (process.env.E2E_CONSOLE) page.on('worker', (w) => appendFileSync(`${process.env.E2E_CONSOLE}`, `${new Date().toISOString()} [worker] ${w.url()}\n`));
  return errors;
}

/**
 * Defines `window.__openWorker(url)` in `page`: starts the app's tracker worker bundle at `url`
 * (a same-origin module) and returns `{ request, terminate }`, `request(req, transfer)` sending
 * one message of the worker protocol (www/src/worker/protocol.js) and resolving with its
 * answer (progress reports skipped). For tools that drive the worker without the app's page
 * (scripts/bench-browser.mjs, scripts/detect-eval-browser.mjs).
 * @param {import('playwright-core').Page} page
 */
export function installWorkerClient(page) {
  return page.evaluate(() => {
    /** @param {string} url */
    /** @type {any} */ (window).__openWorker = (url) => {
      const worker = new Worker(url, { type: 'module' });
      let next = 1;
      /** @type {Map<number, { resolve: (v: any) => void, reject: (e: Error) => void }>} */
      const pending = new Map();
      worker.addEventListener('message', (e) => {
        const p = pending.get(e.data.id);
        if (!p || e.data.progress) return;
        pending.delete(e.data.id);
        if (e.data.ok) p.resolve(e.data);
        else p.reject(new Error(e.data.error));
      });
      worker.addEventListener('error', (e) => {
        for (const p of pending.values()) p.reject(new Error(e.message || 'worker failed to load'));
        pending.clear();
      });
      return {
        /** @param {Record<string, unknown>} req @param {Transferable[]} [transfer] @returns {Promise<any>} */
        request: (req, transfer = []) =>
          new Promise((resolve, reject) => {
            const id = next++;
            pending.set(id, { resolve, reject });
            worker.postMessage({ ...req, id }, transfer);
          }),
        terminate: () => worker.terminate(),
      };
    };
  });
}

/**
 * The app's page state (`window.__shapetrack.state()`), or null while the page is (re)loading.
 * @param {import('playwright-core').Page} page
 * @returns {Promise<any>}
 */
export function pageState(page) {
  return page.evaluate(() => /** @type {any} */ (window).__shapetrack?.state() ?? null);
}

/**
 * Polls the page state until `pred` holds, and returns that state.
 * @param {import('playwright-core').Page} page
 * @param {(s: any) => boolean} pred
 * @param {number} [timeout] milliseconds
 */
export async function untilState(page, pred, timeout = 120_000) {
  const t0 = Date.now();
  for (;;) {
    const s = await pageState(page);
    if (s && pred(s)) return s;
    if (Date.now() - t0 > timeout) throw new Error(`timed out; state: ${JSON.stringify(s)}`);
    await new Promise((r) => setTimeout(r, 50));
  }
}

/**
 * The app under test for one test file, set up once and torn down after the file: serves the
 * built app on `port`, launches Chromium (with extra `args`), and after every test closes the
 * pages that test opened, so a test that leaves the app playing (or a dialog open) cannot break
 * the next one. A page that several tests share is kept with `keep(page)`, made in `setup`
 * (run once the browser is up: top-level `before` hooks of one file do not wait for each other).
 * @param {{ port: number, args?: string[], setup?: (app: any) => Promise<void> }} opts
 */
export function withApp({ port, args = [], setup }) {
  /** @type {Set<import('playwright-core').Page>} */
  const kept = new Set();
  const app = {
    /** @type {Awaited<ReturnType<typeof serve>>} */
    server: /** @type {any} */ (undefined),
    /** @type {Awaited<ReturnType<typeof launch>>} */
    browser: /** @type {any} */ (undefined),
    /** @param {import('playwright-core').Page} page */
    keep(page) {
      kept.add(page);
      return page;
    },
  };
  before(async () => {
    mkdirSync(OUT, { recursive: true });
    app.server = await serve(DIST, port);
    app.browser = await launch({ args });
    await setup?.(app);
  });
  afterEach(async () => {
    for (const page of app.browser?.context.pages() ?? []) {
      if (!kept.has(page)) await page.close().catch(() => {});
    }
  });
  after(async () => {
    await app.browser?.close();
    await app.server?.close();
  });
  return app;
}

/**
 * A screenshot for the docs (JPEG: the committed copies stay small), of the page or of one
 * element.
 * @param {import('playwright-core').Page} page
 * @param {string} name file name without extension
 * @param {import('playwright-core').Locator} [element]
 */
export async function docShot(page, name, element) {
  mkdirSync(SHOTS, { recursive: true });
  await (element ?? page).screenshot({ path: join(SHOTS, `${name}.jpg`), type: 'jpeg', quality: 70 });
}

/**
 * A MOTChallenge file of `tracks` tracks: track i lives for 60 frames from a start that walks
 * across `frames` frames (the timeline test and the browser bench's thousand-track session).
 * @param {number} tracks
 * @param {number} frames at least 61
 * @returns {{ text: string, last: number }} the file and the last frame any track reaches
 */
export function crowdTracks(tracks, frames) {
  const lines = [];
  let last = 0;
  for (let id = 1; id <= tracks; id++) {
    const start = 1 + ((id * 37) % (frames - 60));
    for (let f = start; f < start + 60; f++) {
      const x = (id * 13) % 1200;
      const y = (id * 7) % 680;
      lines.push(`${f},${id},${x + (f - start)},${y},30,40,1,-1,-1,-1`);
    }
    last = Math.max(last, start + 59);
  }
  return { text: lines.join('\n') + '\n', last };
}
