// One timed pass of the wasm core over a synthetic app scene, shared by the wasm benchmarks
// (bench-wasm.mjs, the wasm half of `shapetrack bench --wasm`; bench-wasm-ab.mjs, builds
// against each other): a new tracker with the mask preset tracks every frame of the scene, and
// only `Tracker.update` is timed (the call into wasm and the shapes coming back), not rendering.

/**
 * @param {typeof import('../www/pkg/shapetrack.js')} st  the build's bindings, initialised
 * @param {import('../www/pkg/shapetrack.js').SynthScene} scene
 * @param {import('../www/pkg/shapetrack.js').FrameBuffer} buf  a frame buffer of the scene's size
 * @returns {{ ms: number, detections: number, tracker: import('../www/pkg/shapetrack.js').Tracker }}
 *   the milliseconds spent in `update` over the pass, the detections tracked, and the tracker
 *   (the caller frees it)
 */
export function trackPass(st, scene, buf) {
  const tracker = new st.Tracker({ preset: 'masks' });
  let ms = 0;
  let detections = 0;
  for (let n = 1; n <= scene.frames; n++) {
    const frame = scene.render(n, buf);
    const dets = frame.detections();
    detections += dets.len;
    const t0 = performance.now();
    tracker.update(n, buf, dets);
    ms += performance.now() - t0;
    dets.free();
    frame.free();
  }
  return { ms, detections, tracker };
}
