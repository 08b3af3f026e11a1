// The side panel: the selected track(s) with their edit actions, the live scores, the track
// list. Pure view: it renders what it is given and reports clicks through callbacks.

import { byId, h } from '../lib/dom.js';
import { colorOf } from '../lib/colors.js';

/**
 * @typedef {import('../model/tracks.js').TrackTable} TrackTable
 * @typedef {{ a: number | null, b: number | null }} Selection
 * @typedef {import('../../pkg/shapetrack.js').Scores} Scores  percentages, as TrackEval prints them
 */


/** Height of a track-list row in CSS px (`.track-list li` in style.css sets the same). */
const LIST_ROW = 20;
/** Rows drawn above and below the ones in view, so a fast scroll shows no gap. */
const LIST_MARGIN = 10;

export class Panel {
  /**
   * @param {{
   *   onSelect: (id: number, add: boolean) => void,
   *   onAction: (a: 'merge' | 'swap' | 'split' | 'renumber' | 'delete' | 'undo' | 'redo') => void,
   *   onRenumber: (id: number) => void,
   * }} handlers
   * @param {import('../lib/colors.js').ColourOf} [colour] a track's colour by id
   */
  constructor(handlers, colour = colorOf) {
    this.handlers = handlers;
    this.colour = colour;
    this.none = byId('sel-none');
    this.info = byId('sel-info');
    this.chipA = byId('sel-a');
    this.chipB = byId('sel-b');
    this.facts = byId('sel-facts');
    this.list = byId('track-list');
    this.count = byId('track-count');
    this.metrics = byId('metrics-body');
    this.metricsSrc = byId('metrics-src');
    this.renumberForm = byId('renumber-form', HTMLFormElement);
    this.renumberInput = byId('renumber-input', HTMLInputElement);
    this.buttons = {
      merge: byId('act-merge', HTMLButtonElement),
      swap: byId('act-swap', HTMLButtonElement),
      split: byId('act-split', HTMLButtonElement),
      renumber: byId('act-renumber', HTMLButtonElement),
      delete: byId('act-delete', HTMLButtonElement),
      undo: byId('undo', HTMLButtonElement),
      redo: byId('redo', HTMLButtonElement),
    };
    this.lastEdit = byId('last-edit');
    for (const [name, btn] of Object.entries(this.buttons)) {
      btn.addEventListener('click', () => handlers.onAction(/** @type {any} */ (name)));
    }
    this.renumberForm.addEventListener('submit', (e) => {
      e.preventDefault();
      const v = Number(this.renumberInput.value);
      this.cancelRenumber();
      handlers.onRenumber(v);
    });
    this.list.addEventListener('click', (e) => {
      const li = /** @type {HTMLElement | null} */ (/** @type {HTMLElement} */ (e.target).closest('li[data-id]'));
      if (li) handlers.onSelect(Number(li.dataset.id), e.shiftKey);
    });
    this.listKey = '';
    this.list.addEventListener('scroll', () => this.renderListWindow(), { passive: true });
  }

  /** @param {HTMLElement} chip @param {number} id */
  paintChip(chip, id) {
    chip.textContent = String(id);
    chip.style.background = this.colour(id).css;
  }

  /**
   * Hides the inline "new id" field (Enter, Escape, or the selection went away) and gives the
   * keyboard back to the page. A hidden field keeps focus until the browser's next rendering
   * pass; a shortcut typed before then (Enter, then D at once, or on a busy machine) would land
   * in the field and be dropped.
   */
  cancelRenumber() {
    this.renumberForm.hidden = true;
    if (document.activeElement === this.renumberInput) this.renumberInput.blur();
  }

  /** Shows the inline "new id" field. @param {number} suggestion */
  askRenumber(suggestion) {
    this.renumberForm.hidden = false;
    this.renumberInput.value = String(suggestion);
    this.renumberInput.focus();
    this.renumberInput.select();
  }

  /**
   * @param {{ table: TrackTable, selection: Selection, frame: number, canUndo: boolean, canRedo: boolean, lastEdit: string, busy?: boolean }} s
   *   `busy`: tracking is running; the track list then refreshes a few times a second
   */
  render({ table, selection, frame, canUndo, canRedo, lastEdit, busy = false }) {
    const { a, b } = selection;
    const has = a !== null && table.has(a);
    if (!has) this.cancelRenumber();
    this.none.hidden = has;
    this.info.hidden = !has;
    if (has && a !== null) {
      this.paintChip(this.chipA, a);
      this.chipB.hidden = b === null;
      if (b !== null) this.paintChip(this.chipB, b);
      const span = table.span(a);
      const recs = table.track(a);
      const runs = table.runs(a).length;
      const here = table.get(frame, a);
      /** @type {Array<[string, string]>} */
      const facts = [
        ['frames', span ? `${span[0]}–${span[1]} (${recs.length})` : '–'],
        ['pieces', String(runs)],
        ['here', here ? `${Math.round(here.bbox.w)}×${Math.round(here.bbox.h)} at ${Math.round(here.bbox.x)},${Math.round(here.bbox.y)}${here.interpolated ? ', filled in' : ''}` : 'not in this frame'],
      ];
      const filled = recs.filter((r) => r.interpolated).length;
      // Filled in by the online tracker's coasting or by the offline pass: not seen, either way.
      if (filled) facts.splice(2, 0, ['filled in', `${filled} frame${filled === 1 ? '' : 's'} (not seen: bridged between sightings)`]);
      this.facts.replaceChildren(...facts.flatMap(([k, v]) => [h('dt', {}, [k]), h('dd', {}, [v])]));
      const two = b !== null && table.has(b);
      this.buttons.merge.disabled = !two;
      this.buttons.swap.disabled = !two;
      this.buttons.split.disabled = !span || frame <= span[0] || frame > span[1];
      this.buttons.renumber.disabled = false;
      this.buttons.delete.disabled = false;
    }
    this.buttons.undo.disabled = !canUndo;
    this.buttons.redo.disabled = !canRedo;
    this.lastEdit.textContent = lastEdit;
    // The count is one number: it follows every frame, like the timeline's rows, while the
    // list's rows are rebuilt a few times a second during tracking.
    const count = String(table.trackCount);
    if (this.count.textContent !== count) this.count.textContent = count;
    const now = performance.now();
    if (!busy || now - this.listAt > 400) this.renderList(table, selection);
  }

  /** When the track list was last rebuilt. */
  listAt = 0;

  /** @type {number[]} the ids the list shows, ascending */
  listIds = [];

  /** @type {TrackTable | null} */
  listTable = null;

  /** @type {Selection} */
  listSel = { a: null, b: null };

  /** The rows drawn last (first row, count): scrolling within them redraws nothing. */
  listWindow = '';

  /**
   * The track list is virtualised: it holds one element per row in view (plus a margin) and
   * two spacers standing in for the rest, so a thousand tracks cost what twenty do.
   * @param {TrackTable} table
   * @param {Selection} selection
   */
  renderList(table, selection) {
    const key = `${table.version}:${selection.a}:${selection.b}`;
    if (key === this.listKey) return;
    const newSel = selection.a !== this.listSel.a;
    this.listKey = key;
    this.listAt = performance.now();
    this.listIds = table.ids();
    this.listTable = table;
    this.listSel = { ...selection };
    if (newSel && selection.a !== null) {
      // A track selected elsewhere (stage, timeline) is scrolled into view once.
      const i = this.listIds.indexOf(selection.a);
      const top = i * LIST_ROW;
      const el = this.list;
      if (i >= 0 && (top < el.scrollTop || top + LIST_ROW > el.scrollTop + el.clientHeight)) {
        el.scrollTop = Math.max(0, top - el.clientHeight / 2);
      }
    }
    this.listWindow = '';
    this.renderListWindow();
  }

  /** Draws the rows in view (called on scroll too). */
  renderListWindow() {
    const table = this.listTable;
    if (!table) return;
    const ids = this.listIds;
    const el = this.list;
    const first = Math.max(0, Math.floor(el.scrollTop / LIST_ROW) - LIST_MARGIN);
    const count = Math.ceil((el.clientHeight || 400) / LIST_ROW) + 2 * LIST_MARGIN;
    const last = Math.min(ids.length, first + count);
    const win = `${first}:${last}`;
    if (win === this.listWindow) return;
    this.listWindow = win;
    const { a, b } = this.listSel;
    const spacer = (/** @type {number} */ rows) => h('li', { class: 'spacer', 'aria-hidden': 'true', style: `height:${rows * LIST_ROW}px` });
    const items = ids.slice(first, last).map((id) => {
      const span = table.span(id);
      return h('li', { 'data-id': String(id), class: id === a || id === b ? 'sel' : '' }, [
        h('span', { class: 'sw', style: `background:${this.colour(id).css}` }),
        h('span', {}, [String(id)]),
        h('span', { class: 'span' }, [span ? `${span[0]}–${span[1]}` : '']),
      ]);
    });
    // Replacing the children keeps the scroll position: the spacers keep the list's height.
    this.list.replaceChildren(spacer(first), ...items, spacer(ids.length - last));
  }

  /**
   * @param {Scores | null} s
   * @param {string} source where the ground truth came from
   */
  renderScores(s, source) {
    this.metricsSrc.textContent = source ? `vs ${source}` : '';
    if (!s) {
      // A new source starts without scores: the last source's figures must not stay up as if
      // they were this one's (issue 66: the demo's MOTA stayed on the user's own footage).
      this.metrics.replaceChildren(
        h('p', { class: 'muted' }, [source ? `Scores against ${source} appear as frames are tracked.` : 'Load ground truth (or run the demo) to see MOTA, IDF1 and HOTA live.']),
      );
      return;
    }
    const pct = (/** @type {number} */ v) => (Number.isFinite(v) ? v.toFixed(1) : '–');
    /** @type {Array<[string, string]>} */
    const cells = [
      ['MOTA', pct(s.mota)],
      ['IDF1', pct(s.idf1)],
      ['HOTA', pct(s.hota)],
      ['DetA', pct(s.deta)],
      ['AssA', pct(s.assa)],
      ['IDSW', String(s.idsw)],
    ];
    this.metrics.replaceChildren(
      ...cells.map(([k, v]) => h('div', { class: 'm', 'data-metric': k }, [h('div', { class: 'v' }, [v]), h('div', { class: 'k' }, [k])])),
    );
  }
}
