// The worker side of `shapetrack/worker`: one wasm instance, one tracker, one frame buffer, and
// the background detector unless the page sends its own detections. Requests are handled one at
// a time, in order (the tracker is stateful). Protocol: { id, type, ... } in, { id, ok, value |
// error } out.
//
// The state changes only when a request succeeds: `start` builds the new tracker and detector
// before it frees the old ones (a rejected start leaves the running tracker working, and frees
// what it had built), and a new frame buffer replaces the old one only once it exists. Every
// wasm object is freed by whatever replaces it: wasm memory is not garbage-collected.

import { load, writeRgba, Tracker, BackgroundDetector, Detections, FrameBuffer } from './index.js';

/**
 * @typedef {{ tracker: Tracker, detector: BackgroundDetector | null, buffer: FrameBuffer | null, frame: number }} State
 */

/** @type {State | null} */
let state = null;
let queue = Promise.resolve();

self.addEventListener('message', (e) => {
  const req = e.data;
  queue = queue.then(async () => {
    try {
      const value = await handle(req);
      self.postMessage({ id: req.id, ok: true, value });
    } catch (err) {
      self.postMessage({ id: req.id, ok: false, error: err instanceof Error ? err.message : String(err) });
    }
  });
});

/** @param {any} req */
async function handle(req) {
  switch (req.type) {
    case 'start': {
      await load(req.wasm);
      const next = create(req.options ?? {});
      release(state);
      state = next;
      return null;
    }
    case 'track': {
      const s = need();
      const { width, height, data } = await pixels(req.image);
      if (!s.buffer || s.buffer.width !== width || s.buffer.height !== height) {
        const buffer = new FrameBuffer(width, height);
        s.buffer?.free();
        s.buffer = buffer;
      }
      writeRgba(s.buffer, data);
      let dets;
      if (req.detections) dets = Detections.fromLists(req.detections);
      else if (s.detector) dets = s.detector.detect(s.buffer);
      else throw new Error('started with detector "none": pass detections to track()');
      try {
        const shapes = s.tracker.update(s.frame + 1, s.buffer, dets);
        s.frame += 1;
        return shapes;
      } finally {
        dets.free();
      }
    }
    case 'finish':
      return need().tracker.finish();
    case 'tracks':
      return need().tracker.tracks();
    default:
      throw new Error(`unknown request ${JSON.stringify(req.type)}`);
  }
}

/**
 * A new state from `start`'s options; on an error, what was built is freed before it is thrown.
 * @param {any} o
 * @returns {State}
 */
function create(o) {
  const tracker = new Tracker(o.tracker ?? null, o.offline ? { fps: o.fps ?? 25 } : null);
  try {
    const detector = o.detector === 'none' ? null : new BackgroundDetector(o.background ?? null);
    return { tracker, detector, buffer: null, frame: 0 };
  } catch (err) {
    tracker.free();
    throw err;
  }
}

/** Frees every wasm object of a state. @param {State | null} s */
function release(s) {
  s?.tracker.free();
  s?.detector?.free();
  s?.buffer?.free();
}

function need() {
  if (!state) throw new Error('the tracker worker was not started');
  return state;
}

/**
 * RGBA pixels of an ImageData, an ImageBitmap (drawn on an OffscreenCanvas) or a plain
 * { width, height, data } object.
 * @param {any} image
 */
async function pixels(image) {
  if (typeof ImageBitmap !== 'undefined' && image instanceof ImageBitmap) {
    const canvas = new OffscreenCanvas(image.width, image.height);
    const ctx = /** @type {OffscreenCanvasRenderingContext2D} */ (canvas.getContext('2d', { willReadFrequently: true }));
    ctx.drawImage(image, 0, 0);
    image.close();
    return ctx.getImageData(0, 0, canvas.width, canvas.height);
  }
  if (!image || !(image.width > 0) || !(image.height > 0) || !image.data) {
    throw new Error('track(): pass an ImageData, an ImageBitmap or { width, height, data }');
  }
  return image;
}
