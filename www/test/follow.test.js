import { test } from 'node:test';
import assert from 'node:assert/strict';
import { TrackTable } from '../src/model/tracks.js';
import { EditModel } from '../src/model/edits.js';
import {
  FOLLOW,
  FollowError,
  bitmapBox,
  checkFrame,
  checkShape,
  clipLegs,
  commitFollow,
  correctionLeg,
  followLegs,
  followedRun,
  followedSpans,
  rasterize,
  shiftBitmap,
  stepRecord,
} from '../src/model/follow.js';

/** A record whose box says where it came from (x = frame·10 + tag). */
const rec = (frame, id, tag = 0, extra = {}) => ({ frame, id, bbox: { x: frame * 10 + tag, y: id, w: 5, h: 5 }, ...extra });
/** A follower step for `frame` (tag marks which propagation made it). */
const step = (frame, tag, more = {}) => ({
  frame,
  mask: { size: /** @type {[number, number]} */ ([4, 4]), counts: `m${frame}.${tag}` },
  bbox: { x: frame * 10 + tag, y: 0, w: 5, h: 5 },
  confidence: 0.9,
  lost: false,
  stopped: false,
  ...more,
});

/** Every record of a table as comparable plain data. */
const dump = (/** @type {TrackTable} */ t) => JSON.stringify(t.all());

/**
 * Follows track `id` from `key` along `legs` with steps tagged `tag`, as the app does.
 * @param {EditModel} m
 */
function follow(m, id, key, legs, tag, stopAt = Infinity) {
  const records = [];
  for (const leg of legs) {
    for (let f = leg.from + leg.direction; leg.direction > 0 ? f <= leg.to : f >= leg.to; f += leg.direction) {
      const r = stepRecord(id, step(f, tag, Math.abs(f - leg.from) > stopAt ? { stopped: true } : {}));
      if (!r) break;
      records.push(r);
    }
  }
  return commitFollow(m, { id, key, legs, records, label: `follow ${id}` });
}

test('legs are clipped to the video and refuse bad starts with a FollowError', () => {
  assert.deepEqual(followLegs({ frame: 5, frames: 50, direction: 'forward', length: 100 }), [{ direction: 1, from: 5, to: 50 }]);
  assert.deepEqual(followLegs({ frame: 5, frames: 50, direction: 'both', length: 10 }), [
    { direction: 1, from: 5, to: 15 },
    { direction: -1, from: 5, to: 1 },
  ]);
  // A video of unknown length (webcam) follows forward as far as asked.
  assert.deepEqual(followLegs({ frame: 5, frames: 0, direction: 'forward', length: 3 }), [{ direction: 1, from: 5, to: 8 }]);
  assert.throws(() => followLegs({ frame: 0, frames: 50, direction: 'forward', length: 5 }), FollowError);
  assert.throws(() => followLegs({ frame: 51, frames: 50, direction: 'forward', length: 5 }), /outside the video/);
  assert.throws(() => followLegs({ frame: 2.5, frames: 50, direction: 'forward', length: 5 }), FollowError);
  assert.throws(() => followLegs({ frame: 50, frames: 50, direction: 'forward', length: 5 }), /last frame/);
  assert.throws(() => followLegs({ frame: 1, frames: 50, direction: 'backward', length: 5 }), /first frame/);
  assert.throws(() => followLegs({ frame: 3, frames: 50, direction: 'forward', length: 0 }), FollowError);
  assert.throws(() => checkFrame(-1, 0), FollowError);
  checkFrame(1000, 0);
});

test('an empty or degenerate shape is refused', () => {
  assert.throws(() => checkShape({ bbox: { x: 3, y: 3, w: 0, h: 10 } }), FollowError);
  assert.throws(() => checkShape({ bbox: { x: 3, y: 3, w: 1, h: 1 } }), /empty/);
  assert.throws(() => checkShape({ bbox: { x: NaN, y: 3, w: 4, h: 4 } }), FollowError);
  checkShape({ bbox: { x: 3, y: 3, w: 2, h: 2 } });
});

test('a follow is one edit: a new track, marked followed, its keyframe flagged; undo removes it exactly', () => {
  const m = new EditModel(new TrackTable([rec(1, 1), rec(2, 1)]));
  const before = dump(m.table);
  const id = m.nextId;
  const key = { frame: 3, id, bbox: { x: 0, y: 0, w: 4, h: 4 } };
  follow(m, id, key, followLegs({ frame: 3, frames: 10, direction: 'both', length: 3 }), 1);
  assert.deepEqual(m.table.track(id).map((r) => r.frame), [1, 2, 3, 4, 5, 6]);
  assert.ok(m.table.track(id).every((r) => r.source === FOLLOW));
  assert.deepEqual(m.table.track(id).filter((r) => r.keyframe).map((r) => r.frame), [3]);
  assert.equal(m.nextId, id + 1);
  // The tracker must not reuse the labeller's new number.
  assert.ok(m.taken(id));
  assert.deepEqual(followedSpans(m.table, id), [{ start: 1, end: 6, keys: [3] }]);
  assert.equal(m.undo(), `follow ${id}`);
  assert.equal(dump(m.table), before);
  assert.equal(m.nextId, id);
  m.redo();
  assert.equal(m.table.track(id).length, 6);
});

test('following an existing track replaces its records only where the follower reached', () => {
  const m = new EditModel(new TrackTable([1, 2, 3, 4, 5, 6, 7, 8].map((f) => rec(f, 4))));
  // The follower stops after 2 frames: frames 6..8 keep the tracker's records.
  follow(m, 4, m.table.get(3, 4), followLegs({ frame: 3, frames: 8, direction: 'forward', length: 5 }), 1, 2);
  const t = m.table.track(4);
  assert.deepEqual(t.map((r) => [r.frame, r.source ?? 'tracker']), [
    [1, 'tracker'], [2, 'tracker'], [3, FOLLOW], [4, FOLLOW], [5, FOLLOW], [6, 'tracker'], [7, 'tracker'], [8, 'tracker'],
  ]);
  // The keyframe keeps the picked shape (its box), now flagged.
  assert.equal(m.table.get(3, 4)?.bbox.x, 30);
  assert.ok(m.table.get(3, 4)?.keyframe);
  m.undo();
  assert.ok(m.table.track(4).every((r) => !r.source));
});

test('a lost frame keeps the prediction as interpolated; a stopped one records nothing', () => {
  assert.equal(stepRecord(2, step(5, 0, { lost: true }))?.interpolated, true);
  assert.equal(stepRecord(2, step(5, 0, { stopped: true })), null);
  assert.equal(stepRecord(2, step(5, 0, { mask: null })), null);
  assert.equal(stepRecord(2, step(5, 0))?.score, 0.9);
});

test('a correction re-propagates only up to the next keyframe, or the run end, in the right direction', () => {
  const m = new EditModel(new TrackTable());
  const id = 1;
  // Keyframe at 10, followed 1..20.
  follow(m, id, rec(10, id), followLegs({ frame: 10, frames: 30, direction: 'both', length: 10 }), 1);
  assert.deepEqual(followedRun(m.table, id, 12), { start: 1, end: 20, keys: [10] });
  // After the keyframe: forward to the run's end.
  assert.deepEqual(correctionLeg(m.table, id, 14), { direction: 1, from: 14, to: 20 });
  // Before it: backward to the run's start.
  assert.deepEqual(correctionLeg(m.table, id, 6), { direction: -1, from: 6, to: 1 });
  // The run's last frame: nothing lies beyond.
  assert.equal(correctionLeg(m.table, id, 20), null);
  // Not followed here: no correction leg (a new follow instead).
  assert.equal(correctionLeg(m.table, id, 25), null);
  assert.equal(correctionLeg(m.table, 99, 5), null);

  // Correct at 14 (the labeller's shape, tag 2): frames 15..20 change, 1..13 do not.
  const before = m.table.track(id).map((r) => ({ ...r }));
  const leg14 = /** @type {any} */ (correctionLeg(m.table, id, 14));
  follow(m, id, rec(14, id, 7), [leg14], 2);
  const after = m.table.track(id);
  for (const r of after) {
    const old = before.find((o) => o.frame === r.frame);
    if (r.frame < 14) assert.deepEqual(r, old, `frame ${r.frame} untouched`);
    else assert.notDeepEqual(r.bbox, old?.bbox, `frame ${r.frame} re-propagated`);
  }
  assert.deepEqual(followedSpans(m.table, id), [{ start: 1, end: 20, keys: [10, 14] }]);
  // A correction between two keyframes stops before the next one.
  assert.deepEqual(correctionLeg(m.table, id, 12), { direction: 1, from: 12, to: 13 });
  // Undo restores the records before the correction exactly.
  m.undo();
  assert.deepEqual(m.table.track(id), before);
});

test('a re-propagation that stops sooner drops the stale followed records of its span', () => {
  const m = new EditModel(new TrackTable());
  follow(m, 1, rec(1, 1), followLegs({ frame: 1, frames: 30, direction: 'forward', length: 10 }), 1);
  const leg = /** @type {any} */ (correctionLeg(m.table, 1, 4));
  assert.deepEqual(leg, { direction: 1, from: 4, to: 11 });
  follow(m, 1, rec(4, 1, 5), [leg], 2, 3);
  // 4 is the new keyframe, 5..7 re-followed, 8..11 (from the old keyframe) gone.
  assert.deepEqual(m.table.track(1).map((r) => r.frame), [1, 2, 3, 4, 5, 6, 7]);
  m.undo();
  assert.deepEqual(m.table.track(1).map((r) => r.frame), [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11]);
});

test('tracker output never replaces a followed shape of the same track', () => {
  const m = new EditModel(new TrackTable());
  m.ingest([rec(1, 3)]);
  follow(m, 3, rec(1, 3), followLegs({ frame: 1, frames: 10, direction: 'forward', length: 3 }), 1);
  m.ingest([rec(2, 3, 9), rec(5, 3, 9)]);
  assert.equal(m.table.get(2, 3)?.source, FOLLOW);
  assert.equal(m.table.get(5, 3)?.bbox.x, 59);
  assert.equal(m.takeNotices().length, 0);
});

test('boxes and polygons rasterise to the pixels they cover', () => {
  const box = rasterize({ kind: 'box', box: { x: 1, y: 1, w: 2, h: 3 } }, 5, 5);
  assert.deepEqual(bitmapBox(box, 5), { x: 1, y: 1, w: 2, h: 3 });
  assert.equal(box.reduce((a, b) => a + b, 0), 6);
  // A box outside the frame is clipped away.
  assert.equal(bitmapBox(rasterize({ kind: 'box', box: { x: 9, y: 9, w: 2, h: 2 } }, 5, 5), 5), null);
  // A right triangle with legs of 10: about half of 100 pixels.
  const tri = rasterize({ kind: 'polygon', points: [[0, 0], [10, 0], [0, 10]] }, 12, 12);
  const n = tri.reduce((a, b) => a + b, 0);
  assert.ok(n >= 45 && n <= 55, `${n}`);
  // Pixel centres on the hypotenuse (x + y = 10) are outside: 9 columns and rows.
  assert.deepEqual(bitmapBox(tri, 12), { x: 0, y: 0, w: 9, h: 9 });
  // Fewer than three points cover nothing.
  assert.equal(bitmapBox(rasterize({ kind: 'polygon', points: [[0, 0], [5, 5]] }, 8, 8), 8), null);
});

test('a dragged mask moves by whole pixels and is cut at the frame edge', () => {
  const bm = { x: 1, y: 1, width: 2, height: 2, data: [1, 1, 0, 1] };
  const moved = shiftBitmap(bm, 2.4, 1, 6, 5);
  assert.deepEqual(bitmapBox(moved, 6), { x: 3, y: 2, w: 2, h: 2 });
  assert.equal(moved.reduce((a, b) => a + b, 0), 3);
  // Half outside: only the pixel still in the frame stays.
  const cut = shiftBitmap(bm, 4, 3, 6, 5);
  assert.equal(cut.reduce((a, b) => a + b, 0), 1);
  assert.equal(cut[4 * 6 + 5], 1);
});

test('a new follow of a track stops before its keyframes: no propagation overwrites a given shape', () => {
  const m = new EditModel(new TrackTable());
  follow(m, 1, rec(5, 1), followLegs({ frame: 5, frames: 30, direction: 'forward', length: 10 }), 1);
  // From frame 15 back 15 frames: frames 14..6, not the keyframe at 5 nor what lies before it.
  assert.deepEqual(clipLegs(m.table, 1, followLegs({ frame: 15, frames: 30, direction: 'both', length: 15 })), [
    { direction: 1, from: 15, to: 30 },
    { direction: -1, from: 15, to: 6 },
  ]);
  // Right next to a keyframe, in its direction: nothing to do, said so.
  assert.throws(() => clipLegs(m.table, 1, [{ direction: -1, from: 6, to: 1 }]), /keyframe/);
  // Another track's keyframes do not matter.
  assert.deepEqual(clipLegs(m.table, 2, [{ direction: -1, from: 6, to: 1 }]), [{ direction: -1, from: 6, to: 1 }]);
});
