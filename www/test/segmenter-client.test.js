// The segmenter worker's client (www/src/worker/segmenter/client.js) against a stand-in for the
// worker: load progress reaches onProgress, runs transfer a copy of their input (never the
// caller's buffer unless asked), error replies become SegmenterErrors with their code, a worker
// that fails or is disposed fails every pending and later call instead of leaving it waiting.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { SegmenterClient } from '../src/worker/segmenter/client.js';
import { INPUT_LENGTH, OUTPUT_LENGTH, SegmenterError } from '../src/worker/segmenter/contract.js';

/**
 * A worker stand-in answering after a microtask, as a worker would, in order.
 * @param {{ failLoads?: number, runError?: { code: string, message: string } | null, silent?: boolean }} [opts]
 *   `failLoads`: how many loads fail first; `silent`: never answers
 */
function fakeWorker({ failLoads = 0, runError = null, silent = false } = {}) {
  /** @type {Record<string, Array<(e: any) => void>>} */
  const listeners = { message: [], error: [], messageerror: [] };
  const port = {
    /** @type {any[]} requests received */
    received: [],
    /** @type {Transferable[][]} */
    transfers: [],
    terminated: false,
    /** @param {string} type @param {any} data */
    emit(type, data) {
      for (const l of listeners[type]) l(type === 'message' ? { data } : data);
    },
    /** @param {any} msg @param {Transferable[]} transfer */
    postMessage(msg, transfer) {
      port.received.push(msg);
      port.transfers.push(transfer);
      if (silent) return;
      queueMicrotask(() => {
        if (port.terminated) return;
        const reply = (/** @type {any} */ r) => port.emit('message', { id: msg.id, ...r });
        if (msg.type === 'load') {
          if (failLoads > 0) {
            failLoads--;
            reply({ type: 'error', code: 'fetch', message: 'offline' });
            return;
          }
          reply({ type: 'progress', loaded: 0, total: 10 });
          reply({ type: 'progress', loaded: 10, total: 10 });
          reply({ type: 'loaded', backend: 'wasm', threads: msg.threads ?? 1, gpuSkipped: 'no GPU adapter', ms: 5 });
        } else if (msg.type === 'run') {
          if (runError) reply({ type: 'error', ...runError });
          else reply({ type: 'result', output: new Float32Array(OUTPUT_LENGTH).fill(msg.input[0]), ms: 7 });
        }
      });
    },
    /** @param {string} type @param {(e: any) => void} l */
    addEventListener(type, l) {
      listeners[type].push(l);
    },
    terminate() {
      port.terminated = true;
    },
  };
  return port;
}

/** @param {unknown} e @param {string} code */
const isCode = (e, code) => e instanceof SegmenterError && e.code === code;

test('start loads once, reports progress, and says what the net runs on', async () => {
  const port = fakeWorker();
  let made = 0;
  const seg = new SegmenterClient({
    threads: 2,
    worker: () => {
      made++;
      return port;
    },
  });
  assert.equal(made, 0, 'nothing starts before start()');
  /** @type {Array<{ loaded: number, total: number }>} */
  const progress = [];
  seg.onProgress = (p) => progress.push(p);
  const [a, b] = await Promise.all([seg.start(), seg.start()]);
  assert.equal(a, b);
  assert.deepEqual(a, { backend: 'wasm', threads: 2, gpuSkipped: 'no GPU adapter', ms: 5 });
  assert.deepEqual(seg.info, a);
  assert.deepEqual(progress, [
    { loaded: 0, total: 10 },
    { loaded: 10, total: 10 },
  ]);
  assert.equal(made, 1);
  assert.deepEqual(
    port.received.map((m) => [m.type, m.threads, m.backend]),
    [['load', 2, 'auto']],
  );
});

test('run transfers a copy of its input, or the input itself when asked, and resolves with the output', async () => {
  const port = fakeWorker();
  const seg = new SegmenterClient({ worker: () => port });
  const input = new Float32Array(INPUT_LENGTH).fill(0.25);
  const out = await seg.run(input); // starts the net first
  assert.equal(out.length, OUTPUT_LENGTH);
  assert.equal(out[0], 0.25);
  assert.equal(input.length, INPUT_LENGTH, "the caller's buffer is untouched");
  const run = port.received.findIndex((m) => m.type === 'run');
  assert.notEqual(port.received[run].input, input);
  assert.deepEqual(port.transfers[run], [port.received[run].input.buffer]);

  const mine = new Float32Array(INPUT_LENGTH).fill(0.5);
  const out2 = await seg.run(mine, { transfer: true });
  assert.equal(out2[0], 0.5);
  assert.equal(port.received.at(-1).input, mine);
  assert.deepEqual(port.transfers.at(-1), [mine.buffer]);

  // A view on part of a larger buffer (as on wasm memory) cannot be handed over whole.
  const big = new Float32Array(INPUT_LENGTH + 4);
  await assert.rejects(seg.run(big.subarray(4), { transfer: true }), (e) => isCode(e, 'input'));
  assert.equal((await seg.run(big.subarray(4)))[0], 0, 'copied, it runs');
});

test('a wrong input is refused before anything is sent', async () => {
  const port = fakeWorker();
  const seg = new SegmenterClient({ worker: () => port });
  for (const bad of [new Float32Array(10), new Float32Array(INPUT_LENGTH + 1), /** @type {any} */ (new Uint8Array(INPUT_LENGTH)), /** @type {any} */ (null)]) {
    await assert.rejects(seg.run(bad), (e) => isCode(e, 'input'));
  }
  assert.deepEqual(port.received, []);
});

test("the worker's error replies reject with their code; a failed load may be retried", async () => {
  const port = fakeWorker({ failLoads: 1, runError: { code: 'run', message: 'segmenter: inference failed (oom)' } });
  const seg = new SegmenterClient({ worker: () => port });
  await assert.rejects(seg.start(), (e) => isCode(e, 'fetch') && /offline/.test(/** @type {Error} */ (e).message));
  assert.equal(seg.info, null);
  assert.deepEqual(await seg.start(), { backend: 'wasm', threads: 1, gpuSkipped: 'no GPU adapter', ms: 5 }, 'the second load succeeds');
  await assert.rejects(seg.run(new Float32Array(INPUT_LENGTH)), (e) => isCode(e, 'run') && /oom/.test(/** @type {Error} */ (e).message));
});

test('a worker that fails rejects what is pending and every later call', async () => {
  const port = fakeWorker({ silent: true });
  const seg = new SegmenterClient({ worker: () => port });
  const pending = seg.start();
  port.emit('error', { message: 'SyntaxError in segmenter-worker.js', preventDefault() {} });
  await assert.rejects(pending, (e) => isCode(e, 'worker') && /SyntaxError/.test(/** @type {Error} */ (e).message));
  assert.ok(port.terminated);
  await assert.rejects(seg.run(new Float32Array(INPUT_LENGTH)), (e) => isCode(e, 'worker'));

  const noWorker = new SegmenterClient({
    worker: () => {
      throw new Error('Worker is not defined');
    },
  });
  await assert.rejects(noWorker.start(), (e) => isCode(e, 'worker') && /could not start/.test(/** @type {Error} */ (e).message));
});

test('dispose stops the worker and rejects pending and later calls', async () => {
  const port = fakeWorker({ silent: true });
  const seg = new SegmenterClient({ worker: () => port });
  const pending = seg.start();
  seg.dispose();
  await assert.rejects(pending, (e) => isCode(e, 'disposed'));
  assert.ok(port.terminated);
  await assert.rejects(seg.run(new Float32Array(INPUT_LENGTH)), (e) => isCode(e, 'disposed'));
  seg.dispose(); // twice is harmless
});
