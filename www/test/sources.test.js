import { test } from 'node:test';
import assert from 'node:assert/strict';
import { sequenceName, snapFps, videoSource } from '../src/sources/sources.js';

test('measured frame rates snap to the common ones when close', () => {
  assert.equal(snapFps(29.96), 29.97);
  assert.equal(snapFps(25.2), 25);
  assert.equal(snapFps(23.98), 23.976);
  assert.equal(snapFps(59.5), 59.94);
  // Far from every common rate: kept, rounded to 1/1000.
  assert.equal(snapFps(27.7777), 27.778);
  assert.equal(snapFps(12.5), 12.5);
});

test('image sequences are named after their folder or shared prefix, not their first file', () => {
  assert.equal(sequenceName(['00000.jpg', '00001.jpg'], 'car-shadow'), 'car-shadow');
  assert.equal(sequenceName(['00000.jpg', '00001.jpg', '00002.jpg']), 'images');
  assert.equal(sequenceName(['frame_0001.png', 'frame_0002.png', 'frame_0100.png']), 'frame');
  assert.equal(sequenceName(['street 1.jpg', 'street 2.jpg']), 'street');
  assert.equal(sequenceName(['only.png']), 'only');
});

/**
 * A stand-in for a paused, hidden <video>: a seek fires 'seeked' first and presents the sought
 * frame a few milliseconds later (as Chromium may on a busy machine), or never when
 * `presents` is false; the "bitmap" records which time was on screen when it was grabbed.
 */
class FakeVideo extends EventTarget {
  constructor(presents = true) {
    super();
    this.presents = presents;
    this.duration = 1;
    this.videoWidth = 4;
    this.videoHeight = 3;
    this.playbackRate = 1;
    this.time = 0;
    /** the media time of the frame on screen */
    this.shown = 0;
    this.playing = false;
    /** @type {Map<number, (now: number, meta: { mediaTime: number }) => void>} */
    this.callbacks = new Map();
    this.handles = 0;
  }
  set src(_url) {
    setTimeout(() => this.dispatchEvent(new Event('loadedmetadata')));
  }
  removeAttribute() {}
  load() {}
  /** @param {number} t */
  present(t) {
    this.shown = t;
    const cbs = [...this.callbacks.values()];
    this.callbacks.clear();
    for (const cb of cbs) cb(0, { mediaTime: t });
  }
  /** @param {(now: number, meta: { mediaTime: number }) => void} cb */
  requestVideoFrameCallback(cb) {
    this.callbacks.set(++this.handles, cb);
    // While playing, a frame every 40 ms (25 fps).
    if (this.playing) setTimeout(() => this.playing && this.present(this.shown + 0.04), 1);
    return this.handles;
  }
  /** @param {number} h */
  cancelVideoFrameCallback(h) {
    this.callbacks.delete(h);
  }
  async play() {
    this.playing = true;
    setTimeout(() => this.present(this.shown + 0.04), 1);
  }
  pause() {
    this.playing = false;
  }
  get currentTime() {
    return this.time;
  }
  set currentTime(t) {
    this.time = t;
    setTimeout(() => {
      this.dispatchEvent(new Event('seeked'));
      if (this.presents) setTimeout(() => this.present(t), 5);
    });
  }
}

test('a video frame is grabbed once the sought frame is presented, not at "seeked"', async () => {
  const grab = /** @type {any} */ (globalThis).createImageBitmap;
  /** @type {any} */ (globalThis).createImageBitmap = async (/** @type {FakeVideo} */ v) => ({ shown: v.shown });
  try {
    const video = new FakeVideo();
    const src = await videoSource(/** @type {any} */ (video), new File([new Uint8Array(4)], 'v.webm'));
    assert.equal(src.fps, 25);
    assert.equal(src.frames, 25);
    // Backward, as a backward follow reads: each grab shows its own frame, never the one
    // before the seek.
    for (const n of [16, 15, 14, 3]) {
      const bitmap = /** @type {any} */ (await src.frameAt(n));
      assert.equal(bitmap.shown, (n - 0.5) / 25, `frame ${n}`);
    }
    // A browser that never presents on a seek (no callback for a hidden, paused element)
    // still gets its frame, after the wait's bound, rather than stalling the follow.
    const silent = new FakeVideo(false);
    const s2 = await videoSource(/** @type {any} */ (silent), new File([new Uint8Array(4)], 'v.webm'));
    assert.ok(await s2.frameAt(5));
    src.close();
    s2.close();
  } finally {
    /** @type {any} */ (globalThis).createImageBitmap = grab;
  }
});
