// scene_tree.js: the Nodes panel: the scene's node hierarchy from the scene document
// (GET /v1/scene "nodes": id, name, parent, mesh, translation, rotation, scale), one selected
// node, and numeric fields for its translation, rotation (Euler degrees, XYZ order) and scale.
// Every change goes out as PATCH /v1/nodes/{id} (coalesced per node: one request in flight, the
// latest value of each field wins); answers and 'node' events update the tree. The gizmo
// (gizmo.js) reads the selection and the nodes' world matrices here and moves nodes through
// patch().

import { h } from './dom.js';
import { Coalescer } from './coalescer.js';
import { IDENTITY, eulerToQuat, mat4FromTrs, mat4Mul, quatToEuler } from './xform.js';

const $ = (id) => document.getElementById(id);
const round = (v, d = 4) => Number(v.toFixed(d)) || 0;

export class SceneTree extends EventTarget {
  /* Events: 'select' (detail: { id }: a node, or null), 'change' (a node moved: redraw). */
  constructor(api, { toasts }) {
    super();
    this.api = api;
    this.toasts = toasts;
    this.root = $('node-tree');
    this.count = $('node-count');
    this.editBox = $('node-edit');
    this.title = $('node-title');
    this.nodes = new Map(); // id -> node document
    this.rows = new Map();  // id -> row button
    this.selected = null;
    this.lastEdit = -Infinity;
    this.queue = new Coalescer((id, patch) => this.api.patch(`/v1/nodes/${id}`, patch));
    const fields = (id, label, step) => ['x', 'y', 'z'].map((a) => {
      const input = h('input', { type: 'number', step, 'aria-label': `${label} ${a}`, 'data-field': id,
        oninput: () => this.fieldEdited(id) });
      $(`node-${id}`).append(input);
      return input;
    });
    this.inputs = { t: fields('t', 'translation', '0.05'), r: fields('r', 'rotation degrees', '1'), s: fields('s', 'scale', '0.05') };
  }

  /* A scene document: the tree is rebuilt (a new scene) or refreshed (the same one). */
  setScene(doc) {
    const list = doc && Array.isArray(doc.nodes) ? doc.nodes : [];
    const sameScene = this.doc && doc && this.doc.source === doc.source && this.doc.generation === doc.generation;
    this.doc = doc;
    this.nodes = new Map(list.map((n) => [n.id, n]));
    if (!sameScene) this.selected = null;
    this.render();
    this.fill();
    this.dispatchEvent(new Event('change'));
  }

  /* One node's document (a PATCH answer or a 'node' event). While our own changes of it are on
   * their way, older documents would move it back: they wait for the last answer. */
  applyNode(n) {
    if (!n || n.id === undefined || this.queue.busy(n.id)) return;
    this.nodes.set(n.id, n);
    if (!this.rows.has(n.id)) this.render();
    if (n.id === this.selected) this.fill();
    this.dispatchEvent(new Event('change'));
  }

  render() {
    const kids = new Map();
    for (const n of this.nodes.values()) {
      const p = this.nodes.has(n.parent) ? n.parent : -1;
      if (!kids.has(p)) kids.set(p, []);
      kids.get(p).push(n);
    }
    this.rows.clear();
    const items = [];
    const walk = (parent, depth) => {
      for (const n of kids.get(parent) || []) {
        const row = h('button', {
          type: 'button', role: 'treeitem', class: 'node-row', 'data-id': String(n.id),
          'aria-selected': String(n.id === this.selected), 'aria-level': String(depth + 1),
          style: `padding-left: ${8 + depth * 14}px`, title: `node ${n.id}${n.mesh >= 0 ? ' · mesh ' + n.mesh : ''}`,
          onclick: () => this.select(n.id),
        }, h('span', { class: n.mesh >= 0 ? 'kind mesh' : 'kind' }), h('span', { class: 'name' }, n.name || `node ${n.id}`));
        this.rows.set(n.id, row);
        items.push(row);
        if (depth < 64) walk(n.id, depth + 1);
      }
    };
    walk(-1, 0);
    this.root.replaceChildren(...items);
    const more = this.doc && this.doc.nodes_truncated ? '+' : '';
    this.count.textContent = this.nodes.size ? `(${this.nodes.size}${more})` : '';
  }

  /* Selects node id (null: none) and shows it; scroll brings its row into view. */
  async select(id, { scroll = false } = {}) {
    if (id !== null && !this.nodes.has(id)) {
      try { // beyond the scene document's first nodes
        this.applyNode(await this.api.get(`/v1/nodes/${id}`));
      } catch (e) { this.toasts.error(e); return; }
    }
    this.selected = id;
    for (const [nid, row] of this.rows) row.setAttribute('aria-selected', String(nid === id));
    if (scroll && id !== null && this.rows.has(id)) this.rows.get(id).scrollIntoView({ block: 'nearest' });
    this.fill();
    this.dispatchEvent(new CustomEvent('select', { detail: { id } }));
  }

  get node() { return this.selected !== null ? this.nodes.get(this.selected) || null : null; }

  /* The world matrix of node id from the TRS chain of its ancestors. */
  world(id) {
    let m = IDENTITY;
    for (let n = this.nodes.get(id), depth = 0; n && depth < 256; n = this.nodes.get(n.parent), depth++)
      m = mat4Mul(mat4FromTrs(n.translation, n.rotation, n.scale), m);
    return m;
  }

  parentWorld(id) {
    const n = this.nodes.get(id);
    return n && this.nodes.has(n.parent) ? this.world(n.parent) : IDENTITY;
  }

  /* Shows the selected node in the fields, leaving alone the one being typed into. */
  fill() {
    const n = this.node;
    this.editBox.hidden = !n;
    if (!n) return;
    this.title.textContent = `${n.name || 'node ' + n.id} · node ${n.id}`;
    const active = document.activeElement;
    const set = (inputs, v) => inputs.forEach((input, i) => { if (input !== active) input.value = round(v[i], 3); });
    set(this.inputs.t, n.translation);
    set(this.inputs.r, quatToEuler(n.rotation));
    set(this.inputs.s, n.scale);
  }

  fieldEdited(which) {
    const n = this.node;
    if (!n) return;
    const v = this.inputs[which].map((i) => Number(i.value));
    if (!v.every(Number.isFinite)) return;
    if (which === 't') this.patch(n.id, { translation: v });
    else if (which === 'r') this.patch(n.id, { rotation: eulerToQuat(v).map((x) => round(x, 7)) });
    else if (v.every((x) => Math.abs(x) >= 1e-6)) this.patch(n.id, { scale: v });
  }

  /* Changes node id: shown at once (the gizmo follows), sent coalesced; the answer is applied. */
  async patch(id, patch) {
    const n = this.nodes.get(id);
    if (!n) return;
    this.lastEdit = performance.now();
    this.nodes.set(id, { ...n, ...patch });
    if (id === this.selected) this.fill();
    this.dispatchEvent(new Event('change'));
    try {
      const answer = await this.queue.send(id, patch);
      if (!this.queue.busy(id)) this.applyNode(answer);
    } catch (e) {
      this.toasts.error(e);
      try { this.applyNode(await this.api.get(`/v1/nodes/${id}`)); } catch { /* offline */ }
    }
  }
}
