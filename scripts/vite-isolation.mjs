// Cross-origin isolation for the app (issue 63): the learned segmenter's runtime
// (onnxruntime-web) runs its thread pool on SharedArrayBuffer, which a page has only when it is
// cross-origin isolated: served with COOP `same-origin` and COEP `require-corp`, and its workers'
// scripts with COEP too. Every response of the app's origin carries both headers (the app
// loads nothing from another origin, so `require-corp` blocks nothing of its own), wherever it
// is served: the Vite dev server and preview (this plugin), the e2e harness's static server
// (tests/e2e/harness.mjs), and offline the service worker, whose cached responses keep the
// headers they were fetched with. A production host must send them too (www/README.md).

/** The two headers, as every response of the app's origin carries them. */
export const ISOLATION_HEADERS = Object.freeze({
  'Cross-Origin-Opener-Policy': 'same-origin',
  'Cross-Origin-Embedder-Policy': 'require-corp',
});

/**
 * The Vite plugin: sets ISOLATION_HEADERS on every response of the dev server and of
 * `vite preview`, before any other middleware answers (the SSD's and segmenter's own
 * middlewares among them). Put it first in `plugins`.
 * @returns {import('vite').Plugin}
 */
export function crossOriginIsolation() {
  /** @param {{ middlewares: { use: (fn: (req: unknown, res: import('node:http').ServerResponse, next: () => void) => void) => void } }} server */
  const install = (server) => {
    server.middlewares.use((_req, res, next) => {
      for (const [k, v] of Object.entries(ISOLATION_HEADERS)) res.setHeader(k, v);
      next();
    });
  };
  return {
    name: 'shapetrack-cross-origin-isolation',
    configureServer: install,
    configurePreviewServer: install,
  };
}
