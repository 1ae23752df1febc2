// main.js: wires the viewer together: the stream on the canvas, camera controls (one camera
// message per animation frame at most), the render size (quality.js: debounced resize
// messages, a reduced size while the camera moves), the layout of the panels (layout.js), the
// panels (fed by the stream's world events; the animation panel plays, pauses and seeks the
// scene's glTF animations; the node tree and the gizmo over the picture select and move nodes
// and lights), following other views, stats polling, keys, drag-and-drop upload and the view
// restore after a reconnect.
//
// Views (protocol/stream.md, version 2): every connection owns a view of its own; this page's
// camera and size change only that view. The world (scene, lights, settings, views, animation)
// reaches the panels as 'event' messages on the stream, so nothing but /v1/stats (once a second)
// is polled. Against a version-1 server (one shared view 0, no events) the page still works: it
// reads the panels once per connection and after its own changes.

import { Api } from './api.js';
import { CameraControls, OrbitCamera } from './camera.js';
import { AnimationPanel } from './animation.js';
import { Fullscreen, HelpOverlay, Layout } from './layout.js';
import { LightsPanel } from './lights_panel.js';
import { RenderPanel } from './render_panel.js';
import { Toasts } from './toasts.js';
import { TokenPrompt } from './token_prompt.js';
import { ViewsPanel } from './views_panel.js';
import { ScenePanel } from './scene_panel.js';
import { SceneTree } from './scene_tree.js';
import { Gizmo } from './gizmo.js';
import { QualityPanel, RenderSize, ViewCaps } from './quality.js';
import { StatsPanel } from './stats.js';
import { CanvasView, FrameStream, SUBPROTOCOL } from './stream.js';

const STATS_PERIOD_MS = 1000;
const WORLD_WAIT_MS = 3000;       // how long a restore waits for the scene event before asking GET /v1/scene

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
let scene = null;           // the last scene document: { source, generation, bounds, ... }
let serverStats = null;

/* ---- the stream ------------------------------------------------------------------------------ */

/* Where the stream is: /v1/stream of this page's own origin, ws: or wss: as the page came (the
 * daemon answers it on its API address; a proxy in front routes it like any other path). The
 * token goes as a 'bearer.TOKEN' subprotocol next to 'probecast.v2' (protocol/stream.md); a
 * server that names another subprotocol (probecast.v1: before views) is offered that one. */
async function resolveStream() {
  const health = await api.get('/v1/health', { timeoutMs: 4000 });
  if (health.auth === 'bearer' && !(await api.checkToken())) throw new Error('a token is needed');
  const st = health.stream || {};
  if (!st.path) throw new Error('the server has no stream');
  const scheme = location.protocol === 'https:' ? 'wss:' : 'ws:';
  const protocols = [st.subprotocol || SUBPROTOCOL];
  if (api.token) protocols.push('bearer.' + api.token);
  return { url: `${scheme}//${location.host}${st.path}`, protocols };
}

const stream = new FrameStream({ resolve: resolveStream, view });
let streamState = { state: 'connecting' };
const v2 = () => stream.protocol === 2;

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

stream.addEventListener('state', (e) => { streamState = e.detail; showState(); syncFollow(); });
stream.addEventListener('open', (e) => {
  renderPanel.eventsLive = lightsPanel.eventsLive = e.detail.protocol === 2;
  if (e.detail.protocol !== 2) restoreView(stream.gen); // version 2 waits for the welcome (our view's id)
});
stream.addEventListener('welcome', () => { syncFollow(); restoreView(stream.gen); });

/* The camera of our own view: /v1/views/{id}/camera, or /v1/camera (view 0) in version 1. */
const ownCameraPath = () => (v2() && stream.ownView !== null ? `/v1/views/${stream.ownView}/camera` : '/v1/camera');

/* After every (re)connect (version 2: after the welcome; the connection has a new view): report
 * our size, then restore our camera on the new view when the server still shows the same scene
 * (it restarted, or the connection dropped), else take our view's camera from the server.
 * Camera messages wait for this (`restored`), so input given offline is sent afterwards and
 * input given before the first camera was known is dropped. Retried while the connection
 * lasts if the API fails meanwhile. A viewer that followed another view before the outage
 * watches its own new view again (the old ids are gone with the connection). */
let restored = false;

/* ---- share links: the camera in the URL (#cam=px,py,pz,tx,ty,tz,fov) ------------------------ */
function parseLinkCamera(hash) {
  const m = /(?:^#|&)cam=([^&]*)/.exec(hash || '');
  if (!m) return null;
  const v = decodeURIComponent(m[1]).split(',').map(Number);
  if (v.length !== 7 || !v.every(Number.isFinite) || v[6] <= 0 || v[6] >= 180) return null;
  return { position: v.slice(0, 3), target: v.slice(3, 6), fov: v[6] };
}
let linkCamera = parseLinkCamera(location.hash); // taken by the first restore, then dropped
let linkWritten = -1, linkTimer = 0;
function writeLink() {
  if (!camera.known || camera.version === linkWritten) return;
  linkWritten = camera.version;
  const c = camera.toMessage();
  const hash = '#cam=' + [...c.position, ...c.target, c.fov].map((x) => +x.toFixed(4)).join(',');
  if (location.hash !== hash) history.replaceState(null, '', hash);
}
function scheduleLink() { clearTimeout(linkTimer); linkTimer = setTimeout(writeLink, 250); }
stream.addEventListener('state', (e) => {
  if (e.detail.state === 'open') return;
  restored = false;
  viewsPanel.update({ doc: null }); // the views of a closed connection (ours included) are gone
});
const stale = (gen) => stream.gen !== gen || !stream.open;
async function restoreView(gen) {
  try {
    renderSize.connected();
    viewCaps.connected(); // version 2: our view's caps (a new view has none)
    const [s] = await Promise.all([firstScene(gen), loadCapabilities()]);
    if (stale(gen)) return;
    const same = scene && s.source === scene.source && s.generation === scene.generation;
    setScene(s);
    if (linkCamera && camera.setFromServer(linkCamera)) {
      sentVersion = -1; // a share link's camera goes to our view with the next animation frame
      linkWritten = camera.version;
    } else if (camera.known && same) {
      sentVersion = -1; // the next animation frame sends our camera to our (new) view
    } else {
      const c = await api.get(ownCameraPath());
      if (stale(gen)) return;
      camera.setFromServer(c);
      sentVersion = camera.version;
    }
    restored = true;
    linkCamera = null;
    requestTick();
    if (v2()) {
      // Events that arrived meanwhile: a newer scene than the one restored, our view's size.
      if (stream.world.scene && stream.world.scene !== s) onScene(stream.world.scene);
      if (stream.world.views) onViews(stream.world.views);
      if (stream.world.animation) animPanel.applyEvent(stream.world.animation);
    } else {
      renderPanel.refresh();
      lightsPanel.refresh();
      animPanel.refresh();
    }
  } catch (e) {
    console.warn('probecast: restoring the view failed; retrying:', e.message);
    setTimeout(() => { if (!stale(gen)) restoreView(gen); }, 1000);
  }
}

/* The scene of this connection: its first 'scene' event (sent right after the welcome), or
 * GET /v1/scene when none came within WORLD_WAIT_MS (and in version 1). */
function firstScene(gen) {
  if (!v2()) return api.get('/v1/scene');
  if (stream.world.scene) return Promise.resolve(stream.world.scene);
  return new Promise((resolve, reject) => {
    const done = (doc) => { clearTimeout(timer); stream.removeEventListener('world', onWorld); resolve(doc); };
    const onWorld = (e) => { if (e.detail.what === 'scene' && stream.gen === gen) done(e.detail.data); };
    const timer = setTimeout(() => {
      stream.removeEventListener('world', onWorld);
      api.get('/v1/scene').then(resolve, reject);
    }, WORLD_WAIT_MS);
    stream.addEventListener('world', onWorld);
  });
}

function setScene(s) {
  scene = s;
  scenePanel.render(s);
  sceneTree.setScene(s);
  renderPanel.setEnvironmentImage(s && s.environment_image);
  const b = s && s.bounds;
  if (b && b.min && b.max) camera.sceneSize = Math.max(1e-3, Math.hypot(b.max[0] - b.min[0], b.max[1] - b.min[1], b.max[2] - b.min[2]));
}

/* A scene document (an event, or the answer to our own upload): a new source or generation
 * means a new scene, whose camera the server chose. The same document twice does nothing. */
async function onScene(s) {
  if (!s) return;
  const isNew = !scene || s.source !== scene.source || s.generation !== scene.generation;
  if (!restored) return; // restoreView takes it
  setScene(s);
  if (!isNew) return;
  try {
    await takeNewSceneCamera();
  } catch (e) {
    console.warn('probecast: reading the new scene\'s camera failed:', e.message);
  }
}

/* After a scene load: our view's camera from the server. Should the server have left our view
 * where it was (camera unchanged), take the default view's camera (view 0, which the server
 * points at every new scene) and send it to our view. */
async function takeNewSceneCamera() {
  const gen = stream.gen, before = camera.version;
  let c = await api.get(ownCameraPath());
  let ours = true;
  if (v2() && camera.known && !camera.differsFrom(c)) {
    c = await api.get('/v1/camera');
    ours = false;
  }
  if (stream.gen !== gen || camera.version !== before) return; // reconnected, or the user moved meanwhile
  if (!camera.known || camera.differsFrom(c)) {
    camera.setFromServer(c);
    if (ours) sentVersion = camera.version;
    requestTick();
  }
}

/* A 'views' event: the Views panel. The cameras in it are not adopted: views events come when
 * views are created, freed, resized or followed, and one generated before the server took our
 * latest camera message would move us back. (A camera set on our view through
 * PATCH /v1/views/{id}/camera shows in the frames until our next input replaces it.) */
function onViews(doc) {
  viewsPanel.update({ doc });
}

stream.addEventListener('world', (e) => {
  const { what, data } = e.detail;
  if (what === 'scene') onScene(data);
  else if (what === 'lights') { lightsPanel.applyEvent(data); gizmo.request(); }
  else if (what === 'settings') renderPanel.applyEvent(data);
  else if (what === 'views') onViews(data);
  else if (what === 'animation') animPanel.applyEvent(data);
  else if (what === 'node') sceneTree.applyNode(data);
  // lights that hang on a moved node come as a 'lights' event
});

/* ---- following another view -------------------------------------------------------------------- */
/* Follow(id) watches view id, follow(null) returns to our own view. Camera input while
 * following is not sent: the controls are switched off, so drags, the wheel and the fly keys
 * do nothing (the frames are someone else's view; moving our hidden view would surprise on
 * return). Stop (the top bar, the Views panel or Escape) shows our own view again, with the
 * camera it had. The UI shows the requested view at once; the server's 'following' confirms,
 * and an 'error' (an unknown view) or the followed view going away brings us back. */
function follow(id) {
  if (!stream.follow(id)) {
    toasts.show(v2() ? 'Not connected to the stream.' : 'This server shows everyone one view: nothing to follow.', 'error');
    return false;
  }
  syncFollow();
  return true;
}
function syncFollow() {
  const following = v2() && stream.expectView !== null && stream.expectView !== stream.ownView;
  controls.setEnabled(!following);
  viewsPanel.update({ own: v2() ? stream.ownView : null, watching: v2() ? stream.expectView : null, single: stream.protocol === 1 });
  if (!following) requestTick(); // a camera that changed meanwhile (a new scene) goes out now
  gizmo.request();
}
stream.addEventListener('following', (e) => {
  const was = viewsPanel.following;
  syncFollow();
  if (was && e.detail.own && !stream.pendingFollow) toasts.show('Back to your own view.', 'ok');
});
stream.addEventListener('server-error', (e) => {
  syncFollow();
  toasts.show(e.detail.message, 'error');
});

/* ---- camera input: coalesced to one message per animation frame ---------------------------- */
const controls = new CameraControls(canvas, camera, {
  onChange: () => { fadeHelp(); renderSize.input(); requestTick(); },
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
  if (camera.version !== sentVersion && restored && stream.open && controls.enabled) {
    if (stream.sendCamera(camera.toMessage())) sentVersion = camera.version;
  }
  if (camera.version !== linkWritten) scheduleLink();
  gizmo.request();
  if (controls.keysHeld()) requestTick();
  else lastTick = 0;
}

/* ---- render size: the canvas's CSS size x devicePixelRatio x the Quality panel's scale ------ */
const renderSize = new RenderSize({ stream, view, controls, settings: () => renderPanel.serverSettings });
new ResizeObserver(() => {
  view.fitBacking(); // redraw at once at the new size; the server follows after the debounce
  renderSize.resized();
}).observe(canvas);
function watchDpr() {
  matchMedia(`(resolution: ${window.devicePixelRatio}dppx)`).addEventListener('change', () => {
    renderSize.send(false);
    watchDpr();
  }, { once: true });
}
watchDpr();

/* ---- panels ------------------------------------------------------------------------------------ */
const layout = new Layout();
const statsPanel = new StatsPanel({ stream });
const viewCaps = new ViewCaps({ stream });
const qualityPanel = new QualityPanel(renderSize, viewCaps);
stream.addEventListener('open', (e) => qualityPanel.setAvailable(e.detail.protocol === 2));
stream.addEventListener('frame', (e) => { if (e.detail.viewId === stream.ownView) qualityPanel.show(e.detail); });
const renderPanel = new RenderPanel(api, { toasts });
const lightsPanel = new LightsPanel(api, {
  toasts,
  cameraTarget: () => (camera.known ? camera.target.slice() : null),
  cameraPosition: () => (camera.known ? camera.position() : null),
  sceneBounds: () => (scene && scene.bounds && scene.bounds.min ? scene.bounds : null),
  sceneSize: () => camera.sceneSize,
});
const scenePanel = new ScenePanel(api, {
  toasts,
  onSceneChanged: async (s) => {
    await onScene(s); // the event follows with the same document and changes nothing then
    if (!v2()) { lightsPanel.refresh(); renderPanel.refresh(); animPanel.refresh(); }
  },
});
const viewsPanel = new ViewsPanel({ onFollow: follow });
const sceneTree = new SceneTree(api, { toasts });
const gizmo = new Gizmo({ overlay: $('overlay'), stage: $('stage'), view, camera, controls, tree: sceneTree,
  lights: lightsPanel, api, stream, toasts });
stream.addEventListener('frame', () => gizmo.request()); // the picture's place may change (letterbox)
const animPanel = new AnimationPanel(api, { toasts });
syncFollow();

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

/* Stats: the stream's own numbers four times a second, the server's once a second. Only a
 * version-1 server (no events) has the scene generation in the stats checked for an upload by
 * someone else. */
function renderStats() {
  statsPanel.render({ client: stream.metrics(), header: stream.lastHeader, server: serverStats });
}
setInterval(renderStats, 250);
async function pollStats() {
  try {
    if (!document.hidden) {
      serverStats = await api.get('/v1/stats', { timeoutMs: 3000 });
      statsPanel.addServerSample(serverStats);
      const gen = serverStats.scene && serverStats.scene.generation;
      if (stream.open && restored && !v2() && scene && gen !== undefined && gen !== scene.generation) {
        await onScene(await api.get('/v1/scene'));
        lightsPanel.refresh();
        renderPanel.refresh();
        animPanel.refresh();
      }
    }
  } catch {
    serverStats = null;
    statsPanel.addServerSample(null);
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
  const files = [...e.dataTransfer.files];
  if (files.length) scenePanel.upload(files);
});

/* ---- keys, panels, help, fullscreen ------------------------------------------------------------ */
const help = new HelpOverlay();
const fullscreen = new Fullscreen($('stage'), { toasts });
$('help-btn').addEventListener('click', () => help.toggle());
function toggleUi() {
  document.body.classList.toggle('ui-hidden');
  $('toggle-ui').title = document.body.classList.contains('ui-hidden') ? 'Show panels (H)' : 'Hide panels (H)';
}
$('toggle-ui').addEventListener('click', toggleUi);
window.addEventListener('keydown', (e) => {
  const t = e.target;
  if (e.ctrlKey || e.metaKey || e.altKey || (t && /^(INPUT|TEXTAREA|SELECT)$/.test(t.tagName))) return;
  if (e.key === '?') { e.preventDefault(); help.toggle(); return; }
  if (e.code === 'Escape') {
    // the innermost thing first: the help, then an open panel (narrow layouts), then following
    if (help.isOpen) help.close();
    else if (!layout.close() && viewsPanel.following) follow(null);
    return;
  }
  if (help.isOpen) return;
  if (e.code === 'KeyH') toggleUi();
  else if (e.code === 'KeyP') renderPanel.toggleProbes();
  else if (e.code === 'KeyF' && !e.shiftKey) { e.preventDefault(); fullscreen.toggle(); }
  else if (e.code === 'Space' && animPanel.visible && !(t && t.tagName === 'BUTTON')) {
    e.preventDefault();
    animPanel.toggle();
  }
});
let helpTimer = setTimeout(fadeHelp, 12000);
function fadeHelp() {
  clearTimeout(helpTimer);
  $('help').classList.add('faded');
}

$('share').addEventListener('click', async () => {
  writeLink();
  try {
    await navigator.clipboard.writeText(location.href);
    toasts.show('Link to this view copied.', 'ok');
  } catch {
    toasts.show(`Link to this view: ${location.href}`, 'ok', 15000);
  }
});
$('screenshot').addEventListener('click', async () => {
  try {
    const view = v2() && stream.ownView !== null ? `?view=${stream.ownView}` : '';
    const blob = await api.blob('/v1/frame.jpg' + view, { timeoutMs: 30000 });
    const a = document.createElement('a');
    a.href = URL.createObjectURL(blob);
    a.download = `probecast-${new Date().toISOString().replace(/[:.]/g, '-')}.jpg`;
    document.body.append(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(a.href), 10000);
  } catch (e) {
    toasts.error(e);
  }
});

window.addEventListener('online', () => stream.retryNow());
// A viewer that leaves or hides releases its view at once (the server stops rendering it); it
// takes a new one, with its camera, when it shows again.
document.addEventListener('visibilitychange', () => { if (document.hidden) stream.stop(); else stream.start(); });
window.addEventListener('pagehide', () => stream.stop());
window.addEventListener('pageshow', (ev) => { if (ev.persisted && !document.hidden) stream.start(); });

// For tests and the console: the live objects and a summary of the stream state.
window.probecast = {
  api, stream, camera, controls, view, renderPanel, lightsPanel, scenePanel, viewsPanel, animPanel, follow, sceneTree, gizmo,
  layout, renderSize, viewCaps, help, fullscreen, statsPanel,
  state: () => ({
    state: stream.state, drawnId: stream.drawnId, frames: stream.counters.drawn, inputSeq: stream.lastHeader ? stream.lastHeader.inputSeq : 0,
    sentSeq: stream.nextSeq - 1, reconnects: stream.counters.reconnects, gen: stream.gen, header: stream.lastHeader,
    protocol: stream.protocol, ownView: stream.ownView, watching: stream.watching, following: stream.following,
    viewId: stream.lastHeader ? stream.lastHeader.viewId : null, restored,
  }),
};

stream.start();
pollStats();
