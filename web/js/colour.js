// colour.js: light colours between glTF's linear RGB and the sRGB of <input type=color>, for the
// lights and rendering panels (lights_panel.js, render_panel.js).

const toSrgb = (c) => (c <= 0.0031308 ? 12.92 * c : 1.055 * Math.pow(c, 1 / 2.4) - 0.055);
const toLinear = (c) => (c <= 0.04045 ? c / 12.92 : Math.pow((c + 0.055) / 1.055, 2.4));
export function linearToHex(rgb) {
  const m = Math.max(1, ...rgb); // HDR colours: show the hue
  return '#' + rgb.map((c) => Math.round(Math.min(1, Math.max(0, toSrgb(c / m))) * 255).toString(16).padStart(2, '0')).join('');
}
export function hexToLinear(hex) {
  const n = parseInt(hex.slice(1), 16);
  return [(n >> 16) & 255, (n >> 8) & 255, n & 255].map((v) => Math.round(toLinear(v / 255) * 1e4) / 1e4);
}
