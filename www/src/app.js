// The app controller: owns the state (source, frame, selection, track table) and wires the
// views, the tracker worker and the wasm core on the page together. Views render from state;
// every change goes through a method here and ends in `render()`.

import { EditModel, EditError } from './model/edits.js';
import { runCommand, renumber, validSelection } from './model/commands.js';
import { Session } from './model/session.js';
import { Scorer, scoreInputs } from './model/scoring.js';
import { TrackTable } from './model/tracks.js';
import {
  FollowError,
  bitmapBox,
  checkShape,
  commitFollow,
  correctionLeg,
  followLegs,
  clipLegs,
  followedRun,
  isFollowed,
  rasterize,
  shiftBitmap,
  stepRecord,
} from './model/follow.js';
import { ShapeTool } from './view/shapetool.js';
import { Stage } from './view/stage.js';
import { Timeline } from './view/timeline.js';
import { Panel } from './view/panel.js';
import { FpsMeter } from './lib/fps.js';
import { colorOf } from './lib/colors.js';
import { byId } from './lib/dom.js';
import { startWorker } from './worker/protocol.js';
import { listDetectors } from './worker/detectors.js';
import { videoSource, imageSource, webcamSource } from './sources/sources.js';
import { FORMATS, guessFormat, exportName, formatInfo } from './io/formats.js';

/**
 * @typedef {import('./lib/core.js').Core} Core
 * @typedef {import('./model/tracks.js').TrackRecord} TrackRecord
 * @typedef {import('./sources/sources.js').Source} Source
 * @typedef {import('./worker/protocol.js').StepResult & { painted: boolean }} StepResult
 * @typedef {import('./io/formats.js').FormatId} FormatId
 * @typedef {{ kind: 'synth', name: string, width: number, height: number, frames: number, fps: number }} SynthSource
 * @typedef {Source | SynthSource} AnySource
 */

/** Redraw at most this often (ms) while tracking offline. */
const OFFLINE_DRAW_MS = 250;
/** Share of the offline progress bar taken by the online pass; the re-linker has the rest. */
const ONLINE_SHARE = 0.9;
/** The offline pass's phases after the online pass, in order, as the status line names them. */
const PHASES = /** @type {const} */ ({
  candidates: 'finding broken tracks',
  appearance: 'comparing appearances',
  matching: 'choosing joins',
  filling: 'filling gaps',
});

export class App {
  /** @param {Core} core the page's wasm instance (formats, masks, metrics) */
  constructor(core) {
    this.core = core;
    this.worker = startWorker();
    this.model = new EditModel();
    /** @type {TrackTable | null} */
    this.gt = null;
    this.gtName = '';
    /** @type {AnySource | null} */
    this.source = null;
    /** The session's phase (idle → tracking → finishing → finished), frames and progress. */
    this.session = new Session();
    this.cur = 0;
    this.playing = false;
    /** @type {Promise<void> | null} */
    this.loop = null;
    /** @type {'online' | 'offline'} */
    this.mode = 'online';
    /** @type {'realtime' | 'max'} */
    this.speed = 'realtime';
    /**
     * The detector picked in the menu. `auto` (the default) judges videos, image sequences and
     * the webcam from their first frames (static camera: background detector; moving: the
     * moving-camera one); the synthetic demo keeps the background detector, whose figures on
     * it the docs quote.
     */
    this.detector = 'auto';
    /** @type {import('./worker/detectors.js').Choice | null} what `auto` chose for this source */
    this.detectorChoice = null;
    /** @type {import('../pkg/shapetrack.js').ScenePreset} the synthetic scene the demo opens */
    this.scene = 'demo';
    /**
     * Tracker settings over the detector's own (`?preset=default` starts from the core's box-mode
     * defaults instead of the mask preset the mask detectors use); null: the detector's.
     * @type {import('../pkg/shapetrack.js').TrackerSettings | null}
     */
    this.tracker = null;
    /**
     * Offline-pass settings over the core's defaults (re-linker, gap filling; `?offline=` with
     * JSON, e.g. `{"fill":{"max_gap":30}}`); null: the defaults. The frame rate is the source's.
     * @type {Omit<import('../pkg/shapetrack.js').OfflineSettings, 'fps'> | null}
     */
    this.offlineSettings = null;
    /** @type {{ a: number | null, b: number | null }} */
    this.selection = { a: null, b: null };
    this.options = { masks: true, boxes: true, trails: true, gt: false };
    this.fps = new FpsMeter();
    /** Detections in the last tracked frame. */
    this.lastDetections = 0;
    /** Worker-side milliseconds per frame, for the status line. */
    this.lastTimings = { detect: 0, track: 0, total: 0 };
    /**
     * The detector's learned stage (worker/learned.js): `keyframes` or `off` (the default until
     * its cost and gain are measured across the clips; `?learned=keyframes`, or the checkbox).
     * @type {'off' | 'keyframes'}
     */
    this.learnedPolicy = 'off';
    /**
     * What the learned stage gave this source: keyframes done, frames that took learned masks,
     * masks replaced, regions added, and why the stage stopped (null: it did not).
     */
    this.learnedStats = { keyframes: 0, ms: 0, frames: 0, used: 0, added: 0, failed: /** @type {string | null} */ (null) };
    this.lastEdit = '';
    /** Live scores, throttled while tracking. */
    this.scorer = new Scorer(() => this.score());
    /** @type {import('./view/panel.js').Scores | null} */
    this.scores = null;
    /** Serialises frame grabs: one <video> can seek to one place at a time. */
    this.grabChain = Promise.resolve();

    // A track keeps its colour when renumbered: the edit model knows which colour it wears.
    /** @param {number} id */
    const colour = (id) => colorOf(this.model.colourKey(id));
    this.stage = new Stage(
      byId('frame', HTMLCanvasElement),
      byId('overlay', HTMLCanvasElement),
      (rle) => core.decodeMask(rle),
      colour,
    );
    this.stage.onResize = () => this.render();
    this.attached = this.worker.attach(byId('frame', HTMLCanvasElement));
    this.timeline = new Timeline(byId('timeline', HTMLCanvasElement), ({ id, frame, add }) => {
      if (id !== null) this.select(id, add);
      void this.seek(frame);
    }, colour, {
      zoomIn: byId('tl-zoom-in'),
      zoomOut: byId('tl-zoom-out'),
      all: byId('tl-all'),
      rows: byId('tl-rows'),
      range: byId('tl-range'),
    });
    this.panel = new Panel({
      onSelect: (id, add) => this.select(id, add),
      onAction: (a) => this.action(a),
      // The renumbered track stays selected under its new id.
      onRenumber: (to) => this.edit(() => renumber(this.model, this.selection, to)),
    }, colour);
    /** Draws a box or polygon to follow on the stage. */
    this.shapeTool = new ShapeTool(
      (shape) => {
        void this.refusable(() => this.shapeDrawn(shape));
      },
      () => this.render(),
    );
    this.model.subscribe(() => {
      this.validateSelection();
      if (this.gt) this.scorer.request();
      this.render();
    });
    this.bindControls();
  }

  // ---------------------------------------------------------------- sources

  /** Opens the synthetic demo scene (rendered and tracked in the worker). */
  async openDemo() {
    await this.openSource(null);
  }

  /** @param {File} file */
  async openVideo(file) {
    await this.openSource(await videoSource(byId('video', HTMLVideoElement), file));
  }

  /** @param {File[]} files */
  async openImages(files) {
    await this.openSource(await imageSource(files));
  }

  async openWebcam() {
    await this.openSource(await webcamSource(byId('video', HTMLVideoElement)));
  }

  /**
   * Starts a tracking session on a source (null: the synthetic demo).
   * @param {Source | null} src
   */
  async openSource(src) {
    await this.stop();
    if (this.source && this.source.kind !== 'synth') this.source.close();
    this.status(src ? `opening ${src.name}…` : 'starting the demo scene…');
    const opened = await this.worker.open({
      source: src ? { kind: 'frames', width: src.width, height: src.height, fps: src.fps } : { kind: 'synth', preset: this.scene },
      detector: this.detectorFor(src),
      ...(this.tracker ? { tracker: this.tracker } : {}),
      ...(this.offlineSettings ? { offlineSettings: this.offlineSettings } : {}),
      offline: src?.kind !== 'webcam',
      learned: this.learnedPolicy,
    });
    this.learnedStats = { keyframes: 0, ms: 0, frames: 0, used: 0, added: 0, failed: null };
    /** @type {AnySource} */
    const source = src ?? {
      kind: 'synth',
      name: this.scene,
      width: opened.width,
      height: opened.height,
      frames: opened.frames ?? 0,
      fps: opened.fps,
    };
    this.source = source;
    this.detectorChoice = null;
    this.warming = false;
    // A detector with classes names them: the overlay shows them and exports carry them.
    if (opened.classes.length) this.labels = opened.classes.flatMap((name, i) => (name ? [{ class: i, name }] : []));
    this.session.open({ frames: source.frames ?? 0, offlineCapable: opened.offline });
    this.cur = 0;
    this.selection = { a: null, b: null };
    this.fps.reset();
    this.model.replaceAll([]);
    if (source.kind === 'synth') {
      this.gt = new TrackTable();
      this.gtName = 'scene ground truth';
    } else if (!this.gtName.startsWith('file')) {
      this.gt = null;
      this.gtName = '';
    }
    this.scores = null;
    this.stage.resize(source.width, source.height);
    byId('empty').hidden = true;
    this.status(`${source.name}: ${source.width}×${source.height}${source.frames ? `, ${source.frames} frames` : ''} · core ${opened.version}`);
    await this.stepForward();
  }

  // ---------------------------------------------------------------- playback

  /** Frames the scrubber and the timeline span (the whole source when its length is known). */
  get lastFrame() {
    return this.session.frames || Math.max(this.session.processed, this.model.table.lastFrame());
  }

  /**
   * The last frame a seek may show (see `Session.lastShown`); play (or →) tracks on from there.
   * Frames a follow reached ahead of the tracker can be shown too, except from the webcam
   * (whose old frames are gone).
   */
  get lastShown() {
    const shown = this.session.lastShown(this.lastFrame);
    if (!this.source || this.source.kind === 'webcam') return shown;
    return Math.max(shown, Math.min(this.lastFrame, this.model.table.lastFrame()));
  }

  async togglePlay() {
    if (this.playing) await this.stop();
    else this.play();
  }

  play() {
    if (this.playing || !this.source) return;
    this.playing = true;
    this.renderTransport();
    this.loop = this.run()
      .catch((e) => this.fail(e))
      .finally(() => {
        this.playing = false;
        this.loop = null;
        byId('progress', HTMLProgressElement).hidden = true;
        this.render();
      });
  }

  async stop() {
    this.playing = false;
    if (this.loop) await this.loop;
  }

  /** The play loop: replays what is tracked, tracks what is not, in the chosen mode. */
  async run() {
    const session = this.session;
    if (this.mode === 'offline' && session.offlinePending) {
      if (session.offlineCapable) {
        await this.runOffline();
        return;
      }
      this.status('offline mode needs a video or image sequence with an end: tracking online');
    }
    const t0 = performance.now();
    const f0 = this.cur;
    while (this.playing) {
      const next = this.cur + 1;
      if (session.frames && next > session.frames) break;
      if (!session.needsTracking(next)) {
        await this.show(next);
      } else {
        await this.track({ until: session.frames || Infinity, display: 'every' });
        if (this.source?.kind !== 'webcam') break;
      }
      if (this.speed === 'realtime') await this.pace(t0, this.cur - f0);
    }
  }

  /**
   * Waits until `n` frames after `t0` are due at the source's frame rate.
   * @param {number} t0
   * @param {number} n
   */
  async pace(t0, n) {
    const fps = this.source?.fps || 25;
    const wait = t0 + (n * 1000) / fps - performance.now();
    if (wait > 1) await new Promise((r) => setTimeout(r, wait));
  }

  /**
   * Offline: track every remaining frame as fast as possible, then run the offline pass (the
   * core's trajectory re-linker and gap filling) and apply what it changed to the table. The
   * progress bar follows the frames, then the re-linker's phases.
   */
  async runOffline() {
    const progress = byId('progress', HTMLProgressElement);
    progress.hidden = false;
    progress.max = 1;
    progress.dataset.phase = 'online';
    const session = this.session;
    if (!session.allTracked) {
      await this.track({ until: session.frames, display: 'throttled' });
    }
    if (!this.playing || !session.allTracked) return;
    if (session.offlinePending) {
      session.beginFinishing();
      this.status('offline pass…');
      const phases = Object.keys(PHASES);
      /** @type {Awaited<ReturnType<typeof this.worker.finish>>} */
      let res;
      try {
        res = await this.worker.finish((p) => {
          const i = phases.indexOf(p.phase);
          const done = p.phase === 'done' ? 1 : (Math.max(0, i) + p.fraction) / phases.length;
          progress.value = ONLINE_SHARE + (1 - ONLINE_SHARE) * done;
          progress.dataset.phase = p.phase;
          const name = PHASES[/** @type {keyof typeof PHASES} */ (p.phase)];
          if (name) this.status(`offline pass: ${name}…`);
        });
      } catch (e) {
        // The pass can run again: play (Run) retries it.
        session.abortFinishing();
        throw e;
      }
      const onlineIds = this.model.table.ids().length;
      const onlineInterpolated = this.model.table.all().filter((r) => r.interpolated).length;
      const applied = this.model.relink({ joins: res.joins, filled: res.filled });
      this.lastEdit = this.model.undoStack.at(-1)?.label ?? '';
      const ids = this.model.table.ids().length;
      session.finish({ onlineIds, onlineInterpolated, ids, joins: applied.joined, filled: applied.filled, ms: res.ms });
      const skipped = res.joins.length - applied.joined;
      this.status(
        `offline pass: ${onlineIds} → ${ids} tracks (${applied.joined} joins, ${applied.filled} shapes filled in, ` +
          `${res.ms.toFixed(0)} ms)${skipped ? `; ${skipped} join(s) left to your edits` : ''}`,
      );
    }
    await this.show(this.cur || 1);
  }

  /**
   * Tracks frames `processed+1 ..= until` through the worker, two in flight so the worker never
   * waits for the page to draw.
   * @param {{ until: number, display: 'every' | 'throttled' | 'none' }} opts
   */
  async track({ until, display }) {
    const src = this.source;
    if (!src) return;
    const progress = byId('progress', HTMLProgressElement);
    /** @type {Array<Promise<StepResult>>} */
    const inflight = [];
    let n = this.session.processed + 1;
    let lastDraw = 0;
    while (true) {
      while (this.playing && inflight.length < 2 && n <= until) {
        // Offline, paint a frame now and then so the labeller sees progress.
        const now = performance.now();
        const paint = display === 'every' || (display === 'throttled' && now - lastDraw > OFFLINE_DRAW_MS);
        if (paint) lastDraw = now;
        inflight.push(this.send(src, n++, paint));
      }
      const p = inflight.shift();
      if (!p) break;
      const res = await p;
      this.accept(res);
      // The worker painted the frame if it was asked to; draw its overlay.
      if (res.painted) {
        this.cur = res.frame;
        this.render();
      }
      const frames = this.session.frames;
      progress.value = frames ? (ONLINE_SHARE * res.frame) / frames : 0;
      if (src.kind === 'webcam' && !this.playing) break;
    }
    if (display === 'throttled') {
      this.cur = Math.max(this.cur, 1);
      this.render();
    }
  }

  /**
   * Grabs frame `n` (in order) and posts it to the worker.
   * @param {AnySource} src
   * @param {number} n
   * @param {boolean} display
   * @returns {Promise<StepResult>}
   */
  send(src, n, display) {
    const posted = this.grabChain.then(async () => {
      /** @type {ImageBitmap | undefined} */
      let bitmap;
      if (src.kind === 'webcam') {
        bitmap = (await /** @type {any} */ (src).grab()).bitmap;
      } else if (src.kind !== 'synth') {
        const b = await src.frameAt(n);
        if (!b) throw new Error(`frame ${n} is not available`);
        bitmap = b;
      }
      const result = this.worker.step(n, bitmap, display).then((r) => ({ ...r, painted: display }));
      return { result };
    });
    this.grabChain = posted.then(
      () => undefined,
      () => undefined,
    );
    return posted.then((o) => o.result);
  }

  /**
   * Takes one tracked frame into the table. A result the session does not wait for (from a
   * source replaced meanwhile) is dropped: its shapes belong to another video.
   * @param {StepResult} res
   */
  accept(res) {
    if (this.session.phase !== 'tracking' || res.frame !== this.session.processed + 1) return;
    this.session.trackedFrame(res.frame);
    this.fps.tick(performance.now());
    this.lastTimings = res.timings;
    this.lastDetections = res.detections;
    const chose = res.choice !== null && res.choice.name !== this.detectorChoice?.name;
    if (chose) this.detectorChoice = res.choice;
    // The warm-up message names the choice; a chosen detector that needs no more learning
    // says it detects.
    this.warmupStatus(res.warmup);
    if (chose && !this.warming) this.status(this.choiceNote(`detecting from frame ${res.frame}`));
    if (res.groundTruth && this.gt) {
      for (const g of res.groundTruth) this.gt.add(g);
    }
    if (res.learned) this.learnedStep(res.learned);
    // Ingest last: it notifies the views.
    this.model.ingest(res.shapes);
    for (const n of this.model.takeNotices()) {
      this.status(`two tracks shown as ${n.id} are both seen in frame ${n.frame}: the second goes on as ${n.fresh}`, true);
    }
  }

  /**
   * While the detector learns the scene (a background model's first frames detect nothing;
   * the automatic detector judges the camera first), the status line says so, and says when
   * it is done: empty frames then are not a failure.
   * @param {import('./worker/detectors.js').Warmup | null} w
   */
  warmupStatus(w) {
    if (!w) return;
    const what = {
      background: ['learning the background', 'background learnt'],
      // The moving-camera detector's flow compares each frame with the one before (one
      // frame to wait for); its background-model cue learns `min_age` frames.
      moving: ['measuring the camera motion', 'camera motion measured'],
      judge: ['judging whether the camera moves', 'camera judged'],
    }[w.what ?? 'background'];
    if (w.seen < w.total) {
      this.status(this.choiceNote(`${what[0]}: ${w.seen}/${w.total} frames (nothing is detected until it is learnt)…`));
      this.warming = true;
    } else if (this.warming) {
      this.warming = false;
      this.status(this.choiceNote(`${what[1]} from ${w.total} frame${w.total === 1 ? '' : 's'}: detecting`));
    }
  }

  /**
   * `msg` after what the automatic detector chose, once it has ("camera moves: moving-camera
   * detector · …"), so a later warm-up message does not hide the choice.
   * @param {string} msg
   */
  choiceNote(msg) {
    const c = this.detectorChoice;
    return c ? `${c.why}: ${c.label} · ${msg}` : msg;
  }

  /**
   * The detector a source gets: the menu's, except that `auto` keeps the background detector
   * on the synthetic demo (a still camera by construction; its quality figures are the
   * background detector's).
   * @param {Source | AnySource | null} src null: the synthetic demo
   */
  detectorFor(src) {
    return this.detector === 'auto' && (!src || src.kind === 'synth') ? 'background' : this.detector;
  }

  /**
   * Counts what a frame took from the learned stage; says once why it stopped.
   * @param {NonNullable<StepResult['learned']>} l
   */
  learnedStep(l) {
    const s = this.learnedStats;
    s.keyframes = l.keyframes;
    s.ms = l.ms;
    if (l.use) {
      s.frames += 1;
      s.used += l.use.used;
      s.added += l.use.added;
    }
    if (l.failed && !s.failed) {
      s.failed = l.failed;
      this.status(`learned masks off for this video: ${l.failed}`, true);
    }
  }

  /** Whether the status line shows a warm-up message. */
  warming = false;

  /** Tracks the next frame if it is new, else shows it. */
  async stepForward() {
    if (!this.source) return;
    const next = this.cur + 1;
    if (this.session.frames && next > this.session.frames) return;
    if (this.session.needsTracking(next)) {
      this.playing = true;
      try {
        await this.track({ until: next, display: 'every' });
      } finally {
        this.playing = false;
        this.render();
      }
    } else {
      await this.show(next);
    }
  }

  /**
   * Shows frame `n`, clamped to the frames that can be shown (`lastShown`).
   * @param {number} n
   */
  async seek(n) {
    const target = Math.max(1, Math.min(this.lastShown || 1, Math.round(n)));
    await this.show(target);
  }

  /**
   * Displays frame `n` with its overlay (no tracking).
   * @param {number} n
   */
  async show(n) {
    this.cur = n;
    // Scrubbing fires faster than frames can be fetched: one fetch at a time, the newest
    // wanted frame next (frames skipped in between are never fetched).
    if (this.showing) {
      this.render();
      return this.showing;
    }
    this.showing = (async () => {
      let done = 0;
      while (done !== this.cur) {
        done = this.cur;
        await this.paintFrame(done);
        this.render();
      }
    })();
    try {
      await this.showing;
    } finally {
      this.showing = null;
    }
  }

  /** @type {Promise<void> | null} */
  showing = null;

  /**
   * Has the worker paint frame `n` of the source (a blank frame without a source or pixels).
   * @param {number} n
   */
  async paintFrame(n) {
    const src = this.source;
    const { width, height } = this.stage;
    if (src?.kind === 'synth') {
      await this.worker.render(n);
      return;
    }
    let bitmap = null;
    if (src) {
      const grabbed = this.grabChain.then(() => src.frameAt(n));
      this.grabChain = grabbed.then(
        () => undefined,
        () => undefined,
      );
      bitmap = await grabbed;
    }
    await this.worker.paint(width, height, bitmap);
  }

  // ---------------------------------------------------------------- selection and edits

  /**
   * @param {number} id
   * @param {boolean} add shift: make it the second track of a pair
   */
  select(id, add) {
    if (add && this.selection.a !== null && this.selection.a !== id) this.selection = { a: this.selection.a, b: id };
    else this.selection = { a: id, b: null };
    this.render();
  }

  /** A selected track that no longer exists (merged away, deleted) is deselected. */
  validateSelection() {
    this.selection = validSelection((id) => this.model.table.has(id), this.selection);
  }

  deselect() {
    this.panel.cancelRenumber();
    this.selection = { a: null, b: null };
    this.render();
  }

  /** @param {number} dir */
  cycleTrack(dir) {
    const ids = this.model.table.at(this.cur).map((r) => r.id);
    const pool = ids.length ? ids : this.model.table.ids();
    if (!pool.length) return;
    const i = this.selection.a === null ? -1 : pool.indexOf(this.selection.a);
    const j = i < 0 ? (dir > 0 ? 0 : pool.length - 1) : (i + dir + pool.length) % pool.length;
    this.select(pool[j], false);
  }

  /**
   * Runs an edit command (model/commands.js), reporting a refusal in the status line instead
   * of throwing. The status line then says what was done, so it never shows a message about
   * an earlier state.
   * @param {() => import('./model/commands.js').Outcome} fn
   */
  edit(fn) {
    try {
      const { selection, note, lastEdit } = fn();
      this.selection = selection;
      this.validateSelection();
      this.lastEdit = lastEdit;
      this.status(note);
      this.render();
      return true;
    } catch (e) {
      if (e instanceof EditError) {
        this.status(e.message, true);
        return false;
      }
      throw e;
    }
  }

  /** @param {import('./model/commands.js').Command | 'renumber'} a */
  action(a) {
    if (a !== 'renumber') {
      this.edit(() => runCommand(this.model, a, { selection: this.selection, frame: this.cur }));
    } else if (this.selection.a !== null) {
      this.panel.askRenumber(this.model.nextId);
    } else {
      this.status('select a track first', true);
    }
  }

  // ---------------------------------------------------------------- follow a shape

  /**
   * The follow under way (null: none): Cancel sets `cancel`, and the loop stops asking for
   * frames.
   * @type {{ cancel: boolean } | null}
   */
  following = null;

  /**
   * Switches the drawing tool (the same one again: off, clicks select again).
   * @param {'box' | 'polygon' | null} mode
   */
  useTool(mode) {
    const next = mode === this.shapeTool.mode ? null : mode;
    this.shapeTool.use(next);
    byId('fol-box').setAttribute('aria-pressed', String(next === 'box'));
    byId('fol-poly').setAttribute('aria-pressed', String(next === 'polygon'));
    byId('overlay').classList.toggle('drawing', next !== null);
    // The learned segmenter starts loading while the box is drawn (worker/learned.js).
    if (next === 'box' && this.source && byId('fol-learned', HTMLInputElement).checked) void this.worker.learnedWarm().catch(() => {});
    if (next) {
      const what = next === 'box' ? 'drag a box' : 'click the corners of a polygon (Enter or double-click closes it)';
      const on = this.selection.a !== null ? `: it becomes track ${this.selection.a}'s shape here (Esc first for a new track)` : ' around the object to follow';
      this.status(`${what}${on}`);
    }
  }

  /** The frames a new follow covers, from the Follow card's settings. */
  followSettings() {
    const direction = /** @type {'forward' | 'backward' | 'both'} */ (byId('fol-dir', HTMLSelectElement).value);
    const length = Number(byId('fol-len', HTMLInputElement).value);
    return { direction, length };
  }

  /** Follows the selected track's shape in this frame (F). */
  async followSelected() {
    const id = this.selection.a;
    if (id === null) throw new FollowError('select a shape to follow (click it), or draw a box or polygon around the object (X, P)');
    const r = this.model.table.get(this.cur, id);
    if (!r) throw new FollowError(`track ${id} has no shape in frame ${this.cur}: go to a frame where it is seen, or draw one (X, P)`);
    // A box-only record (a box detector, an import) starts from the outline its box holds.
    const key = r.mask ? r : { ...r, mask: this.core.encodeMask(this.stage.width, this.stage.height, await this.boxMask(r.bbox)) };
    const legs = followLegs({ frame: this.cur, frames: this.session.frames, ...this.followSettings() });
    await this.followFrom(id, key, clipLegs(this.model.table, id, legs));
  }

  /**
   * A box or polygon drawn on the stage (see `shapeGiven`).
   * @param {import('./view/shapetool.js').Shape} shape
   */
  async shapeDrawn(shape) {
    const { width, height } = this.stage;
    // A box says where the object is, not its shape: it becomes the outline it holds. A
    // polygon is the labeller's outline already.
    await this.shapeGiven(shape.kind === 'box' ? await this.boxMask(shape.box) : rasterize(shape, width, height));
  }

  /**
   * How the last box became a mask (`how`, `ms` in the worker, `note`: why not learned), for
   * the status line and the tests.
   * @type {{ how: 'learned' | 'refined', ms: number, note: string | null } | null}
   */
  lastBoxMask = null;

  /**
   * The outline of what `box` holds on this frame, as a full-frame bitmap: by the learned
   * segmenter in the tracker worker when the Follow card's "learned outline" is on and the
   * net loads, else by the weights-free refinement (worker/learned.js). The progress bar shows
   * the net's files arriving, then the inference; tracking stops first (the worker does one
   * thing at a time, and this frame must stay in its buffer).
   * @param {{ x: number, y: number, w: number, h: number }} box
   * @returns {Promise<Uint8Array>}
   */
  async boxMask(box) {
    const src = this.source;
    if (!src) throw new FollowError('open the demo, a video or an image sequence first');
    checkShape({ bbox: box });
    if (this.following) throw new FollowError('a follow is under way: wait for it or cancel it (Esc)');
    await this.stop();
    const learned = byId('fol-learned', HTMLInputElement).checked;
    const progress = byId('fol-progress', HTMLProgressElement);
    progress.hidden = false;
    progress.removeAttribute('value'); // indeterminate until the first report
    this.status(learned ? 'outlining the box…' : 'outlining the box (weights-free)…');
    try {
      const r = await this.worker.boxMask(this.cur, box, learned, await this.grab(src, this.cur), (p) => {
        if (p.phase === 'load') {
          progress.value = p.total ? p.loaded / p.total : 0;
          this.status(`loading the learned segmenter: ${(p.loaded / 1e6).toFixed(1)} of ${(p.total / 1e6).toFixed(1)} MB`);
        } else {
          progress.removeAttribute('value');
          this.status('outlining the box (learned segmenter)…');
        }
      });
      this.lastBoxMask = { how: r.how, ms: r.ms, note: r.note };
      const how = r.how === 'learned' ? 'learned outline' : `weights-free outline${learned && r.note ? ` (${r.note})` : ''}`;
      this.status(`${how} in ${(r.ms / 1000).toFixed(1)} s`);
      return r.bitmap;
    } finally {
      progress.hidden = true;
      progress.value = 0;
    }
  }

  /**
   * A shape the labeller gave on this frame (drawn, or a followed shape dragged), as a
   * full-frame bitmap: with a followed track selected and this frame inside its followed run,
   * a corrected keyframe that re-propagates the frames it affects; with another track
   * selected, that track followed from the shape; else a new track.
   * @param {Uint8Array} bitmap
   */
  async shapeGiven(bitmap) {
    const { width, height } = this.stage;
    const bbox = bitmapBox(bitmap, width) ?? { x: 0, y: 0, w: 0, h: 0 };
    checkShape({ bbox });
    const mask = this.core.encodeMask(width, height, bitmap);
    const frame = this.cur;
    const sel = this.selection.a;
    if (sel === null) {
      const id = this.model.nextId;
      await this.followFrom(id, { frame, id, bbox, mask }, followLegs({ frame, frames: this.session.frames, ...this.followSettings() }));
      return;
    }
    const key = { frame, id: sel, bbox, mask };
    const leg = correctionLeg(this.model.table, sel, frame);
    if (leg) {
      await this.followFrom(sel, key, [leg], `correct ${sel} at frame ${frame}`);
    } else if (followedRun(this.model.table, sel, frame)) {
      // The run's last frame: nothing after it to propagate, the shape alone is corrected.
      commitFollow(this.model, { id: sel, key, legs: [], records: [], label: `correct ${sel} at frame ${frame}` });
      this.lastEdit = this.model.undoStack.at(-1)?.label ?? '';
      this.status(`track ${sel}: shape corrected in frame ${frame}`);
    } else {
      const legs = followLegs({ frame, frames: this.session.frames, ...this.followSettings() });
      await this.followFrom(sel, key, clipLegs(this.model.table, sel, legs));
    }
  }

  /**
   * A drag of the selected track's followed shape (no drawing tool): where it started, and how
   * far it has gone (image pixels). Released, the moved shape is a corrected keyframe.
   * @type {{ id: number, from: { x: number, y: number }, dx: number, dy: number } | null}
   */
  moving = null;

  /**
   * Starts dragging the shape under `p` when it is the selected track's followed shape.
   * @param {{ x: number, y: number }} p
   * @returns {boolean} whether a drag started
   */
  startMove(p) {
    const id = this.selection.a;
    if (id === null || this.following) return false;
    const r = this.model.table.get(this.cur, id);
    if (!isFollowed(r) || this.stage.hit(this.model.table, this.cur, p) !== id) return false;
    this.moving = { id, from: p, dx: 0, dy: 0 };
    return true;
  }

  /** Ends a drag: a shape moved by a pixel or more becomes the track's keyframe here. */
  async endMove() {
    const m = this.moving;
    this.moving = null;
    this.render();
    if (!m || (Math.abs(m.dx) < 1 && Math.abs(m.dy) < 1)) return;
    const r = this.model.table.get(this.cur, m.id);
    const bm = r ? this.stage.mask(r)?.bitmap : null;
    if (!bm) return;
    await this.shapeGiven(shiftBitmap(bm, m.dx, m.dy, this.stage.width, this.stage.height));
  }

  /**
   * Runs a follow, reporting a refusal (an `EditError`: an empty shape, no selection, a frame
   * outside the video) in the status line; anything else fails as usual.
   * @param {() => Promise<void>} fn
   */
  async refusable(fn) {
    try {
      await fn();
    } catch (e) {
      if (e instanceof EditError) this.status(e.message, true);
      else this.fail(e);
    }
  }

  /** Stops the follow under way after the frame in progress; what it followed is kept. */
  cancelFollow() {
    if (this.following) this.following.cancel = true;
  }

  /**
   * A frame's pixels for the follower: none for the synthetic scene (the worker renders it),
   * else the source's bitmap (grabbed in turn with the tracker's frames: one <video> seeks to
   * one place at a time).
   * @param {AnySource} src
   * @param {number} n
   * @returns {Promise<ImageBitmap | undefined>}
   */
  grab(src, n) {
    if (src.kind === 'synth') return Promise.resolve(undefined);
    const grabbed = this.grabChain.then(() => src.frameAt(n));
    this.grabChain = grabbed.then(
      () => undefined,
      () => undefined,
    );
    return grabbed.then((b) => {
      if (!b) throw new FollowError(`frame ${n} is not available from ${src.name}`);
      return b;
    });
  }

  /**
   * Follows track `id` from the shape `key` along `legs` (the worker's follower, a frame at a
   * time, two frames in flight), with progress and Cancel, then applies the result as one
   * edit (undoable). A cancelled follow keeps what it reached and leaves later frames as they
   * were; an error changes nothing.
   * @param {number} id
   * @param {TrackRecord} key the keyframe (its mask is what is followed)
   * @param {import('./model/follow.js').Leg[]} legs
   * @param {string} [label] the edit's name
   */
  async followFrom(id, key, legs, label = `follow ${id} from frame ${key.frame}`) {
    if (this.following) throw new FollowError('a follow is under way: wait for it or cancel it (Esc)');
    const src = this.source;
    if (!src || !key.mask) throw new FollowError('open the demo, a video or an image sequence first');
    checkShape(key);
    await this.stop();
    const run = { cancel: false };
    this.following = run;
    const progress = byId('fol-progress', HTMLProgressElement);
    const cancel = byId('fol-cancel');
    progress.hidden = false;
    progress.value = 0;
    cancel.hidden = false;
    const total = legs.reduce((n, l) => n + Math.abs(l.to - l.from), 0);
    /** @type {TrackRecord[]} */
    const records = [];
    /** @type {import('./model/follow.js').Leg[]} the frames each leg actually covered */
    const reached = [];
    let done = 0;
    let stopped = false;
    try {
      for (const leg of legs) {
        if (run.cancel) break;
        await this.worker.followStart(leg.from, leg.to, key.mask, await this.grab(src, leg.from));
        let last = leg.from;
        /** @type {Array<Promise<{ step: import('./worker/protocol.js').FollowStep }>>} */
        const inflight = [];
        let n = leg.from + leg.direction;
        const inLeg = (/** @type {number} */ f) => (leg.direction > 0 ? f <= leg.to : f >= leg.to);
        let legStopped = false;
        while (true) {
          while (!run.cancel && !legStopped && inflight.length < 2 && inLeg(n)) {
            const f = n;
            inflight.push(this.grab(src, f).then((b) => this.worker.followStep(f, b)));
            n += leg.direction;
          }
          const p = inflight.shift();
          if (!p) break;
          /** @type {{ step: import('./worker/protocol.js').FollowStep }} */
          let answer;
          try {
            answer = await p;
          } catch (e) {
            // The frame still in flight fails or lands after this one: wait for it, so no
            // rejection is left unhandled, then report this one.
            await Promise.allSettled(inflight);
            throw e;
          }
          const { step } = answer;
          if (legStopped) continue;
          const r = stepRecord(id, step);
          if (!r) {
            legStopped = true;
            stopped = true;
            last = leg.to;
            continue;
          }
          records.push(r);
          last = step.frame;
          done++;
          progress.value = total ? done / total : 1;
          this.status(`following ${id}: frame ${step.frame} (${done}/${total})${run.cancel ? ', stopping…' : ''}`);
        }
        // A follower that gave up has said where its target is not: the old followed shapes
        // of the rest of the leg go too. A cancelled leg leaves them.
        reached.push({ ...leg, to: last });
      }
    } finally {
      this.following = null;
      progress.hidden = true;
      cancel.hidden = true;
      await this.worker.followEnd().catch(() => undefined);
    }
    commitFollow(this.model, { id, key, legs: reached, records, label });
    this.lastEdit = label;
    this.selection = { a: id, b: null };
    const how = run.cancel ? ' (cancelled)' : stopped ? ' (the follower lost the target and stopped)' : '';
    this.status(`track ${id}: ${records.length} frame${records.length === 1 ? '' : 's'} followed from frame ${key.frame}${how}`);
    this.render();
  }

  // ---------------------------------------------------------------- files

  /**
   * Reads an annotation file through the core.
   * @param {string} name
   * @param {string} text
   */
  parse(name, text) {
    const format = guessFormat(name, text);
    const info = formatInfo(format);
    // Label Studio (percent) and YOLO (fractions) boxes are relative to the frame: they need
    // the open video's size, and a blank canvas has none to offer.
    if (info.needsSize && !this.source) {
      throw new Error(`${name}: ${info.label} boxes are relative to the frame size; open the video first`);
    }
    const meta = info.needsSize ? { width: this.stage.width, height: this.stage.height } : undefined;
    const a = this.core.parseAnnotations(format, text, name, meta);
    if (a.videos > 1) this.status(`${name} holds ${a.videos} videos: reading the first`);
    if (a.labels.length) this.labels = a.labels;
    return a;
  }

  /** @type {Array<{ class: number, name: string }>} class names from the last import */
  labels = [];

  /**
   * Imports tracks to label (replaces the table; tracking stops). Without an open source the
   * tracks are shown on a blank canvas of the size they imply.
   * @param {string} name
   * @param {string} text
   */
  async importTracks(name, text) {
    const parsed = this.parse(name, text);
    const records = /** @type {TrackRecord[]} */ (parsed.records);
    await this.stop();
    this.model.replaceAll(records);
    if (!this.source) {
      let w = parsed.width ?? 0;
      let h = parsed.height ?? 0;
      for (const r of w && h ? [] : records) {
        if (r.mask) {
          h = r.mask.size[0];
          w = r.mask.size[1];
          break;
        }
        w = Math.max(w, r.bbox.x + r.bbox.w);
        h = Math.max(h, r.bbox.y + r.bbox.h);
      }
      this.stage.resize(Math.max(1, Math.ceil(w)), Math.max(1, Math.ceil(h)));
      byId('empty').hidden = true;
    }
    const table = this.model.table;
    this.session.imported(Math.max(parsed.frames ?? 0, table.lastFrame()));
    this.status(`${name}: ${records.length} records, ${table.ids().length} tracks`);
    // Stay on the frame shown if the import has tracks there; else open on the first frame that
    // has any (without a source, an empty frame is a blank canvas: it looks like a failed import).
    await this.seek(this.cur && table.at(this.cur).length ? this.cur : table.firstFrame() || 1);
  }

  /** @param {string} name @param {string} text */
  loadGroundTruth(name, text) {
    this.gt = new TrackTable(/** @type {TrackRecord[]} */ (this.parse(name, text).records));
    this.gtName = `file ${name}`;
    this.options.gt = true;
    byId('opt-gt', HTMLInputElement).checked = true;
    this.status(`ground truth ${name}: ${this.gt.size} records`);
    this.scorer.request(true);
    this.render();
  }

  /**
   * The track table as text in `format` (written by the core).
   * @param {FormatId} format
   */
  exportText(format) {
    return this.core.writeAnnotations(format, this.model.table.all(), {
      width: this.stage.width,
      height: this.stage.height,
      frames: this.lastFrame,
      name: this.source?.name ?? 'shapetrack',
      labels: this.labels,
    });
  }

  /** @param {FormatId} format */
  download(format) {
    const text = this.exportText(format);
    const name = exportName(this.source?.name ?? 'tracks', format);
    const a = document.createElement('a');
    a.href = URL.createObjectURL(new Blob([text], { type: 'text/plain' }));
    a.download = name;
    a.click();
    setTimeout(() => URL.revokeObjectURL(a.href), 1000);
    this.status(`saved ${name} (${formatInfo(format).label})`);
  }

  // ---------------------------------------------------------------- scores

  /** Scores the table against the ground truth with the core's evaluator (frames seen so far). */
  score() {
    if (!this.gt) return;
    const upto = this.session.lastShown(this.lastFrame);
    const inputs = scoreInputs(this.gt, this.model.table, upto);
    if (!inputs) return;
    try {
      this.scores = this.core.evaluate(inputs.gt, inputs.res, upto, { similarity: 'box' });
    } catch (e) {
      this.status(`scoring failed: ${e instanceof Error ? e.message : e}`, true);
    }
    this.panel.renderScores(this.scores, this.gtName.replace(/^file /, ''));
  }

  // ---------------------------------------------------------------- view

  /**
   * Asks for a redraw. State changes call this freely: the views are drawn once per display
   * frame at most, so tracking faster than the screen refreshes costs no extra drawing.
   */
  render() {
    if (!this.raf) this.raf = requestAnimationFrame(() => this.renderNow());
  }

  /** @type {number} pending animation frame */
  raf = 0;

  /** Main-thread milliseconds per redraw (smoothed), shown with the fps. */
  renderMs = 0;

  renderNow() {
    this.raf = 0;
    const t0 = performance.now();
    const table = this.model.table;
    // While playing, the timeline's bars and the track list (whose contents change every
    // frame) refresh a few times a second; the overlay and playhead every frame.
    const busy = this.playing;
    this.stage.drawOverlay({ table, gt: this.gt, frame: this.cur, selection: this.selection, options: this.options, labels: this.labels });
    this.stage.drawTool(this.shapeTool);
    const mv = this.moving;
    const moved = mv && table.get(this.cur, mv.id);
    if (mv && moved) {
      // The dragged shape's box where it would land.
      const b = moved.bbox;
      this.stage.drawTool({
        draw(ctx, lw) {
          ctx.save();
          ctx.strokeStyle = '#ffffff';
          ctx.lineWidth = lw;
          ctx.setLineDash([lw * 4, lw * 3]);
          ctx.strokeRect(b.x + mv.dx, b.y + mv.dy, b.w, b.h);
          ctx.restore();
        },
      });
    }
    this.timeline.render({ table, frames: this.lastFrame, frame: this.cur, selection: this.selection, busy });
    this.panel.render({
      table,
      selection: this.selection,
      frame: this.cur,
      canUndo: this.model.canUndo,
      canRedo: this.model.canRedo,
      lastEdit: this.lastEdit,
      busy,
    });
    this.renderTransport();
    this.renderMs = 0.9 * this.renderMs + 0.1 * (performance.now() - t0);
  }

  renderTransport() {
    const scrub = byId('scrub', HTMLInputElement);
    scrub.max = String(Math.max(1, this.lastFrame));
    scrub.value = String(Math.max(1, this.cur));
    const total = this.session.frames ? `/${this.session.frames}` : '';
    byId('frame-no').textContent = this.cur ? `${this.cur}${total}` : '–';
    const fps = this.fps.fps;
    byId('fps').textContent = fps ? `${fps.toFixed(1)} fps` : '– fps';
    byId('fps').title = `per frame: detect ${this.lastTimings.detect.toFixed(1)} ms, track ${this.lastTimings.track.toFixed(1)} ms (worker), draw ${this.renderMs.toFixed(1)} ms (page)`;
    const play = byId('play');
    play.classList.toggle('playing', this.playing);
    play.classList.toggle('run', !this.playing && this.mode === 'offline' && this.session.offlinePending);
  }

  /**
   * @param {string} msg
   * @param {boolean} [error]
   */
  status(msg, error = false) {
    const el = byId('status');
    el.textContent = msg;
    el.title = msg;
    el.classList.toggle('error', error);
  }

  /** @param {unknown} e */
  fail(e) {
    const msg = e instanceof Error ? e.message : String(e);
    console.error(e);
    this.status(msg, true);
  }

  // ---------------------------------------------------------------- controls

  bindControls() {
    /** @param {string} id @param {() => unknown} fn */
    const click = (id, fn) =>
      byId(id).addEventListener('click', () => {
        Promise.resolve()
          .then(fn)
          .catch((e) => this.fail(e));
      });
    /** @param {string} id @param {(files: File[]) => unknown} fn */
    const files = (id, fn) => {
      const input = byId(id, HTMLInputElement);
      input.addEventListener('change', () => {
        const list = [...(input.files ?? [])];
        input.value = '';
        if (list.length)
          Promise.resolve()
            .then(() => fn(list))
            .catch((e) => this.fail(e));
      });
    };
    click('src-demo', () => this.openDemo());
    click('empty-demo', () => this.openDemo());
    click('src-video', () => byId('file-video').click());
    click('src-images', () => byId('file-images').click());
    click('src-webcam', () => this.openWebcam());
    click('import', () => byId('file-import').click());
    click('load-gt', () => byId('file-gt').click());
    click('export', () => this.download(/** @type {FormatId} */ (byId('export-format', HTMLSelectElement).value)));
    files('file-video', (f) => this.openVideo(f[0]));
    files('file-images', (f) => this.openImages(f));
    files('file-import', async (f) => this.importTracks(f[0].name, await f[0].text()));
    files('file-gt', async (f) => this.loadGroundTruth(f[0].name, await f[0].text()));
    click('play', () => this.togglePlay());
    click('fwd', () => this.stepForward());
    click('back', () => this.seek(this.cur - 1));
    click('first', () => this.seek(1));
    const scrub = byId('scrub', HTMLInputElement);
    scrub.addEventListener('input', () => void this.seek(Number(scrub.value)).catch((e) => this.fail(e)));

    const exportSel = byId('export-format', HTMLSelectElement);
    exportSel.replaceChildren(...FORMATS.map((f) => new Option(f.label, f.id)));
    const det = byId('detector', HTMLSelectElement);
    det.replaceChildren(...listDetectors().map((d) => new Option(d.label, d.name)));
    det.value = this.detector;
    det.addEventListener('change', () => {
      Promise.resolve()
        .then(() => this.changeDetector(det.value, det.selectedOptions[0]?.text ?? det.value))
        .catch((e) => this.fail(e));
    });
    const learned = byId('det-learned', HTMLInputElement);
    learned.addEventListener('change', () => {
      this.learnedPolicy = learned.checked ? 'keyframes' : 'off';
      if (this.session.phase !== 'tracking') return;
      this.worker.setLearned(this.learnedPolicy).catch((e) => this.fail(e));
    });
    const speed = byId('speed', HTMLSelectElement);
    speed.value = this.speed;
    speed.addEventListener('change', () => {
      this.speed = /** @type {'realtime' | 'max'} */ (speed.value);
    });
    const mode = byId('mode', HTMLSelectElement);
    mode.addEventListener('change', () => {
      this.mode = /** @type {'online' | 'offline'} */ (mode.value);
      this.renderTransport();
    });
    for (const k of /** @type {const} */ (['masks', 'boxes', 'trails', 'gt'])) {
      const box = byId(`opt-${k}`, HTMLInputElement);
      box.checked = this.options[k];
      box.addEventListener('change', () => {
        this.options[k] = box.checked;
        this.render();
      });
    }
    const overlay = byId('overlay', HTMLCanvasElement);
    overlay.addEventListener('pointerdown', (e) => {
      if (this.shapeTool.mode) {
        // A box drag keeps the pointer even when it leaves the canvas.
        overlay.setPointerCapture?.(e.pointerId);
        this.shapeTool.down(this.stage.toImage(e), this.stage.screenScale());
        return;
      }
      const p = this.stage.toImage(e);
      // Dragging the selected track's followed shape moves it (a corrected keyframe).
      if (!e.shiftKey && this.startMove(p)) {
        overlay.setPointerCapture?.(e.pointerId);
        return;
      }
      const id = this.stage.hit(this.model.table, this.cur, p);
      if (id === null) {
        if (!e.shiftKey) this.deselect();
      } else this.select(id, e.shiftKey);
    });
    overlay.addEventListener('pointermove', (e) => {
      const p = this.stage.toImage(e);
      if (this.moving) {
        this.moving.dx = p.x - this.moving.from.x;
        this.moving.dy = p.y - this.moving.from.y;
        this.render();
      } else this.shapeTool.move(p);
    });
    overlay.addEventListener('pointerup', (e) => {
      if (this.moving) void this.refusable(() => this.endMove());
      else this.shapeTool.up(this.stage.toImage(e));
    });
    overlay.addEventListener('dblclick', () => this.shapeTool.close());
    click('fol-box', () => this.useTool('box'));
    click('fol-poly', () => this.useTool('polygon'));
    click('fol-go', () => this.refusable(() => this.followSelected()));
    click('fol-cancel', () => this.cancelFollow());
    // Drop a video, images or an annotation file anywhere on the stage.
    const stage = byId('stage');
    stage.addEventListener('dragover', (e) => {
      e.preventDefault();
      stage.classList.add('drop');
    });
    stage.addEventListener('dragleave', () => stage.classList.remove('drop'));
    stage.addEventListener('drop', (e) => {
      e.preventDefault();
      stage.classList.remove('drop');
      const list = [...(e.dataTransfer?.files ?? [])];
      Promise.resolve()
        .then(() => this.openDropped(list))
        .catch((err) => this.fail(err));
    });
  }

  /**
   * Uses another detector: for the next source, and, while a source is being tracked, from its
   * next frame on (the tracks so far stay; nothing is reopened).
   * @param {string} name
   * @param {string} label
   */
  async changeDetector(name, label) {
    this.detector = name;
    if (this.session.phase !== 'tracking') {
      this.status(`detector: ${label} (for the next video)`);
      return;
    }
    // Frames in flight finish with the old detector; the switch lands between two frames.
    const wasPlaying = this.playing;
    await this.stop();
    const { classes } = await this.worker.setDetector(this.detectorFor(this.source));
    this.detectorChoice = null;
    this.warming = false;
    if (classes.length) this.labels = classes.flatMap((n, i) => (n ? [{ class: i, name: n }] : []));
    this.status(`detector: ${label} from frame ${this.session.processed + 1}`);
    if (wasPlaying) this.play();
  }

  /** @param {File[]} list */
  async openDropped(list) {
    if (!list.length) return;
    const video = list.find((f) => f.type.startsWith('video/'));
    if (video) return this.openVideo(video);
    const images = list.filter((f) => f.type.startsWith('image/'));
    if (images.length) return this.openImages(images);
    return this.importTracks(list[0].name, await list[0].text());
  }

  /**
   * Keyboard dispatch (see lib/keys.js for the table).
   * @param {import('./lib/keys.js').Action} a
   */
  async key(a) {
    switch (a) {
      case 'play':
        return this.togglePlay();
      case 'back':
        return this.seek(this.cur - 1);
      case 'fwd':
        return this.stepForward();
      case 'back10':
        return this.seek(this.cur - 10);
      case 'fwd10':
        return this.seek(this.cur + 10);
      case 'first':
        return this.seek(1);
      case 'last':
        return this.seek(this.lastShown);
      case 'merge':
      case 'swap':
      case 'split':
      case 'renumber':
      case 'delete':
      case 'deleteRecord':
      case 'undo':
      case 'redo':
        return this.action(a);
      case 'deselect':
        // Esc stops what is under way first: a follow, a shape being drawn, the drawing tool.
        if (this.following) return this.cancelFollow();
        if (this.shapeTool.drawing) return this.shapeTool.reset();
        if (this.shapeTool.mode) return this.useTool(null);
        return this.deselect();
      case 'follow':
        return this.refusable(() => this.followSelected());
      case 'drawBox':
        return this.useTool('box');
      case 'drawPolygon':
        return this.useTool('polygon');
      case 'closeShape':
        return this.shapeTool.close();
      case 'prevTrack':
        return this.cycleTrack(-1);
      case 'nextTrack':
        return this.cycleTrack(1);
      case 'masks':
      case 'boxes':
      case 'trails':
      case 'gt': {
        this.options[a] = !this.options[a];
        byId(`opt-${a}`, HTMLInputElement).checked = this.options[a];
        return this.render();
      }
      case 'demo':
        return this.openDemo();
      case 'open':
        return byId('file-video').click();
      case 'import':
        return byId('file-import').click();
      case 'export':
        return this.download(/** @type {FormatId} */ (byId('export-format', HTMLSelectElement).value));
      case 'help':
        return byId('help-dialog', HTMLDialogElement).showModal();
    }
  }
}
