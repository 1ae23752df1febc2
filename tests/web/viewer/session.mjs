// The viewer tests' one session (viewer.test.mjs imports the topic files in order; each imports
// this): the daemon run.sh started, the browser, page A and its context, what every page
// reported, and the helpers bound to them. Started by tests/web/run.sh, which runs the daemon
// and passes it in PCWEB_* variables:
//   PCWEB_HTTP, PCWEB_WS   bound addresses          PCWEB_PIDFILE  the daemon's pid (rewritten
//   PCWEB_EXE, PCWEB_ARGS  its command (JSON argv)                 after the restart test)
//   PCWEB_OUT              screenshots and logs     PCWEB_CHROMIUM, PCWEB_ROOT

import { after, before } from 'node:test';
import assert from 'node:assert/strict';
import {
  MAX_PIXELS, VIEWPORT, httpClient, launchChromium, recordSockets, serverSize, sleep, startDaemon as launch, stopDaemon, until,
} from '../util.mjs';

export const env = process.env;
for (const k of ['PCWEB_HTTP', 'PCWEB_PIDFILE', 'PCWEB_EXE', 'PCWEB_ARGS', 'PCWEB_OUT']) {
  if (!env[k]) throw new Error(`${k} is not set: run this through tests/web/run.sh`);
}
export const BASE = `http://${env.PCWEB_HTTP}`;
const OUT = env.PCWEB_OUT;
// Lavapipe: keep the render tiny. The server scales a viewer's size down to max_pixels; the
// daemon starts at exactly the size the 960x600 page will ask for, so the render size does not
// change while frames are in flight unless a test means it to. (Drags now change it: the viewer
// asks for half the pixels while the camera moves; renderer/view.c's ensure_size() waits for the
// device before it frees the old images, so a readback in flight is safe. The resize test still
// resizes while the server idles.)
export const RENDER = serverSize(VIEWPORT.width, VIEWPORT.height, MAX_PIXELS);

export let browser, context, page;
export const pageErrors = [];
export const requests = new Map(); // page -> [{ t, method, path }] of every HTTP request it made
export const spawned = []; // daemons started here, stopped in after()
export const http = httpClient(BASE);
/* Starts probecast with args; resolves { child, http, ws } after its first stdout line. */
export const startDaemon = (args, logName) => launch(env.PCWEB_EXE, OUT, args, logName, (c) => spawned.push(c));

/* ---- helpers -------------------------------------------------------------------------------- */

export const state = (p = page) => p.evaluate(() => window.probecast.state());

/* Waits until page A has drawn a frame newer than frameId (of the current connection). */
export async function waitDrawnAfter(frameId, timeoutMs = 20000) {
  await page.waitForFunction((id) => window.probecast.state().drawnId > id, frameId, { timeout: timeoutMs });
  return state();
}

/* Waits for a frame newer than frameId, then until the server idles (input stopped, probes
 * converged: its last still frame is out), then for that frame to be drawn. */
export async function settleAfter(frameId, timeoutMs = 30000) {
  await waitDrawnAfter(frameId, timeoutMs);
  await until(async () => (await http('GET', '/v1/stats')).json.rendering === false, 'the server to idle', timeoutMs, 200);
  await sleep(400);
  return state();
}

/* A new page in ctx whose uncaught errors go to pageErrors and whose HTTP requests to requests. */
export async function newViewerPage(ctx) {
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

/* The camera of a view through the HTTP API. */
export const viewCamera = async (id) => {
  const r = await http('GET', `/v1/views/${id}/camera`);
  assert.equal(r.status, 200, r.text);
  return r.json;
};

/* Waits until page p draws a frame of view `viewId` at `size` ({ width, height }). */
export async function waitViewFrame(p, viewId, size, timeoutMs = 20000) {
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
  browser = await launchChromium();
  context = await browser.newContext({ viewport: VIEWPORT, deviceScaleFactor: 1 });
  await recordSockets(context);
  page = await newViewerPage(context);
});

after(async () => {
  if (browser) await browser.close().catch(() => {});
  for (const c of spawned) await stopDaemon(c);
});
