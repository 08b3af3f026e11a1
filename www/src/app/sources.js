// Opening a source (the demo scene, a video, an image sequence, the webcam, a dropped file) and
// choosing the detector it is tracked with.

import { TrackTable } from '../model/tracks.js';
import { byId } from '../lib/dom.js';
import { mayReplace } from './editing.js';
import { emptyLearnedStats } from './tracking.js';
import { videoSource, imageSource, webcamSource } from '../sources/sources.js';

/**
 * @typedef {import('../app.js').App} App
 * @typedef {import('../app.js').AnySource} AnySource
 * @typedef {import('../sources/sources.js').Source} Source
 */

/**
 * Opens the synthetic demo scene (rendered and tracked in the worker).
 * @param {App} app
 */
export async function openDemo(app) {
  await app.openSource(null);
}

/**
 * @param {App} app
 * @param {File} file
 */
export async function openVideo(app, file) {
  await app.openSource(await videoSource(byId('video', HTMLVideoElement), file));
}

/**
 * @param {App} app
 * @param {File[]} files
 */
export async function openImages(app, files) {
  await app.openSource(await imageSource(files));
}

/** @param {App} app */
export async function openWebcam(app) {
  await app.openSource(await webcamSource(byId('video', HTMLVideoElement)));
}

/**
 * Starts a tracking session on a source (null: the synthetic demo).
 * @param {App} app
 * @param {Source | null} src
 */
export async function openSource(app, src) {
  if (!mayReplace(app, src ? `Opening ${src.name}` : 'The demo')) {
    src?.close();
    return;
  }
  await app.stop();
  if (app.source && app.source.kind !== 'synth') app.source.close();
  app.status(src ? `opening ${src.name}…` : 'starting the demo scene…');
  /** @type {Awaited<ReturnType<App['worker']['open']>>} */
  let opened;
  try {
    opened = await app.worker.open({
      source: src ? { kind: 'frames', width: src.width, height: src.height, fps: src.fps } : { kind: 'synth', preset: app.scene },
      detector: app.detectorFor(src),
      detectorOptions: detectorOptions(app.detectorFor(src)),
      ...(app.tracker ? { tracker: app.tracker } : {}),
      ...(app.offlineSettings ? { offlineSettings: app.offlineSettings } : {}),
      offline: src?.kind !== 'webcam',
      learned: app.learnedPolicy,
    });
  } catch (e) {
    // The previous source is closed already: leaving its last frame up would look like the
    // new one opened. Nothing is open now (the tracks stay, they can still be exported), the
    // start screen shows, and the error says why.
    src?.close();
    app.source = null;
    app.session.close();
    byId('empty').hidden = false;
    app.render();
    throw e;
  }
  app.learnedStats = emptyLearnedStats();
  /** @type {AnySource} */
  const source = src ?? {
    kind: 'synth',
    name: app.scene,
    width: opened.width,
    height: opened.height,
    frames: opened.frames ?? 0,
    fps: opened.fps,
  };
  app.source = source;
  showDetectorInUse(app, src);
  app.detectorChoice = null;
  app.warming = false;
  // A detector with classes names them: the overlay shows them and exports carry them.
  if (opened.classes.length) app.labels = opened.classes.flatMap((name, i) => (name ? [{ class: i, name }] : []));
  offerClasses(opened.classes);
  app.session.open({ frames: source.frames ?? 0, offlineCapable: opened.offline });
  app.cur = 0;
  app.selection = { a: null, b: null };
  app.fps.reset();
  app.model.replaceAll([]);
  // The undo bar's "last edit" named an edit of the table just replaced.
  app.lastEdit = '';
  if (source.kind === 'synth') {
    app.gt = new TrackTable();
    app.gtName = 'scene ground truth';
  } else if (!app.gtName.startsWith('file')) {
    app.gt = null;
    app.gtName = '';
  }
  app.scores = null;
  app.panel.renderScores(null, app.gt ? app.gtName.replace(/^file /, '') : '');
  app.stage.resize(source.width, source.height);
  byId('empty').hidden = true;
  app.status(`${source.name}: ${source.width}×${source.height}${source.frames ? `, ${source.frames} frames` : ''} · core ${opened.version}`);
  await app.stepForward();
}

/**
 * The detector a source gets: the menu's, except that `auto` keeps the background detector
 * on the synthetic demo (a still camera by construction; its quality figures are the
 * background detector's).
 * @param {App} app
 * @param {Source | AnySource | null} src null: the synthetic demo
 */
export function detectorFor(app, src) {
  return app.detector === 'auto' && (!src || src.kind === 'synth') ? 'background' : app.detector;
}

/** The object detectors, whose classes and scores the page's filter sets. */
const OBJECT_DETECTORS = new Set(['ssd', 'ssd-moving', 'moving-ssd']);

/**
 * The options of detector `name` from the page's object filter (classes kept, lowest score,
 * shortest track):
 * undefined when it sets nothing or the detector has no classes. A score outside [0, 1] is
 * refused here, naming the field.
 * @param {string} name
 * @returns {Record<string, unknown> | undefined}
 */
export function detectorOptions(name) {
  if (!OBJECT_DETECTORS.has(name)) return undefined;
  const classes = byId('det-classes', HTMLInputElement)
    .value.split(',')
    .map((c) => c.trim())
    .filter((c) => c);
  const text = byId('det-score', HTMLInputElement).value.trim();
  const minScore = text === '' ? undefined : Number(text);
  if (minScore !== undefined && !(minScore >= 0 && minScore <= 1)) throw new Error(`Min score must be between 0 and 1, not ${text}`);
  const framesText = byId('det-frames', HTMLInputElement).value.trim();
  const minFrames = framesText === '' ? undefined : Number(framesText);
  if (minFrames !== undefined && !(Number.isInteger(minFrames) && minFrames >= 1 && minFrames <= 1000)) {
    throw new Error(`Min frames must be a whole number from 1 to 1000, not ${framesText}`);
  }
  const ssd = {
    ...(classes.length ? { classes } : {}),
    ...(minScore !== undefined ? { minScore } : {}),
    ...(minFrames !== undefined ? { minFrames } : {}),
  };
  if (!Object.keys(ssd).length) return undefined;
  return name === 'moving-ssd' ? { ssd } : ssd;
}

/**
 * The object filter's suggestions: the detector's class names (none for a detector without).
 * @param {string[]} classes by index, '' for classes never reported
 */
function offerClasses(classes) {
  const list = byId('det-class-list');
  list.replaceChildren(...classes.filter((c) => c).map((c) => Object.assign(document.createElement('option'), { value: c })));
}

/**
 * Shows the object filter when the Detector menu holds an object detector.
 * @param {App} app
 */
export function showObjectFilter(app) {
  byId('det-objects').hidden = !OBJECT_DETECTORS.has(app.detector);
}

/**
 * Says in the Detector menu what `auto` runs on this source when that is settled before any
 * frame (the demo: the background detector), so the menu does not read "Automatic" over a
 * detector it did not choose; any other source shows the plain label (the status line says
 * what auto chose once it has).
 * @param {App} app
 * @param {Source | AnySource | null | undefined} src null: the synthetic demo; undefined: no
 *   source open
 */
export function showDetectorInUse(app, src) {
  const menu = byId('detector', HTMLSelectElement);
  const auto = /** @type {HTMLOptionElement | undefined} */ ([...menu.options].find((o) => o.value === 'auto'));
  if (!auto) return;
  auto.dataset.label ??= auto.text;
  const used = src === undefined ? app.detector : detectorFor(app, src);
  const option = [...menu.options].find((o) => o.value === used);
  const name = option?.dataset.label ?? option?.text ?? used;
  auto.text = app.detector === 'auto' && used !== 'auto' ? `${auto.dataset.label} (the demo: ${name})` : auto.dataset.label;
}

/**
 * Uses another detector: for the next source, and, while a source is being tracked, from its
 * next frame on (the tracks so far stay; nothing is reopened).
 * @param {App} app
 * @param {string} name
 * @param {string} label
 */
export async function changeDetector(app, name, label) {
  app.detector = name;
  showObjectFilter(app);
  showDetectorInUse(app, app.source ?? undefined);
  if (app.session.phase !== 'tracking') {
    app.status(`detector: ${label} (for the next video)`);
    return;
  }
  // Frames in flight finish with the old detector; the switch lands between two frames.
  const wasPlaying = app.playing;
  await app.stop();
  const used = app.detectorFor(app.source);
  const { classes } = await app.worker.setDetector(used, detectorOptions(used));
  app.detectorChoice = null;
  app.warming = false;
  if (classes.length) app.labels = classes.flatMap((n, i) => (n ? [{ class: i, name: n }] : []));
  offerClasses(classes);
  // The shortest track is the tracker's setting: a tracker that has reported keeps its own.
  const frames = OBJECT_DETECTORS.has(used) && byId('det-frames', HTMLInputElement).value.trim() !== '' && app.session.processed > 0;
  app.status(`detector: ${label} from frame ${app.session.processed + 1}${frames ? ' (Min frames: from the next video)' : ''}`);
  if (wasPlaying) app.play();
}

/**
 * @param {App} app
 * @param {File[]} list
 */
export async function openDropped(app, list) {
  if (!list.length) return;
  const video = list.find((f) => f.type.startsWith('video/'));
  if (video) return app.openVideo(video);
  const images = list.filter((f) => f.type.startsWith('image/'));
  if (images.length) return app.openImages(images);
  return app.importTracks(list[0].name, await list[0].text());
}
