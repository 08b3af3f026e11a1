// Drawing the views from state (stage overlay, timeline, panel, transport), once per display
// frame at most, and the status line.

import { byId } from '../lib/dom.js';

/**
 * @typedef {import('../app.js').App} App
 */

/**
 * Asks for a redraw. State changes call this freely: the views are drawn once per display
 * frame at most, so tracking faster than the screen refreshes costs no extra drawing.
 * @param {App} app
 */
export function render(app) {
  if (!app.raf) app.raf = requestAnimationFrame(() => app.renderNow());
}

/** @param {App} app */
export function renderNow(app) {
  app.raf = 0;
  const t0 = performance.now();
  const table = app.model.table;
  // While playing, the timeline's bars and the track list (whose contents change every
  // frame) refresh a few times a second; the overlay and playhead every frame.
  const busy = app.playing;
  app.stage.drawOverlay({ table, gt: app.gt, frame: app.cur, selection: app.selection, options: app.options, labels: app.labels });
  app.stage.drawTool(app.shapeTool);
  const mv = app.moving;
  const moved = mv && table.get(app.cur, mv.id);
  if (mv && moved) {
    // The dragged shape's box where it would land.
    const b = moved.bbox;
    app.stage.drawTool({
      draw(ctx, lw) {
        ctx.save();
        ctx.strokeStyle = '#ffffff';
        ctx.lineWidth = lw;
        ctx.setLineDash([lw * 4, lw * 3]);
        ctx.strokeRect(b.x + mv.dx, b.y + mv.dy, b.w, b.h);
        ctx.restore();
      },
    });
  }
  app.timeline.render({ table, frames: app.lastFrame, frame: app.cur, selection: app.selection, busy });
  app.panel.render({
    table,
    selection: app.selection,
    frame: app.cur,
    canUndo: app.model.canUndo,
    canRedo: app.model.canRedo,
    lastEdit: app.lastEdit,
    busy,
  });
  app.renderTransport();
  app.renderMs = 0.9 * app.renderMs + 0.1 * (performance.now() - t0);
}

/** @param {App} app */
export function renderTransport(app) {
  const scrub = byId('scrub', HTMLInputElement);
  scrub.max = String(Math.max(1, app.lastFrame));
  scrub.value = String(Math.max(1, app.cur));
  const total = app.session.frames ? `/${app.session.frames}` : '';
  byId('frame-no').textContent = app.cur ? `${app.cur}${total}` : '–';
  const fps = app.fps.fps;
  byId('fps').textContent = fps ? `${fps.toFixed(1)} fps` : '– fps';
  byId('fps').title = `per frame: detect ${app.lastTimings.detect.toFixed(1)} ms, track ${app.lastTimings.track.toFixed(1)} ms (worker), draw ${app.renderMs.toFixed(1)} ms (page)`;
  const play = byId('play');
  play.classList.toggle('playing', app.playing);
  play.classList.toggle('run', !app.playing && app.mode === 'offline' && app.session.offlinePending);
}

/**
 * @param {App} app
 * @param {string} msg
 * @param {boolean} [error]
 */
export function status(app, msg, error = false) {
  const el = byId('status');
  el.textContent = msg;
  el.title = msg;
  el.classList.toggle('error', error);
}

/**
 * @param {App} app
 * @param {unknown} e
 */
export function fail(app, e) {
  const msg = e instanceof Error ? e.message : String(e);
  console.error(e);
  app.status(msg, true);
}
