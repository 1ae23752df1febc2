// layout.js: where the panels go, picture first. Three layouts, picked from the window's size
// and pointer (and again when they change), named by a class on <body>:
//
//   layout-desktop  (1100 px wide or more): one column of collapsible panels on the right
//                   (<details>, open state remembered), at most about a fifth of the picture;
//   layout-compact  (narrower): a toolbar of panel buttons on the right edge; a button opens
//                   its panel over the picture, one at a time; the same button, Esc or the
//                   panel's title closes it;
//   layout-phone    (under 600 px wide, or a coarse pointer under 900 px): the toolbar is a tab
//                   bar at the bottom and the open panel is a bottom sheet above it (at most
//                   half the height, so the picture stays visible above); its handle closes and
//                   reopens it by a tap or a drag.
//
// body.touch (a coarse pointer, or the phone layout) makes every control at least 44 x 44 px
// (viewer.css). Also here: the keyboard-help overlay ('?', Esc) and fullscreen of the picture
// ('f', the Fullscreen API on #stage).

const $ = (id) => document.getElementById(id);

const PHONE_QUERY = '(max-width: 599px), (pointer: coarse) and (max-width: 899px)';
const COMPACT_QUERY = '(max-width: 1099px)';
const TOUCH_QUERY = '(pointer: coarse)';
const SHEET_DRAG_PX = 40;      // a handle drag longer than this opens or closes the sheet
const DESKTOP_CLOSED = ['panel-views', 'panel-quality', 'panel-scene']; // closed by default

export class Layout {
  constructor() {
    this.panels = [...document.querySelectorAll('#dock > details.panel')];
    this.buttons = new Map(); // panel id -> its toolbar button
    for (const b of document.querySelectorAll('#toolbar [data-panel]')) this.buttons.set(b.dataset.panel, b);
    this.mode = null;
    this.active = null;    // compact and phone: the panel shown (its id) or null
    this.lastActive = 'panel-stats';
    this.mq = [PHONE_QUERY, COMPACT_QUERY, TOUCH_QUERY].map((q) => matchMedia(q));
    for (const m of this.mq) m.addEventListener('change', () => this.update());
    for (const [id, b] of this.buttons) b.addEventListener('click', () => this.toggle(id));
    for (const d of this.panels) {
      d.addEventListener('toggle', () => this.onToggle(d));
      // a panel that hides itself (Animation without animations) hides its button too
      const b = this.buttons.get(d.id);
      if (b) {
        b.hidden = d.hidden;
        new MutationObserver(() => {
          b.hidden = d.hidden;
          if (d.hidden && this.active === d.id) this.show(null);
        }).observe(d, { attributes: true, attributeFilter: ['hidden'] });
      }
    }
    this.setupHandle();
    this.update();
  }

  get docked() { return this.mode === 'desktop'; }

  /* Picks the layout for the window as it is now. */
  update() {
    const [phone, compact, touch] = this.mq.map((m) => m.matches);
    const mode = phone ? 'phone' : compact ? 'compact' : 'desktop';
    document.body.classList.toggle('touch', touch || phone);
    if (mode === this.mode) return;
    this.mode = mode;
    for (const m of ['desktop', 'compact', 'phone']) document.body.classList.toggle('layout-' + m, m === mode);
    if (mode === 'desktop') {
      this.active = null;
      for (const d of this.panels) {
        const saved = localStorage.getItem('probecast.panel.' + d.id);
        d.open = saved !== null ? saved === '1' : !DESKTOP_CLOSED.includes(d.id);
        d.classList.remove('active');
      }
      this.sync();
    } else {
      this.show(null);
    }
  }

  /* Compact and phone: shows panel id (null: none) and closes the others. On the desktop it
   * opens the panel in the column and scrolls to it. */
  show(id) {
    if (this.docked) {
      const d = id && $(id);
      if (d) { d.open = true; d.scrollIntoView({ block: 'nearest' }); }
      return;
    }
    this.active = id;
    if (id) this.lastActive = id;
    for (const d of this.panels) {
      const on = d.id === id;
      d.classList.toggle('active', on);
      if (d.open !== on) d.open = on;
    }
    this.sync();
  }

  toggle(id) {
    if (this.docked) {
      const d = $(id);
      if (d) { d.open = !d.open; if (d.open) d.scrollIntoView({ block: 'nearest' }); }
      return;
    }
    this.show(this.active === id ? null : id);
  }

  /* Closes the open panel of the compact and phone layouts; false when none was open. */
  close() {
    if (this.docked || !this.active) return false;
    this.show(null);
    return true;
  }

  /* A panel opened or closed by its title, or by code (an upload opens the Scene panel). */
  onToggle(d) {
    if (this.docked) {
      localStorage.setItem('probecast.panel.' + d.id, d.open ? '1' : '0');
      this.sync();
      return;
    }
    if (d.open && this.active !== d.id) this.show(d.id);
    else if (!d.open && this.active === d.id) this.show(null);
  }

  /* Button states and the sheet's. */
  sync() {
    for (const [id, b] of this.buttons) {
      const d = $(id);
      b.setAttribute('aria-pressed', String(this.docked ? !!(d && d.open) : this.active === id));
    }
    const open = !this.docked && this.active !== null;
    document.body.dataset.sheet = open ? 'open' : 'closed';
    const handle = $('sheet-handle');
    handle.setAttribute('aria-expanded', String(open));
    handle.setAttribute('aria-label', open ? 'Close the panel' : 'Open the panel');
    handle.title = handle.getAttribute('aria-label');
  }

  /* The sheet's handle: a tap toggles, a drag down closes, a drag up opens. */
  setupHandle() {
    const handle = $('sheet-handle');
    let start = null;
    handle.addEventListener('pointerdown', (e) => {
      start = { y: e.clientY, id: e.pointerId };
      handle.setPointerCapture(e.pointerId);
    });
    handle.addEventListener('pointerup', (e) => {
      if (!start || e.pointerId !== start.id) return;
      const dy = e.clientY - start.y;
      start = null;
      if (dy > SHEET_DRAG_PX) this.show(null);
      else if (dy < -SHEET_DRAG_PX) this.show(this.active || this.lastActive);
      else return; // a tap: the click that follows toggles
      handle.dataset.dragged = '1';
    });
    handle.addEventListener('pointercancel', () => { start = null; });
    handle.addEventListener('click', () => {
      if (handle.dataset.dragged) { delete handle.dataset.dragged; return; }
      this.show(this.active ? null : this.lastActive);
    });
  }
}

/* The keyboard-help overlay: open() and close(); Esc, the close button and a click beside the
 * card close it; focus returns to where it was. */
export class HelpOverlay {
  constructor() {
    this.el = $('keys-help');
    this.prevFocus = null;
    $('keys-close').addEventListener('click', () => this.close());
    this.el.addEventListener('click', (e) => { if (e.target === this.el) this.close(); });
  }

  get isOpen() { return !this.el.hidden; }

  open() {
    if (this.isOpen) return;
    this.prevFocus = document.activeElement;
    this.el.hidden = false;
    $('help-btn').setAttribute('aria-expanded', 'true');
    $('keys-close').focus();
  }

  close() {
    if (!this.isOpen) return;
    this.el.hidden = true;
    $('help-btn').setAttribute('aria-expanded', 'false');
    if (this.prevFocus && this.prevFocus.focus) this.prevFocus.focus({ preventScroll: true });
  }

  toggle() { if (this.isOpen) this.close(); else this.open(); }
}

/* Fullscreen of the picture (#stage, with its own exit button); the top-bar button and 'f'.
 * Browsers without the Fullscreen API (iPhone Safari) get a toast instead. */
export class Fullscreen {
  constructor(stage, { toasts }) {
    this.stage = stage;
    this.toasts = toasts;
    this.btn = $('fullscreen');
    this.btn.addEventListener('click', () => this.toggle());
    $('fullscreen-exit').addEventListener('click', () => this.toggle());
    document.addEventListener('fullscreenchange', () => this.sync());
    this.sync();
  }

  get active() { return document.fullscreenElement === this.stage; }

  async toggle() {
    try {
      if (document.fullscreenElement) await document.exitFullscreen();
      else if (this.stage.requestFullscreen) await this.stage.requestFullscreen({ navigationUI: 'hide' });
      else this.toasts.show('This browser cannot show the picture full screen.', 'error');
    } catch (e) {
      this.toasts.show(`Full screen was refused: ${e.message}`, 'error');
    }
    this.sync();
  }

  sync() {
    const on = this.active;
    this.btn.setAttribute('aria-pressed', String(on));
    this.btn.title = on ? 'Leave full screen (F)' : 'Full screen (F)';
    this.btn.setAttribute('aria-label', on ? 'Leave full screen' : 'Full screen');
    document.body.classList.toggle('fullscreen', on);
  }
}
