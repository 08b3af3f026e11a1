// Which annotation format a file is in, and what to call an export. Reading and writing are
// done by the Rust core (parseRecords / writeRecords): this module only picks the format.

/**
 * @typedef {import('../../pkg/shapetrack.js').Format} FormatId  the formats the core reads and writes
 * @typedef {{ id: FormatId, label: string, ext: string, masks: boolean }} FormatInfo
 */

/** @type {FormatInfo[]} */
export const FORMATS = [
  { id: 'mot', label: 'MOT txt', ext: 'txt', masks: false },
  { id: 'mots', label: 'MOTS txt', ext: 'txt', masks: true },
  { id: 'coco-video', label: 'COCO-video JSON', ext: 'json', masks: true },
  { id: 'cvat', label: 'CVAT video XML', ext: 'xml', masks: true },
];

/** @param {string} id @returns {FormatInfo} */
export function formatInfo(id) {
  const f = FORMATS.find((x) => x.id === id);
  if (!f) throw new Error(`unknown format "${id}"`);
  return f;
}

/**
 * Guesses a file's format from its name and first line.
 * @param {string} name
 * @param {string} text
 * @returns {FormatId}
 */
export function guessFormat(name, text) {
  const lower = name.toLowerCase();
  const head = text.trimStart().slice(0, 1);
  if (lower.endsWith('.json') || head === '{' || head === '[') return 'coco-video';
  if (lower.endsWith('.xml') || head === '<') return 'cvat';
  const first = text.split(/\r?\n/).find((l) => l.trim() !== '') ?? '';
  // MOTS: "frame id class height width rle", space-separated, the last field an RLE string
  // (characters 48..111, so never a comma) that is not a plain number.
  const f = first.trim().split(/\s+/);
  if (!first.includes(',') && f.length === 6 && !/^-?[\d.]+$/.test(f[5])) return 'mots';
  return 'mot';
}

/**
 * A file name for an export of `base` in `format`.
 * @param {string} base
 * @param {FormatId} format
 */
export function exportName(base, format) {
  const stem = base.replace(/\.[^.]*$/, '').replace(/[^\w.-]+/g, '_') || 'tracks';
  return `${stem}.${format}.${formatInfo(format).ext}`;
}
