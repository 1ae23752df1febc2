// graphs.js: small live graphs drawn on a <canvas> without a library: a window of samples
// (Series) and a graph (LiveGraph) that draws stacked areas (per-pass GPU times) and lines
// (latencies) over the last WINDOW_MS. stats.js feeds and redraws them.

export const WINDOW_MS = 60000;
/* Series colours, in order (the pass legend uses the same). */
export const COLORS = ['#ffb454', '#6cb6ff', '#5fd68a', '#ff6b6b', '#c792ea', '#4dd0c8', '#f5c451', '#ff8a3d'];

/* The samples { t: performance.now() ms, v } of the last windowMs, oldest first. */
export class Series {
  constructor(windowMs = WINDOW_MS) {
    this.windowMs = windowMs;
    this.points = [];
  }

  push(t, v) {
    if (!Number.isFinite(v)) return;
    this.points.push({ t, v });
    this.trim(t);
  }

  trim(now) {
    const from = now - this.windowMs;
    let i = 0;
    while (i < this.points.length && this.points[i].t < from) i++;
    if (i) this.points.splice(0, i);
  }

  get last() { return this.points.length ? this.points[this.points.length - 1].v : null; }
}

/* The smallest "nice" number (1, 2 or 5 times a power of ten) at or above x. */
function niceCeil(x) {
  if (!(x > 0)) return 1;
  const p = 10 ** Math.floor(Math.log10(x));
  for (const m of [1, 2, 5, 10]) if (m * p >= x) return m * p;
  return 10 * p;
}

/* A graph on one canvas: time runs left (now - windowMs) to right (now); the value axis starts
 * at 0 and ends at a nice number over the largest value shown, written in the top-left corner.
 * The canvas's backing store follows its CSS size times devicePixelRatio. */
export class LiveGraph {
  constructor(canvas, { windowMs = WINDOW_MS, unit = 'ms' } = {}) {
    this.canvas = canvas;
    this.ctx = canvas.getContext('2d');
    this.windowMs = windowMs;
    this.unit = unit;
    this.drawn = false; // whether the last draw() showed any data
  }

  /* Sizes the backing store; false while the canvas is not displayed (a closed panel). */
  fit() {
    const r = this.canvas.getBoundingClientRect();
    if (r.width < 2 || r.height < 2) return false;
    const dpr = window.devicePixelRatio || 1;
    const w = Math.round(r.width * dpr), hgt = Math.round(r.height * dpr);
    if (this.canvas.width !== w || this.canvas.height !== hgt) {
      this.canvas.width = w;
      this.canvas.height = hgt;
    }
    this.dpr = dpr;
    return true;
  }

  /* Draws at time now (performance.now()):
   *   rows:   [{ t, values: number[] }] stacked areas, values[i] in colors[i] (bottom first);
   *   lines:  [{ points: [{ t, v }], color, dots }] polylines (dots: a mark on every sample).
   * Returns whether anything was drawn (false when hidden or without data). */
  draw(now, { rows = [], colors = COLORS, lines = [] } = {}) {
    if (!this.fit()) return false;
    const { ctx, canvas } = this;
    const W = canvas.width, H = canvas.height, dpr = this.dpr;
    ctx.clearRect(0, 0, W, H);
    const from = now - this.windowMs;
    const seen = rows.filter((r) => r.t >= from - 1000);
    const shown = lines.map((l) => ({ ...l, points: l.points.filter((p) => p.t >= from - 1000) }));
    let max = 0;
    for (const r of seen) max = Math.max(max, r.values.reduce((a, v) => a + (v > 0 ? v : 0), 0));
    for (const l of shown) for (const p of l.points) max = Math.max(max, p.v);
    const any = seen.length > 0 || shown.some((l) => l.points.length > 0);
    this.drawn = any;
    if (!any) return false;
    const top = niceCeil(max * 1.1);
    const pad = 12 * dpr;
    const x = (t) => ((t - from) / this.windowMs) * W;
    const y = (v) => H - 1 - (Math.max(0, v) / top) * (H - pad - 2);
    // a faint line at the top value
    ctx.fillStyle = 'rgba(255,255,255,0.08)';
    ctx.fillRect(0, Math.round(y(top)), W, Math.max(1, dpr));
    // stacked areas, bottom layer first
    const layers = seen.length ? Math.max(...seen.map((r) => r.values.length)) : 0;
    const base = seen.map(() => 0);
    for (let k = 0; k < layers; k++) {
      const upper = seen.map((r, i) => base[i] + (r.values[k] > 0 ? r.values[k] : 0));
      ctx.beginPath();
      seen.forEach((r, i) => (i ? ctx.lineTo(x(r.t), y(upper[i])) : ctx.moveTo(x(r.t), y(upper[i]))));
      for (let i = seen.length - 1; i >= 0; i--) ctx.lineTo(x(seen[i].t), y(base[i]));
      ctx.closePath();
      ctx.globalAlpha = 0.55;
      ctx.fillStyle = colors[k % colors.length];
      ctx.fill();
      ctx.globalAlpha = 1;
      ctx.beginPath();
      seen.forEach((r, i) => (i ? ctx.lineTo(x(r.t), y(upper[i])) : ctx.moveTo(x(r.t), y(upper[i]))));
      ctx.strokeStyle = colors[k % colors.length];
      ctx.lineWidth = dpr;
      ctx.stroke();
      for (let i = 0; i < base.length; i++) base[i] = upper[i];
    }
    // a single sample has no width: mark it
    if (seen.length === 1) {
      ctx.fillStyle = colors[0];
      ctx.fillRect(x(seen[0].t) - 2 * dpr, y(base[0]) - dpr, 4 * dpr, H - y(base[0]));
    }
    for (const l of shown) {
      if (!l.points.length) continue;
      ctx.strokeStyle = ctx.fillStyle = l.color;
      ctx.lineWidth = 1.5 * dpr;
      ctx.beginPath();
      l.points.forEach((p, i) => (i ? ctx.lineTo(x(p.t), y(p.v)) : ctx.moveTo(x(p.t), y(p.v))));
      ctx.stroke();
      if (l.dots || l.points.length === 1)
        for (const p of l.points) ctx.fillRect(x(p.t) - 1.5 * dpr, y(p.v) - 1.5 * dpr, 3 * dpr, 3 * dpr);
    }
    ctx.fillStyle = 'rgba(230,232,238,0.75)';
    ctx.font = `${10 * dpr}px ui-monospace, Menlo, Consolas, monospace`;
    ctx.textBaseline = 'top';
    ctx.fillText(`${top} ${this.unit}`, 3 * dpr, 1 * dpr);
    return true;
  }
}
