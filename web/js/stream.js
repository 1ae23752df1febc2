// stream.js: the frame stream (protocol/stream.md, version 2; version 1 as a fallback):
// WebSocket, the server's text messages (welcome, events, following, errors), header parsing,
// JPEG decoding off the main thread, drawing, acknowledgements, input sequence numbers, follow
// requests and reconnects; video frames (format VP9/VP8) go to video.js's WebCodecs decoder.

import { CODECS, FORMAT_JPEG, VideoPath } from './video.js';

export const MAGIC = 0x52464350; // 'PCFR' read as a little-endian uint32
export const HEADER_V1_SIZE = 64;
export const SUBPROTOCOL = 'probecast.v2';
const FLAG_STILL = 1;
const FLAG_KEY = 2;
export const VIDEO_MODES = ['auto', 'video', 'jpeg'];
const BACKOFF_MIN_MS = 250;
const BACKOFF_MAX_MS = 5000;
const CONNECT_TIMEOUT_MS = 5000;
const WINDOW_MS = 1000; // fps and bit rate are measured over the last second
const WORLD_KINDS = ['scene', 'lights', 'node', 'settings', 'views', 'animation'];

/* Parses a frame header from an ArrayBuffer; throws on a message that is not a frame.
 * Versions 1 and 2 share one layout (version 2 only changes what view_id names).
 * 64-bit fields become Numbers (exact below 2^53, i.e. for 285 years of microseconds). */
export function parseHeader(buf) {
  if (!(buf instanceof ArrayBuffer) || buf.byteLength < HEADER_V1_SIZE) throw new Error('short frame message');
  const v = new DataView(buf);
  const u64 = (o) => v.getUint32(o, true) + v.getUint32(o + 4, true) * 4294967296;
  if (v.getUint32(0, true) !== MAGIC) throw new Error('bad frame magic');
  const version = v.getUint16(4, true);
  const headerSize = v.getUint16(6, true);
  if (version !== 1 && version !== 2) throw new Error('unsupported frame version ' + version);
  if (headerSize < HEADER_V1_SIZE) throw new Error('bad frame header size');
  const h = {
    version,
    headerSize,
    frameId: u64(8),
    captureUs: u64(16),
    encodeUs: u64(24),
    sendUs: u64(32),
    viewId: v.getUint32(40, true),
    width: v.getUint32(44, true),
    height: v.getUint32(48, true),
    inputSeq: v.getUint32(52, true),
    jpegSize: v.getUint32(56, true),
    quality: v.getUint8(60),
    still: (v.getUint8(61) & FLAG_STILL) !== 0,
    key: (v.getUint8(61) & FLAG_KEY) !== 0,
    format: v.getUint8(62), // 0 JPEG, 1 VP8, 2 VP9 (only after this viewer asked for video)
  };
  if (headerSize + h.jpegSize > buf.byteLength) throw new Error('truncated frame');
  return h;
}

/* Parses a server text message (version 2); null when it is not a JSON object with a type. */
export function parseServerMessage(text) {
  let m;
  try { m = JSON.parse(text); } catch { return null; }
  return m && typeof m === 'object' && typeof m.type === 'string' ? m : null;
}

/* Decodes JPEG bytes to something drawImage takes. createImageBitmap on a Blob decodes on the
 * browser's image decoding threads (Chromium, Firefox, Safari 15+); the <img>.decode() fallback
 * is asynchronous too. Returns { image, close() }. */
async function decodeJpeg(blob) {
  if (typeof createImageBitmap === 'function') {
    const bmp = await createImageBitmap(blob);
    return { image: bmp, width: bmp.width, height: bmp.height, close: () => bmp.close() };
  }
  const url = URL.createObjectURL(blob);
  const img = new Image();
  img.src = url;
  try {
    await img.decode();
  } finally {
    URL.revokeObjectURL(url);
  }
  return { image: img, width: img.naturalWidth, height: img.naturalHeight, close() {} };
}

/* CanvasView: draws decoded frames into a canvas whose backing store follows its CSS size times
 * devicePixelRatio, fitted without distortion (letterboxed when the view shown (e.g. a followed one) has another
 * aspect). Keeps the last frame so a resize redraws at once. */
export class CanvasView {
  constructor(canvas) {
    this.canvas = canvas;
    this.ctx = canvas.getContext('2d', { alpha: false });
    this.last = null;
    this.fitBacking();
  }

  /* Sizes the backing store; returns the CSS size and device pixel ratio. */
  fitBacking() {
    const r = this.canvas.getBoundingClientRect();
    const dpr = window.devicePixelRatio || 1;
    const w = Math.max(1, Math.round(r.width * dpr));
    const h = Math.max(1, Math.round(r.height * dpr));
    if (this.canvas.width !== w || this.canvas.height !== h) {
      this.canvas.width = w;
      this.canvas.height = h;
      this.redraw();
    }
    return { width: r.width, height: r.height, dpr };
  }

  show(frame) {
    if (this.last && this.last !== frame) this.last.close();
    this.last = frame;
    this.redraw();
  }

  /* Where the frame goes in the canvas's backing store: a frame of nearly the canvas's aspect
   * (a reduced size asked for while moving, rounded) fills the canvas; another aspect (a
   * followed view) is letterboxed. */
  placement(f = this.last) {
    const { canvas } = this;
    if (!f) return { x: 0, y: 0, w: canvas.width, h: canvas.height, s: 1 };
    const s = Math.min(canvas.width / f.width, canvas.height / f.height);
    const near = Math.abs((f.width / f.height) / (canvas.width / canvas.height) - 1) < 0.03;
    const w = near ? canvas.width : Math.round(f.width * s), h = near ? canvas.height : Math.round(f.height * s);
    return { x: (canvas.width - w) >> 1, y: (canvas.height - h) >> 1, w, h, s };
  }

  /* The picture's rectangle in page CSS pixels: { left, top, width, height }. */
  pictureRect() {
    const r = this.canvas.getBoundingClientRect();
    const p = this.placement();
    const k = r.width / Math.max(1, this.canvas.width);
    return { left: r.left + p.x * k, top: r.top + p.y * k, width: p.w * k, height: p.h * k };
  }

  redraw() {
    const { ctx, canvas } = this;
    ctx.fillStyle = '#0b0c10';
    ctx.fillRect(0, 0, canvas.width, canvas.height);
    const f = this.last;
    if (!f) return;
    const p = this.placement(f);
    ctx.imageSmoothingEnabled = true;
    ctx.imageSmoothingQuality = p.s > 1 ? 'medium' : 'high'; // scaled up while moving
    ctx.drawImage(f.image, p.x, p.y, p.w, p.h);
  }
}

/* FrameStream: one WebSocket at a time to the frame stream, reconnecting with exponential
 * backoff (0.25 s doubling to 5 s, 50-100 % jitter).
 *
 *   resolve(): async () => ({ url, protocols }) names the stream for the next attempt (it may
 *              wait, e.g. for a token); throwing schedules a retry.
 *   view:      a CanvasView that receives decoded frames.
 *
 * Views (version 2): the connection owns a view (ownView, from the server's welcome) and
 * watches one view (watching: its own, or the one it follows). follow(id) asks to watch
 * another view, follow(null) returns to the own one; the server confirms with 'following'.
 * Every connection, and so every reconnect, gets a new own view and watches it. On a
 * version-1 server (the subprotocol it chose is not probecast.v2) ownView and watching are 0
 * (the shared view), there are no text messages and follow() does nothing.
 *
 * Frames: the newest wins. One decode runs at a time and one waits; a newer arrival replaces
 * the waiting one, so a slow decoder skips to the newest frame. A frame is never drawn after a
 * newer one of the same view, and each drawn frame is acknowledged ({"type":"ack","frame":id}).
 * Frame ids are global over all views: a followed view's current frame may be older than the
 * own view's last one, so the ordering starts over when the view shown changes; frames of the
 * view left behind (still in flight after a follow request) are dropped.
 *
 * Events: 'state' (detail: { state, retryInMs, attempt, code, reason }), 'open' (detail:
 * { protocol: 1|2 }), 'welcome' (detail: the message), 'world' (detail: { what, data }: an
 * 'event' message; the latest document of each kind is also kept in world[what]),
 * 'following' (detail: { view, own }), 'server-error' (detail: { message }), 'frame'
 * (detail: header, after drawing). */
export class FrameStream extends EventTarget {
  constructor({ resolve, view }) {
    super();
    this.resolve = resolve;
    this.view = view;
    this.ws = null;
    this.gen = 0;            // connection generation: decodes of older connections are dropped
    this.attempt = 0;
    this.state = 'idle';
    this.stopped = true;
    this.retryTimer = 0;
    this.retryAt = 0;
    this.nextSeq = 1;        // camera message sequence numbers, increasing for the page's life
    this.inputs = [];        // [{ seq, t }] sent and not yet seen in a frame
    this.resetConnection();
    this.counters = { received: 0, drawn: 0, skipped: 0, stale: 0, bad: 0, decodeErrors: 0, reconnects: 0, messages: 0 };
    this.recent = [];        // [{ t, bytes, drawn }] over the last WINDOW_MS
    this.latencies = [];     // [{ t, ms }] input-to-frame samples
    this.lastHeader = null;
    // Video (version 2): videoMode 'auto' and 'video' ask for video when videoCodec (the codec
    // this browser decodes, probeVideoCodec) is known; 'jpeg' never. videoMaxKbps caps it.
    this.videoMode = 'auto';
    this.videoCodec = null;
    this.videoMaxKbps = null;
    this.videoFailed = false; // the decoder failed on this page: JPEG until the mode changes
  }

  /* What belongs to one connection: its protocol, views, world documents and frame order. */
  resetConnection() {
    this.protocol = 0;       // 2 or 1 once open
    this.ownView = null;     // the connection's own view (welcome); 0 in version 1
    this.watching = null;    // the view the server says this connection watches
    this.expectView = null;  // the view whose frames are drawn (a follow request sets it at once)
    this.pendingFollow = false;
    this.welcome = null;
    this.world = {};         // what -> the latest 'event' document of this connection
    if (this.video) this.video.close();
    this.video = null;       // VideoPath while this connection asked for video
    this.resetFrames();
  }

  resetFrames() {
    this.newestId = 0;       // newest frame id received of frameView on this connection
    this.drawnId = 0;        // newest frame id drawn of frameView on this connection
    this.frameView = null;   // the view of the frames newestId and drawnId count
    this.decoding = false;
    this.pending = null;
    this.awaitKey = false;   // a video packet was missed: a key frame was asked for
  }

  /* Whether this connection watches a view other than its own. */
  get following() { return this.protocol === 2 && this.watching !== null && this.watching !== this.ownView; }

  start() {
    if (!this.stopped) return;
    this.stopped = false;
    this.connect();
  }

  stop() {
    this.stopped = true;
    clearTimeout(this.retryTimer);
    if (this.ws) {
      const ws = this.ws;
      this.ws = null;
      ws.close(1000, 'viewer closed');
    }
    this.setState('idle');
  }

  /* Connects now, ending a pending backoff wait (used on 'online' and when the tab shows). */
  retryNow() {
    if (this.stopped || this.state !== 'waiting') return;
    clearTimeout(this.retryTimer);
    this.connect();
  }

  get open() { return !!this.ws && this.ws.readyState === WebSocket.OPEN; }

  setState(state, extra = {}) {
    this.state = state;
    this.dispatchEvent(new CustomEvent('state', { detail: { state, attempt: this.attempt, ...extra } }));
  }

  emit(type, detail) { this.dispatchEvent(new CustomEvent(type, { detail })); }

  async connect() {
    if (this.stopped) return;
    this.setState('connecting');
    let target;
    try {
      target = await this.resolve();
    } catch (e) {
      this.scheduleRetry({ reason: e && e.message });
      return;
    }
    if (this.stopped) return;
    let ws;
    try {
      ws = new WebSocket(target.url, target.protocols);
    } catch (e) {
      this.scheduleRetry({ reason: e.message });
      return;
    }
    ws.binaryType = 'arraybuffer';
    const gen = ++this.gen;
    this.ws = ws;
    this.resetConnection();
    const connectTimer = setTimeout(() => { if (ws.readyState === WebSocket.CONNECTING) ws.close(); }, CONNECT_TIMEOUT_MS);
    ws.onopen = () => {
      clearTimeout(connectTimer);
      if (this.ws !== ws) return;
      // A server that predates views answers probecast.v1: it shows everyone view 0.
      this.protocol = ws.protocol === SUBPROTOCOL ? 2 : 1;
      if (this.protocol === 1) this.ownView = this.watching = this.expectView = 0;
      this.setState('open');
      this.emit('open', { protocol: this.protocol });
    };
    ws.onmessage = (ev) => { if (this.ws === ws) this.onMessage(ev.data, gen); };
    ws.onclose = (ev) => {
      clearTimeout(connectTimer);
      if (this.ws !== ws) return;
      this.ws = null;
      this.inputs = []; // never reflected now: the server forgets them with the connection
      this.resetConnection(); // the next connection has a view of its own and watches it
      if (ev.code === 1008 || ev.code === 1009 || ev.code === 1003)
        console.warn(`probecast: the server closed the stream (${ev.code} ${ev.reason}): a viewer message was refused`);
      this.scheduleRetry({ code: ev.code, reason: ev.reason });
    };
  }

  scheduleRetry(extra) {
    if (this.stopped) return;
    const base = Math.min(BACKOFF_MAX_MS, BACKOFF_MIN_MS * 2 ** Math.min(this.attempt, 10));
    const delay = Math.round(base * (0.5 + 0.5 * Math.random()));
    this.attempt++;
    this.counters.reconnects++;
    this.retryAt = performance.now() + delay;
    clearTimeout(this.retryTimer);
    this.retryTimer = setTimeout(() => this.connect(), delay);
    this.setState('waiting', { retryInMs: delay, ...extra });
  }

  /* Sends a viewer message (an object); false when not connected. */
  send(msg) {
    if (!this.open) return false;
    this.ws.send(JSON.stringify(msg));
    return true;
  }

  /* Sends a camera message with the next sequence number; returns the seq or 0. It moves the
   * own view, also while following (main.js sends none then). */
  sendCamera(fields) {
    const seq = this.nextSeq;
    if (!this.send({ type: 'camera', seq, ...fields })) return 0;
    this.nextSeq = seq >= 4294967295 ? 1 : seq + 1;
    this.inputs.push({ seq, t: performance.now() });
    if (this.inputs.length > 256) this.inputs.shift();
    return seq;
  }

  sendResize(width, height, dpr) {
    return this.send({
      type: 'resize',
      width: Math.max(1, Math.min(16384, Math.round(width))),
      height: Math.max(1, Math.min(16384, Math.round(height))),
      dpr: Math.max(0.25, Math.min(8, Math.round(dpr * 1000) / 1000)),
    });
  }

  /* Caps the own view's JPEG quality (1..100) and frame rate (1..240); null: no cap. Version 2
   * only: false when not possible (not connected, version 1, before the welcome). */
  sendQuality(jpeg, maxFps) {
    if (this.protocol !== 2 || this.ownView === null) return false;
    const cap = (v, hi) => (v === null || v === undefined ? null : Math.max(1, Math.min(hi, Math.round(v))));
    return this.send({ type: 'quality', jpeg: cap(jpeg, 100), max_fps: cap(maxFps, 240) });
  }

  /* Chooses between video and JPEG ('auto' | 'video' | 'jpeg'; codec: 'vp9', 'vp8' or null
   * when the browser decodes neither) and asks the server at once when connected. */
  setVideo({ mode = this.videoMode, codec = this.videoCodec, maxKbps = this.videoMaxKbps } = {}) {
    if (mode !== this.videoMode) this.videoFailed = false;
    this.videoMode = VIDEO_MODES.includes(mode) ? mode : 'auto';
    this.videoCodec = codec && CODECS[codec] ? codec : null;
    this.videoMaxKbps = maxKbps;
    this.requestVideo();
  }

  /* Whether this connection should get video now. */
  get wantsVideo() { return this.videoMode !== 'jpeg' && !!this.videoCodec && !this.videoFailed; }

  /* Sends the video request the mode calls for (version 2, after the welcome); a repeated
   * request also makes the server send a key frame. */
  requestVideo() {
    if (this.protocol !== 2 || this.ownView === null) return false;
    if (!this.wantsVideo) {
      if (!this.video) return false;
      this.video.close();
      this.video = null;
      this.emit('video', { active: false, codec: null });
      return this.send({ type: 'video', codec: null, max_kbps: null });
    }
    if (!this.video || this.video.codec !== this.videoCodec) {
      if (this.video) this.video.close();
      this.video = new VideoPath(this.videoCodec, {
        onFrame: (h, frame) => this.presentVideo(h, frame),
        onError: (e) => this.videoError(e),
      });
      this.emit('video', { active: true, codec: this.videoCodec });
    }
    const kbps = this.videoMaxKbps ? Math.max(50, Math.min(100000, Math.round(this.videoMaxKbps))) : null;
    return this.send({ type: 'video', codec: this.videoCodec, max_kbps: kbps });
  }

  /* The decoder failed: JPEG from now on (the server is told), until the mode changes. */
  videoError(e) {
    this.counters.decodeErrors++;
    this.videoFailed = true;
    this.video = null;
    this.send({ type: 'video', codec: null, max_kbps: null });
    this.emit('video', { active: false, codec: null, error: String((e && e.message) || e) });
  }

  /* A video packet: decoded in order; one that cannot be fed asks for a key frame. */
  onVideo(h, data) {
    if (!this.video || h.format !== this.video.format) { this.counters.stale++; return; }
    if (!this.video.decode(h, data) && this.video && !this.video.closed) {
      this.counters.skipped++;
      if (!this.awaitKey) {
        this.awaitKey = true;
        this.requestVideo();
      }
    } else if (h.key) {
      this.awaitKey = false;
    }
  }

  presentVideo(h, frame) {
    if (h.viewId !== this.frameView || h.frameId <= this.drawnId) { frame.close(); return; }
    this.present(h, frame);
  }

  /* Watches view id (null or the own id: the own view again). Frames of the requested view are
   * drawn from now on; the server's 'following' confirms, an 'error' reverts. False when not
   * possible (not connected, version 1, before the welcome). */
  follow(id) {
    if (this.protocol !== 2 || this.ownView === null) return false;
    const own = id === null || id === undefined || id === this.ownView;
    if (!this.send({ type: 'follow', view: own ? null : id })) return false;
    this.expectView = own ? this.ownView : id;
    this.pendingFollow = true;
    return true;
  }

  onMessage(data, gen) {
    if (typeof data === 'string') { this.onText(data); return; }
    const now = performance.now();
    let h;
    try {
      h = parseHeader(data);
    } catch (e) {
      this.counters.bad++;
      return;
    }
    this.counters.received++;
    this.recent.push({ t: now, bytes: data.byteLength, drawn: false });
    if (this.attempt) this.attempt = 0; // frames flow: the next outage starts from the short backoff
    if (this.expectView !== null && h.viewId !== this.expectView) {
      this.counters.stale++; // a view left behind
      if (h.format !== FORMAT_JPEG && this.video) this.video.resync();
      return;
    }
    if (h.viewId !== this.frameView) {
      // Another view from now on: its frame ids are not comparable with the last view's.
      this.newestId = 0;
      this.drawnId = 0;
      this.frameView = h.viewId;
    }
    if (h.frameId <= this.newestId) { this.counters.stale++; return; }
    this.newestId = h.frameId;
    if (h.format !== FORMAT_JPEG) { this.onVideo(h, data); return; }
    const job = { h, gen, blob: new Blob([new Uint8Array(data, h.headerSize, h.jpegSize)], { type: 'image/jpeg' }) };
    if (this.decoding) {
      if (this.pending) this.counters.skipped++;
      this.pending = job;
      return;
    }
    this.decode(job);
  }

  /* Server text messages (version 2): welcome, event, following, error. */
  onText(text) {
    const m = parseServerMessage(text);
    if (!m) { this.counters.bad++; return; }
    this.counters.messages++;
    switch (m.type) {
      case 'welcome':
        if (!Number.isInteger(m.view)) return;
        this.welcome = m;
        this.ownView = this.watching = this.expectView = m.view;
        this.emit('welcome', m);
        this.requestVideo(); // a new view: ask again
        break;
      case 'event':
        if (!WORLD_KINDS.includes(m.what) || !m.data || typeof m.data !== 'object') return;
        this.world[m.what] = m.data;
        this.emit('world', { what: m.what, data: m.data });
        break;
      case 'following': {
        if (!Number.isInteger(m.view)) return;
        this.watching = m.view;
        this.expectView = m.view;
        this.pendingFollow = false;
        this.emit('following', { view: m.view, own: m.view === this.ownView });
        break;
      }
      case 'error':
        // The only request answered with an error that changes what we draw is a follow.
        if (this.pendingFollow) {
          this.pendingFollow = false;
          this.expectView = this.watching;
        }
        this.emit('server-error', { message: String(m.message || 'The server refused a request.') });
        break;
      default:
        break; // newer servers may add messages
    }
  }

  async decode(job) {
    this.decoding = true;
    try {
      const frame = await decodeJpeg(job.blob);
      if (job.gen !== this.gen || job.h.viewId !== this.frameView || job.h.frameId <= this.drawnId) frame.close();
      else this.present(job.h, frame);
    } catch (e) {
      this.counters.decodeErrors++;
    } finally {
      this.decoding = false;
      const next = this.pending;
      this.pending = null;
      if (next && next.gen === this.gen) this.decode(next);
    }
  }

  present(h, frame) {
    const now = performance.now();
    this.drawnId = h.frameId;
    this.view.show(frame);
    this.send({ type: 'ack', frame: h.frameId });
    this.counters.drawn++;
    this.lastHeader = h;
    this.recent.push({ t: now, bytes: 0, drawn: true });
    // Input-to-frame latency: every input this frame reflects gets its sample, measured to
    // the moment the frame is on the canvas. Only frames of the own view reflect our input.
    if (h.viewId === this.ownView) {
      while (this.inputs.length && this.inputs[0].seq <= h.inputSeq) {
        const i = this.inputs.shift();
        this.latencies.push({ t: now, ms: now - i.t });
      }
    }
    if (this.latencies.length > 120) this.latencies.splice(0, this.latencies.length - 120);
    this.emit('frame', h);
  }

  /* Viewer-side numbers over the last second: { fps, kbps, latencyMs (median of the samples of
   * the last 3 s, null if none), lastLatencyMs }. */
  metrics() {
    const now = performance.now();
    while (this.recent.length && now - this.recent[0].t > WINDOW_MS) this.recent.shift();
    let bytes = 0, drawn = 0;
    for (const r of this.recent) { bytes += r.bytes; drawn += r.drawn ? 1 : 0; }
    const lat = this.latencies.filter((l) => now - l.t < 3000).map((l) => l.ms).sort((a, b) => a - b);
    const last = this.latencies.length ? this.latencies[this.latencies.length - 1].ms : null;
    return {
      fps: drawn * 1000 / WINDOW_MS,
      kbps: bytes * 8 / WINDOW_MS,
      latencyMs: lat.length ? lat[lat.length >> 1] : null,
      lastLatencyMs: last,
    };
  }
}
