// What part of the track timeline is in view: a window of frames (zoom and pan along time) and
// a window of rows (scroll through the ids). Pure arithmetic, no DOM, so the rules — zoom keeps
// the frame under the pointer in place, the playhead stays in view, a selected track's row is
// scrolled to, the window follows a growing sequence while it shows all of it — are tested
// under `node --test` and the canvas code only draws what this says is visible.

/** Fewest frames the window may show: closer than this, bars are wider than they are useful. */
export const MIN_SPAN = 10;

export class Viewport {
  constructor() {
    /** Frames in the sequence (the timeline's full width). */
    this.frames = 1;
    /** First frame in view; fractional while zoomed so zooming around a point is smooth. */
    this.start = 1;
    /** Frames in view. */
    this.span = 1;
    /** Whether the window shows the whole sequence: it then grows with it. */
    this.fit = true;
    /** Rows in the table and rows that fit on the canvas. */
    this.rows = 0;
    this.visible = 1;
    /** First row in view. */
    this.top = 0;
  }

  /**
   * Sets the sequence length and the rows on screen, keeping the window valid.
   * @param {number} frames
   * @param {number} rows rows in the table
   * @param {number} visible rows that fit
   */
  resize(frames, rows, visible) {
    this.frames = Math.max(1, frames);
    this.rows = Math.max(0, rows);
    this.visible = Math.max(1, visible);
    if (this.fit) {
      this.start = 1;
      this.span = this.frames;
    }
    this.clampFrames();
    this.top = clamp(this.top, 0, Math.max(0, this.rows - this.visible));
  }

  /** Clamps the frame window into the sequence. */
  clampFrames() {
    this.span = clamp(this.span, Math.min(MIN_SPAN, this.frames), this.frames);
    this.start = clamp(this.start, 1, this.frames - this.span + 1);
    this.fit = this.span >= this.frames;
  }

  /**
   * Zooms by `factor` (> 1 in, < 1 out) keeping frame `at` where it is on screen.
   * @param {number} factor
   * @param {number} at a frame (fractional), usually the one under the pointer
   */
  zoom(factor, at) {
    if (!(factor > 0)) return;
    // A point outside the window (the playhead after a pan away) becomes its centre.
    const inside = at >= this.start && at <= this.start + this.span;
    const share = inside ? (at - this.start) / this.span : 0.5;
    this.span = this.span / factor;
    this.fit = false;
    this.start = at - share * clamp(this.span, Math.min(MIN_SPAN, this.frames), this.frames);
    this.clampFrames();
  }

  /** Shows the whole sequence again. */
  showAll() {
    this.fit = true;
    this.start = 1;
    this.span = this.frames;
  }

  /** @param {number} frames how far to move the window along time (negative: back) */
  pan(frames) {
    this.start += frames;
    this.clampFrames();
  }

  /**
   * Keeps `frame` in view: when it has left the window, the window pages so the frame sits
   * near its left edge (playback then reads left to right, page after page).
   * @param {number} frame
   * @returns {boolean} whether the window moved
   */
  follow(frame) {
    if (this.fit || (frame >= this.start && frame < this.start + this.span)) return false;
    this.start = frame - this.span * 0.1;
    this.clampFrames();
    return true;
  }

  /** @param {number} rows rows to scroll by (negative: up) */
  scroll(rows) {
    this.top = clamp(Math.round(this.top + rows), 0, Math.max(0, this.rows - this.visible));
  }

  /**
   * Brings row `row` into view, in the middle of the rows shown (its neighbours, often the
   * tracks it is confused with, come along); a row already in view stays where it is.
   * @param {number} row
   * @returns {boolean} whether it scrolled
   */
  reveal(row) {
    if (row < 0 || row >= this.rows) return false;
    if (row >= this.top && row < this.top + this.visible) return false;
    this.top = clamp(row - Math.floor(this.visible / 2), 0, Math.max(0, this.rows - this.visible));
    return true;
  }

  /**
   * The frame at a horizontal position across the bars (0: left edge, 1: right edge).
   * @param {number} share
   */
  frameAt(share) {
    return clamp(Math.floor(this.start + share * this.span), 1, this.frames);
  }

  /**
   * Where frame `f`'s column begins across the bars (0: left edge, 1: right edge; outside
   * that range it is out of view).
   * @param {number} f
   */
  shareOf(f) {
    return (f - this.start) / this.span;
  }

  /** The whole frames in view, first and last. @returns {[number, number]} */
  frameRange() {
    const a = Math.max(1, Math.floor(this.start));
    const b = Math.min(this.frames, Math.ceil(this.start + this.span) - 1);
    return [a, Math.max(a, b)];
  }
}

/** @param {number} v @param {number} lo @param {number} hi */
function clamp(v, lo, hi) {
  return Math.min(hi, Math.max(lo, v));
}
