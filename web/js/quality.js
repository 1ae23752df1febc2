// quality.js: the render size this viewer asks for ('resize' messages, protocol/stream.md) and
// the Quality panel that sets it.
//
// The size asked for is the canvas's CSS size times devicePixelRatio (the server scales it down
// to its pixel limits), times the panel's resolution scale (100/75/50/25 % per side). While the
// camera moves (a drag, the wheel, a pinch, held keys) and "lower resolution while moving" is
// on, the viewer asks for half the pixels it would get otherwise, and for the full size again
// once input has stopped for the server's still delay (still_delay_ms): the server renders and
// encodes fewer pixels while moving; the canvas scales the smaller frames up meanwhile.
// Window resizes are debounced (one message per burst); repeated sizes are not sent again.
//
// The protocol lets a viewer choose its size only: a frame-rate cap and the JPEG quality are
// server settings shared by every viewer (max_fps, quality_interactive, quality_still), so the
// panel does not offer them.

const RESIZE_DEBOUNCE_MS = 150;
const INTERACTIVE_PIXELS = 0.5;    // share of the pixels asked for while the camera moves
const DEFAULT_STILL_DELAY_MS = 150;
export const SCALES = [1, 0.75, 0.5, 0.25];
const KEY_SCALE = 'probecast.quality.scale';
const KEY_INTERACTIVE = 'probecast.quality.interactive';

const $ = (id) => document.getElementById(id);

/* stream: FrameStream (sendResize, open); view: CanvasView (fitBacking); controls:
 * CameraControls (active: a pointer is down or a key held); settings(): the server's settings
 * document or null (max_pixels, still_delay_ms). */
export class RenderSize {
  constructor({ stream, view, controls, settings }) {
    this.stream = stream;
    this.view = view;
    this.controls = controls;
    this.settings = settings;
    const s = Number(localStorage.getItem(KEY_SCALE));
    this.scale = SCALES.includes(s) ? s : 1;
    this.interactive = localStorage.getItem(KEY_INTERACTIVE) !== '0';
    this.moving = false;
    this.lastKey = '';
    this.lastSent = null;   // the last resize message sent
    this.debounceTimer = 0;
    this.stillTimer = 0;
    this.listeners = new Set();
  }

  /* The size to ask for now: { width, height, dpr } (CSS pixels and device pixel ratio). */
  request() {
    const { width, height, dpr } = this.view.fitBacking();
    let k = this.scale;
    if (this.moving && this.interactive) {
      // Half the pixels the server would render: it scales a request down to max_pixels, so
      // halve what it grants rather than what was asked for.
      const asked = width * height * dpr * dpr * k * k;
      const s = this.settings();
      const cap = s && s.max_pixels > 0 ? Math.min(asked, s.max_pixels) : asked;
      if (asked > 0) k *= Math.sqrt((INTERACTIVE_PIXELS * cap) / asked);
    }
    return { width: width * k, height: height * k, dpr };
  }

  /* Sends the size unless it is the one sent last (force: send anyway, e.g. after a connect). */
  send(force = false) {
    const r = this.request();
    if (r.width < 1 || r.height < 1) return false;
    const key = `${Math.max(1, Math.round(r.width))}x${Math.max(1, Math.round(r.height))}@${r.dpr}`;
    if (!force && key === this.lastKey) return false;
    if (!this.stream.sendResize(r.width, r.height, r.dpr)) return false;
    this.lastKey = key;
    this.lastSent = { width: Math.max(1, Math.round(r.width)), height: Math.max(1, Math.round(r.height)), dpr: r.dpr };
    for (const fn of this.listeners) fn(this.lastSent);
    return true;
  }

  /* The canvas changed size: send after RESIZE_DEBOUNCE_MS without further changes. */
  resized() {
    clearTimeout(this.debounceTimer);
    this.debounceTimer = setTimeout(() => this.send(false), RESIZE_DEBOUNCE_MS);
  }

  /* Camera input happened: the reduced size at the first input of an interaction, the full
   * size once no input came for the still delay and no pointer or key is held. */
  input() {
    if (!this.interactive || !this.stream.open) return;
    if (!this.moving) {
      this.moving = true;
      this.send(false);
    }
    this.armStill();
  }

  armStill() {
    clearTimeout(this.stillTimer);
    const s = this.settings();
    const delay = s && s.still_delay_ms >= 0 ? s.still_delay_ms : DEFAULT_STILL_DELAY_MS;
    this.stillTimer = setTimeout(() => {
      if (this.controls.active) { this.armStill(); return; }
      this.moving = false;
      this.send(false);
    }, Math.max(50, delay));
  }

  /* After a (re)connect: the full size (an interaction in progress went with the old view). */
  connected() {
    clearTimeout(this.stillTimer);
    this.moving = false;
    this.send(true);
  }

  setScale(s) {
    if (!SCALES.includes(s)) return;
    this.scale = s;
    localStorage.setItem(KEY_SCALE, String(s));
    this.send(false);
  }

  setInteractive(on) {
    this.interactive = !!on;
    localStorage.setItem(KEY_INTERACTIVE, on ? '1' : '0');
    if (!on && this.moving) {
      clearTimeout(this.stillTimer);
      this.moving = false;
      this.send(false);
    }
  }

  onSent(fn) { this.listeners.add(fn); }
}

/* The Quality panel: resolution scale buttons, the interactive-resolution switch and a line
 * that says what was asked for and what the server renders (the last frame of our view). */
export class QualityPanel {
  constructor(size) {
    this.size = size;
    this.seg = $('res-scale');
    this.toggle = $('interactive-res');
    this.out = $('res-out');
    for (const b of this.seg.querySelectorAll('button')) {
      b.addEventListener('click', () => { this.size.setScale(Number(b.dataset.scale)); this.show(); });
    }
    this.toggle.checked = size.interactive;
    this.toggle.addEventListener('change', () => this.size.setInteractive(this.toggle.checked));
    size.onSent(() => this.show());
    this.show();
  }

  show(header = this.header) {
    this.header = header;
    for (const b of this.seg.querySelectorAll('button'))
      b.setAttribute('aria-checked', String(Number(b.dataset.scale) === this.size.scale));
    const s = this.size.lastSent;
    const asked = s ? `asked ${Math.round(s.width * s.dpr)}×${Math.round(s.height * s.dpr)}` : 'asked –';
    const got = header ? ` · rendering ${header.width}×${header.height}${header.still ? '' : ' (moving)'}` : '';
    this.out.textContent = asked + got;
  }
}
