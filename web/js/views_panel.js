// views_panel.js: the views panel: the other viewers' views, each with a Follow button, and the
// "Following view N" banner. The views reach it through the stream's 'views' events
// (protocol/stream.md, version 2).

import { h } from './dom.js';

const $ = (id) => document.getElementById(id);

/* Lists the views of GET /v1/views (from 'views' events) other than our own, each with a Follow
 * button, and shows "Following view N — Stop" in the top bar while we watch another view.
 * onFollow(id) asks to watch view id; onFollow(null) returns to the own view. */
export class ViewsPanel {
  constructor({ onFollow }) {
    this.onFollow = onFollow;
    this.root = $('views');
    this.self = $('views-self');
    this.count = $('view-count');
    this.banner = $('following');
    this.bannerId = $('following-id');
    this.doc = null;
    this.single = false;
    this.own = null;       // our own view's id (null before the welcome or in version 1)
    this.watching = null;  // the view we watch (the own one when not following)
    $('following-stop').addEventListener('click', () => this.onFollow(null));
    this.render();
  }

  /* doc: a 'views' event (the body of GET /v1/views) or null; own, watching: view ids (null
   * while not connected); single: the server predates views (version 1: one shared view). */
  update({ doc = this.doc, own = this.own, watching = this.watching, single = this.single } = {}) {
    this.doc = doc;
    this.own = own;
    this.watching = watching;
    this.single = single;
    this.render();
  }

  get following() { return this.own !== null && this.watching !== null && this.watching !== this.own; }

  render() {
    const views = (this.doc && Array.isArray(this.doc.views)) ? this.doc.views : [];
    const mine = views.find((v) => v.id === this.own);
    if (this.own === null) this.self.textContent = this.single ? 'This server shows everyone one view.' : '–';
    else this.self.replaceChildren(h('b', {}, `Your view ${this.own}`),
      mine ? ` · ${mine.width}×${mine.height}` : '', this.following ? ` · not shown while you follow` : '');
    const others = views.filter((v) => v.id !== this.own);
    this.count.textContent = others.length ? `(${others.length})` : '';
    this.root.replaceChildren(...others.map((v) => {
      const on = v.id === this.watching;
      const who = v.owner === 'http' ? 'HTTP' : String(v.owner || '');
      const title = `${v.owner === 'http' ? 'The default view (/v1/camera)' : 'Another viewer\'s view'}` +
        (Number.isFinite(v.watchers) ? `; ${v.watchers} watching` : '');
      return h('div', { class: 'view-row' + (on ? ' on' : ''), 'data-id': String(v.id) },
        h('span', { class: 'vid' }, `view ${v.id}`),
        h('span', { class: 'vinfo', title }, `${v.width}×${v.height} · ${who}`),
        h('button', {
          type: 'button', class: 'btn small' + (on ? ' primary' : ''), 'aria-pressed': String(on),
          'data-follow': String(v.id), disabled: this.own === null,
          title: on ? 'Back to your own view' : `Watch view ${v.id} (your camera input pauses meanwhile)`,
          onclick: () => this.onFollow(on ? null : v.id),
        }, on ? 'Stop' : 'Follow'));
    }));
    this.banner.hidden = !this.following;
    this.bannerId.textContent = this.following ? String(this.watching) : '';
    document.body.classList.toggle('following', this.following);
  }
}
