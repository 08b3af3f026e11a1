export * from './pkg/shapetrack.js';

/**
 * Instantiates the wasm core once (later calls return the same promise). In Node the module is
 * read from the package; in a page or a worker it is fetched from next to `index.js`. Pass
 * `source` when it lives elsewhere.
 */
export function load(source?: BufferSource | WebAssembly.Module | URL | string | Response | Promise<Response>): Promise<void>;

/**
 * Copies RGBA pixels (`width·height·4` bytes, e.g. `ImageData.data`) into a FrameBuffer; throws
 * when the length does not match or the core is not loaded.
 */
export function writeRgba(buffer: import('./pkg/shapetrack.js').FrameBuffer, rgba: ArrayLike<number>): void;
