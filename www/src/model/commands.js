// The edit commands a labeller gives (merge, swap, split, delete, undo, …) as plain functions of
// the edit model, the selection and the current frame. Each returns the selection after it and
// what the status line should say; a refusal throws `EditError` with the reason. The app only
// routes keys and buttons here and shows the result, so every command's rules — what it needs
// selected, what it selects afterwards, what it reports — are tested under node.

import { EditError } from './edits.js';

/**
 * @typedef {import('./edits.js').EditModel} EditModel
 * @typedef {{ a: number | null, b: number | null }} Selection
 * @typedef {'merge' | 'swap' | 'split' | 'delete' | 'deleteRecord' | 'undo' | 'redo'} Command
 * @typedef {{ selection: Selection, note: string, lastEdit: string }} Outcome
 *   `note` for the status line; `lastEdit` for the undo bar (the edit's label, or what undo did)
 */

/** @param {number | null} id */
function need(id) {
  if (id === null) throw new EditError('select a track first');
  return id;
}

/**
 * Runs one command. Edits that succeed are on the model's undo stack; `note` is the edit's own
 * label unless the command has something more specific to say.
 * @param {EditModel} model
 * @param {Command} command
 * @param {{ selection: Selection, frame: number }} at
 * @returns {Outcome}
 */
export function runCommand(model, command, { selection, frame }) {
  const { a: x, b: y } = selection;
  const label = () => model.undoStack.at(-1)?.label ?? '';
  switch (command) {
    case 'merge': {
      if (y === null) throw new EditError('shift-click a second track to merge into the first');
      const { dropped } = model.merge(need(x), y);
      const note = dropped ? `merge ${y} into ${x}: ${dropped} filled-in shape(s) gave way to seen ones` : label();
      return { selection: { a: x, b: null }, note, lastEdit: label() };
    }
    case 'swap':
      if (y === null) throw new EditError('shift-click a second track to swap with');
      model.swap(need(x), y, frame);
      return { selection, note: label(), lastEdit: label() };
    case 'split': {
      const fresh = model.split(need(x), frame);
      return { selection: { a: fresh, b: null }, note: label(), lastEdit: label() };
    }
    case 'delete':
      model.deleteTrack(need(x));
      return { selection: { a: y, b: null }, note: label(), lastEdit: label() };
    case 'deleteRecord':
      model.deleteRecord(frame, need(x));
      return { selection, note: label(), lastEdit: label() };
    case 'undo': {
      const l = model.undo();
      return { selection, note: l ? `undid: ${l}` : 'nothing to undo', lastEdit: l ? `undid: ${l}` : '' };
    }
    case 'redo': {
      const l = model.redo();
      return { selection, note: l ? `redid: ${l}` : 'nothing to redo', lastEdit: l ? `redid: ${l}` : '' };
    }
  }
}

/**
 * Renumbers the selected track; it stays selected under its new id.
 * @param {EditModel} model
 * @param {Selection} selection
 * @param {number} to
 * @returns {Outcome}
 */
export function renumber(model, selection, to) {
  model.reassign(need(selection.a), to);
  const label = model.undoStack.at(-1)?.label ?? '';
  return { selection: { a: to, b: null }, note: label, lastEdit: label };
}

/**
 * The selection after the table changed: a selected track that no longer exists (merged away,
 * deleted, undone) is dropped, and the second takes the first's place.
 * @param {(id: number) => boolean} has
 * @param {Selection} s
 * @returns {Selection}
 */
export function validSelection(has, s) {
  const ok = (/** @type {number | null} */ id) => id !== null && has(id);
  const b = ok(s.b) ? s.b : null;
  return ok(s.a) ? { a: s.a, b } : { a: b, b: null };
}
