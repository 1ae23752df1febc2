// animation.js: the animation panel — play / pause and a time slider for the scene's glTF
// animations (PATCH /v1/animation), shown only when the scene has some. Like the other panels
// (lights_panel.js, render_panel.js) it owns its DOM subtree (index.html), talks to the server
// only through an Api and takes the body of GET /v1/animation from the stream's 'animation'
// events (applyEvent).

import { Coalescer } from './coalescer.js';

const $ = (id) => document.getElementById(id);

/* The scene's glTF animations (GET /v1/animation, 'animation' events): play / pause and a time
 * slider, shown only when the scene has animations. The server sends an event on play, pause and
 * seek only; while the clip plays the panel advances the time itself from the last document
 * (looping over its duration), as the server's clock does while someone watches. Dragging the
 * slider seeks (coalesced PATCH /v1/animation {time}). */
export class AnimationPanel {
  constructor(api, { toasts }) {
    this.api = api;
    this.toasts = toasts;
    this.doc = null;       // the server's last word: { count, duration, playing, time }
    this.at = 0;           // performance.now() when doc arrived
    this.scrubbing = false;
    this.raf = 0;
    this.queue = new Coalescer((_, patch) => this.api.patch('/v1/animation', patch));
    this.panel = $('panel-anim');
    this.count = $('anim-count');
    this.play = $('anim-play');
    this.slider = $('anim-time');
    this.out = $('anim-out');
    this.play.addEventListener('click', () => this.toggle());
    this.slider.addEventListener('pointerdown', () => { this.scrubbing = true; });
    this.slider.addEventListener('input', () => {
      this.scrubbing = true;
      this.showTime(Number(this.slider.value));
      this.patch({ time: Number(this.slider.value) });
    });
    const release = () => { if (this.scrubbing) { this.scrubbing = false; this.tick(); } };
    this.slider.addEventListener('change', release);
    window.addEventListener('pointerup', release);
    window.addEventListener('pointercancel', release);
  }

  get visible() { return !!this.doc && this.doc.count > 0; }

  /* One GET /v1/animation (a version-1 server sends no events; also after a scene change). */
  async refresh() {
    try {
      this.applyEvent(await this.api.get('/v1/animation'));
    } catch (e) { /* a server without animations support, or offline: the panel stays as it is */ }
  }

  /* An 'animation' event or a PATCH answer (the body of GET /v1/animation). */
  applyEvent(doc) {
    if (!doc || typeof doc.count !== 'number') return;
    this.doc = doc;
    this.at = performance.now();
    this.panel.hidden = !this.visible;
    this.count.textContent = doc.count > 1 ? String(doc.count) : '';
    const d = Math.max(0, Number(doc.duration) || 0);
    this.slider.max = String(d || 1);
    this.slider.step = String(d > 20 ? 0.05 : 0.01);
    this.slider.disabled = !(d > 0);
    this.play.setAttribute('aria-pressed', String(!!doc.playing));
    this.play.textContent = doc.playing ? '❚❚' : '▶';
    this.play.setAttribute('aria-label', doc.playing ? 'Pause' : 'Play');
    this.play.title = (doc.playing ? 'Pause' : 'Play') + ' (space)';
    this.tick();
  }

  /* The clip time now: the document's, plus the time since it arrived while playing. */
  now() {
    const d = this.doc;
    if (!d) return 0;
    const duration = Number(d.duration) || 0;
    if (!d.playing || !(duration > 0)) return d.time || 0;
    const t = (d.time || 0) + (performance.now() - this.at) / 1000;
    return t % duration;
  }

  showTime(t) {
    const d = this.doc ? Number(this.doc.duration) || 0 : 0;
    this.out.textContent = `${t.toFixed(2)} / ${d.toFixed(2)} s`;
  }

  /* Moves the slider along while playing (one animation frame at a time, only when shown). */
  tick() {
    cancelAnimationFrame(this.raf);
    this.raf = 0;
    if (!this.visible) return;
    const t = this.now();
    if (!this.scrubbing && !this.queue.busy('a')) this.slider.value = String(t);
    if (!this.scrubbing) this.showTime(t);
    if (this.doc.playing && this.doc.duration > 0) this.raf = requestAnimationFrame(() => this.tick());
  }

  toggle() {
    if (!this.visible) return;
    this.patch({ playing: !this.doc.playing });
  }

  async patch(p) {
    // Optimistic: the button shows the choice at once; the answer (and its event) confirm it.
    if (this.doc && p.playing !== undefined) this.applyEvent({ ...this.doc, time: this.now(), playing: p.playing });
    try {
      const doc = await this.queue.send('a', p);
      if (!this.queue.busy('a')) this.applyEvent(doc);
    } catch (e) {
      this.toasts.error(e);
      this.refresh();
    }
  }
}
