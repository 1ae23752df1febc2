// Layout, interactive resolution, quality menu, live stats (issue 13 items 1-3): the phone's
// bottom sheet and touch targets, the desktop and compact layouts, the keys help and full screen,
// half the pixels while dragging and the quality caps, the stats panel's rates and graphs. Each
// layout test opens a page of its own in a context of its own.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { coverage, drag, MAX_PIXELS, recordSockets, serverSize, shot, showPanel, sleep, until, VIEWPORT } from '../util.mjs';
import { BASE, browser, http, newViewerPage, page, pageErrors, state } from './session.mjs';

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
    await shot(p, 'phone-sheet.png');
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
      await shot(p, `layout-${vp.width}x${vp.height}.png`);
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
    await shot(p, 'keys-help.png');
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
    // hold the button until a frame of the reduced size arrives (a loaded machine may take
    // longer than the drag to render one)
    await p.waitForFunction((g) => window.__sizes.some((s) => s.w < g.width), granted, { timeout: 20000 });
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
    await showPanel(p, 'panel-quality');
    n = await p.evaluate(() => window.__sent.length);
    await p.locator('#res-scale button[data-scale="0.5"]').click();
    await p.waitForFunction((k) => window.__sent.slice(k).some((x) => x.m.type === 'resize'), n, { timeout: 5000 });
    assert.deepEqual((await resizesAfter(n)).map((x) => x.m), [{ type: 'resize', width: 640, height: 360, dpr: 1 }]);
    assert.equal(await p.locator('#res-scale button[data-scale="0.5"]').getAttribute('aria-checked'), 'true');
    // Interactive resolution off: a drag sends no resize.
    await p.locator('#interactive-res').uncheck();
    n = await p.evaluate(() => window.__sent.length);
    await drag(p, 100, 0);
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
    await drag(p, 80, 0);
    // A frame the daemon encoded before it read the caps may still be on its way (CI saw
    // 60,30,40 once): from the first frame at 50 or below, the caps hold for every frame.
    await p.waitForFunction(() => {
      const i = window.__q.findIndex((q) => q <= 50);
      return i >= 0 && window.__q.length - i >= 3;
    }, null, { timeout: 20000 });
    const qs = await p.evaluate(() => window.__q);
    const first = qs.findIndex((q) => q <= 50);
    assert.ok(qs.slice(first).every((q) => q <= 50), `frames at quality 50 at most once capped: ${qs}`);
    assert.ok(first <= 3, `at most three frames in flight before the caps: ${qs}`);
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
  await showPanel(page, 'panel-stats');
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
  await shot(page, 'stats-graphs.png');
});
