// The SSD detector's arithmetic on synthetic tensors, against values worked out by hand from
// MediaPipe's SsdAnchorsCalculator / TensorsToDetectionsCalculator / NonMaxSuppressionCalculator.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import {
  ANCHORS,
  DECODE,
  decode,
  foreground,
  iou,
  maskInBox,
  nms,
  parseLabels,
  ssdAnchors,
  toInput,
  toPixels,
} from '../src/worker/detectors/ssd-decode.js';

const close = (/** @type {number} */ a, /** @type {number} */ b, eps = 1e-5) =>
  assert.ok(Math.abs(a - b) <= eps, `${a} ≠ ${b}`);

/** @param {Float32Array} a @param {number} i */
const anchor = (a, i) => Array.from(a.subarray(4 * i, 4 * i + 4));

test('the model has 1917 anchors: 19²·3 + 10²·6 + 5²·6 + 3²·6 + 2²·6 + 1·6', () => {
  const a = ssdAnchors();
  assert.equal(a.length / 4, 1917);
  assert.equal(19 * 19 * 3 + 10 * 10 * 6 + 5 * 5 * 6 + 3 * 3 * 6 + 2 * 2 * 6 + 6, 1917);
  assert.equal(a.length / 4, DECODE.numBoxes);
});

test('lowest layer: three reduced anchors per cell (scale 0.1 square, then 0.2 at ratios 2 and ½)', () => {
  const a = ssdAnchors();
  const c = 0.5 / 19;
  [[c, c, 0.1, 0.1], [c, c, 0.2 * Math.SQRT2, 0.2 / Math.SQRT2], [c, c, 0.2 / Math.SQRT2, 0.2 * Math.SQRT2]].forEach(
    (want, i) => anchor(a, i).forEach((v, k) => close(v, want[k])),
  );
  // Row-major cells: anchor 3 is the second cell of the first row.
  close(anchor(a, 3)[0], 1.5 / 19);
  close(anchor(a, 3)[1], c);
  // Last cell of the lowest layer.
  close(anchor(a, 1082)[0], 18.5 / 19);
  close(anchor(a, 1082)[1], 18.5 / 19);
});

test('second layer: five ratios at scale 0.35 plus the interpolated square sqrt(0.35·0.5)', () => {
  const a = ssdAnchors();
  const s = 0.35; // 0.2 + 0.75·1/5
  const want = [
    [s, s],
    [s * Math.sqrt(2), s / Math.sqrt(2)],
    [s * Math.sqrt(0.5), s / Math.sqrt(0.5)],
    [s * Math.sqrt(3), s / Math.sqrt(3)],
    [s * Math.sqrt(0.3333), s / Math.sqrt(0.3333)],
    [Math.sqrt(0.35 * 0.5), Math.sqrt(0.35 * 0.5)],
  ];
  want.forEach(([w, h], k) => {
    const [x, y, aw, ah] = anchor(a, 1083 + k);
    close(x, 0.05);
    close(y, 0.05);
    close(aw, w);
    close(ah, h);
  });
});

test('top layer: one cell in the centre, scale 0.95, interpolated towards 1', () => {
  const a = ssdAnchors();
  const [x, y, w, h] = anchor(a, 1916);
  close(x, 0.5);
  close(y, 0.5);
  close(w, Math.sqrt(0.95));
  close(h, Math.sqrt(0.95));
  const [, , w0] = anchor(a, 1911);
  close(w0, 0.95);
});

test('anchors: same-stride layers share a grid; no strides is an error', () => {
  const a = ssdAnchors({ ...ANCHORS, strides: [150, 150], reduceBoxesInLowestLayer: false, aspectRatios: [1] });
  // One 2×2 grid, each cell with both layers' anchors: (1 ratio + 1 interpolated) × 2 layers.
  assert.equal(a.length / 4, 2 * 2 * 4);
  assert.throws(() => ssdAnchors({ ...ANCHORS, strides: [] }), /no strides/);
});

/** One anchor at (0.5, 0.5) of size 0.2 × 0.4, two classes plus the background. */
function tiny() {
  return { anchors: Float32Array.from([0.5, 0.5, 0.2, 0.4]), o: { ...DECODE, numBoxes: 1, numClasses: 3 } };
}

test('decode: centre offsets over x/y scale 10, sizes exp(t / 5), sigmoid of the best class', () => {
  const { anchors, o } = tiny();
  const [c] = decode([1, 2, 0, 5 * Math.LN2], [10, 0, 2], anchors, o);
  // yc = 1/10·0.4 + 0.5 = 0.54; xc = 2/10·0.2 + 0.5 = 0.54; h = 0.4; w = 2·0.2 = 0.4.
  close(c.xmin, 0.34);
  close(c.ymin, 0.34);
  close(c.xmax, 0.74);
  close(c.ymax, 0.74);
  // The background logit (10) is ignored: class 2, sigmoid(2).
  assert.equal(c.class, 2);
  close(c.score, 1 / (1 + Math.exp(-2)));
});

test('decode: the score threshold is inclusive and applies after the sigmoid', () => {
  const { anchors, o } = tiny();
  assert.equal(decode([0, 0, 0, 0], [9, 0, -1], anchors, o).length, 1, 'sigmoid(0) = 0.5 passes 0.5');
  assert.equal(decode([0, 0, 0, 0], [9, -0.01, -1], anchors, o).length, 0);
  assert.equal(decode([0, 0, 0, 0], [9, -0.01, -1], anchors, { ...o, minScore: 0.3 }).length, 1);
});

test('decode: tensor sizes are checked', () => {
  const { anchors, o } = tiny();
  assert.throws(() => decode([0, 0, 0], [0, 0, 0], anchors, o), /box tensor/);
  assert.throws(() => decode([0, 0, 0, 0], [0, 0], anchors, o), /score tensor/);
  assert.throws(() => decode([0, 0, 0, 0], [0, 0, 0], new Float32Array(8), o), /anchors/);
});

test('decode on the real anchors: one confident anchor with zero offsets is its anchor box', () => {
  const a = ssdAnchors();
  const boxes = new Float32Array(4 * 1917);
  const scores = new Float32Array(24 * 1917).fill(-8);
  scores[1916 * 24 + 23] = 3; // the centre anchor, class 23 (Car)
  const got = decode(boxes, scores, a);
  assert.equal(got.length, 1);
  const s = Math.sqrt(0.95) / 2;
  close(got[0].xmin, 0.5 - s);
  close(got[0].ymax, 0.5 + s);
  assert.equal(got[0].class, 23);
});

test('iou of corner boxes', () => {
  const a = { xmin: 0, ymin: 0, xmax: 2, ymax: 2 };
  close(iou(a, { xmin: 1, ymin: 0, xmax: 3, ymax: 2 }), 2 / 6);
  assert.equal(iou(a, { xmin: 2, ymin: 0, xmax: 3, ymax: 2 }), 0, 'touching');
  assert.equal(iou(a, a), 1);
});

test('nms: highest first, suppresses above the threshold (not at it), across classes by default', () => {
  const A = { xmin: 0, ymin: 0, xmax: 1, ymax: 1, score: 0.9, class: 23 };
  const B = { xmin: 0.1, ymin: 0, xmax: 1.1, ymax: 1, score: 0.8, class: 18 }; // IoU 0.9/1.1 with A
  const C = { xmin: 2, ymin: 2, xmax: 3, ymax: 3, score: 0.7, class: 23 };
  const D = { xmin: 0, ymin: 0, xmax: 1, ymax: 2, score: 0.6, class: 23 }; // IoU exactly 0.5 with A
  assert.deepEqual(nms([D, C, B, A]), [A, C, D]);
  assert.deepEqual(nms([D, C, B, A], { perClass: true }), [A, B, C, D]);
  assert.deepEqual(nms([D, C, B, A], { iou: 0.45 }), [A, C]);
  assert.deepEqual(nms([D, C, B, A], { maxDetections: 1 }), [A]);
  assert.deepEqual(nms([]), []);
});

test('labels: one per line, the trailing newline is no class', () => {
  assert.deepEqual(parseLabels('???\nBicycle\r\nCar\n'), ['???', 'Bicycle', 'Car']);
});

test('toPixels: stretched back to the frame, rounded, clipped; outside is null', () => {
  assert.deepEqual(toPixels({ xmin: 0.25, ymin: 0.5, xmax: 0.75, ymax: 1.2 }, 854, 480), { x: 214, y: 240, w: 427, h: 240 });
  assert.deepEqual(toPixels({ xmin: -0.5, ymin: -0.1, xmax: 0.1, ymax: 0.1 }, 100, 50), { x: 0, y: 0, w: 10, h: 5 });
  assert.equal(toPixels({ xmin: 1.1, ymin: 0, xmax: 1.5, ymax: 1 }, 100, 50), null);
});

test('toInput: RGBA bytes to RGB floats in [-1, 1]', () => {
  const input = new Float32Array(6);
  toInput(Uint8ClampedArray.from([0, 255, 51, 7, 255, 0, 0, 0]), input);
  assert.deepEqual(Array.from(input, (v) => Math.round(v * 1000) / 1000), [-1, 1, -0.6, 1, -1, -1]);
  assert.throws(() => toInput(new Uint8ClampedArray(4), input), /RGBA/);
});

test('maskInBox: foreground inside the box when it fills enough of it, else the filled box', () => {
  // 4×3 frame; box (1,1) 2×2 holds three foreground pixels and one background pixel.
  const fg = Uint8Array.from([1, 1, 1, 1, 0, 1, 1, 0, 0, 0, 1, 0]);
  const box = { x: 1, y: 1, w: 2, h: 2 };
  assert.deepEqual(maskInBox(fg, 4, box, 0.5), { data: Uint8Array.from([1, 1, 0, 1]), filled: false });
  assert.deepEqual(maskInBox(fg, 4, box, 0.8), { data: Uint8Array.from([1, 1, 1, 1]), filled: true });
  assert.deepEqual(maskInBox(null, 4, box, 0), { data: Uint8Array.from([1, 1, 1, 1]), filled: true });
  assert.equal(maskInBox(new Uint8Array(12), 4, box, 0).filled, true, 'no foreground at all');
});

test('foreground: cropped masks painted into one frame, clipped at the borders', () => {
  const fg = foreground(
    [
      { mask: { x: -1, y: 0, width: 2, height: 1, data: [1, 1] } },
      { mask: { x: 2, y: 1, width: 2, height: 2, data: [1, 0, 0, 1] } },
      {},
    ],
    3,
    2,
  );
  assert.deepEqual(Array.from(fg), [1, 0, 0, 0, 0, 1]);
});
