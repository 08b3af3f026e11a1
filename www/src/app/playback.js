// The transport: play, stop, step and seek through the frames, tracking on past the last
// tracked one (see tracking.js) and having the worker paint the frame shown.

import { byId } from '../lib/dom.js';

/**
 * @typedef {import('../app.js').App} App
 */

/** @param {App} app */
export async function togglePlay(app) {
  if (app.playing) await app.stop();
  else app.play();
}

/** @param {App} app */
export function play(app) {
  if (app.playing || !app.source) return;
  app.playing = true;
  app.renderTransport();
  app.loop = app.run()
    .catch((e) => app.fail(e))
    .finally(() => {
      app.playing = false;
      app.loop = null;
      byId('progress', HTMLProgressElement).hidden = true;
      app.render();
    });
}

/** @param {App} app */
export async function stop(app) {
  app.playing = false;
  if (app.loop) await app.loop;
}

/**
 * The play loop: replays what is tracked, tracks what is not, in the chosen mode.
 * @param {App} app
 */
export async function run(app) {
  const session = app.session;
  if (app.mode === 'offline' && session.offlinePending) {
    if (session.offlineCapable) {
      await app.runOffline();
      return;
    }
    app.status('offline mode needs a video or image sequence with an end: tracking online');
  }
  const t0 = performance.now();
  const f0 = app.cur;
  let tracked = false;
  while (app.playing) {
    const next = app.cur + 1;
    if (session.frames && next > session.frames) break;
    if (!session.needsTracking(next)) {
      await app.show(next);
    } else {
      tracked = true;
      await app.track({ until: session.frames || Infinity, display: 'every' });
      if (app.source?.kind !== 'webcam') break;
    }
    if (app.speed === 'realtime') await app.pace(t0, app.cur - f0);
  }
  // Played through to the end: say it is done (and what there is), or the last frame's
  // message would stay as if more were coming.
  if (tracked && app.playing && session.frames && app.cur >= session.frames && app.mode === 'online') {
    const n = app.model.table.ids().length;
    app.status(`done: ${session.frames} frames tracked, ${n} track${n === 1 ? '' : 's'} — export them (E), or fix them first`);
  }
}

/**
 * Waits until `n` frames after `t0` are due at the source's frame rate.
 * @param {App} app
 * @param {number} t0
 * @param {number} n
 */
export async function pace(app, t0, n) {
  const fps = app.source?.fps || 25;
  const wait = t0 + (n * 1000) / fps - performance.now();
  if (wait > 1) await new Promise((r) => setTimeout(r, wait));
}

/**
 * Tracks the next frame if it is new, else shows it.
 * @param {App} app
 */
export async function stepForward(app) {
  if (!app.source) return;
  const next = app.cur + 1;
  if (app.session.frames && next > app.session.frames) return;
  if (app.session.needsTracking(next)) {
    app.playing = true;
    try {
      await app.track({ until: next, display: 'every' });
    } finally {
      app.playing = false;
      app.render();
    }
  } else {
    await app.show(next);
  }
}

/**
 * Shows frame `n`, clamped to the frames that can be shown (`lastShown`).
 * @param {App} app
 * @param {number} n
 */
export async function seek(app, n) {
  const target = Math.max(1, Math.min(app.lastShown || 1, Math.round(n)));
  await app.show(target);
}

/**
 * Displays frame `n` with its overlay (no tracking).
 * @param {App} app
 * @param {number} n
 */
export async function show(app, n) {
  app.cur = n;
  // Scrubbing fires faster than frames can be fetched: one fetch at a time, the newest
  // wanted frame next (frames skipped in between are never fetched).
  if (app.showing) {
    app.render();
    return app.showing;
  }
  app.showing = (async () => {
    let done = 0;
    while (done !== app.cur) {
      done = app.cur;
      await app.paintFrame(done);
      app.render();
    }
  })();
  try {
    await app.showing;
  } finally {
    app.showing = null;
  }
}

/**
 * Has the worker paint frame `n` of the source (a blank frame without a source or pixels).
 * @param {App} app
 * @param {number} n
 */
export async function paintFrame(app, n) {
  const src = app.source;
  const { width, height } = app.stage;
  if (src?.kind === 'synth') {
    await app.worker.render(n);
    return;
  }
  let bitmap = null;
  if (src) {
    const grabbed = app.grabChain.then(() => src.frameAt(n));
    app.grabChain = grabbed.then(
      () => undefined,
      () => undefined,
    );
    bitmap = await grabbed;
  }
  await app.worker.paint(width, height, bitmap);
}
