// Views: one world, many views (protocol/stream.md, version 2). A second page (B) joins page A:
// each has a view of its own at its own size; B follows A's view and returns; a followed view
// that goes away, an unknown view; world changes reach both pages as events; a hidden page lets
// its view go; B closes.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { dist3, drag, MAX_PIXELS, pixels, serverSize, shot, showPanel, sleep, summary, until } from '../util.mjs';
import { BASE, context, http, newViewerPage, page, RENDER, requests, state, viewCamera, waitViewFrame } from './session.mjs';

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
  await showPanel(page, 'panel-views');
  await showPanel(pageB, 'panel-views');
  await page.locator(`#views .view-row[data-id="${b.ownView}"] button[data-follow]`).waitFor({ timeout: 10000 });
  await pageB.locator(`#views .view-row[data-id="${a.ownView}"] button[data-follow]`).waitFor({ timeout: 10000 });
  assert.match(await page.locator(`#views .view-row[data-id="${b.ownView}"]`).textContent(), new RegExp(`${RENDER_B.width}×${RENDER_B.height}`));
  assert.equal(await page.locator(`#views .view-row[data-id="${a.ownView}"]`).count(), 0, 'the own view is not in the list');
  await shot(page, 'views-a.png');
  await shot(pageB, 'views-b.png');
});

test('dragging in one page does not move the other page\'s view', { timeout: 60000 }, async (t) => {
  const a0 = await state(), b0 = await state(pageB);
  const camA0 = await viewCamera(a0.ownView), camB0 = await viewCamera(b0.ownView);
  const sentB = await pageB.evaluate(() => window.__sent.length);
  const sentA = await page.evaluate(() => window.__sent.length);
  await drag(page, -150, 30);
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
  await showPanel(pageB, 'panel-views');
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
  await shot(pageB, 'following.png');
  // A moves: B sees it (a newer frame of A's view; followers get input_seq 0).
  const fromB = b.drawnId;
  const sentA = await page.evaluate(() => window.__sent.length);
  await drag(page, 60, -20);
  await pageB.waitForFunction((id) => {
    const s = window.probecast.state();
    return s.header.viewId === id.view && s.drawnId > id.after;
  }, { view: a.ownView, after: fromB }, { timeout: 20000 });
  assert.equal((await state(pageB)).header.inputSeq, 0);
  // Camera input on B while following is not sent: the drag does nothing.
  const sentB = await pageB.evaluate(() => window.__sent.length);
  const versionB = await pageB.evaluate(() => window.probecast.camera.version);
  await drag(pageB, 100, 20);
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
  await drag(pageB, -80, 0);
  await until(async () => dist3((await viewCamera(b0.ownView)).position, camB0.position) > 0.05, 'B\'s view to move after following', 10000);
});

test('a follower returns to its own view when the followed view goes away', { timeout: 60000 }, async () => {
  const pageC = await newViewerPage(context);
  try {
    await pageC.setViewportSize({ width: 320, height: 200 });
    await pageC.goto(BASE + '/');
    await pageC.waitForFunction(() => window.probecast.state().frames >= 1, null, { timeout: 30000 });
    const c = await state(pageC), b0 = await state(pageB);
    await showPanel(pageB, 'panel-views');
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
    await showPanel(p, 'panel-lights');
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
