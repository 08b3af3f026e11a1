// Annotation files in and out: importing tracks, loading ground truth, exporting the track table
// (all read and written by the core).

import { TrackTable } from '../model/tracks.js';
import { byId } from '../lib/dom.js';
import { mayReplace } from './editing.js';
import { guessFormat, exportName, formatInfo } from '../io/formats.js';

/**
 * @typedef {import('../app.js').App} App
 * @typedef {import('../model/tracks.js').TrackRecord} TrackRecord
 * @typedef {import('../io/formats.js').FormatId} FormatId
 */

/**
 * Reads an annotation file through the core.
 * @param {App} app
 * @param {string} name
 * @param {string} text
 */
export function parse(app, name, text) {
  const format = guessFormat(name, text);
  const info = formatInfo(format);
  // Label Studio (percent) and YOLO (fractions) boxes are relative to the frame: they need
  // the open video's size, and a blank canvas has none to offer.
  if (info.needsSize && !app.source) {
    throw new Error(`${name}: ${info.label} boxes are relative to the frame size; open the video first`);
  }
  const meta = info.needsSize ? { width: app.stage.width, height: app.stage.height } : undefined;
  const a = app.core.parseAnnotations(format, text, name, meta);
  if (a.videos > 1) app.status(`${name} holds ${a.videos} videos: reading the first`);
  if (a.labels.length) app.labels = a.labels;
  return a;
}

/**
 * Imports tracks to label (replaces the table; tracking stops). Without an open source the
 * tracks are shown on a blank canvas of the size they imply.
 * @param {App} app
 * @param {string} name
 * @param {string} text
 */
export async function importTracks(app, name, text) {
  const parsed = app.parse(name, text);
  const records = /** @type {TrackRecord[]} */ (parsed.records);
  if (!mayReplace(app, `Importing ${name}`)) return;
  await app.stop();
  app.model.replaceAll(records);
  app.lastEdit = '';
  if (!app.source) {
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
    app.stage.resize(Math.max(1, Math.ceil(w)), Math.max(1, Math.ceil(h)));
    byId('empty').hidden = true;
  }
  const table = app.model.table;
  app.session.imported(Math.max(parsed.frames ?? 0, table.lastFrame()));
  app.status(`${name}: ${records.length} records, ${table.ids().length} tracks`);
  // Stay on the frame shown if the import has tracks there; else open on the first frame that
  // has any (without a source, an empty frame is a blank canvas: it looks like a failed import).
  await app.seek(app.cur && table.at(app.cur).length ? app.cur : table.firstFrame() || 1);
}

/**
 * @param {App} app
 * @param {string} name @param {string} text
 */
export function loadGroundTruth(app, name, text) {
  app.gt = new TrackTable(/** @type {TrackRecord[]} */ (app.parse(name, text).records));
  app.gtName = `file ${name}`;
  app.options.gt = true;
  byId('opt-gt', HTMLInputElement).checked = true;
  app.status(`ground truth ${name}: ${app.gt.size} records`);
  app.scorer.request(true);
  app.render();
}

/**
 * The track table as text in `format` (written by the core).
 * @param {App} app
 * @param {FormatId} format
 */
export function exportText(app, format) {
  return app.core.writeAnnotations(format, app.model.table.all(), {
    width: app.stage.width,
    height: app.stage.height,
    frames: app.lastFrame,
    name: app.source?.name ?? 'shapetrack',
    labels: app.labels,
  });
}

/**
 * @param {App} app
 * @param {FormatId} format
 */
export function download(app, format) {
  const text = app.exportText(format);
  const name = exportName(app.source?.name ?? 'tracks', format);
  const a = document.createElement('a');
  a.href = URL.createObjectURL(new Blob([text], { type: 'text/plain' }));
  a.download = name;
  a.click();
  app.model.markSaved();
  setTimeout(() => URL.revokeObjectURL(a.href), 1000);
  app.status(`saved ${name} (${formatInfo(format).label})`);
}
