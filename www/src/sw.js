// The service worker: the app works with the network off after the first visit.
//
// The build (scripts/vite-sw.mjs) replaces the placeholders with the versions and the exact
// lists of built files. The install precaches the app shell, the JS, the worker and the
// shapetrack wasm; a new build has a new version, installs a new cache and drops the old one.
// Precached files are served cache-first (they are content-hashed, so a cached file is never
// stale).
//
// Folders in LAZY (the SSD detector's model and TFLite runtime, ~19 MB that most visitors
// never need) are not precached: each file is cached the first time it is fetched and served
// from that cache afterwards, so the detector works offline once it has been used online.
// That cache is named after those files' content, so an app update that does not change them
// keeps it. Anything else from this origin is fetched and kept for next time.

/// <reference lib="webworker" />
const sw = /** @type {ServiceWorkerGlobalScope} */ (/** @type {unknown} */ (self));

const VERSION = '__VERSION__';
const PRECACHE = /** @type {string[]} */ (JSON.parse('__PRECACHE__'));
const CACHE = `shapetrack-${VERSION}`;
const LAZY_VERSION = '__LAZY_VERSION__';
const LAZY = /** @type {string[]} */ (JSON.parse('__LAZY__'));
const LAZY_CACHE = `shapetrack-lazy-${LAZY_VERSION}`;

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
        Promise.all(keys.filter((k) => k.startsWith('shapetrack-') && k !== CACHE && k !== LAZY_CACHE).map((k) => caches.delete(k))),
      )
      .then(() => sw.clients.claim()),
  );
});

sw.addEventListener('fetch', (event) => {
  const req = event.request;
  const url = new URL(req.url);
  if (req.method !== 'GET' || url.origin !== sw.location.origin) return;
  event.respondWith(respond(req, url));
});

/**
 * @param {Request} req
 * @param {URL} url
 */
async function respond(req, url) {
  const scope = new URL(sw.registration.scope);
  const path = url.pathname.startsWith(scope.pathname) ? url.pathname.slice(scope.pathname.length) : null;
  const lazy = path !== null && LAZY.some((p) => path.startsWith(p));
  const cache = await caches.open(lazy ? LAZY_CACHE : CACHE);
  // Navigations (any query string) get the app shell.
  const key = req.mode === 'navigate' ? new URL('./', scope).href : req;
  const hit = await cache.match(key, { ignoreSearch: req.mode === 'navigate' });
  if (hit) return hit;
  const res = await fetch(req);
  if (res.ok && res.type === 'basic') await cache.put(req, res.clone());
  return res;
}
