// The edit commands (model/commands.js): what each needs selected, what it selects after, what
// the status line and the undo bar say, and that a refusal changes nothing.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { TrackTable } from '../src/model/tracks.js';
import { EditModel, EditError } from '../src/model/edits.js';
import { runCommand, renumber, validSelection } from '../src/model/commands.js';

const rec = (frame, id) => ({ frame, id, bbox: { x: frame * 10, y: id, w: 5, h: 5 } });

/** Track 1 on frames 1–3, track 2 on frames 5–6, track 3 on frames 1–6. */
function model() {
  const recs = [];
  for (const f of [1, 2, 3]) recs.push(rec(f, 1));
  for (const f of [5, 6]) recs.push(rec(f, 2));
  for (const f of [1, 2, 3, 4, 5, 6]) recs.push(rec(f, 3));
  return new EditModel(new TrackTable(recs));
}

const layout = (m) => Object.fromEntries(m.table.ids().map((id) => [id, m.table.track(id).map((r) => r.frame)]));

test('merge keeps the first selected, drops the second from the selection, and undo restores both', () => {
  const m = model();
  const out = runCommand(m, 'merge', { selection: { a: 1, b: 2 }, frame: 1 });
  assert.deepEqual(out.selection, { a: 1, b: null });
  assert.deepEqual(layout(m)[1], [1, 2, 3, 5, 6]);
  assert.ok(out.note.length > 0 && out.note === out.lastEdit, 'the status says what was done');
  const undo = runCommand(m, 'undo', { selection: out.selection, frame: 1 });
  assert.match(undo.note, /^undid: /);
  assert.equal(undo.lastEdit, undo.note);
  assert.deepEqual(layout(m), layout(model()));
  const redo = runCommand(m, 'redo', { selection: out.selection, frame: 1 });
  assert.match(redo.note, /^redid: /);
  assert.deepEqual(layout(m)[1], [1, 2, 3, 5, 6]);
});

test('commands that need a selection refuse without one, and change nothing', () => {
  const m = model();
  const before = layout(m);
  for (const c of /** @type {const} */ (['merge', 'swap', 'split', 'delete', 'deleteRecord'])) {
    assert.throws(() => runCommand(m, c, { selection: { a: null, b: null }, frame: 2 }), EditError, c);
  }
  assert.throws(() => runCommand(m, 'merge', { selection: { a: 1, b: null }, frame: 2 }), /shift-click a second track to merge/);
  assert.throws(() => runCommand(m, 'swap', { selection: { a: 1, b: null }, frame: 2 }), /shift-click a second track to swap/);
  assert.throws(() => renumber(m, { a: null, b: null }, 9), /select a track first/);
  assert.deepEqual(layout(m), before);
  assert.equal(m.canUndo, false, 'no refusal lands on the undo stack');
});

test('merging two tracks seen in the same frame is refused with the frames named', () => {
  const m = model();
  assert.throws(() => runCommand(m, 'merge', { selection: { a: 1, b: 3 }, frame: 1 }), EditError);
  assert.deepEqual(layout(m), layout(model()));
});

test('split selects the new later part; delete selects the second track, if any', () => {
  const m = model();
  const split = runCommand(m, 'split', { selection: { a: 3, b: null }, frame: 4 });
  const fresh = /** @type {number} */ (split.selection.a);
  assert.ok(fresh > 3);
  assert.deepEqual(layout(m)[fresh], [4, 5, 6]);
  assert.deepEqual(layout(m)[3], [1, 2, 3]);
  const del = runCommand(m, 'delete', { selection: { a: 1, b: 2 }, frame: 1 });
  assert.deepEqual(del.selection, { a: 2, b: null });
  assert.equal(m.table.has(1), false);
  const one = runCommand(m, 'deleteRecord', { selection: { a: 2, b: null }, frame: 5 });
  assert.deepEqual(one.selection, { a: 2, b: null });
  assert.deepEqual(layout(m)[2], [6]);
});

test('swap exchanges the ids from the current frame on and keeps both selected', () => {
  const m = model();
  const out = runCommand(m, 'swap', { selection: { a: 2, b: 3 }, frame: 5 });
  assert.deepEqual(out.selection, { a: 2, b: 3 });
  assert.deepEqual(layout(m)[3], [1, 2, 3, 4, 5, 6]);
  assert.deepEqual(layout(m)[2], [5, 6]);
  assert.equal(m.table.get(5, 2)?.bbox.y, 3, 'track 2 now wears track 3\'s boxes from frame 5');
});

test('renumber keeps the track selected under its new id; undo with nothing to undo says so', () => {
  const m = model();
  const out = renumber(m, { a: 2, b: 1 }, 40);
  assert.deepEqual(out.selection, { a: 40, b: null });
  assert.deepEqual(layout(m)[40], [5, 6]);
  const fresh = model();
  assert.deepEqual(runCommand(fresh, 'undo', { selection: { a: null, b: null }, frame: 1 }).note, 'nothing to undo');
  assert.equal(runCommand(fresh, 'redo', { selection: { a: null, b: null }, frame: 1 }).lastEdit, '');
});

test('a selection loses tracks that are gone, the second taking the first\'s place', () => {
  const has = (/** @type {number} */ id) => id === 2 || id === 3;
  assert.deepEqual(validSelection(has, { a: 2, b: 3 }), { a: 2, b: 3 });
  assert.deepEqual(validSelection(has, { a: 1, b: 3 }), { a: 3, b: null });
  assert.deepEqual(validSelection(has, { a: 2, b: 9 }), { a: 2, b: null });
  assert.deepEqual(validSelection(has, { a: 7, b: 9 }), { a: null, b: null });
});
