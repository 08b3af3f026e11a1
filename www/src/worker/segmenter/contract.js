// What the segmenter's callers and its worker share, without the net's loading code: the
// input and output sizes of the model (U²-Net-p at 320×320) and the typed error.

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

/** Side of the model's square input and output. */
export const SIDE = 320;
/** Floats run() takes: 3 channels (RGB, CHW order) of SIDE·SIDE. */
export const INPUT_LENGTH = 3 * SIDE * SIDE;
/** Floats run() returns: one probability per pixel of the SIDE·SIDE input. */
export const OUTPUT_LENGTH = SIDE * SIDE;

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

