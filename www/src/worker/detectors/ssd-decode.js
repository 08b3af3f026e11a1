// The SSD detector's arithmetic, in plain JS (no DOM, no wasm, no model) so `node --test` checks
// it on synthetic tensors: MediaPipe's SSD anchors, box decoding, non-maximum suppression, the
// label list, and the way back from the model's 300×300 input to frame pixels and masks.
//
// The settings are those of MediaPipe's Objectron detection subgraph for this very model
// (mediapipe/modules/objectron/object_detection_oid_v4_cpu.pbtxt): SsdAnchorsCalculator,
// TensorsToDetectionsCalculator and NonMaxSuppressionCalculator options. The model reads a
// stretched (not letterboxed) 300×300 RGB image scaled to [-1, 1].

/**
 * @typedef {{
 *   inputWidth: number, inputHeight: number, minScale: number, maxScale: number,
 *   anchorOffsetX: number, anchorOffsetY: number, strides: number[], aspectRatios: number[],
 *   reduceBoxesInLowestLayer: boolean, interpolatedScaleAspectRatio: number,
 *   fixedAnchorSize: boolean,
 * }} AnchorOptions  SsdAnchorsCalculatorOptions (single-scale generation; `num_layers` is
 *   `strides.length`)
 *
 * @typedef {{
 *   numClasses: number, numBoxes: number, xScale: number, yScale: number, wScale: number,
 *   hScale: number, ignoreClasses: number[], sigmoidScore: boolean, minScore: number,
 * }} DecodeOptions  TensorsToDetectionsCalculatorOptions (`num_coords` 4, exponential box size)
 *
 * @typedef {{ xmin: number, ymin: number, xmax: number, ymax: number, score: number, class: number }} Candidate
 *   a decoded box in normalised input coordinates (0–1 across the 300×300 input)
 *
 * @typedef {{ x: number, y: number, w: number, h: number }} PixelBox
 */

/** @type {Readonly<AnchorOptions>} */
export const ANCHORS = Object.freeze({
  inputWidth: 300,
  inputHeight: 300,
  minScale: 0.2,
  maxScale: 0.95,
  anchorOffsetX: 0.5,
  anchorOffsetY: 0.5,
  strides: [16, 32, 64, 128, 256, 512],
  aspectRatios: [1.0, 2.0, 0.5, 3.0, 0.3333],
  reduceBoxesInLowestLayer: true,
  // The proto's default, left implicit in the graph: one more square anchor per cell, at the
  // geometric mean of this layer's scale and the next one's.
  interpolatedScaleAspectRatio: 1.0,
  fixedAnchorSize: false,
});

/** @type {Readonly<DecodeOptions>} */
export const DECODE = Object.freeze({
  numClasses: 24,
  numBoxes: 1917,
  xScale: 10,
  yScale: 10,
  wScale: 5,
  hScale: 5,
  // Class 0 is the background ("???" in the label list).
  ignoreClasses: [0],
  sigmoidScore: true,
  minScore: 0.5,
});

/** NonMaxSuppressionCalculator: hard (unweighted) suppression above this IoU, at most 100 kept. */
export const NMS = Object.freeze({ iou: 0.5, maxDetections: 100 });

/** MediaPipe's layer scale: linear from `min` to `max` over the layers. */
function layerScale(/** @type {number} */ min, /** @type {number} */ max, /** @type {number} */ i, /** @type {number} */ n) {
  return n === 1 ? (min + max) / 2 : min + ((max - min) * i) / (n - 1);
}

/**
 * SSD anchors as SsdAnchorsCalculator generates them, in its order (layer, row, column, anchor):
 * `[xCenter, yCenter, w, h]` per anchor, normalised to the input.
 * @param {AnchorOptions} [o]
 * @returns {Float32Array} 4 numbers per anchor
 */
export function ssdAnchors(o = ANCHORS) {
  const n = o.strides.length;
  if (n === 0) throw new Error('ssdAnchors: no strides');
  /** @type {number[]} */
  const out = [];
  let layer = 0;
  while (layer < n) {
    /** @type {number[]} */
    const heights = [];
    /** @type {number[]} */
    const widths = [];
    /** @type {number[]} */
    const ratios = [];
    /** @type {number[]} */
    const scales = [];
    // Consecutive layers with the same stride share one grid.
    let last = layer;
    while (last < n && o.strides[last] === o.strides[layer]) {
      const scale = layerScale(o.minScale, o.maxScale, last, n);
      if (last === 0 && o.reduceBoxesInLowestLayer) {
        ratios.push(1.0, 2.0, 0.5);
        scales.push(0.1, scale, scale);
      } else {
        for (const r of o.aspectRatios) {
          ratios.push(r);
          scales.push(scale);
        }
        if (o.interpolatedScaleAspectRatio > 0) {
          const next = last === n - 1 ? 1.0 : layerScale(o.minScale, o.maxScale, last + 1, n);
          scales.push(Math.sqrt(scale * next));
          ratios.push(o.interpolatedScaleAspectRatio);
        }
      }
      last++;
    }
    for (let i = 0; i < ratios.length; i++) {
      const s = Math.sqrt(ratios[i]);
      heights.push(scales[i] / s);
      widths.push(scales[i] * s);
    }
    const stride = o.strides[layer];
    const fh = Math.ceil(o.inputHeight / stride);
    const fw = Math.ceil(o.inputWidth / stride);
    for (let y = 0; y < fh; y++) {
      for (let x = 0; x < fw; x++) {
        for (let a = 0; a < heights.length; a++) {
          out.push(
            (x + o.anchorOffsetX) / fw,
            (y + o.anchorOffsetY) / fh,
            o.fixedAnchorSize ? 1 : widths[a],
            o.fixedAnchorSize ? 1 : heights[a],
          );
        }
      }
    }
    layer = last;
  }
  return Float32Array.from(out);
}

/** @param {number} x */
const sigmoid = (x) => 1 / (1 + Math.exp(-x));

/**
 * TensorsToDetectionsCalculator: for every anchor the best class that is not ignored, its
 * (sigmoid) score, and — only for anchors scoring at least `minScore`, which is all the later
 * steps look at — the box decoded from `[ty, tx, th, tw]` against the anchor.
 * @param {ArrayLike<number>} boxes `numBoxes × 4` raw box encodings
 * @param {ArrayLike<number>} scores `numBoxes × numClasses` raw class logits
 * @param {Float32Array} anchors from `ssdAnchors`
 * @param {DecodeOptions} [o]
 * @returns {Candidate[]}
 */
export function decode(boxes, scores, anchors, o = DECODE) {
  const n = o.numBoxes;
  if (anchors.length !== 4 * n) throw new Error(`decode: ${anchors.length / 4} anchors for ${n} boxes`);
  if (boxes.length !== 4 * n) throw new Error(`decode: box tensor has ${boxes.length} values, expected ${4 * n}`);
  if (scores.length !== o.numClasses * n) {
    throw new Error(`decode: score tensor has ${scores.length} values, expected ${o.numClasses * n}`);
  }
  const ignore = new Set(o.ignoreClasses);
  /** @type {Candidate[]} */
  const out = [];
  for (let i = 0; i < n; i++) {
    let best = -Infinity;
    let cls = -1;
    const row = i * o.numClasses;
    for (let c = 0; c < o.numClasses; c++) {
      if (ignore.has(c)) continue;
      const v = scores[row + c];
      if (v > best) {
        best = v;
        cls = c;
      }
    }
    if (cls < 0) continue;
    const score = o.sigmoidScore ? sigmoid(best) : best;
    if (!(score >= o.minScore)) continue;
    const ax = anchors[4 * i];
    const ay = anchors[4 * i + 1];
    const aw = anchors[4 * i + 2];
    const ah = anchors[4 * i + 3];
    const yc = (boxes[4 * i] / o.yScale) * ah + ay;
    const xc = (boxes[4 * i + 1] / o.xScale) * aw + ax;
    const h = Math.exp(boxes[4 * i + 2] / o.hScale) * ah;
    const w = Math.exp(boxes[4 * i + 3] / o.wScale) * aw;
    out.push({ xmin: xc - w / 2, ymin: yc - h / 2, xmax: xc + w / 2, ymax: yc + h / 2, score, class: cls });
  }
  return out;
}

/**
 * Intersection over union of two boxes given by their corners (0 when either is empty).
 * @param {{ xmin: number, ymin: number, xmax: number, ymax: number }} a
 * @param {{ xmin: number, ymin: number, xmax: number, ymax: number }} b
 */
export function iou(a, b) {
  const iw = Math.min(a.xmax, b.xmax) - Math.max(a.xmin, b.xmin);
  const ih = Math.min(a.ymax, b.ymax) - Math.max(a.ymin, b.ymin);
  if (iw <= 0 || ih <= 0) return 0;
  const inter = iw * ih;
  const union = (a.xmax - a.xmin) * (a.ymax - a.ymin) + (b.xmax - b.xmin) * (b.ymax - b.ymin) - inter;
  return union > 0 ? inter / union : 0;
}

/**
 * Hard non-maximum suppression, highest score first: a box is dropped when its IoU with a box
 * already kept exceeds `iou`. MediaPipe's graph suppresses across classes (`perClass` false):
 * this model often fires "Car" and "Vehicle" on the same car, which must stay one object for
 * the tracker. `perClass` suppresses only within a class.
 * @param {Candidate[]} candidates
 * @param {{ iou?: number, maxDetections?: number, perClass?: boolean }} [o]
 * @returns {Candidate[]} kept, by decreasing score
 */
export function nms(candidates, o = {}) {
  const threshold = o.iou ?? NMS.iou;
  const max = o.maxDetections ?? NMS.maxDetections;
  const perClass = o.perClass ?? false;
  // Stable sort: equal scores keep the anchor order, as MediaPipe's does.
  const sorted = candidates
    .map((c, i) => ({ c, i }))
    .sort((a, b) => b.c.score - a.c.score || a.i - b.i)
    .map(({ c }) => c);
  /** @type {Candidate[]} */
  const kept = [];
  for (const c of sorted) {
    if (kept.length >= max) break;
    if (kept.some((k) => (!perClass || k.class === c.class) && iou(k, c) > threshold)) continue;
    kept.push(c);
  }
  return kept;
}

/**
 * The label list (one name a line; line i is class i; a trailing newline is not a class).
 * @param {string} text
 * @returns {string[]}
 */
export function parseLabels(text) {
  const lines = text.replace(/\r\n?/g, '\n').split('\n');
  if (lines.length && lines[lines.length - 1] === '') lines.pop();
  return lines.map((l) => l.trim());
}

/**
 * A normalised box on the stretched input, in frame pixels: whole pixels, clipped to the
 * frame, or null when nothing of it is inside.
 * @param {{ xmin: number, ymin: number, xmax: number, ymax: number }} c
 * @param {number} width frame width
 * @param {number} height frame height
 * @returns {PixelBox | null}
 */
export function toPixels(c, width, height) {
  const x0 = Math.max(0, Math.round(c.xmin * width));
  const y0 = Math.max(0, Math.round(c.ymin * height));
  const x1 = Math.min(width, Math.round(c.xmax * width));
  const y1 = Math.min(height, Math.round(c.ymax * height));
  if (!(x1 > x0 && y1 > y0)) return null;
  return { x: x0, y: y0, w: x1 - x0, h: y1 - y0 };
}

/**
 * Writes an RGBA frame into the model's input: RGB, row-major, scaled to [-1, 1].
 * @param {Uint8ClampedArray | Uint8Array} rgba `4·w·h` bytes (already 300×300)
 * @param {Float32Array} input `3·w·h` floats
 */
export function toInput(rgba, input) {
  const n = input.length / 3;
  if (rgba.length !== 4 * n) throw new Error(`toInput: ${rgba.length} RGBA bytes for ${n} pixels`);
  for (let i = 0, j = 0; i < n; i++, j += 4) {
    input[3 * i] = rgba[j] / 127.5 - 1;
    input[3 * i + 1] = rgba[j + 1] / 127.5 - 1;
    input[3 * i + 2] = rgba[j + 2] / 127.5 - 1;
  }
}

/**
 * The object's mask inside its box: the foreground pixels there when they fill at least
 * `minFill` of the box, else (a still object, a moving camera, a detector with no foreground)
 * the filled box.
 * @param {Uint8Array | null} fg frame-sized foreground (non-zero = moving), or null for none
 * @param {number} width frame width
 * @param {PixelBox} box inside the frame
 * @param {number} minFill fraction of the box, 0–1
 * @returns {{ data: Uint8Array, filled: boolean }} `box.w·box.h` bytes, 1 = object
 */
export function maskInBox(fg, width, box, minFill) {
  const data = new Uint8Array(box.w * box.h);
  if (fg) {
    let count = 0;
    for (let y = 0; y < box.h; y++) {
      const src = (box.y + y) * width + box.x;
      const dst = y * box.w;
      for (let x = 0; x < box.w; x++) {
        if (fg[src + x]) {
          data[dst + x] = 1;
          count++;
        }
      }
    }
    if (count > 0 && count >= minFill * box.w * box.h) return { data, filled: false };
  }
  data.fill(1);
  return { data, filled: true };
}

/**
 * Paints cropped masks (as the background detector returns them) into one frame-sized
 * foreground image.
 * @param {Iterable<{ mask?: { x: number, y: number, width: number, height: number, data: ArrayLike<number> } }>} dets
 * @param {number} width
 * @param {number} height
 * @param {Uint8Array} [out] reused when its size fits
 * @returns {Uint8Array}
 */
export function foreground(dets, width, height, out) {
  const fg = out && out.length === width * height ? out : new Uint8Array(width * height);
  fg.fill(0);
  for (const d of dets) {
    const m = d.mask;
    if (!m) continue;
    for (let y = 0; y < m.height; y++) {
      const fy = m.y + y;
      if (fy < 0 || fy >= height) continue;
      for (let x = 0; x < m.width; x++) {
        const fx = m.x + x;
        if (fx >= 0 && fx < width && m.data[y * m.width + x]) fg[fy * width + fx] = 1;
      }
    }
  }
  return fg;
}
