// The stream: the page loads from the daemon, frames arrive over probecast.v2 on the page's own
// view and are drawn and acknowledged, and the stats panel sees the probe field converge.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { pixels, shot, summary, until, VIEWPORT } from '../util.mjs';
import { BASE, http, page, pageErrors, RENDER, state } from './session.mjs';

test('the viewer page loads from the daemon', { timeout: 30000 }, async () => {
  const res = await fetch(BASE + '/');
  assert.equal(res.status, 200);
  assert.match(res.headers.get('content-type'), /^text\/html/);
  for (const f of ['/viewer.css', '/js/main.js', '/js/stream.js', '/js/camera.js', '/js/api.js', '/js/coalescer.js', '/js/colour.js',
    '/js/toasts.js', '/js/token_prompt.js', '/js/render_panel.js', '/js/lights_panel.js', '/js/views_panel.js', '/js/scene_panel.js',
    '/js/animation.js', '/js/dom.js', '/js/stats.js', '/js/graphs.js', '/js/layout.js', '/js/quality.js']) {
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
  const pix = summary(await pixels(page));
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
  await shot(page, 'loaded.png');
});

test('the stats panel shows the probe field converging, then converged', { timeout: 60000 }, async () => {
  const probes = page.locator('#st-probes');
  await page.waitForFunction(() => /\bconverged\b/.test(document.querySelector('#st-probes').textContent), null, { timeout: 50000 });
  const title = await probes.getAttribute('title');
  assert.match(title, /^awake 0, sleeping \d+, off \d+$/, `probe states in the tooltip: ${title}`);
});
