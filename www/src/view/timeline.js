// The track timeline — the thesis' "two-dimensional barcode" (Fig. 36–40): one row per track
// id, one column per frame, a bar wherever the track exists. Fragmented identities show as
// broken rows, identity switches as bars that stop where another starts. Click a row to select
// the track and jump to that frame; shift-click adds a second track (merge, swap). Spans the
// offline pass filled in (interpolated shapes) are hatched, so what was seen and what was
// inferred stay apart.

import { colorOf } from '../lib/colors.js';

/**
 * @typedef {import('../model/tracks.js').TrackTable} TrackTable
 * @typedef {{ a: number | null, b: number | null }} Selection
 */

const GUTTER = 34; // px for the id labels

export class Timeline {
  /**
   * @param {HTMLCanvasElement} canvas
   * @param {(pick: { id: number | null, frame: number, add: boolean }) => void} onPick
   * @param {import('../lib/colors.js').ColourOf} [colour] a track's colour by id
   */
  constructor(canvas, onPick, colour = colorOf) {
    this.colour = colour;
    this.canvas = canvas;
    this.ctx = /** @type {CanvasRenderingContext2D} */ (canvas.getContext('2d'));
    this.onPick = onPick;
    /** First row shown (the barcode scrolls when there are more tracks than rows). */
    this.scroll = 0;
    /** @type {number[]} */
    this.ids = [];
    this.frames = 1;
    this.rowH = 8;
    /** Cache key of the bars layer, and when it was drawn. */
    this.key = '';
    this.barsAt = 0;
    this.bars = document.createElement('canvas');
    /** Hatch patterns for filled-in spans, by colour and size. @type {Map<string, CanvasPattern | null>} */
    this.hatches = new Map();
    /** @type {Parameters<Timeline['render']>[0] | null} */
    this.last = null;
    canvas.addEventListener('pointerdown', (e) => this.pick(e));
    canvas.addEventListener('pointermove', (e) => this.hover(e));
    canvas.addEventListener(
      'wheel',
      (e) => {
        const rows = this.visibleRows();
        if (this.ids.length <= rows) return;
        e.preventDefault();
        this.scroll = Math.max(0, Math.min(this.ids.length - rows, this.scroll + Math.sign(e.deltaY) * 3));
        this.key = '';
        if (this.last) this.render(this.last);
      },
      { passive: false },
    );
    new ResizeObserver(() => {
      this.key = '';
      if (this.last) this.render(this.last);
    }).observe(canvas);
  }

  visibleRows() {
    return Math.max(1, Math.floor((this.canvas.height - 4) / this.rowH));
  }

  /** @param {MouseEvent} e */
  locate(e) {
    const r = this.canvas.getBoundingClientRect();
    const x = ((e.clientX - r.left) / r.width) * this.canvas.width;
    const y = ((e.clientY - r.top) / r.height) * this.canvas.height;
    const w = this.canvas.width - GUTTER;
    const frame = Math.min(this.frames, Math.max(1, Math.floor(((x - GUTTER) / w) * this.frames) + 1));
    const row = Math.floor((y - 2) / this.rowH) + this.scroll;
    const id = row >= 0 && row < this.ids.length ? this.ids[row] : null;
    return { id, frame };
  }

  /** @param {PointerEvent} e */
  pick(e) {
    const { id, frame } = this.locate(e);
    this.onPick({ id, frame, add: e.shiftKey });
  }

  /** @param {PointerEvent} e */
  hover(e) {
    const { id, frame } = this.locate(e);
    const filled = id !== null && !!this.last?.table.get(frame, id)?.interpolated;
    this.canvas.title = id === null ? `frame ${frame}` : `track ${id} · frame ${frame}${filled ? ' (filled in)' : ''}`;
  }

  /**
   * @param {{ table: TrackTable, frames: number, frame: number, selection: Selection, busy?: boolean }} s
   *   `busy`: tracking is running, so the bars (which change every frame) may lag a little
   */
  render(s) {
    this.last = s;
    const { canvas, ctx } = this;
    const dpr = globalThis.devicePixelRatio || 1;
    const cw = Math.round(canvas.clientWidth * dpr);
    const ch = Math.round(canvas.clientHeight * dpr);
    if (cw > 0 && (canvas.width !== cw || canvas.height !== ch)) {
      canvas.width = cw;
      canvas.height = ch;
    }
    this.ids = s.table.ids();
    this.frames = Math.max(1, s.frames, s.table.lastFrame());
    // Rows shrink to fit every track, down to 2 px; below that the barcode scrolls.
    this.rowH = Math.max(2 * dpr, Math.min(14 * dpr, Math.floor((canvas.height - 4) / Math.max(1, this.ids.length))));
    this.scroll = Math.min(this.scroll, Math.max(0, this.ids.length - this.visibleRows()));
    const key = `${s.table.version}:${this.frames}:${canvas.width}x${canvas.height}:${this.scroll}:${this.ids.length}`;
    const now = performance.now();
    if (key !== this.key && (!s.busy || now - this.barsAt > 150)) {
      this.drawBars(s.table);
      this.key = key;
      this.barsAt = now;
    }
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    ctx.drawImage(this.bars, 0, 0);
    const w = canvas.width - GUTTER;
    const fx = (/** @type {number} */ f) => GUTTER + ((f - 1) / this.frames) * w;
    // Selected rows: a light band across the whole row and a marker in the gutter, visible
    // even when rows are 2 px high.
    for (const id of [s.selection.a, s.selection.b]) {
      if (id === null) continue;
      const row = this.ids.indexOf(id) - this.scroll;
      if (row < 0 || row >= this.visibleRows()) continue;
      const y = 2 + row * this.rowH;
      const band = Math.max(this.rowH, 4 * dpr);
      const top = y + this.rowH / 2 - band / 2;
      ctx.fillStyle = 'rgba(255,255,255,0.16)';
      ctx.fillRect(GUTTER, top, w, band);
      ctx.fillStyle = '#fff';
      ctx.beginPath();
      ctx.moveTo(GUTTER - 2, y + this.rowH / 2);
      ctx.lineTo(GUTTER - 2 - 6 * dpr, top - 2 * dpr);
      ctx.lineTo(GUTTER - 2 - 6 * dpr, top + band + 2 * dpr);
      ctx.fill();
    }
    const x = fx(s.frame) + w / this.frames / 2;
    ctx.fillStyle = '#fff';
    ctx.fillRect(Math.round(x) - dpr / 2, 0, Math.max(1, dpr), canvas.height);
  }

  /**
   * Diagonal stripes in the track's colour over a faint wash of it.
   * @param {CanvasRenderingContext2D} ctx
   * @param {number} id
   * @param {number} dpr
   */
  hatch(ctx, id, dpr) {
    const n = Math.max(4, Math.round(5 * dpr));
    const { css, rgb } = this.colour(id);
    const key = `${css}:${n}`;
    let p = this.hatches.get(key);
    if (p === undefined) {
      const tile = document.createElement('canvas');
      tile.width = tile.height = n;
      const g = /** @type {CanvasRenderingContext2D} */ (tile.getContext('2d'));
      const [r, gr, b] = rgb;
      g.fillStyle = `rgba(${r},${gr},${b},0.22)`;
      g.fillRect(0, 0, n, n);
      g.strokeStyle = css;
      g.lineWidth = Math.max(1, dpr * 1.2);
      g.beginPath();
      // The main diagonal and the two corner pieces: the tile repeats seamlessly.
      for (const o of [-n, 0, n]) {
        g.moveTo(o, n);
        g.lineTo(o + n, 0);
      }
      g.stroke();
      p = ctx.createPattern(tile, 'repeat');
      this.hatches.set(key, p);
    }
    return p;
  }

  /** @param {TrackTable} table */
  drawBars(table) {
    const { canvas } = this;
    const bars = this.bars;
    bars.width = canvas.width;
    bars.height = canvas.height;
    const ctx = /** @type {CanvasRenderingContext2D} */ (bars.getContext('2d'));
    const w = canvas.width - GUTTER;
    const fw = w / this.frames;
    const rows = this.visibleRows();
    const gap = this.rowH >= 6 ? 1 : 0;
    const dpr = globalThis.devicePixelRatio || 1;
    const labels = this.rowH >= 9 * dpr;
    ctx.font = `${Math.min(this.rowH - 1, 11 * dpr)}px ui-monospace, monospace`;
    ctx.textBaseline = 'middle';
    ctx.textAlign = 'right';
    for (let row = 0; row < rows && row + this.scroll < this.ids.length; row++) {
      const id = this.ids[row + this.scroll];
      const y = 2 + row * this.rowH;
      const solid = this.colour(id).css;
      for (const [a, b, filled] of table.spans(id)) {
        ctx.fillStyle = filled ? (this.hatch(ctx, id, dpr) ?? solid) : solid;
        // At least one device pixel wide, so a single-frame track is still visible.
        ctx.fillRect(GUTTER + (a - 1) * fw, y, Math.max(1, (b - a + 1) * fw), this.rowH - gap);
      }
      if (labels) {
        ctx.fillStyle = '#8a909c';
        ctx.fillText(String(id), GUTTER - 4, y + this.rowH / 2);
      }
    }
    if (this.ids.length > rows) {
      ctx.fillStyle = '#8a909c';
      ctx.textAlign = 'left';
      ctx.fillText(`${this.scroll + 1}–${Math.min(this.ids.length, this.scroll + rows)}/${this.ids.length}`, 2, canvas.height - 8);
    }
  }
}
