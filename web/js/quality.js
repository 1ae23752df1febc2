// quality.js: the render size this viewer asks for ('resize' messages, protocol/stream.md), the
// caps it sets on its own view ('quality' messages) and the Quality panel that sets both.
//
// The size asked for is the canvas's CSS size times devicePixelRatio (the server scales it down
// to its pixel limits), times the panel's resolution scale (100/75/50/25 % per side). While the
// camera moves (a drag, the wheel, a pinch, held keys) and "lower resolution while moving" is
// on, the viewer asks for half the pixels it would get otherwise, and for the full size again
// once input has stopped for the server's still delay (still_delay_ms): the server renders and
// encodes fewer pixels while moving; the canvas scales the smaller frames up meanwhile.
// Window resizes are debounced (one message per burst); repeated sizes are not sent again.
//
// Version 2 also lets a viewer cap its own view's JPEG quality and frame rate: 'auto' (null)
// leaves the server's settings (quality_interactive, quality_still, max_fps), a number caps them
// further (the server's max_fps and its lag-based quality cap still apply on top). A new view
// starts without caps, so they are sent again after every welcome; a version-1 server has no
// such message and the panel's choices are disabled.
//
// Format (version 2): auto and video ask for VP9 (else VP8) video when this browser's
// VideoDecoder supports it (video.js); JPEG never does. The viewer falls back to JPEG by itself
// when the decoder fails. Stills after the camera stops stay JPEG in every mode.

import { probeVideoCodec } from './video.js';

const RESIZE_DEBOUNCE_MS = 150;
const INTERACTIVE_PIXELS = 0.5;    // share of the pixels asked for while the camera moves
const DEFAULT_STILL_DELAY_MS = 150;
export const SCALES = [1, 0.75, 0.5, 0.25];
const KEY_SCALE = 'probecast.quality.scale';
const KEY_INTERACTIVE = 'probecast.quality.interactive';
export const JPEG_CAPS = [null, 90, 75, 50]; // null: auto (the server's qualities)
export const FPS_CAPS = [null, 60, 30, 15];  // null: auto (the server's max_fps)
const KEY_JPEG = 'probecast.quality.jpeg';
const KEY_FPS = 'probecast.quality.fps';
const KEY_FORMAT = 'probecast.quality.format';
export const FORMATS = ['auto', 'video', 'jpeg'];

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

/* A stored choice: one of `choices` (null = auto), else auto. */
function storedCap(key, choices) {
  const v = localStorage.getItem(key);
  const n = v === null || v === '' ? null : Number(v);
  return choices.includes(n) ? n : null;
}

/* The caps of this viewer's own view: JPEG quality and frame rate, null = auto (no cap).
 * stream: FrameStream (sendQuality). */
export class ViewCaps {
  constructor({ stream }) {
    this.stream = stream;
    this.jpeg = storedCap(KEY_JPEG, JPEG_CAPS);
    this.maxFps = storedCap(KEY_FPS, FPS_CAPS);
    this.listeners = new Set();
  }

  /* Sends both caps; false when the stream cannot (not connected, version 1, before the
   * welcome). */
  send() {
    const ok = this.stream.sendQuality(this.jpeg, this.maxFps);
    for (const fn of this.listeners) fn();
    return ok;
  }

  /* After the welcome: the connection's new view has no caps; set ours again (nothing to send
   * when both are auto). */
  connected() {
    if (this.jpeg !== null || this.maxFps !== null) this.send();
  }

  setJpeg(q) {
    if (!JPEG_CAPS.includes(q)) return;
    this.jpeg = q;
    localStorage.setItem(KEY_JPEG, q === null ? '' : String(q));
    this.send();
  }

  setMaxFps(n) {
    if (!FPS_CAPS.includes(n)) return;
    this.maxFps = n;
    localStorage.setItem(KEY_FPS, n === null ? '' : String(n));
    this.send();
  }

  onChange(fn) { this.listeners.add(fn); }
}

const capValue = (b) => (b.dataset.value === 'auto' ? null : Number(b.dataset.value));

/* The Quality panel: resolution scale buttons, the interactive-resolution switch, the JPEG
 * quality and frame-rate caps, and a line that says what was asked for and what the server
 * renders (the last frame of our view). */
export class QualityPanel {
  constructor(size, caps) {
    this.size = size;
    this.caps = caps;
    this.seg = $('res-scale');
    this.jpegSeg = $('jpeg-cap');
    this.fpsSeg = $('fps-cap');
    this.formatSeg = $('video-mode');
    const stream = caps.stream;
    const stored = localStorage.getItem(KEY_FORMAT);
    stream.setVideo({ mode: FORMATS.includes(stored) ? stored : 'auto' });
    probeVideoCodec().then((codec) => { this.codec = codec; stream.setVideo({ codec }); this.show(); });
    for (const b of this.formatSeg.querySelectorAll('button'))
      b.addEventListener('click', () => {
        localStorage.setItem(KEY_FORMAT, b.dataset.value);
        stream.setVideo({ mode: b.dataset.value });
        this.show();
      });
    stream.addEventListener('video', () => this.show());
    this.toggle = $('interactive-res');
    this.out = $('res-out');
    for (const b of this.seg.querySelectorAll('button')) {
      b.addEventListener('click', () => { this.size.setScale(Number(b.dataset.scale)); this.show(); });
    }
    for (const b of this.jpegSeg.querySelectorAll('button'))
      b.addEventListener('click', () => this.caps.setJpeg(capValue(b)));
    for (const b of this.fpsSeg.querySelectorAll('button'))
      b.addEventListener('click', () => this.caps.setMaxFps(capValue(b)));
    this.toggle.checked = size.interactive;
    this.toggle.addEventListener('change', () => this.size.setInteractive(this.toggle.checked));
    size.onSent(() => this.show());
    caps.onChange(() => this.show());
    this.show();
  }

  /* Version 1 servers have no per-view caps: their choices are disabled. */
  setAvailable(on) {
    for (const b of [...this.jpegSeg.querySelectorAll('button'), ...this.fpsSeg.querySelectorAll('button'),
      ...this.formatSeg.querySelectorAll('button')]) {
      b.disabled = !on;
      b.title = on ? '' : 'This server shares one view among viewers (protocol version 1): no per-viewer caps';
    }
  }

  show(header = this.header) {
    this.header = header;
    for (const b of this.seg.querySelectorAll('button'))
      b.setAttribute('aria-checked', String(Number(b.dataset.scale) === this.size.scale));
    for (const b of this.jpegSeg.querySelectorAll('button'))
      b.setAttribute('aria-checked', String(capValue(b) === this.caps.jpeg));
    for (const b of this.fpsSeg.querySelectorAll('button'))
      b.setAttribute('aria-checked', String(capValue(b) === this.caps.maxFps));
    const stream = this.caps.stream;
    for (const b of this.formatSeg.querySelectorAll('button'))
      b.setAttribute('aria-checked', String(b.dataset.value === stream.videoMode));
    const s = this.size.lastSent;
    const asked = s ? `asked ${Math.round(s.width * s.dpr)}×${Math.round(s.height * s.dpr)}` : 'asked –';
    const got = header ? ` · rendering ${header.width}×${header.height}${header.still ? '' : ' (moving)'} · ${header.format ? ['jpeg', 'vp8', 'vp9'][header.format] || 'video' : 'q' + header.quality}` : '';
    this.out.textContent = asked + got;
  }
}
