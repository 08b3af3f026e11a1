// The tracker worker: one wasm instance, single-threaded, owning the frame buffer, the
// detector, the tracker and (for the demo) the synthetic scene. The page stays responsive
// while frames are tracked here. Protocol: ./protocol.js.
//
// The worker also paints the page's frame canvas (an OffscreenCanvas handed over once): a
// tracked frame is painted straight from wasm memory right before its result is posted, so
// the page only draws the overlay and no frame is copied back and forth.
//
// The synthetic scene's frames are rendered ahead by a second worker, the scene feeder
// (./feed.js), on another core; this worker renders them itself only for a detector that
// reads the scene's own detections (`needsScene`, the "scene masks" one: they live in this
// worker's memory) or when the feeder is unavailable.

import { loadCore } from '../lib/core.js';
import { createDetector } from './detectors.js';
import { SceneFeed } from './feed.js';
import { LearnedKeyframes, boxMask, warmLearned } from './learned.js';

/** @typedef {import('../lib/core.js').Core} Core */
/** @typedef {import('./protocol.js').Request & { id: number }} Req */

const ctx = /** @type {DedicatedWorkerGlobalScope} */ (/** @type {unknown} */ (self));

/**
 * @typedef {{
 *   core: Core,
 *   memory: WebAssembly.Memory,
 *   width: number,
 *   height: number,
 *   buffer: import('../../pkg/shapetrack.js').FrameBuffer,
 *   tracker: import('../../pkg/shapetrack.js').Tracker,
 *   detector: import('./detectors.js').Detector,
 *   scene: import('../../pkg/shapetrack.js').SynthScene | null,
 *   feed: SceneFeed | null,
 *   canvas: OffscreenCanvas | null,
 *   ctx2d: OffscreenCanvasRenderingContext2D | null,
 *   follower: import('../../pkg/shapetrack.js').Follower | null,
 *   followTo: number,
 *   cache: Map<number, Uint8ClampedArray>,
 *   trackerSettings: {
 *     detector: import('../../pkg/shapetrack.js').TrackerSettings | undefined,
 *     page: import('../../pkg/shapetrack.js').TrackerSettings | undefined,
 *     offline: import('../../pkg/shapetrack.js').OfflineSettings | null,
 *   },
 *   reported: boolean,
 *   learned: LearnedKeyframes | null,
 *   learnedPolicy: 'off' | 'keyframes',
 * }} Session  `feed`: the scene feeder rendering the synthetic frames ahead (null: this worker
 *   renders them); `follower`: the shape being followed (`followStart`); `followTo`: the frame its
 *   leg ends at; `cache`: synthetic frames rendered ahead of a backward leg (see `followFrame`);
 *   `trackerSettings`: what the tracker was built from (the detector's settings, the page's
 *   over them, the offline options); `reported`: whether the tracker has reported a shape;
 *   `learned`: the detector's learned stage (null: off, or a detector that needs the scene)
 */

/** @type {Session | null} */
let session = null;

/** The page's frame canvas, once attached. */
let view = /** @type {{ canvas: OffscreenCanvas, ctx: OffscreenCanvasRenderingContext2D } | null} */ (null);

/** Requests run one at a time, in order: the tracker is stateful and frames must not overlap. */
let queue = Promise.resolve();

ctx.addEventListener('message', (e) => {
  const req = /** @type {Req} */ (e.data);
  queue = queue.then(() => handle(req));
});

/** @param {Req} req */
async function handle(req) {
  try {
    const { result, transfer } = await dispatch(req);
    ctx.postMessage({ id: req.id, ok: true, ...result }, transfer);
  } catch (err) {
    const message = err instanceof Error ? err.message : String(err);
    ctx.postMessage({ id: req.id, ok: false, error: message });
  }
}

/**
 * @param {Req} req
 * @returns {Promise<{ result: Record<string, unknown>, transfer: Transferable[] }>}
 */
async function dispatch(req) {
  switch (req.type) {
    case 'open':
      return { result: await open(req), transfer: [] };
    case 'attach': {
      const ctx2d = /** @type {OffscreenCanvasRenderingContext2D} */ (req.canvas.getContext('2d', { alpha: false }));
      view = { canvas: req.canvas, ctx: ctx2d };
      return { result: {}, transfer: [] };
    }
    case 'paint':
      paint(req.width, req.height, req.bitmap ?? null);
      return { result: {}, transfer: [] };
    case 'step':
      return { result: await step(req.frame, req.bitmap ?? null, req.display !== false, req.detections === true), transfer: [] };
    case 'render':
      return { result: await render(req.frame), transfer: [] };
    case 'setDetector':
      return { result: await setDetector(req.detector, req.detectorOptions), transfer: [] };
    case 'finish':
      return { result: finish(req.id), transfer: [] };
    case 'tracks':
      return { result: { records: need().tracker.tracks() }, transfer: [] };
    case 'followStart':
      return { result: await followStart(req.frame, req.to, req.mask, req.bitmap ?? null), transfer: [] };
    case 'followStep':
      return { result: await followStep(req.frame, req.bitmap ?? null), transfer: [] };
    case 'followEnd':
      followEnd();
      return { result: {}, transfer: [] };
    case 'setLearned':
      setLearned(need(), req.learned);
      return { result: {}, transfer: [] };
    case 'learnedWarm':
      warmLearned();
      return { result: {}, transfer: [] };
    case 'boxMask': {
      const s = need();
      await framePixels(s, req.frame, req.bitmap ?? null);
      // Nothing else runs in this worker meanwhile (one request at a time): the frame buffer
      // keeps this frame while the net looks at it.
      const r = await boxMask(s.core, s.buffer, req.box, {
        learned: req.learned,
        onProgress: (progress) => ctx.postMessage({ id: req.id, progress }),
      });
      return { result: r, transfer: [r.bitmap.buffer] };
    }
    case 'close':
      close();
      return { result: {}, transfer: [] };
    default:
      throw new Error(`unknown request ${JSON.stringify(/** @type {any} */ (req).type)}`);
  }
}

function need() {
  if (!session) throw new Error('no open session: send "open" first');
  return session;
}

function close() {
  if (!session) return;
  followEnd();
  session.learned?.dispose();
  session.detector.dispose?.();
  session.tracker.free();
  session.buffer.free();
  session.feed?.close();
  session.scene?.free();
  session = null;
}

/** @param {import('./protocol.js').OpenRequest} req */
async function open(req) {
  close();
  const { core, memory } = await loadCore();
  /** @type {import('../../pkg/shapetrack.js').SynthScene | null} */
  let scene = null;
  let width;
  let height;
  let frames = null;
  let fps = 25;
  if (req.source.kind === 'synth') {
    const preset = /** @type {import('../../pkg/shapetrack.js').ScenePreset} */ (req.source.preset ?? 'demo');
    const { width: w, height: h } = req.source;
    scene = w !== undefined && h !== undefined ? core.SynthScene.sized(preset, w, h) : new core.SynthScene(preset);
    width = scene.width;
    height = scene.height;
    frames = scene.frames;
    fps = scene.fps;
  } else {
    width = req.source.width;
    height = req.source.height;
  }
  const buffer = new core.FrameBuffer(width, height);
  const feed = scene && req.source.kind === 'synth' ? startFeed(req.source, scene) : null;
  const detector = createDetector(req.detector, req.detectorOptions);
  await detector.init({ core, width, height });
  if (req.source.kind === 'frames') fps = req.source.fps || fps;
  // With an end to the video the tracker keeps what the offline pass needs (appearance
  // snapshots), so the page may switch to offline at any time before the end.
  const trackerSettings = { detector: detector.tracker, page: req.tracker, offline: req.offline ? { ...req.offlineSettings, fps } : null };
  const tracker = new core.Tracker({ ...trackerSettings.detector, ...trackerSettings.page }, trackerSettings.offline);
  session = {
    core,
    memory,
    width,
    height,
    buffer,
    tracker,
    detector,
    scene,
    feed,
    canvas: null,
    ctx2d: null,
    follower: null,
    followTo: 0,
    cache: new Map(),
    trackerSettings,
    reported: false,
    learned: null,
    learnedPolicy: 'off',
  };
  setLearned(session, req.learned);
  return {
    width,
    height,
    frames,
    fps,
    hasGroundTruth: scene !== null,
    version: core.version(),
    classes: detector.classes ?? [],
    offline: tracker.offline,
  };
}

/**
 * Turns the detector's learned stage on (`keyframes`) or off (./learned.js). Not for a
 * detector that reads the synthetic scene's own masks: they are the truth already.
 * @param {Session} s
 * @param {'off' | 'keyframes' | undefined} policy
 */
function setLearned(s, policy) {
  s.learnedPolicy = policy ?? 'off';
  const on = s.learnedPolicy === 'keyframes' && s.detector.needsScene !== true;
  if (on === (s.learned !== null)) return;
  s.learned?.dispose();
  s.learned = on ? new LearnedKeyframes(s.core, s.width, s.height) : null;
  // The net's load (2 s or more) starts now, not on the first keyframe.
  if (on) warmLearned({ run: false });
}

/**
 * Replaces the session's detector (the tracker keeps its tracks and settings). The new one is
 * made and initialised before the old one goes, so a detector that fails to load (the SSD's
 * model files) leaves the session as it was.
 * @param {string} name
 * @param {Record<string, unknown>} [options]
 */
async function setDetector(name, options) {
  const s = need();
  const detector = createDetector(name, options);
  await detector.init({ core: s.core, width: s.width, height: s.height });
  s.detector.dispose?.();
  s.detector = detector;
  setLearned(s, s.learnedPolicy);
  return { classes: detector.classes ?? [] };
}

/**
 * An RGBA view on the frame buffer. Built fresh each time: any wasm allocation may grow memory
 * and detach an older view.
 * @param {Session} s
 */
function pixels(s) {
  return new Uint8ClampedArray(s.memory.buffer, s.buffer.ptr(), s.buffer.len());
}

/**
 * Writes a bitmap's pixels into the wasm frame buffer (scaled to the session size if needed).
 * @param {Session} s
 * @param {ImageBitmap} bitmap
 */
function load(s, bitmap) {
  if (!s.canvas || !s.ctx2d) {
    s.canvas = new OffscreenCanvas(s.width, s.height);
    s.ctx2d = /** @type {OffscreenCanvasRenderingContext2D} */ (
      s.canvas.getContext('2d', { willReadFrequently: true, alpha: false })
    );
  }
  s.ctx2d.drawImage(bitmap, 0, 0, s.width, s.height);
  const img = s.ctx2d.getImageData(0, 0, s.width, s.height);
  pixels(s).set(img.data);
}

/**
 * Paints the page's frame canvas: a bitmap, or (none given) a blank frame, at `width×height`.
 * @param {number} width
 * @param {number} height
 * @param {ImageBitmap | null} bitmap
 */
function paint(width, height, bitmap) {
  if (!view) return;
  if (view.canvas.width !== width || view.canvas.height !== height) {
    view.canvas.width = width;
    view.canvas.height = height;
  }
  if (bitmap) {
    view.ctx.drawImage(bitmap, 0, 0, width, height);
    bitmap.close();
  } else {
    view.ctx.fillStyle = '#0b0c0e';
    view.ctx.fillRect(0, 0, width, height);
  }
}

/**
 * @typedef {{ groundTruth: import('../../pkg/shapetrack.js').Records, detections: import('../../pkg/shapetrack.js').Detections | null }} Synthetic
 *   a synthetic frame in the frame buffer: its ground truth records and, when asked for, the
 *   scene's own detections (the caller frees them)
 */

/**
 * Starts the scene feeder for the synthetic source `source` (this worker's scene `scene`
 * tells what the feeder's must be); null where workers cannot start workers.
 * @param {{ preset?: import('../../pkg/shapetrack.js').ScenePreset, width?: number, height?: number }} source
 * @param {import('../../pkg/shapetrack.js').SynthScene} scene
 * @returns {SceneFeed | null}
 */
function startFeed(source, scene) {
  if (typeof Worker === 'undefined') return null;
  try {
    const worker = new Worker(new URL('./scene-feeder.js', import.meta.url), { type: 'module', name: 'shapetrack-scene' });
    const { preset = 'demo', width, height } = source;
    return new SceneFeed(worker, { preset, width, height }, { width: scene.width, height: scene.height, frames: scene.frames });
  } catch {
    return null;
  }
}

/**
 * Puts synthetic frame `n` into the frame buffer: from the scene feeder, or rendered here when
 * the scene's own detections are wanted (`withDetections`), when there is no feeder, or when
 * it has failed (this worker then renders every later frame itself; the feeder's error only
 * costs speed). A frame outside the scene is rendered here, which reports the typed error.
 * @param {Session} s
 * @param {number} n
 * @param {boolean} withDetections
 * @returns {Promise<Synthetic>}
 */
async function syntheticFrame(s, n, withDetections) {
  const scene = s.scene;
  if (!scene) throw new Error(`frame ${n}: the source is not synthetic`);
  const inScene = Number.isInteger(n) && n >= 1 && n <= scene.frames;
  if (s.feed && !withDetections && inScene) {
    try {
      const fed = await s.feed.take(n);
      pixels(s).set(new Uint8Array(fed.pixels));
      s.feed.recycle(fed.pixels);
      return { groundTruth: fed.groundTruth, detections: null };
    } catch (err) {
      console.warn(`${err instanceof Error ? err.message : String(err)}; rendering the scene in the tracker worker from now on`);
      s.feed.close();
      s.feed = null;
    }
  }
  const sf = scene.render(n, s.buffer);
  try {
    return { groundTruth: sf.groundTruth(), detections: withDetections ? sf.detections() : null };
  } finally {
    sf.free();
  }
}

/**
 * Paints the frame buffer (the pixels wasm just worked on) without copying it first: the
 * ImageData is a view on wasm memory, put straight onto the canvas.
 * @param {Session} s
 */
function paintBuffer(s) {
  if (!view) return;
  if (view.canvas.width !== s.width || view.canvas.height !== s.height) {
    view.canvas.width = s.width;
    view.canvas.height = s.height;
  }
  view.ctx.putImageData(new ImageData(pixels(s), s.width, s.height), 0, 0);
}

/**
 * Tracks one frame; paints it on the page's canvas when `display`; returns the detector's own
 * output too when `withDetections`.
 * @param {number} frame
 * @param {ImageBitmap | null} bitmap
 * @param {boolean} display
 * @param {boolean} [withDetections]
 * @returns {Promise<Omit<import('./protocol.js').StepResult, 'bitmap'>>}
 */
async function step(frame, bitmap, display, withDetections = false) {
  const s = need();
  const t0 = performance.now();
  /** @type {Synthetic | null} */
  let synthetic = null;
  if (s.scene) {
    synthetic = await syntheticFrame(s, frame, s.detector.needsScene === true);
  } else {
    if (!bitmap) throw new Error(`frame ${frame}: no pixels sent`);
    load(s, bitmap);
  }
  const t1 = performance.now();
  const out = await s.detector.detect({
    index: frame,
    width: s.width,
    height: s.height,
    buffer: s.buffer,
    pixels: () => pixels(s),
    bitmap,
    scene: synthetic?.detections ?? null,
  });
  let dets = out instanceof s.core.Detections ? out : s.core.Detections.fromLists(out);
  /** @type {import('./learned.js').LearnedUse} */
  let learnedUse = null;
  if (s.learned) {
    // Never waits for the net: a keyframe starts in the background when none runs, and the
    // last one's masks, carried to this frame, replace the detector's.
    try {
      s.learned.keyframe(frame, () => pixels(s), dets, s.memory);
      const applied = s.learned.apply(frame, dets);
      dets = applied.dets;
      learnedUse = applied.use;
    } catch (e) {
      dets.free();
      throw e;
    }
  }
  const t2 = performance.now();
  const detections = dets.len;
  /** @type {import('../../pkg/shapetrack.js').Shapes} */
  let shapes;
  /** @type {import('../../pkg/shapetrack.js').DetectionList | undefined} */
  let detected;
  try {
    // Before the tracker takes them (it may not keep them as given).
    if (withDetections) detected = dets.toList();
    if (!s.reported && s.detector.tracker !== s.trackerSettings.detector) rebuildTracker(s);
    shapes = s.tracker.update(frame, s.buffer, dets);
  } finally {
    dets.free();
  }
  s.reported ||= shapes.length > 0;
  const t3 = performance.now();
  const groundTruth = synthetic?.groundTruth ?? null;
  if (display) {
    if (bitmap) paint(s.width, s.height, bitmap);
    else paintBuffer(s);
  } else {
    bitmap?.close();
  }
  return {
    frame,
    shapes,
    detections,
    groundTruth,
    timings: { detect: t2 - t1, track: t3 - t2, total: t3 - t0 },
    warmup: s.detector.warmup?.() ?? null,
    choice: s.detector.choice?.() ?? null,
    learned: s.learned ? { use: learnedUse, ...s.learned.state() } : null,
    ...(detected ? { detected } : {}),
  };
}

/**
 * Rebuilds the tracker with the detector's current settings (the page's still over them),
 * caught up to the frames tracked so far with empty frames. Only while no shape has been
 * reported: then nothing is lost (the automatic detector reports nothing until it has chosen;
 * a detector picked before the first track takes its own settings).
 * @param {Session} s
 */
function rebuildTracker(s) {
  const settings = { ...s.trackerSettings, detector: s.detector.tracker };
  const tracker = new s.core.Tracker({ ...settings.detector, ...settings.page }, settings.offline);
  const none = s.core.Detections.fromLists({});
  try {
    for (let k = 1; k <= s.tracker.frame; k++) tracker.updateDetections(k, none);
  } catch (e) {
    tracker.free();
    throw e;
  } finally {
    none.free();
  }
  s.tracker.free();
  s.tracker = tracker;
  s.trackerSettings = settings;
}

/** Progress reports are posted at most this often (ms), and at every change of phase. */
const PROGRESS_MS = 50;

/**
 * The offline pass (the core's trajectory re-linker, thesis ch. 5) over everything tracked.
 * Its progress goes to the page as `{ id, progress }` messages before the answer. The page
 * already holds the online result, so only what the pass changed is sent back.
 * @param {number} id the request's id
 * @returns {import('./protocol.js').FinishResult}
 */
function finish(id) {
  const s = need();
  let phase = '';
  let last = 0;
  const t0 = performance.now();
  const out = s.tracker.finish((progress) => {
    const now = performance.now();
    if (progress.phase === phase && progress.fraction < 1 && now - last < PROGRESS_MS) return;
    phase = progress.phase;
    last = now;
    ctx.postMessage({ id, progress });
  });
  const ms = performance.now() - t0;
  const ids = new Set(out.records.map((r) => r.id));
  return {
    joins: out.joins,
    // Only what this pass filled in: records the online pass coasted over are in the table.
    filled: out.added,
    records: out.records.length,
    ids: ids.size,
    ms,
  };
}

/**
 * Renders and paints a synthetic frame (scrubbing), without tracking it.
 * @param {number} frame
 */
async function render(frame) {
  const s = need();
  if (!s.scene) throw new Error('only the synthetic source renders frames in the worker');
  const { groundTruth } = await syntheticFrame(s, frame, false);
  paintBuffer(s);
  return { groundTruth };
}

// ---------------------------------------------------------------- follow this shape

/**
 * Synthetic frames rendered at once ahead of a backward leg. The scene renders forward cheaply
 * (a few ms a frame) but any earlier frame replays from its last checkpoint (up to 100 frames
 * back), so a backward leg renders a block of frames forward, keeps their pixels (~3.7 MB each
 * at 1280×720) and steps back through them.
 */
const BACK_BLOCK = 12;

/**
 * Puts frame `n` of the leg being followed into the frame buffer: the synthetic scene's, or
 * the page's bitmap (videos and image sequences: the page grabs them, in either direction).
 * @param {Session} s
 * @param {number} n
 * @param {ImageBitmap | null} bitmap
 */
async function followFrame(s, n, bitmap) {
  if (bitmap) {
    load(s, bitmap);
    bitmap.close();
    return;
  }
  if (!s.scene) throw new Error(`frame ${n}: no pixels sent`);
  const cached = s.cache.get(n);
  if (cached) {
    pixels(s).set(cached);
    return;
  }
  s.cache.clear();
  if (s.followTo < n) {
    // Backward: render the block ending at n in order, keep its frames but n.
    const lo = Math.max(1, s.followTo, n - BACK_BLOCK + 1);
    for (let k = lo; k < n; k++) {
      await syntheticFrame(s, k, false);
      s.cache.set(k, pixels(s).slice());
    }
  }
  await syntheticFrame(s, n, false);
}

/**
 * Puts frame `n` into the frame buffer without tracking it: the page's bitmap, or the
 * synthetic scene's frame.
 * @param {Session} s
 * @param {number} n
 * @param {ImageBitmap | null} bitmap
 */
async function framePixels(s, n, bitmap) {
  if (bitmap) {
    load(s, bitmap);
    bitmap.close();
    return;
  }
  if (!s.scene) throw new Error(`frame ${n}: no pixels sent`);
  await syntheticFrame(s, n, false);
}

/**
 * Starts following the shape `mask` (RLE of the whole frame) on frame `frame`, for a leg that
 * ends at frame `to` (either side of `frame`). The core's Follower checks the mask (an empty
 * one is an error); the scene checks the frame's range. Replaces any follow under way.
 * @param {number} frame
 * @param {number} to
 * @param {import('../model/tracks.js').Rle} mask
 * @param {ImageBitmap | null} bitmap
 */
async function followStart(frame, to, mask, bitmap) {
  const s = need();
  followEnd();
  s.followTo = to;
  await followFrame(s, frame, bitmap);
  s.follower = new s.core.Follower(s.buffer, mask);
  return {};
}

/**
 * Follows the target into frame `frame` (the next one of the leg, in its direction).
 * @param {number} frame
 * @param {ImageBitmap | null} bitmap
 */
async function followStep(frame, bitmap) {
  const s = need();
  if (!s.follower) throw new Error('no follow under way: send "followStart" first');
  await followFrame(s, frame, bitmap);
  const out = s.follower.step(s.buffer);
  return { step: { frame, ...out } };
}

/** Ends the follow under way (frees the follower and the frames kept for it). */
function followEnd() {
  if (!session) return;
  session.follower?.free();
  session.follower = null;
  session.cache.clear();
}
