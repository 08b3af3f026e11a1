// Frames per second over a sliding window of recent frames: steady enough to read, quick to
// follow a change of scene.

export class FpsMeter {
  /** @param {number} [window] number of frames averaged */
  constructor(window = 30) {
    this.window = window;
    /** @type {number[]} */
    this.times = [];
  }

  /** @param {number} t timestamp in ms (performance.now()) */
  tick(t) {
    this.times.push(t);
    if (this.times.length > this.window + 1) this.times.shift();
  }

  reset() {
    this.times = [];
  }

  /** Frames per second over the window; 0 until two frames were seen. */
  get fps() {
    const n = this.times.length;
    if (n < 2) return 0;
    const dt = this.times[n - 1] - this.times[0];
    return dt > 0 ? ((n - 1) * 1000) / dt : 0;
  }
}
