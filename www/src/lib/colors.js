// One colour per track id, stable across runs and far apart for neighbouring ids (golden-angle
// hues), so an identity switch is visible as a colour change.

/** @type {Map<number, { css: string, rgb: [number, number, number] }>} */
const cache = new Map();

/**
 * @param {number} h hue in degrees
 * @param {number} s saturation 0..1
 * @param {number} l lightness 0..1
 * @returns {[number, number, number]}
 */
export function hslToRgb(h, s, l) {
  const a = s * Math.min(l, 1 - l);
  /** @param {number} n */
  const f = (n) => {
    const k = (n + h / 30) % 12;
    return Math.round(255 * (l - a * Math.max(-1, Math.min(k - 3, 9 - k, 1))));
  };
  return [f(0), f(8), f(4)];
}

/**
 * @typedef {{ css: string, rgb: [number, number, number] }} Colour
 * @typedef {(id: number) => Colour} ColourOf how views colour a track id (the app's keeps a
 *   renumbered track's colour)
 */

/**
 * The colour of an id.
 * @param {number} id
 * @returns {Colour}
 */
export function colorOf(id) {
  let c = cache.get(id);
  if (!c) {
    const hue = (((id * 137.50776) % 360) + 360) % 360;
    // Alternate lightness a little so ids with similar hues still differ.
    const rgb = hslToRgb(hue, 0.75, id % 2 ? 0.58 : 0.5);
    c = { css: `rgb(${rgb[0]},${rgb[1]},${rgb[2]})`, rgb };
    cache.set(id, c);
  }
  return c;
}
