// shapetrack as a library: the Rust core's wasm bindings (every class and function of
// `pkg/shapetrack.js`) plus `load()`, which instantiates the module once wherever it runs — in
// Node it reads the .wasm next to this file, in a page or a worker it fetches it from there
// (bundlers see the `new URL(…, import.meta.url)` and ship the file). Nothing is downloaded
// from anywhere else.

import init from './pkg/shapetrack.js';

export * from './pkg/shapetrack.js';

/** @type {Promise<{ memory: WebAssembly.Memory }> | null} */
let ready = null;

/** The instance's memory, once loaded: FrameBuffers live in it. @type {WebAssembly.Memory | null} */
let mem = null;

/**
 * Instantiates the wasm core (once; later calls return the same promise).
 * @param {BufferSource | WebAssembly.Module | URL | string | Response | Promise<Response>} [source]
 *   where the module is, when not next to this file (e.g. a URL your server maps)
 * @returns {Promise<void>}
 */
export function load(source) {
  ready ??= (async () => {
    if (source !== undefined) return init({ module_or_path: source });
    const url = new URL('./pkg/shapetrack_bg.wasm', import.meta.url);
    if (url.protocol === 'file:') {
      // Node: fetch() does not read file: URLs. The specifier is a variable so bundlers for the
      // browser do not try to resolve a Node module.
      const fs = 'node:fs/promises';
      const { readFile } = await import(/* @vite-ignore */ /* webpackIgnore: true */ fs);
      return init({ module_or_path: await readFile(url) });
    }
    return init({ module_or_path: url });
  })();
  return ready.then((out) => {
    mem = out.memory;
  });
}

/**
 * Copies RGBA pixels (`width·height·4` bytes, e.g. `ImageData.data`) into a FrameBuffer. The view
 * on wasm memory is built for this one copy: any allocation in wasm may move it.
 * @param {import('./pkg/shapetrack.js').FrameBuffer} buffer
 * @param {ArrayLike<number>} rgba
 */
export function writeRgba(buffer, rgba) {
  if (!mem) throw new Error('shapetrack: call load() first');
  if (rgba.length !== buffer.len()) {
    throw new Error(`shapetrack: ${rgba.length} bytes for a ${buffer.width}×${buffer.height} frame (needs ${buffer.len()})`);
  }
  new Uint8Array(mem.buffer, buffer.ptr(), buffer.len()).set(rgba);
}
