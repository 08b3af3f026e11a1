// A Vite plugin that emits sw.js next to index.html with the build's exact file lists, so the
// service worker can precache the app shell, every JS chunk, the worker and the wasm on its
// first install (runtime caching alone would miss what the first visit fetched before the
// worker took control).
//
// Files under a `lazy` folder (the SSD detector's model and runtime, ~19 MB, see
// scripts/models.mjs; the learned segmenter's, ~19 MB, scripts/segmenter-model.mjs) are left
// out of the install: most visitors never use them. The service worker caches each of them
// the first time it is fetched, in a cache per folder named after that folder's content, so a
// feature works offline once it has been used online, and an app update that leaves a
// folder's files unchanged keeps its cache.
import { createHash } from 'node:crypto';
import { readFileSync } from 'node:fs';

/**
 * The build's files split into what the install precaches and what is cached on first use,
 * with a version for each set (a hash of names and contents): `lazyVersion` of all lazy files,
 * `lazyVersions` of each lazy folder's.
 * @param {Record<string, { type: 'chunk', code: string } | { type: 'asset', source: string | Uint8Array }>} bundle
 * @param {string[]} lazy folder prefixes (relative to the build root) cached on first use
 */
export function splitBundle(bundle, lazy) {
  const files = Object.keys(bundle)
    .filter((f) => !f.endsWith('.map') && f !== 'sw.js')
    .sort();
  const isLazy = (/** @type {string} */ f) => lazy.some((p) => f.startsWith(p));
  const version = (/** @type {string[]} */ list) => {
    const hash = createHash('sha256');
    for (const f of list) {
      const item = bundle[f];
      hash.update(f);
      hash.update(item.type === 'chunk' ? item.code : item.source);
    }
    return hash.digest('hex').slice(0, 12);
  };
  const precache = files.filter((f) => !isLazy(f));
  const onDemand = files.filter(isLazy);
  /** @type {Record<string, string>} */
  const lazyVersions = Object.fromEntries(lazy.map((p) => [p, version(onDemand.filter((f) => f.startsWith(p)))]));
  return { precache, onDemand, version: version(precache), lazyVersion: version(onDemand), lazyVersions };
}

/**
 * @param {{ source: string, lazy?: string[] }} opts `source`: path of the service worker
 *   source, with the placeholders `__PRECACHE__` and `__LAZY__` (JSON array strings),
 *   `__LAZY_VERSIONS__` (a JSON object string: folder → version) and `__VERSION__`; `lazy`:
 *   folders cached on first use
 * @returns {import('vite').Plugin}
 */
export function serviceWorker({ source, lazy = [] }) {
  return {
    name: 'shapetrack-service-worker',
    apply: 'build',
    // After Vite's HTML plugin has emitted the pages, so the bench page is precached too.
    enforce: 'post',
    generateBundle(_options, bundle) {
      const split = splitBundle(/** @type {any} */ (bundle), lazy);
      const code = readFileSync(source, 'utf8')
        .replace("'__PRECACHE__'", JSON.stringify(JSON.stringify(['./', ...split.precache])))
        .replace("'__LAZY__'", JSON.stringify(JSON.stringify(lazy)))
        .replace("'__VERSION__'", JSON.stringify(split.version))
        .replace("'__LAZY_VERSIONS__'", JSON.stringify(JSON.stringify(split.lazyVersions)));
      this.emitFile({ type: 'asset', fileName: 'sw.js', source: code });
    },
  };
}
