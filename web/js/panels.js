// panels.js: the overlay panels: views (follow), lights, rendering settings, plus toasts and
// the token prompt (the scene panel: scene_panel.js). Each panel owns its DOM subtree (found by id in
// index.html), talks to the server only through an Api (api.js) and reports failures with the
// server's own message. The world's state reaches the panels through the stream's 'event'
// messages (protocol/stream.md, version 2): applyEvent(doc) takes a document that is exactly
// the body of the matching GET; the panels never poll. refresh() (one GET) is only for a
// version-1 server, which sends no events.

import { h, icon } from './dom.js';

const $ = (id) => document.getElementById(id);

/* Icons (16 x 16 stroke paths) for dom.js's icon(). */
const ICON_TARGET = 'M8 1.5v3M8 11.5v3M1.5 8h3M11.5 8h3M8 4.5a3.5 3.5 0 1 0 0 7a3.5 3.5 0 1 0 0-7z';
const ICON_DELETE = 'M4 4l8 8M12 4l-8 8';

/* ---- colours: glTF light colours are linear RGB; <input type=color> is sRGB ---------------- */
const toSrgb = (c) => (c <= 0.0031308 ? 12.92 * c : 1.055 * Math.pow(c, 1 / 2.4) - 0.055);
const toLinear = (c) => (c <= 0.04045 ? c / 12.92 : Math.pow((c + 0.055) / 1.055, 2.4));
export function linearToHex(rgb) {
  const m = Math.max(1, ...rgb); // HDR colours: show the hue
  return '#' + rgb.map((c) => Math.round(Math.min(1, Math.max(0, toSrgb(c / m))) * 255).toString(16).padStart(2, '0')).join('');
}
export function hexToLinear(hex) {
  const n = parseInt(hex.slice(1), 16);
  return [(n >> 16) & 255, (n >> 8) & 255, n & 255].map((v) => Math.round(toLinear(v / 255) * 1e4) / 1e4);
}

/* Intensity slider: logarithmic from 0.01 to 10000, with 0 at the far left. */
const SLIDER_MAX = 1000;
const intensityToSlider = (v) => (v > 0 ? Math.min(SLIDER_MAX, Math.max(1, ((Math.log10(v) + 2) / 6) * SLIDER_MAX)) : 0);
const sliderToIntensity = (p) => (p > 0 ? Number(Math.pow(10, (p / SLIDER_MAX) * 6 - 2).toPrecision(3)) : 0);

/* Coalescer: at most one request in flight per key; patches given meanwhile are merged and
 * sent when it returns (the latest value of each field wins). send(key, patch) -> Promise of
 * the server's answer (after the merged request that carried the patch). */
export class Coalescer {
  constructor(request) {
    this.request = request; // (key, patch) => Promise
    this.slots = new Map();
  }
  send(key, patch) {
    let s = this.slots.get(key);
    if (!s) { s = { busy: false, next: null, waiters: [] }; this.slots.set(key, s); }
    s.next = { ...(s.next || {}), ...patch };
    const p = new Promise((resolve, reject) => s.waiters.push({ resolve, reject }));
    if (!s.busy) this.pump(key, s);
    return p;
  }
  busy(key) { const s = this.slots.get(key); return !!s && (s.busy || !!s.next); }
  async pump(key, s) {
    s.busy = true;
    while (s.next) {
      const patch = s.next, waiters = s.waiters;
      s.next = null;
      s.waiters = [];
      try {
        const r = await this.request(key, patch);
        waiters.forEach((w) => w.resolve(r));
      } catch (e) {
        waiters.forEach((w) => w.reject(e));
      }
    }
    s.busy = false;
    this.slots.delete(key);
  }
}

/* ---- toasts -------------------------------------------------------------------------------- */
export class Toasts {
  constructor(root = $('toasts')) { this.root = root; }
  show(message, kind = 'error', ms = kind === 'error' ? 7000 : 3500) {
    const el = h('div', { class: 'toast ' + kind, role: kind === 'error' ? 'alert' : 'status' }, message);
    this.root.append(el);
    while (this.root.children.length > 4) this.root.firstChild.remove();
    setTimeout(() => el.remove(), ms);
    return el;
  }
  error(e) { return this.show(e && e.message ? e.message : String(e), 'error'); }
}

/* ---- the token prompt ---------------------------------------------------------------------- */
/* ask(reason) -> Promise<string|null>. After the user cancels, later asks wait (without a
 * dialog) until reopen() is called, so a reconnect loop does not nag. onState(waiting) tells
 * the status bar that a token is needed. */
export class TokenPrompt {
  constructor({ onState = () => {} } = {}) {
    this.dialog = $('token-dialog');
    this.input = $('token-input');
    this.reason = $('token-reason');
    this.onState = onState;
    this.current = null;
    this.declined = false;
    this.wake = null;
    $('token-cancel').addEventListener('click', () => this.dialog.close('cancel'));
  }

  ask(reason) {
    if (this.current) return this.current;
    this.current = (async () => {
      this.onState(true);
      if (this.declined) await new Promise((r) => { this.wake = r; });
      const t = await this.show(reason);
      this.declined = !t;
      this.onState(!t);
      return t;
    })().finally(() => { this.current = null; });
    return this.current;
  }

  reopen() {
    this.declined = false;
    if (this.wake) { const w = this.wake; this.wake = null; w(); }
  }

  show(reason) {
    return new Promise((resolve) => {
      this.reason.textContent = reason || 'This server needs an access token.';
      this.input.value = '';
      this.dialog.returnValue = '';
      const done = () => {
        this.dialog.removeEventListener('close', done);
        const v = this.input.value.trim();
        resolve(this.dialog.returnValue !== 'cancel' && v ? v : null);
      };
      this.dialog.addEventListener('close', done);
      this.dialog.showModal();
      this.input.focus();
    });
  }
}

/* ---- rendering settings ------------------------------------------------------------------ */
const GI_LABELS = [['off', 'Off'], ['classic', 'Classic'], ['ddgi', 'DDGI'], ['pathtrace', 'Path trace']];
const SKY_LABELS = [['uniform', 'Uniform'], ['gradient', 'Gradient'], ['image', 'HDR/EXR image']];

/* A linear radiance (r, g, b) as a colour picker value and a strength (its largest channel),
 * and back: what the sky and ground controls show and send. */
export function radianceToPicker(rgb) {
  const k = Math.max(rgb[0], rgb[1], rgb[2]);
  if (!(k > 0)) return { color: '#ffffff', strength: 0 };
  return { color: linearToHex(rgb.map((c) => c / k)), strength: k };
}
export function pickerToRadiance(color, strength) {
  const v = hexToLinear(color);
  const k = Math.max(...v) || 1;
  return v.map((c) => Math.round((c / k) * strength * 10000) / 10000);
}
const VIEW_LABELS = [['final', 'Final'], ['irradiance', 'Irradiance'], ['probes', 'Probes']];
const GI_TITLES = {
  off: 'Direct light only',
  classic: 'Irradiance probes without visibility (leaks through thin walls)',
  ddgi: 'Dynamic Diffuse Global Illumination: probes with visibility (Majercik et al. 2019)',
  pathtrace: 'Reference path tracer: samples accumulate while nothing changes (slow on a CPU)',
};

export class RenderPanel {
  constructor(api, { toasts }) {
    this.api = api;
    this.toasts = toasts;
    this.settings = null;     // what the controls show (optimistic while a change is on its way)
    this.serverSettings = null; // the server's last word: an event or an answer
    this.eventsLive = false;  // true while the stream delivers 'settings' events
    this.queue = new Coalescer((_, patch) => this.api.patch('/v1/settings', patch));
    this.gi = $('gi-modes');
    this.view = $('view-modes');
    this.exposure = $('exposure');
    this.exposureOut = $('exposure-out');
    this.animate = $('animate');
    this.setCapabilities({});
    this.exposure.addEventListener('input', () => {
      this.exposureOut.textContent = `${Number(this.exposure.value).toFixed(1)} EV`;
      this.patch({ exposure: Number(this.exposure.value) });
    });
    this.animate.addEventListener('change', () => this.patch({ animate: this.animate.checked }));
    this.setupEnvironment();
  }

  /* The environment controls: mode, sky and ground radiance (colour x strength), the HDR image
   * (a Radiance .hdr or OpenEXR .exr, PUT /v1/environment), its intensity and rotation. */
  setupEnvironment() {
    this.skyModes = $('sky-modes');
    this.skyModes.replaceChildren(...SKY_LABELS.map(([v, label]) => h('button', {
      type: 'button', role: 'radio', 'data-value': v, 'aria-checked': 'false',
      title: v === 'gradient' ? 'From the ground colour (below) to the sky colour (above)'
        : v === 'image' ? 'An equirectangular HDR image (Radiance .hdr or OpenEXR .exr)' : 'The sky colour in every direction',
      onclick: () => (v === 'image' && !this.hasImage ? $('hdr-file').click() : this.patch({ sky_mode: v })),
    }, label)));
    const sendSky = () => this.patch({ sky: pickerToRadiance($('sky-color').value, Number($('sky-strength').value) || 0) });
    const sendGround = () => this.patch({ sky_ground: pickerToRadiance($('ground-color').value, Number($('ground-strength').value) || 0) });
    $('sky-color').addEventListener('input', sendSky);
    $('sky-strength').addEventListener('change', sendSky);
    $('ground-color').addEventListener('input', sendGround);
    $('ground-strength').addEventListener('change', sendGround);
    $('sky-intensity').addEventListener('input', () => {
      $('sky-intensity-out').textContent = Number($('sky-intensity').value).toFixed(2);
      this.patch({ sky_intensity: Number($('sky-intensity').value) });
    });
    $('sky-rotation').addEventListener('input', () => {
      $('sky-rotation-out').textContent = `${$('sky-rotation').value}°`;
      this.patch({ sky_rotation: Number($('sky-rotation').value) });
    });
    $('hdr-btn').addEventListener('click', () => $('hdr-file').click());
    $('hdr-file').addEventListener('change', async () => {
      const f = $('hdr-file').files[0];
      $('hdr-file').value = '';
      if (!f) return;
      $('hdr-out').textContent = 'uploading…';
      try {
        // the server reads the format from the file's first bytes; the type names it
        const type = /\.exr$/i.test(f.name) ? 'image/x-exr' : 'image/vnd.radiance';
        const r = await this.api.putBytes('/v1/environment', f, type);
        this.hasImage = true;
        $('hdr-out').textContent = `${f.name} (${r.width}×${r.height})`;
        if (!this.eventsLive) this.refresh(); // else the settings event brings sky_mode image
      } catch (e) {
        $('hdr-out').textContent = '';
        this.toasts.error(e);
      }
    });
  }

  /* The scene document says whether an environment image is loaded. */
  setEnvironmentImage(img) {
    this.hasImage = !!img;
    if (!img) $('hdr-out').textContent = '';
    else if (!$('hdr-out').textContent || $('hdr-out').textContent === 'uploading…')
      $('hdr-out').textContent = `${img.width}×${img.height}`;
  }

  /* gi, view: the enums the API offers (from /v1/openapi.yaml); defaults are those of v1. */
  setCapabilities({ gi = ['off', 'classic', 'ddgi'], view = ['final', 'irradiance', 'probes'] }) {
    this.giAllowed = gi;
    this.viewAllowed = view;
    this.gi.replaceChildren(...GI_LABELS.map(([v, label]) => {
      const ok = gi.includes(v);
      return h('button', {
        type: 'button', role: 'radio', 'data-value': v, 'aria-checked': 'false', disabled: !ok,
        title: ok ? GI_TITLES[v] || label
          : `Not offered by this server: PATCH /v1/settings accepts gi_mode ${gi.join(', ')}. ` +
            'Path-traced references are rendered offline with `probecast render --gi pathtrace`.',
        onclick: () => this.patch({ gi_mode: v }),
      }, label);
    }));
    // The path-trace button is disabled, and disabled buttons get no hover events in most
    // browsers: its wrapper carries the tooltip too.
    for (const b of this.gi.querySelectorAll('button:disabled')) {
      const wrap = h('span', { style: 'flex:1;display:flex', title: b.title });
      b.replaceWith(wrap);
      b.style.flex = '1';
      wrap.append(b);
    }
    this.view.replaceChildren(...VIEW_LABELS.filter(([v]) => view.includes(v)).map(([v, label]) => h('button', {
      type: 'button', role: 'radio', 'data-value': v, 'aria-checked': 'false',
      title: v === 'probes' ? 'Probe visualisation (P)' : v === 'irradiance' ? 'Indirect irradiance only' : 'The lit image',
      onclick: () => this.patch({ view: v }),
    }, label)));
    if (this.settings) this.apply(this.settings);
  }

  /* One GET /v1/settings (a version-1 server sends no events). */
  async refresh() {
    try {
      this.applyEvent(await this.api.get('/v1/settings'));
    } catch (e) { /* the status bar shows the connection; the next refresh fixes it */ }
  }

  /* A 'settings' event (the body of GET /v1/settings). While a change of ours is on its way the
   * controls keep the user's choice; its answer (or the next event) shows the server's. */
  applyEvent(s) {
    if (!s) return;
    this.serverSettings = s;
    if (!this.queue.busy('s')) this.apply(s);
  }

  apply(s) {
    if (!s) return;
    this.settings = s;
    for (const b of this.gi.querySelectorAll('button')) b.setAttribute('aria-checked', String(b.dataset.value === s.gi_mode));
    for (const b of this.view.querySelectorAll('button')) b.setAttribute('aria-checked', String(b.dataset.value === s.view));
    if (document.activeElement !== this.exposure && !this.queue.busy('s') && Number.isFinite(s.exposure)) {
      this.exposure.value = s.exposure;
      this.exposureOut.textContent = `${Number(s.exposure).toFixed(1)} EV`;
    }
    this.animate.checked = !!s.animate;
    if (s.sky_mode) {
      for (const b of this.skyModes.querySelectorAll('button')) b.setAttribute('aria-checked', String(b.dataset.value === s.sky_mode));
      $('ground-row').hidden = s.sky_mode !== 'gradient';
      for (const id of ['hdr-intensity-row', 'hdr-rotation-row']) $(id).hidden = s.sky_mode !== 'image';
      $('sky-label').textContent = s.sky_mode === 'gradient' ? 'Sky (zenith)' : 'Sky';
      const busy = this.queue.busy('s');
      const show = (colorId, strengthId, rgb) => {
        if (!Array.isArray(rgb) || busy || [colorId, strengthId].includes(document.activeElement && document.activeElement.id)) return;
        const p = radianceToPicker(rgb);
        $(colorId).value = p.color;
        $(strengthId).value = Number(p.strength.toPrecision(4));
      };
      show('sky-color', 'sky-strength', s.sky);
      show('ground-color', 'ground-strength', s.sky_ground);
      if (!busy && document.activeElement !== $('sky-intensity') && Number.isFinite(s.sky_intensity)) {
        $('sky-intensity').value = s.sky_intensity;
        $('sky-intensity-out').textContent = Number(s.sky_intensity).toFixed(2);
      }
      if (!busy && document.activeElement !== $('sky-rotation') && Number.isFinite(s.sky_rotation)) {
        $('sky-rotation').value = s.sky_rotation;
        $('sky-rotation-out').textContent = `${s.sky_rotation}°`;
      }
    }
  }

  async patch(p) {
    // Optimistic: the control shows the choice at once; the answer confirms or reverts it.
    if (this.settings) this.apply({ ...this.settings, ...p });
    try {
      const s = await this.queue.send('s', p);
      if (s) this.serverSettings = s;
      if (!this.queue.busy('s')) this.apply(s);
    } catch (e) {
      this.toasts.error(e);
      if (this.eventsLive) this.apply(this.serverSettings); // back to the server's state
      else this.refresh();
    }
  }

  toggleProbes() {
    if (!this.settings || !this.viewAllowed.includes('probes')) return;
    this.patch({ view: this.settings.view === 'probes' ? 'final' : 'probes' });
  }
}

/* ---- lights ------------------------------------------------------------------------------ */
/* Lists the lights of GET /v1/lights (from 'lights' events); every control edits through
 * PATCH /v1/lights/{id} (coalesced per light), Add posts, × deletes; the answers are shown at
 * once and the events that follow confirm them. cameraTarget() and sceneSize() place new
 * lights where the user is looking, at a strength that suits the scene's size. */
export class LightsPanel {
  constructor(api, { toasts, cameraTarget, cameraPosition, sceneBounds, sceneSize }) {
    this.api = api;
    this.toasts = toasts;
    this.cameraTarget = cameraTarget;
    this.cameraPosition = cameraPosition;
    this.sceneBounds = sceneBounds;
    this.sceneSize = sceneSize;
    this.root = $('lights');
    this.count = $('light-count');
    this.cards = new Map(); // id -> { el, light, inputs }
    this.lights = [];       // the server's last list (an event, or our own answers applied to it)
    this.eventsLive = false; // true while the stream delivers 'lights' events
    this.lastEdit = -Infinity;
    this.queue = new Coalescer((id, patch) => this.api.patch(`/v1/lights/${id}`, patch));
    $('light-add').addEventListener('click', () => this.add($('light-type').value));
  }

  /* One GET /v1/lights (a version-1 server sends no events). */
  async refresh() {
    try {
      this.applyEvent(await this.api.get('/v1/lights'));
    } catch (e) { /* offline: keep the list */ }
  }

  /* A 'lights' event (the body of GET /v1/lights). Cards being edited keep the user's values
   * (render() skips them). */
  applyEvent(doc) {
    if (!doc || !Array.isArray(doc.lights)) return;
    this.lights = doc.lights;
    this.render(this.lights);
  }

  /* Applies one light of our own answers (PATCH, POST) to the list. */
  upsert(l) {
    if (!l || l.id === undefined) return;
    const i = this.lights.findIndex((x) => x.id === l.id);
    this.lights = i >= 0 ? this.lights.map((x) => (x.id === l.id ? l : x)) : [...this.lights, l];
  }

  /* Whether the user is working in the list (an edit in the last 2 s or on its way): periodic
   * refreshes wait then (and fill() never overwrites the focused control). */
  editing() {
    if (performance.now() - this.lastEdit < 2000) return true;
    for (const id of this.cards.keys()) if (this.queue.busy(id)) return true;
    return false;
  }

  render(lights) {
    this.lights = lights;
    const seen = new Set();
    lights.forEach((l, i) => {
      seen.add(l.id);
      let c = this.cards.get(l.id);
      if (!c) {
        c = this.card(l, i < 3);
        this.cards.set(l.id, c);
      }
      this.root.append(c.el); // server order
      if (!this.queue.busy(l.id)) this.fill(c, l);
    });
    for (const [id, c] of this.cards) if (!seen.has(id)) { c.el.remove(); this.cards.delete(id); }
    this.count.textContent = lights.length ? `(${lights.length})` : '';
  }

  card(l, open) {
    const num = (axis, field) => h('input', {
      type: 'number', step: '0.05', 'aria-label': `${field} ${axis}`, 'data-field': field,
      oninput: () => this.edit(c, { [field]: c.vec(field) }),
    });
    const c = { light: l, inputs: {} };
    c.vec = (field) => c.inputs[field].map((i) => Number(i.value) || 0);
    c.inputs.color = h('input', { type: 'color', 'aria-label': 'colour', oninput: () => this.edit(c, { color: hexToLinear(c.inputs.color.value) }) });
    c.inputs.slider = h('input', {
      type: 'range', min: '0', max: String(SLIDER_MAX), step: '1', 'aria-label': 'intensity',
      oninput: () => {
        const v = sliderToIntensity(Number(c.inputs.slider.value));
        c.inputs.intensity.value = v;
        this.edit(c, { intensity: v });
      },
    });
    c.inputs.intensity = h('input', {
      type: 'number', min: '0', step: 'any', 'aria-label': 'intensity value',
      oninput: () => {
        const v = Number(c.inputs.intensity.value);
        if (!(v >= 0)) return;
        c.inputs.slider.value = intensityToSlider(v);
        this.edit(c, { intensity: v });
      },
    });
    c.inputs.position = ['x', 'y', 'z'].map((a) => num(a, 'position'));
    c.inputs.direction = ['x', 'y', 'z'].map((a) => num(a, 'direction'));
    c.swatch = h('span', { class: 'swatch' });
    c.name = h('span', { class: 'name' });
    c.type = h('span', { class: 'type' });
    c.dirLine = h('div', { class: 'line' }, h('span', {}, 'direction'), h('div', { class: 'xyz' }, c.inputs.direction));
    c.posLine = h('div', { class: 'line' }, h('span', {}, 'position'), h('div', { class: 'xyz' }, c.inputs.position));
    const tools = h('span', { class: 'tools' },
      h('button', { type: 'button', title: 'Move to the centre of the view', 'aria-label': 'move to view centre',
        onclick: (e) => { e.preventDefault(); this.moveToView(c); } }, icon(ICON_TARGET)),
      h('button', { type: 'button', class: 'danger', title: 'Delete this light', 'aria-label': 'delete light',
        onclick: (e) => { e.preventDefault(); this.remove(c); } }, icon(ICON_DELETE)));
    c.el = h('details', { class: 'light', open, 'data-id': String(l.id) },
      h('summary', {}, c.swatch, c.name, c.type, tools),
      h('div', { class: 'body' },
        h('div', { class: 'line' }, h('span', {}, 'colour'), c.inputs.color),
        h('div', { class: 'line' }, h('span', {}, 'intensity'), h('div', { class: 'inten' }, c.inputs.slider, c.inputs.intensity)),
        c.posLine, c.dirLine));
    return c;
  }

  /* Shows l in the card, leaving alone the control the user is editing. */
  fill(c, l) {
    c.light = l;
    const active = document.activeElement;
    const set = (input, v) => { if (input !== active) input.value = v; };
    c.name.textContent = l.name || `light ${l.id}`;
    c.type.textContent = l.type + (l.node >= 0 ? ` · node ${l.node}` : '');
    const hex = linearToHex(l.color || [1, 1, 1]);
    c.swatch.style.background = hex;
    c.swatch.style.boxShadow = `0 0 ${l.intensity > 0 ? 8 : 0}px ${hex}`;
    set(c.inputs.color, hex);
    set(c.inputs.intensity, Number((l.intensity ?? 0).toPrecision(4)));
    set(c.inputs.slider, intensityToSlider(l.intensity ?? 0));
    (l.position || [0, 0, 0]).forEach((v, i) => set(c.inputs.position[i], Number(v.toFixed(3)) || 0));
    (l.direction || [0, -1, 0]).forEach((v, i) => set(c.inputs.direction[i], Number(v.toFixed(3)) || 0));
    c.posLine.hidden = l.type === 'directional';
    c.dirLine.hidden = l.type === 'point';
  }

  async edit(c, patch) {
    this.lastEdit = performance.now();
    c.el.classList.add('busy');
    if (patch.color) c.swatch.style.background = linearToHex(patch.color);
    try {
      const l = await this.queue.send(c.light.id, patch);
      this.upsert(l);
      if (!this.queue.busy(c.light.id) && l) this.fill(c, l);
    } catch (e) {
      this.toasts.error(e);
      if (this.eventsLive) { const l = this.lights.find((x) => x.id === c.light.id); if (l) this.fill(c, l); }
      else this.refresh();
    } finally {
      if (!this.queue.busy(c.light.id)) c.el.classList.remove('busy');
    }
  }

  moveToView(c) {
    const t = this.cameraTarget();
    if (t) this.edit(c, { position: t.map((v) => Math.round(v * 1000) / 1000) });
  }

  async remove(c) {
    try {
      await this.api.del(`/v1/lights/${c.light.id}`);
      this.toasts.show(`Deleted ${c.light.name || 'light ' + c.light.id}.`, 'ok');
      this.render(this.lights.filter((x) => x.id !== c.light.id));
    } catch (e) {
      this.toasts.error(e);
      if (!this.eventsLive) this.refresh();
    }
  }

  /* Where a new light goes: outside the model, on the camera's side and above it (a key light's
   * place), so that it lights what the user sees instead of sitting inside the mesh. Point and
   * spot lights get an intensity that gives about the default key light's 2.5 at the model's
   * centre; a spot aims at it; a directional light shines from there toward it. */
  static placement(type, bounds, eye, target) {
    const lo = bounds ? bounds.min : [target[0] - 1, target[1] - 1, target[2] - 1];
    const hi = bounds ? bounds.max : [target[0] + 1, target[1] + 1, target[2] + 1];
    const c = [0, 1, 2].map((i) => 0.5 * (lo[i] + hi[i]));
    const radius = Math.max(0.05, 0.5 * Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]));
    let toward = eye ? [eye[0] - c[0], eye[1] - c[1], eye[2] - c[2]] : [0, 0, 1];
    let n = Math.hypot(...toward) || 1;
    toward = toward.map((v) => v / n);
    // from the camera's side, raised by 45 degrees over the model and a little to its left
    const up = [0, 1, 0];
    const left = [toward[2], 0, -toward[0]].map((v) => v / (Math.hypot(toward[2], toward[0]) || 1));
    let dir = [0, 1, 2].map((i) => toward[i] + up[i] + 0.4 * left[i]);
    n = Math.hypot(...dir);
    dir = dir.map((v) => v / n);
    const dist = radius * 1.6;
    const round = (v) => Math.round(v * 1000) / 1000;
    const position = [0, 1, 2].map((i) => round(c[i] + dir[i] * dist));
    const aim = dir.map((v) => round(-v));
    if (type === 'directional') return { intensity: 2.5, direction: aim };
    const body = { intensity: Number((2.5 * dist * dist).toPrecision(3)), position };
    if (type === 'spot') Object.assign(body, { direction: aim, inner_cone_angle: 0.35, outer_cone_angle: 0.6 });
    return body;
  }

  async add(type) {
    const target = this.cameraTarget() || [0, 1, 0];
    const body = { type, color: [1, 1, 1],
      ...LightsPanel.placement(type, this.sceneBounds(), this.cameraPosition(), target) };
    try {
      const l = await this.api.post('/v1/lights', body);
      this.upsert(l);
      this.render(this.lights);
      const c = l && this.cards.get(l.id);
      if (c) { c.el.open = true; c.el.scrollIntoView({ block: 'nearest' }); }
    } catch (e) {
      this.toasts.error(e);
    }
  }
}

/* ---- views: follow another viewer --------------------------------------------------------- */
/* Lists the views of GET /v1/views (from 'views' events) other than our own, each with a Follow
 * button, and shows "Following view N — Stop" in the top bar while we watch another view.
 * onFollow(id) asks to watch view id; onFollow(null) returns to the own view. */
export class ViewsPanel {
  constructor({ onFollow }) {
    this.onFollow = onFollow;
    this.root = $('views');
    this.self = $('views-self');
    this.count = $('view-count');
    this.banner = $('following');
    this.bannerId = $('following-id');
    this.doc = null;
    this.single = false;
    this.own = null;       // our own view's id (null before the welcome or in version 1)
    this.watching = null;  // the view we watch (the own one when not following)
    $('following-stop').addEventListener('click', () => this.onFollow(null));
    this.render();
  }

  /* doc: a 'views' event (the body of GET /v1/views) or null; own, watching: view ids (null
   * while not connected); single: the server predates views (version 1: one shared view). */
  update({ doc = this.doc, own = this.own, watching = this.watching, single = this.single } = {}) {
    this.doc = doc;
    this.own = own;
    this.watching = watching;
    this.single = single;
    this.render();
  }

  get following() { return this.own !== null && this.watching !== null && this.watching !== this.own; }

  render() {
    const views = (this.doc && Array.isArray(this.doc.views)) ? this.doc.views : [];
    const mine = views.find((v) => v.id === this.own);
    if (this.own === null) this.self.textContent = this.single ? 'This server shows everyone one view.' : '–';
    else this.self.replaceChildren(h('b', {}, `Your view ${this.own}`),
      mine ? ` · ${mine.width}×${mine.height}` : '', this.following ? ` · not shown while you follow` : '');
    const others = views.filter((v) => v.id !== this.own);
    this.count.textContent = others.length ? `(${others.length})` : '';
    this.root.replaceChildren(...others.map((v) => {
      const on = v.id === this.watching;
      const who = v.owner === 'http' ? 'HTTP' : String(v.owner || '');
      const title = `${v.owner === 'http' ? 'The default view (/v1/camera)' : 'Another viewer\'s view'}` +
        (Number.isFinite(v.watchers) ? `; ${v.watchers} watching` : '');
      return h('div', { class: 'view-row' + (on ? ' on' : ''), 'data-id': String(v.id) },
        h('span', { class: 'vid' }, `view ${v.id}`),
        h('span', { class: 'vinfo', title }, `${v.width}×${v.height} · ${who}`),
        h('button', {
          type: 'button', class: 'btn small' + (on ? ' primary' : ''), 'aria-pressed': String(on),
          'data-follow': String(v.id), disabled: this.own === null,
          title: on ? 'Back to your own view' : `Watch view ${v.id} (your camera input pauses meanwhile)`,
          onclick: () => this.onFollow(on ? null : v.id),
        }, on ? 'Stop' : 'Follow'));
    }));
    this.banner.hidden = !this.following;
    this.bannerId.textContent = this.following ? String(this.watching) : '';
    document.body.classList.toggle('following', this.following);
  }
}
