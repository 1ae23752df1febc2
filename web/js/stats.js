// stats.js: the Stats panel: the viewer's own numbers (frames drawn per second, input-to-frame
// latency, bit rate, the last frame's header), the server's (GET /v1/stats, polled once a second
// by main.js: frames rendered per second, GPU time per pass, rays, the GI probe field's
// convergence) and two live graphs of the last 60 s (graphs.js): GPU milliseconds per pass,
// stacked, and input-to-frame latency with the server's share of it.

import { h, fixed, si } from './dom.js';
import { COLORS, LiveGraph, Series } from './graphs.js';

const $ = (id) => document.getElementById(id);

export class StatsPanel {
  /* stream: the FrameStream (its 'frame' events carry the header's server timestamps). */
  constructor({ stream }) {
    this.f = {};
    for (const k of ['fps', 'server-fps', 'latency', 'server-ms', 'kbps', 'frame', 'size', 'rays', 'probes', 'gpu',
      'passes', 'device', 'converge']) this.f[k] = $('st-' + k);
    this.passRows = new Map();
    this.stream = stream;
    this.gpuGraph = new LiveGraph($('graph-gpu'));
    this.latencyGraph = new LiveGraph($('graph-latency'));
    this.gpuRows = [];       // [{ t, passes: { name: ms } }], one per stats poll
    this.passNames = [];     // every pass name seen in the window, in the server's order
    this.latency = new Series();   // input-to-frame milliseconds (FrameStream.latencies)
    this.serverMs = new Series();  // capture to send of each drawn frame of our view (server clock)
    this.latencySeen = 0;          // performance.now() of the newest latency sample taken
    this.prevPoll = null;          // { t, frames } of the previous stats answer
    this.serverFps = null;         // frames rendered per second between the last two answers
    stream.addEventListener('frame', (e) => {
      const hd = e.detail;
      if (hd.sendUs > hd.captureUs && hd.viewId === stream.ownView)
        this.serverMs.push(performance.now(), (hd.sendUs - hd.captureUs) / 1000);
    });
  }

  /* One answer of GET /v1/stats (null when the poll failed): the server's frame rate (frames
   * rendered between two answers over the time between them; the server's own one-second
   * count before that) and a sample of the GPU graph (zero while the server idles). */
  addServerSample(server) {
    const now = performance.now();
    if (!server) { this.prevPoll = null; this.serverFps = null; return; }
    const frames = Number(server.frames_rendered);
    if (this.prevPoll && Number.isFinite(frames) && frames >= this.prevPoll.frames && now > this.prevPoll.t)
      this.serverFps = (frames - this.prevPoll.frames) / ((now - this.prevPoll.t) / 1000);
    else this.serverFps = Number.isFinite(server.fps) ? server.fps : null;
    this.prevPoll = Number.isFinite(frames) ? { t: now, frames } : null;
    const passes = {};
    if (server.rendering !== false) {
      for (const [k, v] of Object.entries(server.gpu_ms || {})) if (Number.isFinite(v)) passes[k] = v;
      const w = server.world && server.world.gpu_ms_total;
      if (Number.isFinite(w) && w > 0) passes['probe update'] = w;
    }
    for (const k of Object.keys(passes)) if (!this.passNames.includes(k)) this.passNames.push(k);
    this.gpuRows.push({ t: now, passes });
    while (this.gpuRows.length && this.gpuRows[0].t < now - 61000) this.gpuRows.shift();
  }

  /* client: FrameStream.metrics(); header: the last drawn frame's header (or null); server:
   * GET /v1/stats (or null when the poll failed). */
  render({ client, header, server }) {
    const f = this.f;
    f.fps.textContent = fixed(client.fps, 1);
    f['server-fps'].innerHTML = Number.isFinite(this.serverFps)
      ? `${fixed(this.serverFps, 1)}${server && server.rendering === false ? ' <small>idle</small>' : ''}` : '–';
    f['server-fps'].title = server && Number.isFinite(server.fps) ? `the server's count of the last second: ${server.fps}` : '';
    f.latency.textContent = client.latencyMs !== null ? `${fixed(client.latencyMs, 0)} ms`
      : client.lastLatencyMs !== null ? `${fixed(client.lastLatencyMs, 0)} ms (idle)` : '–';
    f['server-ms'].innerHTML = header && header.sendUs >= header.captureUs && header.encodeUs >= header.captureUs
      ? `${fixed((header.encodeUs - header.captureUs) / 1000, 1)} ms <small>+ ${fixed((header.sendUs - header.encodeUs) / 1000, 1)} wait</small>`
      : '–';
    f.kbps.textContent = `${client.kbps >= 10000 ? (client.kbps / 1000).toFixed(1) + ' Mbit/s' : fixed(client.kbps, 0) + ' kbit/s'}`;
    const kind = (h) => (h.format ? `${['jpeg', 'vp8', 'vp9'][h.format] || 'video'}${h.key ? ' key' : ''}` : `q${h.quality}`);
    f.frame.innerHTML = header ? `#${header.frameId} <small>${kind(header)}${header.still ? ' still' : ''}</small>` : '–';
    f.size.innerHTML = header ? `${header.width}×${header.height}${header.version >= 2 ? ` <small>view ${header.viewId}</small>` : ''}` : '–';
    this.takeLatencies();
    this.drawGraphs();
    if (!server) {
      for (const k of ['rays', 'probes', 'gpu']) f[k].textContent = '–';
      this.renderConvergence(null);
      this.renderPasses({});
      return;
    }
    f.rays.textContent = si(server.rays_per_second);
    const p = server.probes || {};
    const st = p.states || null;
    if (p.mode === 'pathtrace') {
      const pt = this.pathTrace(server);
      f.probes.innerHTML = pt
        ? `path trace <small>· ${pt.samples} / ${pt.target} samples</small>`
        : `path trace <small>· ${server.rendering === false ? 'done' : 'accumulating…'}</small>`;
      f.probes.title = 'Samples accumulate in your view while nothing changes; any change starts over.';
    } else {
      const active = p.mode && p.mode !== 'off' ? p.total || 0 : 0;
      // convergence progress: the share of the lit probes that have settled (asleep)
      const progress = st && Number.isFinite(p.convergence) && !p.converged
        ? ` ${Math.floor(p.convergence * 100)}% · ${st.awake} awake` : '';
      f.probes.innerHTML = active
        ? `${active} <small>${p.mode} · ${p.converged ? 'converged' : 'converging' + progress}</small>`
        : `0 <small>${p.mode || 'off'}</small>`;
      f.probes.title = st ? `awake ${st.awake}, sleeping ${st.sleeping}, off ${st.off}` : '';
    }
    this.renderConvergence(server);
    f.gpu.innerHTML = server.rendering === false ? `idle <small>(converged)</small>`
      : `${fixed(server.gpu_ms_total, 1)} ms`;
    f.device.textContent = server.device ? `${server.device}${server.stream ? ` · ${server.stream.viewers} viewer${server.stream.viewers === 1 ? '' : 's'}` : ''}` : '';
    f.device.title = f.device.textContent;
    this.renderPasses(server.gpu_ms || {});
  }

  /* The path tracer's progress in the view this page shows: { samples, target } from
   * GET /v1/stats "pathtrace" (its entry for our view, else the fewest of the watched views);
   * null when the server does not report it. */
  pathTrace(server) {
    const pt = server && server.pathtrace;
    if (!pt || !Number.isFinite(pt.target) || pt.target <= 0) return null;
    const mine = Array.isArray(pt.views) && this.stream.watching !== null
      ? pt.views.find((v) => v && v.view === this.stream.watching) : null;
    const samples = mine && Number.isFinite(mine.samples) ? mine.samples : pt.samples;
    return Number.isFinite(samples) ? { samples: Math.min(samples, pt.target), target: pt.target } : null;
  }

  /* The GI progress bar: the probes' convergence (0..1) in DDGI and classic modes; in path
   * tracing the share of the target samples accumulated (without a count from the server: an
   * indeterminate bar while it renders, a full one when done). */
  renderConvergence(server) {
    const bar = this.f.converge;
    const p = (server && server.probes) || {};
    let frac = null, label = 'GI –', busy = false;
    const pt = p.mode === 'pathtrace' ? this.pathTrace(server) : null;
    if (pt) {
      frac = pt.samples / pt.target;
      label = `path trace: ${pt.samples} / ${pt.target} samples`;
    } else if (p.mode === 'pathtrace') {
      busy = server.rendering !== false;
      frac = busy ? null : 1;
      label = busy ? 'path trace: accumulating' : 'path trace: done';
    } else if (p.mode && p.mode !== 'off' && Number.isFinite(p.convergence)) {
      frac = p.converged ? 1 : Math.max(0, Math.min(1, p.convergence));
      label = p.converged ? 'GI converged' : `GI converging ${Math.floor(frac * 100)}%`;
    } else if (p.mode === 'off') label = 'GI off';
    bar.classList.toggle('busy', busy);
    bar.dataset.done = String(frac === 1);
    bar.querySelector('i').style.width = frac === null ? '' : `${(frac * 100).toFixed(1)}%`;
    bar.querySelector('span').textContent = label;
    if (frac === null) bar.removeAttribute('aria-valuenow');
    else bar.setAttribute('aria-valuenow', String(Math.round(frac * 100)));
  }

  /* The pass legend: colour (as in the graph) and milliseconds of the last frame. */
  renderPasses(passes) {
    const names = Object.keys(passes);
    for (const [name, row] of this.passRows) if (!(name in passes)) { row.el.remove(); this.passRows.delete(name); }
    for (const name of names) {
      let row = this.passRows.get(name);
      if (!row) {
        const ms = h('span', { class: 'ms' }), sw = h('i', { class: 'sw' });
        row = { el: h('div', { class: 'pass' }, sw, h('span', { class: 'name' }, name), ms), ms, sw };
        this.passRows.set(name, row);
      }
      this.f.passes.append(row.el); // keeps the server's order
      row.ms.textContent = fixed(passes[name], 2);
      if (!this.passNames.includes(name)) this.passNames.push(name);
      row.sw.style.background = COLORS[this.passNames.indexOf(name) % COLORS.length];
    }
  }

  /* New input-to-frame samples of the stream (it keeps the last 120). */
  takeLatencies() {
    for (const l of this.stream.latencies) {
      if (l.t <= this.latencySeen) continue;
      this.latency.push(l.t, l.ms);
      this.latencySeen = l.t;
    }
  }

  drawGraphs() {
    const now = performance.now();
    this.latency.trim(now);
    this.serverMs.trim(now);
    this.gpuGraph.draw(now, {
      rows: this.gpuRows.map((r) => ({ t: r.t, values: this.passNames.map((k) => r.passes[k] || 0) })),
    });
    this.latencyGraph.draw(now, {
      lines: [
        { points: this.serverMs.points, color: COLORS[1] },
        { points: this.latency.points, color: COLORS[0], dots: true },
      ],
    });
  }
}
