// gizmo.js: the 2D overlay over the picture (#overlay): the selected node's move or rotate
// gizmo, the lights as icons, and picking.
//
// Everything is projected with this viewer's own camera (camera.js) the way the server projects
// it (xform.js), into the rectangle the picture fills (CanvasView.pictureRect). The overlay takes
// no pointer events itself: a capture listener on #stage looks at every press first and keeps
// the ones that land on a handle (44 px targets) away from the camera controls:
//   - an arrow of the move gizmo moves the node along that axis of its parent's frame (the
//     drag projected on the arrow's screen direction), a ring of the rotate gizmo turns it about
//     that axis (the drag's angle around the node's origin) — PATCH /v1/nodes/{id} through the
//     node tree, coalesced;
//   - a light icon (point and spot lights) moves the light in the plane through it facing the
//     camera — PATCH /v1/lights/{id} through the Lights panel;
//   - a click elsewhere (a press and release within CLICK_PX and CLICK_MS, not an orbit drag)
//     asks POST /v1/views/{id}/pick of the view shown and selects the node hit (or none).
// While the viewer follows another view (the controls are off) it draws and picks nothing.

import {
  add3, cameraBasis, cross3, dot3, len3, mat4Dir, norm3, project, quatAxisAngle, quatMul, quatNormalize,
  rayAt, scale3, sub3,
} from './xform.js';

const HANDLE_PX = 22;      // hit radius: 44 px targets
const ARROW_PX = 90;       // on-screen length of an arrow and radius of a ring
const CLICK_PX = 6;
const CLICK_MS = 600;
const RING_STEPS = 48;
const AXIS_COLORS = ['#ff5c5c', '#6bd66b', '#5c9dff'];
const AXES = [[1, 0, 0], [0, 1, 0], [0, 0, 1]];

export class Gizmo {
  constructor({ overlay, stage, view, camera, controls, tree, lights, api, stream, toasts }) {
    Object.assign(this, { overlay, stage, view, camera, controls, tree, lights, api, stream, toasts });
    this.ctx = overlay.getContext('2d');
    this.mode = 'move';
    this.drag = null;  // { kind: 'axis'|'ring'|'light', ... }
    this.press = null; // a press that may become a click
    this.down = new Set(); // pointers down (a second finger makes a pinch, not a click)
    this.queued = false;
    this.lightIcons = []; // [{ id, x, y }] as last drawn
    this.handles = [];    // [{ kind, axis, pts }] as last drawn
    stage.addEventListener('pointerdown', (e) => this.pointerDown(e), { capture: true });
    stage.addEventListener('pointermove', (e) => this.move(e), { capture: true });
    stage.addEventListener('pointerup', (e) => { this.down.delete(e.pointerId); this.up(e); }, { capture: true });
    stage.addEventListener('pointercancel', (e) => {
      this.down.delete(e.pointerId);
      this.drag = null;
      this.press = null;
    }, { capture: true });
    tree.addEventListener('select', () => this.request());
    tree.addEventListener('change', () => this.request());
    new ResizeObserver(() => this.request()).observe(overlay);
    for (const b of document.querySelectorAll('#gizmo-modes [data-mode]'))
      b.addEventListener('click', () => this.setMode(b.dataset.mode));
  }

  setMode(mode) {
    this.mode = mode === 'rotate' ? 'rotate' : 'move';
    for (const b of document.querySelectorAll('#gizmo-modes [data-mode]'))
      b.setAttribute('aria-checked', String(b.dataset.mode === this.mode));
    this.request();
  }

  get active() { return this.controls.enabled && this.camera.known; }

  /* Redraws on the next animation frame (once however often asked). */
  request() {
    if (this.queued) return;
    this.queued = true;
    requestAnimationFrame(() => { this.queued = false; this.draw(); });
  }

  /* ---- drawing ------------------------------------------------------------------------------- */

  draw() {
    const { overlay, ctx } = this;
    const r = overlay.getBoundingClientRect();
    const dpr = window.devicePixelRatio || 1;
    const w = Math.max(1, Math.round(r.width * dpr)), h = Math.max(1, Math.round(r.height * dpr));
    if (overlay.width !== w || overlay.height !== h) { overlay.width = w; overlay.height = h; }
    ctx.setTransform(dpr, 0, 0, dpr, -r.left * dpr, -r.top * dpr); // draw in page CSS px
    ctx.clearRect(r.left, r.top, r.width, r.height);
    this.lightIcons = [];
    this.handles = [];
    if (!this.active) return;
    this.basis = cameraBasis(this.camera);
    this.rect = this.view.pictureRect();
    if (!(this.rect.width > 0 && this.rect.height > 0)) return;
    this.drawLights();
    this.drawGizmo();
  }

  drawLights() {
    const { ctx } = this;
    for (const l of this.lights.lights || []) {
      if (l.type === 'directional' || !Array.isArray(l.position)) continue;
      const p = project(this.basis, this.rect, l.position);
      if (!p) continue;
      this.lightIcons.push({ id: l.id, x: p.x, y: p.y, depth: p.depth });
      ctx.save();
      ctx.translate(p.x, p.y);
      ctx.strokeStyle = 'rgba(0,0,0,.65)';
      ctx.lineWidth = 4;
      ctx.beginPath();
      ctx.arc(0, 0, 9, 0, 2 * Math.PI);
      ctx.stroke();
      ctx.fillStyle = '#ffd27a';
      ctx.fill();
      ctx.strokeStyle = '#ffd27a';
      ctx.lineWidth = 2;
      for (let k = 0; k < 8; k++) { // rays of a sun
        const a = (k * Math.PI) / 4;
        ctx.beginPath();
        ctx.moveTo(Math.cos(a) * 12, Math.sin(a) * 12);
        ctx.lineTo(Math.cos(a) * 16, Math.sin(a) * 16);
        ctx.stroke();
      }
      if (l.type === 'spot' && Array.isArray(l.direction)) { // where it points
        const q = project(this.basis, this.rect, add3(l.position, scale3(l.direction, 0.25 * this.worldPerPx(p.depth) * 200)));
        if (q) {
          ctx.beginPath();
          ctx.moveTo(0, 0);
          ctx.lineTo(q.x - p.x, q.y - p.y);
          ctx.stroke();
        }
      }
      ctx.restore();
    }
  }

  /* World units per CSS pixel at depth z in the picture. */
  worldPerPx(z) { return (2 * z * this.basis.ty) / this.rect.height; }

  /* The selected node's origin, its parent's frame and the gizmo's world size, or null. */
  frame() {
    const n = this.tree.node;
    if (!n) return null;
    const world = this.tree.world(n.id);
    const origin = [world[12], world[13], world[14]];
    const o = project(this.basis, this.rect, origin);
    if (!o) return null;
    const parent = this.tree.parentWorld(n.id);
    const size = ARROW_PX * this.worldPerPx(o.depth);
    return { n, origin, o, parent, size };
  }

  drawGizmo() {
    const f = this.frame();
    if (!f) return;
    const { ctx } = this;
    ctx.lineCap = 'round';
    for (let i = 0; i < 3; i++) {
      const axis = norm3(mat4Dir(f.parent, AXES[i]));
      let pts;
      if (this.mode === 'move') {
        const tip = project(this.basis, this.rect, add3(f.origin, scale3(axis, f.size)));
        if (!tip) continue;
        pts = [f.o, tip];
      } else {
        const u = norm3(Math.abs(axis[1]) < 0.9 ? cross3(axis, [0, 1, 0]) : cross3(axis, [1, 0, 0]));
        const v = cross3(axis, u);
        pts = [];
        for (let k = 0; k <= RING_STEPS; k++) {
          const a = (k / RING_STEPS) * 2 * Math.PI;
          const p = project(this.basis, this.rect, add3(f.origin, scale3(add3(scale3(u, Math.cos(a)), scale3(v, Math.sin(a))), f.size)));
          if (p) pts.push(p);
        }
      }
      const hot = this.drag && this.drag.axis === i;
      for (const [style, width] of [['rgba(0,0,0,.6)', hot ? 7 : 5], [AXIS_COLORS[i], hot ? 4 : 2.5]]) {
        ctx.strokeStyle = style;
        ctx.lineWidth = width;
        ctx.beginPath();
        pts.forEach((p, k) => (k ? ctx.lineTo(p.x, p.y) : ctx.moveTo(p.x, p.y)));
        ctx.stroke();
      }
      if (this.mode === 'move') { // the arrow's head: the handle
        const tip = pts[1];
        ctx.fillStyle = AXIS_COLORS[i];
        ctx.beginPath();
        ctx.arc(tip.x, tip.y, hot ? 9 : 7, 0, 2 * Math.PI);
        ctx.fill();
      }
      this.handles.push({ kind: this.mode === 'move' ? 'axis' : 'ring', axis: i, pts, world: axis });
    }
    ctx.fillStyle = '#fff';
    ctx.beginPath();
    ctx.arc(f.o.x, f.o.y, 4, 0, 2 * Math.PI);
    ctx.fill();
  }

  /* ---- pointer ----------------------------------------------------------------------------- */

  /* What is under page point (x, y): a light icon or a gizmo handle within HANDLE_PX, the
   * nearest first. */
  hit(x, y) {
    let best = null, bestD = HANDLE_PX;
    for (const l of this.lightIcons) {
      const d = Math.hypot(l.x - x, l.y - y);
      if (d < bestD) { best = { kind: 'light', id: l.id }; bestD = d; }
    }
    for (const hd of this.handles) {
      let d;
      if (hd.kind === 'axis') d = Math.hypot(hd.pts[1].x - x, hd.pts[1].y - y) * 0.8; // the head first
      else d = Math.min(...hd.pts.slice(1).map((p, k) => segDist(hd.pts[k], p, x, y)));
      if (hd.kind === 'axis') d = Math.min(d, segDist(hd.pts[0], hd.pts[1], x, y) + 4);
      if (d < bestD) { best = { kind: hd.kind, axis: hd.axis, world: hd.world }; bestD = d; }
    }
    return best;
  }

  pointerDown(e) {
    this.down.add(e.pointerId);
    this.press = null;
    if (!this.active || this.down.size > 1 || (e.pointerType === 'mouse' && e.button !== 0)) return;
    this.draw(); // the handles as the picture is now
    const hit = this.hit(e.clientX, e.clientY);
    if (!hit) {
      this.press = { x: e.clientX, y: e.clientY, t: performance.now(), id: e.pointerId };
      return;
    }
    e.stopPropagation(); // the camera controls never see it
    e.preventDefault();
    this.stage.setPointerCapture(e.pointerId);
    if (hit.kind === 'light') {
      const l = (this.lights.lights || []).find((x) => x.id === hit.id);
      if (!l) return;
      this.drag = { kind: 'light', id: l.id, pointer: e.pointerId, start: l.position.slice() };
    } else {
      const f = this.frame();
      if (!f) return;
      this.drag = { kind: hit.kind, axis: hit.axis, world: hit.world, pointer: e.pointerId, x: e.clientX, y: e.clientY,
        node: f.n.id, t0: f.n.translation.slice(), q0: f.n.rotation.slice(), o: f.o, origin: f.origin,
        size: f.size, parentLen: len3(mat4Dir(f.parent, AXES[hit.axis])) || 1 };
    }
    this.request();
  }

  move(e) {
    const d = this.drag;
    if (this.press && this.press.id === e.pointerId && Math.hypot(e.clientX - this.press.x, e.clientY - this.press.y) > CLICK_PX)
      this.press = null; // an orbit drag, not a click
    if (!d || d.pointer !== e.pointerId) return;
    e.stopPropagation();
    const basis = cameraBasis(this.camera), rect = this.view.pictureRect();
    if (d.kind === 'light') {
      // the plane through the light's start facing the camera
      const ray = rayAt(basis, rect, e.clientX, e.clientY);
      const t = dot3(sub3(d.start, basis.eye), basis.fwd) / dot3(ray, basis.fwd);
      if (!(t > 0)) return;
      const p = add3(basis.eye, scale3(ray, t)).map((v) => Math.round(v * 1000) / 1000);
      const card = this.lights.cards.get(d.id);
      const l = (this.lights.lights || []).find((x) => x.id === d.id);
      if (l) l.position = p; // drawn there at once
      if (card) this.lights.edit(card, { position: p });
      this.request();
      return;
    }
    if (d.kind === 'axis') {
      const tip = project(basis, rect, add3(d.origin, scale3(d.world, d.size)));
      const o = project(basis, rect, d.origin);
      if (!tip || !o) return;
      const ax = tip.x - o.x, ay = tip.y - o.y, l2 = ax * ax + ay * ay;
      if (l2 < 4) return; // the axis points at the camera
      const along = ((e.clientX - d.x) * ax + (e.clientY - d.y) * ay) / l2; // in arrow lengths
      const t = d.t0.slice();
      t[d.axis] = Math.round((d.t0[d.axis] + (along * d.size) / d.parentLen) * 1e4) / 1e4;
      this.tree.patch(d.node, { translation: t });
    } else {
      const a0 = Math.atan2(d.y - d.o.y, d.x - d.o.x), a1 = Math.atan2(e.clientY - d.o.y, e.clientX - d.o.x);
      // screen angles grow clockwise (y down); an axis toward the camera turns counter-clockwise
      const facing = dot3(d.world, sub3(basis.eye, d.origin)) > 0;
      const angle = (facing ? -1 : 1) * (a1 - a0);
      const q = quatNormalize(quatMul(quatAxisAngle(AXES[d.axis], angle), d.q0));
      this.tree.patch(d.node, { rotation: q.map((v) => Math.round(v * 1e7) / 1e7) });
    }
  }

  async up(e) {
    if (this.drag && this.drag.pointer === e.pointerId) {
      e.stopPropagation();
      this.drag = null;
      this.request();
      return;
    }
    const p = this.press;
    this.press = null;
    if (!p || p.id !== e.pointerId || performance.now() - p.t > CLICK_MS) return;
    await this.pick(e.clientX, e.clientY);
  }

  /* Selects the node under page point (x, y) of the picture (POST /v1/views/{id}/pick). */
  async pick(x, y) {
    const rect = this.view.pictureRect();
    const u = (x - rect.left) / rect.width, v = (y - rect.top) / rect.height;
    if (!(u >= 0 && u <= 1 && v >= 0 && v <= 1)) return;
    const s = this.stream;
    const viewId = s.protocol === 2 && s.ownView !== null ? s.ownView : 0;
    try {
      const hit = await this.api.post(`/v1/views/${viewId}/pick`, { x: u, y: v });
      await this.tree.select(hit && hit.hit ? hit.node : null, { scroll: true });
    } catch (err) {
      this.toasts.error(err);
    }
  }
}

/* Distance from (x, y) to the segment a-b. */
function segDist(a, b, x, y) {
  const dx = b.x - a.x, dy = b.y - a.y, l2 = dx * dx + dy * dy;
  const t = l2 > 0 ? Math.max(0, Math.min(1, ((x - a.x) * dx + (y - a.y) * dy) / l2)) : 0;
  return Math.hypot(a.x + t * dx - x, a.y + t * dy - y);
}
