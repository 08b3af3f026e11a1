// The service worker: the app works with the network off after the first visit.
//
// The build (scripts/vite-sw.mjs) replaces the two placeholders with the version and the exact
// list of built files. Precached files are served cache-first (they are content-hashed, so a
// cached file is never stale); a new build has a new version, installs a new cache and drops
// the old one. Anything else from this origin is fetched and kept for next time.

/// <reference lib="webworker" />
const sw = /** @type {ServiceWorkerGlobalScope} */ (/** @type {unknown} */ (self));

const VERSION = '__VERSION__';
const PRECACHE = /** @type {string[]} */ (JSON.parse('__PRECACHE__'));
const CACHE = `shapetrack-${VERSION}`;

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
      .then((keys) => Promise.all(keys.filter((k) => k.startsWith('shapetrack-') && k !== CACHE).map((k) => caches.delete(k))))
      .then(() => sw.clients.claim()),
  );
});

sw.addEventListener('fetch', (event) => {
  const req = event.request;
  const url = new URL(req.url);
  if (req.method !== 'GET' || url.origin !== sw.location.origin) return;
  event.respondWith(respond(req));
});

/** @param {Request} req */
async function respond(req) {
  const cache = await caches.open(CACHE);
  // Navigations (any query string) get the app shell.
  const key = req.mode === 'navigate' ? new URL('./', sw.registration.scope).href : req;
  const hit = await cache.match(key, { ignoreSearch: req.mode === 'navigate' });
  if (hit) return hit;
  const res = await fetch(req);
  if (res.ok && res.type === 'basic') await cache.put(req, res.clone());
  return res;
}
