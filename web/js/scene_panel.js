// scene_panel.js: the Scene panel: what GET /v1/scene says about the scene (the uploaded file's
// name first), and uploads with PUT /v1/scene?name=FILE (drag-and-drop, the file picker or a
// folder, with progress). Several files — a .gltf with its .bin and images — are packed into one
// .glb in the page first (gltf_pack.js); a file the .gltf needs and that was not chosen is
// reported by name before anything is sent.

import { sceneContentType } from './api.js';
import { h } from './dom.js';
import { prepareSceneUpload } from './gltf_pack.js';

const $ = (id) => document.getElementById(id);
const mb = (n) => (n / 1048576).toFixed(n < 10485760 ? 2 : 1) + ' MB';

/* ---- scene and upload -------------------------------------------------------------------- */
/* Shows GET /v1/scene and uploads files with PUT /v1/scene (XMLHttpRequest for progress).
 * onSceneChanged(scene) runs after a successful upload. upload() takes a File or a list of
 * them. */
export class ScenePanel {
  constructor(api, { toasts, onSceneChanged }) {
    this.api = api;
    this.toasts = toasts;
    this.onSceneChanged = onSceneChanged;
    this.info = $('scene-info');
    this.btn = $('upload-btn');
    this.file = $('upload-file');
    this.box = $('upload');
    this.bar = $('upload-bar');
    this.text = $('upload-text');
    this.err = $('upload-error');
    this.job = null;
    this.btn.addEventListener('click', () => this.file.click());
    this.folder = $('upload-folder');
    $('upload-folder-btn').addEventListener('click', () => this.folder.click());
    for (const input of [this.file, this.folder]) {
      input.addEventListener('change', () => {
        const files = [...(input.files || [])];
        input.value = '';
        if (files.length) this.upload(files);
      });
    }
    $('upload-cancel').addEventListener('click', () => this.job && this.job.abort());
    this.err.title = 'Click to dismiss';
    this.err.addEventListener('click', () => { this.err.hidden = true; });
  }

  render(s) {
    if (!s) return;
    const p = s.probes || {};
    const src = s.source === 'upload' ? 'uploaded scene' : s.source;
    this.info.replaceChildren(
      s.file_name ? h('div', { class: 'file-name', id: 'scene-file', title: s.file_name }, s.file_name) : '',
      h('div', {}, h('b', {}, src || '–'), s.generation ? ` · generation ${s.generation}` : ''),
      h('div', {}, `${(s.triangles || 0).toLocaleString('en')} triangles · ${s.node_count ?? '–'} nodes · ${s.light_count ?? '–'} lights`),
      p.counts ? h('div', {}, `probes ${p.counts.join('×')} (${p.total}) · ${p.rays_per_probe} rays · ${p.mode}`) : '',
      ...(s.warnings || []).slice(0, 3).map((w) => h('div', { class: 'hint' }, '⚠ ' + w)));
  }

  showError(name, e) {
    this.err.replaceChildren(h('b', {}, `${name} was not loaded`), h('span', { class: 'msg' }, e.message),
      e.status ? h('div', { class: 'hint' }, `HTTP ${e.status} · ${e.code}`) : '');
    this.err.hidden = false;
    this.err.scrollIntoView({ block: 'nearest' });
    // The panel shows the message; a toast only when the panels are hidden (H).
    if (document.body.classList.contains('ui-hidden')) this.toasts.show(`${name}: ${e.message}`, 'error');
  }

  async upload(chosen) {
    if (this.job || this.packing) { this.toasts.show('An upload is already running.', 'error'); return; }
    const files = chosen instanceof Blob ? [chosen] : [...chosen];
    const panel = $('panel-scene');
    panel.open = true;
    requestAnimationFrame(() => panel.scrollIntoView({ block: 'nearest' }));
    this.err.hidden = true;
    let up;
    this.packing = true;
    try {
      up = await prepareSceneUpload(files);
    } catch (e) {
      this.showError(files.length === 1 ? files[0].name : `${files.length} files`, e);
      return;
    } finally {
      this.packing = false;
    }
    const file = up.body;
    const type = files.includes(file) ? sceneContentType(file) : up.type;
    this.box.hidden = false;
    this.btn.disabled = true;
    const progress = this.bar.parentElement;
    progress.classList.remove('indeterminate');
    const path = '/v1/scene?name=' + encodeURIComponent(up.name);
    this.job = this.api.upload(path, file, type, (frac, phase) => {
      if (phase === 'process') {
        progress.classList.add('indeterminate');
        this.text.textContent = 'Validating and building the BVH…';
      } else {
        this.bar.style.width = `${(frac * 100).toFixed(1)}%`;
        this.text.textContent = `Uploading ${(frac * 100).toFixed(0)} % · ${mb(frac * file.size)} of ${mb(file.size)}`;
      }
    });
    try {
      const scene = await this.job.promise;
      this.toasts.show(`Loaded ${up.name}: ${(scene && scene.triangles || 0).toLocaleString('en')} triangles.`, 'ok');
      this.render(scene);
      this.onSceneChanged(scene);
    } catch (e) {
      if (e.code !== 'aborted') this.showError(up.name, e);
    } finally {
      this.job = null;
      this.box.hidden = true;
      this.btn.disabled = false;
      progress.classList.remove('indeterminate');
      this.bar.style.width = '0';
    }
  }
}
