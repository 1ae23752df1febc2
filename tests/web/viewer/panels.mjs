// The panels that change the world: a light's colour and intensity, adding and deleting lights,
// GI mode and the probe view, and the environment (gradient, HDR and EXR uploads).

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { pixels, shot, showPanel, sleep, summary, until } from '../util.mjs';
import { http, page, settleAfter, state, waitDrawnAfter } from './session.mjs';

test('a light edit in the panel changes the picture', { timeout: 90000 }, async (t) => {
  await showPanel(page, 'panel-lights');
  const card = page.locator('#lights details.light').first();
  await card.waitFor({ timeout: 10000 });
  const id = Number(await card.getAttribute('data-id'));
  // Let the frames of the drag settle first, then compare against the last one.
  await settleAfter(0);
  const before = summary(await pixels(page));
  const patched = page.waitForResponse((r) => r.url().endsWith(`/v1/lights/${id}`) && r.request().method() === 'PATCH');
  await card.locator('input[type=color]').fill('#ff2000');
  const res = await patched;
  assert.equal(res.status(), 200);
  await settleAfter((await state()).drawnId);
  await shot(page, 'light-red.png');
  const light = (await http('GET', `/v1/lights/${id}`)).json;
  assert.ok(light.color[0] > 0.9 && light.color[1] < 0.05 && light.color[2] < 0.01, `colour set: ${light.color}`);
  const afterColour = summary(await pixels(page));
  const ratio = (m) => m[1] / Math.max(1, m[0]);
  assert.ok(ratio(afterColour.mean) < ratio(before.mean) * 0.8,
    `green/red fell under a red light: ${ratio(before.mean).toFixed(2)} -> ${ratio(afterColour.mean).toFixed(2)}`);
  // Intensity through the number field: a much dimmer light darkens the picture.
  const dimmed = page.waitForResponse((r) => r.url().endsWith(`/v1/lights/${id}`) && r.request().method() === 'PATCH');
  await card.locator('input[aria-label="intensity value"]').fill('0.05');
  await dimmed;
  await settleAfter((await state()).drawnId);
  await shot(page, 'light-dim.png');
  const dim = summary(await pixels(page));
  assert.equal((await http('GET', `/v1/lights/${id}`)).json.intensity, 0.05);
  assert.ok(dim.mean[0] < afterColour.mean[0] * 0.75, `dimmer: red ${afterColour.mean[0].toFixed(1)} -> ${dim.mean[0].toFixed(1)}`);
  t.diagnostic(`mean rgb: white ${before.mean.map(Math.round)}, red ${afterColour.mean.map(Math.round)}, dim ${dim.mean.map(Math.round)}`);
  // Put it back (white, as bright as before) for the tests that follow.
  await http('PATCH', `/v1/lights/${id}`, { color: [1, 1, 1], intensity: 3 });
});

test('lights are added and deleted through the panel', { timeout: 30000 }, async () => {
  const count = async () => (await http('GET', '/v1/lights')).json.lights.length;
  const n0 = await count();
  await showPanel(page, 'panel-lights');
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

test('the rendering panel switches GI mode and the probe view', { timeout: 120000 }, async () => {
  await showPanel(page, 'panel-render');
  const pt = page.locator('#gi-modes button[data-value=pathtrace]');
  assert.equal(await pt.isDisabled(), false, 'the API offers gi_mode pathtrace');
  await pt.click();
  await until(async () => (await http('GET', '/v1/settings')).json.gi_mode === 'pathtrace', 'gi_mode pathtrace');
  // the panel marks the mode once the server's answer arrives (it may trail the settings)
  await until(async () => (await pt.getAttribute('aria-checked')) === 'true', 'path trace checked');
  await waitDrawnAfter((await state()).drawnId + 1);
  await shot(page, 'pathtrace.png');
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
  await shot(page, 'probes.png');
  // P toggles the probe view back.
  await page.locator('#view').focus();
  await page.keyboard.press('p');
  await until(async () => (await http('GET', '/v1/settings')).json.view === 'final', 'view final');
  await page.locator('#gi-modes button[data-value=ddgi]').click();
  await until(async () => (await http('GET', '/v1/settings')).json.gi_mode === 'ddgi', 'gi_mode ddgi');
  // probe paths: shown with probes, sent as probe_paths, checked from the server's settings
  await page.locator('#probe-paths-row').waitFor({ state: 'visible', timeout: 5000 });
  assert.equal(await page.locator('#probe-paths button[data-value="0"]').getAttribute('aria-checked'), 'true');
  await page.locator('#probe-paths button[data-value="3"]').click();
  await until(async () => (await http('GET', '/v1/settings')).json.probe_paths === 3, 'probe_paths 3');
  await until(async () => (await page.locator('#probe-paths button[data-value="3"]').getAttribute('aria-checked')) === 'true', '3 checked');
  await page.locator('#probe-paths button[data-value="0"]').click();
  await until(async () => (await http('GET', '/v1/settings')).json.probe_paths === 0, 'probe_paths 0');
  // near-field rays: off on a CPU device, sent as near_field, checked from the server's settings
  await page.locator('#near-field-row').waitFor({ state: 'visible', timeout: 5000 });
  assert.equal(await page.locator('#near-field button[data-value="off"]').getAttribute('aria-checked'), 'true');
  await page.locator('#near-field button[data-value="on"]').click();
  await until(async () => (await http('GET', '/v1/settings')).json.near_field === 'on', 'near_field on');
  await until(async () => (await page.locator('#near-field button[data-value="on"]').getAttribute('aria-checked')) === 'true', 'on checked');
  await page.locator('#near-field button[data-value="off"]').click();
  await until(async () => (await http('GET', '/v1/settings')).json.near_field === 'off', 'near_field off');
  await page.locator('#gi-modes button[data-value=off]').click();
  await until(async () => await page.locator('#probe-paths-row').isHidden(), 'probe paths hidden with gi off');
  assert.ok(await page.locator('#near-field-row').isHidden(), 'near field hidden with gi off');
  await page.locator('#gi-modes button[data-value=ddgi]').click();
  await until(async () => (await http('GET', '/v1/settings')).json.gi_mode === 'ddgi', 'gi_mode ddgi again');
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
  await showPanel(page, 'panel-render');
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
