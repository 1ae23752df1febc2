// Browser tests of the viewer (web/) in Debian's headless Chromium, driven by playwright-core.
// Started by tests/web/run.sh, which runs the daemon and passes it in PCWEB_* variables:
//   PCWEB_HTTP, PCWEB_WS   bound addresses          PCWEB_PIDFILE  the daemon's pid (rewritten here
//   PCWEB_EXE, PCWEB_ARGS  its command (JSON argv)                  after the restart test)
//   PCWEB_OUT              screenshots and logs     PCWEB_CHROMIUM, PCWEB_ROOT
// The tests run in order on one page (a second and third page join for the views tests); each
// asserts what the user would see. The stream speaks version 2 (protocol/stream.md): every page
// owns a view of its own, and the world reaches it as events, never by polling.

import { after, before, test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { chromium } from 'playwright-core';
import { CHROMIUM_ARGS, httpClient, sleep, startDaemon as launch, stopDaemon, until } from './util.mjs';

const env = process.env;
for (const k of ['PCWEB_HTTP', 'PCWEB_PIDFILE', 'PCWEB_EXE', 'PCWEB_ARGS', 'PCWEB_OUT']) {
  if (!env[k]) throw new Error(`${k} is not set: run this through tests/web/run.sh`);
}
const BASE = `http://${env.PCWEB_HTTP}`;
const OUT = env.PCWEB_OUT;
const VIEWPORT = { width: 960, height: 600 };
// Lavapipe: keep the render tiny. The server scales a viewer's size down to max_pixels; the
// daemon starts at exactly the size the 960x600 page will ask for, so the render size does not
// change while frames are in flight unless a test means it to. (Drags now change it: the viewer
// asks for half the pixels while the camera moves; renderer/view.c's ensure_size() waits for the
// device before it frees the old images, so a readback in flight is safe. The resize test still
// resizes while the server idles.)
const MAX_PIXELS = 15360;
/* The render size the server picks for a viewer of w x h CSS pixels at dpr 1 (render_loop.c). */
function serverSize(w, h, maxPixels) {
  if (w * h > maxPixels) {
    const k = Math.sqrt(maxPixels / (w * h));
    w = Math.floor(w * k);
    h = Math.floor(h * k);
  }
  return { width: Math.min(4096, Math.max(16, w)), height: Math.min(4096, Math.max(16, h)) };
}
const RENDER = serverSize(VIEWPORT.width, VIEWPORT.height, MAX_PIXELS);

let browser, context, page;
const pageErrors = [];
const requests = new Map(); // page -> [{ t, method, path }] of every HTTP request it made
const spawned = []; // daemons started here, stopped in after()
const http = httpClient(BASE);
/* Starts probecast with args; resolves { child, http, ws } after its first stdout line. */
const startDaemon = (args, logName) => launch(env.PCWEB_EXE, OUT, args, logName, (c) => spawned.push(c));

/* ---- helpers -------------------------------------------------------------------------------- */

const state = (p = page) => p.evaluate(() => window.probecast.state());

/* The canvas scaled to 96x60, as [r, g, b, r, g, b, ...]. */
async function pixels(p = page) {
  return p.evaluate(() => {
    const src = document.getElementById('view');
    const c = document.createElement('canvas');
    c.width = 96;
    c.height = 60;
    const ctx = c.getContext('2d', { willReadFrequently: true });
    ctx.drawImage(src, 0, 0, c.width, c.height);
    const d = ctx.getImageData(0, 0, c.width, c.height).data;
    const rgb = [];
    for (let i = 0; i < d.length; i += 4) rgb.push(d[i], d[i + 1], d[i + 2]);
    return rgb;
  });
}

function summary(rgb) {
  const n = rgb.length / 3;
  const mean = [0, 0, 0];
  for (let i = 0; i < rgb.length; i++) mean[i % 3] += rgb[i] / n;
  let v = 0;
  for (let i = 0; i < rgb.length; i++) v += (rgb[i] - mean[i % 3]) ** 2;
  return { mean, std: Math.sqrt(v / rgb.length) };
}

function meanAbsDiff(a, b) {
  let s = 0;
  for (let i = 0; i < a.length; i++) s += Math.abs(a[i] - b[i]);
  return s / a.length;
}

async function shot(name, p = page) {
  await p.screenshot({ path: path.join(OUT, name) });
}

/* Drags on the canvas from its centre by (dx, dy) in steps. */
async function drag(dx, dy, p = page) {
  const vp = p.viewportSize() || VIEWPORT;
  const cx = vp.width / 2, cy = vp.height / 2;
  await p.mouse.move(cx, cy);
  await p.mouse.down();
  await p.mouse.move(cx + dx, cy + dy, { steps: 12 });
  await p.mouse.up();
}

/* Shows panel `id` (e.g. 'panel-lights'). The 960 x 600 page has the compact layout: its toolbar
 * opens one panel at a time over the picture (layout.js); on the desktop layout the panel's title
 * opens it in the column. */
async function showPanel(id, p = page) {
  const shown = () => p.evaluate((pid) => {
    const d = document.getElementById(pid);
    return d.open && d.getBoundingClientRect().height > 0;
  }, id);
  if (await shown()) return;
  if (await p.evaluate(() => document.body.classList.contains('layout-desktop'))) await p.locator(`#${id} > summary`).click();
  else await p.locator(`#toolbar [data-panel="${id}"]`).click();
  await until(shown, `panel ${id} to show`, 5000, 50);
}

/* The share of the picture (the canvas) that something else covers: hit tests on an 8 px grid
 * (elements that let the pointer through, such as the fading hint line, do not count). */
function coverage(p) {
  return p.evaluate(() => {
    const r = document.getElementById('view').getBoundingClientRect();
    let n = 0, covered = 0;
    for (let y = r.top + 4; y < r.bottom; y += 8) {
      for (let x = r.left + 4; x < r.right; x += 8) {
        n++;
        const e = document.elementFromPoint(x, y);
        if (!e || e.id !== 'view') covered++;
      }
    }
    return covered / n;
  });
}

/* Waits until the page has drawn a frame newer than frameId (of the current connection). */
async function waitDrawnAfter(frameId, timeoutMs = 20000) {
  await page.waitForFunction((id) => window.probecast.state().drawnId > id, frameId, { timeout: timeoutMs });
  return state();
}

/* Waits for a frame newer than frameId, then until the server idles (input stopped, probes
 * converged: its last still frame is out), then for that frame to be drawn. */
async function settleAfter(frameId, timeoutMs = 30000) {
  await waitDrawnAfter(frameId, timeoutMs);
  await until(async () => (await http('GET', '/v1/stats')).json.rendering === false, 'the server to idle', timeoutMs, 200);
  await sleep(400);
  return state();
}

function alive(pid) {
  try {
    const stat = fs.readFileSync(`/proc/${pid}/stat`, 'utf8');
    return !/^\d+ \(.*\) Z /.test(stat);
  } catch {
    return false;
  }
}

async function newViewerPage(ctx) {
  const p = await ctx.newPage();
  p.on('pageerror', (e) => pageErrors.push(e.message));
  const reqs = [];
  requests.set(p, reqs);
  p.on('request', (r) => {
    const u = new URL(r.url());
    reqs.push({ t: Date.now(), method: r.method(), path: u.pathname });
  });
  return p;
}

/* Record every text message a page sends and receives on a WebSocket, and count animation
 * frames, to check coalescing, the restore after a reconnect and the server's messages. */
async function recordSockets(ctx) {
  await ctx.addInitScript(() => {
    window.__sent = [];
    window.__recv = [];
    window.__raf = 0;
    const tick = () => { window.__raf++; requestAnimationFrame(tick); };
    requestAnimationFrame(tick);
    const send = WebSocket.prototype.send;
    WebSocket.prototype.send = function (data) {
      if (typeof data === 'string') {
        try { window.__sent.push({ t: performance.now(), raf: window.__raf, m: JSON.parse(data) }); } catch { /* ignore */ }
      }
      return send.call(this, data);
    };
    const WS = WebSocket;
    window.WebSocket = class extends WS {
      constructor(...args) {
        super(...args);
        this.addEventListener('message', (e) => {
          if (typeof e.data !== 'string') return;
          try { window.__recv.push({ t: performance.now(), m: JSON.parse(e.data) }); } catch { /* ignore */ }
        });
      }
    };
  });
}

/* The camera of a view through the HTTP API. */
const viewCamera = async (id) => {
  const r = await http('GET', `/v1/views/${id}/camera`);
  assert.equal(r.status, 200, r.text);
  return r.json;
};
const dist3 = (a, b) => Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);

/* Waits until page p draws a frame of view `viewId` at `size` ({ width, height }). */
async function waitViewFrame(p, viewId, size, timeoutMs = 20000) {
  await p.waitForFunction(([id, w]) => {
    const h = window.probecast.state().header;
    return h && h.viewId === id && (!w || (h.width === w.width && h.height === w.height));
  }, [viewId, size || null], { timeout: timeoutMs });
  return state(p);
}

/* ---- set-up ------------------------------------------------------------------------------- */

before(async () => {
  const r = await http('PATCH', '/v1/settings', { max_pixels: MAX_PIXELS });
  assert.equal(r.status, 200, r.text);
  assert.deepEqual({ width: r.json.width, height: r.json.height }, RENDER,
    'run.sh starts the daemon at the size the page will ask for');
  browser = await chromium.launch({ executablePath: env.PCWEB_CHROMIUM || '/usr/bin/chromium', args: CHROMIUM_ARGS });
  context = await browser.newContext({ viewport: VIEWPORT, deviceScaleFactor: 1 });
  await recordSockets(context);
  page = await newViewerPage(context);
});

after(async () => {
  if (browser) await browser.close().catch(() => {});
  for (const c of spawned) await stopDaemon(c);
});

/* ---- tests -------------------------------------------------------------------------------- */

test('the viewer page loads from the daemon', { timeout: 30000 }, async () => {
  const res = await fetch(BASE + '/');
  assert.equal(res.status, 200);
  assert.match(res.headers.get('content-type'), /^text\/html/);
  for (const f of ['/viewer.css', '/js/main.js', '/js/stream.js', '/js/camera.js', '/js/api.js', '/js/panels.js', '/js/scene_panel.js', '/js/animation.js',
    '/js/dom.js', '/js/stats.js', '/js/graphs.js', '/js/layout.js', '/js/quality.js']) {
    const r = await fetch(BASE + f);
    assert.equal(r.status, 200, f);
    assert.match(r.headers.get('content-type'), f.endsWith('.css') ? /^text\/css/ : /^text\/javascript/, f);
  }
  await page.goto(BASE + '/');
  assert.equal(await page.title(), 'probecast');
  await page.waitForFunction(() => window.probecast && document.getElementById('panel-stats'), null, { timeout: 10000 });
  assert.deepEqual(pageErrors, []);
});

test('frames arrive, are drawn and acknowledged', { timeout: 40000 }, async () => {
  await page.waitForFunction(() => window.probecast.state().frames >= 1, null, { timeout: 30000 });
  const s = await state();
  assert.equal(s.state, 'open');
  assert.deepEqual({ width: s.header.width, height: s.header.height }, RENDER, 'the render size follows the page');
  // The viewer reported its size: the render has the canvas's aspect (960x600 -> 16:10).
  await until(async () => {
    const h = (await state()).header;
    return Math.abs(h.width / h.height - VIEWPORT.width / VIEWPORT.height) < 0.05;
  }, 'a frame with the canvas aspect');
  const pix = summary(await pixels());
  assert.ok(pix.std > 12, `the canvas shows a picture, not a flat colour (std ${pix.std.toFixed(1)})`);
  const acks = await page.evaluate(() => window.__sent.filter((x) => x.m.type === 'ack').map((x) => x.m.frame));
  assert.ok(acks.length >= 1, 'frames are acknowledged');
  for (let i = 1; i < acks.length; i++) assert.ok(acks[i] > acks[i - 1], 'acks (drawn frames) only move forward');
  const resize = await page.evaluate(() => window.__sent.find((x) => x.m.type === 'resize'));
  assert.deepEqual(resize.m, { type: 'resize', width: VIEWPORT.width, height: VIEWPORT.height, dpr: 1 });
  // Version 2: the page has a view of its own (not the default view 0) and is shown it.
  const v = await state();
  assert.equal(v.protocol, 2, 'the stream speaks probecast.v2');
  assert.equal(await page.evaluate(() => window.probecast.stream.ws.protocol), 'probecast.v2');
  assert.ok(Number.isInteger(v.ownView) && v.ownView !== 0, `an own view (${v.ownView})`);
  assert.equal(v.header.version, 2);
  assert.equal(v.header.viewId, v.ownView, 'frames of the own view');
  assert.equal(v.following, false);
  // The server's first message is the welcome, then one event of each kind.
  const recv = await page.evaluate(() => window.__recv.map((x) => x.m));
  assert.equal(recv[0].type, 'welcome');
  assert.equal(recv[0].protocol, 2);
  assert.equal(recv[0].view, v.ownView);
  const kinds = new Set(recv.filter((m) => m.type === 'event').map((m) => m.what));
  for (const k of ['scene', 'lights', 'settings', 'views']) assert.ok(kinds.has(k), `a '${k}' event after the welcome`);
  assert.equal((await http('GET', '/v1/health')).json.stream.subprotocol, 'probecast.v2');
  await shot('loaded.png');
});

test('the stats panel shows the probe field converging, then converged', { timeout: 60000 }, async () => {
  const probes = page.locator('#st-probes');
  await page.waitForFunction(() => /\bconverged\b/.test(document.querySelector('#st-probes').textContent), null, { timeout: 50000 });
  const title = await probes.getAttribute('title');
  assert.match(title, /^awake 0, sleeping \d+, off \d+$/, `probe states in the tooltip: ${title}`);
});

test('dragging orbits the camera; frames reflect the input', { timeout: 40000 }, async () => {
  const own = (await state()).ownView;
  const camBefore = await viewCamera(own);
  const cam0Before = (await http('GET', '/v1/camera')).json;
  const s0 = await state();
  const pix0 = await pixels();
  const sentBefore = await page.evaluate(() => window.__sent.length);
  await drag(140, 40);
  const sent = await page.evaluate((n) => window.__sent.slice(n).filter((x) => x.m.type === 'camera'), sentBefore);
  assert.ok(sent.length >= 1, 'camera messages were sent');
  // Coalesced: at most one camera message per animation frame, sequence numbers increasing.
  const perFrame = new Map();
  for (const x of sent) perFrame.set(x.raf, (perFrame.get(x.raf) || 0) + 1);
  assert.ok(Math.max(...perFrame.values()) === 1, 'one camera message per animation frame at most');
  for (let i = 1; i < sent.length; i++) assert.ok(sent[i].m.seq > sent[i - 1].m.seq, 'seq increases');
  assert.deepEqual(Object.keys(sent[0].m).sort(), ['fov', 'position', 'seq', 'target', 'type', 'up']);
  const lastSeq = sent[sent.length - 1].m.seq;
  // A frame that reflects the last input arrives and is drawn.
  await page.waitForFunction((seq) => window.probecast.state().inputSeq >= seq, lastSeq, { timeout: 30000 });
  const s1 = await state();
  assert.ok(s1.drawnId > s0.drawnId);
  const diff = meanAbsDiff(pix0, await pixels());
  assert.ok(diff > 4, `the picture changed after the drag (mean difference ${diff.toFixed(1)})`);
  const camAfter = await viewCamera(own);
  const moved = dist3(camAfter.position, camBefore.position);
  assert.ok(moved > 0.1, `the camera of the page's view moved (${moved.toFixed(3)})`);
  const cam0After = (await http('GET', '/v1/camera')).json;
  assert.ok(dist3(cam0After.position, cam0Before.position) < 1e-6, 'the default view 0 (GET /v1/camera) stays');
  // The latency readout has a number now.
  await page.waitForFunction(() => /\d+ ms/.test(document.getElementById('st-latency').textContent), null, { timeout: 5000 });
  await shot('orbited.png');
});

test('the URL carries the camera: a shared link opens the same view; the screenshot button downloads a still', { timeout: 60000 }, async () => {
  const a = await state();
  await page.waitForFunction(() => /#cam=/.test(location.hash), null, { timeout: 10000 });
  const link = page.url();
  const v = decodeURIComponent(/cam=([^&]*)/.exec(new URL(link).hash)[1]).split(',').map(Number);
  assert.equal(v.length, 7);
  // the page's own view really has that camera
  const own = (await http('GET', `/v1/views/${a.ownView}/camera`)).json;
  for (let k = 0; k < 3; k++) {
    assert.ok(Math.abs(own.position[k] - v[k]) < 1e-3, `position ${own.position} vs link ${v}`);
    assert.ok(Math.abs(own.target[k] - v[3 + k]) < 1e-3, `target ${own.target} vs link ${v}`);
  }
  // a link with another camera opens a page whose own view takes it
  const want = [v[0] + 0.5, v[1] + 0.25, v[2], v[3], v[4], v[5], 50];
  const pc = await newViewerPage(context);
  await pc.goto(`${BASE}/#cam=${want.join(',')}`);
  await pc.waitForFunction(() => window.probecast.state().ownView !== null, null, { timeout: 30000 });
  const c = await state(pc);
  await until(async () => {
    const cam = (await http('GET', `/v1/views/${c.ownView}/camera`)).json;
    return [0, 1, 2].every((k) => Math.abs(cam.position[k] - want[k]) < 1e-3 && Math.abs(cam.target[k] - want[3 + k]) < 1e-3) &&
      Math.abs(cam.fov - 50) < 0.01;
  }, 'the linked camera on the new page\'s view', 10000);
  // the screenshot: a JPEG of the page's own view at its size
  await waitViewFrame(pc, c.ownView, null, 30000).catch(() => {});
  const [dl] = await Promise.all([pc.waitForEvent('download', { timeout: 30000 }), pc.click('#screenshot')]);
  const bytes = fs.readFileSync(await dl.path());
  assert.ok(bytes.length > 500 && bytes[0] === 0xff && bytes[1] === 0xd8, 'the download is a JPEG');
  assert.match(dl.suggestedFilename(), /^probecast-.*\.jpg$/);
  await pc.close();
});

test('wheel zooms, right-drag pans, W flies, a two-finger pinch zooms', { timeout: 30000 }, async () => {
  const cam = () => page.evaluate(() => {
    const c = window.probecast.camera;
    return { d: c.distance, target: c.target.slice(), version: c.version };
  });
  const lastSent = () => page.evaluate(() => window.__sent.filter((x) => x.m.type === 'camera').pop().m);
  const cx = VIEWPORT.width / 2, cy = VIEWPORT.height / 2;
  await page.mouse.move(cx, cy);
  let c0 = await cam();
  await page.mouse.wheel(0, -400);
  await page.waitForFunction((v) => window.probecast.camera.version > v, c0.version);
  let c1 = await cam();
  assert.ok(c1.d < c0.d * 0.8, `wheel up zooms in (${c0.d.toFixed(2)} -> ${c1.d.toFixed(2)})`);
  await page.mouse.wheel(0, 400);
  await page.mouse.down({ button: 'right' });
  await page.mouse.move(cx + 80, cy, { steps: 5 });
  await page.mouse.up({ button: 'right' });
  c0 = c1;
  c1 = await cam();
  assert.ok(Math.abs(c1.d - c0.d / Math.exp(-400 * 0.0015)) < 0.05 * c1.d, 'wheel down zooms back out');
  assert.ok(Math.hypot(...c1.target.map((v, i) => v - c0.target[i])) > 0.05, 'right-drag moves the target');
  // W flies forward: eye and target move together, so the orbit distance stays.
  await page.locator('#view').focus();
  await page.keyboard.down('KeyW');
  await sleep(300);
  await page.keyboard.up('KeyW');
  const c2 = await cam();
  assert.ok(Math.hypot(...c2.target.map((v, i) => v - c1.target[i])) > 0.05, 'W moves the camera');
  assert.ok(Math.abs(c2.d - c1.d) < 1e-6, 'flying keeps the orbit distance');
  // Two fingers moving apart zoom in (touch pointer events through the DevTools protocol).
  const cdp = await context.newCDPSession(page);
  const touch = (type, spread) => cdp.send('Input.dispatchTouchEvent', {
    type, touchPoints: type === 'touchEnd' ? [] : [{ x: cx - spread, y: cy, id: 1 }, { x: cx + spread, y: cy, id: 2 }],
  });
  await touch('touchStart', 40);
  for (const s of [60, 80, 100, 120]) { await touch('touchMove', s); await sleep(20); }
  await touch('touchEnd', 0);
  await cdp.detach();
  const c3 = await cam();
  assert.ok(c3.d < c2.d * 0.5, `pinching out zooms in (${c2.d.toFixed(2)} -> ${c3.d.toFixed(2)})`);
  // Every change went out as a camera message; the last one is the camera now.
  await sleep(100);
  const m = await lastSent();
  const pos = await page.evaluate(() => window.probecast.camera.toMessage().position);
  assert.deepEqual(m.position, pos);
  await page.keyboard.press('Home'); // frame the scene again for the tests that follow (F is full screen)
});

test('a light edit in the panel changes the picture', { timeout: 90000 }, async (t) => {
  await showPanel('panel-lights');
  const card = page.locator('#lights details.light').first();
  await card.waitFor({ timeout: 10000 });
  const id = Number(await card.getAttribute('data-id'));
  // Let the frames of the drag settle first, then compare against the last one.
  await settleAfter(0);
  const before = summary(await pixels());
  const patched = page.waitForResponse((r) => r.url().endsWith(`/v1/lights/${id}`) && r.request().method() === 'PATCH');
  await card.locator('input[type=color]').fill('#ff2000');
  const res = await patched;
  assert.equal(res.status(), 200);
  await settleAfter((await state()).drawnId);
  await shot('light-red.png');
  const light = (await http('GET', `/v1/lights/${id}`)).json;
  assert.ok(light.color[0] > 0.9 && light.color[1] < 0.05 && light.color[2] < 0.01, `colour set: ${light.color}`);
  const afterColour = summary(await pixels());
  const ratio = (m) => m[1] / Math.max(1, m[0]);
  assert.ok(ratio(afterColour.mean) < ratio(before.mean) * 0.8,
    `green/red fell under a red light: ${ratio(before.mean).toFixed(2)} -> ${ratio(afterColour.mean).toFixed(2)}`);
  // Intensity through the number field: a much dimmer light darkens the picture.
  const dimmed = page.waitForResponse((r) => r.url().endsWith(`/v1/lights/${id}`) && r.request().method() === 'PATCH');
  await card.locator('input[aria-label="intensity value"]').fill('0.05');
  await dimmed;
  await settleAfter((await state()).drawnId);
  await shot('light-dim.png');
  const dim = summary(await pixels());
  assert.equal((await http('GET', `/v1/lights/${id}`)).json.intensity, 0.05);
  assert.ok(dim.mean[0] < afterColour.mean[0] * 0.75, `dimmer: red ${afterColour.mean[0].toFixed(1)} -> ${dim.mean[0].toFixed(1)}`);
  t.diagnostic(`mean rgb: white ${before.mean.map(Math.round)}, red ${afterColour.mean.map(Math.round)}, dim ${dim.mean.map(Math.round)}`);
  // Put it back (white, as bright as before) for the tests that follow.
  await http('PATCH', `/v1/lights/${id}`, { color: [1, 1, 1], intensity: 3 });
});

test('lights are added and deleted through the panel', { timeout: 30000 }, async () => {
  const count = async () => (await http('GET', '/v1/lights')).json.lights.length;
  const n0 = await count();
  await showPanel('panel-lights');
  await page.locator('#light-type').selectOption('spot');
  await page.locator('#light-add').click();
  await page.waitForFunction((n) => document.querySelectorAll('#lights details.light').length === n + 1, n0, { timeout: 10000 });
  const lights = (await http('GET', '/v1/lights')).json.lights;
  assert.equal(lights.length, n0 + 1);
  const added = lights[lights.length - 1];
  assert.equal(added.type, 'spot');
  const card = page.locator(`#lights details.light[data-id="${added.id}"]`);
  assert.equal(await card.locator('input[aria-label="direction y"]').isVisible(), true, 'a spot light shows its direction');
  // placed outside the model, on the camera's side, above it, and aimed at its centre
  const b = (await http('GET', '/v1/scene')).json.bounds;
  const cam = (await http('GET', '/v1/camera')).json;
  const c = [0, 1, 2].map((i) => 0.5 * (b.min[i] + b.max[i]));
  const p = added.position;
  const inside = [0, 1, 2].every((i) => p[i] >= b.min[i] && p[i] <= b.max[i]);
  assert.equal(inside, false, `the new light at ${p} is outside the bounds ${b.min} .. ${b.max}`);
  const toCam = [0, 1, 2].map((i) => cam.position[i] - c[i]);
  const toLight = [0, 1, 2].map((i) => p[i] - c[i]);
  assert.ok(toCam[0] * toLight[0] + toCam[1] * toLight[1] + toCam[2] * toLight[2] > 0, 'on the camera side');
  assert.ok(p[1] > c[1], 'above the centre');
  const d = added.direction;
  assert.ok(d[0] * toLight[0] + d[1] * toLight[1] + d[2] * toLight[2] < 0, 'the spot aims at the model');
  assert.ok(Number(await card.locator('input[aria-label="direction y"]').inputValue()) < 0);
  await card.locator('button[aria-label="delete light"]').click();
  await page.waitForFunction((n) => document.querySelectorAll('#lights details.light').length === n, n0, { timeout: 10000 });
  assert.equal(await count(), n0);
});

test('the rendering panel switches GI mode and the probe view', { timeout: 30000 }, async () => {
  await showPanel('panel-render');
  const pt = page.locator('#gi-modes button[data-value=pathtrace]');
  assert.equal(await pt.isDisabled(), false, 'the API offers gi_mode pathtrace');
  await pt.click();
  await until(async () => (await http('GET', '/v1/settings')).json.gi_mode === 'pathtrace', 'gi_mode pathtrace');
  // the panel marks the mode once the server's answer arrives (it may trail the settings)
  await until(async () => (await pt.getAttribute('aria-checked')) === 'true', 'path trace checked');
  await waitDrawnAfter((await state()).drawnId + 1);
  await shot('pathtrace.png');
  // The stats panel counts the samples of our view up to the server's target (64 on lavapipe).
  const target = (await until(async () => (await http('GET', '/v1/stats')).json.pathtrace, 'a path-trace sample count')).target;
  assert.ok(target >= 1, `target ${target}`);
  await page.waitForFunction((t) => new RegExp(`path trace · \\d+ / ${t} samples`).test(document.getElementById('st-probes').textContent),
    target, { timeout: 10000 });
  await page.waitForFunction((t) => document.getElementById('st-probes').textContent.includes(`· ${t} / ${t} samples`),
    target, { timeout: 60000 });
  assert.match(await page.locator('#st-converge').textContent(), new RegExp(`path trace: ${target} / ${target} samples`));
  const ownView = (await state()).ownView;
  const own = (await http('GET', '/v1/stats')).json.pathtrace.views.find((v) => v.view === ownView);
  assert.deepEqual(own, { view: ownView, samples: target }, 'GET /v1/stats lists our view\'s samples');
  await page.locator('#gi-modes button[data-value=classic]').click();
  await until(async () => (await http('GET', '/v1/settings')).json.gi_mode === 'classic', 'gi_mode classic');
  await until(async () => (await page.locator('#gi-modes button[data-value=classic]').getAttribute('aria-checked')) === 'true', 'classic checked');
  const idAt = (await state()).drawnId;
  await page.locator('#view-modes button[data-value=probes]').click();
  await until(async () => (await http('GET', '/v1/settings')).json.view === 'probes', 'view probes');
  await waitDrawnAfter(idAt + 1);
  await sleep(300);
  await shot('probes.png');
  // P toggles the probe view back.
  await page.locator('#view').focus();
  await page.keyboard.press('p');
  await until(async () => (await http('GET', '/v1/settings')).json.view === 'final', 'view final');
  await page.locator('#gi-modes button[data-value=ddgi]').click();
  await until(async () => (await http('GET', '/v1/settings')).json.gi_mode === 'ddgi', 'gi_mode ddgi');
});

/* A w x h OpenEXR file, one part, scanlines, no compression, HALF channels B, G, R (the order
 * the format stores them: by name) from rgb(x, y) -> [r, g, b] as IEEE half bits. */
function tinyExr(w, h, rgb) {
  const parts = [];
  const u8 = (...b) => parts.push(Buffer.from(b));
  const i32 = (...v) => { const b = Buffer.alloc(4 * v.length); v.forEach((x, i) => b.writeInt32LE(x, 4 * i)); parts.push(b); };
  const f32 = (...v) => { const b = Buffer.alloc(4 * v.length); v.forEach((x, i) => b.writeFloatLE(x, 4 * i)); parts.push(b); };
  const attr = (name, type, size) => { parts.push(Buffer.from(`${name}\0${type}\0`)); i32(size); };
  u8(0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0); // magic, version 2, single-part scanline
  attr('channels', 'chlist', 3 * 18 + 1);
  for (const c of ['B', 'G', 'R']) { parts.push(Buffer.from(`${c}\0`)); i32(1); u8(0, 0, 0, 0); i32(1, 1); }
  u8(0);
  attr('compression', 'compression', 1); u8(0);
  attr('dataWindow', 'box2i', 16); i32(0, 0, w - 1, h - 1);
  attr('displayWindow', 'box2i', 16); i32(0, 0, w - 1, h - 1);
  attr('lineOrder', 'lineOrder', 1); u8(0);
  attr('pixelAspectRatio', 'float', 4); f32(1);
  attr('screenWindowCenter', 'v2f', 8); f32(0, 0);
  attr('screenWindowWidth', 'float', 4); f32(1);
  u8(0);
  const header = Buffer.concat(parts.splice(0));
  const line = 8 + 3 * w * 2; // y, size, then the planes
  const table = Buffer.alloc(8 * h);
  for (let y = 0; y < h; y++) table.writeBigUInt64LE(BigInt(header.length + table.length + y * line), 8 * y);
  const body = Buffer.alloc(line * h);
  for (let y = 0; y < h; y++) {
    body.writeInt32LE(y, y * line);
    body.writeInt32LE(3 * w * 2, y * line + 4);
    for (let x = 0; x < w; x++) {
      const [r, g, b] = rgb(x, y);
      [b, g, r].forEach((v, c) => body.writeUInt16LE(v, y * line + 8 + (c * w + x) * 2));
    }
  }
  return Buffer.concat([header, table, body]);
}

test('the environment controls set a gradient and upload HDR and EXR images', { timeout: 60000 }, async () => {
  await showPanel('panel-render');
  await page.locator('#sky-modes button[data-value=gradient]').click();
  await until(async () => (await http('GET', '/v1/settings')).json.sky_mode === 'gradient', 'sky_mode gradient');
  await until(async () => page.locator('#ground-row').isVisible(), 'the ground colour shows in gradient mode');
  await page.locator('#ground-color').fill('#ff0000');
  await page.locator('#ground-strength').fill('0.5');
  await page.locator('#ground-strength').dispatchEvent('change');
  await until(async () => {
    const g = (await http('GET', '/v1/settings')).json.sky_ground;
    return g[0] === 0.5 && g[1] === 0 && g[2] === 0;
  }, 'sky_ground red 0.5');
  // a 2 x 1 Radiance file through the file input: the mode becomes image, the scene names it
  const hdr = Buffer.concat([Buffer.from('#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n'),
    Buffer.from([0x80, 0x40, 0x20, 0x81, 0x40, 0x40, 0x40, 0x81])]);
  await page.locator('#hdr-file').setInputFiles({ name: 'tiny.hdr', mimeType: 'image/vnd.radiance', buffer: hdr });
  await until(async () => (await http('GET', '/v1/settings')).json.sky_mode === 'image', 'sky_mode image');
  const img = (await http('GET', '/v1/scene')).json.environment_image;
  assert.deepEqual(img, { width: 2, height: 1 });
  await until(async () => /tiny\.hdr/.test(await page.locator('#hdr-out').textContent()), 'the file name shown');
  // an OpenEXR file through the same input (it offers .exr): the answer's size shows
  assert.match(await page.locator('#hdr-file').getAttribute('accept'), /\.exr/);
  const exr = tinyExr(4, 2, (x, y) => [0x3c00, x === 0 ? 0x3800 : 0, y ? 0x3400 : 0]);
  await page.locator('#hdr-file').setInputFiles({ name: 'tiny.exr', mimeType: 'image/x-exr', buffer: exr });
  await until(async () => /tiny\.exr \(4×2\)/.test(await page.locator('#hdr-out').textContent()), 'the .exr name and size shown');
  assert.deepEqual((await http('GET', '/v1/scene')).json.environment_image, { width: 4, height: 2 });
  // the panel follows the settings event (or the answer), which may come a moment later
  await until(async () => page.locator('#hdr-rotation-row').isVisible(), 'rotation shows in image mode');
  // back to what the other tests expect: no image, a uniform black sky, no ground
  assert.equal((await http('DELETE', '/v1/environment')).status, 204);
  await http('PATCH', '/v1/settings', { sky_mode: 'uniform', sky_ground: [0, 0, 0] });
  await until(async () => (await page.locator('#sky-modes button[data-value=uniform]').getAttribute('aria-checked')) === 'true', 'uniform checked');
});

/* ---- layout, interactive resolution, quality menu, live stats (issue 13 items 1-3) ---------- */

test('phone: a bottom sheet below the picture, 44 px touch targets, a touch drag orbits', { timeout: 90000 }, async () => {
  const ctx = await browser.newContext({ viewport: { width: 390, height: 844 }, deviceScaleFactor: 2, isMobile: true, hasTouch: true });
  await recordSockets(ctx);
  const p = await newViewerPage(ctx);
  try {
    await p.goto(BASE + '/');
    await p.waitForFunction(() => window.probecast.state().frames >= 1 && window.probecast.state().restored, null, { timeout: 30000 });
    assert.deepEqual(await p.evaluate(() => ['layout-phone', 'touch'].map((c) => document.body.classList.contains(c))), [true, true]);
    // Closed at first: only the tab bar at the bottom; the picture has the rest.
    assert.equal(await p.evaluate(() => document.body.dataset.sheet), 'closed');
    assert.equal(await p.locator('#dock').isVisible(), false);
    assert.ok(await coverage(p) < 0.25, 'the closed sheet leaves the picture free');
    // A tab opens its panel in the sheet; the upper part of the picture stays visible.
    await p.locator('#toolbar [data-panel="panel-render"]').tap();
    await p.locator('#gi-modes button[data-value=ddgi]').waitFor({ timeout: 5000 });
    assert.equal(await p.evaluate(() => document.body.dataset.sheet), 'open');
    const sheet = await p.locator('#ui').boundingBox();
    assert.ok(sheet.y >= 844 * 0.4, `the open sheet starts at y ${sheet.y.toFixed(0)} (at most 60 % of the height)`);
    const above = await p.evaluate((top) => {
      let n = 0, seen = 0;
      for (let y = 80; y < top; y += 8) for (let x = 4; x < innerWidth; x += 8) { n++; if (document.elementFromPoint(x, y).id === 'view') seen++; }
      return seen / n;
    }, sheet.y);
    assert.ok(above > 0.95, `the picture above the sheet is visible (${(above * 100).toFixed(0)} %)`);
    await shot('phone-sheet.png', p);
    // Every visible control of every panel (and of the top bar) is at least 44 x 44 px.
    const ids = await p.evaluate(() => [...document.querySelectorAll('#toolbar [data-panel]')].filter((b) => !b.hidden).map((b) => b.dataset.panel));
    assert.ok(ids.length >= 6, `panel tabs: ${ids}`);
    const small = [];
    for (const id of ids) {
      if (!(await p.evaluate((pid) => window.probecast.layout.active === pid, id))) await p.locator(`#toolbar [data-panel="${id}"]`).tap();
      await p.waitForFunction((pid) => document.getElementById(pid).getBoundingClientRect().height > 0, id, { timeout: 5000 });
      small.push(...await p.evaluate((pid) => [...document.querySelectorAll('#topbar button, #topbar input, #ui button, #ui input, #ui select, #ui summary')]
        .filter((el) => el.getClientRects().length > 0 && getComputedStyle(el).visibility !== 'hidden')
        .map((el) => ({ panel: pid, el: el.id || el.getAttribute('aria-label') || el.dataset.value || el.textContent.trim().slice(0, 20), r: el.getBoundingClientRect() }))
        .filter((x) => x.r.width < 43.5 || x.r.height < 43.5)
        .map((x) => `${x.panel}: ${x.el} ${x.r.width.toFixed(0)}x${x.r.height.toFixed(0)}`), id));
    }
    assert.deepEqual(small, [], 'controls under 44 px');
    // The handle: a tap closes the sheet, a tap opens it again, a drag down closes it.
    await p.locator('#sheet-handle').tap();
    await p.waitForFunction(() => document.body.dataset.sheet === 'closed', null, { timeout: 3000 });
    assert.equal(await p.locator('#dock').isVisible(), false);
    await p.locator('#sheet-handle').tap();
    await p.waitForFunction(() => document.body.dataset.sheet === 'open', null, { timeout: 3000 });
    const hb = await p.locator('#sheet-handle').boundingBox();
    await p.mouse.move(hb.x + hb.width / 2, hb.y + hb.height / 2);
    await p.mouse.down();
    await p.mouse.move(hb.x + hb.width / 2, hb.y + hb.height / 2 + 120, { steps: 6 });
    await p.mouse.up();
    await p.waitForFunction(() => document.body.dataset.sheet === 'closed', null, { timeout: 3000 });
    // One finger dragged over the picture orbits: camera messages go out.
    const n = await p.evaluate(() => window.__sent.length);
    const v0 = await p.evaluate(() => window.probecast.camera.version);
    const cdp = await ctx.newCDPSession(p);
    const touch = (type, x) => cdp.send('Input.dispatchTouchEvent', { type, touchPoints: type === 'touchEnd' ? [] : [{ x, y: 300, id: 1 }] });
    await touch('touchStart', 120);
    for (const x of [140, 160, 180, 200, 220, 240]) { await touch('touchMove', x); await sleep(20); }
    await touch('touchEnd', 0);
    await cdp.detach();
    await p.waitForFunction((k) => window.__sent.slice(k).some((x) => x.m.type === 'camera'), n, { timeout: 5000 });
    assert.ok(await p.evaluate(() => window.probecast.camera.version) > v0, 'the camera moved');
    assert.deepEqual(pageErrors, []);
  } finally {
    await ctx.close();
  }
});

test('desktop: panels cover at most a quarter of the picture; ? shows the keys; the fullscreen button', { timeout: 60000 }, async () => {
  const ctx = await browser.newContext({ viewport: { width: 1280, height: 720 }, deviceScaleFactor: 1 });
  const p = await newViewerPage(ctx);
  try {
    await p.goto(BASE + '/');
    await p.waitForFunction(() => window.probecast.state().frames >= 1, null, { timeout: 30000 });
    for (const [vp, layout] of [[{ width: 1280, height: 720 }, 'layout-desktop'], [{ width: 800, height: 600 }, 'layout-compact']]) {
      await p.setViewportSize(vp);
      await p.waitForFunction((c) => document.body.classList.contains(c), layout, { timeout: 5000 });
      await sleep(300);
      const c = await coverage(p);
      assert.ok(c <= 0.25, `${vp.width}x${vp.height}: the panels cover ${(c * 100).toFixed(1)} % of the picture`);
      await shot(`layout-${vp.width}x${vp.height}.png`, p);
    }
    // The compact toolbar opens one panel at a time; Esc closes it.
    await p.locator('#toolbar [data-panel="panel-stats"]').click();
    await p.locator('#st-fps').waitFor({ timeout: 5000 });
    await p.locator('#toolbar [data-panel="panel-lights"]').click();
    await p.locator('#light-add').waitFor({ timeout: 5000 });
    assert.equal(await p.locator('#st-fps').isVisible(), false, 'one panel at a time');
    await p.locator('#view').focus();
    await p.keyboard.press('Escape');
    await p.locator('#light-add').waitFor({ state: 'hidden', timeout: 5000 });
    // '?' opens the keyboard help, which lists the keys; Esc closes it. The ? button too.
    await p.keyboard.press('?');
    await p.locator('#keys-help').waitFor({ timeout: 5000 });
    const keys = await p.locator('#keys-help kbd').allTextContents();
    for (const k of ['W', 'A', 'S', 'D', 'Q', 'E', 'Home', 'F', 'P', 'H', 'Space', '?', 'Esc']) assert.ok(keys.includes(k), `the help names ${k}: ${keys}`);
    await shot('keys-help.png', p);
    await p.keyboard.press('Escape');
    await p.locator('#keys-help').waitFor({ state: 'hidden', timeout: 5000 });
    await p.locator('#help-btn').click();
    await p.locator('#keys-help').waitFor({ timeout: 5000 });
    await p.keyboard.press('Escape');
    await p.locator('#keys-help').waitFor({ state: 'hidden', timeout: 5000 });
    // Fullscreen: the button asks for the picture's container (#stage); F toggles it too.
    await p.evaluate(() => {
      window.__fullscreen = [];
      const request = Element.prototype.requestFullscreen;
      Element.prototype.requestFullscreen = function (...a) { window.__fullscreen.push(this.id); return request.apply(this, a); };
    });
    await p.locator('#fullscreen').click();
    await p.waitForFunction(() => window.__fullscreen.length === 1, null, { timeout: 5000 });
    assert.deepEqual(await p.evaluate(() => window.__fullscreen), ['stage']);
    const fsElement = await p.evaluate(() => document.fullscreenElement && document.fullscreenElement.id);
    assert.ok(fsElement === null || fsElement === 'stage', `fullscreen element: ${fsElement}`);
    if (fsElement) {
      await p.evaluate(() => document.exitFullscreen());
      await p.waitForFunction(() => !document.fullscreenElement, null, { timeout: 5000 });
    }
    await p.locator('#view').focus();
    await p.keyboard.press('f');
    await p.waitForFunction(() => window.__fullscreen.length === 2, null, { timeout: 5000 });
    await p.evaluate(() => document.fullscreenElement && document.exitFullscreen());
    assert.deepEqual(pageErrors, []);
  } finally {
    await ctx.close();
  }
});

test('dragging asks for half the pixels, then the full size; the quality menu scales the size and caps quality and frame rate', { timeout: 60000 }, async () => {
  const vp = { width: 1280, height: 720 };
  const ctx = await browser.newContext({ viewport: vp, deviceScaleFactor: 1 });
  await recordSockets(ctx);
  const p = await newViewerPage(ctx);
  const resizesAfter = (k) => p.evaluate((n) => window.__sent.slice(n).filter((x) => x.m.type === 'resize'), k);
  const full = { type: 'resize', width: vp.width, height: vp.height, dpr: 1 };
  try {
    await p.goto(BASE + '/');
    await p.waitForFunction(() => window.probecast.state().frames >= 1 && window.probecast.state().restored, null, { timeout: 30000 });
    await p.evaluate(() => {
      window.__sizes = [];
      window.probecast.stream.addEventListener('frame', (e) => window.__sizes.push({ t: performance.now(), w: e.detail.width, h: e.detail.height }));
    });
    const granted = serverSize(vp.width, vp.height, MAX_PIXELS);
    let n = await p.evaluate(() => window.__sent.length);
    const cx = vp.width / 2, cy = vp.height / 2;
    await p.mouse.move(cx, cy);
    await p.mouse.down();
    for (let i = 1; i <= 20; i++) { await p.mouse.move(cx + i * 8, cy + i); await sleep(30); }
    const tUp = await p.evaluate(() => performance.now());
    await p.mouse.up();
    await p.waitForFunction((k) => {
      const r = window.__sent.slice(k).filter((x) => x.m.type === 'resize');
      return r.length >= 2 && r[r.length - 1].m.width === 1280;
    }, n, { timeout: 5000 });
    const rs = await resizesAfter(n);
    const reduced = rs[0];
    assert.ok(reduced.t < tUp, 'the reduced size was asked for during the drag');
    // half the pixels the server grants at full size (it scales requests down to max_pixels)
    const px = reduced.m.width * reduced.m.height * reduced.m.dpr ** 2;
    const want = 0.5 * granted.width * granted.height;
    assert.ok(Math.abs(px - want) < 0.1 * want, `reduced to ${reduced.m.width}x${reduced.m.height} (${px} px, want about ${want})`);
    assert.ok(Math.abs(reduced.m.width / reduced.m.height - vp.width / vp.height) < 0.05, 'the same aspect');
    assert.deepEqual(rs[rs.length - 1].m, full, 'the full size again after the release');
    assert.ok(rs[rs.length - 1].t > tUp);
    assert.equal(rs.length, 2, 'one message down, one back');
    // the server rendered the smaller size meanwhile, and the full one after
    await p.waitForFunction((g) => {
      const s = window.__sizes;
      return s.length && s[s.length - 1].w === g.width && s[s.length - 1].h === g.height;
    }, granted, { timeout: 20000 });
    const sizes = await p.evaluate(() => window.__sizes);
    assert.ok(sizes.some((s) => s.w < granted.width), `a reduced frame arrived: ${JSON.stringify(sizes.slice(-6))}`);
    // The quality menu: 50 % asks for half the size, 100 % for the full size again.
    await showPanel('panel-quality', p);
    n = await p.evaluate(() => window.__sent.length);
    await p.locator('#res-scale button[data-scale="0.5"]').click();
    await p.waitForFunction((k) => window.__sent.slice(k).some((x) => x.m.type === 'resize'), n, { timeout: 5000 });
    assert.deepEqual((await resizesAfter(n)).map((x) => x.m), [{ type: 'resize', width: 640, height: 360, dpr: 1 }]);
    assert.equal(await p.locator('#res-scale button[data-scale="0.5"]').getAttribute('aria-checked'), 'true');
    // Interactive resolution off: a drag sends no resize.
    await p.locator('#interactive-res').uncheck();
    n = await p.evaluate(() => window.__sent.length);
    await drag(100, 0, p);
    await sleep(500);
    assert.deepEqual(await resizesAfter(n), [], 'no resize while moving with interactive resolution off');
    assert.ok((await p.evaluate((k) => window.__sent.slice(k).filter((x) => x.m.type === 'camera'), n)).length >= 1);
    await p.locator('#interactive-res').check();
    n = await p.evaluate(() => window.__sent.length);
    await p.locator('#res-scale button[data-scale="1"]').click();
    await p.waitForFunction((k) => window.__sent.slice(k).some((x) => x.m.type === 'resize'), n, { timeout: 5000 });
    assert.deepEqual((await resizesAfter(n)).map((x) => x.m), [full]);

    // JPEG quality and frame-rate caps: a 'quality' message for our view; its frames (the
    // re-encoded still, then new ones) come at quality 50 at most.
    const qualityAfter = (k) => p.evaluate((i) => window.__sent.slice(i).filter((x) => x.m.type === 'quality').map((x) => x.m), k);
    n = await p.evaluate(() => window.__sent.length);
    await p.locator('#jpeg-cap button[data-value="50"]').click();
    await p.locator('#fps-cap button[data-value="15"]').click();
    assert.deepEqual(await qualityAfter(n), [
      { type: 'quality', jpeg: 50, max_fps: null },
      { type: 'quality', jpeg: 50, max_fps: 15 },
    ]);
    assert.equal(await p.locator('#jpeg-cap button[data-value="50"]').getAttribute('aria-checked'), 'true');
    assert.equal(await p.locator('#fps-cap button[data-value="15"]').getAttribute('aria-checked'), 'true');
    assert.equal(await p.locator('#fps-cap button[data-value="auto"]').getAttribute('aria-checked'), 'false');
    assert.deepEqual(await p.evaluate(() => [localStorage.getItem('probecast.quality.jpeg'), localStorage.getItem('probecast.quality.fps')]),
      ['50', '15']);
    await p.evaluate(() => {
      window.__q = [];
      window.probecast.stream.addEventListener('frame', (e) => window.__q.push(e.detail.quality));
    });
    await drag(80, 0, p);
    await p.waitForFunction(() => window.__q.length >= 2, null, { timeout: 20000 });
    const qs = await p.evaluate(() => window.__q);
    assert.ok(qs.every((q) => q <= 50), `frames at quality 50 at most: ${qs}`);
    // after a reconnect (a new view, without caps) the caps are sent again after the welcome
    n = await p.evaluate(() => window.__sent.length);
    const gen = (await state(p)).gen;
    await p.evaluate(() => { window.probecast.stream.stop(); window.probecast.stream.start(); });
    await p.waitForFunction((g) => window.probecast.state().gen !== g && window.probecast.state().restored, gen, { timeout: 30000 });
    await until(async () => (await qualityAfter(n)).length >= 1, 'the caps sent again after the welcome', 10000);
    assert.deepEqual(await qualityAfter(n), [{ type: 'quality', jpeg: 50, max_fps: 15 }]);
    const welcomeAt = await p.evaluate(() => window.__recv.filter((x) => x.m.type === 'welcome').pop().t);
    const sentAt = await p.evaluate((k) => window.__sent.slice(k).find((x) => x.m.type === 'quality').t, n);
    assert.ok(sentAt >= welcomeAt, 'after the welcome');
    // back to auto: both caps lifted
    n = await p.evaluate(() => window.__sent.length);
    await p.locator('#jpeg-cap button[data-value="auto"]').click();
    await p.locator('#fps-cap button[data-value="auto"]').click();
    assert.deepEqual((await qualityAfter(n)).pop(), { type: 'quality', jpeg: null, max_fps: null });
  } finally {
    await ctx.close();
  }
});

test('the stats panel: frame rates while frames arrive, GI convergence, live graphs', { timeout: 60000 }, async () => {
  await showPanel('panel-stats');
  const num = (id) => page.evaluate((i) => parseFloat(document.getElementById(i).textContent), id);
  // Drag for a few seconds: frames flow, latency samples come in, the server renders.
  const cx = VIEWPORT.width / 2, cy = VIEWPORT.height / 2;
  let drawnFps = 0, serverFps = 0;
  await page.mouse.move(cx, cy);
  await page.mouse.down();
  for (let i = 0; i < 40; i++) {
    await page.mouse.move(cx + 60 * Math.sin(i / 4), cy + 10 * Math.cos(i / 4));
    await sleep(80);
    if (i % 5 === 4) {
      drawnFps = Math.max(drawnFps, await num('st-fps'));
      serverFps = Math.max(serverFps, await num('st-server-fps'));
    }
  }
  await page.mouse.up();
  assert.ok(drawnFps > 0, `the fps readout showed frames arriving (${drawnFps})`);
  assert.ok(serverFps > 0, `the server's frame rate showed (${serverFps})`);
  // Convergence: a bar with the probes' progress (converged once the server idles).
  await until(async () => (await http('GET', '/v1/stats')).json.rendering === false, 'the server to idle', 30000, 250);
  await page.waitForFunction(() => document.getElementById('st-converge').getAttribute('aria-valuenow') === '100', null, { timeout: 10000 });
  assert.match(await page.locator('#st-converge').textContent(), /GI converged/);
  // The graphs drew: pixels on both canvases.
  const inked = (id) => page.evaluate((i) => {
    const c = document.getElementById(i);
    const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
    let n = 0;
    for (let k = 3; k < d.length; k += 4) if (d[k] > 0) n++;
    return { n, w: c.width, h: c.height };
  }, id);
  const gpu = await inked('graph-gpu'), lat = await inked('graph-latency');
  assert.ok(gpu.n > 100, `the GPU graph drew ${gpu.n} pixels of ${gpu.w}x${gpu.h}`);
  assert.ok(lat.n > 100, `the latency graph drew ${lat.n} pixels of ${lat.w}x${lat.h}`);
  assert.ok(await page.locator('#st-passes .pass').count() >= 1, 'the pass legend');
  await shot('stats-graphs.png');
});

/* ---- views: one world, many views (protocol/stream.md, version 2) ---------------------------- */

// A second page with another window size (and so another render size). It shares the browser
// context (and so its pool of at most 6 HTTP connections) with page A: the daemon takes at most
// 16 HTTP connections from one address, and every context keeps up to 6 of its own open.
const VIEWPORT_B = { width: 800, height: 640 }; // the compact layout: panels open from the toolbar
const RENDER_B = serverSize(VIEWPORT_B.width, VIEWPORT_B.height, MAX_PIXELS);
let pageB;

test('two pages get their own views, each at its own size', { timeout: 60000 }, async () => {
  assert.notDeepEqual(RENDER_B, RENDER, 'the two pages ask for different render sizes');
  pageB = await newViewerPage(context);
  await pageB.setViewportSize(VIEWPORT_B);
  await pageB.goto(BASE + '/');
  await pageB.waitForFunction(() => window.probecast.state().ownView !== null, null, { timeout: 30000 });
  const b = await waitViewFrame(pageB, (await state(pageB)).ownView, RENDER_B, 30000);
  const a = await state();
  assert.equal(b.protocol, 2);
  assert.notEqual(a.ownView, b.ownView, 'each page has a view of its own');
  assert.equal(a.header.viewId, a.ownView);
  assert.deepEqual({ width: a.header.width, height: a.header.height }, RENDER, 'page A keeps its size');
  assert.deepEqual({ width: b.header.width, height: b.header.height }, RENDER_B, 'page B gets its size');
  assert.ok(summary(await pixels(pageB)).std > 12, 'page B shows a picture');
  // GET /v1/views lists both (and the default view 0, owned by HTTP).
  const views = (await http('GET', '/v1/views')).json;
  const byId = new Map(views.views.map((v) => [v.id, v]));
  assert.equal(byId.get(0) && byId.get(0).owner, 'http');
  assert.deepEqual(byId.get(a.ownView) && { owner: byId.get(a.ownView).owner, width: byId.get(a.ownView).width, height: byId.get(a.ownView).height },
    { owner: 'viewer', ...RENDER });
  assert.deepEqual(byId.get(b.ownView) && { owner: byId.get(b.ownView).owner, width: byId.get(b.ownView).width, height: byId.get(b.ownView).height },
    { owner: 'viewer', ...RENDER_B });
  assert.ok(views.limits && views.limits.max_views > 0);
  // Each page's Views panel lists the other's view with a Follow button (from a 'views' event).
  await showPanel('panel-views');
  await showPanel('panel-views', pageB);
  await page.locator(`#views .view-row[data-id="${b.ownView}"] button[data-follow]`).waitFor({ timeout: 10000 });
  await pageB.locator(`#views .view-row[data-id="${a.ownView}"] button[data-follow]`).waitFor({ timeout: 10000 });
  assert.match(await page.locator(`#views .view-row[data-id="${b.ownView}"]`).textContent(), new RegExp(`${RENDER_B.width}×${RENDER_B.height}`));
  assert.equal(await page.locator(`#views .view-row[data-id="${a.ownView}"]`).count(), 0, 'the own view is not in the list');
  await shot('views-a.png');
  await shot('views-b.png', pageB);
});

test('dragging in one page does not move the other page\'s view', { timeout: 60000 }, async (t) => {
  const a0 = await state(), b0 = await state(pageB);
  const camA0 = await viewCamera(a0.ownView), camB0 = await viewCamera(b0.ownView);
  const sentB = await pageB.evaluate(() => window.__sent.length);
  const sentA = await page.evaluate(() => window.__sent.length);
  await drag(-150, 30);
  const camsA = await page.evaluate((n) => window.__sent.slice(n).filter((x) => x.m.type === 'camera'), sentA);
  assert.ok(camsA.length >= 1, 'page A sent camera messages');
  await page.waitForFunction((seq) => window.probecast.state().inputSeq >= seq, camsA[camsA.length - 1].m.seq, { timeout: 30000 });
  await sleep(500);
  const camA1 = await viewCamera(a0.ownView), camB1 = await viewCamera(b0.ownView);
  assert.ok(dist3(camA1.position, camA0.position) > 0.1, 'page A\'s view moved');
  assert.ok(dist3(camB1.position, camB0.position) < 1e-6 && dist3(camB1.target, camB0.target) < 1e-6, 'page B\'s view did not move');
  const b1 = await state(pageB);
  assert.equal(b1.header.viewId, b0.ownView, 'page B still shows its own view');
  assert.equal(b1.header.inputSeq, b0.header.inputSeq, 'page B\'s frames reflect no input of A');
  assert.deepEqual({ width: b1.header.width, height: b1.header.height }, RENDER_B);
  assert.equal((await pageB.evaluate((n) => window.__sent.slice(n).filter((x) => x.m.type === 'camera'), sentB)).length, 0);
  t.diagnostic(`page B's last frame id ${b0.drawnId} -> ${b1.drawnId} while A dragged (A: ${a0.drawnId} -> ${(await state()).drawnId})`);
});

test('page B follows page A\'s view, then returns to its own', { timeout: 90000 }, async () => {
  const a = await state(), b0 = await state(pageB);
  await showPanel('panel-views', pageB);
  const follow = pageB.locator(`#views .view-row[data-id="${a.ownView}"] button[data-follow]`);
  assert.equal(await follow.textContent(), 'Follow');
  await follow.click();
  // B receives frames of A's view at A's size.
  let b = await waitViewFrame(pageB, a.ownView, RENDER, 20000);
  assert.equal(b.watching, a.ownView, 'the server confirmed (following)');
  assert.equal(b.following, true);
  assert.equal(b.ownView, b0.ownView, 'B keeps its own view');
  assert.equal(await pageB.locator('#following').isVisible(), true);
  assert.match(await pageB.locator('#following').textContent(), new RegExp(`Following view ${a.ownView}`));
  assert.equal(await pageB.locator(`#views .view-row[data-id="${a.ownView}"] button[data-follow]`).textContent(), 'Stop');
  await shot('following.png', pageB);
  // A moves: B sees it (a newer frame of A's view; followers get input_seq 0).
  const fromB = b.drawnId;
  const sentA = await page.evaluate(() => window.__sent.length);
  await drag(60, -20);
  await pageB.waitForFunction((id) => {
    const s = window.probecast.state();
    return s.header.viewId === id.view && s.drawnId > id.after;
  }, { view: a.ownView, after: fromB }, { timeout: 20000 });
  assert.equal((await state(pageB)).header.inputSeq, 0);
  // Camera input on B while following is not sent: the drag does nothing.
  const sentB = await pageB.evaluate(() => window.__sent.length);
  const versionB = await pageB.evaluate(() => window.probecast.camera.version);
  await drag(100, 20, pageB);
  await pageB.mouse.wheel(0, -300);
  await sleep(300);
  assert.deepEqual(await pageB.evaluate((n) => window.__sent.slice(n).filter((x) => x.m.type === 'camera'), sentB), []);
  assert.equal(await pageB.evaluate(() => window.probecast.camera.version), versionB, 'B\'s camera did not change');
  assert.ok(await page.evaluate((n) => window.__sent.slice(n).some((x) => x.m.type === 'camera'), sentA));
  assert.ok(await pageB.evaluate((n) => window.__sent.slice(n).some((x) => x.m.type === 'follow' && x.m.view !== null), 0));
  // Stop: back to B's own view and size.
  await pageB.locator('#following-stop').click();
  b = await waitViewFrame(pageB, b0.ownView, RENDER_B, 20000);
  assert.equal(b.watching, b0.ownView);
  assert.equal(b.following, false);
  assert.equal(await pageB.locator('#following').isHidden(), true);
  const follows = await pageB.evaluate(() => window.__sent.filter((x) => x.m.type === 'follow').map((x) => x.m));
  assert.deepEqual(follows, [{ type: 'follow', view: a.ownView }, { type: 'follow', view: null }]);
  // Input works again and moves B's own view.
  const camB0 = await viewCamera(b0.ownView);
  await drag(-80, 0, pageB);
  await until(async () => dist3((await viewCamera(b0.ownView)).position, camB0.position) > 0.05, 'B\'s view to move after following', 10000);
});

test('a follower returns to its own view when the followed view goes away', { timeout: 60000 }, async () => {
  const pageC = await newViewerPage(context);
  try {
    await pageC.setViewportSize({ width: 320, height: 200 });
    await pageC.goto(BASE + '/');
    await pageC.waitForFunction(() => window.probecast.state().frames >= 1, null, { timeout: 30000 });
    const c = await state(pageC), b0 = await state(pageB);
    await showPanel('panel-views', pageB);
    const follow = pageB.locator(`#views .view-row[data-id="${c.ownView}"] button[data-follow]`);
    await follow.waitFor({ timeout: 10000 });
    await follow.click();
    await waitViewFrame(pageB, c.ownView, null, 20000);
    assert.equal(await pageB.locator('#following').isVisible(), true);
    await pageC.close();
    // The server says 'following' with B's own id: the UI is back on B's view.
    await pageB.waitForFunction((own) => {
      const s = window.probecast.state();
      return s.watching === own && !s.following;
    }, b0.ownView, { timeout: 15000 });
    await pageB.locator('#following').waitFor({ state: 'hidden', timeout: 5000 });
    const recv = await pageB.evaluate(() => window.__recv.map((x) => x.m).filter((m) => m.type === 'following'));
    assert.deepEqual(recv[recv.length - 1], { type: 'following', view: b0.ownView });
    await waitViewFrame(pageB, b0.ownView, RENDER_B, 20000);
    await pageB.locator(`#views .view-row[data-id="${c.ownView}"]`).waitFor({ state: 'detached', timeout: 10000 });
    assert.equal(await pageB.evaluate(() => window.probecast.controls.enabled), true, 'B\'s camera input works again');
  } finally {
    if (!pageC.isClosed()) await pageC.close();
  }
});

test('following an unknown view is refused and changes nothing', { timeout: 30000 }, async () => {
  const b0 = await state(pageB);
  await pageB.evaluate(() => window.probecast.follow(987654));
  await pageB.locator('.toast.error').first().waitFor({ timeout: 10000 });
  await pageB.waitForFunction((own) => {
    const s = window.probecast.state();
    return s.watching === own && !s.following && window.probecast.stream.expectView === own;
  }, b0.ownView, { timeout: 10000 });
  assert.equal(await pageB.locator('#following').isHidden(), true);
  assert.equal((await state(pageB)).state, 'open', 'the connection stays open');
});

test('world changes through the HTTP API reach both pages as events, without polling', { timeout: 60000 }, async () => {
  const t0 = Date.now();
  // A light added through the HTTP API appears in both pages' lights panel.
  const r = await http('POST', '/v1/lights', { type: 'point', position: [0, 1.5, 0], color: [0.2, 0.4, 1], intensity: 2, name: 'from-http' });
  assert.equal(r.status, 201, r.text);
  const id = r.json.id;
  for (const p of [page, pageB]) {
    await showPanel('panel-lights', p);
    await p.locator(`#lights details.light[data-id="${id}"]`).waitFor({ timeout: 10000 });
  }
  assert.match(await pageB.locator(`#lights details.light[data-id="${id}"] .name`).textContent(), /from-http/);
  // A change to it shows up too.
  assert.equal((await http('PATCH', `/v1/lights/${id}`, { intensity: 7.5 })).status, 200);
  for (const p of [page, pageB]) {
    await p.waitForFunction((lid) => {
      const el = document.querySelector(`#lights details.light[data-id="${lid}"] input[aria-label="intensity value"]`);
      return el && Number(el.value) === 7.5;
    }, id, { timeout: 10000 });
  }
  // Settings changed through the HTTP API show up in both pages' rendering panel.
  const exposure0 = (await http('GET', '/v1/settings')).json.exposure;
  assert.equal((await http('PATCH', '/v1/settings', { exposure: 1.5 })).status, 200);
  for (const p of [page, pageB]) {
    await p.waitForFunction(() => Number(document.getElementById('exposure').value) === 1.5, null, { timeout: 10000 });
  }
  // Deleted: gone from both.
  assert.equal((await http('DELETE', `/v1/lights/${id}`)).status, 204);
  for (const p of [page, pageB]) {
    await p.locator(`#lights details.light[data-id="${id}"]`).waitFor({ state: 'detached', timeout: 10000 });
  }
  assert.equal((await http('PATCH', '/v1/settings', { exposure: exposure0 })).status, 200);
  await sleep(1500); // more than a stats period: a poller would have asked by now
  // Neither page asked for the world's state: no GET of lights, settings or scene ever.
  for (const [name, p] of [['A', page], ['B', pageB]]) {
    const world = requests.get(p).filter((q) => q.method === 'GET' && /^\/v1\/(lights|settings|scene|nodes|views)(\/|$)/.test(q.path) &&
      !/\/camera$/.test(q.path));
    assert.deepEqual(world, [], `page ${name} polled the world's state`);
    const stats = requests.get(p).filter((q) => q.path === '/v1/stats' && q.t >= t0);
    const secs = (Date.now() - t0) / 1000;
    assert.ok(stats.length <= secs + 2, `page ${name}: /v1/stats at most once a second (${stats.length} in ${secs.toFixed(1)} s)`);
  }
});

test('a hidden page releases its view at once and takes a new one when shown', { timeout: 40000 }, async () => {
  const b0 = await state(pageB);
  const t0 = Date.now();
  await pageB.evaluate(() => {
    Object.defineProperty(document, 'hidden', { value: true, configurable: true });
    document.dispatchEvent(new Event('visibilitychange'));
  });
  await until(async () => !(await http('GET', '/v1/views')).json.views.some((v) => v.id === b0.ownView), 'hidden B\'s view to be freed', 3000);
  assert.ok(Date.now() - t0 < 3000, 'released within 3 s');
  await pageB.evaluate(() => {
    Object.defineProperty(document, 'hidden', { value: false, configurable: true });
    document.dispatchEvent(new Event('visibilitychange'));
  });
  await pageB.waitForFunction((old) => { const s = window.probecast.state(); return s.ownView !== null && s.ownView !== old; }, b0.ownView, { timeout: 20000 });
  const b1 = await state(pageB);
  await waitViewFrame(pageB, b1.ownView, RENDER_B, 30000);
  // pagehide (the tab closes or is put in the back/forward cache) releases it the same way
  await pageB.evaluate(() => window.dispatchEvent(new PageTransitionEvent('pagehide', { persisted: true })));
  await until(async () => !(await http('GET', '/v1/views')).json.views.some((v) => v.id === b1.ownView), 'B\'s view to be freed on pagehide', 3000);
  await pageB.evaluate(() => window.dispatchEvent(new PageTransitionEvent('pageshow', { persisted: true })));
  await pageB.waitForFunction((old) => { const s = window.probecast.state(); return s.ownView !== null && s.ownView !== old; }, b1.ownView, { timeout: 20000 });
});

test('the second page closes; its view goes away', { timeout: 30000 }, async () => {
  const b = await state(pageB);
  await pageB.close();
  await until(async () => !(await http('GET', '/v1/views')).json.views.some((v) => v.id === b.ownView), 'B\'s view to be freed', 10000);
  await page.locator(`#views .view-row[data-id="${b.ownView}"]`).waitFor({ state: 'detached', timeout: 10000 });
});

test('a rejected upload shows the server\'s message', { timeout: 30000 }, async () => {
  // A GLB whose header promises more bytes than it has.
  const json = Buffer.from('{"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"no');
  const glb = Buffer.alloc(12 + 8 + json.length);
  glb.write('glTF', 0, 'latin1');
  glb.writeUInt32LE(2, 4);
  glb.writeUInt32LE(4096, 8);
  glb.writeUInt32LE(4076, 12);
  glb.write('JSON', 16, 'latin1');
  json.copy(glb, 20);
  const cases = [
    { name: 'truncated.glb', mimeType: 'model/gltf-binary', buffer: glb, type: 'model/gltf-binary' },
    { name: 'notes.txt', mimeType: 'text/plain', buffer: Buffer.from('not a scene\n'), type: 'application/octet-stream' },
    // a .gltf that refers to a file beside it: one uploaded file cannot; the message says what to do
    { name: 'parts.gltf', mimeType: 'model/gltf+json', type: 'model/gltf+json', hint: /upload a \.glb/,
      buffer: Buffer.from('{"asset":{"version":"2.0"},"buffers":[{"byteLength":8,"uri":"parts.bin"}]}') },
  ];
  for (const c of cases) {
    const expected = await http('PUT', '/v1/scene', new Uint8Array(c.buffer), { 'Content-Type': c.type });
    assert.equal(expected.status, 422, expected.text);
    assert.ok(expected.json.message.length > 0);
    if (c.hint) assert.match(expected.json.message, c.hint);
    // the page packs a .gltf with separate files itself and names the missing one
    // (gltf_pack.js; scene.test.mjs checks its message)
    if (c.name.endsWith('.gltf')) continue;
    await page.locator('#upload-file').setInputFiles({ name: c.name, mimeType: c.mimeType, buffer: c.buffer });
    await page.waitForFunction((msg) => {
      const el = document.querySelector('#upload-error .msg');
      return el && !document.getElementById('upload-error').hidden && el.textContent === msg;
    }, expected.json.message, { timeout: 15000 });
    assert.match(await page.locator('#upload-error').textContent(), new RegExp(c.name.replace('.', '\\.')));
    if (c.name.endsWith('.glb')) await shot('upload-rejected.png');
  }
  assert.equal((await http('GET', '/v1/scene')).json.source, 'builtin:cornell', 'the old scene keeps rendering');
});

test('the viewer recovers when the daemon restarts and restores its view', { timeout: 60000 }, async () => {
  const pid = Number(fs.readFileSync(env.PCWEB_PIDFILE, 'utf8'));
  const s0 = await state();
  const t0 = await page.evaluate(() => performance.now());
  process.kill(pid, 'SIGTERM');
  await until(() => !alive(pid), 'the daemon to exit', 15000);
  await page.waitForFunction(() => window.probecast.state().state !== 'open', null, { timeout: 10000 });
  // Move the camera while the server is away: the viewer must send it after reconnecting.
  await drag(-120, -30);
  const offlineCam = await page.evaluate(() => window.probecast.camera.toMessage());
  await sleep(300);
  await shot('offline.png');
  const d = await startDaemon(JSON.parse(env.PCWEB_ARGS), 'daemon-restarted.log');
  fs.writeFileSync(env.PCWEB_PIDFILE, String(d.child.pid));
  assert.equal(d.http, env.PCWEB_HTTP);
  await page.waitForFunction((g) => {
    const s = window.probecast.state();
    return s.state === 'open' && s.gen > g && s.drawnId > 0;
  }, s0.gen, { timeout: 30000 });
  // The view came back on the page's new view: the camera moved offline, and the viewer's size.
  const own = (await state()).ownView;
  assert.ok(Number.isInteger(own));
  assert.equal((await state()).header.viewId, own);
  const cam = await until(async () => {
    const c = await viewCamera(own);
    return dist3(c.position, offlineCam.position) < 1e-3 ? c : null;
  }, 'the camera of the page\'s new view to be the viewer\'s', 10000);
  assert.ok(cam);
  const after = await page.evaluate((t) => window.__sent.filter((x) => x.t > t), t0);
  assert.ok(after.some((x) => x.m.type === 'resize' && x.m.width === VIEWPORT.width), 'the size was sent again');
  const cams = after.filter((x) => x.m.type === 'camera');
  assert.ok(cams.length >= 1);
  const s1 = await state();
  await page.waitForFunction((seq) => window.probecast.state().inputSeq >= seq, cams[cams.length - 1].m.seq, { timeout: 20000 });
  assert.ok(s1.reconnects > s0.reconnects);
  const pix = summary(await pixels());
  assert.ok(pix.std > 12, 'a picture after the restart');
  await shot('restarted.png');
});

test('the render size follows the window (debounced resize messages)', { timeout: 60000 }, async () => {
  // Resize only while the server idles (GI converged, nothing in flight): see RENDER above.
  await until(async () => (await http('GET', '/v1/stats')).json.rendering === false, 'the server to idle', 45000, 250);
  const n = await page.evaluate(() => window.__sent.length);
  // The viewer waits 150 ms after a change; on a loaded machine a change can itself take longer
  // than that, and then a message between changes is right. The longest gap decides.
  const changed = [];
  for (const w of [900, 840, 800]) {
    await page.setViewportSize({ width: w, height: 500 });
    changed.push(performance.now());
    await sleep(30);
  }
  await sleep(600);
  const resizes = await page.evaluate((k) => window.__sent.slice(k).filter((x) => x.m.type === 'resize').map((x) => x.m), n);
  const gap = Math.max(changed[1] - changed[0], changed[2] - changed[1]);
  assert.deepEqual(resizes[resizes.length - 1], { type: 'resize', width: 800, height: 500, dpr: 1 }, 'the last message has the final size');
  if (gap < 120) assert.equal(resizes.length, 1, `one message after the last change (changes ${gap.toFixed(0)} ms apart)`);
  else assert.ok(resizes.length <= 3, `at most one message per change (changes ${gap.toFixed(0)} ms apart)`);
  const want = serverSize(800, 500, MAX_PIXELS);
  await page.waitForFunction((w) => {
    const h = window.probecast.state().header;
    return h && h.width === w.width && h.height === w.height;
  }, want, { timeout: 20000 });
  const pix = summary(await pixels());
  assert.ok(pix.std > 12, 'a picture at the new size');
  await shot('resized.png');
});

/* A small self-contained glTF: a floor, a back wall and a block, lit by a point light. */
function tinyGltf() {
  const quads = [
    [[-2, 0, -2], [2, 0, -2], [2, 0, 2], [-2, 0, 2]],          // floor
    [[-2, 0, -2], [-2, 2, -2], [2, 2, -2], [2, 0, -2]],        // back wall
    [[-0.4, 0, 0.4], [0.4, 0, 0.4], [0.4, 1.2, 0.4], [-0.4, 1.2, 0.4]], // block front
  ];
  const pos = [], idx = [];
  for (const q of quads) {
    const b = pos.length / 3;
    for (const v of q) pos.push(...v);
    idx.push(b, b + 1, b + 2, b, b + 2, b + 3, b, b + 2, b + 1, b, b + 3, b + 2); // both sides
  }
  const p = Buffer.from(new Float32Array(pos).buffer);
  const i = Buffer.from(new Uint16Array(idx).buffer);
  const bin = Buffer.concat([p, i]);
  const min = [0, 1, 2].map((k) => Math.min(...pos.filter((_, j) => j % 3 === k)));
  const max = [0, 1, 2].map((k) => Math.max(...pos.filter((_, j) => j % 3 === k)));
  return JSON.stringify({
    asset: { version: '2.0' },
    extensionsUsed: ['KHR_lights_punctual'],
    extensions: { KHR_lights_punctual: { lights: [{ type: 'point', color: [1, 0.9, 0.8], intensity: 8 }] } },
    scene: 0,
    scenes: [{ nodes: [0, 1] }],
    nodes: [{ mesh: 0, name: 'room' }, { name: 'lamp', translation: [0.8, 1.6, 0.8], extensions: { KHR_lights_punctual: { light: 0 } } }],
    meshes: [{ primitives: [{ attributes: { POSITION: 0 }, indices: 1, material: 0 }] }],
    materials: [{ pbrMetallicRoughness: { baseColorFactor: [0.8, 0.8, 0.8, 1], metallicFactor: 0, roughnessFactor: 1 } }],
    buffers: [{ byteLength: bin.length, uri: 'data:application/octet-stream;base64,' + bin.toString('base64') }],
    bufferViews: [{ buffer: 0, byteOffset: 0, byteLength: p.length }, { buffer: 0, byteOffset: p.length, byteLength: i.length }],
    accessors: [
      { bufferView: 0, componentType: 5126, count: pos.length / 3, type: 'VEC3', min, max },
      { bufferView: 1, componentType: 5123, count: idx.length, type: 'SCALAR' },
    ],
  });
}

test('a dropped-in scene uploads with progress and replaces the view', { timeout: 60000 }, async () => {
  const s0 = await state();
  const camBefore = await page.evaluate(() => window.probecast.camera.toMessage().position);
  await page.evaluate(() => {
    window.__uploadTexts = [];
    const el = document.getElementById('upload-text');
    new MutationObserver(() => window.__uploadTexts.push(el.textContent)).observe(el, { childList: true, characterData: true, subtree: true });
  });
  await page.locator('#upload-file').setInputFiles({ name: 'tiny.gltf', mimeType: 'model/gltf+json', buffer: Buffer.from(tinyGltf()) });
  await page.waitForFunction(() => [...document.querySelectorAll('.toast.ok')].some((t) => /Loaded tiny\.gltf/.test(t.textContent)),
    null, { timeout: 30000 });
  const texts = await page.evaluate(() => window.__uploadTexts);
  assert.ok(texts.some((t) => /^Uploading \d+ %/.test(t)), `upload progress shown: ${JSON.stringify(texts)}`);
  assert.equal(await page.locator('#upload').isHidden(), true, 'the progress bar goes away');
  const sc = (await http('GET', '/v1/scene')).json;
  assert.equal(sc.source, 'upload');
  assert.equal(sc.light_count, 1);
  assert.match(await page.locator('#scene-info').textContent(), /uploaded scene/);
  // The viewer took the new scene's camera (on its own view) and shows the new scene.
  const own = (await state()).ownView;
  await until(async () => {
    const c = await viewCamera(own);
    const m = await page.evaluate(() => window.probecast.camera.toMessage().position);
    return dist3(c.position, m) < 1e-3 && dist3(m, camBefore) > 1e-3;
  }, 'the page and its view to share the new scene\'s camera', 10000);
  await settleAfter(s0.drawnId);
  await page.waitForFunction(() => document.querySelectorAll('#lights details.light').length === 1, null, { timeout: 10000 });
  assert.ok(summary(await pixels()).std > 8, 'the new scene is drawn');
  await shot('uploaded.png');
});

test('a token prompt appears when the server needs one', { timeout: 60000 }, async () => {
  const token = 'web-test.token_1';
  const size = serverSize(VIEWPORT.width, VIEWPORT.height, 4096);
  const d = await startDaemon(['serve', '--http', '127.0.0.1:0', '--ws', '127.0.0.1:0',
    '--width', String(size.width), '--height', String(size.height),
    '--probes', '2,2,2', '--rays', '8', '--no-animate', '--encoders', '1', '--token', token,
    '--web-dir', path.join(env.PCWEB_ROOT, 'web')], 'daemon-token.log');
  const base = `http://${d.http}`;
  assert.equal((await http('PATCH', `${base}/v1/settings`, { max_pixels: 4096 })).status, 401);
  assert.equal((await http('PATCH', `${base}/v1/settings`, { max_pixels: 4096 }, { Authorization: 'Bearer ' + token })).status, 200);
  const ctx = await browser.newContext({ viewport: VIEWPORT, deviceScaleFactor: 1 });
  const p = await newViewerPage(ctx);
  try {
    await p.goto(base + '/');
    await p.locator('#token-dialog[open]').waitFor({ timeout: 15000 });
    await p.locator('#token-input').fill('wrong-token');
    await p.locator('#token-ok').click();
    await p.locator('#token-dialog[open]').waitFor({ timeout: 15000 }); // asked again
    assert.match(await p.locator('#token-reason').textContent(), /refused/);
    await shot('token-prompt.png', p);
    await p.locator('#token-input').fill(token);
    await p.locator('#token-ok').click();
    await p.waitForFunction(() => window.probecast.state().frames >= 1, null, { timeout: 30000 });
    assert.equal(await p.evaluate(() => sessionStorage.getItem('probecast.token')), token);
    // HTTP changes carry the token: switch GI off through the panel.
    await showPanel('panel-render', p);
    await p.locator('#gi-modes button[data-value=off]').click();
    await until(async () => (await http('GET', `${base}/v1/settings`)).json.gi_mode === 'off', 'gi_mode off with the token');
  } finally {
    await ctx.close();
    await stopDaemon(d.child);
  }
});

test('no uncaught errors in the page', () => {
  assert.deepEqual(pageErrors, []);
});

test('the daemon survived the session and stops cleanly', { timeout: 20000 }, async () => {
  const pid = Number(fs.readFileSync(env.PCWEB_PIDFILE, 'utf8'));
  const child = spawned.find((c) => c.pid === pid);
  assert.ok(child && alive(pid), 'the restarted daemon is still running');
  const exited = new Promise((r) => child.once('exit', (code, signal) => r({ code, signal })));
  child.kill('SIGTERM');
  assert.deepEqual(await exited, { code: 0, signal: null });
});
