// Selection and edits: which tracks are selected, and the edit commands (merge, swap, split,
// renumber, delete, undo) run on them with refusals reported in the status line.

import { EditError } from '../model/edits.js';
import { runCommand, validSelection } from '../model/commands.js';

/**
 * @typedef {import('../app.js').App} App
 */

/**
 * @param {App} app
 * @param {number} id
 * @param {boolean} add shift: make it the second track of a pair
 */
export function select(app, id, add) {
  if (add && app.selection.a !== null && app.selection.a !== id) app.selection = { a: app.selection.a, b: id };
  else app.selection = { a: id, b: null };
  app.render();
}

/**
 * A selected track that no longer exists (merged away, deleted) is deselected.
 * @param {App} app
 */
export function validateSelection(app) {
  app.selection = validSelection((id) => app.model.table.has(id), app.selection);
}

/** @param {App} app */
export function deselect(app) {
  app.panel.cancelRenumber();
  app.selection = { a: null, b: null };
  app.render();
}

/**
 * @param {App} app
 * @param {number} dir
 */
export function cycleTrack(app, dir) {
  const ids = app.model.table.at(app.cur).map((r) => r.id);
  const pool = ids.length ? ids : app.model.table.ids();
  if (!pool.length) return;
  const i = app.selection.a === null ? -1 : pool.indexOf(app.selection.a);
  const j = i < 0 ? (dir > 0 ? 0 : pool.length - 1) : (i + dir + pool.length) % pool.length;
  app.select(pool[j], false);
}

/**
 * Runs an edit command (model/commands.js), reporting a refusal in the status line instead
 * of throwing. The status line then says what was done, so it never shows a message about
 * an earlier state.
 * @param {App} app
 * @param {() => import('../model/commands.js').Outcome} fn
 */
export function edit(app, fn) {
  try {
    const { selection, note, lastEdit } = fn();
    app.selection = selection;
    app.validateSelection();
    app.lastEdit = lastEdit;
    app.status(note);
    app.render();
    return true;
  } catch (e) {
    if (e instanceof EditError) {
      app.status(e.message, true);
      return false;
    }
    throw e;
  }
}

/**
 * @param {App} app
 * @param {import('../model/commands.js').Command | 'renumber'} a
 */
export function action(app, a) {
  if (a !== 'renumber') {
    app.edit(() => runCommand(app.model, a, { selection: app.selection, frame: app.cur }));
  } else if (app.selection.a !== null) {
    app.panel.askRenumber(app.model.nextId);
  } else {
    app.status('select a track first', true);
  }
}

/**
 * Whether `what` (opening a source, the demo, an import) may replace the track table: yes when
 * it holds no edits made since the last export; otherwise the person is asked first (a
 * replace clears the undo history, so it could not be taken back). Says so in the status line
 * when they keep their work.
 * @param {App} app
 * @param {string} what e.g. "Opening clip.mp4"
 * @returns {boolean}
 */
export function mayReplace(app, what) {
  if (!app.model.unsaved) return true;
  const n = app.model.undoStack.length;
  const ok = window.confirm(`${what} replaces the tracks, with ${n} edit${n === 1 ? '' : 's'} not exported yet (this cannot be undone). Replace them?`);
  if (!ok) app.status('kept your tracks and edits: export them first, or confirm to replace them');
  return ok;
}
