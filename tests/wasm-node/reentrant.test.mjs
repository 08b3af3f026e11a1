// Issue 65, class 3: a tracker used from inside its own `finish` progress callback, through the
// generated JS glue (www/pkg), as a page would. The tracker is busy there: its methods throw an
// Error, `finish` reports it and leaves the tracker as it was; `free()` throws too but takes
// effect when `finish` returns. Never a trap, never a use after free, never an object that
// every later call refuses ("recursive use of an object detected"), and the module goes on.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import * as st from '../../www/pkg/shapetrack.js';

st.initSync({ module: readFileSync(new URL('../../www/pkg/shapetrack_bg.wasm', import.meta.url)) });

/** An offline tracker over a box hidden on frames 11–15 (the offline pass joins the gap). */
function tracked() {
  const t = new st.Tracker({ max_lost: 3 }, { fps: 25, width: 320, height: 240 });
  for (let n = 1; n <= 30; n++) {
    const boxes = n <= 10 || n > 15 ? [{ bbox: { x: 10 + 3 * n, y: 20, w: 30, h: 40 }, score: 0.9 }] : [];
    const d = st.Detections.fromLists({ boxes });
    t.updateDetections(n, d);
    d.free();
  }
  return t;
}

/** `f` throws an Error, not a trap; returns its message. @param {() => unknown} f */
function errorOf(f) {
  try {
    f();
  } catch (e) {
    assert.ok(e instanceof Error && !(e instanceof WebAssembly.RuntimeError), `not a trap: ${e}`);
    return e.message;
  }
  assert.fail('did not throw');
}

/** The module still tracks. */
function stillWorks() {
  const t = tracked();
  assert.equal(t.finish().records.length > 0, true);
  t.free();
}

const reference = (() => {
  const t = tracked();
  const out = t.finish();
  t.free();
  return JSON.stringify(out);
})();

test('calling the tracker from its progress callback is an Error that changes nothing', () => {
  for (const call of [
    (/** @type {any} */ t) => t.tracks(),
    (/** @type {any} */ t) => t.frame,
    (/** @type {any} */ t) => t.finish(),
    (/** @type {any} */ t) => t.updateDetections(31, st.Detections.fromLists({})),
  ]) {
    const t = tracked();
    const msg = errorOf(() => t.finish(() => call(t)));
    assert.match(msg, /progress callback threw: recursive use of an object/);
    // As it was: not finished, the same result as a tracker never interrupted.
    assert.equal(t.finished, false);
    assert.equal(t.frame, 30);
    assert.equal(JSON.stringify(t.finish()), reference);
    t.free();
  }
  stillWorks();
});

test('free() from the progress callback releases the tracker when finish returns', () => {
  // Uncaught, free's Error ends finish; the tracker is gone afterwards, as asked.
  const t = tracked();
  const msg = errorOf(() => t.finish(() => t.free()));
  assert.match(msg, /progress callback threw/);
  assert.match(errorOf(() => t.frame), /null pointer/);
  assert.match(errorOf(() => t.free()), /null pointer/);
  stillWorks();
  // Caught, finish completes and returns its result; the tracker is released after it.
  const u = tracked();
  let frees = 0;
  const out = u.finish(() => {
    if (frees++ === 0) assert.throws(() => u.free());
  });
  assert.equal(JSON.stringify(out), reference);
  assert.match(errorOf(() => u.tracks()), /null pointer/);
  stillWorks();
});

test('another tracker can be used and freed from the progress callback', () => {
  const t = tracked();
  const other = tracked();
  let done = false;
  const out = t.finish(() => {
    if (!done) {
      assert.equal(JSON.stringify(other.finish()), reference);
      other.free();
      done = true;
    }
  });
  assert.ok(done);
  assert.equal(JSON.stringify(out), reference);
  t.free();
  stillWorks();
});
