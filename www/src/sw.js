// The service worker: the app works with the network off after the first visit.
//
// The build (scripts/vite-sw.mjs) replaces the placeholders with the versions and the exact
// lists of built files. The install precaches the app shell, the JS, the worker and the
// shapetrack wasm; a new build has a new version, installs a new cache and drops the old one.
// Precached files are served cache-first (they are content-hashed, so a cached file is never
// stale).
//
// Folders in LAZY (the SSD detector's model and TFLite runtime under ssd/, ~19 MB; the learned
// segmenter's model and ONNX runtime under seg/, ~19 MB: files most visitors never need) are
// not precached: each file is cached the first time it is fetched and served from that cache
// afterwards, so the feature works offline once it has been used online. Each folder has its
// own cache, named after that folder's content, so an app update that does not change a
// folder's files keeps its cache. Anything else from this origin is fetched and kept for next
// time.
//
// A response fetched here is handed to the page while its copy is written to the cache (not
// after): a large model then streams to the page as it arrives, and its download progress
// shows, instead of jumping from nothing to all once the cache holds it.
//
// Cached responses keep their headers, the cross-origin isolation headers among them (the app
// is served with them: see www/vite.config.js), so an offline page is isolated as an online one.

/// <reference lib="webworker" />
const sw = /** @type {ServiceWorkerGlobalScope} */ (/** @type {unknown} */ (self));

const VERSION = '__VERSION__';
const PRECACHE = /** @type {string[]} */ (JSON.parse('__PRECACHE__'));
const CACHE = `shapetrack-${VERSION}`;
const LAZY = /** @type {string[]} */ (JSON.parse('__LAZY__'));
const LAZY_VERSIONS = /** @type {Record<string, string>} */ (JSON.parse('__LAZY_VERSIONS__'));
/** The cache of each lazy folder: `shapetrack-lazy-ssd-<version>` for `ssd/`. */
const LAZY_CACHES = Object.fromEntries(LAZY.map((p) => [p, `shapetrack-lazy-${p.replace(/\/+$/, '').replace(/[^\w-]/g, '_')}-${LAZY_VERSIONS[p]}`]));
const KEEP = new Set([CACHE, ...Object.values(LAZY_CACHES)]);

sw.addEventListener('install', (event) => {
  event.waitUntil(
    caches
      .open(CACHE)
      .then((cache) => cache.addAll(PRECACHE))
      .then(() => sw.skipWaiting()),
  );
});

sw.addEventListener('activate', (event) => {
  event.waitUntil(
    caches
      .keys()
      .then((keys) =>
        Promise.all(keys.filter((k) => k.startsWith('shapetrack-') && !KEEP.has(k)).map((k) => caches.delete(k))),
      )
      .then(() => sw.clients.claim()),
  );
});

sw.addEventListener('fetch', (event) => {
  const req = event.request;
  const url = new URL(req.url);
  if (req.method !== 'GET' || url.origin !== sw.location.origin) return;
  event.respondWith(respond(req, url, event));
});

/**
 * @param {Request} req
 * @param {URL} url
 * @param {FetchEvent} event
 */
async function respond(req, url, event) {
  const scope = new URL(sw.registration.scope);
  const path = url.pathname.startsWith(scope.pathname) ? url.pathname.slice(scope.pathname.length) : null;
  const lazy = path === null ? undefined : LAZY.find((p) => path.startsWith(p));
  const cache = await caches.open(lazy ? LAZY_CACHES[lazy] : CACHE);
  // A navigation (any query string) gets its page when it is precached (the app, the bench
  // page), the app shell otherwise. Vary is ignored: a server that answers `Vary: Origin`
  // (vite preview does, as the README serves the app) would otherwise never match the page's
  // module script and CSS, requested with an Origin header, against the copies the install
  // stored without one, and the page came up unstyled and dead offline. Every cached file is
  // this origin's and content-hashed or versioned, so no variant can be the wrong one.
  const opts = { ignoreVary: true };
  const hit =
    req.mode === 'navigate'
      ? ((await cache.match(req, { ...opts, ignoreSearch: true })) ?? (await cache.match(new URL('./', scope).href, opts)))
      : await cache.match(req, opts);
  if (hit) return hit;
  const res = await fetch(req);
  if (res.ok && res.type === 'basic') {
    // Written while the page reads the response (see the top of this file); the worker stays
    // alive until the copy is stored.
    event.waitUntil(cache.put(req, res.clone()).catch((e) => console.warn(`service worker: ${url.pathname} not cached:`, e)));
  }
  return res;
}
