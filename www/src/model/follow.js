// "Follow this shape": the bookkeeping of followed spans, keyframes and their re-propagation.
//
// Pure (no DOM, no wasm), so it runs under `node --test`. The follower itself runs in the
// worker (the core's `Follower`, one frame at a time); this module decides which frames a
// follow covers, which records it replaces, and turns its result into one edit of the edit
// model, so Undo takes a whole follow (or a re-propagation) back exactly.
//
// All the state lives in the records: a followed record carries `source: 'follow'`, and the
// shape the labeller gave (drawn, or picked on the stage) also `keyframe: true`. Nothing is
// kept beside the table, so undo/redo, merges and imports cannot leave stale span bookkeeping
// behind, and followed records stay ordinary records (they export, draw and score as any other).

import { EditError } from './edits.js';

/**
 * @typedef {import('./tracks.js').TrackRecord} TrackRecord
 * @typedef {import('./tracks.js').TrackTable} TrackTable
 * @typedef {import('./tracks.js').Box} Box
 * @typedef {import('./tracks.js').Rle} Rle
 * @typedef {import('./edits.js').EditModel} EditModel
 * @typedef {1 | -1} Direction  1: forward (later frames), -1: backward
 * @typedef {{ direction: Direction, from: number, to: number }} Leg
 *   one propagation: from the keyframe `from` (exclusive) to `to` (inclusive), in `direction`
 * @typedef {{ frame: number, mask?: Rle | null, bbox?: Box | null, confidence: number, lost: boolean, stopped: boolean }} StepOut
 *   the follower's answer for one frame (the worker's `followStep`)
 */

/** The `source` of followed records. */
export const FOLLOW = 'follow';

/** A follow that cannot start as asked: an empty shape, a frame outside the video, ... */
export class FollowError extends EditError {
  /** @param {string} message */
  constructor(message) {
    super(message);
    this.name = 'FollowError';
  }
}

/** @param {TrackRecord | undefined} r whether the follower made this record */
export const isFollowed = (r) => r?.source === FOLLOW;

/**
 * Checks that `frame` can be shown: a whole number in `1..=frames` (`frames` 0: unknown length,
 * any frame from 1).
 * @param {number} frame
 * @param {number} frames
 */
export function checkFrame(frame, frames) {
  if (!Number.isInteger(frame) || frame < 1 || (frames > 0 && frame > frames)) {
    throw new FollowError(`frame ${frame} is outside the video (frames 1–${frames || '…'})`);
  }
}

/**
 * Checks the shape a follow starts from: its box must hold some pixels. The follower needs an appearance to follow; an empty or degenerate shape has none.
 * @param {{ bbox: Box, mask?: Rle | null }} shape
 */
export function checkShape(shape) {
  const b = shape.bbox;
  if (!b || !(b.w >= 2 && b.h >= 2) || ![b.x, b.y, b.w, b.h].every(Number.isFinite)) {
    throw new FollowError('the shape to follow is empty: draw a box or polygon around the object (at least 2×2 pixels)');
  }
  // An empty mask (a drawn polygon with no pixel inside) is refused by the core's Follower
  // with its own error; its box is already empty here.
}

/**
 * The legs of a new follow from `frame`: forward, backward or both, `length` frames each way,
 * clipped to the video.
 * @param {{ frame: number, frames: number, direction: 'forward' | 'backward' | 'both', length: number }} a
 *   `frames`: the video's length (0: unknown, forward unbounded)
 * @returns {Leg[]}
 */
export function followLegs({ frame, frames, direction, length }) {
  checkFrame(frame, frames);
  if (!Number.isInteger(length) || length < 1) throw new FollowError(`follow for at least 1 frame, not ${length}`);
  /** @type {Leg[]} */
  const legs = [];
  if (direction !== 'backward') {
    const to = frames > 0 ? Math.min(frames, frame + length) : frame + length;
    if (to > frame) legs.push({ direction: 1, from: frame, to });
  }
  if (direction !== 'forward') {
    const to = Math.max(1, frame - length);
    if (to < frame) legs.push({ direction: -1, from: frame, to });
  }
  if (!legs.length) throw new FollowError(`nothing to follow ${direction} from frame ${frame}: it is the video's ${frame === 1 ? 'first' : 'last'} frame`);
  return legs;
}

/**
 * Legs of a follow of track `id` cut short before the track's keyframes: a keyframe is a shape
 * the labeller gave, and no propagation overwrites it (a correction stops there the same way).
 * @param {TrackTable} table
 * @param {number} id
 * @param {Leg[]} legs
 * @returns {Leg[]} the legs that still cover a frame
 * @throws {FollowError} when none does
 */
export function clipLegs(table, id, legs) {
  /** @type {Leg[]} */
  const out = [];
  for (const leg of legs) {
    let to = leg.from;
    for (let f = leg.from + leg.direction; leg.direction > 0 ? f <= leg.to : f >= leg.to; f += leg.direction) {
      if (table.get(f, id)?.keyframe) break;
      to = f;
    }
    if (to !== leg.from) out.push({ ...leg, to });
  }
  if (!out.length && legs.length) {
    throw new FollowError(`track ${id} has a keyframe next to frame ${legs[0].from} in that direction: nothing to follow before it`);
  }
  return out;
}

/**
 * The run of followed records of track `id` around `frame`: the consecutive frames whose
 * records the follower made (keyframes included), and the keyframes in it.
 * @param {TrackTable} table
 * @param {number} id
 * @param {number} frame
 * @returns {{ start: number, end: number, keys: number[] } | null} null: `frame` is in no run
 */
export function followedRun(table, id, frame) {
  if (!isFollowed(table.get(frame, id))) return null;
  let start = frame;
  let end = frame;
  while (isFollowed(table.get(start - 1, id))) start--;
  while (isFollowed(table.get(end + 1, id))) end++;
  const keys = [];
  for (let f = start; f <= end; f++) if (table.get(f, id)?.keyframe) keys.push(f);
  return { start, end, keys };
}

/**
 * What a corrected keyframe of track `id` at `frame` re-propagates: the frames it affects and
 * only those. Frames after an earlier keyframe were propagated forward from it, so a correction
 * there goes forward up to the next keyframe (exclusive) or the run's end; frames before every
 * keyframe were propagated backward, so a correction there goes back to the run's start.
 * @param {TrackTable} table
 * @param {number} id
 * @param {number} frame
 * @returns {Leg | null} null: `frame` is in no followed run, or nothing lies beyond it
 */
export function correctionLeg(table, id, frame) {
  const run = followedRun(table, id, frame);
  if (!run) return null;
  const before = run.keys.filter((k) => k < frame);
  const after = run.keys.filter((k) => k > frame);
  if (before.length || !after.length) {
    const to = after.length ? after[0] - 1 : run.end;
    return to > frame ? { direction: 1, from: frame, to } : null;
  }
  const to = run.start;
  return to < frame ? { direction: -1, from: frame, to } : null;
}

/**
 * The record a follower step becomes: an ordinary record of track `id`, marked followed. A frame
 * where the follower lost the target keeps its predicted shape, flagged `interpolated` (drawn
 * dashed, exported as not a keyframe): it was inferred, not seen.
 * @param {number} id
 * @param {StepOut} s
 * @returns {TrackRecord | null} null: the follower had stopped (nothing to record)
 */
export function stepRecord(id, s) {
  if (s.stopped || !s.mask || !s.bbox) return null;
  /** @type {TrackRecord} */
  const r = { frame: s.frame, id, bbox: s.bbox, mask: s.mask, score: s.confidence, source: FOLLOW };
  if (s.lost) r.interpolated = true;
  return r;
}

/**
 * Applies a follow to the model as one edit: the keyframe record and the followed records of
 * track `id` replace the track's records at those frames, and any earlier followed records of
 * the track inside `legs` that the new run did not reach (it stopped sooner) are removed: they
 * came from the old keyframe. Records outside the legs are untouched.
 * @param {EditModel} model
 * @param {{ id: number, key: TrackRecord, legs: Leg[], records: TrackRecord[], label: string }} a
 *   `key`: the shape the follow started from (made a keyframe here); `records`: the followed
 *   records (track `id`)
 * @returns {{ added: number, removed: number }}
 */
export function commitFollow(model, { id, key, legs, records, label }) {
  const table = model.table;
  /** @type {Set<TrackRecord>} */
  const removed = new Set();
  const keyRec = { ...key, id, source: FOLLOW, keyframe: true };
  delete keyRec.interpolated;
  const added = [keyRec, ...records];
  for (const r of added) {
    const old = table.get(r.frame, id);
    if (old) removed.add(old);
  }
  for (const leg of legs) {
    const lo = Math.min(leg.from, leg.to);
    const hi = Math.max(leg.from, leg.to);
    for (let f = lo; f <= hi; f++) {
      const old = table.get(f, id);
      if (old && isFollowed(old)) removed.add(old);
    }
  }
  // A new track (drawn on the stage) gets a number of the labeller's, which the tracker must
  // not reuse.
  const fresh = !table.has(id);
  if (fresh) model.labellerIds.add(id);
  model.commit(label, [...removed], added, new Map(), fresh ? Math.max(model.nextId, id + 1) : model.nextId);
  return { added: added.length, removed: removed.size };
}

/**
 * The followed spans of a track for the timeline: maximal runs of followed records, each with
 * its keyframes.
 * @param {TrackTable} table
 * @param {number} id
 * @returns {Array<{ start: number, end: number, keys: number[] }>}
 */
export function followedSpans(table, id) {
  /** @type {Array<{ start: number, end: number, keys: number[] }>} */
  const out = [];
  for (const r of table.track(id)) {
    if (!isFollowed(r)) continue;
    const last = out[out.length - 1];
    if (last && r.frame === last.end + 1) last.end = r.frame;
    else out.push({ start: r.frame, end: r.frame, keys: [] });
    if (r.keyframe) out[out.length - 1].keys.push(r.frame);
  }
  return out;
}

/**
 * A box or polygon (image coordinates) as a full-frame bitmap, `width·height` bytes, 1 inside:
 * what the core's `encodeMask` turns into the RLE a follow starts from. Polygons are filled
 * even-odd at pixel centres.
 * @param {{ kind: 'box', box: Box } | { kind: 'polygon', points: Array<[number, number]> }} shape
 * @param {number} width
 * @param {number} height
 * @returns {Uint8Array}
 */
export function rasterize(shape, width, height) {
  const out = new Uint8Array(width * height);
  if (shape.kind === 'box') {
    const { x, y, w, h } = shape.box;
    const x0 = Math.max(0, Math.round(x));
    const x1 = Math.min(width, Math.round(x + w));
    for (let r = Math.max(0, Math.round(y)); r < Math.min(height, Math.round(y + h)); r++) out.fill(1, r * width + x0, r * width + Math.max(x0, x1));
    return out;
  }
  const pts = shape.points;
  if (pts.length < 3) return out;
  for (let r = 0; r < height; r++) {
    const cy = r + 0.5;
    /** @type {number[]} */
    const xs = [];
    for (let i = 0, j = pts.length - 1; i < pts.length; j = i++) {
      const [xi, yi] = pts[i];
      const [xj, yj] = pts[j];
      if (yi > cy !== yj > cy) xs.push(xi + ((cy - yi) / (yj - yi)) * (xj - xi));
    }
    xs.sort((a, b) => a - b);
    for (let k = 0; k + 1 < xs.length; k += 2) {
      const a = Math.max(0, Math.ceil(xs[k] - 0.5));
      const b = Math.min(width, Math.ceil(xs[k + 1] - 0.5));
      if (b > a) out.fill(1, r * width + a, r * width + b);
    }
  }
  return out;
}

/**
 * A mask bitmap cropped to its foreground (the core's `decodeMask`) moved by `(dx, dy)` whole
 * pixels, as a full-frame bitmap (`width·height` bytes); what leaves the frame is cut off. A
 * labeller who drags a followed shape gives this as the corrected keyframe.
 * @param {{ x: number, y: number, width: number, height: number, data: ArrayLike<number> }} bm
 * @param {number} dx
 * @param {number} dy
 * @param {number} width
 * @param {number} height
 * @returns {Uint8Array}
 */
export function shiftBitmap(bm, dx, dy, width, height) {
  const out = new Uint8Array(width * height);
  const ox = bm.x + Math.round(dx);
  const oy = bm.y + Math.round(dy);
  for (let r = 0; r < bm.height; r++) {
    const y = oy + r;
    if (y < 0 || y >= height) continue;
    for (let c = 0; c < bm.width; c++) {
      const x = ox + c;
      if (x >= 0 && x < width && bm.data[r * bm.width + c]) out[y * width + x] = 1;
    }
  }
  return out;
}

/**
 * The bounding box of a shape's foreground pixels in a bitmap (null: none).
 * @param {Uint8Array} bitmap
 * @param {number} width
 * @returns {Box | null}
 */
export function bitmapBox(bitmap, width) {
  let x0 = Infinity;
  let y0 = Infinity;
  let x1 = -1;
  let y1 = -1;
  for (let i = 0; i < bitmap.length; i++) {
    if (!bitmap[i]) continue;
    const x = i % width;
    const y = (i - x) / width;
    if (x < x0) x0 = x;
    if (x > x1) x1 = x;
    if (y < y0) y0 = y;
    if (y > y1) y1 = y;
  }
  return x1 < 0 ? null : { x: x0, y: y0, w: x1 - x0 + 1, h: y1 - y0 + 1 };
}
