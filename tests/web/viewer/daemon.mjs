// The page against the daemon: a rejected upload, a daemon restart the page recovers from, then
// (after the restart, which checks the page's first size) a window resize, a scene upload that
// replaces the view, a daemon that asks for a token; and the session's end: no uncaught errors in
// any page, and the restarted daemon stops cleanly.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { alive, dist3, drag, MAX_PIXELS, pixels, serverSize, shot, showPanel, sleep, stopDaemon, summary, until, VIEWPORT } from '../util.mjs';
import { browser, env, http, newViewerPage, page, pageErrors, settleAfter, spawned, startDaemon, state, viewCamera } from './session.mjs';

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
    if (c.name.endsWith('.glb')) await shot(page, 'upload-rejected.png');
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
  await drag(page, -120, -30);
  const offlineCam = await page.evaluate(() => window.probecast.camera.toMessage());
  await sleep(300);
  await shot(page, 'offline.png');
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
  const pix = summary(await pixels(page));
  assert.ok(pix.std > 12, 'a picture after the restart');
  await shot(page, 'restarted.png');
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
  const pix = summary(await pixels(page));
  assert.ok(pix.std > 12, 'a picture at the new size');
  await shot(page, 'resized.png');
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
  assert.ok(summary(await pixels(page)).std > 8, 'the new scene is drawn');
  await shot(page, 'uploaded.png');
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
    await shot(p, 'token-prompt.png');
    await p.locator('#token-input').fill(token);
    await p.locator('#token-ok').click();
    await p.waitForFunction(() => window.probecast.state().frames >= 1, null, { timeout: 30000 });
    assert.equal(await p.evaluate(() => sessionStorage.getItem('probecast.token')), token);
    // HTTP changes carry the token: switch GI off through the panel.
    await showPanel(p, 'panel-render');
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
