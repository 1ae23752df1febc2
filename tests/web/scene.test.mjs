// Browser tests of the viewer's scene editing (web/js/scene_tree.js, gizmo.js, gltf_pack.js,
// scene_panel.js) in Debian's headless Chromium, driven by playwright-core, against a daemon of
// their own on lavapipe. Started by tests/web/run.sh after viewer.test.mjs, with PCWEB_EXE,
// PCWEB_OUT, PCWEB_CHROMIUM and PCWEB_ROOT set.
//
// The scene is a .gltf with a separate .bin (a floor, a box under a group node, a point light
// and a camera looking at the box), chosen in the file input as two files: the page packs them
// into one .glb. Then: the node tree lists the nodes; a click on the picture selects the box
// (POST /v1/views/{id}/pick); a numeric field and the gizmo's arrow move it (PATCH
// /v1/nodes/{id}, seen in GET /v1/scene); a ring turns it; the light's icon drags the light; a
// folder holding the two files uploads too.

import { after, before, test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import {
  MAX_PIXELS, VIEWPORT, httpClient, launchChromium, shot, showPanel, sleep, startDaemon, stopDaemon, until,
} from './util.mjs';

const env = process.env;
for (const k of ['PCWEB_EXE', 'PCWEB_OUT', 'PCWEB_ROOT']) {
  if (!env[k]) throw new Error(`${k} is not set: run this through tests/web/run.sh`);
}
const OUT = env.PCWEB_OUT;

let daemon, http, browser, page;
const pageErrors = [];
const posts = []; // [{ path, body }] of the page's POST and PATCH requests

const closePanels = () => page.evaluate(() => window.probecast.layout.show(null));

/* ---- the test scene: scene.gltf + scene.bin ------------------------------------------------- */

/* A 1 x 1 white PNG. */
const WHITE_PNG = 'iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAIAAACQd1PeAAAADElEQVR4nGP4//8/AAX+Av4N70a4AAAAAElFTkSuQmCC';

function sceneFiles() {
  const floor = [-2, 0, -2, -2, 0, 2, 2, 0, 2, 2, 0, -2];
  const box = [];
  for (let i = 0; i < 8; i++) box.push(i & 1 ? 0.5 : -0.5, i & 2 ? 0.5 : -0.5, i & 4 ? 0.5 : -0.5);
  const boxIdx = [0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5, 0, 1, 5, 0, 5, 4, 2, 6, 7, 2, 7, 3, 0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6];
  const parts = [Buffer.from(new Float32Array(floor).buffer), Buffer.from(new Uint16Array([0, 1, 2, 0, 2, 3]).buffer),
    Buffer.from(new Float32Array(box).buffer), Buffer.from(new Uint16Array(boxIdx).buffer)];
  const views = [];
  let at = 0;
  for (const p of parts) { views.push({ buffer: 0, byteOffset: at, byteLength: p.length }); at += (p.length + 3) & ~3; }
  const bin = Buffer.alloc(at);
  parts.forEach((p, i) => p.copy(bin, views[i].byteOffset));
  const tilt = Math.atan2(0.7, 3.5); // the camera looks down at the box
  const gltf = {
    asset: { version: '2.0' },
    extensionsUsed: ['KHR_lights_punctual'],
    extensions: { KHR_lights_punctual: { lights: [{ type: 'point', intensity: 12, color: [1, 1, 1] }] } },
    scene: 0,
    scenes: [{ nodes: [0, 1, 3, 4] }],
    nodes: [
      { name: 'floor', mesh: 0 },
      { name: 'group', children: [2] },
      { name: 'box', mesh: 1, translation: [0, 0.5, 0] },
      { name: 'lamp', translation: [0.9, 1.5, 1.2], extensions: { KHR_lights_punctual: { light: 0 } } },
      { name: 'cam', camera: 0, translation: [0, 1.2, 3.5], rotation: [-Math.sin(tilt / 2), 0, 0, Math.cos(tilt / 2)] },
    ],
    cameras: [{ type: 'perspective', perspective: { yfov: 0.8, znear: 0.05 } }],
    materials: [{ pbrMetallicRoughness: { baseColorFactor: [0.8, 0.8, 0.8, 1] } },
      { pbrMetallicRoughness: { baseColorFactor: [0.9, 0.2, 0.1, 1], baseColorTexture: { index: 0 } } }],
    textures: [{ source: 0 }],
    images: [{ uri: 'tex/white%20dot.png' }], // a file in a folder beside the .gltf, its name URI-encoded
    meshes: [{ primitives: [{ attributes: { POSITION: 0 }, indices: 1, material: 0 }] },
      { primitives: [{ attributes: { POSITION: 2 }, indices: 3, material: 1 }] }],
    buffers: [{ byteLength: bin.length, uri: 'scene.bin' }],
    bufferViews: views,
    accessors: [
      { bufferView: 0, componentType: 5126, count: 4, type: 'VEC3', min: [-2, 0, -2], max: [2, 0, 2] },
      { bufferView: 1, componentType: 5123, count: 6, type: 'SCALAR' },
      { bufferView: 2, componentType: 5126, count: 8, type: 'VEC3', min: [-0.5, -0.5, -0.5], max: [0.5, 0.5, 0.5] },
      { bufferView: 3, componentType: 5123, count: 36, type: 'SCALAR' },
    ],
  };
  return {
    gltf: { name: 'scene.gltf', mimeType: 'model/gltf+json', buffer: Buffer.from(JSON.stringify(gltf)) },
    bin: { name: 'scene.bin', mimeType: 'application/octet-stream', buffer: bin },
    png: { name: 'white dot.png', mimeType: 'image/png', buffer: Buffer.from(WHITE_PNG, 'base64') },
  };
}
const BOX = 2;

const node = async (id) => (await http('GET', '/v1/scene')).json.nodes.find((n) => n.id === id);
/* The gizmo's handles and light icons as drawn now (page CSS px). */
const overlay = () => page.evaluate(() => {
  const g = window.probecast.gizmo;
  g.draw();
  return { handles: g.handles.map((h) => ({ kind: h.kind, axis: h.axis, pts: h.pts.map((p) => ({ x: p.x, y: p.y })) })),
    lights: g.lightIcons.map((l) => ({ id: l.id, x: l.x, y: l.y })) };
});

async function mouseDrag(from, to, steps = 10) {
  await page.mouse.move(from.x, from.y);
  await page.mouse.down();
  await page.mouse.move(to.x, to.y, { steps });
  await page.mouse.up();
}

/* ---- set-up ---------------------------------------------------------------------------------- */

before(async () => {
  daemon = await startDaemon(env.PCWEB_EXE, OUT, ['serve', '--http', '127.0.0.1:0', '--ws', '127.0.0.1:0', '--width', '156', '--height', '97',
    '--probes', '2,2,2', '--rays', '8', '--hysteresis', '0.5', '--no-animate', '--encoders', '1', '--max-fps', '20',
    '--web-dir', path.join(env.PCWEB_ROOT, 'web')], 'daemon-scene.log');
  const BASE = `http://${daemon.http}`;
  http = httpClient(BASE);
  assert.equal((await http('PATCH', '/v1/settings', { max_pixels: MAX_PIXELS })).status, 200);
  browser = await launchChromium();
  const context = await browser.newContext({ viewport: VIEWPORT, deviceScaleFactor: 1 });
  page = await context.newPage();
  page.on('pageerror', (e) => pageErrors.push(e.message));
  page.on('request', (r) => {
    if (r.method() === 'POST' || r.method() === 'PATCH' || r.method() === 'PUT')
      posts.push({ method: r.method(), path: new URL(r.url()).pathname + new URL(r.url()).search, body: r.postData() });
  });
  await page.goto(BASE + '/');
  await page.waitForFunction(() => window.probecast && window.probecast.state().frames >= 1, null, { timeout: 60000 });
});

after(async () => {
  if (browser) await browser.close().catch(() => {});
  if (daemon) await stopDaemon(daemon.child);
});

/* ---- tests ----------------------------------------------------------------------------------- */

test('a .gltf chosen without its .bin is not sent: the message names the file and suggests .glb', { timeout: 30000 }, async () => {
  const gen = (await http('GET', '/v1/scene')).json.generation;
  const n = posts.length;
  await page.locator('#upload-file').setInputFiles([sceneFiles().gltf]);
  await page.waitForFunction(() => !document.getElementById('upload-error').hidden, null, { timeout: 10000 });
  const msg = await page.locator('#upload-error .msg').textContent();
  assert.match(msg, /scene\.bin/);
  assert.match(msg, /\.glb/);
  assert.match(await page.locator('#upload-error').textContent(), /scene\.gltf was not loaded/);
  assert.equal(posts.slice(n).filter((p) => p.method === 'PUT').length, 0, 'nothing was uploaded');
  assert.equal((await http('GET', '/v1/scene')).json.generation, gen);
  await shot(page, 'scene-missing-bin.png');
});

test('a .gltf with its .bin and image, chosen together, is packed into a .glb and loads; the file name shows', { timeout: 60000 }, async () => {
  const { gltf, bin, png } = sceneFiles();
  const n = posts.length;
  await page.locator('#upload-file').setInputFiles([gltf, bin, png]);
  await page.waitForFunction(() => [...document.querySelectorAll('.toast.ok')].some((t) => /Loaded scene\.gltf/.test(t.textContent)),
    null, { timeout: 30000 });
  const put = await until(() => posts.slice(n).find((p) => p.method === 'PUT'), 'the PUT request', 5000);
  assert.equal(put.path, '/v1/scene?name=scene.gltf');
  const sc = (await http('GET', '/v1/scene')).json;
  assert.equal(sc.file_name, 'scene.gltf');
  assert.equal(sc.triangles, 14);
  assert.equal(sc.node_count, 5);
  assert.equal(sc.light_count, 1);
  assert.equal(sc.texture_count, 1, 'the image went into the .glb');
  await showPanel(page, 'panel-scene');
  assert.equal(await page.locator('#scene-file').textContent(), 'scene.gltf');
  assert.equal(await page.locator('#upload-error').isHidden(), true);
});

test('the node tree lists the nodes with their hierarchy', { timeout: 30000 }, async () => {
  await showPanel(page, 'panel-nodes');
  await page.waitForFunction(() => document.querySelectorAll('#node-tree .node-row').length === 5, null, { timeout: 10000 });
  const rows = await page.$$eval('#node-tree .node-row', (els) => els.map((e) => ({
    id: Number(e.dataset.id), name: e.textContent, level: Number(e.getAttribute('aria-level')) })));
  assert.deepEqual(rows.map((r) => r.name), ['floor', 'group', 'box', 'lamp', 'cam']);
  assert.equal(rows.find((r) => r.name === 'box').level, 2, 'box is under group');
  assert.equal(rows.find((r) => r.name === 'group').level, 1);
  assert.match(await page.locator('#node-count').textContent(), /5/);
  await shot(page, 'scene-tree.png');
});

test('clicking the picture selects the node under the cursor; the sky selects nothing', { timeout: 40000 }, async () => {
  // the page has the scene's camera (it looks at the box)
  await page.waitForFunction(() => window.probecast.state().restored && window.probecast.camera.known, null, { timeout: 20000 });
  await closePanels();
  const rect = await page.evaluate(() => window.probecast.view.pictureRect());
  const camBefore = await page.evaluate(() => window.probecast.camera.version);
  const n = posts.length;
  await page.mouse.click(rect.left + rect.width / 2, rect.top + rect.height / 2);
  await page.waitForFunction((id) => window.probecast.sceneTree.selected === id, BOX, { timeout: 15000 });
  const pick = await until(() => posts.slice(n).find((p) => /\/v1\/views\/\d+\/pick$/.test(p.path)), 'the pick request', 5000);
  const own = (await page.evaluate(() => window.probecast.state())).ownView;
  assert.equal(pick.path, `/v1/views/${own}/pick`);
  const body = JSON.parse(pick.body);
  assert.ok(Math.abs(body.x - 0.5) < 0.01 && Math.abs(body.y - 0.5) < 0.01, pick.body);
  assert.equal(await page.evaluate(() => window.probecast.camera.version), camBefore, 'a click does not orbit');
  await showPanel(page, 'panel-nodes');
  assert.equal(await page.locator(`#node-tree .node-row[data-id="${BOX}"]`).getAttribute('aria-selected'), 'true');
  assert.match(await page.locator('#node-title').textContent(), /box/);
  assert.equal(await page.locator('#node-edit').isHidden(), false);
  // the top of the picture is sky: nothing is selected
  await closePanels();
  await page.mouse.click(rect.left + rect.width / 2, rect.top + 4);
  await page.waitForFunction(() => window.probecast.sceneTree.selected === null, null, { timeout: 15000 });
  // a drag orbits and picks nothing
  const before = posts.length;
  await mouseDrag({ x: rect.left + rect.width / 2, y: rect.top + rect.height / 2 }, { x: rect.left + rect.width / 2 + 40, y: rect.top + rect.height / 2 });
  await sleep(500);
  assert.equal(posts.slice(before).filter((p) => /pick$/.test(p.path)).length, 0, 'a drag is not a click');
  // back to the scene's camera, and select the box again from the tree
  await page.evaluate(async () => {
    const p = window.probecast;
    p.camera.setFromServer(await p.api.get('/v1/camera'));
    p.controls.onChange();
  });
  await showPanel(page, 'panel-nodes');
  await page.locator(`#node-tree .node-row[data-id="${BOX}"]`).click();
  await page.waitForFunction((id) => window.probecast.sceneTree.selected === id, BOX, { timeout: 5000 });
});

test('editing a translation field sends PATCH and the node moves', { timeout: 30000 }, async () => {
  await showPanel(page, 'panel-nodes');
  const x = page.locator('#node-t input').first();
  await x.fill('0.3');
  await until(async () => (await node(BOX)).translation[0] === 0.3, 'GET /v1/scene to show the box at x = 0.3', 10000);
  // playwright reports the page's requests asynchronously: the answer may be in first
  await until(() => posts.some((p) => p.method === 'PATCH' && p.path === `/v1/nodes/${BOX}`), 'PATCH /v1/nodes/{id} sent', 5000);
  const world = (await http('GET', `/v1/nodes/${BOX}`)).json.world_translation;
  assert.deepEqual(world, [0.3, 0.5, 0]);
  // the rotation field in degrees becomes a quaternion about y
  const ry = page.locator('#node-r input').nth(1);
  await ry.fill('90');
  await until(async () => Math.abs((await node(BOX)).rotation[1] - Math.SQRT1_2) < 1e-4, 'a 90 degree turn about y', 10000);
  await page.locator('#node-r input').nth(1).fill('0');
  await until(async () => Math.abs((await node(BOX)).rotation[1]) < 1e-6, 'the turn undone', 10000);
});

test('dragging the gizmo\'s x arrow moves the box along x', { timeout: 30000 }, async () => {
  await closePanels();
  await page.waitForFunction(() => window.probecast.gizmo.handles.length === 3, null, { timeout: 10000 });
  const before = (await node(BOX)).translation;
  const camBefore = await page.evaluate(() => window.probecast.camera.version);
  const { handles } = await overlay();
  const xArrow = handles.find((h) => h.kind === 'axis' && h.axis === 0);
  const [o, tip] = xArrow.pts;
  // half an arrow's length further along the arrow
  await mouseDrag(tip, { x: tip.x + (tip.x - o.x) / 2, y: tip.y + (tip.y - o.y) / 2 });
  await until(async () => {
    const t = (await node(BOX)).translation;
    return t[0] > before[0] + 0.05 && Math.abs(t[1] - before[1]) < 1e-6 && Math.abs(t[2] - before[2]) < 1e-6;
  }, 'the box to move along x only', 10000);
  assert.equal(await page.evaluate(() => window.probecast.camera.version), camBefore, 'the camera did not orbit');
  await shot(page, 'scene-gizmo-move.png');
});

test('dragging a ring of the rotate gizmo turns the box', { timeout: 30000 }, async () => {
  await page.evaluate(() => window.probecast.gizmo.setMode('rotate'));
  const { handles } = await overlay();
  const ring = handles.find((h) => h.kind === 'ring' && h.axis === 1);
  const a = ring.pts[Math.floor(ring.pts.length / 8)], b = ring.pts[Math.floor(ring.pts.length / 4)];
  await mouseDrag(a, b);
  await until(async () => Math.abs((await node(BOX)).rotation[1]) > 0.05, 'the box to turn about y', 10000);
  const q = (await node(BOX)).rotation;
  assert.ok(Math.abs(q[0]) < 1e-4 && Math.abs(q[2]) < 1e-4, `a turn about y only: ${q}`);
  await page.evaluate(() => window.probecast.gizmo.setMode('move'));
});

test('the light is drawn as an icon and dragging it moves the light', { timeout: 30000 }, async () => {
  await closePanels();
  const l0 = (await http('GET', '/v1/lights')).json.lights[0];
  const { lights } = await overlay();
  const icon = lights.find((l) => l.id === l0.id);
  assert.ok(icon, 'the light has an icon');
  await mouseDrag(icon, { x: icon.x - 60, y: icon.y });
  await until(async () => (await http('GET', '/v1/lights')).json.lights[0].position[0] < l0.position[0] - 0.1,
    'the light to move left', 10000);
  await until(() => posts.some((p) => p.method === 'PATCH' && p.path === `/v1/lights/${l0.id}`), 'PATCH /v1/lights/{id} sent', 5000);
  await shot(page, 'scene-light-drag.png');
});

test('a folder holding the .gltf, its .bin and a sub-folder with the image uploads as one .glb', { timeout: 60000 }, async () => {
  const dir = fs.mkdtempSync(path.join(OUT, 'scene-folder-'));
  const { gltf, bin, png } = sceneFiles();
  fs.mkdirSync(path.join(dir, 'model', 'tex'), { recursive: true });
  fs.writeFileSync(path.join(dir, 'model', gltf.name), gltf.buffer);
  fs.writeFileSync(path.join(dir, 'model', bin.name), bin.buffer);
  fs.writeFileSync(path.join(dir, 'model', 'tex', png.name), png.buffer);
  const gen = (await http('GET', '/v1/scene')).json.generation;
  const n = posts.length;
  await page.locator('#upload-folder').setInputFiles(path.join(dir, 'model'));
  await until(async () => (await http('GET', '/v1/scene')).json.generation > gen, 'the folder\'s scene to load', 30000);
  const put = await until(() => posts.slice(n).find((p) => p.method === 'PUT'), 'the PUT request', 5000);
  assert.equal(put.path, '/v1/scene?name=scene.gltf');
  const sc = (await http('GET', '/v1/scene')).json;
  assert.equal(sc.file_name, 'scene.gltf');
  assert.equal(sc.triangles, 14);
  assert.equal(sc.texture_count, 1);
  fs.rmSync(dir, { recursive: true, force: true });
});

test('phone: the Nodes tab opens the tree in the bottom sheet with 44 px rows and controls', { timeout: 60000 }, async () => {
  const ctx = await browser.newContext({ viewport: { width: 390, height: 760 }, deviceScaleFactor: 1, hasTouch: true, isMobile: true });
  const p = await ctx.newPage();
  p.on('pageerror', (e) => pageErrors.push(e.message));
  try {
    await p.goto(page.url().replace(/#.*$/, ''));
    await p.waitForFunction(() => window.probecast && window.probecast.state().frames >= 1, null, { timeout: 60000 });
    assert.ok(await p.evaluate(() => document.body.classList.contains('layout-phone')));
    await p.locator('#toolbar [data-panel="panel-nodes"]').tap();
    await p.waitForFunction(() => document.querySelectorAll('#node-tree .node-row').length === 5, null, { timeout: 10000 });
    await p.locator(`#node-tree .node-row[data-id="${BOX}"]`).tap();
    await p.locator('#node-edit').waitFor({ state: 'visible', timeout: 5000 });
    const small = await p.evaluate(() => [...document.querySelectorAll('#node-tree .node-row, #gizmo-modes button, #node-edit input')]
      .map((e) => e.getBoundingClientRect()).filter((r) => r.width > 0 && r.height < 44).length);
    assert.equal(small, 0, 'every row, button and field is at least 44 px high');
    await shot(p, 'scene-phone.png');
  } finally {
    await ctx.close();
  }
});

test('no uncaught errors in the page', () => {
  assert.deepEqual(pageErrors, []);
});
