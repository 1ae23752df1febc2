// toasts.js: short messages over the picture (an error shows the server's own message), at most
// four at a time, each gone after a few seconds.

import { h } from './dom.js';

const $ = (id) => document.getElementById(id);

export class Toasts {
  constructor(root = $('toasts')) { this.root = root; }
  show(message, kind = 'error', ms = kind === 'error' ? 7000 : 3500) {
    const el = h('div', { class: 'toast ' + kind, role: kind === 'error' ? 'alert' : 'status' }, message);
    this.root.append(el);
    while (this.root.children.length > 4) this.root.firstChild.remove();
    setTimeout(() => el.remove(), ms);
    return el;
  }
  error(e) { return this.show(e && e.message ? e.message : String(e), 'error'); }
}
