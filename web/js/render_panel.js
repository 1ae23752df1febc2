// render_panel.js: the rendering panel: GI mode, probe paths, the view (final, irradiance, probes), exposure,
// the demo animation and the environment (sky, ground, an HDR image). Like every panel it owns
// its DOM subtree (found by id in index.html), talks to the server only through an Api (api.js)
// and reports failures with the server's own message. The settings reach it through the
// stream's 'settings' events (protocol/stream.md, version 2): applyEvent(doc) takes the body of
// GET /v1/settings; the panel never polls. refresh() (one GET) is only for a version-1 server,
// which sends no events.

import { h } from './dom.js';
import { Coalescer } from './coalescer.js';
import { hexToLinear, linearToHex } from './colour.js';

const $ = (id) => document.getElementById(id);

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
// probe_paths values offered (the API takes 0..8; more than three bounces measured no better)
const PATH_LABELS = [[0, 'First hit'], [1, '1'], [2, '2'], [3, '3']];
const PATH_TITLES = {
  0: 'Probe rays end at their first hit, as in the DDGI paper (the default on a CPU device)',
  3: 'Three bounces (the default): builtin:interior -26% -> -9% against the path tracer; probe updates cost about 2x',
};
const NEAR_LABELS = [['on', 'On'], ['off', 'Off']];
const NEAR_TITLES = {
  on: 'Pixels of a resting view trace short rays for 64 frames: corners and contacts darken as they should (the default on a GPU)',
  off: 'The probe field alone (the default on a CPU device)',
};
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
    this.paths = $('probe-paths');
    this.paths.replaceChildren(...PATH_LABELS.map(([v, label]) => h('button', {
      type: 'button', role: 'radio', 'data-value': String(v), 'aria-checked': 'false',
      title: PATH_TITLES[v] || `${v} bounce${v > 1 ? 's' : ''} before the probe field ends a probe ray`,
      onclick: () => this.patch({ probe_paths: v }),
    }, label)));
    this.near = $('near-field');
    this.near.replaceChildren(...NEAR_LABELS.map(([v, label]) => h('button', {
      type: 'button', role: 'radio', 'data-value': v, 'aria-checked': 'false', title: NEAR_TITLES[v],
      onclick: () => this.patch({ near_field: v }),
    }, label)));
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
    // a server without the setting (older) shows no control; with gi off or path traced it is moot
    $('probe-paths-row').hidden = !Number.isInteger(s.probe_paths) || !['classic', 'ddgi'].includes(s.gi_mode);
    for (const b of this.paths.querySelectorAll('button')) b.setAttribute('aria-checked', String(Number(b.dataset.value) === s.probe_paths));
    $('near-field-row').hidden = typeof s.near_field !== 'string' || !['classic', 'ddgi'].includes(s.gi_mode);
    for (const b of this.near.querySelectorAll('button')) b.setAttribute('aria-checked', String(b.dataset.value === s.near_field));
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
