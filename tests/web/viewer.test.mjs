// Browser tests of the viewer (web/) in Debian's headless Chromium, driven by playwright-core.
// Started by tests/web/run.sh, which runs the daemon and passes it in PCWEB_* variables:
//   PCWEB_HTTP, PCWEB_WS   bound addresses          PCWEB_PIDFILE  the daemon's pid (rewritten here
//   PCWEB_EXE, PCWEB_ARGS  its command (JSON argv)                  after the restart test)
//   PCWEB_OUT              screenshots and logs     PCWEB_CHROMIUM, PCWEB_ROOT
// The tests run in order on one page; each asserts what the user would see.

import { after, before, test } from 'node:test';
import assert from 'node:assert/strict';
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import readline from 'node:readline';
import { chromium } from 'playwright-core';

const env = process.env;
for (const k of ['PCWEB_HTTP', 'PCWEB_PIDFILE', 'PCWEB_EXE', 'PCWEB_ARGS', 'PCWEB_OUT']) {
  if (!env[k]) throw new Error(`${k} is not set: run this through tests/web/run.sh`);
}
const BASE = `http://${env.PCWEB_HTTP}`;
const OUT = env.PCWEB_OUT;
const VIEWPORT = { width: 960, height: 600 };
// Lavapipe: keep the render tiny. The server scales a viewer's size down to max_pixels; the
// daemon starts at exactly the size the 960x600 page will ask for, so the render size does not
// change while frames are in flight. (A size change while a readback copy is in flight crashes
// the daemon today: rd_renderer's ensure_size() destroys the rgba8 buffer that a pending copy of
// server/readback.c still reads. Only the resize test changes the size, while the server idles.)
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
const CHROMIUM_ARGS = ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
  '--disable-background-networking', '--disable-component-update', '--disable-sync'];

let browser, context, page;
const pageErrors = [];
const spawned = []; // daemons started here, stopped in after()

/* ---- helpers -------------------------------------------------------------------------------- */

async function http(method, url, body, headers = {}) {
  const res = await fetch(url.startsWith('http') ? url : BASE + url, {
    method,
    headers: body !== undefined && !(body instanceof Uint8Array) ? { 'Content-Type': 'application/json', ...headers } : headers,
    body: body === undefined ? undefined : body instanceof Uint8Array ? body : JSON.stringify(body),
  });
  const text = await res.text();
  let json = null;
  try { json = text ? JSON.parse(text) : null; } catch { /* not JSON */ }
  return { status: res.status, json, text };
}

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

async function until(fn, what, timeoutMs = 20000, everyMs = 100) {
  const end = Date.now() + timeoutMs;
  let last;
  while (Date.now() < end) {
    last = await fn();
    if (last) return last;
    await sleep(everyMs);
  }
  throw new Error(`timed out after ${timeoutMs} ms waiting for ${what}`);
}

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
  const cx = VIEWPORT.width / 2, cy = VIEWPORT.height / 2;
  await p.mouse.move(cx, cy);
  await p.mouse.down();
  await p.mouse.move(cx + dx, cy + dy, { steps: 12 });
  await p.mouse.up();
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

/* Starts probecast with args; resolves { child, http, ws } after its first stdout line. */
function startDaemon(args, logName) {
  return new Promise((resolve, reject) => {
    const log = fs.openSync(path.join(OUT, logName), 'a');
    const child = spawn(env.PCWEB_EXE, args, { stdio: ['ignore', 'pipe', log] });
    spawned.push(child);
    const timer = setTimeout(() => reject(new Error('the daemon did not print its ports within 30 s')), 30000);
    child.once('exit', (code) => reject(new Error(`the daemon exited with ${code} at start-up (see ${logName})`)));
    const lines = readline.createInterface({ input: child.stdout });
    lines.once('line', (line) => {
      clearTimeout(timer);
      const m = /^probecast serving http=(\S+) ws=(\S+)/.exec(line);
      if (!m) { reject(new Error('unexpected first line: ' + line)); return; }
      lines.on('line', () => {}); // keep draining stdout
      resolve({ child, http: m[1], ws: m[2] });
    });
  });
}

async function stopDaemon(child) {
  if (child.exitCode !== null || child.signalCode !== null) return;
  const exited = new Promise((r) => child.once('exit', r));
  child.kill('SIGTERM');
  await Promise.race([exited, sleep(10000)]);
  if (child.exitCode === null && child.signalCode === null) child.kill('SIGKILL');
}

async function newViewerPage(ctx) {
  const p = await ctx.newPage();
  p.on('pageerror', (e) => pageErrors.push(e.message));
  return p;
}

/* ---- set-up ------------------------------------------------------------------------------- */

before(async () => {
  const r = await http('PATCH', '/v1/settings', { max_pixels: MAX_PIXELS });
  assert.equal(r.status, 200, r.text);
  assert.deepEqual({ width: r.json.width, height: r.json.height }, RENDER,
    'run.sh starts the daemon at the size the page will ask for');
  browser = await chromium.launch({ executablePath: env.PCWEB_CHROMIUM || '/usr/bin/chromium', args: CHROMIUM_ARGS });
  context = await browser.newContext({ viewport: VIEWPORT, deviceScaleFactor: 1 });
  // Record every text message the page sends on a WebSocket, and count animation frames, to
  // check coalescing and the restore after a reconnect.
  await context.addInitScript(() => {
    window.__sent = [];
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
  });
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
  for (const f of ['/viewer.css', '/js/main.js', '/js/stream.js', '/js/camera.js', '/js/api.js', '/js/panels.js']) {
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
  await shot('loaded.png');
});

test('dragging orbits the camera; frames reflect the input', { timeout: 40000 }, async () => {
  const camBefore = (await http('GET', '/v1/camera')).json;
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
  const camAfter = (await http('GET', '/v1/camera')).json;
  const moved = Math.hypot(...camAfter.position.map((v, i) => v - camBefore.position[i]));
  assert.ok(moved > 0.1, `the server's camera moved (${moved.toFixed(3)})`);
  // The latency readout has a number now.
  await page.waitForFunction(() => /\d+ ms/.test(document.getElementById('st-latency').textContent), null, { timeout: 5000 });
  await shot('orbited.png');
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
  await page.keyboard.press('KeyF'); // frame the scene again for the tests that follow
});

test('a light edit in the panel changes the picture', { timeout: 40000 }, async (t) => {
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
  await page.locator('#light-type').selectOption('spot');
  await page.locator('#light-add').click();
  await page.waitForFunction((n) => document.querySelectorAll('#lights details.light').length === n + 1, n0, { timeout: 10000 });
  const lights = (await http('GET', '/v1/lights')).json.lights;
  assert.equal(lights.length, n0 + 1);
  const added = lights[lights.length - 1];
  assert.equal(added.type, 'spot');
  const card = page.locator(`#lights details.light[data-id="${added.id}"]`);
  assert.equal(await card.locator('input[aria-label="direction y"]').isVisible(), true, 'a spot light shows its direction');
  assert.equal(Number(await card.locator('input[aria-label="direction y"]').inputValue()), -1);
  await card.locator('button[aria-label="delete light"]').click();
  await page.waitForFunction((n) => document.querySelectorAll('#lights details.light').length === n, n0, { timeout: 10000 });
  assert.equal(await count(), n0);
});

test('the rendering panel switches GI mode and the probe view', { timeout: 30000 }, async () => {
  const pt = page.locator('#gi-modes button[data-value=pathtrace]');
  assert.equal(await pt.isDisabled(), false, 'the API offers gi_mode pathtrace');
  await pt.click();
  await until(async () => (await http('GET', '/v1/settings')).json.gi_mode === 'pathtrace', 'gi_mode pathtrace');
  // the panel marks the mode once the server's answer arrives (it may trail the settings)
  await until(async () => (await pt.getAttribute('aria-checked')) === 'true', 'path trace checked');
  await waitDrawnAfter((await state()).drawnId + 1);
  await shot('pathtrace.png');
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
  ];
  for (const c of cases) {
    const expected = await http('PUT', '/v1/scene', new Uint8Array(c.buffer), { 'Content-Type': c.type });
    assert.equal(expected.status, 422, expected.text);
    assert.ok(expected.json.message.length > 0);
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
  // The view came back: the camera moved offline, and the viewer's size.
  const cam = await until(async () => {
    const c = (await http('GET', '/v1/camera')).json;
    return Math.hypot(...c.position.map((v, i) => v - offlineCam.position[i])) < 1e-3 ? c : null;
  }, 'the server camera to be the viewer\'s', 10000);
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
  for (const w of [900, 840, 800]) {
    await page.setViewportSize({ width: w, height: 500 });
    await sleep(30);
  }
  await sleep(600);
  const resizes = await page.evaluate((k) => window.__sent.slice(k).filter((x) => x.m.type === 'resize').map((x) => x.m), n);
  assert.deepEqual(resizes, [{ type: 'resize', width: 800, height: 500, dpr: 1 }], 'one message after the last change');
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
  // The viewer took the server's new camera and shows the new scene.
  const cam = (await http('GET', '/v1/camera')).json;
  await page.waitForFunction((p) => {
    const m = window.probecast.camera.toMessage().position;
    return Math.hypot(m[0] - p[0], m[1] - p[1], m[2] - p[2]) < 1e-3;
  }, cam.position, { timeout: 10000 });
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
