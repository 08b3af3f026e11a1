// Drawing a shape to follow on the stage: a box (drag) or a polygon (click the corners; Enter,
// a double-click or a click on the first corner closes it; Esc drops it). The tool only
// collects image coordinates and draws its preview over the overlay; what the shape becomes
// (a new followed track, or a corrected keyframe) is the app's business.

/**
 * @typedef {import('../model/tracks.js').Box} Box
 * @typedef {{ kind: 'box', box: Box } | { kind: 'polygon', points: Array<[number, number]> }} Shape
 * @typedef {{ x: number, y: number }} Point
 */

/** A click this close to the first corner (screen pixels) closes the polygon. */
const CLOSE_PX = 8;

export class ShapeTool {
  /**
   * @param {(shape: Shape) => void} onDone called with each finished shape
   * @param {() => void} onChange called when the preview changes (redraw)
   */
  constructor(onDone, onChange) {
    this.onDone = onDone;
    this.onChange = onChange;
    /** @type {'box' | 'polygon' | null} the tool in use (null: none, clicks select) */
    this.mode = null;
    /** @type {Point | null} where a box drag started */
    this.anchor = null;
    /** @type {Point | null} the pointer */
    this.pointer = null;
    /** @type {Array<[number, number]>} corners placed so far */
    this.points = [];
  }

  /** @param {'box' | 'polygon' | null} mode */
  use(mode) {
    this.mode = mode;
    this.reset();
  }

  /** Drops the shape being drawn (the tool stays). */
  reset() {
    this.anchor = null;
    this.pointer = null;
    this.points = [];
    this.onChange();
  }

  /** Whether a shape is being drawn. */
  get drawing() {
    return this.anchor !== null || this.points.length > 0;
  }

  /**
   * @param {Point} p image coordinates
   * @param {number} scale screen pixels per image pixel
   */
  down(p, scale) {
    if (this.mode === 'box') {
      this.anchor = p;
      this.pointer = p;
    } else if (this.mode === 'polygon') {
      const first = this.points[0];
      if (first && this.points.length >= 3 && Math.hypot(p.x - first[0], p.y - first[1]) * scale <= CLOSE_PX) {
        this.close();
        return;
      }
      this.points.push([p.x, p.y]);
    }
    this.onChange();
  }

  /** @param {Point} p */
  move(p) {
    if (!this.mode) return;
    this.pointer = p;
    if (this.drawing) this.onChange();
  }

  /** @param {Point} p */
  up(p) {
    if (this.mode !== 'box' || !this.anchor) return;
    const a = this.anchor;
    const box = { x: Math.min(a.x, p.x), y: Math.min(a.y, p.y), w: Math.abs(p.x - a.x), h: Math.abs(p.y - a.y) };
    this.reset();
    this.onDone({ kind: 'box', box });
  }

  /** Closes the polygon being drawn (a double-click's second click added a corner twice). */
  close() {
    if (this.mode !== 'polygon') return;
    /** @type {Array<[number, number]>} */
    const pts = [];
    for (const q of this.points) {
      const last = pts[pts.length - 1];
      if (!last || Math.hypot(q[0] - last[0], q[1] - last[1]) > 0.5) pts.push(q);
    }
    this.reset();
    this.onDone({ kind: 'polygon', points: pts });
  }

  /**
   * Draws the shape being drawn, in image coordinates (the context's transform maps them).
   * @param {CanvasRenderingContext2D} ctx
   * @param {number} lineWidth in image pixels
   */
  draw(ctx, lineWidth) {
    if (!this.drawing) return;
    ctx.save();
    ctx.strokeStyle = '#ffffff';
    ctx.lineWidth = lineWidth;
    ctx.setLineDash([lineWidth * 4, lineWidth * 3]);
    ctx.beginPath();
    if (this.anchor && this.pointer) {
      const a = this.anchor;
      const p = this.pointer;
      ctx.rect(Math.min(a.x, p.x), Math.min(a.y, p.y), Math.abs(p.x - a.x), Math.abs(p.y - a.y));
    } else {
      this.points.forEach(([x, y], i) => (i ? ctx.lineTo(x, y) : ctx.moveTo(x, y)));
      if (this.pointer) ctx.lineTo(this.pointer.x, this.pointer.y);
    }
    ctx.stroke();
    ctx.restore();
  }
}
