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
import { INPUT_LENGTH, SegmenterError } from './segmenter/contract.js';

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
 * The segmenter, shared by the box masks and the detector's keyframes (one net, one worker,
 * loaded once). One thread: the tracker worker has the other core.
 */
function segmenter() {
  client ??= new SegmenterClient({ threads: 1 });
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
 * reports it).
 */
export function warmLearned() {
  const seg = segmenter();
  if (seg.info) return;
  seg
    .start()
    .then(() => seg.run(new Float32Array(INPUT_LENGTH), { transfer: true }))
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
 */
async function runJob(job, buf, onProgress) {
  const seg = segmenter();
  seg.onProgress = onProgress ? (p) => onProgress({ phase: 'load', ...p }) : null;
  try {
    await seg.start();
  } catch (e) {
    forgetSegmenter();
    throw e;
  }
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
      job = new core.SegmentJob(buf, dets, 'off');
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
