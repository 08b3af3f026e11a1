// Vite serves and builds the app in www/. The wasm core comes from www/pkg (built by
// scripts/build-wasm.mjs, never committed); the service worker is generated at build time with
// the exact list of files to precache, so the app works offline after one visit (the SSD
// detector's files, under ssd/, are cached when first used instead).
import { defineConfig } from 'vite';
import { fileURLToPath } from 'node:url';
import { serviceWorker } from '../scripts/vite-sw.mjs';
import { SSD_DIR, ssdModel } from '../scripts/models.mjs';

const root = fileURLToPath(new URL('.', import.meta.url));

export default defineConfig({
  root,
  base: './',
  clearScreen: false,
  build: {
    outDir: 'dist',
    emptyOutDir: true,
    target: 'es2022',
    // The wasm is fetched by URL (instantiateStreaming), never inlined as base64.
    assetsInlineLimit: 0,
    // Two pages: the app, and the bench page (fps for a chosen resolution and detector).
    rollupOptions: { input: { index: `${root}index.html`, bench: `${root}bench.html` } },
  },
  // The SSD detector's model and TFLite runtime (from npm packages) are emitted by the worker
  // build, which is the only one that runs them; the page's instance serves them in dev.
  worker: { format: 'es', plugins: () => [ssdModel({ worker: true })] },
  server: { host: '127.0.0.1', port: 5173 },
  preview: { host: '127.0.0.1', port: 4173 },
  plugins: [serviceWorker({ source: fileURLToPath(new URL('./src/sw.js', import.meta.url)), lazy: [SSD_DIR] }), ssdModel()],
});
