// lights_panel.js: the lights panel: add, move, recolour, dim and delete the scene's lights. Like
// every panel it owns its DOM subtree (found by id in index.html), talks to the server only
// through an Api (api.js) and reports failures with the server's own message. The lights reach
// it through the stream's 'lights' events (protocol/stream.md, version 2): applyEvent(doc) takes
// the body of GET /v1/lights; the panel never polls. refresh() (one GET) is only for a version-1
// server, which sends no events.

import { h, icon } from './dom.js';
import { Coalescer } from './coalescer.js';
import { hexToLinear, linearToHex } from './colour.js';

const $ = (id) => document.getElementById(id);

/* Icons (16 x 16 stroke paths) for dom.js's icon(). */
const ICON_TARGET = 'M8 1.5v3M8 11.5v3M1.5 8h3M11.5 8h3M8 4.5a3.5 3.5 0 1 0 0 7a3.5 3.5 0 1 0 0-7z';
const ICON_DELETE = 'M4 4l8 8M12 4l-8 8';

/* Intensity slider: logarithmic from 0.01 to 10000, with 0 at the far left. */
const SLIDER_MAX = 1000;
const intensityToSlider = (v) => (v > 0 ? Math.min(SLIDER_MAX, Math.max(1, ((Math.log10(v) + 2) / 6) * SLIDER_MAX)) : 0);
const sliderToIntensity = (p) => (p > 0 ? Number(Math.pow(10, (p / SLIDER_MAX) * 6 - 2).toPrecision(3)) : 0);

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
