// coalescer.js: at most one request in flight per key, the patches given meanwhile merged into
// the next one. The panels that edit the world through PATCH requests (lights_panel.js,
// render_panel.js, animation.js, scene_tree.js) send through one, so that a dragged slider
// sends no more requests than the server answers.

/* Coalescer: at most one request in flight per key; patches given meanwhile are merged and
 * sent when it returns (the latest value of each field wins). send(key, patch) -> Promise of
 * the server's answer (after the merged request that carried the patch). */
export class Coalescer {
  constructor(request) {
    this.request = request; // (key, patch) => Promise
    this.slots = new Map();
  }
  send(key, patch) {
    let s = this.slots.get(key);
    if (!s) { s = { busy: false, next: null, waiters: [] }; this.slots.set(key, s); }
    s.next = { ...(s.next || {}), ...patch };
    const p = new Promise((resolve, reject) => s.waiters.push({ resolve, reject }));
    if (!s.busy) this.pump(key, s);
    return p;
  }
  busy(key) { const s = this.slots.get(key); return !!s && (s.busy || !!s.next); }
  async pump(key, s) {
    s.busy = true;
    while (s.next) {
      const patch = s.next, waiters = s.waiters;
      s.next = null;
      s.waiters = [];
      try {
        const r = await this.request(key, patch);
        waiters.forEach((w) => w.resolve(r));
      } catch (e) {
        waiters.forEach((w) => w.reject(e));
      }
    }
    s.busy = false;
    this.slots.delete(key);
  }
}
