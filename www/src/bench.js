// The bench page (bench.html): how fast the app's pipeline runs in this browser for a chosen
// resolution and detector. Each run starts its own tracker worker on the synthetic demo scene
// rendered at that size (`SynthScene.sized`: shapes, speeds and occluders scaled with the
// frame), tracks frame after frame as fast as it goes with the frame painted by the worker
// and two frames in flight (both as in the app), draws the tracked boxes here, and reports
// frames per second with the median per-frame times. A benchmark, not a test: nothing here
// judges the figure.
//
// URL parameters (for scripts/bench-browser.mjs): `?size=WxH&detector=NAME&frames=N&run=1`
// starts a run on load (`&offline=0`: the tracker keeps nothing for the offline pass, unlike
// the app with a video or the demo); `window.__bench` holds the results and the last error.

import { startWorker } from './worker/protocol.js';
import { listDetectors } from './worker/detectors.js';
import { byId, h } from './lib/dom.js';

/** Frames tracked before timing starts: the background model learns, the JIT warms up. */
export const WARMUP = 30;
/** Frames requested from the worker ahead of the one drawn, as the app's player keeps. */
const IN_FLIGHT = 2;
/** The demo scene's length: the warm-up and the timed frames must fit. */
const SCENE_FRAMES = 600;

/**
 * @typedef {{ size: string, detector: string, offline: boolean, frames: number, fps: number,
 *   detect: number, track: number, worker: number, page: number }} BenchResult
 *   `offline`: whether the tracker kept what the offline pass needs, as the app does for a video
 *   or the demo; `fps`: timed frames over the wall time they took (worker and page together);
 *   the others are medians in milliseconds per frame
 */

const state = {
  /** @type {BenchResult[]} */
  results: [],
  running: false,
  /** @type {string | null} */
  error: null,
};
/** @type {any} */ (window).__bench = state;

/** @param {number[]} xs */
function median(xs) {
  const s = [...xs].sort((a, b) => a - b);
  return s.length ? s[s.length >> 1] : NaN;
}

/**
 * "1280x720" → [1280, 720]; anything else is an error naming the value.
 * @param {string} text
 * @returns {[number, number]}
 */
export function parseSize(text) {
  const m = /^(\d+)x(\d+)$/.exec(text.trim());
  if (!m) throw new Error(`size "${text}" is not WIDTHxHEIGHT (e.g. 1280x720)`);
  return [Number(m[1]), Number(m[2])];
}

/**
 * One run: a fresh worker and a fresh frame canvas (a canvas is handed to one worker only).
 * @param {{ size: string, detector: string, offline: boolean, frames: number }} opts
 * @param {(text: string) => void} status
 * @returns {Promise<BenchResult>}
 */
async function run({ size, detector, offline, frames }, status) {
  const [width, height] = parseSize(size);
  if (!(Number.isInteger(frames) && frames >= 1 && frames <= SCENE_FRAMES - WARMUP)) {
    throw new Error(`frames ${frames}: must be a whole number in 1..=${SCENE_FRAMES - WARMUP}`);
  }
  const old = byId('bench-frame', HTMLCanvasElement);
  const canvas = /** @type {HTMLCanvasElement} */ (h('canvas', { id: 'bench-frame' }));
  old.replaceWith(canvas);
  const overlay = byId('bench-overlay', HTMLCanvasElement);
  overlay.width = width;
  overlay.height = height;
  const ctx = /** @type {CanvasRenderingContext2D} */ (overlay.getContext('2d'));
  const client = startWorker();
  try {
    await client.attach(canvas);
    await client.open({ source: { kind: 'synth', preset: 'demo', width, height }, detector, offline });
    /** @type {{ detect: number[], track: number[], worker: number[], page: number[] }} */
    const times = { detect: [], track: [], worker: [], page: [] };
    const last = WARMUP + frames;
    // As the app's player does (App.track): two frames in flight, so the worker starts the
    // next frame while this page draws the last one's overlay, and the two cores work side by
    // side instead of taking turns.
    /** @type {Array<Promise<import('./worker/protocol.js').StepResult>>} */
    const inflight = [];
    let next = 1;
    let t0 = 0;
    for (let n = 1; n <= last; n++) {
      while (inflight.length < IN_FLIGHT && next <= last) {
        const p = client.step(next++, undefined, true);
        // A failed frame is reported by the await below; the one behind it, still in flight
        // when the run stops, must not surface as an unhandled rejection.
        p.catch(() => {});
        inflight.push(p);
      }
      const r = /** @type {import('./worker/protocol.js').StepResult} */ (await inflight.shift());
      if (r.frame !== n) throw new Error(`frame ${r.frame} answered where ${n} was expected`);
      const p0 = performance.now();
      ctx.clearRect(0, 0, width, height);
      ctx.lineWidth = 2;
      ctx.strokeStyle = '#ffb84c';
      for (const s of r.shapes) ctx.strokeRect(s.bbox.x, s.bbox.y, s.bbox.w, s.bbox.h);
      const page = performance.now() - p0;
      if (n > WARMUP) {
        times.detect.push(r.timings.detect);
        times.track.push(r.timings.track);
        times.worker.push(r.timings.total);
        times.page.push(page);
      }
      if (n % 30 === 0) status(`${size}, ${detector}: frame ${n} of ${last}…`);
      // The clock starts once the warm-up's last frame is drawn: `frames` frames follow.
      if (n === WARMUP) t0 = performance.now();
    }
    const wall = performance.now() - t0;
    return {
      size,
      detector,
      offline,
      frames,
      fps: (frames * 1000) / wall,
      detect: median(times.detect),
      track: median(times.track),
      worker: median(times.worker),
      page: median(times.page),
    };
  } finally {
    client.worker.terminate();
  }
}

/** @param {BenchResult} r */
function row(r) {
  const ms = (/** @type {number} */ x) => x.toFixed(1);
  return h('tr', {}, [r.size, r.detector, r.offline ? 'yes' : 'no', String(r.frames), r.fps.toFixed(1), ms(r.detect), ms(r.track), ms(r.worker), ms(r.page)].map((t) => h('td', {}, [t])));
}

function main() {
  const sizeSel = byId('bench-size', HTMLSelectElement);
  const detSel = byId('bench-detector', HTMLSelectElement);
  const framesIn = byId('bench-frames', HTMLInputElement);
  const offlineIn = byId('bench-offline', HTMLInputElement);
  const button = byId('bench-run', HTMLButtonElement);
  const statusEl = byId('bench-status');
  const body = /** @type {HTMLElement} */ (byId('bench-results').querySelector('tbody'));
  detSel.replaceChildren(...listDetectors().map((d) => new Option(d.label, d.name)));
  detSel.value = 'background';
  const status = (/** @type {string} */ t) => (statusEl.textContent = t);

  const params = new URLSearchParams(location.search);
  const size = params.get('size');
  if (size) {
    // A size not in the menu is added to it (any WxH the scene accepts can be measured).
    if (![...sizeSel.options].some((o) => o.value === size)) sizeSel.add(new Option(size.replace('x', '×'), size));
    sizeSel.value = size;
  }
  const det = params.get('detector');
  let bad = null;
  if (det) {
    if ([...detSel.options].some((o) => o.value === det)) detSel.value = det;
    else bad = `unknown detector "${det}" (have: ${[...detSel.options].map((o) => o.value).join(', ')})`;
  }
  const frames = params.get('frames');
  if (frames) framesIn.value = frames;
  if (params.get('offline') === '0') offlineIn.checked = false;

  const start = async () => {
    if (state.running) return;
    state.running = true;
    state.error = null;
    button.disabled = true;
    const opts = { size: sizeSel.value, detector: detSel.value, offline: offlineIn.checked, frames: Number(framesIn.value) };
    try {
      const r = await run(opts, status);
      state.results.push(r);
      body.append(row(r));
      status(`${r.size}, ${r.detector}: ${r.fps.toFixed(1)} fps over ${r.frames} frames.`);
    } catch (e) {
      state.error = e instanceof Error ? e.message : String(e);
      status(`Failed: ${state.error}`);
    } finally {
      state.running = false;
      button.disabled = false;
    }
  };
  byId('bench-form').addEventListener('submit', (e) => {
    e.preventDefault();
    void start();
  });
  if (bad) {
    state.error = bad;
    status(`Failed: ${bad}`);
  } else if (params.get('run') === '1') void start();
}

main();
