// The app controller: owns the state (source, frame, selection, track table) and wires the
// views, the tracker worker and the wasm core on the page together. Views render from state;
// every change goes through a method here and ends in `render()`. The methods' work lives in
// app/, one module per concern (sources, playback, tracking, editing, follow, files, scores,
// view, controls); each method here hands `this` to its module's function, so calls between
// them still go through the instance (`app.accept`, say, can be wrapped from outside).

import { EditModel } from './model/edits.js';
import { renumber } from './model/commands.js';
import { Session } from './model/session.js';
import { Scorer } from './model/scoring.js';
import { ShapeTool } from './view/shapetool.js';
import { Stage } from './view/stage.js';
import { Timeline } from './view/timeline.js';
import { Panel } from './view/panel.js';
import { FpsMeter } from './lib/fps.js';
import { colorOf } from './lib/colors.js';
import { byId } from './lib/dom.js';
import { startWorker } from './worker/protocol.js';
import * as sources from './app/sources.js';
import * as playback from './app/playback.js';
import * as tracking from './app/tracking.js';
import * as editing from './app/editing.js';
import * as follow from './app/follow.js';
import * as annotations from './app/annotations.js';
import * as scores from './app/scores.js';
import * as view from './app/view.js';
import * as controls from './app/controls.js';

/**
 * @typedef {import('./lib/core.js').Core} Core
 * @typedef {import('./model/tracks.js').TrackRecord} TrackRecord
 * @typedef {import('./model/tracks.js').TrackTable} TrackTable
 * @typedef {import('./sources/sources.js').Source} Source
 * @typedef {import('./worker/protocol.js').StepResult & { painted: boolean }} StepResult
 * @typedef {import('./io/formats.js').FormatId} FormatId
 * @typedef {{ kind: 'synth', name: string, width: number, height: number, frames: number, fps: number }} SynthSource
 * @typedef {Source | SynthSource} AnySource
 */

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
    /** What the learned stage gave this source (`emptyLearnedStats`). */
    this.learnedStats = tracking.emptyLearnedStats();
    this.lastEdit = '';
    /** The last source or detector change (see `inTurn`). @type {Promise<void>} */
    this.changes = Promise.resolve();
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

  /** Whether the status line shows a warm-up message. */
  warming = false;

  /** @type {Promise<void> | null} */
  showing = null;

  /**
   * The follow under way (null: none): Cancel sets `cancel`, and the loop stops asking for
   * frames.
   * @type {{ cancel: boolean } | null}
   */
  following = null;

  /**
   * How the last box became a mask (`how`, `ms` in the worker, `note`: why not learned), for
   * the status line and the tests.
   * @type {{ how: 'learned' | 'refined', ms: number, note: string | null } | null}
   */
  lastBoxMask = null;

  /**
   * A drag of the selected track's followed shape (no drawing tool): where it started, and how
   * far it has gone (image pixels). Released, the moved shape is a corrected keyframe.
   * @type {{ id: number, from: { x: number, y: number }, dx: number, dy: number } | null}
   */
  moving = null;

  /** @type {Array<{ class: number, name: string }>} class names from the last import */
  labels = [];

  /** @type {number} pending animation frame */
  raf = 0;

  /** Main-thread milliseconds per redraw (smoothed), shown with the fps. */
  renderMs = 0;

  // ---------------------------------------------------------------- frames

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

  // ---------------------------------------------------------------- sources (app/sources.js)

  openDemo() {
    return sources.openDemo(this);
  }

  /** @param {File} file */
  openVideo(file) {
    return sources.openVideo(this, file);
  }

  /** @param {File[]} files */
  openImages(files) {
    return sources.openImages(this, files);
  }

  openWebcam() {
    return sources.openWebcam(this);
  }

  /** @param {Source | null} src */
  openSource(src) {
    return this.inTurn(() => sources.openSource(this, src));
  }

  /**
   * Runs source and detector changes one after another, each to its end: a detector switch
   * waits seconds for its files, and a source opened meanwhile must not interleave with it
   * (the switch's resumed play then sent the new source's frames to the old session: "frame
   * N: no pixels sent" for the whole session). A change that fails does not block the next.
   * @template T
   * @param {() => Promise<T>} fn
   * @returns {Promise<T>}
   */
  inTurn(fn) {
    const run = this.changes.then(fn, fn);
    this.changes = run.then(
      () => undefined,
      () => undefined,
    );
    return run;
  }

  /** Shows the object detectors' class and score filter when one is picked. */
  showObjectFilter() {
    sources.showObjectFilter(this);
  }

  /** @param {Source | AnySource | null} src null: the synthetic demo */
  detectorFor(src) {
    return sources.detectorFor(this, src);
  }

  /**
   * @param {string} name
   * @param {string} label
   */
  changeDetector(name, label) {
    return this.inTurn(() => sources.changeDetector(this, name, label));
  }

  /** @param {File[]} list */
  openDropped(list) {
    return sources.openDropped(this, list);
  }

  // ---------------------------------------------------------------- playback (app/playback.js)

  togglePlay() {
    return playback.togglePlay(this);
  }

  play() {
    return playback.play(this);
  }

  stop() {
    return playback.stop(this);
  }

  run() {
    return playback.run(this);
  }

  /**
   * @param {number} t0
   * @param {number} n
   */
  pace(t0, n) {
    return playback.pace(this, t0, n);
  }

  stepForward() {
    return playback.stepForward(this);
  }

  /** @param {number} n */
  seek(n) {
    return playback.seek(this, n);
  }

  /** @param {number} n */
  show(n) {
    return playback.show(this, n);
  }

  /** @param {number} n */
  paintFrame(n) {
    return playback.paintFrame(this, n);
  }

  // ---------------------------------------------------------------- tracking (app/tracking.js)

  /** @param {{ until: number, display: 'every' | 'throttled' | 'none' }} opts */
  track(opts) {
    return tracking.track(this, opts);
  }

  /**
   * @param {AnySource} src
   * @param {number} n
   * @param {boolean} display
   * @returns {Promise<StepResult>}
   */
  send(src, n, display) {
    return tracking.send(this, src, n, display);
  }

  runOffline() {
    return tracking.runOffline(this);
  }

  /** @param {StepResult} res */
  accept(res) {
    return tracking.accept(this, res);
  }

  /** @param {import('./worker/detectors.js').Warmup | null} w */
  warmupStatus(w) {
    return tracking.warmupStatus(this, w);
  }

  /** @param {string} msg */
  choiceNote(msg) {
    return tracking.choiceNote(this, msg);
  }

  /** @param {NonNullable<StepResult['learned']>} l */
  learnedStep(l) {
    return tracking.learnedStep(this, l);
  }

  // ---------------------------------------------------------------- editing (app/editing.js)

  /**
   * @param {number} id
   * @param {boolean} add shift: make it the second track of a pair
   */
  select(id, add) {
    return editing.select(this, id, add);
  }

  validateSelection() {
    return editing.validateSelection(this);
  }

  deselect() {
    return editing.deselect(this);
  }

  /** @param {number} dir */
  cycleTrack(dir) {
    return editing.cycleTrack(this, dir);
  }

  /** @param {() => import('./model/commands.js').Outcome} fn */
  edit(fn) {
    return editing.edit(this, fn);
  }

  /** @param {import('./model/commands.js').Command | 'renumber'} a */
  action(a) {
    return editing.action(this, a);
  }

  // ---------------------------------------------------------------- follow (app/follow.js)

  /** @param {'box' | 'polygon' | null} mode */
  useTool(mode) {
    return follow.useTool(this, mode);
  }

  followSettings() {
    return follow.followSettings(this);
  }

  followSelected() {
    return follow.followSelected(this);
  }

  /** @param {import('./view/shapetool.js').Shape} shape */
  shapeDrawn(shape) {
    return follow.shapeDrawn(this, shape);
  }

  /**
   * @param {{ x: number, y: number, w: number, h: number }} box
   * @returns {Promise<Uint8Array>}
   */
  boxMask(box) {
    return follow.boxMask(this, box);
  }

  /** @param {Uint8Array} bitmap */
  shapeGiven(bitmap) {
    return follow.shapeGiven(this, bitmap);
  }

  /**
   * @param {{ x: number, y: number }} p
   * @returns {boolean} whether a drag started
   */
  startMove(p) {
    return follow.startMove(this, p);
  }

  endMove() {
    return follow.endMove(this);
  }

  /** @param {() => Promise<void>} fn */
  refusable(fn) {
    return follow.refusable(this, fn);
  }

  cancelFollow() {
    return follow.cancelFollow(this);
  }

  /**
   * @param {AnySource} src
   * @param {number} n
   * @returns {Promise<ImageBitmap | undefined>}
   */
  grab(src, n) {
    return follow.grab(this, src, n);
  }

  /**
   * @param {number} id
   * @param {TrackRecord} key the keyframe (its mask is what is followed)
   * @param {import('./model/follow.js').Leg[]} legs
   * @param {string} [label] the edit's name
   */
  followFrom(id, key, legs, label) {
    return follow.followFrom(this, id, key, legs, label);
  }

  // ---------------------------------------------------------------- annotations (app/annotations.js)

  /**
   * @param {string} name
   * @param {string} text
   */
  parse(name, text) {
    return annotations.parse(this, name, text);
  }

  /**
   * @param {string} name
   * @param {string} text
   */
  importTracks(name, text) {
    return annotations.importTracks(this, name, text);
  }

  /**
   * @param {string} name
   * @param {string} text
   */
  loadGroundTruth(name, text) {
    return annotations.loadGroundTruth(this, name, text);
  }

  /** @param {FormatId} format */
  exportText(format) {
    return annotations.exportText(this, format);
  }

  /** @param {FormatId} format */
  download(format) {
    return annotations.download(this, format);
  }

  // ---------------------------------------------------------------- scores (app/scores.js)

  score() {
    return scores.score(this);
  }

  // ---------------------------------------------------------------- view (app/view.js)

  render() {
    return view.render(this);
  }

  renderNow() {
    return view.renderNow(this);
  }

  renderTransport() {
    return view.renderTransport(this);
  }

  /**
   * @param {string} msg
   * @param {boolean} [error]
   */
  status(msg, error) {
    return view.status(this, msg, error);
  }

  /** @param {unknown} e */
  fail(e) {
    return view.fail(this, e);
  }

  // ---------------------------------------------------------------- controls (app/controls.js)

  bindControls() {
    return controls.bindControls(this);
  }

  /** @param {import('./lib/keys.js').Action} a */
  key(a) {
    return controls.key(this, a);
  }
}
