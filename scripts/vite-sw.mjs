// A Vite plugin that emits sw.js next to index.html with the build's exact file list, so the
// service worker can precache the app shell, every JS chunk, the worker and the wasm on its
// first install (runtime caching alone would miss what the first visit fetched before the
// worker took control).
import { createHash } from 'node:crypto';
import { readFileSync } from 'node:fs';

/**
 * @param {{ source: string }} opts path of the service worker source, which contains the
 *   placeholders `__PRECACHE__` (a JSON array string) and `__VERSION__`
 * @returns {import('vite').Plugin}
 */
export function serviceWorker({ source }) {
  return {
    name: 'shapetrack-service-worker',
    apply: 'build',
    generateBundle(_options, bundle) {
      const files = Object.keys(bundle)
        .filter((f) => !f.endsWith('.map') && f !== 'sw.js')
        .sort();
      const hash = createHash('sha256');
      for (const f of files) {
        const item = bundle[f];
        hash.update(f);
        hash.update(item.type === 'chunk' ? item.code : item.source);
      }
      const version = hash.digest('hex').slice(0, 12);
      const code = readFileSync(source, 'utf8')
        .replace("'__PRECACHE__'", JSON.stringify(JSON.stringify(['./', ...files])))
        .replace("'__VERSION__'", JSON.stringify(version));
      this.emitFile({ type: 'asset', fileName: 'sw.js', source: code });
    },
  };
}
