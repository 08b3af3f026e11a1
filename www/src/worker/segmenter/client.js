// The client of the segmenter worker (./segmenter-worker.js): a promise API over its messages.
//
// Where it is spawned: in the app, by the tracker worker (a nested dedicated worker, as the
// scene feeder is, ../feed.js). The segmenter's input is a crop the Rust core cuts from the
// frame in the tracker worker's wasm memory, and its output goes back to the core there to
// become a mask; spawned from the tracker worker, the 1.2 MB input and 0.4 MB output go
// straight between the two workers (transferred), while from the page every run would cross
// the page's main thread twice, which is busy painting frames and the overlay. Its own worker,
// not the tracker worker itself: an inference takes about a second on this project's 2-core
// machine, and the tracker must keep its frame rate meanwhile (the other core runs the model).
// The page can spawn one as well (the tests and the benchmark do, through
// `window.__shapetrack.segmenter()`): the class only needs `Worker`.
//
//   const seg = new SegmenterClient();
//   seg.onProgress = ({ loaded, total }) => …;          // bytes of the model + runtime
//   const { backend, threads } = await seg.start();     // fetched, checked, session started
//   const probs = await seg.run(input);                 // Float32Array 3·s·s → s·s (s = 320 or 256)
//   seg.dispose();

import { SegmenterError, sideOfInput } from './contract.js';

/**
 * @typedef {import('./net.js').LoadProgress} LoadProgress
 * @typedef {import('./contract.js').SegmenterErrorCode} SegmenterErrorCode
 *
 * @typedef {import('./net.js').BackendChoice} BackendChoice
 *
 * @typedef {{ type: 'load', id: number, threads?: number, backend?: BackendChoice }
 *   | { type: 'run', id: number, input: Float32Array }
 *   | { type: 'dispose', id: number }} SegmenterRequest  messages to the segmenter worker;
 *   `run`'s input buffer is transferred
 * @typedef {{ type: 'progress', id: number, loaded: number, total: number }
 *   | { type: 'loaded', id: number, backend: 'wasm' | 'webgpu', threads: number, gpuSkipped: string | null, ms: number }
 *   | { type: 'result', id: number, output: Float32Array, ms: number }
 *   | { type: 'disposed', id: number }
 *   | { type: 'error', id: number, code: SegmenterErrorCode, message: string }} SegmenterReply
 *   messages from it: `progress` before a load's `loaded`; `result`'s buffer is transferred;
 *   `error` answers the request `id` that failed (-1: a message without an id)
 *
 * @typedef {{ backend: 'wasm' | 'webgpu', threads: number, gpuSkipped: string | null, ms: number }} Started
 *   the backend and CPU thread count the net runs with, why it is not on WebGPU (null when it
 *   is), and how long the load took in the worker
 *
 * @typedef {{
 *   postMessage: (msg: SegmenterRequest, transfer: Transferable[]) => void,
 *   addEventListener: (type: 'message' | 'error' | 'messageerror', listener: (e: any) => void) => void,
 *   terminate: () => void,
 * }} SegmenterPort  the worker (or, in tests, a stand-in for one)
 */

/** Spawns the app's segmenter worker (bundled by Vite from this URL). */
function spawn() {
  return new Worker(new URL('./segmenter-worker.js', import.meta.url), { type: 'module', name: 'shapetrack-segmenter' });
}

export class SegmenterClient {
  /**
   * Nothing starts until `start()`.
   * @param {{ threads?: number, backend?: BackendChoice, worker?: () => SegmenterPort }} [opts]
   *   `threads`: CPU threads the net may use (default 1, the right count beside a tracker
   *   worker on a 2-core machine; more take effect only in a cross-origin isolated page);
   *   `backend`: `auto` (default: WebGPU on a hardware adapter, else the CPU), `wasm` or
   *   `webgpu`; `worker`: makes the worker (default: the app's segmenter worker)
   */
  constructor({ threads = 1, backend = 'auto', worker = spawn } = {}) {
    this.threads = threads;
    this.backend = backend;
    this.makeWorker = worker;
    /** @type {((p: LoadProgress) => void) | null} called with each progress report of the load */
    this.onProgress = null;
    /** @type {SegmenterPort | null} */
    this.port = null;
    /** @type {Promise<Started> | null} */
    this.started = null;
    /** @type {Started | null} what the net runs on, once started */
    this.info = null;
    this.next = 1;
    /** @type {Map<number, { resolve: (r: any) => void, reject: (e: SegmenterError) => void }>} */
    this.pending = new Map();
    /** @type {SegmenterError | null} set once the worker is gone (failed or disposed) */
    this.dead = null;
  }

  /**
   * Starts the worker and loads the net (fetch with progress, checks, session). Calling it
   * again returns the same promise; after a failed load it tries again.
   * @returns {Promise<Started>}
   */
  start() {
    this.started ??= this.request({ type: 'load', threads: this.threads, backend: this.backend }).then(
      (/** @type {Started} */ r) => (this.info = { backend: r.backend, threads: r.threads, gpuSkipped: r.gpuSkipped, ms: r.ms }),
      (/** @type {SegmenterError} */ e) => {
        this.started = null;
        throw e;
      },
    );
    return this.started;
  }

  /**
   * Runs the net on one input: 3·side·side floats (CHW, RGB, normalised; `sideOfInput`),
   * resolves with side·side probabilities. The input is copied into a buffer that is transferred (a view on wasm
   * memory cannot be), unless `transfer`: then `input`'s own buffer is transferred and
   * detached here, which needs `input` to span its whole buffer.
   * @param {Float32Array} input
   * @param {{ transfer?: boolean }} [opts]
   * @returns {Promise<Float32Array>}
   */
  async run(input, { transfer = false } = {}) {
    if (!(input instanceof Float32Array) || sideOfInput(input.length) === null) {
      throw new SegmenterError('input', `segmenter: run() takes a Float32Array of 3·side·side (side a multiple of 32 from 128 to 320), not ${input instanceof Float32Array ? `one of ${input.length}` : typeof input}`);
    }
    if (transfer && (input.byteOffset !== 0 || input.byteLength !== input.buffer.byteLength)) {
      throw new SegmenterError('input', 'segmenter: run(input, { transfer: true }) needs an input that spans its whole buffer');
    }
    await this.start();
    const own = transfer ? input : input.slice();
    const r = await this.request({ type: 'run', input: own }, [own.buffer]);
    return /** @type {Float32Array} */ (r.output);
  }

  /** Stops the worker; pending and later calls reject with a `disposed` SegmenterError. */
  dispose() {
    this.fail(new SegmenterError('disposed', 'segmenter: the client was disposed'));
  }

  /**
   * @param {{ type: 'load', threads?: number, backend?: BackendChoice } | { type: 'run', input: Float32Array }} req
   * @param {Transferable[]} [transfer]
   * @returns {Promise<any>}
   */
  request(req, transfer = []) {
    if (this.dead) return Promise.reject(this.dead);
    const port = this.open();
    if (!port) return Promise.reject(this.dead);
    const id = this.next++;
    return new Promise((resolve, reject) => {
      this.pending.set(id, { resolve, reject });
      try {
        port.postMessage(/** @type {SegmenterRequest} */ ({ ...req, id }), transfer);
      } catch (e) {
        this.pending.delete(id);
        reject(new SegmenterError('worker', `segmenter: could not send "${req.type}" (${e instanceof Error ? e.message : e})`, { cause: e }));
      }
    });
  }

  /** The worker, started on first use; null (and `dead` set) when it cannot start. */
  open() {
    if (this.port) return this.port;
    try {
      const port = this.makeWorker();
      port.addEventListener('message', (e) => this.receive(/** @type {SegmenterReply} */ (e.data)));
      // A script that fails to load or throws at top level, or a reply that cannot be read:
      // the worker is unusable, every call fails (instead of waiting forever).
      port.addEventListener('error', (e) => {
        e?.preventDefault?.();
        this.fail(new SegmenterError('worker', `segmenter worker failed: ${e?.message || 'it could not load'}`));
      });
      port.addEventListener('messageerror', () => this.fail(new SegmenterError('worker', 'segmenter worker: a reply could not be read')));
      this.port = port;
      return port;
    } catch (e) {
      this.dead = new SegmenterError('worker', `segmenter worker could not start (${e instanceof Error ? e.message : e})`, { cause: e });
      return null;
    }
  }

  /** @param {SegmenterReply} msg */
  receive(msg) {
    if (msg.type === 'progress') {
      this.onProgress?.({ loaded: msg.loaded, total: msg.total });
      return;
    }
    const p = this.pending.get(msg.id);
    if (!p) return;
    this.pending.delete(msg.id);
    if (msg.type === 'error') p.reject(new SegmenterError(msg.code, msg.message));
    else p.resolve(msg);
  }

  /** @param {SegmenterError} err */
  fail(err) {
    this.dead ??= err;
    this.port?.terminate();
    this.port = null;
    for (const p of this.pending.values()) p.reject(err);
    this.pending.clear();
  }
}
