// camera.js: the viewer's camera model and its mouse, touch and keyboard controls.
//
// OrbitCamera is an orbit around a target (yaw, pitch, distance) with world +Y up, the
// convention of glTF and of PATCH /v1/camera; flying moves the target and the eye together.
// CameraControls turns pointer events (mouse, pen, touch) and keys into camera changes; it
// never talks to the network: it calls onChange() and the caller coalesces (main.js sends at
// most one camera message per animation frame).

const UP = [0, 1, 0];
const PITCH_LIMIT = Math.PI / 2 - 0.01;
const ORBIT_RAD_PER_PX = 0.006;
const KEY_ORBIT_RAD_PER_S = 1.6;

const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const len = (a) => Math.hypot(a[0], a[1], a[2]);
const clamp = (x, lo, hi) => Math.min(hi, Math.max(lo, x));
const finite3 = (a) => Array.isArray(a) && a.length === 3 && a.every(Number.isFinite);

export class OrbitCamera {
  constructor() {
    this.target = [0, 1, 0];
    this.distance = 4;
    this.yaw = 0;
    this.pitch = 0;
    this.fov = 40;
    this.sceneSize = 2;   // diagonal of the scene bounds: scales zoom limits and fly speed
    this.version = 0;     // increases with every change
    this.known = false;   // true once set from the server or by the user
  }

  changed() { this.version++; this.known = true; }

  /* Adopts a camera of GET /v1/camera (position and target or forward, fov in degrees). */
  setFromServer(c) {
    if (!c || !finite3(c.position)) return false;
    let target = finite3(c.target) ? c.target : finite3(c.forward) ? add(c.position, c.forward) : null;
    if (!target) return false;
    let off = sub(c.position, target);
    if (len(off) < 1e-6) off = [0, 0, 1e-3];
    const r = len(off);
    this.target = target.slice();
    this.distance = r;
    this.pitch = clamp(Math.asin(clamp(off[1] / r, -1, 1)), -PITCH_LIMIT, PITCH_LIMIT);
    this.yaw = Math.atan2(off[0], off[2]);
    if (Number.isFinite(c.fov)) this.fov = c.fov;
    this.changed();
    return true;
  }

  /* Whether a server camera differs visibly from this one (for syncing with other viewers). */
  differsFrom(c) {
    if (!c || !finite3(c.position) || !finite3(c.target)) return false;
    const eps = 1e-3 * Math.max(1, this.distance);
    return len(sub(c.position, this.position())) > eps || len(sub(c.target, this.target)) > eps ||
      (Number.isFinite(c.fov) && Math.abs(c.fov - this.fov) > 0.01);
  }

  /* Frames an axis-aligned box: the target at its centre, the whole box in view. */
  frameBounds(min, max) {
    if (!finite3(min) || !finite3(max)) return;
    const centre = scale(add(min, max), 0.5);
    const radius = Math.max(1e-3, len(sub(max, min)) / 2);
    this.sceneSize = radius * 2;
    this.target = centre;
    this.distance = radius / Math.sin((this.fov * Math.PI) / 360) * 1.05;
    this.yaw = 0;
    this.pitch = 0.15;
    this.changed();
  }

  offsetDir() {
    const cp = Math.cos(this.pitch);
    return [cp * Math.sin(this.yaw), Math.sin(this.pitch), cp * Math.cos(this.yaw)];
  }
  position() { return add(this.target, scale(this.offsetDir(), this.distance)); }
  forward() { return scale(this.offsetDir(), -1); }
  right() { return [Math.cos(this.yaw), 0, -Math.sin(this.yaw)]; }
  /* The camera's own up (perpendicular to forward and right). */
  camUp() {
    const f = this.forward(), r = this.right();
    return [r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]];
  }

  orbit(dYaw, dPitch) {
    this.yaw = (this.yaw + dYaw) % (2 * Math.PI);
    this.pitch = clamp(this.pitch + dPitch, -PITCH_LIMIT, PITCH_LIMIT);
    this.changed();
  }

  /* Moves the target in the view plane by pixel deltas (viewHeightPx: the view's height). */
  pan(dxPx, dyPx, viewHeightPx) {
    const perPx = (2 * this.distance * Math.tan((this.fov * Math.PI) / 360)) / Math.max(1, viewHeightPx);
    this.target = add(this.target, add(scale(this.right(), -dxPx * perPx), scale(this.camUp(), dyPx * perPx)));
    this.changed();
  }

  zoom(factor) {
    if (!(factor > 0)) return;
    const s = Math.max(this.sceneSize, 1e-3);
    this.distance = clamp(this.distance * factor, s * 0.005, s * 50);
    this.changed();
  }

  /* Moves eye and target by v (world units). */
  translate(v) {
    this.target = add(this.target, v);
    this.changed();
  }

  /* The fields of a camera message or PATCH /v1/camera. Rounded to keep messages short. */
  toMessage() {
    const r = (a) => a.map((x) => Math.round(x * 1e5) / 1e5);
    return { position: r(this.position()), target: r(this.target), up: UP, fov: Math.round(this.fov * 100) / 100 };
  }
}

const FLY_KEYS = {
  KeyW: [0, 0, 1], KeyS: [0, 0, -1], KeyA: [-1, 0, 0], KeyD: [1, 0, 0],
  KeyQ: [0, -1, 0], KeyE: [0, 1, 0], PageDown: [0, -1, 0], PageUp: [0, 1, 0],
};
const ORBIT_KEYS = { ArrowLeft: [1, 0], ArrowRight: [-1, 0], ArrowUp: [0, -1], ArrowDown: [0, 1] };

function typingInto(el) {
  if (!el || el === document.body) return false;
  const tag = el.tagName;
  return tag === 'INPUT' || tag === 'TEXTAREA' || tag === 'SELECT' || el.isContentEditable;
}

/* Pointer, wheel and keyboard controls of an OrbitCamera on an element.
 *   left drag / one finger: orbit      right or middle drag, shift+drag / two fingers: pan
 *   wheel / pinch: zoom                W A S D fly, Q E down/up, Shift faster; arrows orbit
 *   double-click, Home or '.': onFrame() (the caller frames the scene; F is full screen, main.js)
 * onChange() is called after every change; update(dt) applies held keys and returns whether
 * the camera moved (call it every animation frame while keysHeld()). While `enabled` is false
 * (the viewer follows another view) input is ignored: drags, wheel, pinch and keys do nothing. */
export class CameraControls {
  constructor(element, camera, { onChange = () => {}, onFrame = () => {} } = {}) {
    this.el = element;
    this.cam = camera;
    this.onChange = onChange;
    this.onFrame = onFrame;
    this.pointers = new Map(); // id -> { x, y, mode }
    this.pinch = null;
    this.keys = new Set();
    this.shift = false;
    this.lastInput = 0;        // performance.now() of the last user input
    this.enabled = true;
    this.listeners = [];
    const on = (target, type, fn, opts) => {
      target.addEventListener(type, fn, opts);
      this.listeners.push(() => target.removeEventListener(type, fn, opts));
    };
    on(element, 'pointerdown', (e) => this.pointerDown(e));
    on(element, 'pointermove', (e) => this.pointerMove(e));
    on(element, 'pointerup', (e) => this.pointerUp(e));
    on(element, 'pointercancel', (e) => this.pointerUp(e));
    on(element, 'lostpointercapture', (e) => this.pointerUp(e));
    on(element, 'wheel', (e) => this.wheel(e), { passive: false });
    on(element, 'contextmenu', (e) => e.preventDefault());
    on(element, 'dblclick', (e) => { e.preventDefault(); if (this.enabled) this.onFrame(); });
    on(window, 'keydown', (e) => this.keyDown(e));
    on(window, 'keyup', (e) => { this.shift = e.shiftKey; this.keys.delete(e.code); });
    on(window, 'blur', () => this.keys.clear());
  }

  dispose() { for (const off of this.listeners) off(); this.listeners = []; }

  input() {
    this.lastInput = performance.now();
    this.onChange();
  }

  /* Turns input on or off; turning it off ends drags and releases held keys. */
  setEnabled(on) {
    this.enabled = !!on;
    if (this.enabled) return;
    this.pointers.clear();
    this.pinch = null;
    this.keys.clear();
    this.el.classList.remove('dragging');
  }

  pointerDown(e) {
    if (!this.enabled || (e.pointerType === 'mouse' && e.button > 2)) return;
    this.el.focus({ preventScroll: true });
    this.el.setPointerCapture(e.pointerId);
    const pan = e.pointerType === 'mouse' && (e.button === 1 || e.button === 2 || e.shiftKey || e.ctrlKey);
    this.pointers.set(e.pointerId, { x: e.clientX, y: e.clientY, mode: pan ? 'pan' : 'orbit' });
    if (this.pointers.size === 2) this.pinch = this.pinchState();
    this.el.classList.add('dragging');
    e.preventDefault();
  }

  pinchState() {
    const [a, b] = [...this.pointers.values()];
    return { d: Math.hypot(a.x - b.x, a.y - b.y), cx: (a.x + b.x) / 2, cy: (a.y + b.y) / 2 };
  }

  pointerMove(e) {
    const p = this.pointers.get(e.pointerId);
    if (!p) return;
    // Coalesced events carry every position since the last frame; their sum is this delta.
    const dx = e.clientX - p.x, dy = e.clientY - p.y;
    p.x = e.clientX;
    p.y = e.clientY;
    if (this.pointers.size >= 2) {
      const now = this.pinchState(), before = this.pinch;
      this.pinch = now;
      if (!before) return;
      if (before.d > 0 && now.d > 0) this.cam.zoom(before.d / now.d);
      this.cam.pan(now.cx - before.cx, now.cy - before.cy, this.el.clientHeight);
    } else if (p.mode === 'pan') {
      this.cam.pan(dx, dy, this.el.clientHeight);
    } else {
      this.cam.orbit(-dx * ORBIT_RAD_PER_PX, dy * ORBIT_RAD_PER_PX);
    }
    this.input();
  }

  pointerUp(e) {
    if (!this.pointers.delete(e.pointerId)) return;
    this.pinch = this.pointers.size === 2 ? this.pinchState() : null;
    if (this.pointers.size === 0) this.el.classList.remove('dragging');
  }

  wheel(e) {
    e.preventDefault();
    if (!this.enabled) return;
    const px = e.deltaMode === 1 ? e.deltaY * 16 : e.deltaMode === 2 ? e.deltaY * 400 : e.deltaY;
    this.cam.zoom(Math.exp(clamp(px, -400, 400) * (e.ctrlKey ? 0.01 : 0.0015)));
    this.input();
  }

  keyDown(e) {
    if (!this.enabled || typingInto(e.target) || e.ctrlKey || e.metaKey || e.altKey) return;
    if (e.code === 'Home' || e.code === 'Period' || e.code === 'NumpadDecimal') { e.preventDefault(); this.onFrame(); return; }
    this.shift = e.shiftKey;
    if (!(e.code in FLY_KEYS) && !(e.code in ORBIT_KEYS)) return;
    e.preventDefault();
    this.keys.add(e.code);
    this.input();
  }

  keysHeld() { return this.keys.size > 0; }

  /* Whether an interaction is under way: a pointer is down or a key is held. */
  get active() { return this.pointers.size > 0 || this.keys.size > 0; }

  /* Applies held keys over dt seconds. */
  update(dt) {
    if (!this.enabled || !this.keys.size || !(dt > 0)) return false;
    dt = Math.min(dt, 0.1);
    const fast = this.shift ? 4 : 1;
    const speed = Math.max(0.2, this.cam.sceneSize * 0.35) * fast * dt;
    let f = 0, r = 0, u = 0, yaw = 0, pitch = 0;
    for (const k of this.keys) {
      const m = FLY_KEYS[k];
      if (m) { r += m[0]; u += m[1]; f += m[2]; }
      const o = ORBIT_KEYS[k];
      if (o) { yaw += o[0]; pitch += o[1]; }
    }
    if (!f && !r && !u && !yaw && !pitch) return false;
    if (f || r || u) {
      const v = add(add(scale(this.cam.forward(), f), scale(this.cam.right(), r)), scale(UP, u));
      const n = len(v);
      if (n > 0) this.cam.translate(scale(v, speed / n));
    }
    if (yaw || pitch) this.cam.orbit(yaw * KEY_ORBIT_RAD_PER_S * dt, pitch * KEY_ORBIT_RAD_PER_S * dt);
    this.lastInput = performance.now();
    return true;
  }
}
