import { test } from 'node:test';
import assert from 'node:assert/strict';
import { actionFor, numberFieldIgnores, SHORTCUTS } from '../src/lib/keys.js';
import { FpsMeter } from '../src/lib/fps.js';
import { colorOf, hslToRgb } from '../src/lib/colors.js';

test('keys map to actions, modifiers matter', () => {
  assert.equal(actionFor({ key: ' ' }), 'play');
  assert.equal(actionFor({ key: 'ArrowRight' }), 'fwd');
  assert.equal(actionFor({ key: 'ArrowRight', shiftKey: true }), 'fwd10');
  assert.equal(actionFor({ key: 'z', ctrlKey: true }), 'undo');
  assert.equal(actionFor({ key: 'Z', ctrlKey: true, shiftKey: true }), 'redo');
  assert.equal(actionFor({ key: 'y', metaKey: true }), 'redo');
  assert.equal(actionFor({ key: 'm' }), 'merge');
  assert.equal(actionFor({ key: 'm', ctrlKey: true }), null);
  assert.equal(actionFor({ key: 'Delete', shiftKey: true }), 'deleteRecord');
  assert.equal(actionFor({ key: 'q' }), null);
});

test('every shortcut is reachable: no binding is shadowed by an earlier one', () => {
  const probes = {
    play: { key: ' ' }, back: { key: 'ArrowLeft' }, fwd: { key: 'ArrowRight' },
    back10: { key: 'ArrowLeft', shiftKey: true }, fwd10: { key: 'ArrowRight', shiftKey: true },
    first: { key: 'Home' }, last: { key: 'End' }, merge: { key: 'm' }, swap: { key: 'w' },
    split: { key: 's' }, renumber: { key: 'n' }, delete: { key: 'Delete' },
    deleteRecord: { key: 'Delete', shiftKey: true }, undo: { key: 'z', ctrlKey: true },
    redo: { key: 'z', ctrlKey: true, shiftKey: true }, deselect: { key: 'Escape' },
    prevTrack: { key: '[' }, nextTrack: { key: ']' }, masks: { key: 'k' }, boxes: { key: 'b' },
    trails: { key: 't' }, gt: { key: 'g' }, demo: { key: 'd' }, open: { key: 'o' },
    import: { key: 'i' }, export: { key: 'e' }, help: { key: '?', shiftKey: true },
    follow: { key: 'f' }, drawBox: { key: 'x' }, drawPolygon: { key: 'p' }, closeShape: { key: 'Enter' },
  };
  assert.equal(Object.keys(probes).length, SHORTCUTS.length);
  for (const [action, e] of Object.entries(probes)) assert.equal(actionFor(e), action, action);
});

test('fps meter averages over its window', () => {
  const m = new FpsMeter(4);
  assert.equal(m.fps, 0);
  for (let i = 0; i < 10; i++) m.tick(i * 40);
  assert.ok(Math.abs(m.fps - 25) < 1e-9);
  m.tick(9 * 40 + 20);
  assert.ok(m.fps > 25);
});

test('colours are stable and neighbours differ', () => {
  assert.deepEqual(colorOf(3), colorOf(3));
  const [a, b] = [colorOf(1).rgb, colorOf(2).rgb];
  assert.ok(Math.abs(a[0] - b[0]) + Math.abs(a[1] - b[1]) + Math.abs(a[2] - b[2]) > 100);
  assert.deepEqual(hslToRgb(0, 1, 0.5), [255, 0, 0]);
  assert.deepEqual(hslToRgb(120, 1, 0.5), [0, 255, 0]);
});

test('a number field lets through the shortcuts it has no use for, and keeps what a number needs', () => {
  for (const key of [' ', 'd', 'm', 'k', '?', '[']) assert.equal(numberFieldIgnores({ key }), true, key);
  for (const key of ['0', '7', '-', '+', '.', 'e', 'E', 'Backspace', 'ArrowLeft', 'ArrowUp', 'Enter', 'Tab']) {
    assert.equal(numberFieldIgnores({ key }), false, key);
  }
  assert.equal(numberFieldIgnores({ key: 'z', ctrlKey: true }), false, 'Ctrl+Z undoes in the field');
});
