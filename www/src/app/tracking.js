// Tracking through the worker: frames grabbed and posted two in flight, results taken into the
// track table (with the detector's warm-up and learned-stage notes), and the offline pass.

import { byId } from '../lib/dom.js';

/**
 * @typedef {import('../app.js').App} App
 * @typedef {import('../app.js').AnySource} AnySource
 * @typedef {import('../app.js').StepResult} StepResult
 */

/** Redraw at most this often (ms) while tracking offline. */
const OFFLINE_DRAW_MS = 250;
/** Share of the offline progress bar taken by the online pass; the re-linker has the rest. */
const ONLINE_SHARE = 0.9;
/** The offline pass's phases after the online pass, in order, as the status line names them. */
const PHASES = /** @type {const} */ ({
  candidates: 'finding broken tracks',
  appearance: 'comparing appearances',
  matching: 'choosing joins',
  filling: 'filling gaps',
});

/**
 * Tracks frames `processed+1 ..= until` through the worker, two in flight so the worker never
 * waits for the page to draw.
 * @param {App} app
 * @param {{ until: number, display: 'every' | 'throttled' | 'none' }} opts
 */
export async function track(app, { until, display }) {
  const src = app.source;
  if (!src) return;
  const progress = byId('progress', HTMLProgressElement);
  /** @type {Array<Promise<StepResult>>} */
  const inflight = [];
  let n = app.session.processed + 1;
  let lastDraw = 0;
  // At speed 1× a played-through file is shown at its own frame rate, the first time through
  // too (the camera paces itself); the frames are still posted two ahead, so the worker keeps
  // working while the page waits.
  const paced = display === 'every' && app.speed === 'realtime' && src.kind !== 'webcam';
  const t0 = performance.now();
  const f0 = n;
  while (true) {
    while (app.playing && inflight.length < 2 && n <= until) {
      // Offline, paint a frame now and then so the labeller sees progress.
      const now = performance.now();
      const paint = display === 'every' || (display === 'throttled' && now - lastDraw > OFFLINE_DRAW_MS);
      if (paint) lastDraw = now;
      inflight.push(app.send(src, n++, paint));
    }
    const p = inflight.shift();
    if (!p) break;
    const res = await p;
    app.accept(res);
    // The worker painted the frame if it was asked to; draw its overlay.
    if (res.painted) {
      app.cur = res.frame;
      app.render();
    }
    if (paced) await app.pace(t0, res.frame - f0 + 1);
    const frames = app.session.frames;
    progress.value = frames ? (ONLINE_SHARE * res.frame) / frames : 0;
    if (src.kind === 'webcam' && !app.playing) break;
  }
  if (display === 'throttled') {
    app.cur = Math.max(app.cur, 1);
    app.render();
  }
}

/**
 * Grabs frame `n` (in order) and posts it to the worker.
 * @param {App} app
 * @param {AnySource} src
 * @param {number} n
 * @param {boolean} display
 * @returns {Promise<StepResult>}
 */
export function send(app, src, n, display) {
  const posted = app.grabChain.then(async () => {
    /** @type {ImageBitmap | undefined} */
    let bitmap;
    if (src.kind === 'webcam') {
      bitmap = (await /** @type {any} */ (src).grab()).bitmap;
    } else if (src.kind !== 'synth') {
      const b = await src.frameAt(n);
      if (!b) throw new Error(`frame ${n} is not available`);
      bitmap = b;
    }
    const result = app.worker.step(n, bitmap, display).then((r) => ({ ...r, painted: display }));
    return { result };
  });
  app.grabChain = posted.then(
    () => undefined,
    () => undefined,
  );
  return posted.then((o) => o.result);
}

/**
 * Offline: track every remaining frame as fast as possible, then run the offline pass (the
 * core's trajectory re-linker and gap filling) and apply what it changed to the table. The
 * progress bar follows the frames, then the re-linker's phases.
 * @param {App} app
 */
export async function runOffline(app) {
  const progress = byId('progress', HTMLProgressElement);
  progress.hidden = false;
  progress.max = 1;
  progress.dataset.phase = 'online';
  const session = app.session;
  if (!session.allTracked) {
    await app.track({ until: session.frames, display: 'throttled' });
  }
  if (!app.playing || !session.allTracked) return;
  if (session.offlinePending) {
    session.beginFinishing();
    app.status('offline pass…');
    const phases = Object.keys(PHASES);
    /** @type {Awaited<ReturnType<typeof app.worker.finish>>} */
    let res;
    try {
      res = await app.worker.finish((p) => {
        const i = phases.indexOf(p.phase);
        const done = p.phase === 'done' ? 1 : (Math.max(0, i) + p.fraction) / phases.length;
        progress.value = ONLINE_SHARE + (1 - ONLINE_SHARE) * done;
        progress.dataset.phase = p.phase;
        const name = PHASES[/** @type {keyof typeof PHASES} */ (p.phase)];
        if (name) app.status(`offline pass: ${name}…`);
      });
    } catch (e) {
      // The pass can run again: play (Run) retries it.
      session.abortFinishing();
      throw e;
    }
    const onlineIds = app.model.table.ids().length;
    const onlineInterpolated = app.model.table.all().filter((r) => r.interpolated).length;
    // The pass's joins are the tracker's output, not the person's edits: a table that had no
    // unsaved edits before it has none after (replacing it asks nothing).
    const clean = !app.model.unsaved;
    const applied = app.model.relink({ joins: res.joins, filled: res.filled });
    if (clean) app.model.markSaved();
    app.lastEdit = app.model.undoStack.at(-1)?.label ?? '';
    const ids = app.model.table.ids().length;
    session.finish({ onlineIds, onlineInterpolated, ids, joins: applied.joined, filled: applied.filled, ms: res.ms });
    const skipped = res.joins.length - applied.joined;
    app.status(
      `offline pass: ${onlineIds} → ${ids} tracks (${applied.joined} joins, ${applied.filled} shapes filled in, ` +
        `${res.ms.toFixed(0)} ms)${skipped ? `; ${skipped} join(s) left to your edits` : ''}`,
    );
  }
  await app.show(app.cur || 1);
}

/**
 * Takes one tracked frame into the table. A result the session does not wait for (from a
 * source replaced meanwhile) is dropped: its shapes belong to another video.
 * @param {App} app
 * @param {StepResult} res
 */
export function accept(app, res) {
  if (app.session.phase !== 'tracking' || res.frame !== app.session.processed + 1) return;
  app.session.trackedFrame(res.frame);
  app.fps.tick(performance.now());
  app.lastTimings = res.timings;
  app.lastDetections = res.detections;
  const chose = res.choice !== null && res.choice.name !== app.detectorChoice?.name;
  if (chose) app.detectorChoice = res.choice;
  // The warm-up message names the choice; a chosen detector that needs no more learning
  // says it detects.
  app.warmupStatus(res.warmup);
  if (chose && !app.warming) app.status(app.choiceNote(`detecting from frame ${res.frame}`));
  if (res.groundTruth && app.gt) {
    for (const g of res.groundTruth) app.gt.add(g);
  }
  if (res.learned) app.learnedStep(res.learned);
  // Ingest last: it notifies the views.
  app.model.ingest(res.shapes);
  for (const n of app.model.takeNotices()) {
    app.status(`two tracks shown as ${n.id} are both seen in frame ${n.frame}: the second goes on as ${n.fresh}`, true);
  }
}

/**
 * While the detector learns the scene (a background model's first frames detect nothing;
 * the automatic detector judges the camera first), the status line says so, and says when
 * it is done: empty frames then are not a failure.
 * @param {App} app
 * @param {import('../worker/detectors.js').Warmup | null} w
 */
export function warmupStatus(app, w) {
  if (!w) return;
  const what = {
    background: ['learning the background', 'background learnt'],
    // The moving-camera detector's flow compares each frame with the one before (one
    // frame to wait for); its background-model cue learns `min_age` frames.
    moving: ['measuring the camera motion', 'camera motion measured'],
    judge: ['judging whether the camera moves', 'camera judged'],
  }[w.what ?? 'background'];
  if (w.seen < w.total) {
    app.status(app.choiceNote(`${what[0]}: ${w.seen}/${w.total} frames (nothing is detected until it is learnt)…`));
    app.warming = true;
  } else if (app.warming) {
    app.warming = false;
    app.status(app.choiceNote(`${what[1]} from ${w.total} frame${w.total === 1 ? '' : 's'}: detecting`));
  }
}

/**
 * `msg` after what the automatic detector chose, once it has ("camera moves: moving-camera
 * detector · …"), so a later warm-up message does not hide the choice.
 * @param {App} app
 * @param {string} msg
 */
export function choiceNote(app, msg) {
  const c = app.detectorChoice;
  return c ? `${c.why}: ${c.label} · ${msg}` : msg;
}

/**
 * What the learned stage gave a source so far (`App.learnedStats`): keyframes done and the
 * last one's ms, frames that took learned masks, masks replaced, regions added, whether a
 * keyframe runs, and why the stage stopped (null: it did not). Fresh for each source.
 */
export function emptyLearnedStats() {
  return { keyframes: 0, ms: 0, frames: 0, used: 0, added: 0, running: false, failed: /** @type {string | null} */ (null) };
}

/**
 * Counts what a frame took from the learned stage; says once why it stopped.
 * @param {App} app
 * @param {NonNullable<StepResult['learned']>} l
 */
export function learnedStep(app, l) {
  const s = app.learnedStats;
  s.keyframes = l.keyframes;
  s.ms = l.ms;
  s.running = l.running;
  if (l.use) {
    s.frames += 1;
    s.used += l.use.used;
    s.added += l.use.added;
  }
  if (l.failed && !s.failed) {
    s.failed = l.failed;
    app.status(`learned masks off for this video: ${l.failed}`, true);
  }
}
