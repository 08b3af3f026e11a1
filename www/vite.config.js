// Vite serves and builds the app in www/. The wasm core comes from www/pkg (built by
// scripts/build-wasm.mjs, never committed); the service worker is generated at build time with
// the exact list of files to precache, so the app works offline after one visit (the SSD
// detector's files, under ssd/, and the learned segmenter's, under seg/, are cached when first
// used instead). Every response carries the cross-origin isolation headers
// (scripts/vite-isolation.mjs): the segmenter's runtime needs them for more than one thread.
import { defineConfig } from 'vite';
import { fileURLToPath } from 'node:url';
import { serviceWorker } from '../scripts/vite-sw.mjs';
import { crossOriginIsolation } from '../scripts/vite-isolation.mjs';
import { SSD_DIR, ssdModel } from '../scripts/models.mjs';
import { SEG_DIR, segmenterModel } from '../scripts/segmenter-model.mjs';

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
  // The SSD detector's model and TFLite runtime, and the segmenter's model and ONNX runtime
  // (from npm packages), are emitted by the worker build, which is the only one that runs them;
  // the page's instances serve them in dev.
  worker: { format: 'es', plugins: () => [ssdModel({ worker: true }), segmenterModel({ worker: true })] },
  server: { host: '127.0.0.1', port: 5173 },
  preview: { host: '127.0.0.1', port: 4173 },
  plugins: [
    // First: its headers go on every response, the other plugins' middlewares' included.
    crossOriginIsolation(),
    serviceWorker({ source: fileURLToPath(new URL('./src/sw.js', import.meta.url)), lazy: [SSD_DIR, SEG_DIR] }),
    ssdModel(),
    segmenterModel(),
  ],
});
