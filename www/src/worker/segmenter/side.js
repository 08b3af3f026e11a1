// The side the net runs at. u2netp.onnx declares a fixed [1, 3, 320, 320] input and seven
// [1, 1, 320, 320] outputs, but every resize inside it takes its size from the shape of the
// tensor it follows, so the same weights run at another side once the declared dimensions say
// so (onnxruntime refuses an input of another shape than the declared one). The core crops and
// reads maps at `SIDE` (contract.js, the Rust `segment::SIDE`); this rewrites the model's
// declared height and width to it, in place: a side whose varint has as many bytes as 320's
// (128…16383) keeps every length in the file, so nothing else moves. The model's hash is
// checked on the bytes as published, before this.

import { SegmenterError } from './contract.js';

/** The side u2netp.onnx declares. */
export const MODEL_SIDE = 320;

/**
 * @param {Uint8Array} buf
 * @param {number} at
 * @returns {[number, number]} the varint's value and the offset after it
 */
function varint(buf, at) {
  let value = 0;
  let scale = 1;
  for (let i = 0; i < 8; i++) {
    if (at >= buf.length) throw new SegmenterError('model', 'segmenter: the model file ends inside a number');
    const b = buf[at++];
    value += (b & 0x7f) * scale;
    if (b < 0x80) return [value, at];
    scale *= 128;
  }
  throw new SegmenterError('model', 'segmenter: the model file holds a number too long to read');
}

/**
 * The fields of the protobuf message in `buf[start, end)`: field number, wire type, and where
 * its value starts and ends (a length-delimited field: its bytes; a varint: its bytes too).
 * @param {Uint8Array} buf
 * @param {number} start
 * @param {number} end
 * @returns {Generator<{ field: number, wire: number, start: number, end: number }>}
 */
function* fields(buf, start, end) {
  let at = start;
  while (at < end) {
    const [key, after] = varint(buf, at);
    const field = Math.floor(key / 8);
    const wire = key % 8;
    let s = after;
    let e;
    if (wire === 0) e = varint(buf, s)[1];
    else if (wire === 1) e = s + 8;
    else if (wire === 5) e = s + 4;
    else if (wire === 2) {
      const [len, body] = varint(buf, s);
      s = body;
      e = body + len;
    } else throw new SegmenterError('model', `segmenter: the model file has a field of wire type ${wire}, not an ONNX model`);
    if (e > end) throw new SegmenterError('model', 'segmenter: the model file ends inside a field');
    yield { field, wire, start: s, end: e };
    at = e;
  }
}

/**
 * The first length-delimited sub-message `field` of the message in `[start, end)`.
 * @param {Uint8Array} buf
 * @param {number} start
 * @param {number} end
 * @param {number} field
 */
function child(buf, start, end, field) {
  for (const f of fields(buf, start, end)) if (f.field === field && f.wire === 2) return f;
  return null;
}

/**
 * A copy of `model` (u2netp.onnx's bytes) whose declared input and output height and width are
 * `side` instead of 320. Throws a SegmenterError `model` when the file is not laid out as
 * expected (one input and the outputs of four dimensions, the input's last two 320).
 * @param {Uint8Array} model
 * @param {number} side
 * @returns {Uint8Array}
 */
export function atSide(model, side) {
  if (!(Number.isInteger(side) && side >= 128 && side < 16384)) {
    throw new SegmenterError('input', `segmenter: a side must be a whole number in 128…16383, not ${side}`);
  }
  const out = model.slice();
  if (side === MODEL_SIDE) return out;
  let inputs = 0;
  let outputs = 0;
  for (const { input, dims } of declared(out)) {
    if (dims.length !== 4) throw new SegmenterError('model', `segmenter: a model input or output has ${dims.length} dimensions, expected 4`);
    let fixed = 0;
    // A symbolic dimension (the side outputs': `dim_param`, null here) follows the input.
    for (const value of dims.slice(2)) {
      if (!value) continue;
      if (varint(out, value.start)[0] !== MODEL_SIDE || value.end - value.start !== 2) {
        throw new SegmenterError('model', `segmenter: a model input or output is not ${MODEL_SIDE} pixels wide and high`);
      }
      out[value.start] = 0x80 | (side & 0x7f);
      out[value.start + 1] = side >> 7;
      fixed++;
    }
    if (input) inputs += fixed === 2 ? 1 : 2;
    else if (fixed === 2) outputs++;
  }
  // The one input, and at least the first (used) output, were declared at the model's side.
  if (inputs !== 1 || outputs < 1) throw new SegmenterError('model', `segmenter: the model does not declare one ${MODEL_SIDE}×${MODEL_SIDE} input and output`);
  return out;
}

/**
 * The shapes the model declares for its inputs and outputs, in order (a symbolic dimension as
 * null): what `atSide` rewrote, for a test or a diagnostic.
 * @param {Uint8Array} model
 * @returns {{ inputs: (number | null)[][], outputs: (number | null)[][] }}
 */
export function declaredShapes(model) {
  /** @type {{ inputs: (number | null)[][], outputs: (number | null)[][] }} */
  const shapes = { inputs: [], outputs: [] };
  for (const { input, dims } of declared(model)) {
    (input ? shapes.inputs : shapes.outputs).push(dims.map((d) => (d ? varint(model, d.start)[0] : null)));
  }
  return shapes;
}

/**
 * The graph's declared inputs and outputs, in order: for each, whether it is an input, and
 * where each dimension's fixed value lies (its varint; null for a symbolic dimension).
 * ModelProto.graph = 7; GraphProto.input = 11, .output = 12; ValueInfoProto.type = 2;
 * TypeProto.tensor_type = 1; TypeProto.Tensor.shape = 2; TensorShapeProto.dim = 1;
 * Dimension.dim_value = 1 (onnx.proto3).
 * @param {Uint8Array} model
 * @returns {Generator<{ input: boolean, dims: ({ start: number, end: number } | null)[] }>}
 */
function* declared(model) {
  const graph = child(model, 0, model.length, 7);
  if (!graph) throw new SegmenterError('model', 'segmenter: the model file has no graph');
  for (const v of fields(model, graph.start, graph.end)) {
    if ((v.field !== 11 && v.field !== 12) || v.wire !== 2) continue;
    const type = child(model, v.start, v.end, 2);
    const tensor = type && child(model, type.start, type.end, 1);
    const shape = tensor && child(model, tensor.start, tensor.end, 2);
    const dims = shape ? [...fields(model, shape.start, shape.end)].filter((f) => f.field === 1 && f.wire === 2) : [];
    yield { input: v.field === 11, dims: dims.map((d) => [...fields(model, d.start, d.end)].find((f) => f.field === 1 && f.wire === 0) ?? null) };
  }
}
