// Keyboard shortcuts: one table, used both to dispatch keys and to draw the help dialog, so the
// two never disagree. Pure (no DOM) for the unit tests.

/**
 * @typedef {'play' | 'back' | 'fwd' | 'back10' | 'fwd10' | 'first' | 'last' | 'merge' | 'swap'
 *   | 'split' | 'renumber' | 'delete' | 'deleteRecord' | 'undo' | 'redo' | 'deselect'
 *   | 'prevTrack' | 'nextTrack' | 'masks' | 'boxes' | 'trails' | 'gt' | 'help' | 'demo'
 *   | 'open' | 'import' | 'export' | 'follow' | 'drawBox' | 'drawPolygon' | 'closeShape'} Action
 *
 * @typedef {{ key: string, ctrlKey?: boolean, metaKey?: boolean, shiftKey?: boolean, altKey?: boolean }} KeyLike
 */

/** @type {Array<{ keys: string, action: Action, what: string, match: (e: KeyLike) => boolean }>} */
export const SHORTCUTS = [];

/**
 * @param {string} keys
 * @param {Action} action
 * @param {string} what
 * @param {(e: KeyLike) => boolean} match
 */
function bind(keys, action, what, match) {
  SHORTCUTS.push({ keys, action, what, match });
}

/** @param {KeyLike} e */
const mod = (e) => Boolean(e.ctrlKey || e.metaKey);
/** @param {string} k @returns {(e: KeyLike) => boolean} */
const plain = (k) => (e) => !mod(e) && !e.altKey && !e.shiftKey && e.key.toLowerCase() === k;

bind('Space', 'play', 'play / pause', (e) => !mod(e) && e.key === ' ');
bind('←', 'back', 'previous frame', (e) => !mod(e) && !e.shiftKey && e.key === 'ArrowLeft');
bind('→', 'fwd', 'next frame', (e) => !mod(e) && !e.shiftKey && e.key === 'ArrowRight');
bind('Shift+←', 'back10', '10 frames back', (e) => !mod(e) && Boolean(e.shiftKey) && e.key === 'ArrowLeft');
bind('Shift+→', 'fwd10', '10 frames on', (e) => !mod(e) && Boolean(e.shiftKey) && e.key === 'ArrowRight');
bind('Home', 'first', 'first frame', (e) => e.key === 'Home');
bind('End', 'last', 'last frame', (e) => e.key === 'End');
bind('M', 'merge', 'merge the second selected track into the first', plain('m'));
bind('W', 'swap', 'swap the two selected ids from this frame on', plain('w'));
bind('S', 'split', 'split the selected track at this frame', plain('s'));
bind('N', 'renumber', 'give the selected track a new number', plain('n'));
bind('Del', 'delete', 'delete the selected track', (e) => !mod(e) && !e.shiftKey && (e.key === 'Delete' || e.key === 'Backspace'));
bind('Shift+Del', 'deleteRecord', 'delete the selected track in this frame only', (e) => !mod(e) && Boolean(e.shiftKey) && (e.key === 'Delete' || e.key === 'Backspace'));
bind('Ctrl+Z', 'undo', 'undo', (e) => mod(e) && !e.shiftKey && e.key.toLowerCase() === 'z');
bind('Ctrl+Shift+Z', 'redo', 'redo (also Ctrl+Y)', (e) => mod(e) && ((Boolean(e.shiftKey) && e.key.toLowerCase() === 'z') || e.key.toLowerCase() === 'y'));
bind('Esc', 'deselect', 'clear the selection', (e) => e.key === 'Escape');
bind('[', 'prevTrack', 'select the previous track', (e) => !mod(e) && e.key === '[');
bind(']', 'nextTrack', 'select the next track', (e) => !mod(e) && e.key === ']');
bind('K', 'masks', 'show / hide masks', plain('k'));
bind('B', 'boxes', 'show / hide boxes', plain('b'));
bind('T', 'trails', 'show / hide trails', plain('t'));
bind('G', 'gt', 'show / hide ground truth', plain('g'));
bind('D', 'demo', 'start the demo scene', plain('d'));
bind('O', 'open', 'open a video', plain('o'));
bind('I', 'import', 'import tracks', plain('i'));
bind('E', 'export', 'export tracks', plain('e'));
bind('F', 'follow', 'follow the selected shape from this frame', plain('f'));
bind('X', 'drawBox', 'draw a box to follow (or to correct the selected followed track here)', plain('x'));
bind('P', 'drawPolygon', 'draw a polygon to follow: click its corners', plain('p'));
bind('Enter', 'closeShape', 'close the polygon being drawn', (e) => !mod(e) && e.key === 'Enter');
bind('?', 'help', 'this help and the legend of the marks', (e) => e.key === '?');

/**
 * @param {KeyLike} e
 * @returns {Action | null}
 */
export function actionFor(e) {
  for (const s of SHORTCUTS) if (s.match(e)) return s.action;
  return null;
}

/**
 * Whether a number field (the follow's Frames box, the new-id field) has no use for `e`: a
 * space, or a printable key that cannot be part of a number. Such a key leaves the field and
 * acts as its shortcut, instead of vanishing (typing Space there to play did nothing).
 * @param {KeyLike} e
 */
export function numberFieldIgnores(e) {
  if (mod(e) || e.altKey) return false;
  return e.key === ' ' || (e.key.length === 1 && !/[0-9eE+\-.,]/.test(e.key));
}
