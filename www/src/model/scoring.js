// Live scores while tracking: the table is scored against the ground truth on the frames seen so
// far, but not on every frame — scoring a long sequence costs more than tracking a frame — so
// requests are throttled to one per interval, and a request inside the interval is kept for its
// end (the scores shown are never older than one interval). The clock and timer are injectable:
// the rule is tested under node without waiting.

/** Recompute scores at most this often (ms) while tracking. */
export const SCORE_MS = 500;

/**
 * @typedef {import('./tracks.js').TrackTable} TrackTable
 * @typedef {import('./tracks.js').TrackRecord} TrackRecord
 */

export class Scorer {
  /**
   * @param {() => void} score computes and shows the scores
   * @param {{ interval?: number, now?: () => number, later?: (fn: () => void, ms: number) => unknown }} [opts]
   */
  constructor(score, { interval = SCORE_MS, now = () => performance.now(), later = (fn, ms) => setTimeout(fn, ms) } = {}) {
    this.score = score;
    this.interval = interval;
    this.now = now;
    this.later = later;
    this.last = -Infinity;
    this.pending = false;
  }

  /**
   * Asks for scores: now if the last ones are older than the interval (or `immediate`), else
   * once at the interval's end.
   * @param {boolean} [immediate]
   */
  request(immediate = false) {
    const t = this.now();
    if (!immediate && t - this.last < this.interval) {
      if (!this.pending) {
        this.pending = true;
        this.later(() => {
          this.pending = false;
          this.request(true);
        }, this.interval - (t - this.last));
      }
      return;
    }
    this.last = t;
    this.score();
  }
}

/**
 * The records to score: ground truth and results up to frame `upto` (the frames tracked so far;
 * later ground truth would count as misses the tracker has not had a chance at).
 * @param {TrackTable} gt
 * @param {TrackTable} table
 * @param {number} upto
 * @returns {{ gt: TrackRecord[], res: TrackRecord[] } | null} null when there is nothing to score
 */
export function scoreInputs(gt, table, upto) {
  if (upto < 1) return null;
  const g = gt.all().filter((r) => r.frame <= upto);
  if (!g.length) return null;
  return { gt: g, res: table.all().filter((r) => r.frame <= upto) };
}
