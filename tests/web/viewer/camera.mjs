// The camera: a drag orbits the page's own view (coalesced camera messages, frames that reflect
// the input); the URL carries the camera and the screenshot button downloads a still; wheel,
// right-drag, W and a two-finger pinch.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import { dist3, drag, meanAbsDiff, pixels, shot, sleep, until, VIEWPORT } from '../util.mjs';
import { BASE, context, http, newViewerPage, page, state, viewCamera, waitViewFrame } from './session.mjs';

test('dragging orbits the camera; frames reflect the input', { timeout: 40000 }, async () => {
  const own = (await state()).ownView;
  const camBefore = await viewCamera(own);
  const cam0Before = (await http('GET', '/v1/camera')).json;
  const s0 = await state();
  const pix0 = await pixels(page);
  const sentBefore = await page.evaluate(() => window.__sent.length);
  await drag(page, 140, 40);
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
  const diff = meanAbsDiff(pix0, await pixels(page));
  assert.ok(diff > 4, `the picture changed after the drag (mean difference ${diff.toFixed(1)})`);
  const camAfter = await viewCamera(own);
  const moved = dist3(camAfter.position, camBefore.position);
  assert.ok(moved > 0.1, `the camera of the page's view moved (${moved.toFixed(3)})`);
  const cam0After = (await http('GET', '/v1/camera')).json;
  assert.ok(dist3(cam0After.position, cam0Before.position) < 1e-6, 'the default view 0 (GET /v1/camera) stays');
  // The latency readout has a number now.
  await page.waitForFunction(() => /\d+ ms/.test(document.getElementById('st-latency').textContent), null, { timeout: 5000 });
  await shot(page, 'orbited.png');
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
