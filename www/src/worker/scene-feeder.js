// The scene feeder: a worker started by the tracker worker that renders the synthetic scene's
// frames ahead of the one being tracked, as a camera or a video decoder delivers frames while
// the previous one is processed. Rendering a frame (the scene, illumination drift, sensor
// noise) costs about as much as detecting it, so on one worker the two took turns; here the
// scene renders frame n+1 on another core while the tracker worker detects and tracks frame n.
//
// Protocol (messages from the tracker worker, answered in order; see ./feed.js):
// - `{ type: 'open', preset, width?, height? }` → `{ type: 'opened', width, height, frames }`
//   (the scene as the tracker worker's own `SynthScene` makes it: same preset, same size, same
//   frames, bit for bit);
// - `{ type: 'render', frame, buffer? }` → `{ type: 'frame', frame, pixels, groundTruth }`:
//   the frame's RGBA bytes in `pixels` (an ArrayBuffer, transferred; `buffer`, when sent and
//   of the right size, is reused for it, so frames do not allocate) and its ground truth;
// - any failure → `{ type: 'error', frame?, message }`.

import { loadCore } from '../lib/core.js';

const ctx = /** @type {DedicatedWorkerGlobalScope} */ (/** @type {unknown} */ (self));

/**
 * @type {{ scene: import('../../pkg/shapetrack.js').SynthScene,
 *   buffer: import('../../pkg/shapetrack.js').FrameBuffer, memory: WebAssembly.Memory } | null}
 */
let state = null;

/** Messages are handled one at a time, in order. */
let queue = Promise.resolve();

ctx.addEventListener('message', (/** @type {MessageEvent} */ e) => {
  const msg = /** @type {import('./feed.js').FeederRequest} */ (e.data);
  queue = queue.then(() => handle(msg));
});

/** @param {import('./feed.js').FeederRequest} msg */
async function handle(msg) {
  try {
    if (msg.type === 'open') {
      const { core, memory } = await loadCore();
      state?.scene.free();
      state?.buffer.free();
      const scene =
        msg.width !== undefined && msg.height !== undefined
          ? core.SynthScene.sized(msg.preset, msg.width, msg.height)
          : new core.SynthScene(msg.preset);
      state = { scene, buffer: new core.FrameBuffer(scene.width, scene.height), memory };
      ctx.postMessage({ type: 'opened', width: scene.width, height: scene.height, frames: scene.frames });
      return;
    }
    if (!state) throw new Error('the scene feeder has no scene: send "open" first');
    const { scene, buffer, memory } = state;
    const sf = scene.render(msg.frame, buffer);
    const groundTruth = sf.groundTruth();
    sf.free();
    // A fresh view: any wasm allocation may have grown (and detached) memory.
    const src = new Uint8Array(memory.buffer, buffer.ptr(), buffer.len());
    const out = msg.buffer && msg.buffer.byteLength === src.length ? msg.buffer : new ArrayBuffer(src.length);
    new Uint8Array(out).set(src);
    ctx.postMessage({ type: 'frame', frame: msg.frame, pixels: out, groundTruth }, [out]);
  } catch (err) {
    const message = err instanceof Error ? err.message : String(err);
    ctx.postMessage({ type: 'error', frame: msg.type === 'render' ? msg.frame : undefined, message });
  }
}
