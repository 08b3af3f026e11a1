// The track table: every object of every frame, indexed by frame and by id.
//
// Pure data (no DOM, no wasm) so it runs under `node --test`. Records are the same plain objects
// the wasm readers return and the writers take (`RecordJs` in the generated types), which keeps
// import → edit → export a straight line with no conversion layer.

/**
 * @typedef {{ x: number, y: number, w: number, h: number }} Box
 * @typedef {{ size: [number, number], counts: string }} Rle
 * @typedef {{
 *   frame: number, id: number, bbox: Box, score?: number, class?: number,
 *   visibility?: number, mask?: Rle, interpolated?: boolean, occluded?: boolean,
 *   state?: string, source?: string, keyframe?: boolean,
 * }} TrackRecord  `source: 'follow'`: made by the follower (model/follow.js); `keyframe`: a
 *   shape the labeller gave a follow
 */

export class TrackTable {
  /** @param {Iterable<TrackRecord>} [records] */
  constructor(records = []) {
    /** @type {Map<number, Map<number, TrackRecord>>} frame → id → record */
    this.byFrame = new Map();
    /** @type {Map<number, Map<number, TrackRecord>>} id → frame → record */
    this.byId = new Map();
    /** Bumped on every change so views can cache derived data. */
    this.version = 0;
    for (const r of records) this.add(r);
  }

  /**
   * Adds a record; a record already at the same (frame, id) is replaced and returned.
   * @param {TrackRecord} r
   * @returns {TrackRecord | undefined}
   */
  add(r) {
    const old = this.get(r.frame, r.id);
    if (old) this.remove(old);
    let f = this.byFrame.get(r.frame);
    if (!f) this.byFrame.set(r.frame, (f = new Map()));
    f.set(r.id, r);
    let t = this.byId.get(r.id);
    if (!t) this.byId.set(r.id, (t = new Map()));
    t.set(r.frame, r);
    this.version++;
    return old;
  }

  /**
   * Removes exactly this record object (not another one at the same place).
   * @param {TrackRecord} r
   * @returns {boolean} whether it was there
   */
  remove(r) {
    const f = this.byFrame.get(r.frame);
    if (!f || f.get(r.id) !== r) return false;
    f.delete(r.id);
    if (f.size === 0) this.byFrame.delete(r.frame);
    const t = this.byId.get(r.id);
    if (t) {
      t.delete(r.frame);
      if (t.size === 0) this.byId.delete(r.id);
    }
    this.version++;
    return true;
  }

  /** @param {number} frame @param {number} id */
  get(frame, id) {
    return this.byFrame.get(frame)?.get(id);
  }

  /** @param {number} frame @returns {TrackRecord[]} the records of one frame, by id */
  at(frame) {
    const f = this.byFrame.get(frame);
    return f ? [...f.values()].sort((a, b) => a.id - b.id) : [];
  }

  /** @param {number} id @returns {TrackRecord[]} one track, by frame */
  track(id) {
    const t = this.byId.get(id);
    return t ? [...t.values()].sort((a, b) => a.frame - b.frame) : [];
  }

  /** @param {number} id */
  has(id) {
    return this.byId.has(id);
  }

  /** How many tracks the table holds (what `ids().length` says, without listing them). */
  get trackCount() {
    return this.byId.size;
  }

  /** @returns {number[]} every id, ascending */
  ids() {
    return [...this.byId.keys()].sort((a, b) => a - b);
  }

  /** @param {number} id @returns {[number, number] | null} first and last frame */
  span(id) {
    const t = this.byId.get(id);
    if (!t) return null;
    let lo = Infinity;
    let hi = -Infinity;
    for (const f of t.keys()) {
      if (f < lo) lo = f;
      if (f > hi) hi = f;
    }
    return [lo, hi];
  }

  /**
   * Maximal runs of consecutive frames where the track exists: what the timeline draws.
   * @param {number} id
   * @returns {Array<[number, number]>} inclusive [start, end] pairs
   */
  runs(id) {
    const frames = [...(this.byId.get(id)?.keys() ?? [])].sort((a, b) => a - b);
    /** @type {Array<[number, number]>} */
    const out = [];
    for (const f of frames) {
      const last = out[out.length - 1];
      if (last && f === last[1] + 1) last[1] = f;
      else out.push([f, f]);
    }
    return out;
  }

  /**
   * Like `runs`, but a run also ends where records switch between observed and filled in
   * (`interpolated`): the timeline draws filled spans differently.
   * @param {number} id
   * @returns {Array<[number, number, boolean]>} inclusive [start, end, filled] triples
   */
  spans(id) {
    const t = this.byId.get(id);
    if (!t) return [];
    const frames = [...t.keys()].sort((a, b) => a - b);
    /** @type {Array<[number, number, boolean]>} */
    const out = [];
    for (const f of frames) {
      const filled = !!t.get(f)?.interpolated;
      const last = out[out.length - 1];
      if (last && f === last[1] + 1 && last[2] === filled) last[1] = f;
      else out.push([f, f, filled]);
    }
    return out;
  }

  /** Smallest frame number with a record (0 when empty). */
  firstFrame() {
    let lo = 0;
    for (const f of this.byFrame.keys()) if (lo === 0 || f < lo) lo = f;
    return lo;
  }

  /** Largest frame number with a record (0 when empty). */
  lastFrame() {
    let hi = 0;
    for (const f of this.byFrame.keys()) if (f > hi) hi = f;
    return hi;
  }

  /** Largest id (0 when empty). */
  maxId() {
    let hi = 0;
    for (const id of this.byId.keys()) if (id > hi) hi = id;
    return hi;
  }

  /** Number of records. */
  get size() {
    let n = 0;
    for (const f of this.byFrame.values()) n += f.size;
    return n;
  }

  /** @returns {TrackRecord[]} every record, by frame then id (the order writers use) */
  all() {
    const frames = [...this.byFrame.keys()].sort((a, b) => a - b);
    return frames.flatMap((f) => this.at(f));
  }
}
