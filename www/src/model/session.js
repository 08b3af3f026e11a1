// The tracking session as an explicit state machine. Before it, the app kept `tracking`,
// `finished`, `processed`, `frames`, `offlineCapable` and `offlineReport` as loose fields, and
// every method re-derived from their combination what it may do (track the next frame? seek
// there? run the offline pass?). Here the phases are named, each transition checks it is
// allowed, and the questions the app asks are answered in one place:
//
//   idle ──open──▶ tracking ──beginFinishing──▶ finishing ──finish──▶ finished
//    │                ▲  │                         │
//    │                │  └───────import────────────┼──────────────▶ finished (imported)
//    │                └──────abortFinishing────────┘
//    └──import──▶ finished (imported)
//
// `tracking`: a source is open and frames up to `processed` have been tracked (online, or the
// offline mode's online pass). `finishing`: the offline pass (re-linker, gap filling) is
// running on the whole sequence. `finished`: the tracks are final — the offline pass ran, or
// tracks were imported — and only edits change them. Pure state, no DOM: tested under node.

/** @typedef {'idle' | 'tracking' | 'finishing' | 'finished'} Phase */

/**
 * What the last offline pass did: ids before and after, joins, filled-in records, time; and
 * how many records the online pass had already flagged interpolated.
 * @typedef {{ onlineIds: number, onlineInterpolated: number, ids: number, joins: number, filled: number, ms: number }} OfflineReport
 */

/** A transition the session's phase does not allow (a bug in the caller, not a user error). */
export class SessionError extends Error {
  /** @param {string} message */
  constructor(message) {
    super(message);
    this.name = 'SessionError';
  }
}

export class Session {
  constructor() {
    /** @type {Phase} */
    this.phase = 'idle';
    /** Frames in the source (0: not known, a live camera). */
    this.frames = 0;
    /** The last frame tracked. */
    this.processed = 0;
    /** Whether the source has an end the offline pass can work to (not a webcam). */
    this.offlineCapable = false;
    /** Whether the tracks came from tracking this source (false: imported). */
    this.tracked = false;
    /** @type {OfflineReport | null} */
    this.report = null;
  }

  /**
   * @param {Phase[]} allowed
   * @param {string} what
   */
  expect(allowed, what) {
    if (!allowed.includes(this.phase)) throw new SessionError(`cannot ${what} while ${this.phase}`);
  }

  /**
   * A source was opened for tracking: start over at frame 0.
   * @param {{ frames: number, offlineCapable: boolean }} src
   */
  open({ frames, offlineCapable }) {
    this.phase = 'tracking';
    this.frames = Math.max(0, frames);
    this.processed = 0;
    this.offlineCapable = offlineCapable;
    this.tracked = true;
    this.report = null;
  }

  /** The source failed to open (or was closed): nothing is being tracked. */
  close() {
    this.phase = 'idle';
    this.frames = 0;
    this.processed = 0;
    this.offlineCapable = false;
    this.report = null;
  }

  /**
   * Tracks were imported: they are final, there is nothing to track (the source, if any,
   * stays open for viewing).
   * @param {number} frames the length the import implies (or the open source's)
   */
  imported(frames) {
    this.phase = 'finished';
    this.frames = Math.max(this.frames, frames);
    this.tracked = false;
    this.report = null;
  }

  /**
   * Frame `n` was tracked. Frames arrive in order; one that is not the next is a bug.
   * @param {number} n
   */
  trackedFrame(n) {
    this.expect(['tracking'], 'track a frame');
    if (n !== this.processed + 1) throw new SessionError(`frame ${n} tracked after ${this.processed}`);
    if (this.frames && n > this.frames) throw new SessionError(`frame ${n} is past the end (${this.frames})`);
    this.processed = n;
  }

  /** Whether frame `n` still has to be tracked before it can be shown. @param {number} n */
  needsTracking(n) {
    return this.phase === 'tracking' && n > this.processed && (!this.frames || n <= this.frames);
  }

  /** Whether every frame of a source with an end has been tracked. */
  get allTracked() {
    return this.frames > 0 && this.processed >= this.frames;
  }

  /**
   * The last frame a seek may show: while tracking (or finishing), the last frame tracked — a
   * frame past it has no tracks yet, and its raw pixels under the frame counter would pass an
   * untracked frame off as tracked. Otherwise the sequence's end (`lastFrame`, which the app
   * knows from the table for imports).
   * @param {number} lastFrame
   */
  lastShown(lastFrame) {
    return this.phase === 'tracking' || this.phase === 'finishing' ? this.processed : lastFrame;
  }

  /** Whether play in offline mode should run the offline pass (rather than replay). */
  get offlinePending() {
    return this.phase === 'tracking';
  }

  /** Starts the offline pass: every frame must have been tracked. */
  beginFinishing() {
    this.expect(['tracking'], 'start the offline pass');
    if (!this.offlineCapable) throw new SessionError('this source has no end: the offline pass cannot run');
    if (!this.allTracked) throw new SessionError(`the offline pass needs every frame tracked (${this.processed}/${this.frames})`);
    this.phase = 'finishing';
  }

  /** The offline pass was stopped or failed: tracking may resume it later. */
  abortFinishing() {
    this.expect(['finishing'], 'abort the offline pass');
    this.phase = 'tracking';
  }

  /** @param {OfflineReport} report what the offline pass did */
  finish(report) {
    this.expect(['finishing'], 'finish the offline pass');
    this.phase = 'finished';
    this.report = report;
  }
}
