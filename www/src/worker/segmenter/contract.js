// What the segmenter's callers and its worker share, without the net's loading code: the
// input and output sizes of the model (U²-Net-p, 320×320 as its file declares it, smaller for a
// crop around a given box) and the typed error.

/**
 * @typedef {'fetch' | 'integrity' | 'insecure' | 'runtime' | 'model' | 'input' | 'run' | 'disposed' | 'worker' | 'protocol'} SegmenterErrorCode
 *   `fetch`: a file could not be fetched (offline before first use, HTTP error); `integrity`: a
 *   file's size or hash is wrong; `insecure`: no crypto.subtle (the page is not a secure
 *   context) to check the hash with; `runtime`: no backend could start (no wasm SIMD, the
 *   runtime failed to load); `model`: the model is not the expected one (inputs, outputs);
 *   `input`: run() given the wrong input; `run`: the inference failed; `disposed`: used after
 *   dispose(); `worker`: the segmenter worker failed or could not start; `protocol`: a message
 *   the worker does not know
 */

/** Side of the model's square input and output as its file declares it: the whole frame's. */
export const SIDE = 320;
/**
 * Side a crop around a given box (a box a person drew) runs at: half the arithmetic of 320 for
 * the same J from boxes (the core's `segment::BOX_SIDE`, where the measurement is named).
 */
export const BOX_SIDE = 256;
/** Floats run() takes at SIDE: 3 channels (RGB, CHW order) of SIDE·SIDE. */
export const INPUT_LENGTH = 3 * SIDE * SIDE;
/** Floats run() returns at SIDE: one probability per pixel of the SIDE·SIDE input. */
export const OUTPUT_LENGTH = SIDE * SIDE;

/**
 * Floats of an input at `side`.
 * @param {number} side
 */
export const inputLength = (side) => 3 * side * side;

/**
 * The side of an input of `length` floats (3·side·side, side a multiple of 32 from 128 to
 * SIDE, the sides the core runs the net at), or null.
 * @param {number} length
 * @returns {number | null}
 */
export function sideOfInput(length) {
  const side = Math.round(Math.sqrt(length / 3));
  return 3 * side * side === length && side >= 128 && side <= SIDE && side % 32 === 0 ? side : null;
}

/** An error of the segmenter, with a code a caller can act on (see SegmenterErrorCode). */
export class SegmenterError extends Error {
  /**
   * @param {SegmenterErrorCode} code
   * @param {string} message
   * @param {{ cause?: unknown }} [options]
   */
  constructor(code, message, options) {
    super(message, options);
    this.name = 'SegmenterError';
    /** @type {SegmenterErrorCode} */
    this.code = code;
  }
}

