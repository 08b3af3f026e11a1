// The learned segmentation stage (issue 63) as the tracker worker uses it: the Rust core picks
// the crops and turns the net's maps into masks (`SegmentJob`), the segmenter worker
// (./segmenter/, spawned from here, so crops and maps go between the two workers without
// crossing the page) runs U²-Net-p.
//
// - `boxMask`: a box the labeller drew or imported becomes the outline of what it holds. With
//   the learned stage off, or when the net cannot load (offline before its first use, no wasm
//   SIMD) or finds nothing in the box, the weights-free refinement (`BoxRefiner`, the colour
//   cut the SSD's boxes go through) does it instead: a box always becomes a mask.
// - `LearnedKeyframes`: the detector's masks replaced by learned ones without ever making the
//   tracker wait for the net (an inference takes 2 s or more on this project's 2-core machine,
//   where a frame gets ~50 ms). See the class.

import { SegmenterClient } from './segmenter/client.js';
import { BOX_SIDE, SegmenterError, inputLength } from './segmenter/contract.js';

/**
 * @typedef {import('../lib/core.js').Core} Core
 * @typedef {import('../../pkg/shapetrack.js').FrameBuffer} FrameBuffer
 * @typedef {import('../../pkg/shapetrack.js').Detections} Detections
 * @typedef {import('../../pkg/shapetrack.js').DetectionJs} DetectionJs
 * @typedef {import('../../pkg/shapetrack.js').MaskBitmap} MaskBitmap
 * @typedef {{ x: number, y: number, w: number, h: number }} Box
 *
 * @typedef {{ phase: 'load', loaded: number, total: number } | { phase: 'run' }} LearnedProgress
 *   the net's files arriving (bytes of both), then an inference under way
 *
 * @typedef {{ bitmap: Uint8Array, bbox: Box, how: 'learned' | 'refined', ms: number, note: string | null }} BoxMask
 *   a whole-frame bitmap (1 = object); `how` made it; `ms` from the request to the mask, in
 *   the worker (the net's load included the first time); `note`: why not learned (null when
 *   it is)
 */

/** @type {SegmenterClient | null} */
let client = null;

/**
 * Threads the net asks for while the detector's keyframes are off: a drawn box's outline is
 * all the worker does then (the tracker waits for it), so the net may have every core of a
 * 2-core machine. With keyframes on, one: they run beside the tracker, and two threads there
 * lost to one (www/README.md, bench:segmenter under load).
 */
export const IDLE_THREADS = 2;

/** Keyframe stages alive in this worker (each takes the net down to one thread). */
let keyframeUsers = 0;

/** Threads the net should have now (exported for the unit tests). */
export function wantedThreads() {
  return keyframeUsers > 0 ? 1 : IDLE_THREADS;
}

/**
 * The segmenter, shared by the box masks and the detector's keyframes (one net, one worker,
 * loaded once per thread count). When the wanted thread count changed (keyframes turned on or
 * off) and nothing is pending on it, the old one is dropped and the next use loads anew (from
 * the service worker's cache: ~2 s, once per switch).
 */
function segmenter() {
  if (client && client.threads !== wantedThreads() && client.pending.size === 0) forgetSegmenter();
  client ??= new SegmenterClient({ threads: wantedThreads() });
  return client;
}

/** Drops the segmenter after a failed load, so a later use tries again (back online). */
function forgetSegmenter() {
  client?.dispose();
  client = null;
}

/**
 * Starts loading the net, and runs it once on zeros, without waiting for either: the page
 * asks when the labeller picks the box tool, so the load (2 s or more) and the first
 * inference's extra cost (the runtime allocates and tiers up: ~1.5 s more than later ones)
 * pass while the box is drawn. A failure is forgotten here (the next use tries again and
 * reports it). `run: false` loads only (the detector's keyframes: a zero inference there
 * would take a core from the tracker for nothing).
 * @param {{ run?: boolean }} [opts]
 */
export function warmLearned({ run = true } = {}) {
  const seg = segmenter();
  if (seg.info) return;
  seg
    .start()
    .then(() => (run ? seg.run(new Float32Array(inputLength(BOX_SIDE)), { transfer: true }) : undefined))
    .catch(() => {
      if (client === seg && !seg.info) forgetSegmenter();
    });
}

/**
 * Runs every pending crop of `job` through the net, the frame read from `buf` (which must
 * hold the job's frame throughout).
 * @param {import('../../pkg/shapetrack.js').SegmentJob} job
 * @param {FrameBuffer} buf
 * @param {(p: LearnedProgress) => void} [onProgress]
 * @param {() => void} [onLoaded] called once the net is loaded, before its first inference
 */
async function runJob(job, buf, onProgress, onLoaded) {
  const seg = segmenter();
  // Only a caller that reports progress sets it: a keyframe in the background must not
  // silence a drawn box's progress bar.
  if (onProgress) seg.onProgress = (p) => onProgress({ phase: 'load', ...p });
  try {
    await seg.start();
  } catch (e) {
    forgetSegmenter();
    throw e;
  }
  onLoaded?.();
  while (job.remaining > 0) {
    // `input` returns a Float32Array of its own (copied out of wasm memory): transferred.
    const input = job.input(buf);
    onProgress?.({ phase: 'run' });
    job.supply(await seg.run(input, { transfer: true }));
  }
}

/**
 * A whole-frame bitmap from a detection's cropped mask (or its filled box without one).
 * @param {DetectionJs} d
 * @param {number} width
 * @param {number} height
 */
function frameBitmap(d, width, height) {
  const out = new Uint8Array(width * height);
  const m = d.mask;
  if (m) {
    for (let y = 0; y < m.height; y++) {
      const fy = m.y + y;
      if (fy < 0 || fy >= height) continue;
      for (let x = 0; x < m.width; x++) {
        const fx = m.x + x;
        if (fx >= 0 && fx < width && m.data[y * m.width + x]) out[fy * width + fx] = 1;
      }
    }
    return out;
  }
  const x0 = Math.max(0, Math.round(d.bbox.x));
  const y0 = Math.max(0, Math.round(d.bbox.y));
  const x1 = Math.min(width, Math.round(d.bbox.x + d.bbox.w));
  const y1 = Math.min(height, Math.round(d.bbox.y + d.bbox.h));
  for (let y = y0; y < y1; y++) out.fill(1, y * width + x0, y * width + x1);
  return out;
}

/**
 * The mask of what `box` holds in the frame in `buf`: learned when `learned` and the net is
 * available, else refined without weights (see the top of this file). A SegmenterError (the
 * net could not load or run) is no failure: it is the `note` of a refined mask.
 * @param {Core} core
 * @param {FrameBuffer} buf
 * @param {Box} box
 * @param {{ learned: boolean, onProgress?: (p: LearnedProgress) => void }} opts
 * @returns {Promise<BoxMask>}
 */
export async function boxMask(core, buf, box, { learned, onProgress }) {
  const t0 = performance.now();
  const { width, height } = buf;
  let note = 'the learned stage is off';
  if (learned) {
    const dets = core.Detections.fromLists({ boxes: [{ bbox: box }] });
    /** @type {import('../../pkg/shapetrack.js').SegmentJob | null} */
    let job = null;
    try {
      job = new core.SegmentJob(buf, dets, 'off', { side: BOX_SIDE });
      await runJob(job, buf, onProgress);
      const done = job.finish();
      try {
        const [d] = done.toList();
        // A box-only input comes back with a mask only when the net found its object.
        if (d?.mask) return { bitmap: frameBitmap(d, width, height), bbox: d.bbox, how: 'learned', ms: performance.now() - t0, note: null };
        note = 'the net found no object in the box';
      } finally {
        done.free();
      }
    } catch (e) {
      if (!(e instanceof SegmenterError)) throw e;
      note = e.message;
    } finally {
      job?.free();
      dets.free();
    }
  }
  const dets = core.Detections.fromLists({ boxes: [{ bbox: box }] });
  try {
    const refiner = new core.BoxRefiner();
    try {
      refiner.refine(buf, dets);
    } finally {
      refiner.free();
    }
    const [d] = dets.toList();
    return { bitmap: frameBitmap(d, width, height), bbox: d.bbox, how: 'refined', ms: performance.now() - t0, note };
  } finally {
    dets.free();
  }
}

// ---------------------------------------------------------------- the detector's keyframes

/**
 * Frames between two keyframes' starts while the detections stay as they were: the net runs
 * on a core the tracker and the page share on a 2-core machine, and back to back it cost the
 * tracker 40 % of its frames (scripts/bench-learned-fps.mjs, 2026-12-06); a keyframe every two
 * seconds or so at the tracker's rate leaves it most of the time.
 */
export const KEYFRAME_EVERY = 50;

/**
 * Fewest frames between two keyframes' starts when the frame has another number of
 * detections than the last keyframe had (a new object, or one lost: its masks are the ones
 * to learn).
 */
export const KEYFRAME_MIN_GAP = 10;

/**
 * Most of the wall time the net may spend on keyframes: after a keyframe whose inferences took
 * `t` ms, the next starts `t·(1/KEYFRAME_DUTY − 1)` ms after it ended at the soonest. The
 * frame counts above assume the net keeps up with them; on a slow or busy machine an inference
 * takes seconds and keyframes 50 frames apart ran back to back, taking a quarter of the
 * tracker's rate on two cores (16.4 → 12.6 fps, scripts/bench-learned-fps.mjs, 2026-12-06).
 * A bound in time follows the machine: a fast one keeps its keyframes every 50 frames, a slow
 * one spaces them out instead of losing frames.
 */
export const KEYFRAME_DUTY = 1 / 3;
/**
 * When a keyframe may start (see `LearnedKeyframes`): every `KEYFRAME_EVERY` frames, every
 * `KEYFRAME_MIN_GAP` while the number of detections changes, and never while the net is still
 * owed rest (`KEYFRAME_DUTY`). Kept apart from the class so that the rule is tested without a
 * net.
 */
export class KeyframeSchedule {
  constructor() {
    this.lastStart = -Infinity;
    /** detections of the last keyframe */
    this.lastCount = -1;
    /** the soonest time (ms, `performance.now()`'s clock) the next keyframe may start */
    this.readyAt = -Infinity;
  }

  /**
   * Whether a keyframe may start on frame `frame`, which has `count` detections, at `now`.
   * @param {number} frame
   * @param {number} count
   * @param {number} now
   */
  due(frame, count, now) {
    if (now < this.readyAt) return false;
    const since = frame - this.lastStart;
    return since >= KEYFRAME_MIN_GAP && (since >= KEYFRAME_EVERY || count !== this.lastCount);
  }

  /**
   * A keyframe started on frame `frame` with `count` detections.
   * @param {number} frame
   * @param {number} count
   */
  started(frame, count) {
    this.lastStart = frame;
    this.lastCount = count;
  }

  /**
   * The keyframe's inferences took `busy` ms (the net's load excluded: it happens once) and
   * ended at `now`.
   * @param {number} busy
   * @param {number} now
   */
  finished(busy, now) {
    this.readyAt = now + Math.max(0, busy) * (1 / KEYFRAME_DUTY - 1);
  }
}
/**
 * Crops per keyframe beyond the whole-frame pass (the core's `max_crops`), the highest
 * detection score first: two inferences a keyframe (4 s or more on this 2-core machine) keep
 * the learned masks a few seconds old at most; a crowded frame's other detections keep their
 * weights-free masks (or get the whole-frame pass's region).
 */
export const KEYFRAME_CROPS = 1;

/**
 * One keyframe in this many looks at the whole frame first (`proposals`: objects that stand
 * still); the others only at the top detection's crop, one inference instead of two, so their
 * masks are half as old when they land (the first keyframe is a whole-frame one).
 */
export const KEYFRAME_WHOLE_EVERY = 3;

/**
 * Oldest a keyframe's learned mask may be, in frames since the keyframe's own frame, to take a
 * detection's place. Shifted by its detection's motion, an outline follows an object that
 * moves, not its changes of shape, and those come fast: the ground-truth mask of a DAVIS
 * moving-camera clip, shifted so, keeps J 0.90 one frame later, 0.82 three, 0.76 five, 0.57
 * twenty-five (bus, camel, car-roundabout, dog; 0.79 / 0.65 / 0.57 / 0.40 on bmx-trees, hike,
 * scooter-black, soapbox), while the detector's own masks score about 0.74 there. A learned
 * mask (J 0.83 from its box) is worth taking only a frame or two after its keyframe: with a
 * fast net (WebGPU), not on a 2-core machine's wasm, where a keyframe takes seconds and its
 * carried masks lowered the tracker's J on every clip (0.736 → 0.714, bench-learned-fps).
 */
export const REPLACE_AGE = 2;

/**
 * Frames a learned region no detection gave (an object standing still) is added at most,
 * after it arrives. It is added where it was on its keyframe: right for a still camera, off by the camera's motion
 * since then for a moving one, so only briefly (a second at 25 fps); the tracker's track
 * carries it on.
 */
export const REGION_FRAMES = 25;

/** Box IoU above which a learned mask and a detection are the same object (see `apply`). */
export const MATCH_IOU = 0.3;

/**
 * Mask IoU a carried learned mask must have with the detection's own mask to take its place.
 * A keyframe's mask is seconds old when it lands on this machine (a keyframe takes 10 s or
 * more beside the tracker under load); shifted, it is still the object's outline while the
 * object keeps its shape, and no longer when it turned or the match was wrong. Replaced
 * unconditionally, the carried masks lowered the tracker's mean J on four DAVIS moving-camera
 * clips from 0.736 to 0.650 (scripts/bench-learned-fps.mjs, 2026-12-06); the follower takes
 * a learned outline by the same test (`FollowConfig::learned_iou`, 0.5).
 */
export const AGREE_IOU = 0.5;

/**
 * Mask IoU of two cropped masks.
 * @param {MaskBitmap} a
 * @param {MaskBitmap} b
 */
export function maskIou(a, b) {
  let inter = 0;
  let na = 0;
  let nb = 0;
  for (const v of a.data) na += v ? 1 : 0;
  for (const v of b.data) nb += v ? 1 : 0;
  const x0 = Math.max(a.x, b.x);
  const x1 = Math.min(a.x + a.width, b.x + b.width);
  const y0 = Math.max(a.y, b.y);
  const y1 = Math.min(a.y + a.height, b.y + b.height);
  for (let y = y0; y < y1; y++) {
    for (let x = x0; x < x1; x++) {
      if (a.data[(y - a.y) * a.width + x - a.x] && b.data[(y - b.y) * b.width + x - b.x]) inter++;
    }
  }
  const union = na + nb - inter;
  return union ? inter / union : 0;
}

/** Share of a learned region's pixels on a current detection above which it is not added. */
const COVERED = 0.5;

/**
 * @typedef {{ used: number, added: number, from: number } | null} LearnedUse  what a frame took
 *   from the learned stage: detections whose mask was replaced by a learned one (`used`),
 *   learned regions no detection covered, added as detections (`added`, objects that do not
 *   move), from the keyframe `from`; null when no keyframe's masks were carried
 *
 * @typedef {{ keyframes: number, failed: string | null, running: boolean, ms: number }} LearnedState
 *   keyframes done, why the stage stopped (the net could not load or run), whether one runs,
 *   and how long the last one took (ms, from its start to its masks; the net's load included
 *   for the first)
 */

/** @param {Box} a @param {Box} b */
function boxIou(a, b) {
  const iw = Math.min(a.x + a.w, b.x + b.w) - Math.max(a.x, b.x);
  const ih = Math.min(a.y + a.h, b.y + b.h) - Math.max(a.y, b.y);
  if (iw <= 0 || ih <= 0) return 0;
  return (iw * ih) / (a.w * a.h + b.w * b.h - iw * ih);
}

/**
 * `m` moved by whole pixels (`dx`, `dy`) and clipped to the frame; null when nothing is left.
 * @param {MaskBitmap} m
 * @param {number} dx
 * @param {number} dy
 * @param {number} width
 * @param {number} height
 * @returns {MaskBitmap | null}
 */
export function shiftMask(m, dx, dy, width, height) {
  const x = m.x + dx;
  const y = m.y + dy;
  const x0 = Math.max(0, x);
  const y0 = Math.max(0, y);
  const x1 = Math.min(width, x + m.width);
  const y1 = Math.min(height, y + m.height);
  if (x1 <= x0 || y1 <= y0) return null;
  if (x0 === x && y0 === y && x1 - x0 === m.width && y1 - y0 === m.height) return { ...m, x, y };
  const w = x1 - x0;
  const data = new Uint8Array(w * (y1 - y0));
  for (let r = y0; r < y1; r++) {
    const src = (r - y) * m.width + (x0 - x);
    data.set(m.data.subarray(src, src + w), (r - y0) * w);
  }
  return { x: x0, y: y0, width: w, height: y1 - y0, data };
}

/** @param {MaskBitmap} m */
const maskBox = (m) => ({ x: m.x, y: m.y, w: m.width, h: m.height });
/** @param {Box} b */
const centre = (b) => [b.x + b.w / 2, b.y + b.h / 2];

/**
 * The learned stage of the automatic (or any) detector, never in the way of the frames:
 *
 * 1. `keyframe`: when no keyframe is under way and `KEYFRAME_EVERY` frames have passed (or
 *    `KEYFRAME_MIN_GAP`, when the number of detections changed), and the net has rested
 *    enough since the last one (`KEYFRAME_DUTY`, `KeyframeSchedule`), the frame is copied and a `SegmentJob` started on the copy with the frame's detections as
 *    boxes, in `proposals` mode (the whole frame first: salient regions no detection covers
 *    are added, objects that stand still), `KEYFRAME_CROPS` crops at most. It runs on the
 *    segmenter worker while the tracker goes on with the weights-free masks.
 * 2. `apply`, every frame: the latest keyframe's learned masks (frame k, now k + m) are
 *    carried to this frame. A learned mask is matched to the keyframe's detection it came
 *    from (box IoU ≥ `MATCH_IOU`; a region the whole frame proposed stands for itself), that
 *    box to this frame's detections (the same), and shifted by the displacement of their
 *    boxes' centres; it then takes the place of the matched detection's mask if the two
 *    masks agree (IoU ≥ `AGREE_IOU`: a mismatched outline is not taken), and only up to
 *    `REPLACE_AGE` frames after the keyframe's own frame (an older outline has lost the
 *    object's shape). A proposed region no detection of this frame matches is added where it
 *    was (an object standing still), for `REGION_FRAMES` at most after it arrives, unless a
 *    detection covers it; until the next keyframe's masks arrive.
 *
 * If the net cannot load (offline before its first use) or fails, the stage stops for the
 * session (`state().failed` says why) and the detector's masks go through unchanged.
 */
export class LearnedKeyframes {
  /**
   * @param {Core} core
   * @param {number} width
   * @param {number} height
   */
  constructor(core, width, height) {
    this.core = core;
    this.width = width;
    this.height = height;
    /** @type {FrameBuffer | null} the frame a keyframe looks at (a copy: the tracker goes on) */
    this.copy = null;
    /** @type {Promise<void> | null} */
    this.running = null;
    this.schedule = new KeyframeSchedule();
    /** @type {{ frame: number, arrived: number, inputs: Box[], learned: DetectionJs[] } | null}
     * the latest keyframe's result (`arrived`: the first frame it was applied to) */
    this.result = null;
    this.keyframes = 0;
    /** keyframes started */
    this.started = 0;
    this.ms = 0;
    /** @type {string | null} */
    this.failed = null;
    this.disposed = false;
    keyframeUsers++;
  }

  /** @returns {LearnedState} */
  state() {
    return { keyframes: this.keyframes, failed: this.failed, running: this.running !== null, ms: this.ms };
  }

  /**
   * Starts a keyframe on frame `frame` (its pixels and the detector's `dets`) when none is
   * under way; returns at once either way.
   * @param {number} frame
   * @param {() => Uint8ClampedArray} pixels a fresh RGBA view on the frame buffer
   * @param {Detections} dets
   * @param {WebAssembly.Memory} memory
   */
  keyframe(frame, pixels, dets, memory) {
    if (this.running || this.failed || this.disposed) return;
    if (!this.schedule.due(frame, dets.len, performance.now())) return;
    this.copy ??= new this.core.FrameBuffer(this.width, this.height);
    // Views made after the allocation above: it may have grown (and detached) wasm memory.
    new Uint8ClampedArray(memory.buffer, this.copy.ptr(), this.copy.len()).set(pixels());
    // Boxes only: a detection comes back with a mask exactly when the net found its object.
    const given = dets.toList();
    const inputs = given.map((d) => d.bbox);
    const boxes = this.core.Detections.fromLists({ boxes: given.map((d) => ({ bbox: d.bbox, score: d.score, class: d.class })) });
    /** @type {import('../../pkg/shapetrack.js').SegmentJob} */
    let job;
    try {
      const whole = this.started % KEYFRAME_WHOLE_EVERY === 0 ? 'proposals' : 'off';
      job = new this.core.SegmentJob(this.copy, boxes, whole, { max_crops: KEYFRAME_CROPS });
      this.started += 1;
    } finally {
      boxes.free();
    }
    this.schedule.started(frame, given.length);
    const copy = this.copy;
    const t0 = performance.now();
    let loaded = t0;
    this.running = runJob(job, copy, undefined, () => {
      loaded = performance.now();
    })
      .then(() => {
        const now = performance.now();
        this.schedule.finished(now - loaded, now);
        const done = job.finish();
        try {
          if (!this.disposed) {
            this.result = { frame, arrived: -1, inputs, learned: done.toList().filter((d) => d.mask) };
            this.keyframes += 1;
            this.ms = performance.now() - t0;
          }
        } finally {
          done.free();
        }
      })
      .catch((/** @type {unknown} */ e) => {
        this.failed = e instanceof Error ? e.message : String(e);
      })
      .finally(() => {
        job.free();
        this.running = null;
      });
  }

  /**
   * `dets` (frame `frame`'s, consumed) with the latest keyframe's learned masks carried over
   * (see the class); `dets` itself when there are none to carry.
   * @param {number} frame
   * @param {Detections} dets
   * @returns {{ dets: Detections, use: LearnedUse }}
   */
  apply(frame, dets) {
    const r = this.result;
    if (!r || frame < r.frame || r.learned.length === 0) return { dets, use: null };
    if (r.arrived < 0) r.arrived = frame;
    const replace = frame - r.frame <= REPLACE_AGE;
    if (!replace && frame - r.arrived > REGION_FRAMES) return { dets, use: null };
    const list = dets.toList();
    /** @type {Array<{ mask: MaskBitmap, iou: number } | null>} the learned mask each detection takes */
    const take = list.map(() => null);
    /** @type {import('./detectors.js').MaskInput[]} */
    const regions = [];
    for (const l of r.learned) {
      const lm = /** @type {MaskBitmap} */ (l.mask);
      let k = -1;
      let best = MATCH_IOU;
      r.inputs.forEach((b, i) => {
        const v = boxIou(b, l.bbox);
        if (v >= best) [k, best] = [i, v];
      });
      // The keyframe's box of this object: the detection it came from, or (a region the
      // whole frame proposed) its own.
      const kb = k >= 0 ? r.inputs[k] : l.bbox;
      let j = -1;
      let bj = MATCH_IOU;
      list.forEach((d, i) => {
        const v = boxIou(kb, d.bbox);
        if (v >= bj) [j, bj] = [i, v];
      });
      if (j >= 0 && !replace) continue;
      if (j < 0) {
        // Not detected now: a region is added for a while (an object standing still); a
        // detection's object has gone, nothing to correct.
        if (k < 0 && frame - r.arrived <= REGION_FRAMES) regions.push({ ...lm, score: l.score, class: l.class });
        continue;
      }
      const [kx, ky] = centre(kb);
      const [dx, dy] = centre(list[j].bbox);
      const moved = shiftMask(lm, Math.round(dx - kx), Math.round(dy - ky), this.width, this.height);
      const own = list[j].mask;
      if (moved && own && maskIou(moved, own) < AGREE_IOU) continue;
      if (moved && (!take[j] || bj > /** @type {{ iou: number }} */ (take[j]).iou)) take[j] = { mask: moved, iou: bj };
    }
    let used = 0;
    /** @type {import('./detectors.js').MaskInput[]} */
    const masks = [];
    /** @type {import('./detectors.js').BoxInput[]} */
    const boxes = [];
    list.forEach((d, i) => {
      const t = take[i];
      if (t) used += 1;
      const m = t?.mask ?? d.mask;
      if (m) masks.push({ ...m, score: d.score, class: d.class });
      else boxes.push({ bbox: d.bbox, score: d.score, class: d.class });
    });
    if (used === 0 && regions.length === 0) return { dets, use: null };
    const out = this.core.Detections.fromLists({ masks, boxes });
    let added = 0;
    try {
      if (regions.length) {
        const extra = this.core.Detections.fromLists({ masks: regions });
        try {
          added = out.addUncovered(extra, COVERED);
        } finally {
          extra.free();
        }
      }
    } catch (e) {
      out.free();
      throw e;
    }
    dets.free();
    return { dets: out, use: used + added > 0 ? { used, added, from: r.frame } : null };
  }

  /** Stops using the net (a keyframe under way finishes unseen) and frees the frame copy. */
  dispose() {
    if (!this.disposed) keyframeUsers--;
    this.disposed = true;
    const copy = this.copy;
    this.copy = null;
    if (this.running) void this.running.finally(() => copy?.free());
    else copy?.free();
  }
}
