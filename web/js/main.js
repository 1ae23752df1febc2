// main.js: wires the viewer together: the stream on the canvas, camera controls (one camera
// message per animation frame at most), the render size (debounced resize messages), the
// panels, stats polling, drag-and-drop upload and the view restore after a reconnect.

import { Api } from './api.js';
import { CameraControls, OrbitCamera } from './camera.js';
import { LightsPanel, RenderPanel, ScenePanel, StatsPanel, Toasts, TokenPrompt } from './panels.js';
import { CanvasView, FrameStream } from './stream.js';

const RESIZE_DEBOUNCE_MS = 150;
const STATS_PERIOD_MS = 1000;
const CAMERA_SYNC_IDLE_MS = 2000; // adopt another viewer's camera only after this long without input

const $ = (id) => document.getElementById(id);
const canvas = $('view');
const statusEl = $('status');
const statusText = $('status-text');

const toasts = new Toasts();
let authWaiting = false;
const tokenPrompt = new TokenPrompt({ onState: (waiting) => { authWaiting = waiting; showState(); } });
const api = new Api({
  onUnauthorized: () => tokenPrompt.ask(api.token ? 'The server refused the token. Enter the right one:'
                                              : 'This server needs an access token (probecast serve --token).'),
});
const view = new CanvasView(canvas);
const camera = new OrbitCamera();
let sentVersion = 0;        // camera.version last sent or adopted from the server
let scene = null;           // last GET /v1/scene: { source, generation, bounds, ... }
let serverStats = null;

/* ---- the stream ------------------------------------------------------------------------------ */

/* Where the stream is: the --ws port from /v1/health, on the host that served this page. The
 * token goes as a 'bearer.TOKEN' subprotocol next to 'probecast.v1' (protocol/stream.md). */
async function resolveStream() {
  const health = await api.get('/v1/health', { timeoutMs: 4000 });
  if (health.auth === 'bearer' && !(await api.checkToken())) throw new Error('a token is needed');
  const st = health.stream || {};
  if (!st.port) throw new Error('the server has no stream');
  const scheme = location.protocol === 'https:' ? 'wss:' : 'ws:';
  const protocols = [st.subprotocol || 'probecast.v1'];
  if (api.token) protocols.push('bearer.' + api.token);
  return { url: `${scheme}//${location.hostname}:${st.port}${st.path || '/v1/stream'}`, protocols };
}

const stream = new FrameStream({ resolve: resolveStream, view });
let streamState = { state: 'connecting' };

function showState() {
  const s = authWaiting ? 'auth' : streamState.state;
  statusEl.dataset.state = s;
  document.body.classList.toggle('stale', s !== 'open');
  if (s === 'auth') statusText.textContent = 'token needed · click';
  else if (s === 'open') statusText.textContent = `live · ${stream.metrics().fps.toFixed(0)} fps`;
  else if (s === 'waiting') {
    const left = Math.max(0, (stream.retryAt - performance.now()) / 1000);
    statusText.textContent = `offline · retry in ${left.toFixed(1)} s`;
  } else statusText.textContent = 'connecting…';
}
statusEl.addEventListener('click', () => { if (authWaiting) tokenPrompt.reopen(); else stream.retryNow(); });
setInterval(showState, 250);

stream.addEventListener('state', (e) => { streamState = e.detail; showState(); });
stream.addEventListener('open', () => restoreView(stream.gen));

/* After every (re)connect: report our size, then restore our camera when the server still shows
 * the same scene (it restarted, or the connection dropped), else take the server's camera.
 * Camera messages wait for this (`restored`), so input given offline is sent afterwards and
 * input given before the first camera was known is dropped. Retried while the connection
 * lasts if the API fails meanwhile. */
let restored = false;
stream.addEventListener('state', (e) => { if (e.detail.state !== 'open') restored = false; });
async function restoreView(gen) {
  try {
    sendResize(true);
    const [s] = await Promise.all([api.get('/v1/scene'), loadCapabilities()]);
    if (stream.gen !== gen || !stream.open) return;
    const same = scene && s.source === scene.source && s.generation === scene.generation;
    setScene(s);
    if (camera.known && same) {
      sentVersion = -1; // the next animation frame sends our camera
    } else {
      await adoptServerCamera(true);
      if (stream.gen !== gen || !stream.open) return;
    }
    restored = true;
    requestTick();
    renderPanel.refresh();
    lightsPanel.refresh();
  } catch (e) {
    console.warn('probecast: restoring the view failed; retrying:', e.message);
    setTimeout(() => { if (stream.gen === gen && stream.open) restoreView(gen); }, 1000);
  }
}

function setScene(s) {
  scene = s;
  scenePanel.render(s);
  const b = s && s.bounds;
  if (b && b.min && b.max) camera.sceneSize = Math.max(1e-3, Math.hypot(b.max[0] - b.min[0], b.max[1] - b.min[1], b.max[2] - b.min[2]));
}

/* Takes the server's camera: always when forced (new scene, first connection), otherwise only
 * when it differs, the user is idle and nothing of ours waits to be sent. */
async function adoptServerCamera(force) {
  const before = camera.version;
  const c = await api.get('/v1/camera');
  if (!force && (camera.version !== before || camera.version !== sentVersion || !restored ||
                 performance.now() - controls.lastInput < CAMERA_SYNC_IDLE_MS)) return;
  if (force || camera.differsFrom(c)) {
    camera.setFromServer(c);
    sentVersion = camera.version;
  }
}

/* ---- camera input: coalesced to one message per animation frame ---------------------------- */
const controls = new CameraControls(canvas, camera, {
  onChange: () => { fadeHelp(); requestTick(); },
  onFrame: () => {
    if (scene && scene.bounds) { camera.frameBounds(scene.bounds.min, scene.bounds.max); requestTick(); }
  },
});
let tickQueued = false, lastTick = 0;
function requestTick() {
  if (tickQueued) return;
  tickQueued = true;
  requestAnimationFrame(tick);
}
function tick(t) {
  tickQueued = false;
  const dt = lastTick ? (t - lastTick) / 1000 : 0;
  lastTick = t;
  controls.update(dt);
  if (camera.version !== sentVersion && restored && stream.open) {
    if (stream.sendCamera(camera.toMessage())) sentVersion = camera.version;
  }
  if (controls.keysHeld()) requestTick();
  else lastTick = 0;
}

/* ---- render size: the canvas's CSS size x devicePixelRatio, debounced ------------------------- */
let lastSize = '', resizeTimer = 0;
function sendResize(force) {
  const { width, height, dpr } = view.fitBacking();
  if (width < 1 || height < 1) return;
  const key = `${Math.round(width)}x${Math.round(height)}@${dpr}`;
  if (!force && key === lastSize) return;
  if (stream.sendResize(width, height, dpr)) lastSize = key;
}
new ResizeObserver(() => {
  view.fitBacking(); // redraw at once at the new size; the server follows after the debounce
  clearTimeout(resizeTimer);
  resizeTimer = setTimeout(() => sendResize(false), RESIZE_DEBOUNCE_MS);
}).observe(canvas);
function watchDpr() {
  matchMedia(`(resolution: ${window.devicePixelRatio}dppx)`).addEventListener('change', () => {
    sendResize(false);
    watchDpr();
  }, { once: true });
}
watchDpr();

/* ---- panels ------------------------------------------------------------------------------------ */
const statsPanel = new StatsPanel();
const renderPanel = new RenderPanel(api, { toasts });
const lightsPanel = new LightsPanel(api, {
  toasts,
  cameraTarget: () => (camera.known ? camera.target.slice() : null),
  sceneSize: () => camera.sceneSize,
});
const scenePanel = new ScenePanel(api, {
  toasts,
  onSceneChanged: async (s) => {
    setScene(s);
    await adoptServerCamera(true).catch(() => {}); // the server moved the camera to the new scene
    lightsPanel.refresh();
    renderPanel.refresh();
  },
});

/* Which gi_mode and view values the API takes, read from /v1/openapi.yaml once: a server that
 * learns path tracing enables its button without a viewer change. */
let capsLoaded = false;
async function loadCapabilities() {
  if (capsLoaded) return;
  try {
    const res = await fetch('/v1/openapi.yaml', { cache: 'no-store' });
    if (!res.ok) return;
    const yaml = await res.text();
    const enumOf = (field) => {
      const m = yaml.match(new RegExp(`\\n( +)${field}:[ \\t]*\\n(?:\\1 +.*\\n)*?\\1 +enum:[ \\t]*\\[([^\\]]*)\\]`));
      return m ? m[2].split(',').map((x) => x.trim().replace(/^['"]|['"]$/g, '')).filter(Boolean) : undefined;
    };
    renderPanel.setCapabilities({ gi: enumOf('gi_mode'), view: enumOf('view') });
    capsLoaded = true;
  } catch { /* keep the v1 defaults */ }
}

/* Stats: the stream's own numbers four times a second, the server's once a second. A changed
 * scene generation (another viewer uploaded) refreshes the panels and the camera. */
function renderStats() {
  statsPanel.render({ client: stream.metrics(), header: stream.lastHeader, server: serverStats });
}
setInterval(renderStats, 250);
let pollCount = 0;
async function pollStats() {
  try {
    if (!document.hidden) {
      const n = ++pollCount;
      serverStats = await api.get('/v1/stats', { timeoutMs: 3000 });
      const live = stream.open && restored;
      const gen = serverStats.scene && serverStats.scene.generation;
      if (live && scene && gen !== undefined && gen !== scene.generation) {
        setScene(await api.get('/v1/scene'));
        await adoptServerCamera(true);
        lightsPanel.refresh();
      } else if (live && n % 2 === 0 && performance.now() - controls.lastInput > CAMERA_SYNC_IDLE_MS) {
        await adoptServerCamera(false);
      }
      // Other viewers, the API and the demo animation change settings and lights too.
      if (live && n % 5 === 0) renderPanel.refresh();
      if (live && n % 3 === 0 && $('panel-lights').open && !lightsPanel.editing()) lightsPanel.refresh();
    }
  } catch {
    serverStats = null;
  }
  setTimeout(pollStats, STATS_PERIOD_MS);
}

/* ---- drag and drop ----------------------------------------------------------------------------- */
const drop = $('drop');
let dragDepth = 0;
const hasFiles = (e) => e.dataTransfer && [...e.dataTransfer.types].includes('Files');
window.addEventListener('dragenter', (e) => { if (hasFiles(e)) { dragDepth++; drop.hidden = false; e.preventDefault(); } });
window.addEventListener('dragover', (e) => { if (hasFiles(e)) { e.preventDefault(); e.dataTransfer.dropEffect = 'copy'; } });
window.addEventListener('dragleave', () => { if (--dragDepth <= 0) { dragDepth = 0; drop.hidden = true; } });
window.addEventListener('drop', (e) => {
  if (!hasFiles(e)) return;
  e.preventDefault();
  dragDepth = 0;
  drop.hidden = true;
  const f = e.dataTransfer.files[0];
  if (f) scenePanel.upload(f);
});

/* ---- keys, panels, help ----------------------------------------------------------------------- */
function toggleUi() {
  document.body.classList.toggle('ui-hidden');
  $('toggle-ui').title = document.body.classList.contains('ui-hidden') ? 'Show panels (H)' : 'Hide panels (H)';
}
$('toggle-ui').addEventListener('click', toggleUi);
window.addEventListener('keydown', (e) => {
  const t = e.target;
  if (e.ctrlKey || e.metaKey || e.altKey || (t && /^(INPUT|TEXTAREA|SELECT)$/.test(t.tagName))) return;
  if (e.code === 'KeyH') toggleUi();
  else if (e.code === 'KeyP') renderPanel.toggleProbes();
});
let helpTimer = setTimeout(fadeHelp, 12000);
function fadeHelp() {
  clearTimeout(helpTimer);
  $('help').classList.add('faded');
}

// Panels remember whether they are open; on a small screen they start closed.
for (const d of document.querySelectorAll('details.panel')) {
  const key = 'probecast.panel.' + d.id;
  const saved = localStorage.getItem(key);
  if (saved !== null) d.open = saved === '1';
  else if (innerWidth < 720) d.open = false;
  d.addEventListener('toggle', () => localStorage.setItem(key, d.open ? '1' : '0'));
}

window.addEventListener('online', () => stream.retryNow());
document.addEventListener('visibilitychange', () => { if (!document.hidden) stream.retryNow(); });

// For tests and the console: the live objects and a summary of the stream state.
window.probecast = {
  api, stream, camera, controls, view, renderPanel, lightsPanel, scenePanel,
  state: () => ({
    state: stream.state, drawnId: stream.drawnId, frames: stream.counters.drawn, inputSeq: stream.lastHeader ? stream.lastHeader.inputSeq : 0,
    sentSeq: stream.nextSeq - 1, reconnects: stream.counters.reconnects, gen: stream.gen, header: stream.lastHeader,
  }),
};

stream.start();
pollStats();
