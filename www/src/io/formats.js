// Which annotation format a file is in, and what to call an export. Reading and writing are
// done by the Rust core (parseRecords / writeRecords): this module only picks the format.

/**
 * @typedef {import('../../pkg/shapetrack.js').Format} FormatId  the formats the core reads and writes
 * @typedef {{ id: FormatId, label: string, ext: string, masks: boolean, needsSize?: boolean }} FormatInfo
 *   `needsSize`: coordinates are relative to the frame, so reading needs its width and height
 */

/** @type {FormatInfo[]} */
export const FORMATS = [
  { id: 'mot', label: 'MOT txt', ext: 'txt', masks: false },
  { id: 'mots', label: 'MOTS txt', ext: 'txt', masks: true },
  { id: 'coco-video', label: 'COCO-video JSON', ext: 'json', masks: true },
  { id: 'cvat', label: 'CVAT video XML', ext: 'xml', masks: true },
  { id: 'scalabel', label: 'Scalabel / BDD100K JSON', ext: 'json', masks: true },
  { id: 'label-studio', label: 'Label Studio video JSON', ext: 'json', masks: false, needsSize: true },
  { id: 'yolo', label: 'YOLO txt with track ids', ext: 'txt', masks: false, needsSize: true },
];

/** @param {string} id @returns {FormatInfo} */
export function formatInfo(id) {
  const f = FORMATS.find((x) => x.id === id);
  if (!f) throw new Error(`unknown format "${id}"`);
  return f;
}

/**
 * Which JSON format a parsed document is, by its shape: Label Studio exports tasks (objects
 * with "annotations" and "data"), Scalabel lists frames (objects with "labels" or
 * "frameIndex", or {"frames": [...]}), COCO-video has "videos"/"annotations" objects or is a
 * results list (objects with "video_id"). Extensions say nothing: all three are .json.
 * @param {unknown} doc
 * @returns {FormatId}
 */
function jsonFormat(doc) {
  /** @param {unknown} o @param {string} k */
  const has = (o, k) => o !== null && typeof o === 'object' && !Array.isArray(o) && k in o;
  const first = Array.isArray(doc) ? doc[0] : doc;
  if (has(first, 'annotations') && (has(first, 'data') || Array.isArray(/** @type {any} */ (first).annotations))) {
    // A COCO file also has "annotations", but beside "videos" / "categories", not "data".
    if (!has(first, 'videos') && !has(first, 'categories')) return 'label-studio';
  }
  if (has(doc, 'frames') || has(first, 'frameIndex') || has(first, 'videoName') || (has(first, 'labels') && !has(first, 'video_id'))) {
    return 'scalabel';
  }
  return 'coco-video';
}

/**
 * Guesses a file's format from its content (and, when the content does not say, its name).
 * @param {string} name
 * @param {string} text
 * @returns {FormatId}
 */
export function guessFormat(name, text) {
  const lower = name.toLowerCase();
  const head = text.trimStart().slice(0, 1);
  if (head === '{' || head === '[' || lower.endsWith('.json')) {
    try {
      return jsonFormat(JSON.parse(text));
    } catch {
      // Malformed: let the COCO reader report where.
      return 'coco-video';
    }
  }
  if (lower.endsWith('.xml') || head === '<') return 'cvat';
  const first = text.split(/\r?\n/).find((l) => l.trim() !== '') ?? '';
  // MOTS: "frame id class height width rle", space-separated, the last field an RLE string
  // (characters 48..111, so never a comma) that is not a plain number.
  const f = first.trim().split(/\s+/);
  if (!first.includes(',') && f.length === 6 && !/^-?[\d.]+$/.test(f[5])) return 'mots';
  // YOLO single file: "frame class cx cy w h [conf] id", space-separated, integer frame and
  // class, centre and size as fractions of the frame (MOT boxes are pixels, so rarely all ≤ 1;
  // a MOT file's "x y w h" of 0/1 would need a 1-pixel box at the origin).
  if (!first.includes(',') && f.length >= 7 && f.length <= 8) {
    const nums = f.map(Number);
    const ints = /^\d+$/.test(f[0]) && /^\d+$/.test(f[1]) && /^-?\d+$/.test(f[f.length - 1]);
    const fractions = nums.slice(2, 6).every((v) => Number.isFinite(v) && v >= -1 && v <= 2) && nums[4] <= 1 && nums[5] <= 1;
    const decimals = f.slice(2, 6).some((v) => v.includes('.'));
    if (ints && fractions && decimals) return 'yolo';
  }
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
