// The core (wasm) and the page's net agree on the side the network runs at: the core crops to
// it and reads maps at it (`segment::SIDE`), the net declares it to onnxruntime
// (www/src/worker/segmenter/contract.js, side.js). A side changed on one side only would fail
// every learned outline at run time, with an input-length error.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import * as st from '../../www/pkg/shapetrack.js';
import { INPUT_LENGTH, OUTPUT_LENGTH, SIDE } from '../../www/src/worker/segmenter/contract.js';

st.initSync({ module: readFileSync(new URL('../../www/pkg/shapetrack_bg.wasm', import.meta.url)) });

test('the core and the net run the network at one side', () => {
  assert.equal(st.segmentSide(), SIDE);
  assert.equal(st.segmentInputLength(), INPUT_LENGTH);
  assert.equal(st.segmentOutputLength(), OUTPUT_LENGTH);
});
