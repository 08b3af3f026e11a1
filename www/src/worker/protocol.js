// The page ↔ tracker-worker protocol. Every request carries an `id`; the worker answers each
// one exactly once, with `{ id, ok: true, ...result }` or `{ id, ok: false, error }`, in the
// order the requests were sent. Video frames travel as transferred ImageBitmaps (no copies).
// The worker paints the page's frame canvas (handed over once with `attach`), so the page
// only draws overlays: a tracked frame is painted just before its result is posted. Only
// `finish` and `boxMask` send messages before their answer: `{ id, progress }` reports of the
// offline pass, and of the learned net's files arriving then its inference (`boxMask`: a drawn
// or imported box → the outline of what it holds, learned or refined, see ./learned.js).
//
// Following a shape (`followStart`, then one `followStep` per frame, `followEnd`) is driven by
// the page a frame at a time rather than as one long request with progress messages: video
// and image frames come from the page (in either direction), the page's progress bar moves
// with each answer, and Cancel simply stops asking (a long request could not be interrupted:
// the worker runs one request at a time and has no shared memory with the page).

/**
 * @typedef {import('../model/tracks.js').TrackRecord} TrackRecord
 * @typedef {import('../../pkg/shapetrack.js').TrackerSettings} TrackerSettings
 * @typedef {import('../../pkg/shapetrack.js').ScenePreset} ScenePreset
 *
 * @typedef {import('../../pkg/shapetrack.js').OfflineProgress} OfflineProgress
 * @typedef {import('../../pkg/shapetrack.js').JoinJs} JoinJs
 *
 * @typedef {{ kind: 'synth', preset?: ScenePreset, width?: number, height?: number } | { kind: 'frames', width: number, height: number, fps: number }} SourceSpec
 *   a synthetic scene given a `width` and `height` is rendered at that size (its shapes scaled
 *   with the frame: the bench page)
 *
 * @typedef {{
 *   source: SourceSpec,
 *   detector: string,
 *   tracker?: TrackerSettings,
 *   detectorOptions?: Record<string, unknown>,
 *   offline?: boolean,
 *   offlineSettings?: Omit<import('../../pkg/shapetrack.js').OfflineSettings, 'fps'>,
 *   learned?: 'off' | 'keyframes',
 * }} OpenRequest  `offline`: keep what the offline pass needs (a video or image sequence
 *   with an end; not the webcam), so `finish` can run it; `offlineSettings`: that pass's
 *   settings over the core's defaults (the frame rate is the source's); `learned`: the
 *   detector's learned stage (worker/learned.js's LearnedKeyframes; default off)
 *
 * @typedef {{ width: number, height: number, frames: number | null, fps: number, hasGroundTruth: boolean, version: string, classes: string[], offline: boolean }} OpenResult
 *   `classes`: the detector's class names by class id (empty when it has none; an empty name
 *   is a class it never reports); `offline`: whether `finish` can run the offline pass
 *
 * @typedef {{ joins: JoinJs[], filled: TrackRecord[], records: number, ids: number, ms: number }} FinishResult
 *   what the offline pass changed: the joins (tracker ids) and the filled-in records; the
 *   total of records and of ids after it, and the time it took in the worker
 *
 * @typedef {{ detect: number, track: number, total: number }} Timings milliseconds in the worker
 *
 * @typedef {{
 *   frame: number,
 *   shapes: TrackRecord[],
 *   detections: number,
 *   groundTruth: TrackRecord[] | null,
 *   timings: Timings,
 *   warmup: import('./detectors.js').Warmup | null,
 *   choice: import('./detectors.js').Choice | null,
 *   detected?: import('../../pkg/shapetrack.js').DetectionList,
 *   learned: (import('./learned.js').LearnedState & { use: import('./learned.js').LearnedUse }) | null,
 * }} StepResult  `learned`: what this frame took from the detector's learned stage, and the
 *   stage's state (null: off); `warmup`: how far the detector's model has learnt the scene (a
 *   background model's first frames detect nothing); null for detectors that need no warm-up; `choice`:
 *   the detector the automatic one chose, once it has; `detected`: the detector's own output
 *   (boxes, cropped masks, scores, classes), only when the step asked for it with
 *   `detections: true` (tools that score a detector apart from the tracker, e.g.
 *   scripts/detect-eval-browser.mjs)
 *
 * @typedef {import('../../pkg/shapetrack.js').FollowStepJs & { frame: number }} FollowStep
 *   the follower's answer for one frame
 *
 * @typedef {{ type: 'open' } & OpenRequest
 *   | { type: 'attach', canvas: OffscreenCanvas }
 *   | { type: 'paint', width: number, height: number, bitmap?: ImageBitmap | null }
 *   | { type: 'step', frame: number, bitmap?: ImageBitmap, display?: boolean, detections?: boolean }
 *   | { type: 'setDetector', detector: string, detectorOptions?: Record<string, unknown> }
 *   | { type: 'render', frame: number }
 *   | { type: 'finish' }
 *   | { type: 'followStart', frame: number, to: number, mask: import('../model/tracks.js').Rle, bitmap?: ImageBitmap }
 *   | { type: 'followStep', frame: number, bitmap?: ImageBitmap }
 *   | { type: 'followEnd' }
 *   | { type: 'learnedWarm' }
 *   | { type: 'setLearned', learned: 'off' | 'keyframes' }
 *   | { type: 'boxMask', frame: number, box: { x: number, y: number, w: number, h: number }, learned: boolean, bitmap?: ImageBitmap }
 *   | { type: 'tracks' }
 *   | { type: 'close' }} Request
 */

/**
 * The page's handle on the tracker worker: promise-based requests over postMessage.
 */
export class WorkerClient {
  /** @param {Worker} worker */
  constructor(worker) {
    this.worker = worker;
    this.nextId = 1;
    /** @type {Map<number, { resolve: (v: any) => void, reject: (e: Error) => void, onProgress?: (p: any) => void }>} */
    this.pending = new Map();
    worker.addEventListener('message', (e) => this.onMessage(e.data));
    worker.addEventListener('error', (e) => this.failAll(new Error(e.message || 'worker failed to load')));
    worker.addEventListener('messageerror', () => this.failAll(new Error('worker message could not be decoded')));
  }

  /** @param {any} msg */
  onMessage(msg) {
    const p = this.pending.get(msg.id);
    if (!p) return;
    if (msg.progress) {
      p.onProgress?.(msg.progress);
      return;
    }
    this.pending.delete(msg.id);
    if (msg.ok) p.resolve(msg);
    else p.reject(new Error(msg.error));
  }

  /** @param {Error} err */
  failAll(err) {
    for (const p of this.pending.values()) p.reject(err);
    this.pending.clear();
  }

  /**
   * @template T
   * @param {Request} req
   * @param {Transferable[]} [transfer]
   * @param {(p: any) => void} [onProgress] called with the progress reports sent before the answer
   * @returns {Promise<T>}
   */
  request(req, transfer = [], onProgress) {
    const id = this.nextId++;
    return new Promise((resolve, reject) => {
      this.pending.set(id, { resolve, reject, onProgress });
      this.worker.postMessage({ ...req, id }, transfer);
    });
  }

  /** @param {OpenRequest} req @returns {Promise<OpenResult>} */
  open(req) {
    return this.request({ type: 'open', ...req });
  }
  /**
   * Switches the open session's detector from the next frame on: the tracker and its tracks
   * stay (its settings are the ones chosen at open, unless it has reported no shape yet: then
   * it takes the new detector's), the new detector starts fresh (a background model learns
   * again).
   * @param {string} detector
   * @param {Record<string, unknown>} [detectorOptions]
   * @returns {Promise<{ classes: string[] }>}
   */
  setDetector(detector, detectorOptions) {
    return this.request({ type: 'setDetector', detector, detectorOptions });
  }


  /**
   * Tracks one frame. For a synthetic source the worker renders the frame itself.
   * @param {number} frame 1-based
   * @param {ImageBitmap} [bitmap] the frame's pixels (transferred), for video and image sources
   * @param {boolean} [display] whether to paint the frame on the page's canvas
   * @returns {Promise<StepResult>}
   */
  step(frame, bitmap, display = true) {
    return this.request({ type: 'step', frame, bitmap, display }, bitmap ? [bitmap] : []);
  }

  /** Paints a synthetic frame (scrubbing), without tracking it. @param {number} frame */
  render(frame) {
    return /** @type {Promise<{ groundTruth: TrackRecord[] | null }>} */ (this.request({ type: 'render', frame }));
  }

  /**
   * Hands the page's frame canvas to the worker, which paints every frame from then on.
   * @param {{ transferControlToOffscreen(): OffscreenCanvas }} canvas the page's frame canvas
   */
  attach(canvas) {
    const offscreen = canvas.transferControlToOffscreen();
    return this.request({ type: 'attach', canvas: offscreen }, [offscreen]);
  }

  /**
   * Paints a frame (a bitmap, transferred) or a blank one of the given size.
   * @param {number} width
   * @param {number} height
   * @param {ImageBitmap | null} [bitmap]
   */
  paint(width, height, bitmap = null) {
    return this.request({ type: 'paint', width, height, bitmap }, bitmap ? [bitmap] : []);
  }

  /**
   * Ends an offline run: the offline pass (trajectory re-linking, gap filling) over everything
   * tracked. The session must have been opened with `offline`.
   * @param {(p: OfflineProgress) => void} [onProgress] the pass's progress, phase by phase
   * @returns {Promise<FinishResult>}
   */
  finish(onProgress) {
    return this.request({ type: 'finish' }, [], onProgress);
  }

  /**
   * Starts following a shape from frame `frame` for a leg ending at frame `to`.
   * @param {number} frame
   * @param {number} to
   * @param {import('../model/tracks.js').Rle} mask the shape, RLE of the whole frame
   * @param {ImageBitmap} [bitmap] frame `frame`'s pixels (transferred), for video and image sources
   * @returns {Promise<{}>}
   */
  followStart(frame, to, mask, bitmap) {
    return this.request({ type: 'followStart', frame, to, mask, bitmap }, bitmap ? [bitmap] : []);
  }

  /**
   * Follows the shape into frame `frame`, the next of the leg.
   * @param {number} frame
   * @param {ImageBitmap} [bitmap]
   * @returns {Promise<{ step: FollowStep }>}
   */
  followStep(frame, bitmap) {
    return this.request({ type: 'followStep', frame, bitmap }, bitmap ? [bitmap] : []);
  }

  /** Ends the follow under way. @returns {Promise<{}>} */
  followEnd() {
    return this.request({ type: 'followEnd' });
  }

  /**
   * Turns the detector's learned stage on or off for the open session.
   * @param {'off' | 'keyframes'} learned
   * @returns {Promise<{}>}
   */
  setLearned(learned) {
    return this.request({ type: 'setLearned', learned });
  }

  /**
   * Starts loading the learned segmenter in the background (answered at once; see
   * learned.js's `warmLearned`). @returns {Promise<{}>}
   */
  learnedWarm() {
    return this.request({ type: 'learnedWarm' });
  }

  /**
   * The outline of what `box` holds in frame `frame` (./learned.js): learned when `learned`
   * and the net is available, else refined without weights.
   * @param {number} frame
   * @param {{ x: number, y: number, w: number, h: number }} box
   * @param {boolean} learned
   * @param {ImageBitmap} [bitmap] the frame's pixels (transferred), for video and image sources
   * @param {(p: import('./learned.js').LearnedProgress) => void} [onProgress]
   * @returns {Promise<import('./learned.js').BoxMask>}
   */
  boxMask(frame, box, learned, bitmap, onProgress) {
    return this.request({ type: 'boxMask', frame, box, learned, bitmap }, bitmap ? [bitmap] : [], onProgress);
  }

  terminate() {
    this.failAll(new Error('worker terminated'));
    this.worker.terminate();
  }
}

/** Starts the tracker worker (a module worker: one wasm instance, single-threaded). */
export function startWorker() {
  const worker = new Worker(new URL('./worker.js', import.meta.url), { type: 'module', name: 'shapetrack-tracker' });
  return new WorkerClient(worker);
}
