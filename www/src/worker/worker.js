// The tracker worker: one wasm instance, single-threaded, owning the frame buffer, the
// detector, the tracker and (for the demo) the synthetic scene. The page stays responsive
// while frames are tracked here. Protocol: ./protocol.js.

import { loadCore } from '../lib/core.js';
import { createDetector } from './detectors.js';

/** @typedef {import('../lib/core.js').Core} Core */
/** @typedef {import('./protocol.js').Request & { id: number }} Req */

const ctx = /** @type {DedicatedWorkerGlobalScope} */ (/** @type {unknown} */ (self));

/**
 * @typedef {{
 *   core: Core,
 *   memory: WebAssembly.Memory,
 *   width: number,
 *   height: number,
 *   buffer: InstanceType<Core['FrameBuffer']>,
 *   tracker: InstanceType<Core['Tracker']>,
 *   detector: import('./detectors.js').Detector,
 *   scene: InstanceType<Core['SynthScene']> | null,
 *   canvas: OffscreenCanvas | null,
 *   ctx2d: OffscreenCanvasRenderingContext2D | null,
 * }} Session
 */

/** @type {Session | null} */
let session = null;

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
    case 'step':
      return step(req.frame, req.bitmap ?? null, req.display !== false);
    case 'render':
      return render(req.frame);
    case 'finish':
      return { result: { records: need().tracker.finish() }, transfer: [] };
    case 'tracks':
      return { result: { records: need().tracker.tracks() }, transfer: [] };
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
  session.detector.dispose?.();
  session.tracker.free();
  session.buffer.free();
  session.scene?.free();
  session = null;
}

/** @param {import('./protocol.js').OpenRequest} req */
async function open(req) {
  close();
  const { core, memory } = await loadCore();
  /** @type {InstanceType<Core['SynthScene']> | null} */
  let scene = null;
  let width;
  let height;
  let frames = null;
  let fps = 25;
  if (req.source.kind === 'synth') {
    scene = new core.SynthScene(req.source.preset ?? 'demo');
    width = scene.width;
    height = scene.height;
    frames = scene.frames;
    fps = scene.fps;
  } else {
    width = req.source.width;
    height = req.source.height;
  }
  const buffer = new core.FrameBuffer(width, height);
  const tracker = new core.Tracker(/** @type {any} */ (req.tracker ?? {}));
  const detector = createDetector(req.detector, req.detectorOptions);
  await detector.init({ core, width, height });
  session = { core, memory, width, height, buffer, tracker, detector, scene, canvas: null, ctx2d: null };
  return { width, height, frames, fps, hasGroundTruth: scene !== null, version: core.version() };
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

/** A bitmap of the frame buffer, for the page to draw. @param {Session} s */
function snapshot(s) {
  const img = new ImageData(pixels(s).slice(), s.width, s.height);
  return createImageBitmap(img);
}

/**
 * @param {number} frame
 * @param {ImageBitmap | null} bitmap
 * @param {boolean} display
 */
async function step(frame, bitmap, display) {
  const s = need();
  const t0 = performance.now();
  /** @type {InstanceType<Core['SceneFrame']> | null} */
  let sceneFrame = null;
  if (s.scene) {
    sceneFrame = s.scene.render(frame, s.buffer);
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
    scene: sceneFrame ? sceneFrame.detections() : null,
  });
  const dets = out instanceof s.core.Detections ? out : s.core.Detections.fromLists(/** @type {any} */ (out), s.width, s.height);
  const t2 = performance.now();
  const detections = dets.len;
  const shapes = s.tracker.update(frame, s.buffer, dets);
  dets.free();
  const t3 = performance.now();
  const groundTruth = sceneFrame ? sceneFrame.groundTruth() : null;
  sceneFrame?.free();
  /** @type {Transferable[]} */
  const transfer = [];
  let shown = null;
  if (display) {
    shown = bitmap ?? (await snapshot(s));
    transfer.push(shown);
  } else {
    bitmap?.close();
  }
  return {
    result: {
      frame,
      bitmap: shown,
      shapes,
      detections,
      groundTruth,
      timings: { detect: t2 - t1, track: t3 - t2, total: t3 - t0 },
    },
    transfer,
  };
}

/** @param {number} frame */
async function render(frame) {
  const s = need();
  if (!s.scene) throw new Error('only the synthetic source renders frames in the worker');
  const sf = s.scene.render(frame, s.buffer);
  const groundTruth = sf.groundTruth();
  sf.free();
  const bitmap = await snapshot(s);
  return { result: { bitmap, groundTruth }, transfer: [bitmap] };
}
