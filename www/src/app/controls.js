// The page's controls and keys: buttons, menus, checkboxes, the stage's pointer and drop events,
// and the keyboard dispatch, each bound to an app method.

import { byId } from '../lib/dom.js';
import { listDetectors } from '../worker/detectors.js';
import { FORMATS } from '../io/formats.js';

/**
 * @typedef {import('../app.js').App} App
 * @typedef {import('../io/formats.js').FormatId} FormatId
 */

/** @param {App} app */
export function bindControls(app) {
  /** @param {string} id @param {() => unknown} fn */
  const click = (id, fn) =>
    byId(id).addEventListener('click', () => {
      Promise.resolve()
        .then(fn)
        .catch((e) => app.fail(e));
    });
  /** @param {string} id @param {(files: File[]) => unknown} fn */
  const files = (id, fn) => {
    const input = byId(id, HTMLInputElement);
    input.addEventListener('change', () => {
      const list = [...(input.files ?? [])];
      input.value = '';
      if (list.length)
        Promise.resolve()
          .then(() => fn(list))
          .catch((e) => app.fail(e));
    });
  };
  click('src-demo', () => app.openDemo());
  click('empty-demo', () => app.openDemo());
  click('src-video', () => byId('file-video').click());
  click('src-images', () => byId('file-images').click());
  // A folder pick (where the browser has one) opens a DAVIS or MOTChallenge folder in one go
  // and names the exports after it; a pick of numbered files can only call them `images`.
  if ('webkitdirectory' in HTMLInputElement.prototype) click('src-folder', () => byId('file-folder').click());
  else byId('src-folder').hidden = true;
  click('src-webcam', () => app.openWebcam());
  click('import', () => byId('file-import').click());
  click('load-gt', () => byId('file-gt').click());
  click('export', () => app.download(/** @type {FormatId} */ (byId('export-format', HTMLSelectElement).value)));
  files('file-video', (f) => app.openVideo(f[0]));
  files('file-images', (f) => app.openImages(f));
  files('file-folder', (f) => app.openImages(f));
  files('file-import', async (f) => app.importTracks(f[0].name, await f[0].text()));
  files('file-gt', async (f) => app.loadGroundTruth(f[0].name, await f[0].text()));
  click('play', () => app.togglePlay());
  click('fwd', () => app.stepForward());
  click('back', () => app.seek(app.cur - 1));
  click('first', () => app.seek(1));
  const scrub = byId('scrub', HTMLInputElement);
  scrub.addEventListener('input', () => void app.seek(Number(scrub.value)).catch((e) => app.fail(e)));

  const exportSel = byId('export-format', HTMLSelectElement);
  exportSel.replaceChildren(...FORMATS.map((f) => new Option(f.label, f.id)));
  const det = byId('detector', HTMLSelectElement);
  det.replaceChildren(...listDetectors().map((d) => new Option(d.label, d.name)));
  det.value = app.detector;
  const applyDetector = () => {
    Promise.resolve()
      .then(() => app.changeDetector(det.value, det.selectedOptions[0]?.text ?? det.value))
      .catch((e) => app.fail(e));
  };
  det.addEventListener('change', applyDetector);
  app.showObjectFilter();
  // The object filter applies from the next frame while tracking (the detector is set again,
  // its model kept), else to the next source; its shortest track is the tracker's setting,
  // which a running tracker keeps (changeDetector says so).
  for (const id of ['det-classes', 'det-score', 'det-frames']) byId(id, HTMLInputElement).addEventListener('change', applyDetector);
  const learned = byId('det-learned', HTMLInputElement);
  learned.addEventListener('change', () => {
    app.learnedPolicy = learned.checked ? 'keyframes' : 'off';
    if (app.session.phase !== 'tracking') return;
    app.worker.setLearned(app.learnedPolicy).catch((e) => app.fail(e));
  });
  const speed = byId('speed', HTMLSelectElement);
  speed.value = app.speed;
  speed.addEventListener('change', () => {
    app.speed = /** @type {'realtime' | 'max'} */ (speed.value);
  });
  const mode = byId('mode', HTMLSelectElement);
  mode.addEventListener('change', () => {
    app.mode = /** @type {'online' | 'offline'} */ (mode.value);
    app.renderTransport();
  });
  for (const k of /** @type {const} */ (['masks', 'boxes', 'trails', 'gt'])) {
    const box = byId(`opt-${k}`, HTMLInputElement);
    box.checked = app.options[k];
    box.addEventListener('change', () => {
      app.options[k] = box.checked;
      app.render();
    });
  }
  const overlay = byId('overlay', HTMLCanvasElement);
  overlay.addEventListener('pointerdown', (e) => {
    if (app.shapeTool.mode) {
      // A box drag keeps the pointer even when it leaves the canvas.
      overlay.setPointerCapture?.(e.pointerId);
      app.shapeTool.down(app.stage.toImage(e), app.stage.screenScale());
      return;
    }
    const p = app.stage.toImage(e);
    // Dragging the selected track's followed shape moves it (a corrected keyframe).
    if (!e.shiftKey && app.startMove(p)) {
      overlay.setPointerCapture?.(e.pointerId);
      return;
    }
    const id = app.stage.hit(app.model.table, app.cur, p);
    if (id === null) {
      if (!e.shiftKey) app.deselect();
    } else app.select(id, e.shiftKey);
  });
  overlay.addEventListener('pointermove', (e) => {
    const p = app.stage.toImage(e);
    if (app.moving) {
      app.moving.dx = p.x - app.moving.from.x;
      app.moving.dy = p.y - app.moving.from.y;
      app.render();
    } else app.shapeTool.move(p);
  });
  overlay.addEventListener('pointerup', (e) => {
    if (app.moving) void app.refusable(() => app.endMove());
    else app.shapeTool.up(app.stage.toImage(e));
  });
  overlay.addEventListener('dblclick', () => app.shapeTool.close());
  click('fol-box', () => app.useTool('box'));
  click('fol-poly', () => app.useTool('polygon'));
  click('fol-go', () => app.refusable(() => app.followSelected()));
  click('fol-cancel', () => app.cancelFollow());
  // Drop a video, images or an annotation file anywhere on the stage.
  const stage = byId('stage');
  stage.addEventListener('dragover', (e) => {
    e.preventDefault();
    stage.classList.add('drop');
  });
  stage.addEventListener('dragleave', () => stage.classList.remove('drop'));
  stage.addEventListener('drop', (e) => {
    e.preventDefault();
    stage.classList.remove('drop');
    const list = [...(e.dataTransfer?.files ?? [])];
    Promise.resolve()
      .then(() => app.openDropped(list))
      .catch((err) => app.fail(err));
  });
}

/**
 * Keyboard dispatch (see lib/keys.js for the table).
 * @param {App} app
 * @param {import('../lib/keys.js').Action} a
 */
export async function key(app, a) {
  switch (a) {
    case 'play':
      return app.togglePlay();
    case 'back':
      return app.seek(app.cur - 1);
    case 'fwd':
      return app.stepForward();
    case 'back10':
      return app.seek(app.cur - 10);
    case 'fwd10':
      return app.seek(app.cur + 10);
    case 'first':
      return app.seek(1);
    case 'last':
      return app.seek(app.lastShown);
    case 'merge':
    case 'swap':
    case 'split':
    case 'renumber':
    case 'delete':
    case 'deleteRecord':
    case 'undo':
    case 'redo':
      return app.action(a);
    case 'deselect':
      // Esc stops what is under way first: a follow, a shape being drawn, the drawing tool.
      if (app.following) return app.cancelFollow();
      if (app.shapeTool.drawing) return app.shapeTool.reset();
      if (app.shapeTool.mode) return app.useTool(null);
      return app.deselect();
    case 'follow':
      return app.refusable(() => app.followSelected());
    case 'drawBox':
      return app.useTool('box');
    case 'drawPolygon':
      return app.useTool('polygon');
    case 'closeShape':
      return app.shapeTool.close();
    case 'prevTrack':
      return app.cycleTrack(-1);
    case 'nextTrack':
      return app.cycleTrack(1);
    case 'masks':
    case 'boxes':
    case 'trails':
    case 'gt': {
      app.options[a] = !app.options[a];
      byId(`opt-${a}`, HTMLInputElement).checked = app.options[a];
      return app.render();
    }
    case 'demo':
      return app.openDemo();
    case 'open':
      return byId('file-video').click();
    case 'import':
      return byId('file-import').click();
    case 'export':
      return app.download(/** @type {FormatId} */ (byId('export-format', HTMLSelectElement).value));
    case 'help':
      return byId('help-dialog', HTMLDialogElement).showModal();
  }
}
