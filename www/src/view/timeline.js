// The track timeline — the thesis' "two-dimensional barcode" (Fig. 36–40): one row per track
// id, one column per frame, a bar wherever the track exists. Fragmented identities show as
// broken rows, identity switches as bars that stop where another starts. Click a row to select
// the track and jump to that frame; shift-click adds a second track (merge, swap). Spans the
// offline pass filled in (interpolated shapes) are hatched, so what was seen and what was
// inferred stay apart. Spans a follow made (model/follow.js) carry a white band along the
// row's foot, and each keyframe (a shape the labeller gave) a white tick across the row.
//
// A labelling session can hold a thousand tracks over thousands of frames, so the timeline is a
// window onto the barcode (lib/viewport.js): rows stay tall enough to carry their id and scroll
// (wheel, or drag the scrollbar), the frame axis zooms around the pointer (Ctrl+wheel, the +/−
// buttons) and pans (Shift+wheel), the window follows the playhead and scrolls to a track
// selected elsewhere. Only the rows and frames in view are drawn, so the cost of a redraw
// depends on the canvas, not on the number of tracks.

import { colorOf } from '../lib/colors.js';
import { Viewport } from '../lib/viewport.js';
import { followedSpans } from '../model/follow.js';

/**
 * @typedef {import('../model/tracks.js').TrackTable} TrackTable
 * @typedef {{ a: number | null, b: number | null }} Selection
 * @typedef {{ zoomIn?: HTMLElement, zoomOut?: HTMLElement, all?: HTMLElement, rows?: HTMLElement, range?: HTMLElement }} TimelineControls
 */

/** Row height in CSS px when rows are readable (id labels fit), and the most a row grows to. */
const ROW_READABLE = 12;
const ROW_MAX = 14;
/** Row height in CSS px in the compact (overview) layout, where every track fits if it can. */
const ROW_COMPACT = 2;
/** Scrollbar width in CSS px, drawn when there are more rows than fit. */
const SCROLLBAR = 8;
/** Zoom factor per wheel notch and per button press. */
const ZOOM_STEP = 1.25;
const ZOOM_BUTTON = 2;

export class Timeline {
  /**
   * @param {HTMLCanvasElement} canvas
   * @param {(pick: { id: number | null, frame: number, add: boolean }) => void} onPick
   * @param {import('../lib/colors.js').ColourOf} [colour] a track's colour by id
   * @param {TimelineControls} [controls] buttons and the range readout beside the canvas
   */
  constructor(canvas, onPick, colour = colorOf, controls = {}) {
    this.colour = colour;
    this.canvas = canvas;
    this.ctx = /** @type {CanvasRenderingContext2D} */ (canvas.getContext('2d'));
    this.onPick = onPick;
    this.controls = controls;
    this.view = new Viewport();
    /** Compact rows: the whole barcode at a glance, ids in the tooltip only. */
    this.compact = false;
    /** @type {number[]} the table's ids, ascending (cached by table version) */
    this.ids = [];
    this.idsVersion = -1;
    /** @type {TrackTable | null} */
    this.idsTable = null;
    this.rowH = 8;
    this.gutter = 34;
    /** Cache key of the bars layer, and when it was drawn. */
    this.key = '';
    this.barsAt = 0;
    this.bars = document.createElement('canvas');
    /** Hatch patterns for filled-in spans, by colour and size. @type {Map<string, CanvasPattern | null>} */
    this.hatches = new Map();
    /** @type {Parameters<Timeline['render']>[0] | null} */
    this.last = null;
    /** The selected id the rows were last scrolled to (a new selection scrolls once). */
    this.revealed = /** @type {number | null} */ (null);
    /** The frame the window last followed (a new frame pages it once; panning away stays). */
    this.followed = 0;
    /** Whether a scrollbar drag is in progress. */
    this.dragging = false;
    canvas.addEventListener('pointerdown', (e) => this.pointerDown(e));
    canvas.addEventListener('pointermove', (e) => this.pointerMove(e));
    canvas.addEventListener('pointerup', () => (this.dragging = false));
    canvas.addEventListener('wheel', (e) => this.wheel(e), { passive: false });
    controls.zoomIn?.addEventListener('click', () => this.zoomBy(ZOOM_BUTTON));
    controls.zoomOut?.addEventListener('click', () => this.zoomBy(1 / ZOOM_BUTTON));
    controls.all?.addEventListener('click', () => {
      this.view.showAll();
      this.redraw();
    });
    controls.rows?.addEventListener('click', () => {
      this.compact = !this.compact;
      this.redraw();
    });
    new ResizeObserver(() => this.redraw()).observe(canvas);
  }

  /** Redraws from the last state (after a scroll, zoom or resize). */
  redraw() {
    this.key = '';
    if (this.last) this.render(this.last);
  }

  /** Device pixels per CSS pixel. */
  get dpr() {
    return globalThis.devicePixelRatio || 1;
  }

  /** Width of the scrollbar in canvas pixels (0 when every row fits). */
  get scrollbar() {
    return this.ids.length > this.view.visible ? Math.round(SCROLLBAR * this.dpr) : 0;
  }

  /** Width of the bars area in canvas pixels. */
  get barsWidth() {
    return Math.max(1, this.canvas.width - this.gutter - this.scrollbar);
  }

  /**
   * Zooms the frame axis around the playhead (buttons) or a given frame (wheel).
   * @param {number} factor
   * @param {number} [at]
   */
  zoomBy(factor, at) {
    const f = at ?? (this.last ? this.last.frame + 0.5 : this.view.start + this.view.span / 2);
    this.view.zoom(factor, f);
    this.redraw();
  }

  /** @param {WheelEvent} e */
  wheel(e) {
    e.preventDefault();
    const { x } = this.canvasXY(e);
    const notches = Math.sign(e.deltaY || e.deltaX);
    if (e.ctrlKey || e.metaKey) {
      const share = (x - this.gutter) / this.barsWidth;
      this.zoomBy(ZOOM_STEP ** -notches, this.view.start + Math.max(0, Math.min(1, share)) * this.view.span);
    } else if (e.shiftKey || Math.abs(e.deltaX) > Math.abs(e.deltaY)) {
      this.view.pan(notches * Math.max(1, this.view.span * 0.1));
      this.redraw();
    } else {
      this.view.scroll(notches * 3);
      this.redraw();
    }
  }

  /** @param {MouseEvent} e @returns {{ x: number, y: number }} canvas pixels */
  canvasXY(e) {
    const r = this.canvas.getBoundingClientRect();
    return {
      x: ((e.clientX - r.left) / r.width) * this.canvas.width,
      y: ((e.clientY - r.top) / r.height) * this.canvas.height,
    };
  }

  /** @param {MouseEvent} e */
  locate(e) {
    const { x, y } = this.canvasXY(e);
    const frame = this.view.frameAt((x - this.gutter) / this.barsWidth);
    const row = Math.floor((y - 2) / this.rowH) + this.view.top;
    const id = row >= 0 && row < this.ids.length && row < this.view.top + this.view.visible ? this.ids[row] : null;
    return { id, frame };
  }

  /** @param {PointerEvent} e */
  pointerDown(e) {
    const { x, y } = this.canvasXY(e);
    if (this.scrollbar && x >= this.canvas.width - this.scrollbar) {
      this.dragging = true;
      this.canvas.setPointerCapture?.(e.pointerId);
      this.scrollTo(y);
      return;
    }
    const { id, frame } = this.locate(e);
    this.onPick({ id, frame, add: e.shiftKey });
  }

  /** @param {PointerEvent} e */
  pointerMove(e) {
    if (this.dragging) {
      this.scrollTo(this.canvasXY(e).y);
      return;
    }
    const { id, frame } = this.locate(e);
    const r = id === null ? undefined : this.last?.table.get(frame, id);
    const what = r?.keyframe ? ' (keyframe)' : r?.source === 'follow' ? ' (followed)' : r?.interpolated ? ' (filled in)' : '';
    this.canvas.title = id === null ? `frame ${frame}` : `track ${id} · frame ${frame}${what}`;
  }

  /** Scrolls so the scrollbar's thumb is centred at canvas height `y`. @param {number} y */
  scrollTo(y) {
    const share = Math.max(0, Math.min(1, y / this.canvas.height));
    this.view.top = 0;
    this.view.scroll(Math.round(share * this.ids.length - this.view.visible / 2));
    this.redraw();
  }

  /**
   * Where the cell of track `id` at `frame` is on the page (CSS pixels, the centre of the
   * cell), or null when it is out of view. For tests and for anything pointing into the
   * barcode.
   * @param {number} id
   * @param {number} frame
   */
  cellAt(id, frame) {
    const row = this.ids.indexOf(id) - this.view.top;
    const share = this.view.shareOf(frame + 0.5);
    if (row < 0 || row >= this.view.visible || share < 0 || share > 1) return null;
    const r = this.canvas.getBoundingClientRect();
    const kx = r.width / this.canvas.width;
    const ky = r.height / this.canvas.height;
    return {
      x: r.left + (this.gutter + share * this.barsWidth) * kx,
      y: r.top + (2 + (row + 0.5) * this.rowH) * ky,
      // The cell's box in canvas pixels, for pixel checks.
      canvas: {
        x0: this.gutter + this.view.shareOf(frame) * this.barsWidth,
        x1: this.gutter + this.view.shareOf(frame + 1) * this.barsWidth,
        y0: 2 + row * this.rowH,
        h: this.rowH,
      },
    };
  }

  /**
   * @param {{ table: TrackTable, frames: number, frame: number, selection: Selection, busy?: boolean }} s
   *   `busy`: tracking is running, so the bars (which change every frame) may lag a little
   */
  render(s) {
    this.last = s;
    const { canvas, ctx } = this;
    const dpr = this.dpr;
    const cw = Math.round(canvas.clientWidth * dpr);
    const ch = Math.round(canvas.clientHeight * dpr);
    if (cw > 0 && (canvas.width !== cw || canvas.height !== ch)) {
      canvas.width = cw;
      canvas.height = ch;
    }
    if (s.table.version !== this.idsVersion || s.table !== this.idsTable) {
      this.ids = s.table.ids();
      this.idsVersion = s.table.version;
      this.idsTable = s.table;
    }
    const n = this.ids.length;
    // Readable rows grow to fill the canvas when there are few tracks and scroll when there
    // are many; compact rows shrink to show every track down to 2 px.
    const fitH = Math.floor((canvas.height - 4) / Math.max(1, n));
    const minH = (this.compact ? ROW_COMPACT : ROW_READABLE) * dpr;
    this.rowH = Math.max(minH, Math.min(ROW_MAX * dpr, fitH));
    const visible = Math.max(1, Math.floor((canvas.height - 4) / this.rowH));
    this.view.resize(Math.max(1, s.frames, s.table.lastFrame()), n, visible);
    // The id labels set the gutter: the widest id in the table, in the label font.
    ctx.font = this.font();
    const widest = n ? ctx.measureText(String(this.ids[n - 1])).width : 0;
    this.gutter = Math.max(Math.round(34 * dpr), Math.ceil(widest + 14 * dpr));
    // A newly selected track is scrolled into view once (scrolling away from it afterwards is
    // the user's choice); the playhead pages the frame window when it leaves it.
    const sel = s.selection.a;
    if (sel !== this.revealed) {
      this.revealed = sel;
      if (sel !== null) this.view.reveal(this.ids.indexOf(sel));
    }
    if (s.frame !== this.followed) {
      this.followed = s.frame;
      this.view.follow(s.frame);
    }
    const v = this.view;
    const key = `${s.table.version}:${v.frames}:${canvas.width}x${canvas.height}:${v.top}:${n}:${v.start}:${v.span}:${this.rowH}`;
    const now = performance.now();
    if (key !== this.key && (!s.busy || now - this.barsAt > 150)) {
      this.drawBars(s.table);
      this.key = key;
      this.barsAt = now;
    }
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    ctx.drawImage(this.bars, 0, 0);
    const w = this.barsWidth;
    // Selected rows: a light band across the whole row and a marker in the gutter, visible
    // even when rows are 2 px high.
    for (const id of [s.selection.a, s.selection.b]) {
      if (id === null) continue;
      const row = this.ids.indexOf(id) - v.top;
      if (row < 0 || row >= v.visible) continue;
      const y = 2 + row * this.rowH;
      const band = Math.max(this.rowH, 4 * dpr);
      const top = y + this.rowH / 2 - band / 2;
      ctx.fillStyle = 'rgba(255,255,255,0.16)';
      ctx.fillRect(this.gutter, top, w, band);
      ctx.fillStyle = '#fff';
      ctx.beginPath();
      ctx.moveTo(this.gutter - 2, y + this.rowH / 2);
      ctx.lineTo(this.gutter - 2 - 6 * dpr, top - 2 * dpr);
      ctx.lineTo(this.gutter - 2 - 6 * dpr, top + band + 2 * dpr);
      ctx.fill();
    }
    const share = v.shareOf(s.frame + 0.5);
    if (share >= 0 && share <= 1) {
      const x = this.gutter + share * w;
      ctx.fillStyle = '#fff';
      ctx.fillRect(Math.round(x) - dpr / 2, 0, Math.max(1, dpr), canvas.height);
    }
    this.renderReadout();
  }

  /** The label font, sized to the rows. */
  font() {
    return `${Math.max(6, Math.min(this.rowH - 1, 11 * this.dpr))}px ui-monospace, monospace`;
  }

  /** Which tracks and frames are in view, in words, beside the controls. */
  renderReadout() {
    const { range, all, rows } = this.controls;
    const v = this.view;
    const n = this.ids.length;
    const [a, b] = v.frameRange();
    if (range) {
      const tracks = n > v.visible ? `tracks ${v.top + 1}–${Math.min(n, v.top + v.visible)} of ${n}` : `${n} track${n === 1 ? '' : 's'}`;
      const text = `${tracks} · frames ${a}–${b}${v.fit ? '' : ` of ${v.frames}`}`;
      if (range.textContent !== text) range.textContent = text;
    }
    if (all) /** @type {HTMLButtonElement} */ (all).disabled = v.fit;
    if (rows) rows.setAttribute('aria-pressed', String(this.compact));
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
    const v = this.view;
    const w = this.barsWidth;
    const fw = w / v.span;
    const gap = this.rowH >= 6 ? 1 : 0;
    const dpr = this.dpr;
    const labels = this.rowH >= 9 * dpr;
    const [first, last] = v.frameRange();
    ctx.font = this.font();
    ctx.textBaseline = 'middle';
    ctx.textAlign = 'right';
    // Bars are clipped to the bars area: a zoomed window cuts spans at its edges.
    ctx.save();
    ctx.beginPath();
    ctx.rect(this.gutter, 0, w, canvas.height);
    ctx.clip();
    for (let row = 0; row < v.visible && row + v.top < this.ids.length; row++) {
      const id = this.ids[row + v.top];
      const y = 2 + row * this.rowH;
      const solid = this.colour(id).css;
      for (const [a, b, filled] of table.spans(id)) {
        if (b < first || a > last) continue;
        ctx.fillStyle = filled ? (this.hatch(ctx, id, dpr) ?? solid) : solid;
        // At least one device pixel wide, so a single-frame track is still visible.
        ctx.fillRect(this.gutter + (a - v.start) * fw, y, Math.max(1, (b - a + 1) * fw), this.rowH - gap);
      }
      // Followed spans: a band along the row's foot; keyframes: a tick across the row.
      const band = Math.max(1, Math.round((this.rowH - gap) / 4));
      for (const span of followedSpans(table, id)) {
        if (span.end < first || span.start > last) continue;
        ctx.fillStyle = '#ffffff';
        ctx.fillRect(this.gutter + (span.start - v.start) * fw, y + this.rowH - gap - band, Math.max(1, (span.end - span.start + 1) * fw), band);
        for (const k of span.keys) {
          ctx.fillRect(this.gutter + (k - v.start + 0.5) * fw - Math.max(1, dpr), y, Math.max(2, 2 * dpr), this.rowH - gap);
        }
      }
    }
    ctx.restore();
    if (labels) {
      ctx.fillStyle = '#8a909c';
      for (let row = 0; row < v.visible && row + v.top < this.ids.length; row++) {
        ctx.fillText(String(this.ids[row + v.top]), this.gutter - 10 * dpr, 2 + row * this.rowH + this.rowH / 2);
      }
    }
    const sb = this.scrollbar;
    if (sb) {
      // The thumb's length is the share of rows in view, its place the share above.
      const n = this.ids.length;
      const h = canvas.height;
      ctx.fillStyle = '#1c1f25';
      ctx.fillRect(canvas.width - sb, 0, sb, h);
      ctx.fillStyle = '#4a505c';
      const thumb = Math.max(6 * dpr, (v.visible / n) * h);
      ctx.fillRect(canvas.width - sb + 1, (v.top / n) * h, sb - 2, thumb);
    }
  }
}
