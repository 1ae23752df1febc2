// util.mjs: what the browser tests (viewer.test.mjs, scene.test.mjs) share: Chromium's flags,
// waiting, starting and stopping a daemon, and a JSON HTTP client.

import { spawn } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import readline from 'node:readline';

export const CHROMIUM_ARGS = ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
  '--disable-background-networking', '--disable-component-update', '--disable-sync'];

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
