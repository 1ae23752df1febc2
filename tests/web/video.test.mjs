// Browser test of the viewer's video path (web/js/video.js; issue 26) in Debian's headless
// Chromium, against a daemon of its own on lavapipe. Started by tests/web/run.sh after
// scene.test.mjs, with PCWEB_EXE, PCWEB_OUT and PCWEB_ROOT set.
//
// This Chromium's WebCodecs decodes VP9 (VideoDecoder.isConfigSupported says so on a secure
// origin such as http://127.0.0.1): the page on 'auto' asks for VP9, frames whose header says
// VP9 are decoded and drawn into the canvas (a picture, not a flat colour), the still after the
// camera stops is JPEG; the quality menu's JPEG choice tells the server and frames are JPEG
// again; a decoder error falls back to JPEG by itself.

import { after, before, test } from 'node:test';
import assert from 'node:assert/strict';
import path from 'node:path';
import {
  MAX_PIXELS, VIEWPORT, httpClient, launchChromium, pixels, shot, showPanel, startDaemon, stopDaemon, summary, until,
} from './util.mjs';

const env = process.env;
for (const k of ['PCWEB_EXE', 'PCWEB_OUT', 'PCWEB_ROOT']) {
  if (!env[k]) throw new Error(`${k} is not set: run this through tests/web/run.sh`);
}
const OUT = env.PCWEB_OUT;

let daemon, http, browser, page;
const pageErrors = [];

before(async () => {
  daemon = await startDaemon(env.PCWEB_EXE, OUT, ['serve', '--http', '127.0.0.1:0', '--ws', '127.0.0.1:0', '--width', '156', '--height', '97',
    '--gi', 'off', '--no-animate', '--encoders', '1', '--max-fps', '20', '--scene', 'builtin:cornell',
    '--web-dir', path.join(env.PCWEB_ROOT, 'web')], 'daemon-video.log');
  http = httpClient(`http://${daemon.http}`);
  assert.equal((await http('PATCH', '/v1/settings', { max_pixels: MAX_PIXELS })).status, 200);
  browser = await launchChromium();
  const context = await browser.newContext({ viewport: VIEWPORT, deviceScaleFactor: 1 });
  await context.addInitScript(() => {
    window.__frames = [];
    window.__sentVideo = [];
    const send = WebSocket.prototype.send;
    WebSocket.prototype.send = function (d) {
      if (typeof d === 'string' && d.includes('"video"')) window.__sentVideo.push(JSON.parse(d));
      return send.call(this, d);
    };
  });
  page = await context.newPage();
  page.on('pageerror', (e) => pageErrors.push(e.message));
  await page.goto(`http://${daemon.http}/`);
  await page.waitForFunction(() => window.probecast && window.probecast.stream, null, { timeout: 10000 });
  await page.evaluate(() => window.probecast.stream.addEventListener('frame', (e) =>
    window.__frames.push({ id: e.detail.frameId, format: e.detail.format, key: e.detail.key, still: e.detail.still })));
});

after(async () => {
  if (browser) await browser.close().catch(() => {});
  if (daemon) await stopDaemon(daemon.child);
});

/* Moves the camera a little every 60 ms for ms (the page's own stream, as a drag would). */
const orbit = (ms) => page.evaluate(async (ms) => {
  const s = window.probecast.stream;
  const end = performance.now() + ms;
  for (let i = 0; performance.now() < end; i++) {
    s.sendCamera({ position: [-1 + 0.02 * (i % 100), 1.5, 3.5], target: [0, 0.5, 0] });
    await new Promise((r) => setTimeout(r, 60));
  }
}, ms);

/* Keeps the camera moving (orbit, half a second at a time) until cond() holds, or throws after
 * timeoutMs: frames are video only while the camera moves (the still after it stops is JPEG),
 * and on a loaded machine a fixed orbit may end before the frames that were asked for came. */
const orbitUntil = async (cond, what, timeoutMs) => {
  let moving = true;
  const mover = (async () => { while (moving) await orbit(500); })();
  try {
    await until(cond, what, timeoutMs);
  } finally {
    moving = false;
    await mover;
  }
};

test('auto asks for VP9 and draws decoded video frames into the canvas', { timeout: 90000 }, async () => {
  const codec = await page.evaluate(async () => (await import('/js/video.js')).probeVideoCodec());
  assert.equal(codec, 'vp9', 'this Chromium decodes VP9 with WebCodecs');
  await until(async () => (await page.evaluate(() => window.__sentVideo.length)) >= 1, 'a video request', 15000);
  const req = await page.evaluate(() => window.__sentVideo[0]);
  assert.deepEqual(req, { type: 'video', codec: 'vp9', max_kbps: null });
  const n = await page.evaluate(() => window.__frames.length);
  await orbitUntil(async () => (await page.evaluate((n) => window.__frames.slice(n).filter((f) => f.format === 2).length, n)) >= 5,
    'five VP9 frames drawn', 40000);
  const frames = await page.evaluate((n) => window.__frames.slice(n), n);
  const video = frames.filter((f) => f.format === 2);
  assert.ok(video[0].key, 'the first VP9 frame drawn is a key frame');
  const pix = summary(await pixels(page));
  assert.ok(pix.std > 12, `the canvas shows the decoded picture (std ${pix.std.toFixed(1)})`);
  await shot(page, 'video.png');
  // the still after the camera stops comes as JPEG
  await until(async () => {
    const f = await page.evaluate(() => window.__frames[window.__frames.length - 1]);
    return f.format === 0 && f.still;
  }, 'a JPEG still after the camera stopped', 10000);
  const st = await page.evaluate(() => window.probecast.stream.counters);
  assert.equal(st.decodeErrors, 0);
  assert.deepEqual(pageErrors, []);
});

test('the quality menu\'s JPEG choice returns to JPEG; video again after', { timeout: 90000 }, async () => {
  await showPanel(page, 'panel-quality');
  const k = await page.evaluate(() => window.__sentVideo.length);
  await page.locator('#video-mode button[data-value="jpeg"]').click();
  await until(async () => (await page.evaluate((k) => window.__sentVideo.slice(k), k)).some((m) => m.codec === null), 'codec null sent', 5000);
  let n = await page.evaluate(() => window.__frames.length);
  await orbit(1500);
  await until(async () => (await page.evaluate((n) => window.__frames.slice(n).length, n)) >= 3, 'frames', 15000);
  let frames = await page.evaluate((n) => window.__frames.slice(n), n);
  assert.ok(frames.every((f) => f.format === 0), `JPEG only: ${JSON.stringify(frames.map((f) => f.format))}`);
  // counted before the click: a VP9 frame may arrive before the next evaluate returns
  n = await page.evaluate(() => window.__frames.length);
  await page.locator('#video-mode button[data-value="auto"]').click();
  await orbitUntil(async () => (await page.evaluate((n) => window.__frames.slice(n).filter((f) => f.format === 2).length, n)) >= 3,
    'VP9 again', 30000);
  frames = await page.evaluate((n) => window.__frames.slice(n).filter((f) => f.format === 2), n);
  assert.ok(frames[0].key, 'a new stream starts with a key frame');
});

test('a decoder error falls back to JPEG and tells the server', { timeout: 60000 }, async () => {
  const k = await page.evaluate(() => window.__sentVideo.length);
  // what a decoder error does: VideoPath calls onError
  await page.evaluate(() => window.probecast.stream.video.fail(new Error('test: decoder failed')));
  await until(async () => (await page.evaluate((k) => window.__sentVideo.slice(k), k)).some((m) => m.codec === null), 'codec null sent', 5000);
  const n = await page.evaluate(() => window.__frames.length);
  await orbit(1500);
  await until(async () => (await page.evaluate((n) => window.__frames.slice(n).length, n)) >= 3, 'frames', 15000);
  const frames = await page.evaluate((n) => window.__frames.slice(n), n);
  assert.ok(frames.every((f) => f.format === 0), `JPEG after the error: ${JSON.stringify(frames.map((f) => f.format))}`);
  assert.deepEqual(pageErrors, []);
});
