// The tracker worker's side of the scene feeder (./scene-feeder.js): synthetic frames rendered
// on another core, ahead of the frame being tracked.
//
// While frames are asked for in order (tracking, playing), each frame asked for also asks the
// feeder for the next `AHEAD`, so the scene renders frame n+1 while this worker detects and
// tracks frame n; the feeder answers in order, one frame at a time. A frame asked for out of
// order (a seek, a backward leg of "follow this shape") is rendered on its own, and frames
// asked for ahead that are no longer wanted are recycled when they arrive. The pixels travel
// as transferred ArrayBuffers (no copy on the way) and their buffers go back to the feeder for
// later frames (no allocation per frame).
//
// Any failure of the feeder (it could not start, its scene disagrees with this worker's, a
// render failed there) fails every frame waited for and every later one with the same error:
// the tracker worker then renders the frames itself, as it did before the feeder existed.

/** Frames asked for ahead of the one being tracked. */
export const AHEAD = 2;

/**
 * @typedef {import('../../pkg/shapetrack.js').Records} Records
 * @typedef {{ type: 'open', preset: import('../../pkg/shapetrack.js').ScenePreset, width?: number, height?: number }
 *   | { type: 'render', frame: number, buffer?: ArrayBuffer }} FeederRequest
 * @typedef {{ type: 'opened', width: number, height: number, frames: number }
 *   | { type: 'frame', frame: number, pixels: ArrayBuffer, groundTruth: Records }
 *   | { type: 'error', frame?: number, message: string }} FeederReply
 * @typedef {{ frame: number, pixels: ArrayBuffer, groundTruth: Records }} FedFrame
 *   one rendered frame: RGBA bytes and its ground truth records
 * @typedef {{
 *   postMessage: (msg: FeederRequest, transfer: Transferable[]) => void,
 *   addEventListener: (type: 'message' | 'error', listener: (e: any) => void) => void,
 *   terminate: () => void,
 * }} FeederPort  the feeder worker (or, in tests, a stand-in for one)
 * @typedef {{ promise: Promise<FedFrame>, resolve: (f: FedFrame) => void, reject: (e: Error) => void,
 *   fed: FedFrame | null, taken: boolean }} Pending  a frame asked for: `fed` once it arrived,
 *   `taken` once `take` asked for it (it leaves `pending` when both hold)
 */

export class SceneFeed {
  /**
   * Opens the feeder's scene.
   * @param {FeederPort} port
   * @param {{ preset: import('../../pkg/shapetrack.js').ScenePreset, width?: number, height?: number }} source
   * @param {{ width: number, height: number, frames: number }} expect  this worker's own scene,
   *   which the feeder's must equal
   */
  constructor(port, source, expect) {
    this.port = port;
    this.frames = expect.frames;
    /** @type {Map<number, Pending>} frames asked for and not yet taken or not yet arrived */
    this.pending = new Map();
    /** @type {ArrayBuffer[]} buffers of frames already copied, for the next requests */
    this.pool = [];
    /** The last frame taken (0: none yet). */
    this.last = 0;
    /** @type {Error | null} */
    this.failed = null;
    /** @type {(ok: boolean) => void} */
    let settle = () => {};
    /** Resolves once the feeder's scene is open (false: it failed first). */
    this.opened = new Promise((resolve) => (settle = resolve));
    this.settleOpened = settle;
    this.expect = expect;
    port.addEventListener('message', (e) => this.receive(/** @type {FeederReply} */ (e.data)));
    port.addEventListener('error', (e) => {
      e?.preventDefault?.();
      this.fail(new Error(`the scene feeder failed: ${e?.message ?? 'it could not start'}`));
    });
    port.postMessage({ type: 'open', ...source }, []);
  }

  /** @param {FeederReply} msg */
  receive(msg) {
    if (this.failed) return;
    if (msg.type === 'opened') {
      const { width, height, frames } = this.expect;
      if (msg.width !== width || msg.height !== height || msg.frames !== frames) {
        this.fail(new Error(`the scene feeder's scene is ${msg.width}×${msg.height}, ${msg.frames} frames; expected ${width}×${height}, ${frames}`));
      } else {
        this.settleOpened(true);
      }
    } else if (msg.type === 'frame') {
      const p = this.pending.get(msg.frame);
      if (p && !p.fed) {
        p.fed = { frame: msg.frame, pixels: msg.pixels, groundTruth: msg.groundTruth };
        if (p.taken) this.pending.delete(msg.frame);
        p.resolve(p.fed);
      } else {
        // Asked for ahead, then not wanted (a seek).
        this.recycle(msg.pixels);
      }
    } else {
      this.fail(new Error(`the scene feeder failed${msg.frame !== undefined ? ` on frame ${msg.frame}` : ''}: ${msg.message}`));
    }
  }

  /**
   * Every frame waited for, and every later one, fails with `err`; the feeder stops.
   * @param {Error} err
   */
  fail(err) {
    if (this.failed) return;
    this.failed = err;
    this.settleOpened(false);
    for (const p of this.pending.values()) p.reject(err);
    this.pending.clear();
    this.pool = [];
    this.port.terminate();
  }

  /**
   * Asks the feeder for frame `n`.
   * @param {number} n
   * @returns {Pending}
   */
  request(n) {
    /** @type {Pending} */
    const p = /** @type {any} */ ({ fed: null, taken: false });
    p.promise = new Promise((resolve, reject) => {
      p.resolve = resolve;
      p.reject = reject;
    });
    // A frame asked for ahead may fail with nobody waiting for it: not an unhandled rejection.
    p.promise.catch(() => {});
    this.pending.set(n, p);
    const buffer = this.pool.pop();
    this.port.postMessage({ type: 'render', frame: n, buffer }, buffer ? [buffer] : []);
    return p;
  }

  /**
   * Frame `n` (1-based, within the scene): its pixels and ground truth. Give the pixels back
   * with `recycle` once copied.
   * @param {number} n
   * @returns {Promise<FedFrame>}
   */
  async take(n) {
    if (this.failed) throw this.failed;
    const inOrder = n === this.last + 1;
    this.last = n;
    // Frames asked for ahead that this one makes unwanted are recycled (when they arrive).
    for (const [k, q] of [...this.pending]) {
      if (!q.taken && (k < n || k > n + AHEAD)) {
        this.pending.delete(k);
        if (q.fed) this.recycle(q.fed.pixels);
      }
    }
    const p = this.pending.get(n) ?? this.request(n);
    p.taken = true;
    if (p.fed) this.pending.delete(n);
    if (inOrder) {
      for (let k = n + 1; k <= Math.min(n + AHEAD, this.frames); k++) {
        if (!this.pending.has(k)) this.request(k);
      }
    }
    if (!(await this.opened)) throw this.failed ?? new Error('the scene feeder failed');
    return p.promise;
  }

  /**
   * A frame's buffer, copied from: reused for a later frame.
   * @param {ArrayBuffer} buffer
   */
  recycle(buffer) {
    if (!this.failed && buffer.byteLength > 0 && this.pool.length <= AHEAD) this.pool.push(buffer);
  }

  /** Stops the feeder. */
  close() {
    this.fail(new Error('the scene feeder was closed'));
  }
}
