// The wasm API under hostile and careless calls, in Node, from the built package (www/pkg):
// each gets a thrown Error, never a trap, and the module keeps working afterwards (a trap in
// the browser kills the page's tracker; a broken instance fails every later call).

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import * as st from '../../www/pkg/shapetrack.js';

st.initSync({ module: readFileSync(new URL('../../www/pkg/shapetrack_bg.wasm', import.meta.url)) });

/** The module still answers a normal call. */
function stillWorks() {
  const rle = st.encodeMask(4, 3, new Uint8Array([0, 1, 1, 0, 0, 1, 1, 0, 0, 0, 0, 0]));
  const m = st.decodeMask(rle);
  assert.equal(m.width * m.height >= 4, true);
  const t = new st.Tracker();
  t.free();
}

/** `f` throws an Error (not a RuntimeError trap) whose message matches `re`. */
function throwsError(f, re) {
  assert.throws(f, (e) => {
    assert.ok(!(e instanceof WebAssembly.RuntimeError), `trap: ${e}`);
    if (re) assert.match(String(e.message ?? e), re);
    return true;
  });
  stillWorks();
}

test('mask sizes that overflow 32 bits are errors', () => {
  throwsError(() => st.encodeMask(65536, 65536, new Uint8Array(0)));
  throwsError(() =>
    st.Detections.fromLists({
      masks: [{ x: 0, y: 0, width: 65536, height: 65536, data: new Uint8Array(0), score: 1, class: -1 }],
      boxes: [],
    }),
  );
});

test('a MOTS line declaring a 65536 x 65536 mask is an error, in parse and decode', () => {
  // Runs 0, 2^31, 2^31 in COCO's compressed form, as the native test builds them.
  const counts = '0PPPPPP2PPPPPP2';
  throwsError(() => st.decodeMask({ size: [65536, 65536], counts }));
  throwsError(() => st.parseAnnotations('mots', `1 -1 -1 65536 65536 ${counts}\n`, 'm.txt'), /m\.txt/);
});

test('CVAT run lengths that wrap around are an error', () => {
  const xml =
    '<annotations><version>1.1</version><meta><task><size>10</size><original_size><width>64</width>' +
    '<height>48</height></original_size></task></meta><track id="0" label="a">' +
    '<mask frame="0" keyframe="1" outside="0" occluded="0" rle="0, 10, 18446744073709551611" ' +
    'left="0" top="47" width="5" height="1"/></track></annotations>';
  throwsError(() => st.parseAnnotations('cvat', xml, 'c.xml'), /rle/);
});

test('settings: deep nesting, arrays, NaN and non-objects are errors naming the place', () => {
  let deep = {};
  const root = deep;
  for (let i = 0; i < 5000; i++) deep = deep.x = {};
  throwsError(() => new st.Tracker(root), /deeper/);
  throwsError(() => new st.Tracker([1, 2, 3]), /plain object/);
  throwsError(() => new st.BackgroundDetector([1, 2]), /plain object/);
  throwsError(() => new st.Tracker({ motion: [0.1, 0.2] }), /motion/);
  throwsError(() => new st.Tracker({ max_cost: NaN }), /max_cost/);
  throwsError(() => new st.Tracker({ max_cost: Infinity }), /max_cost/);
});

test('mask detections without a frame or an image size are refused, not emptied', () => {
  const t = new st.Tracker();
  const dets = st.Detections.fromLists({
    masks: [{ x: 2, y: 3, width: 2, height: 2, data: new Uint8Array([1, 1, 1, 1]), score: 1, class: -1 }],
    boxes: [],
  });
  throwsError(() => t.updateDetections(1, dets), /image size/);
  // With the size given, the mask comes back.
  const u = new st.Tracker({ min_hits: 1 }, { fps: 30, width: 16, height: 16 });
  const out = u.updateDetections(1, dets);
  for (const s of out) assert.deepEqual(s.mask?.size, [16, 16]);
});

test('numbers beyond u32 and non-strings are errors, not wrapped or trapped', () => {
  throwsError(() => st.parseAnnotations('mot', 12345, 'x'), /must be strings/);
  throwsError(() => new st.FrameBuffer(2 ** 32 + 8, 8), /width/);
  throwsError(() => new st.FrameBuffer(-1, 8), /width/);
  throwsError(() => st.encodeMask(2.5, 2, new Uint8Array(5)), /width/);
  const t = new st.Tracker();
  const none = st.Detections.fromLists({ masks: [], boxes: [] });
  throwsError(() => t.updateDetections(2 ** 32 + 1, none), /frame/);
  // The tracker is unharmed: frame 1 is still the next one.
  assert.deepEqual(t.updateDetections(1, none), []);
});
