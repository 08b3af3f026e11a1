// The video's frame rate given with the offline options (`new Tracker(settings, { fps })`, what
// the page and the library's worker pass) reaches the online tracker too, as `shapetrack track
// --fps` does: its frame counts that measure time are scaled to it. Before, the online tracker
// kept its 30 fps counts on any video (the page's tracker on a 5 fps clip kept a lost track in
// the main association for 1.6 s and handed the car of DAVIS car-shadow to a neighbour's id,
// while the CLI kept one id).

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import * as st from '../../www/pkg/shapetrack.js';

st.initSync({ module: readFileSync(new URL('../../www/pkg/shapetrack_bg.wasm', import.meta.url)) });

/**
 * A box detected on frames 1–15 and then never again: the frames the tracker reports it on
 * (after 15: coasted, `interpolated`, for `coast_frames` at the tracker's frame rate).
 * @param {Record<string, unknown> | null} settings
 * @param {Record<string, unknown> | null} offline
 */
function reported(settings, offline) {
  const tracker = new st.Tracker(settings, offline);
  /** @type {number[]} */
  const frames = [];
  for (let n = 1; n <= 40; n++) {
    const boxes = n <= 15 ? [{ bbox: { x: 10 + 2 * n, y: 20, w: 30, h: 40 }, score: 0.9 }] : [];
    const dets = st.Detections.fromLists({ boxes });
    for (const s of tracker.updateDetections(n, dets)) frames.push(s.frame);
    dets.free();
  }
  tracker.free();
  return frames;
}

test('the offline options’ fps is the online tracker’s frame rate, unless the settings give one', () => {
  const size = { width: 200, height: 100 };
  const at30 = reported({}, { fps: 30, ...size });
  // 8 coasted frames at 30 fps (the counts' own rate, as with no rate at all) …
  assert.deepEqual(at30, reported({}, null));
  assert.equal(Math.max(...at30), 15 + 8);
  // … 8 · 5/30 → 1 at 5 fps, as with the rate given in the settings.
  const at5 = reported({}, { fps: 5, ...size });
  assert.equal(Math.max(...at5), 15 + 1);
  assert.deepEqual(at5, reported({ frame_rate: 5 }, null));
  // The settings' own rate wins.
  assert.deepEqual(reported({ frame_rate: 30 }, { fps: 5, ...size }), at30);
});
