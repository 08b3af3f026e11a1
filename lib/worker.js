// `shapetrack/worker`: the tracker in a Web Worker, so a page stays responsive while frames are
// tracked. The worker loads its own wasm instance from the package and runs the background
// detector (the thesis' adaptive subtractor) on each frame unless you pass detections.
//
//   const tracker = await TrackerWorker.start({ tracker: { preset: 'masks' } });
//   const shapes = await tracker.track(ctx.getImageData(0, 0, w, h));   // ids, boxes, masks

export class TrackerWorker {
  /**
   * Starts a worker and a tracker in it.
   * @param {import('./worker.d.ts').TrackerWorkerOptions} [options]
   */
  static async start(options = {}) {
    const worker = new Worker(new URL('./tracker-worker.js', import.meta.url), { type: 'module' });
    const t = new TrackerWorker(worker);
    const { wasm, ...rest } = options;
    try {
      await t.request({ type: 'start', options: rest, wasm: wasm instanceof URL ? wasm.href : wasm });
    } catch (err) {
      // Nobody holds this worker but us: a rejected start stops it (its thread and its wasm
      // instance), rather than leaving it running unreachable.
      t.terminate();
      throw err;
    }
    return t;
  }

  /** @param {Worker} worker */
  constructor(worker) {
    this.worker = worker;
    this.next = 1;
    /** @type {Map<number, { ok: (v: any) => void, fail: (e: Error) => void }>} */
    this.pending = new Map();
    worker.addEventListener('message', (e) => {
      const { id, ok, value, error } = e.data;
      const p = this.pending.get(id);
      if (!p) return;
      this.pending.delete(id);
      if (ok) p.ok(value);
      else p.fail(new Error(error));
    });
    worker.addEventListener('error', (e) => {
      const err = new Error(`shapetrack worker failed: ${e.message}`);
      for (const p of this.pending.values()) p.fail(err);
      this.pending.clear();
    });
  }

  /**
   * @param {Record<string, unknown>} msg
   * @param {Transferable[]} [transfer]
   * @returns {Promise<any>}
   */
  request(msg, transfer = []) {
    const id = this.next++;
    return new Promise((ok, fail) => {
      this.pending.set(id, { ok, fail });
      this.worker.postMessage({ ...msg, id }, transfer);
    });
  }

  /**
   * Tracks the next frame. An ImageBitmap is transferred (and closed); ImageData is copied.
   * @param {ImageData | ImageBitmap | { width: number, height: number, data: Uint8ClampedArray | Uint8Array }} image
   * @param {import('./pkg/shapetrack.js').DetectionLists} [detections] your detector's output (instead of the background detector)
   * @returns {Promise<import('./pkg/shapetrack.js').Shapes>}
   */
  track(image, detections) {
    const transfer = typeof ImageBitmap !== 'undefined' && image instanceof ImageBitmap ? [image] : [];
    return this.request({ type: 'track', image, detections }, transfer);
  }

  /** The offline pass (started with `offline: true`). @returns {Promise<import('./pkg/shapetrack.js').OfflineOutput>} */
  finish() {
    return this.request({ type: 'finish' });
  }

  /** Every shape reported so far. @returns {Promise<import('./pkg/shapetrack.js').Records>} */
  tracks() {
    return this.request({ type: 'tracks' });
  }

  /** Stops the worker; pending requests fail. */
  terminate() {
    this.worker.terminate();
    const err = new Error('shapetrack worker terminated');
    for (const p of this.pending.values()) p.fail(err);
    this.pending.clear();
  }
}
