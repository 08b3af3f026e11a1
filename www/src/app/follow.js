// Following a shape: the box and polygon tool, a drawn or dragged shape turned into a keyframe,
// and the worker's follower run over the frames from it as one undoable edit.

import { EditError } from '../model/edits.js';
import {
  FollowError,
  bitmapBox,
  checkShape,
  commitFollow,
  correctionLeg,
  followLegs,
  clipLegs,
  followedRun,
  isFollowed,
  rasterize,
  shiftBitmap,
  stepRecord,
} from '../model/follow.js';
import { byId } from '../lib/dom.js';

/**
 * @typedef {import('../app.js').App} App
 * @typedef {import('../app.js').AnySource} AnySource
 * @typedef {import('../model/tracks.js').TrackRecord} TrackRecord
 */

/**
 * Switches the drawing tool (the same one again: off, clicks select again).
 * @param {App} app
 * @param {'box' | 'polygon' | null} mode
 */
export function useTool(app, mode) {
  const next = mode === app.shapeTool.mode ? null : mode;
  app.shapeTool.use(next);
  byId('fol-box').setAttribute('aria-pressed', String(next === 'box'));
  byId('fol-poly').setAttribute('aria-pressed', String(next === 'polygon'));
  byId('overlay').classList.toggle('drawing', next !== null);
  // The learned segmenter starts loading while the box is drawn (worker/learned.js).
  if (next === 'box' && app.source && byId('fol-learned', HTMLInputElement).checked) void app.worker.learnedWarm().catch(() => {});
  if (next) {
    const what = next === 'box' ? 'drag a box' : 'click the corners of a polygon (Enter or double-click closes it)';
    const on = app.selection.a !== null ? `: it becomes track ${app.selection.a}'s shape here (Esc first for a new track)` : ' around the object to follow';
    app.status(`${what}${on}`);
  }
}

/**
 * The frames a new follow covers, from the Follow card's settings.
 * @param {App} app
 */
export function followSettings(app) {
  const direction = /** @type {'forward' | 'backward' | 'both'} */ (byId('fol-dir', HTMLSelectElement).value);
  const length = Number(byId('fol-len', HTMLInputElement).value);
  return { direction, length };
}

/**
 * Follows the selected track's shape in this frame (F).
 * @param {App} app
 */
export async function followSelected(app) {
  const id = app.selection.a;
  if (id === null) throw new FollowError('select a shape to follow (click it), or draw a box or polygon around the object (X, P)');
  const r = app.model.table.get(app.cur, id);
  if (!r) throw new FollowError(`track ${id} has no shape in frame ${app.cur}: go to a frame where it is seen, or draw one (X, P)`);
  // A box-only record (a box detector, an import) starts from the outline its box holds.
  const key = r.mask ? r : { ...r, mask: app.core.encodeMask(app.stage.width, app.stage.height, await app.boxMask(r.bbox)) };
  const legs = followLegs({ frame: app.cur, frames: app.session.frames, ...app.followSettings() });
  await app.followFrom(id, key, clipLegs(app.model.table, id, legs));
}

/**
 * A box or polygon drawn on the stage (see `shapeGiven`).
 * @param {App} app
 * @param {import('../view/shapetool.js').Shape} shape
 */
export async function shapeDrawn(app, shape) {
  const { width, height } = app.stage;
  // A box says where the object is, not its shape: it becomes the outline it holds. A
  // polygon is the labeller's outline already.
  await app.shapeGiven(shape.kind === 'box' ? await app.boxMask(shape.box) : rasterize(shape, width, height));
  // Done: the tool is put away, so the next click selects again instead of starting another
  // box (a refused shape throws above and leaves it armed for another try).
  if (app.shapeTool.mode) app.useTool(null);
}

/**
 * The outline of what `box` holds on this frame, as a full-frame bitmap: by the learned
 * segmenter in the tracker worker when the Follow card's "learned outline" is on and the
 * net loads, else by the weights-free refinement (worker/learned.js). The progress bar shows
 * the net's files arriving, then the inference; tracking stops first (the worker does one
 * thing at a time, and this frame must stay in its buffer).
 * @param {App} app
 * @param {{ x: number, y: number, w: number, h: number }} box
 * @returns {Promise<Uint8Array>}
 */
export async function boxMask(app, box) {
  const src = app.source;
  if (!src) throw new FollowError('open the demo, a video or an image sequence first');
  checkShape({ bbox: box });
  if (app.following) throw new FollowError('a follow is under way: wait for it or cancel it (Esc)');
  await app.stop();
  const learned = byId('fol-learned', HTMLInputElement).checked;
  const progress = byId('fol-progress', HTMLProgressElement);
  progress.hidden = false;
  progress.removeAttribute('value'); // indeterminate until the first report
  app.status(learned ? 'outlining the box…' : 'outlining the box (weights-free)…');
  try {
    const r = await app.worker.boxMask(app.cur, box, learned, await app.grab(src, app.cur), (p) => {
      if (p.phase === 'load') {
        progress.value = p.total ? p.loaded / p.total : 0;
        app.status(`loading the learned segmenter: ${(p.loaded / 1e6).toFixed(1)} of ${(p.total / 1e6).toFixed(1)} MB`);
      } else {
        progress.removeAttribute('value');
        app.status('outlining the box (learned segmenter)…');
      }
    });
    app.lastBoxMask = { how: r.how, ms: r.ms, note: r.note };
    const how = r.how === 'learned' ? 'learned outline' : `weights-free outline${learned && r.note ? ` (${r.note})` : ''}`;
    app.status(`${how} in ${(r.ms / 1000).toFixed(1)} s`);
    return r.bitmap;
  } finally {
    progress.hidden = true;
    progress.value = 0;
  }
}

/**
 * A shape the labeller gave on this frame (drawn, or a followed shape dragged), as a
 * full-frame bitmap: with a followed track selected and this frame inside its followed run,
 * a corrected keyframe that re-propagates the frames it affects; with another track
 * selected, that track followed from the shape; else a new track.
 * @param {App} app
 * @param {Uint8Array} bitmap
 */
export async function shapeGiven(app, bitmap) {
  const { width, height } = app.stage;
  const bbox = bitmapBox(bitmap, width) ?? { x: 0, y: 0, w: 0, h: 0 };
  checkShape({ bbox });
  const mask = app.core.encodeMask(width, height, bitmap);
  const frame = app.cur;
  const sel = app.selection.a;
  if (sel === null) {
    const id = app.model.nextId;
    await app.followFrom(id, { frame, id, bbox, mask }, followLegs({ frame, frames: app.session.frames, ...app.followSettings() }));
    return;
  }
  const key = { frame, id: sel, bbox, mask };
  const leg = correctionLeg(app.model.table, sel, frame);
  if (leg) {
    await app.followFrom(sel, key, [leg], `correct ${sel} at frame ${frame}`);
  } else if (followedRun(app.model.table, sel, frame)) {
    // The run's last frame: nothing after it to propagate, the shape alone is corrected.
    commitFollow(app.model, { id: sel, key, legs: [], records: [], label: `correct ${sel} at frame ${frame}` });
    app.lastEdit = app.model.undoStack.at(-1)?.label ?? '';
    app.status(`track ${sel}: shape corrected in frame ${frame}`);
  } else {
    const legs = followLegs({ frame, frames: app.session.frames, ...app.followSettings() });
    await app.followFrom(sel, key, clipLegs(app.model.table, sel, legs));
  }
}

/**
 * Starts dragging the shape under `p` when it is the selected track's followed shape.
 * @param {App} app
 * @param {{ x: number, y: number }} p
 * @returns {boolean} whether a drag started
 */
export function startMove(app, p) {
  const id = app.selection.a;
  if (id === null || app.following) return false;
  const r = app.model.table.get(app.cur, id);
  if (!isFollowed(r) || app.stage.hit(app.model.table, app.cur, p) !== id) return false;
  app.moving = { id, from: p, dx: 0, dy: 0 };
  return true;
}

/**
 * Ends a drag: a shape moved by a pixel or more becomes the track's keyframe here.
 * @param {App} app
 */
export async function endMove(app) {
  const m = app.moving;
  app.moving = null;
  app.render();
  if (!m || (Math.abs(m.dx) < 1 && Math.abs(m.dy) < 1)) return;
  const r = app.model.table.get(app.cur, m.id);
  const bm = r ? app.stage.mask(r)?.bitmap : null;
  if (!bm) return;
  await app.shapeGiven(shiftBitmap(bm, m.dx, m.dy, app.stage.width, app.stage.height));
}

/**
 * Runs a follow, reporting a refusal (an `EditError`: an empty shape, no selection, a frame
 * outside the video) in the status line; anything else fails as usual.
 * @param {App} app
 * @param {() => Promise<void>} fn
 */
export async function refusable(app, fn) {
  try {
    await fn();
  } catch (e) {
    if (e instanceof EditError) app.status(e.message, true);
    else app.fail(e);
  }
}

/**
 * Stops the follow under way after the frame in progress; what it followed is kept.
 * @param {App} app
 */
export function cancelFollow(app) {
  if (app.following) app.following.cancel = true;
}

/**
 * A frame's pixels for the follower: none for the synthetic scene (the worker renders it),
 * else the source's bitmap (grabbed in turn with the tracker's frames: one <video> seeks to
 * one place at a time).
 * @param {App} app
 * @param {AnySource} src
 * @param {number} n
 * @returns {Promise<ImageBitmap | undefined>}
 */
export function grab(app, src, n) {
  if (src.kind === 'synth') return Promise.resolve(undefined);
  const grabbed = app.grabChain.then(() => src.frameAt(n));
  app.grabChain = grabbed.then(
    () => undefined,
    () => undefined,
  );
  return grabbed.then((b) => {
    if (!b) throw new FollowError(`frame ${n} is not available from ${src.name}`);
    return b;
  });
}

/**
 * Follows track `id` from the shape `key` along `legs` (the worker's follower, a frame at a
 * time, two frames in flight), with progress and Cancel, then applies the result as one
 * edit (undoable). A cancelled follow keeps what it reached and leaves later frames as they
 * were; an error changes nothing.
 * @param {App} app
 * @param {number} id
 * @param {TrackRecord} key the keyframe (its mask is what is followed)
 * @param {import('../model/follow.js').Leg[]} legs
 * @param {string} [label] the edit's name
 */
export async function followFrom(app, id, key, legs, label = `follow ${id} from frame ${key.frame}`) {
  if (app.following) throw new FollowError('a follow is under way: wait for it or cancel it (Esc)');
  const src = app.source;
  if (!src || !key.mask) throw new FollowError('open the demo, a video or an image sequence first');
  checkShape(key);
  await app.stop();
  const run = { cancel: false };
  app.following = run;
  const progress = byId('fol-progress', HTMLProgressElement);
  const cancel = byId('fol-cancel');
  progress.hidden = false;
  progress.value = 0;
  cancel.hidden = false;
  const total = legs.reduce((n, l) => n + Math.abs(l.to - l.from), 0);
  /** @type {TrackRecord[]} */
  const records = [];
  /** @type {import('../model/follow.js').Leg[]} the frames each leg actually covered */
  const reached = [];
  let done = 0;
  let stopped = false;
  try {
    for (const leg of legs) {
      if (run.cancel) break;
      await app.worker.followStart(leg.from, leg.to, key.mask, await app.grab(src, leg.from));
      let last = leg.from;
      /** @type {Array<Promise<{ step: import('../worker/protocol.js').FollowStep }>>} */
      const inflight = [];
      let n = leg.from + leg.direction;
      const inLeg = (/** @type {number} */ f) => (leg.direction > 0 ? f <= leg.to : f >= leg.to);
      let legStopped = false;
      while (true) {
        while (!run.cancel && !legStopped && inflight.length < 2 && inLeg(n)) {
          const f = n;
          inflight.push(app.grab(src, f).then((b) => app.worker.followStep(f, b)));
          n += leg.direction;
        }
        const p = inflight.shift();
        if (!p) break;
        /** @type {{ step: import('../worker/protocol.js').FollowStep }} */
        let answer;
        try {
          answer = await p;
        } catch (e) {
          // The frame still in flight fails or lands after this one: wait for it, so no
          // rejection is left unhandled, then report this one.
          await Promise.allSettled(inflight);
          throw e;
        }
        const { step } = answer;
        if (legStopped) continue;
        const r = stepRecord(id, step);
        if (!r) {
          legStopped = true;
          stopped = true;
          last = leg.to;
          continue;
        }
        records.push(r);
        last = step.frame;
        done++;
        progress.value = total ? done / total : 1;
        app.status(`following ${id}: frame ${step.frame} (${done}/${total})${run.cancel ? ', stopping…' : ''}`);
      }
      // A follower that gave up has said where its target is not: the old followed shapes
      // of the rest of the leg go too. A cancelled leg leaves them.
      reached.push({ ...leg, to: last });
    }
  } finally {
    app.following = null;
    progress.hidden = true;
    cancel.hidden = true;
    await app.worker.followEnd().catch(() => undefined);
  }
  commitFollow(app.model, { id, key, legs: reached, records, label });
  app.lastEdit = label;
  app.selection = { a: id, b: null };
  const how = run.cancel ? ' (cancelled)' : stopped ? ' (the follower lost the target and stopped)' : '';
  app.status(`track ${id}: ${records.length} frame${records.length === 1 ? '' : 's'} followed from frame ${key.frame}${how}`);
  app.render();
}
