// The stage: the video frame on one canvas (painted by the tracker worker) and the overlay
// (masks, boxes, ids, trails) on a second one above it, drawn here; a selection change
// redraws only the overlay. Shapes the offline pass filled in (interpolated) are drawn
// dashed, with a fainter mask: they were inferred, not seen.

import { colorOf } from '../lib/colors.js';

/**
 * @typedef {import('../model/tracks.js').TrackRecord} TrackRecord
 * @typedef {import('../model/tracks.js').TrackTable} TrackTable
 * @typedef {{ x: number, y: number, width: number, height: number, data: Uint8Array }} Bitmap
 * @typedef {(rle: NonNullable<TrackRecord['mask']>) => Bitmap} MaskDecoder
 * @typedef {{ masks: boolean, boxes: boolean, trails: boolean, gt: boolean }} ViewOptions
 * @typedef {{ a: number | null, b: number | null }} Selection
 */

/** Frames of history a trail shows. */
const TRAIL = 40;

export class Stage {
  /**
   * @param {HTMLCanvasElement} frameCanvas
   * @param {HTMLCanvasElement} overlayCanvas
   * @param {MaskDecoder} decode
   * @param {import('../lib/colors.js').ColourOf} [colour] a track's colour by id
   */
  constructor(frameCanvas, overlayCanvas, decode, colour = colorOf) {
    this.colour = colour;
    this.frameCanvas = frameCanvas;
    this.overlay = overlayCanvas;
    this.decode = decode;
    this.octx = /** @type {CanvasRenderingContext2D} */ (overlayCanvas.getContext('2d'));
    /**
     * Decoded, tinted masks by record object: edits make new record objects, so a track whose
     * colour changed (a merge into another) is redrawn without any invalidation logic.
     * @type {WeakMap<TrackRecord, { canvas: OffscreenCanvas, bitmap: Bitmap } | null>}
     */
    this.maskCache = new WeakMap();
    /** Image size (the frame canvas belongs to the worker: its size is kept here). */
    this.width = frameCanvas.width;
    this.height = frameCanvas.height;
    // Scale both canvases to fit the stage (up or down), keeping the aspect ratio; pointer
    // mapping reads the resulting CSS box, so it stays exact.
    const parent = frameCanvas.parentElement;
    if (parent) new ResizeObserver(() => this.fit()).observe(parent);
  }

  fit() {
    const parent = this.frameCanvas.parentElement;
    if (!parent) return;
    const scale = Math.min(parent.clientWidth / this.width, parent.clientHeight / this.height);
    if (!(scale > 0)) return;
    const cw = Math.floor(this.width * scale);
    const ch = Math.floor(this.height * scale);
    for (const c of [this.frameCanvas, this.overlay]) {
      c.style.width = `${cw}px`;
      c.style.height = `${ch}px`;
    }
    // The overlay has the screen's resolution, not the video's: ids and lines stay crisp and
    // the same size at any zoom, and a 4K frame does not cost a 4K overlay.
    const dpr = globalThis.devicePixelRatio || 1;
    const ow = Math.max(1, Math.round(cw * dpr));
    const oh = Math.max(1, Math.round(ch * dpr));
    if (this.overlay.width !== ow || this.overlay.height !== oh) {
      this.overlay.width = ow;
      this.overlay.height = oh;
      this.onResize?.();
    }
  }

  /** Called after the overlay's resolution changed (its content is lost): redraw. */
  onResize = /** @type {(() => void) | null} */ (null);

  /** @param {number} width @param {number} height */
  resize(width, height) {
    if (width === this.width && height === this.height) return;
    this.width = width;
    this.height = height;
    this.fit();
  }

  /**
   * @param {TrackRecord} r
   * @returns {{ canvas: OffscreenCanvas, bitmap: Bitmap } | null}
   */
  mask(r) {
    if (!r.mask) return null;
    let m = this.maskCache.get(r);
    if (m === undefined) {
      m = null;
      const bm = this.decode(r.mask);
      if (bm.width > 0 && bm.height > 0) {
        const canvas = new OffscreenCanvas(bm.width, bm.height);
        const ctx = /** @type {OffscreenCanvasRenderingContext2D} */ (canvas.getContext('2d'));
        const img = ctx.createImageData(bm.width, bm.height);
        const [cr, cg, cb] = this.colour(r.id).rgb;
        const px = img.data;
        for (let i = 0; i < bm.data.length; i++) {
          if (bm.data[i]) {
            px[i * 4] = cr;
            px[i * 4 + 1] = cg;
            px[i * 4 + 2] = cb;
            px[i * 4 + 3] = 255;
          }
        }
        ctx.putImageData(img, 0, 0);
        m = { canvas, bitmap: bm };
      }
      this.maskCache.set(r, m);
    }
    return m;
  }

  /**
   * Redraws the overlay for one frame.
   * @param {{ table: TrackTable, gt: TrackTable | null, frame: number, selection: Selection, options: ViewOptions, labels?: Array<{ class: number, name: string }> }} args
   *   `labels`: class names, shown after the id when a record has a known class
   */
  drawOverlay({ table, gt, frame, selection, options, labels = [] }) {
    const ctx = this.octx;
    const k = this.overlay.width / this.width;
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.clearRect(0, 0, this.overlay.width, this.overlay.height);
    // Draw in image coordinates; sizes below are divided by k to stay constant on screen.
    ctx.setTransform(k, 0, 0, k, 0, 0);
    ctx.imageSmoothingEnabled = false;
    const dpr = globalThis.devicePixelRatio || 1;
    const records = table.at(frame);
    const selected = (/** @type {number} */ id) => id === selection.a || id === selection.b;
    const anySelected = selection.a !== null;
    const line = (1.5 * dpr) / k;
    if (options.masks) {
      for (const r of records) {
        const m = this.mask(r);
        if (!m) continue;
        ctx.globalAlpha = (selected(r.id) ? 0.65 : anySelected ? 0.2 : 0.45) * (r.interpolated ? 0.5 : 1);
        ctx.drawImage(m.canvas, m.bitmap.x, m.bitmap.y);
      }
      ctx.globalAlpha = 1;
    }
    if (options.trails) {
      for (const r of records) this.drawTrail(table, r.id, frame, selected(r.id), line);
    }
    if (options.gt && gt) {
      ctx.setLineDash([(6 * dpr) / k, (4 * dpr) / k]);
      ctx.lineWidth = line;
      ctx.strokeStyle = 'rgba(255,255,255,0.8)';
      for (const g of gt.at(frame)) ctx.strokeRect(g.bbox.x, g.bbox.y, g.bbox.w, g.bbox.h);
      ctx.setLineDash([]);
    }
    const font = (12 * dpr) / k;
    ctx.font = `600 ${font}px system-ui, sans-serif`;
    ctx.textBaseline = 'top';
    for (const r of records) {
      const { css } = this.colour(r.id);
      const sel = selected(r.id);
      const b = r.bbox;
      // A filled-in shape always gets its dashed outline: that is what marks it.
      if (options.boxes || sel || r.interpolated) {
        ctx.lineWidth = sel ? line * 2 : line;
        ctx.strokeStyle = css;
        ctx.globalAlpha = anySelected && !sel ? 0.5 : 1;
        if (r.interpolated) ctx.setLineDash([(5 * dpr) / k, (4 * dpr) / k]);
        ctx.strokeRect(b.x, b.y, b.w, b.h);
        ctx.setLineDash([]);
      }
      const name = r.class !== undefined && r.class >= 0 ? labels.find((l) => l.class === r.class)?.name : undefined;
      const label = `${r.id}${r.interpolated ? '*' : ''}${r.keyframe ? '◆' : ''}${name ? ` ${name}` : ''}`;
      const pad = (3 * dpr) / k;
      const tw = ctx.measureText(label).width + 2 * pad;
      const th = font + 2 * pad;
      const ty = b.y - th >= 0 ? b.y - th : b.y;
      ctx.fillStyle = css;
      ctx.fillRect(b.x, ty, tw, th);
      ctx.fillStyle = '#111';
      ctx.fillText(label, b.x + pad, ty + pad);
      ctx.globalAlpha = 1;
    }
  }

  /**
   * @param {TrackTable} table
   * @param {number} id
   * @param {number} frame
   * @param {boolean} sel
   * @param {number} line
   */
  drawTrail(table, id, frame, sel, line) {
    const ctx = this.octx;
    const t = table.byId.get(id);
    if (!t) return;
    /** @type {Array<[number, number]>} */
    const pts = [];
    for (let f = Math.max(1, frame - TRAIL); f <= frame; f++) {
      const r = t.get(f);
      if (r) pts.push([r.bbox.x + r.bbox.w / 2, r.bbox.y + r.bbox.h / 2]);
    }
    if (pts.length < 2) return;
    ctx.strokeStyle = this.colour(id).css;
    ctx.lineWidth = sel ? line * 1.6 : line;
    ctx.lineCap = 'round';
    for (let i = 1; i < pts.length; i++) {
      ctx.globalAlpha = 0.15 + (0.75 * i) / pts.length;
      ctx.beginPath();
      ctx.moveTo(pts[i - 1][0], pts[i - 1][1]);
      ctx.lineTo(pts[i][0], pts[i][1]);
      ctx.stroke();
    }
    ctx.globalAlpha = 1;
  }

  /**
   * Draws a drawing tool's preview (a box or polygon being drawn) over the overlay, after
   * `drawOverlay`.
   * @param {{ draw(ctx: CanvasRenderingContext2D, lineWidth: number): void }} tool
   */
  drawTool(tool) {
    const k = this.overlay.width / this.width;
    const dpr = globalThis.devicePixelRatio || 1;
    this.octx.setTransform(k, 0, 0, k, 0, 0);
    tool.draw(this.octx, (1.5 * dpr) / k);
  }

  /** Screen pixels per image pixel on the overlay. */
  screenScale() {
    return this.overlay.getBoundingClientRect().width / this.width || 1;
  }

  /**
   * Image coordinates of a pointer event on the overlay.
   * @param {MouseEvent} e
   */
  toImage(e) {
    const r = this.overlay.getBoundingClientRect();
    return {
      x: ((e.clientX - r.left) / r.width) * this.width,
      y: ((e.clientY - r.top) / r.height) * this.height,
    };
  }

  /**
   * The track under an image point: inside a mask first, else inside a box; the smallest wins,
   * so a shape in front of a larger one can still be picked.
   * @param {TrackTable} table
   * @param {number} frame
   * @param {{ x: number, y: number }} p
   * @returns {number | null}
   */
  hit(table, frame, p) {
    let inMask = null;
    let inBox = null;
    let maskArea = Infinity;
    let boxArea = Infinity;
    for (const r of table.at(frame)) {
      const b = r.bbox;
      if (p.x < b.x || p.y < b.y || p.x >= b.x + b.w || p.y >= b.y + b.h) continue;
      const area = b.w * b.h;
      if (area < boxArea) {
        boxArea = area;
        inBox = r.id;
      }
      const bm = this.mask(r)?.bitmap;
      if (!bm) continue;
      const lx = Math.floor(p.x) - bm.x;
      const ly = Math.floor(p.y) - bm.y;
      if (lx >= 0 && ly >= 0 && lx < bm.width && ly < bm.height && bm.data[ly * bm.width + lx] && area < maskArea) {
        maskArea = area;
        inMask = r.id;
      }
    }
    return inMask ?? inBox;
  }
}
