// Loads the wasm core once per JS realm (the page and each worker get their own instance).
//
// The page uses it for file formats, mask decoding and metrics; the worker for tracking. The
// `memory` export is what FrameBuffer views are built on.

import init, * as core from '../../pkg/shapetrack.js';

/** @typedef {typeof core} Core */

/** @type {Promise<{ core: Core, memory: WebAssembly.Memory }> | null} */
let loading = null;

/** @returns {Promise<{ core: Core, memory: WebAssembly.Memory }>} */
export function loadCore() {
  loading ??= init().then((exports) => ({ core, memory: exports.memory }));
  return loading;
}
