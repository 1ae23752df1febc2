// dom.js: small DOM and number-formatting helpers shared by the panels (lights_panel.js,
// render_panel.js, views_panel.js, toasts.js, stats.js, layout.js, quality.js). No state.

/* h('div', { class: 'x', onclick: f }, child, 'text') */
export function h(tag, attrs = {}, ...children) {
  const el = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (v === undefined || v === null || v === false) continue;
    if (k.startsWith('on')) el.addEventListener(k.slice(2), v);
    else if (k === 'class') el.className = v;
    else if (k in el && typeof v !== 'string') el[k] = v;
    else el.setAttribute(k, v === true ? '' : v);
  }
  for (const c of children.flat()) if (c !== null && c !== undefined && c !== false) el.append(c);
  return el;
}

/* An icon as inline SVG (no icon font: glyphs such as ⌖ are missing from many system fonts). */
export function icon(d, size = 14) {
  const svg = document.createElementNS('http://www.w3.org/2000/svg', 'svg');
  svg.setAttribute('viewBox', '0 0 16 16');
  svg.setAttribute('width', String(size));
  svg.setAttribute('height', String(size));
  svg.setAttribute('aria-hidden', 'true');
  const path = document.createElementNS('http://www.w3.org/2000/svg', 'path');
  path.setAttribute('d', d);
  path.setAttribute('fill', 'none');
  path.setAttribute('stroke', 'currentColor');
  path.setAttribute('stroke-width', '1.6');
  path.setAttribute('stroke-linecap', 'round');
  svg.append(path);
  return svg;
}

export const fixed = (x, d) => (Number.isFinite(x) ? x.toFixed(d) : '–');

export function si(x, unit = '') {
  if (!Number.isFinite(x)) return '–';
  const a = Math.abs(x);
  if (a >= 1e9) return (x / 1e9).toFixed(2) + ' G' + unit;
  if (a >= 1e6) return (x / 1e6).toFixed(2) + ' M' + unit;
  if (a >= 1e3) return (x / 1e3).toFixed(1) + ' k' + unit;
  return x.toFixed(0) + (unit ? ' ' + unit : '');
}
