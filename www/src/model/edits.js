// Identity edits over the track table, with undo/redo.
//
// A labeller fixes a tracker's few identity mistakes: two fragments of one object (merge), an
// identity switch between two objects (swap from a frame on), one track that covers two objects
// (split), a track that is not an object at all (delete), or a wrong number (reassign). Every
// edit is a patch — records removed, records added, id aliases before and after — so undo and
// redo are exact and cost only the records an edit touched.
//
// Tracking can still be running while the labeller edits (online mode). The alias map makes an
// edit hold for frames that have not arrived yet: after "merge 7 into 3", whatever the tracker
// still calls 7 is shown and exported as 3; after "delete 9", the tracker's 9 stays hidden.
// Ids a labeller creates (split) are taken from above every id seen so far, and tracker ids
// that later collide with them are moved aside, so two objects never share an id.

import { TrackTable } from './tracks.js';

/** @typedef {import('./tracks.js').TrackRecord} TrackRecord */

/**
 * @typedef {{
 *   label: string,
 *   removed: TrackRecord[],
 *   added: TrackRecord[],
 *   aliasesBefore: Map<number, number | null>,
 *   aliasesAfter: Map<number, number | null>,
 *   nextIdBefore: number,
 *   nextIdAfter: number,
 *   coloursBefore: Map<number, number>,
 *   coloursAfter: Map<number, number>,
 * }} Patch
 */

/** An edit that cannot be done as asked (unknown id, frame outside the track, ...). */
export class EditError extends Error {
  /** @param {string} message */
  constructor(message) {
    super(message);
    this.name = 'EditError';
  }
}

/**
 * @param {TrackRecord} r
 * @param {number} id
 * @returns {TrackRecord}
 */
const withId = (r, id) => ({ ...r, id });

/**
 * Ascending frame numbers as short text for a message: `3–7, 9, 12–40 (13 frames)`; past four
 * runs, the first three and "…".
 * @param {number[]} frames ascending
 */
export function frameRanges(frames) {
  /** @type {string[]} */
  const parts = [];
  for (let i = 0; i < frames.length; ) {
    let k = i;
    while (k + 1 < frames.length && frames[k + 1] === frames[k] + 1) k++;
    parts.push(k > i ? `${frames[i]}–${frames[k]}` : String(frames[i]));
    i = k + 1;
  }
  const shown = parts.length > 4 ? [...parts.slice(0, 3), '…'] : parts;
  return `${shown.join(', ')}${frames.length > 1 ? ` (${frames.length} frames)` : ''}`;
}

export class EditModel {
  /** @param {TrackTable} [table] */
  constructor(table = new TrackTable()) {
    this.table = table;
    /**
     * Tracker id → shown id (null: deleted). One step, never a chain: every edit rewrites the
     * targets, so resolving is a single lookup.
     * @type {Map<number, number | null>}
     */
    this.aliases = new Map();
    /** @type {Set<number>} tracker ids already ingested (they own their own number) */
    this.trackerIds = new Set();
    /** @type {Set<number>} ids a labeller created (split), which the tracker must not reuse */
    this.labellerIds = new Set();
    /** Above every id seen so far: what the next labeller-made track gets. */
    this.nextId = table.maxId() + 1;
    /**
     * Shown id → the id whose colour it wears, for tracks that were renumbered (absent: its
     * own). A track's colour is how a labeller follows it; a new number must not change it.
     * @type {Map<number, number>}
     */
    this.colours = new Map();
    /** @type {Patch[]} */
    this.undoStack = [];
    /** @type {Patch[]} */
    this.redoStack = [];
    /**
     * The undo stack's top when the work was last saved (exported) or replaced: the table
     * holds unsaved edits while the top differs (undoing back to it makes it clean again).
     * @type {Patch | null}
     */
    this.savedTop = null;
    /** @type {Set<() => void>} */
    this.listeners = new Set();
    /**
     * Tracker tracks that `ingest` had to keep apart (see there), for the app to say so.
     * @type {Array<{ frame: number, id: number, fresh: number }>}
     */
    this.notices = [];
  }

  /** The notices since the last call (see {@link EditModel#notices}). */
  takeNotices() {
    return this.notices.splice(0);
  }

  /**
   * @param {() => void} fn called after every change
   * @returns {() => void} unsubscribes
   */
  subscribe(fn) {
    this.listeners.add(fn);
    return () => {
      this.listeners.delete(fn);
    };
  }

  emit() {
    for (const fn of this.listeners) fn();
  }

  /**
   * The id a tracker id is shown under, null when its track was deleted.
   * @param {number} trackerId
   * @returns {number | null}
   */
  resolve(trackerId) {
    const a = this.aliases.get(trackerId);
    return a === undefined ? trackerId : a;
  }

  /**
   * The id whose colour track `id` is drawn in (its own unless it was renumbered).
   * @param {number} id
   * @returns {number}
   */
  colourKey(id) {
    return this.colours.get(id) ?? id;
  }

  /**
   * Whether a tracker id seen for the first time would collide with an id already in use
   * (a labeller's split, a renumbering, an imported track).
   * @param {number} id
   */
  taken(id) {
    if (this.labellerIds.has(id) || this.table.has(id)) return true;
    for (const v of this.aliases.values()) if (v === id) return true;
    return false;
  }

  /**
   * Adds tracker output. Not an edit: it does not enter the undo history, but it goes through
   * the aliases so past edits keep holding. One update may report several frames (a track
   * confirmed now also reports its tentative frames), so records carry their own frame.
   * @param {TrackRecord[]} records
   */
  ingest(records) {
    for (const r of records) {
      const frame = r.frame;
      if (!this.trackerIds.has(r.id)) {
        this.trackerIds.add(r.id);
        if (!this.aliases.has(r.id) && this.taken(r.id)) this.aliases.set(r.id, this.nextId++);
      }
      const id = this.resolve(r.id);
      if (id === null) continue;
      const there = this.table.get(frame, id);
      // The labeller followed this track through this frame (model/follow.js): the shape they
      // asked for stands, the tracker's later view of the same track does not replace it.
      if (there?.source === 'follow') continue;
      if (there) {
        // Two tracker tracks the labeller declared one object (a merge of fragments, a
        // renumbering onto another's id) are both seen in this frame: they are two objects
        // after all. Hiding one would lose a label without a word, so this one continues
        // under a new id from here on (not an edit: the merge before this frame stands), and
        // the app says so.
        const fresh = this.nextId++;
        this.aliases.set(r.id, fresh);
        this.table.add(withId(r, fresh));
        this.notices.push({ frame, id, fresh });
        continue;
      }
      this.table.add(id === r.id ? r : withId(r, id));
      if (id >= this.nextId) this.nextId = id + 1;
    }
    this.emit();
  }

  /**
   * Replaces the whole table and clears the history (an import: old patches refer to records
   * that no longer exist, and the new ids are not the tracker's).
   * @param {TrackRecord[]} records
   */
  replaceAll(records) {
    this.aliases = new Map();
    this.trackerIds = new Set();
    this.labellerIds = new Set();
    this.table = new TrackTable(records);
    this.nextId = this.table.maxId() + 1;
    this.colours = new Map();
    this.undoStack = [];
    this.redoStack = [];
    this.savedTop = null;
    this.emit();
  }

  /** Marks the table as it is now as saved (it was just exported). */
  markSaved() {
    this.savedTop = this.undoStack.at(-1) ?? null;
  }

  /** Whether the table holds edits made since it was last saved or replaced. */
  get unsaved() {
    return (this.undoStack.at(-1) ?? null) !== this.savedTop;
  }

  /**
   * Applies the tracker's offline pass (trajectory re-linking, gap filling) to the table, as
   * one edit that undo takes back.
   *
   * The table already holds the online pass (ingested frame by frame) with the labeller's
   * edits, and the offline pass changes nothing else: it says which tracks are one object
   * (`joins`, tracker ids) and adds shapes in the gaps (`filled`, under the joined identity's
   * tracker id). So instead of replacing the table, each join is applied like a merge of the
   * later track into the earlier one, in time order, and the labeller's word wins:
   * - a track the labeller edited by id (merged away, renumbered, split, swapped, deleted) is
   *   not joined to anything: the labeller already said what it is;
   * - a join to a track the labeller deleted is not made;
   * - a track whose number was merged into, or renumbered, is joined under its shown number.
   * A gap is filled only when the table shows one identity at both of its ends and nothing
   * inside it.
   * @param {{
   *   joins: Array<{ slave: number, master: number, master_first: number }>,
   *   filled: TrackRecord[],
   * }} pass
   * @returns {{ joined: number, filled: number }} what was applied
   */
  relink({ joins, filled }) {
    const table = this.table;
    /** @type {TrackRecord[]} */
    const removed = [];
    /** @type {Set<TrackRecord>} records this pass added (moved again: not an original) */
    const added = new Set();
    /** Shown id → shown id for tracks this pass moved. @type {Map<number, number>} */
    const moved = new Map();
    const follow = (/** @type {number | null} */ id) => {
      for (let k = 0; id !== null && moved.has(id) && k <= moved.size; k++) id = /** @type {number} */ (moved.get(id));
      return id;
    };
    const drop = (/** @type {TrackRecord} */ r) => {
      table.remove(r);
      if (added.has(r)) added.delete(r);
      else removed.push(r);
    };
    const put = (/** @type {TrackRecord} */ r) => {
      table.add(r);
      added.add(r);
    };

    let joined = 0;
    for (const j of [...joins].sort((a, b) => a.master_first - b.master_first)) {
      if (this.aliases.has(j.master) || !table.has(j.master)) continue;
      const from = j.master;
      const to = follow(this.resolve(j.slave));
      if (to === null || to === from) continue;
      for (const r of table.track(from)) {
        drop(r);
        const there = table.get(r.frame, to);
        // The pass joins over a slave's coasted tail: an observation replaces a coasted
        // prediction of the same frame, never the other way round.
        if (there && there.interpolated && !r.interpolated) drop(there);
        if (!table.get(r.frame, to)) put(withId(r, to));
      }
      moved.set(from, to);
      joined++;
    }

    // Each filled run is one gap of one chain (root tracker id): its ends belong to the
    // chain member that is current at that frame (members start where their join says).
    /** @type {Map<number, Array<[number, number]>>} root → [first frame, member] by start */
    const members = new Map();
    const slaveOf = new Map(joins.map((j) => [j.master, j.slave]));
    for (const j of joins) {
      let root = j.master;
      for (let k = 0; slaveOf.has(root) && k <= joins.length; k++) root = /** @type {number} */ (slaveOf.get(root));
      const list = members.get(root) ?? [[-Infinity, root]];
      list.push([j.master_first, j.master]);
      members.set(root, list);
    }
    for (const list of members.values()) list.sort((a, b) => a[0] - b[0]);
    const memberAt = (/** @type {number} */ root, /** @type {number} */ frame) => {
      let m = root;
      for (const [first, id] of members.get(root) ?? []) if (first <= frame) m = id;
      return m;
    };
    let nFilled = 0;
    const runs = [...filled].sort((a, b) => a.id - b.id || a.frame - b.frame);
    for (let i = 0; i < runs.length; ) {
      let k = i + 1;
      while (k < runs.length && runs[k].id === runs[i].id && runs[k].frame === runs[k - 1].frame + 1) k++;
      const run = runs.slice(i, k);
      i = k;
      const root = run[0].id;
      const fa = run[0].frame - 1;
      const fb = run[run.length - 1].frame + 1;
      const id = follow(this.resolve(memberAt(root, fa)));
      if (id === null || id !== follow(this.resolve(memberAt(root, fb)))) continue;
      if (!table.get(fa, id) || !table.get(fb, id) || run.some((r) => table.get(r.frame, id))) continue;
      for (const r of run) put(id === r.id ? r : withId(r, id));
      nFilled += run.length;
    }

    // Undo the working changes, then record them as one edit (which applies them again).
    for (const r of added) table.remove(r);
    for (const r of removed) table.add(r);
    if (joined || nFilled) {
      // Future tracker output of a moved track goes where the track went, in one step.
      const renames = new Map([...moved.keys()].map((id) => [id, follow(id)]));
      this.commit(`offline pass: ${joined} join(s), ${nFilled} filled`, removed, [...added], renames);
    }
    return { joined, filled: nFilled };
  }

  /**
   * Records and applies an edit.
   * @param {string} label
   * @param {TrackRecord[]} removed
   * @param {TrackRecord[]} added
   * @param {Map<number, number | null>} renames shown id → new shown id (null: deleted), for
   *   frames still to come from the tracker
   * @param {number} [nextIdAfter]
   * @param {Map<number, number>} [coloursAfter] the colour map after the edit (default: as is)
   */
  commit(label, removed, added, renames, nextIdAfter = this.nextId, coloursAfter = this.colours) {
    const aliasesAfter = new Map();
    for (const [t, shown] of this.aliases) {
      aliasesAfter.set(t, shown !== null && renames.has(shown) ? /** @type {number | null} */ (renames.get(shown)) : shown);
    }
    // Tracker ids shown under their own number follow a rename of that number.
    for (const [shown, to] of renames) {
      if (!this.aliases.has(shown) && this.trackerIds.has(shown)) aliasesAfter.set(shown, to);
    }
    for (const [t, shown] of aliasesAfter) if (shown === t) aliasesAfter.delete(t);
    /** @type {Patch} */
    const patch = {
      label,
      removed,
      added,
      aliasesBefore: new Map(this.aliases),
      aliasesAfter,
      nextIdBefore: this.nextId,
      nextIdAfter,
      coloursBefore: this.colours,
      coloursAfter,
    };
    this.applyPatch(patch);
    this.undoStack.push(patch);
    this.redoStack = [];
    this.emit();
    return patch;
  }

  /** @param {Patch} p */
  applyPatch(p) {
    for (const r of p.removed) this.table.remove(r);
    for (const r of p.added) this.table.add(r);
    this.aliases = new Map(p.aliasesAfter);
    this.nextId = p.nextIdAfter;
    this.colours = p.coloursAfter;
  }

  /** @param {Patch} p */
  revertPatch(p) {
    for (const r of p.added) this.table.remove(r);
    for (const r of p.removed) this.table.add(r);
    this.aliases = new Map(p.aliasesBefore);
    this.nextId = p.nextIdBefore;
    this.colours = p.coloursBefore;
  }

  /** @returns {string | null} the label of the undone edit */
  undo() {
    const p = this.undoStack.pop();
    if (!p) return null;
    this.revertPatch(p);
    this.redoStack.push(p);
    this.emit();
    return p.label;
  }

  /** @returns {string | null} the label of the redone edit */
  redo() {
    const p = this.redoStack.pop();
    if (!p) return null;
    this.applyPatch(p);
    this.undoStack.push(p);
    this.emit();
    return p.label;
  }

  get canUndo() {
    return this.undoStack.length > 0;
  }

  get canRedo() {
    return this.redoStack.length > 0;
  }

  /** @param {number} id */
  requireTrack(id) {
    if (!this.table.has(id)) throw new EditError(`there is no track ${id}`);
  }

  /**
   * Merges track `drop` into track `keep`: one object, two fragments. One object is in one
   * place per frame, so two tracks both seen in the same frame are two objects: the merge is
   * refused (an `EditError` naming the frames) rather than one side's shapes silently lost.
   * Where only one side was seen and the other's shape was filled in (coasted over a missed
   * detection, or interpolated by the offline pass), the seen one is kept; where both were
   * filled in, the kept track's.
   * @param {number} keep
   * @param {number} drop
   * @returns {{ dropped: number }} how many filled-in shapes gave way to the other track's
   */
  merge(keep, drop) {
    if (keep === drop) throw new EditError('cannot merge a track with itself');
    this.requireTrack(keep);
    this.requireTrack(drop);
    const moved = this.table.track(drop);
    /** @type {TrackRecord[]} the kept track's filled-in shapes that give way */
    const replaced = [];
    const added = [];
    /** @type {number[]} */
    const both = [];
    let dropped = 0;
    for (const r of moved) {
      const there = this.table.get(r.frame, keep);
      if (!there) added.push(withId(r, keep));
      else if (!there.interpolated && !r.interpolated) both.push(r.frame);
      else if (there.interpolated && !r.interpolated) {
        replaced.push(there);
        added.push(withId(r, keep));
        dropped++;
      } else dropped++;
    }
    if (both.length) {
      throw new EditError(
        `tracks ${keep} and ${drop} are both seen in frame${both.length === 1 ? '' : 's'} ${frameRanges(both)}: ` +
          'two objects, not one — to fix an identity switch use Swap (W), or split or delete the overlap first',
      );
    }
    this.commit(`merge ${drop} into ${keep}`, [...moved, ...replaced], added, new Map([[drop, keep]]));
    return { dropped };
  }

  /**
   * Gives track `id` the number `to`, keeping its colour. When `to` is already a track this is
   * a merge.
   * @param {number} id
   * @param {number} to
   */
  reassign(id, to) {
    if (!Number.isInteger(to) || to < 1) throw new EditError(`an id must be a positive integer, not ${to}`);
    this.requireTrack(id);
    if (id === to) return;
    if (this.table.has(to)) {
      this.merge(to, id);
      return;
    }
    const removed = this.table.track(id);
    const added = removed.map((r) => withId(r, to));
    // Patches hold their colour maps: a fresh map per edit, never changed afterwards.
    const colours = new Map(this.colours);
    const key = this.colourKey(id);
    colours.delete(id);
    if (key === to) colours.delete(to);
    else colours.set(to, key);
    this.commit(`renumber ${id} as ${to}`, removed, added, new Map([[id, to]]), Math.max(this.nextId, to + 1), colours);
  }

  /**
   * Splits track `id` at `frame`: records from `frame` on get a new id, which is returned.
   * Frames still to come from the tracker continue the new (later) part.
   * @param {number} id
   * @param {number} frame
   * @returns {number} the new id
   */
  split(id, frame) {
    this.requireTrack(id);
    const [first, last] = /** @type {[number, number]} */ (this.table.span(id));
    if (frame <= first || frame > last) {
      throw new EditError(`to split track ${id}, pick a frame in ${first + 1}..${last}`);
    }
    const fresh = this.nextId;
    const removed = this.table.track(id).filter((r) => r.frame >= frame);
    const added = removed.map((r) => withId(r, fresh));
    this.labellerIds.add(fresh);
    this.commit(`split ${id} at frame ${frame} as ${fresh}`, removed, added, new Map([[id, fresh]]), fresh + 1);
    return fresh;
  }

  /**
   * Swaps the identities of tracks `a` and `b` from `frame` on: the fix for an identity switch.
   * @param {number} a
   * @param {number} b
   * @param {number} frame
   */
  swap(a, b, frame) {
    if (a === b) throw new EditError('cannot swap a track with itself');
    this.requireTrack(a);
    this.requireTrack(b);
    const ra = this.table.track(a).filter((r) => r.frame >= frame);
    const rb = this.table.track(b).filter((r) => r.frame >= frame);
    if (!ra.length && !rb.length) throw new EditError(`neither ${a} nor ${b} exists from frame ${frame} on`);
    const added = [...ra.map((r) => withId(r, b)), ...rb.map((r) => withId(r, a))];
    this.commit(`swap ${a} and ${b} from frame ${frame}`, [...ra, ...rb], added, new Map([[a, b], [b, a]]));
  }

  /**
   * Deletes track `id` (a false track); the tracker's later output for it stays hidden.
   * @param {number} id
   */
  deleteTrack(id) {
    this.requireTrack(id);
    this.commit(`delete ${id}`, this.table.track(id), [], new Map([[id, null]]));
  }

  /**
   * Deletes one record (a false detection inside a good track).
   * @param {number} frame
   * @param {number} id
   */
  deleteRecord(frame, id) {
    const r = this.table.get(frame, id);
    if (!r) throw new EditError(`track ${id} has no record in frame ${frame}`);
    this.commit(`delete ${id} in frame ${frame}`, [r], [], new Map());
  }
}
