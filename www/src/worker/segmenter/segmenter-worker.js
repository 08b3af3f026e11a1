// The segmenter worker: hosts the learned segmentation net (./net.js) so an inference (about a
// second on this project's 2-core machine) runs on a core of its own, beside the tracker
// worker, instead of stalling its frames. Driven by SegmenterClient (./client.js).
//
// Protocol (types in ./client.js): requests `load` (answered by `progress` reports, then
// `loaded`), `run` (its input's buffer transferred in; answered by `result`, the output's
// buffer transferred out) and `dispose` (`disposed`); any failure is an `error` reply with the
// request's id, a SegmenterError code and a message, never an unhandled rejection. Requests are
// handled one at a time, in order.

import { loadNet, SegmenterError } from './net.js';

/**
 * @typedef {import('./client.js').SegmenterRequest} SegmenterRequest
 * @typedef {import('./client.js').SegmenterReply} SegmenterReply
 * @typedef {import('./net.js').Net} Net
 */

const scope = /** @type {DedicatedWorkerGlobalScope} */ (/** @type {unknown} */ (self));

/** @type {Promise<Net> | null} */
let loading = null;
/** @type {Net | null} */
let net = null;
/** @type {Promise<void>} */
let queue = Promise.resolve();

/**
 * @param {SegmenterReply} reply
 * @param {Transferable[]} [transfer]
 */
const post = (reply, transfer = []) => scope.postMessage(reply, transfer);

scope.addEventListener('message', (e) => {
  const req = /** @type {SegmenterRequest} */ (e.data);
  queue = queue.then(() => handle(req));
});

/** @param {SegmenterRequest} req */
async function handle(req) {
  const id = typeof req?.id === 'number' ? req.id : -1;
  try {
    switch (req?.type) {
      case 'load': {
        const t0 = performance.now();
        // A second load (after a first one succeeded) answers at once.
        loading ??= loadNet({ threads: req.threads ?? 1, backend: req.backend ?? 'auto', onProgress: (p) => post({ type: 'progress', id, ...p }) });
        try {
          net = await loading;
        } catch (err) {
          loading = null; // a later load may succeed (back online)
          throw err;
        }
        post({ type: 'loaded', id, backend: net.backend, threads: net.threads, gpuSkipped: net.gpuSkipped, ms: performance.now() - t0 });
        return;
      }
      case 'run': {
        if (!net) throw new SegmenterError('protocol', 'segmenter: "run" before "load" succeeded');
        const t0 = performance.now();
        const output = await net.run(req.input);
        post({ type: 'result', id, output, ms: performance.now() - t0 }, [output.buffer]);
        return;
      }
      case 'dispose': {
        const n = net;
        net = null;
        loading = null;
        await n?.dispose();
        post({ type: 'disposed', id });
        return;
      }
      default:
        throw new SegmenterError('protocol', `segmenter: unknown request ${JSON.stringify(/** @type {any} */ (req)?.type)}`);
    }
  } catch (err) {
    const code = err instanceof SegmenterError ? err.code : 'run';
    post({ type: 'error', id, code, message: err instanceof Error ? err.message : String(err) });
  }
}
