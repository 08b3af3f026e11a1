import { test } from 'node:test';
import assert from 'node:assert/strict';
import { TrackTable } from '../src/model/tracks.js';
import { EditModel, EditError, frameRanges } from '../src/model/edits.js';

/** A record of track `id` in `frame` whose box encodes both, so moves are traceable. */
const rec = (frame, id) => ({ frame, id, bbox: { x: frame * 10, y: id, w: 5, h: 5 } });

/** Track id → sorted frames, the whole content of a table in a comparable form. */
function layout(table) {
  return Object.fromEntries(table.ids().map((id) => [id, table.track(id).map((r) => r.frame)]));
}

/** Boxes keep their origin: the x of a record says which frame it came from. */
function origin(table, frame, id) {
  return table.get(frame, id)?.bbox;
}

function model(spec) {
  const recs = [];
  for (const [id, frames] of Object.entries(spec)) for (const f of frames) recs.push(rec(f, Number(id)));
  return new EditModel(new TrackTable(recs));
}

test('table indexes by frame and id, and runs compress gaps', () => {
  const t = new TrackTable([rec(1, 2), rec(2, 2), rec(4, 2), rec(2, 5)]);
  assert.deepEqual(t.ids(), [2, 5]);
  assert.deepEqual(t.at(2).map((r) => r.id), [2, 5]);
  assert.deepEqual(t.runs(2), [[1, 2], [4, 4]]);
  t.add({ ...rec(3, 2), interpolated: true });
  assert.deepEqual(t.runs(2), [[1, 4]]);
  assert.deepEqual(t.spans(2), [[1, 2, false], [3, 3, true], [4, 4, false]]);
  t.remove(/** @type {any} */ (t.get(3, 2)));
  assert.deepEqual(t.span(2), [1, 4]);
  assert.equal(t.size, 4);
  assert.equal(t.lastFrame(), 4);
  assert.equal(t.firstFrame(), 1);
  t.remove(/** @type {any} */ (t.get(1, 2)));
  assert.equal(t.firstFrame(), 2);
  assert.equal(new TrackTable().firstFrame(), 0);
  t.add(rec(1, 2));
  assert.equal(t.maxId(), 5);
  assert.deepEqual(t.all().map((r) => [r.frame, r.id]), [[1, 2], [2, 2], [2, 5], [4, 2]]);
  // Replacing at the same place returns the old record; removing a stale object is a no-op.
  const old = t.get(2, 5);
  assert.equal(t.add(rec(2, 5)), old);
  assert.equal(t.remove(old), false);
  assert.equal(t.size, 4);
});

test('merge moves every record and undo/redo restore exactly', () => {
  const m = model({ 1: [1, 2, 3], 2: [5, 6] });
  const before = layout(m.table);
  m.merge(1, 2);
  assert.deepEqual(layout(m.table), { 1: [1, 2, 3, 5, 6] });
  assert.deepEqual(origin(m.table, 5, 1), { x: 50, y: 2, w: 5, h: 5 });
  assert.equal(m.undo(), 'merge 2 into 1');
  assert.deepEqual(layout(m.table), before);
  assert.equal(m.redo(), 'merge 2 into 1');
  assert.deepEqual(layout(m.table), { 1: [1, 2, 3, 5, 6] });
  assert.equal(m.redo(), null);
});

test('tracks both seen in one frame are two objects: the merge is refused, nothing is lost', () => {
  const m = model({ 1: [1, 2, 3, 4], 2: [3, 4, 6, 9, 10] });
  assert.throws(() => m.merge(1, 2), (e) => e instanceof EditError && /both seen in frames 3–4 \(2 frames\)/.test(e.message));
  assert.throws(() => m.reassign(2, 1), /tracks 1 and 2 are both seen in frames 3–4/, 'renumbering onto a track is a merge');
  assert.deepEqual(layout(m.table), { 1: [1, 2, 3, 4], 2: [3, 4, 6, 9, 10] });
  assert.equal(m.canUndo, false, 'a refused edit is not in the history');
  assert.equal(frameRanges([3]), '3');
  assert.equal(frameRanges([1, 2, 3, 5, 7, 8]), '1–3, 5, 7–8 (6 frames)');
  assert.equal(frameRanges([1, 3, 5, 7, 9]), '1, 3, 5, … (5 frames)');
});

test('a merge over filled-in shapes keeps what was seen', () => {
  const filled = (/** @type {number} */ f, /** @type {number} */ id) => ({ ...rec(f, id), interpolated: true });
  // 1 coasted through frames 3–4 while 2 was seen there; 2 was filled in at 6 where 1 was seen;
  // both were filled in at 7.
  const m = new EditModel(
    new TrackTable([rec(1, 1), rec(2, 1), filled(3, 1), filled(4, 1), rec(6, 1), filled(7, 1), rec(3, 2), rec(4, 2), filled(6, 2), filled(7, 2), rec(8, 2)]),
  );
  assert.deepEqual(m.merge(1, 2), { dropped: 4 });
  assert.deepEqual(layout(m.table), { 1: [1, 2, 3, 4, 6, 7, 8] });
  for (const f of [3, 4, 8]) assert.equal(origin(m.table, f, 1)?.y, 2, `frame ${f}: the seen shape of 2`);
  assert.equal(m.table.get(3, 1)?.interpolated, undefined);
  assert.equal(origin(m.table, 6, 1)?.y, 1, 'frame 6: the seen shape of 1');
  assert.equal(origin(m.table, 7, 1)?.y, 1, 'frame 7: both filled in, the kept track’s');
  m.undo();
  assert.deepEqual(layout(m.table), { 1: [1, 2, 3, 4, 6, 7], 2: [3, 4, 6, 7, 8] });
  assert.equal(m.table.get(3, 1)?.interpolated, true);
});

test('split gives the later part a fresh id above every id', () => {
  const m = model({ 1: [1, 2, 3, 4], 7: [1] });
  const fresh = m.split(1, 3);
  assert.equal(fresh, 8);
  assert.deepEqual(layout(m.table), { 1: [1, 2], 7: [1], 8: [3, 4] });
  assert.throws(() => m.split(1, 1), EditError);
  assert.throws(() => m.split(1, 9), EditError);
  m.undo();
  assert.deepEqual(layout(m.table), { 1: [1, 2, 3, 4], 7: [1] });
  // The undone id is handed out again: nothing refers to it any more.
  assert.equal(m.split(1, 2), 8);
});

test('swap exchanges identities from a frame on (an identity switch fix)', () => {
  const m = model({ 1: [1, 2, 3, 4], 2: [1, 2, 3, 4] });
  m.swap(1, 2, 3);
  assert.equal(m.table.get(3, 1)?.bbox.y, 2);
  assert.equal(m.table.get(4, 2)?.bbox.y, 1);
  assert.equal(m.table.get(2, 1)?.bbox.y, 1);
  m.undo();
  assert.equal(m.table.get(3, 1)?.bbox.y, 1);
});

test('reassign renumbers, or merges when the number is taken', () => {
  const m = model({ 1: [1, 2], 2: [4] });
  m.reassign(1, 10);
  assert.deepEqual(layout(m.table), { 2: [4], 10: [1, 2] });
  m.reassign(2, 10);
  assert.deepEqual(layout(m.table), { 10: [1, 2, 4] });
  assert.throws(() => m.reassign(10, 0), EditError);
  assert.throws(() => m.reassign(3, 4), /no track 3/);
  m.undo();
  m.undo();
  assert.deepEqual(layout(m.table), { 1: [1, 2], 2: [4] });
});

test('a renumbered track keeps its colour, through undo, redo and renumbering again', () => {
  const m = model({ 1: [1, 2], 2: [4], 3: [5] });
  m.reassign(1, 10);
  assert.equal(m.colourKey(10), 1, 'track 10 wears the colour it had as 1');
  m.reassign(10, 20);
  assert.equal(m.colourKey(20), 1);
  assert.equal(m.colourKey(10), 10, 'the number it left has no colour of its own left over');
  // Another track given the freed number wears its own colour, not the renumbered one's.
  m.reassign(3, 1);
  assert.equal(m.colourKey(1), 3);
  m.undo();
  assert.equal(m.colourKey(1), 1);
  assert.equal(m.colourKey(20), 1);
  m.undo();
  assert.equal(m.colourKey(10), 1);
  m.redo();
  assert.equal(m.colourKey(20), 1);
  // Merged into another track, it takes that track's colour: it is that object now.
  m.reassign(2, 20);
  assert.equal(m.colourKey(20), 1);
  m.reassign(20, 2);
  assert.equal(m.colourKey(2), 1);
  m.replaceAll([rec(1, 2)]);
  assert.equal(m.colourKey(2), 2, 'an import starts with every id its own colour');
});

test('delete a track and a single record, both undoable', () => {
  const m = model({ 1: [1, 2], 2: [1, 2] });
  m.deleteTrack(2);
  m.deleteRecord(2, 1);
  assert.deepEqual(layout(m.table), { 1: [1] });
  m.undo();
  m.undo();
  assert.deepEqual(layout(m.table), { 1: [1, 2], 2: [1, 2] });
  assert.equal(m.canUndo, false);
  assert.equal(m.canRedo, true);
});

test('a new edit drops the redo stack', () => {
  const m = model({ 1: [1], 2: [2], 3: [3] });
  m.merge(1, 2);
  m.undo();
  m.merge(1, 3);
  assert.equal(m.canRedo, false);
  assert.deepEqual(layout(m.table), { 1: [1, 3], 2: [2] });
});

test('edits keep holding for frames the tracker has not delivered yet', () => {
  const m = new EditModel();
  m.ingest([rec(1, 1), rec(1, 3)]);
  m.ingest([rec(2, 2), rec(2, 3)]);
  m.merge(1, 2); // 2 is 1 from now on
  m.deleteTrack(3); // 3 is a false track
  m.ingest([rec(3, 2), rec(3, 3), rec(3, 4)]);
  assert.deepEqual(layout(m.table), { 1: [1, 2, 3], 4: [3] });
  assert.equal(m.table.get(3, 1)?.bbox.y, 2);
  // Undo brings back the aliases too: tracker id 3 shows again from then on.
  m.undo();
  m.ingest([rec(4, 3)]);
  assert.deepEqual(m.table.track(3).map((r) => r.frame), [1, 2, 4]);
});

test('split during tracking: later tracker frames continue the new part', () => {
  const m = new EditModel();
  for (const f of [1, 2, 3]) m.ingest([rec(f, 1)]);
  const fresh = m.split(1, 3);
  m.ingest([rec(4, 1)]);
  assert.deepEqual(layout(m.table), { 1: [1, 2], [fresh]: [3, 4] });
});

test('a tracker id that collides with a labeller id is moved aside', () => {
  const m = new EditModel();
  for (const f of [1, 2, 3]) m.ingest([rec(f, 1)]);
  const fresh = m.split(1, 2); // fresh = 2
  assert.equal(fresh, 2);
  m.ingest([rec(4, 1), rec(4, 2)]); // the tracker now spawns its own track 2
  const t = layout(m.table);
  assert.deepEqual(t[1], [1]);
  assert.deepEqual(t[2], [2, 3, 4]);
  const other = Object.keys(t).map(Number).find((id) => id > 2);
  assert.ok(other, 'the tracker track 2 got a new id');
  assert.deepEqual(t[other], [4]);
  assert.equal(m.table.get(4, other)?.bbox.y, 2);
});

test('renumbering during tracking follows the tracker id; merged tracks seen together are kept apart', () => {
  const m = new EditModel();
  m.ingest([rec(1, 1)]);
  m.ingest([rec(2, 2)]);
  m.reassign(1, 9);
  m.merge(9, 2);
  assert.deepEqual(m.takeNotices(), []);
  // Both tracker tracks are seen in frame 3: two objects after all. No shape is hidden: the
  // second continues under a new id, the merge before frame 3 stands, and a notice says so.
  m.ingest([rec(3, 1), rec(3, 2)]);
  assert.deepEqual(layout(m.table), { 9: [1, 2, 3], 10: [3] });
  assert.equal(m.table.get(3, 9)?.bbox.y, 1);
  assert.equal(m.table.get(3, 10)?.bbox.y, 2);
  assert.deepEqual(m.takeNotices(), [{ frame: 3, id: 9, fresh: 10 }]);
  assert.deepEqual(m.takeNotices(), [], 'a notice is given once');
  m.ingest([rec(4, 1), rec(4, 2)]);
  assert.deepEqual(layout(m.table), { 9: [1, 2, 3, 4], 10: [3, 4] });
  assert.deepEqual(m.takeNotices(), []);
});

test('replaceAll (an import) starts afresh', () => {
  const m = new EditModel();
  m.ingest([rec(1, 1)]);
  m.ingest([rec(2, 2)]);
  m.merge(1, 2);
  m.replaceAll([rec(1, 1), rec(2, 2)]);
  assert.deepEqual(layout(m.table), { 1: [1], 2: [2] });
  assert.equal(m.canUndo, false);
  assert.equal(m.resolve(2), 2, 'old aliases are gone');
});

/** Tracker output: each track id over the given frames. */
function tracked(spec) {
  const recs = [];
  for (const [id, frames] of Object.entries(spec)) for (const f of frames) recs.push(rec(f, Number(id)));
  return recs.sort((a, b) => a.frame - b.frame);
}

/** Filled-in records of tracker id `id` (the joined identity's) in `frames`. */
const fill = (id, frames) => frames.map((f) => ({ ...rec(f, id), interpolated: true }));

test('the offline pass joins tracks and fills gaps as one undoable edit', () => {
  const m = new EditModel();
  m.ingest(tracked({ 1: [1, 2, 3], 2: [7, 8, 9], 3: [1, 2, 3, 4, 5, 6, 7, 8, 9] }));
  const online = layout(m.table);
  const out = m.relink({ joins: [{ slave: 1, master: 2, master_first: 7 }], filled: fill(1, [4, 5, 6]) });
  assert.deepEqual(out, { joined: 1, filled: 3 });
  assert.deepEqual(layout(m.table), { 1: [1, 2, 3, 4, 5, 6, 7, 8, 9], 3: [1, 2, 3, 4, 5, 6, 7, 8, 9] });
  assert.deepEqual(m.table.track(1).map((r) => !!r.interpolated), [false, false, false, true, true, true, false, false, false]);
  assert.deepEqual(origin(m.table, 8, 1), { x: 80, y: 2, w: 5, h: 5 }, 'the joined records are the tracker\'s');
  assert.equal(m.resolve(2), 1, 'later output of tracker 2 goes to 1');
  // Edits work on the joined identity, and undo takes them back one by one, then the pass.
  assert.equal(m.split(1, 5), 4);
  assert.deepEqual(layout(m.table), { 1: [1, 2, 3, 4], 3: [1, 2, 3, 4, 5, 6, 7, 8, 9], 4: [5, 6, 7, 8, 9] });
  assert.equal(m.undo(), 'split 1 at frame 5 as 4');
  assert.equal(m.undo(), 'offline pass: 1 join(s), 3 filled');
  assert.deepEqual(layout(m.table), online);
  assert.equal(m.resolve(2), 2);
  m.redo();
  assert.deepEqual(layout(m.table), { 1: [1, 2, 3, 4, 5, 6, 7, 8, 9], 3: [1, 2, 3, 4, 5, 6, 7, 8, 9] });
});

test('a join over a coasted tail keeps the observations', () => {
  const m = new EditModel();
  // Track 1 seen in 1–3, coasted (predicted, interpolated) in 4–6; track 2 seen from 5 on.
  m.ingest([...tracked({ 1: [1, 2, 3], 2: [5, 6, 7] }), ...fill(1, [4, 5, 6])].sort((a, b) => a.frame - b.frame));
  assert.deepEqual(m.relink({ joins: [{ slave: 1, master: 2, master_first: 5 }], filled: [] }), { joined: 1, filled: 0 });
  assert.deepEqual(layout(m.table), { 1: [1, 2, 3, 4, 5, 6, 7] });
  assert.deepEqual(m.table.track(1).map((r) => !!r.interpolated), [false, false, false, true, false, false, false]);
  m.undo();
  assert.deepEqual(layout(m.table), { 1: [1, 2, 3, 4, 5, 6], 2: [5, 6, 7] });
});

test('the offline pass follows chains and fills every gap of one', () => {
  const m = new EditModel();
  m.ingest(tracked({ 1: [1, 2], 2: [5, 6], 3: [9, 10] }));
  const joins = [
    { slave: 2, master: 3, master_first: 9 },
    { slave: 1, master: 2, master_first: 5 },
  ];
  assert.deepEqual(m.relink({ joins, filled: fill(1, [3, 4, 7, 8]) }), { joined: 2, filled: 4 });
  assert.deepEqual(layout(m.table), { 1: [1, 2, 3, 4, 5, 6, 7, 8, 9, 10] });
});

test('the labeller\'s edits win over the offline pass', () => {
  const m = new EditModel();
  m.ingest(tracked({ 1: [1, 2, 3], 2: [7, 8, 9], 4: [1, 2, 3], 5: [7, 8, 9], 6: [1, 2], 7: [6, 7] }));
  m.reassign(2, 20); // the labeller says 2 is its own object
  m.reassign(4, 40); // and names 4: its continuation joins it under that name
  m.deleteTrack(6); // a false track: nothing is joined to it
  const out = m.relink({
    joins: [
      { slave: 1, master: 2, master_first: 7 },
      { slave: 4, master: 5, master_first: 7 },
      { slave: 6, master: 7, master_first: 6 },
    ],
    filled: [...fill(1, [4, 5, 6]), ...fill(4, [4, 5, 6]), ...fill(6, [3, 4, 5])],
  });
  assert.deepEqual(out, { joined: 1, filled: 3 });
  assert.deepEqual(layout(m.table), { 1: [1, 2, 3], 7: [6, 7], 20: [7, 8, 9], 40: [1, 2, 3, 4, 5, 6, 7, 8, 9] });
  // A split track is the labeller's too.
  const s = new EditModel();
  s.ingest(tracked({ 1: [1, 2, 3], 2: [7, 8, 9, 10] }));
  const fresh = s.split(2, 9);
  assert.deepEqual(s.relink({ joins: [{ slave: 1, master: 2, master_first: 7 }], filled: fill(1, [4, 5, 6]) }), { joined: 0, filled: 0 });
  assert.deepEqual(layout(s.table), { 1: [1, 2, 3], 2: [7, 8], [fresh]: [9, 10] });
  assert.equal(s.undo(), `split 2 at frame 9 as ${fresh}`, 'a pass that changed nothing is not an edit');
});

test('the offline pass keeps a frame the labeller filled already', () => {
  const m = new EditModel();
  m.ingest(tracked({ 1: [1, 2, 3, 5], 2: [4] }));
  m.merge(1, 2); // the labeller bridged the gap by hand
  assert.deepEqual(m.relink({ joins: [], filled: fill(1, [4]) }), { joined: 0, filled: 0 });
  assert.equal(m.table.get(4, 1)?.bbox.y, 2);
});

test('listeners hear every change', () => {
  const m = model({ 1: [1], 2: [2] });
  let n = 0;
  const off = m.subscribe(() => n++);
  m.merge(1, 2);
  m.undo();
  m.redo();
  off();
  m.undo();
  assert.equal(n, 3);
});

test('one update may report earlier frames (a track confirmed late)', () => {
  const m = new EditModel();
  m.ingest([rec(1, 1)]);
  m.ingest([rec(2, 1)]);
  // Frame 3 confirms track 2 and reports its tentative frames 1 and 2 too.
  m.ingest([rec(3, 1), rec(1, 2), rec(2, 2), rec(3, 2)]);
  assert.deepEqual(layout(m.table), { 1: [1, 2, 3], 2: [1, 2, 3] });
});

test('unsaved: edits since the last save or replace; undoing back to the saved state is clean', () => {
  const m = model({ 1: [1, 2, 3], 2: [5, 6], 3: [8] });
  assert.equal(m.unsaved, false, 'a fresh table has nothing unsaved');
  m.merge(1, 2);
  assert.equal(m.unsaved, true);
  m.markSaved();
  assert.equal(m.unsaved, false, 'saved');
  m.merge(1, 3);
  assert.equal(m.unsaved, true, 'an edit after the save');
  m.undo();
  assert.equal(m.unsaved, false, 'undone back to the saved state');
  m.undo();
  assert.equal(m.unsaved, true, 'undone past the save: the table differs from what was saved');
  m.redo();
  assert.equal(m.unsaved, false);
  m.replaceAll([rec(1, 9)]);
  assert.equal(m.unsaved, false, 'a replaced table starts clean');
});
