// Entry point: loads the wasm core, builds the app, binds the keyboard, registers the service
// worker (production builds), and exposes a read-only view of the state for the end-to-end tests
// (`window.__shapetrack`).
//
// URL parameters: `?demo=0` does not start the demo on load; `?speed=max` tracks as fast as
// possible instead of at the source's frame rate; `?mode=offline`; `?scene=occlusion` (or
// `default`) opens another synthetic scene as the demo; `?preset=default` (or `masks`) chooses
// the tracker's settings preset over the detector's choice.

import { loadCore } from './lib/core.js';
import { App } from './app.js';
import { actionFor, numberFieldIgnores, SHORTCUTS } from './lib/keys.js';
import { byId, h } from './lib/dom.js';

/** @param {Event} e */
function typing(e) {
  const t = /** @type {HTMLElement | null} */ (e.target);
  return !!t && (t.tagName === 'INPUT' || t.tagName === 'SELECT' || t.tagName === 'TEXTAREA' || t.isContentEditable);
}

async function main() {
  const { core } = await loadCore();
  const app = new App(core);
  // Closing or reloading the tab with edits not exported asks first: they live only here.
  addEventListener('beforeunload', (e) => {
    if (app.model.unsaved) e.preventDefault();
  });
  const params = new URLSearchParams(location.search);
  if (params.get('speed') === 'max') {
    app.speed = 'max';
    byId('speed', HTMLSelectElement).value = 'max';
  }
  const scene = params.get('scene');
  if (scene === 'demo' || scene === 'default' || scene === 'occlusion') app.scene = scene;
  const preset = params.get('preset');
  if (preset === 'default' || preset === 'masks') app.tracker = { preset };
  const offline = params.get('offline');
  if (offline) {
    // Settings the core rejects fail the open with its message; JSON that does not parse
    // fails here, with where.
    try {
      app.offlineSettings = JSON.parse(offline);
    } catch (e) {
      app.fail(new Error(`?offline= is not JSON: ${e instanceof Error ? e.message : e}`));
    }
  }
  if (params.get('learned') === 'keyframes') {
    app.learnedPolicy = 'keyframes';
    byId('det-learned', HTMLInputElement).checked = true;
  }
  if (params.get('mode') === 'offline') {
    app.mode = 'offline';
    byId('mode', HTMLSelectElement).value = 'offline';
  }

  document.addEventListener('keydown', (e) => {
    // An open dialog owns the keyboard: its own Esc closes it (so no preventDefault here), and
    // no shortcut reaches the player behind it.
    if (document.querySelector('dialog[open]')) return;
    const t = /** @type {HTMLElement | null} */ (e.target);
    if (typing(e)) {
      if (e.key === 'Escape' && t?.id === 'renumber-input') {
        // Esc in the new-id field gives up the renumbering, not the selection.
        e.preventDefault();
        app.panel.cancelRenumber();
        t.blur();
        return;
      }
      // (The new-id field is left by Enter or Esc only: a stray letter there is no command.)
      const numberField = t instanceof HTMLInputElement && t.type === 'number' && t.id !== 'renumber-input';
      if (e.key !== 'Escape' && !(numberField && numberFieldIgnores(e))) return;
      t?.blur();
    }
    // Enter on a focused button or link activates it, as usual; elsewhere it closes a polygon.
    if (e.key === 'Enter' && t?.closest?.('button, a, summary')) return;
    const a = actionFor(e);
    if (!a) return;
    e.preventDefault();
    Promise.resolve(app.key(a)).catch((err) => app.fail(err));
  });
  byId('help').addEventListener('click', () => void app.key('help'));
  byId('legend-open').addEventListener('click', () => {
    void app.key('help');
    byId('legend').scrollIntoView({ block: 'nearest' });
  });
  byId('help-table').replaceChildren(...SHORTCUTS.map((s) => h('tr', {}, [h('td', {}, [h('kbd', {}, [s.keys])]), h('td', {}, [s.what])])));

  exposeForTests(app);

  if (import.meta.env.PROD && 'serviceWorker' in navigator) {
    navigator.serviceWorker.register('./sw.js').catch((e) => console.warn('service worker not registered:', e));
  }

  if (params.get('demo') !== '0') {
    await app.openDemo();
    app.play();
  }
}

/**
 * What the end-to-end tests read and drive. Tests assert on this state (ids per frame, fps),
 * not only on pixels.
 * @param {App} app
 */
function exposeForTests(app) {
  const api = {
    app,
    /** A summary of the state, safe to serialise. */
    state: () => ({
      source: app.source ? { kind: app.source.kind, name: app.source.name, width: app.source.width, height: app.source.height } : null,
      size: [app.stage.width, app.stage.height],
      frame: app.cur,
      phase: app.session.phase,
      processed: app.session.processed,
      frames: app.session.frames,
      playing: app.playing,
      finished: app.session.phase === 'finished',
      offline: app.session.report,
      fps: app.fps.fps,
      timings: app.lastTimings,
      detections: app.lastDetections,
      drawMs: app.renderMs,
      ids: app.model.table.ids(),
      selection: app.selection,
      scores: app.scores,
      canUndo: app.model.canUndo,
      following: app.following !== null,
      tool: app.shapeTool.mode,
      status: byId('status').textContent,
      detector: app.detector,
      detectorChoice: app.detectorChoice?.name ?? null,
      boxMask: app.lastBoxMask,
      learned: app.learnedStats,
    }),
    /** Every record as the table holds it (frame, id, bbox, ...). */
    records: () => app.model.table.all(),
    groundTruth: () => app.gt?.all() ?? [],
    /** What the tracker in the worker reported, for checking the page lost nothing. */
    trackerRecords: () => app.worker.request({ type: 'tracks' }).then((r) => /** @type {any} */ (r).records),
    /**
     * A client of the app's segmenter worker (issue 63), spawned from this page, for the e2e
     * test and scripts/bench-segmenter.mjs (the app itself will run it from the tracker worker).
     * Loaded on call: its code and files are not part of the page's start.
     * @param {{ threads?: number, backend?: 'auto' | 'wasm' | 'webgpu' }} [opts]
     */
    segmenter: async (opts) => new (await import('./worker/segmenter/client.js')).SegmenterClient(opts),
  };
  /** @type {any} */ (window).__shapetrack = api;
  window.dispatchEvent(new Event('shapetrack-ready'));
}

main().catch((e) => {
  console.error(e);
  const el = document.getElementById('status');
  if (el) {
    el.textContent = `failed to start: ${e instanceof Error ? e.message : e}`;
    el.classList.add('error');
  }
});
