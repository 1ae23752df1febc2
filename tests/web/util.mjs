// util.mjs: what the browser tests (viewer.test.mjs with viewer/*.mjs, scene.test.mjs) share:
// Chromium and the page size, waiting, starting and stopping a daemon, a JSON HTTP client, and
// helpers that act on a page given to them (panels, screenshots, drags, the canvas's pixels).
// Nothing here holds a suite's state: viewer/session.mjs holds the viewer tests' browser and pages.

import { spawn } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import readline from 'node:readline';
import { chromium } from 'playwright-core';

export const CHROMIUM_ARGS = ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
  '--disable-background-networking', '--disable-component-update', '--disable-sync'];

/* The page size of both suites and the render size cap: 156 x 97 for the 960 x 600 page, the size
 * run.sh starts its daemon at (lavapipe shares two cores with Chromium). */
export const VIEWPORT = { width: 960, height: 600 };
export const MAX_PIXELS = 15360;

/* The render size the server picks for a viewer of w x h CSS pixels at dpr 1 (render_loop.c). */
export function serverSize(w, h, maxPixels) {
  if (w * h > maxPixels) {
    const k = Math.sqrt(maxPixels / (w * h));
    w = Math.floor(w * k);
    h = Math.floor(h * k);
  }
  return { width: Math.min(4096, Math.max(16, w)), height: Math.min(4096, Math.max(16, h)) };
}

/* Debian's headless Chromium (PCWEB_CHROMIUM, set by run.sh, or /usr/bin/chromium). */
export const launchChromium = () =>
  chromium.launch({ executablePath: process.env.PCWEB_CHROMIUM || '/usr/bin/chromium', args: CHROMIUM_ARGS });

export const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

/* Polls fn until it returns something truthy (returned), or throws after timeoutMs. */
export async function until(fn, what, timeoutMs = 20000, everyMs = 100) {
  const end = Date.now() + timeoutMs;
  let last;
  while (Date.now() < end) {
    last = await fn();
    if (last) return last;
    await sleep(everyMs);
  }
  throw new Error(`timed out after ${timeoutMs} ms waiting for ${what}`);
}

/* http(method, url, body, headers) -> { status, json, text }: url is absolute or a path under
 * base; a Uint8Array body goes as it is, anything else as JSON. */
export function httpClient(base) {
  return async function http(method, url, body, headers = {}) {
    const res = await fetch(url.startsWith('http') ? url : base + url, {
      method,
      headers: body !== undefined && !(body instanceof Uint8Array) ? { 'Content-Type': 'application/json', ...headers } : headers,
      body: body === undefined ? undefined : body instanceof Uint8Array ? body : JSON.stringify(body),
    });
    const text = await res.text();
    let json = null;
    try { json = text ? JSON.parse(text) : null; } catch { /* not JSON */ }
    return { status: res.status, json, text };
  };
}

/* Starts the probecast executable exe with args, its stderr appended to out/logName; resolves
 * { child, http, ws } after its first stdout line. onSpawn(child) runs at once (to stop it
 * later even when the start fails). */
export function startDaemon(exe, out, args, logName, onSpawn = () => {}) {
  return new Promise((resolve, reject) => {
    const log = fs.openSync(path.join(out, logName), 'a');
    const child = spawn(exe, args, { stdio: ['ignore', 'pipe', log] });
    onSpawn(child);
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

/* SIGTERM, up to 10 s, then SIGKILL. */
export async function stopDaemon(child) {
  if (child.exitCode !== null || child.signalCode !== null) return;
  const exited = new Promise((r) => child.once('exit', r));
  child.kill('SIGTERM');
  await Promise.race([exited, sleep(10000)]);
  if (child.exitCode === null && child.signalCode === null) child.kill('SIGKILL');
}

/* A process is alive while /proc has it and it is not a zombie. */
export function alive(pid) {
  try {
    const stat = fs.readFileSync(`/proc/${pid}/stat`, 'utf8');
    return !/^\d+ \(.*\) Z /.test(stat);
  } catch {
    return false;
  }
}

/* ---- on a page ---------------------------------------------------------------------------- */

/* A screenshot of page p, as name in PCWEB_OUT. */
export async function shot(p, name) {
  await p.screenshot({ path: path.join(process.env.PCWEB_OUT, name) });
}

/* Shows panel `id` (e.g. 'panel-lights') on page p. The 960 x 600 page has the compact layout: its
 * toolbar opens one panel at a time over the picture (layout.js); on the desktop layout the
 * panel's title opens it in the column. */
export async function showPanel(p, id) {
  const shown = () => p.evaluate((pid) => {
    const d = document.getElementById(pid);
    return d.open && d.getBoundingClientRect().height > 0;
  }, id);
  if (await shown()) return;
  if (await p.evaluate(() => document.body.classList.contains('layout-desktop'))) await p.locator(`#${id} > summary`).click();
  else await p.locator(`#toolbar [data-panel="${id}"]`).click();
  await until(shown, `panel ${id} to show`, 5000, 50);
}

/* Drags on page p's canvas from its centre by (dx, dy) in steps. */
export async function drag(p, dx, dy) {
  const vp = p.viewportSize() || VIEWPORT;
  const cx = vp.width / 2, cy = vp.height / 2;
  await p.mouse.move(cx, cy);
  await p.mouse.down();
  await p.mouse.move(cx + dx, cy + dy, { steps: 12 });
  await p.mouse.up();
}

/* Page p's canvas scaled to 96x60, as [r, g, b, r, g, b, ...]. */
export async function pixels(p) {
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

/* The mean colour and the standard deviation of pixels()' output. */
export function summary(rgb) {
  const n = rgb.length / 3;
  const mean = [0, 0, 0];
  for (let i = 0; i < rgb.length; i++) mean[i % 3] += rgb[i] / n;
  let v = 0;
  for (let i = 0; i < rgb.length; i++) v += (rgb[i] - mean[i % 3]) ** 2;
  return { mean, std: Math.sqrt(v / rgb.length) };
}

export function meanAbsDiff(a, b) {
  let s = 0;
  for (let i = 0; i < a.length; i++) s += Math.abs(a[i] - b[i]);
  return s / a.length;
}

export const dist3 = (a, b) => Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);

/* The share of page p's picture (the canvas) that something else covers: hit tests on an 8 px
 * grid (elements that let the pointer through, such as the fading hint line, do not count). */
export function coverage(p) {
  return p.evaluate(() => {
    const r = document.getElementById('view').getBoundingClientRect();
    let n = 0, covered = 0;
    for (let y = r.top + 4; y < r.bottom; y += 8) {
      for (let x = r.left + 4; x < r.right; x += 8) {
        n++;
        const e = document.elementFromPoint(x, y);
        if (!e || e.id !== 'view') covered++;
      }
    }
    return covered / n;
  });
}

/* Makes every page of browser context ctx record each text message it sends and receives on a
 * WebSocket (window.__sent, window.__recv) and count animation frames (window.__raf), to check
 * coalescing, the restore after a reconnect and the server's messages. */
export async function recordSockets(ctx) {
  await ctx.addInitScript(() => {
    window.__sent = [];
    window.__recv = [];
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
    const WS = WebSocket;
    window.WebSocket = class extends WS {
      constructor(...args) {
        super(...args);
        this.addEventListener('message', (e) => {
          if (typeof e.data !== 'string') return;
          try { window.__recv.push({ t: performance.now(), m: JSON.parse(e.data) }); } catch { /* ignore */ }
        });
      }
    };
  });
}
