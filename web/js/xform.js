// xform.js: the little linear algebra the node tree and the gizmo need, in glTF's conventions:
// quaternions [x, y, z, w], column-major 4x4 matrices (m[col * 4 + row]), a node's local
// matrix T * R * S, and a camera projection that matches the server's (renderer/scene/camera.c:
// right = forward x up, a pixel's ray forward + ndc.x * right * tan(fov/2) * aspect +
// ndc.y * up * tan(fov/2)). No DOM.

export const sub3 = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
export const add3 = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
export const scale3 = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
export const dot3 = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
export const cross3 = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
export const len3 = (a) => Math.hypot(a[0], a[1], a[2]);
export const norm3 = (a) => { const l = len3(a) || 1; return [a[0] / l, a[1] / l, a[2] / l]; };

/* a * b (apply b first). */
export function quatMul(a, b) {
  const [ax, ay, az, aw] = a, [bx, by, bz, bw] = b;
  return [aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
    aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz];
}

export function quatNormalize(q) {
  const l = Math.hypot(...q) || 1;
  return q.map((v) => v / l);
}

/* Rotation by angle (radians) about a unit axis. */
export function quatAxisAngle(axis, angle) {
  const s = Math.sin(angle / 2);
  return [axis[0] * s, axis[1] * s, axis[2] * s, Math.cos(angle / 2)];
}

/* Euler angles in degrees, order XYZ (R = Rx * Ry * Rz, as three.js's 'XYZ'), to a quaternion
 * and back. */
export function eulerToQuat(deg) {
  const [x, y, z] = deg.map((d) => (d * Math.PI) / 180);
  const qx = quatAxisAngle([1, 0, 0], x), qy = quatAxisAngle([0, 1, 0], y), qz = quatAxisAngle([0, 0, 1], z);
  return quatNormalize(quatMul(quatMul(qx, qy), qz));
}

export function quatToEuler(q) {
  const m = mat4FromTrs([0, 0, 0], q, [1, 1, 1]);
  const m13 = m[8], m11 = m[0], m12 = m[4], m23 = m[9], m33 = m[10], m32 = m[6], m22 = m[5];
  const y = Math.asin(Math.max(-1, Math.min(1, m13)));
  let x, z;
  if (Math.abs(m13) < 0.9999999) {
    x = Math.atan2(-m23, m33);
    z = Math.atan2(-m12, m11);
  } else {
    x = Math.atan2(m32, m22);
    z = 0;
  }
  return [x, y, z].map((r) => (r * 180) / Math.PI);
}

export function mat4FromTrs(t, q, s) {
  const [x, y, z, w] = quatNormalize(q);
  const xx = x * x, yy = y * y, zz = z * z, xy = x * y, xz = x * z, yz = y * z, wx = w * x, wy = w * y, wz = w * z;
  return [
    (1 - 2 * (yy + zz)) * s[0], 2 * (xy + wz) * s[0], 2 * (xz - wy) * s[0], 0,
    2 * (xy - wz) * s[1], (1 - 2 * (xx + zz)) * s[1], 2 * (yz + wx) * s[1], 0,
    2 * (xz + wy) * s[2], 2 * (yz - wx) * s[2], (1 - 2 * (xx + yy)) * s[2], 0,
    t[0], t[1], t[2], 1,
  ];
}

export function mat4Mul(a, b) {
  const o = new Array(16).fill(0);
  for (let c = 0; c < 4; c++) for (let r = 0; r < 4; r++) {
    let v = 0;
    for (let k = 0; k < 4; k++) v += a[k * 4 + r] * b[c * 4 + k];
    o[c * 4 + r] = v;
  }
  return o;
}

export const IDENTITY = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1];

/* The direction m carries v to (no translation). */
export const mat4Dir = (m, v) => [0, 1, 2].map((r) => m[r] * v[0] + m[4 + r] * v[1] + m[8 + r] * v[2]);
export const mat4Point = (m, p) => add3(mat4Dir(m, p), [m[12], m[13], m[14]]);

/* The camera of OrbitCamera (camera.js) as the server builds it. */
export function cameraBasis(camera) {
  const eye = camera.position();
  const fwd = norm3(camera.forward());
  let right = cross3(fwd, [0, 1, 0]);
  if (len3(right) < 1e-6) right = [1, 0, 0];
  right = norm3(right);
  const up = cross3(right, fwd);
  return { eye, fwd, right, up, ty: Math.tan((camera.fov * Math.PI) / 360) };
}

/* World point -> { x, y } in the picture rect (CSS px of the page), or null when behind the
 * camera. rect: { left, top, width, height }. */
export function project(basis, rect, p) {
  const d = sub3(p, basis.eye);
  const z = dot3(d, basis.fwd);
  if (z <= 1e-6) return null;
  const tx = basis.ty * (rect.width / rect.height);
  const nx = dot3(d, basis.right) / (z * tx), ny = dot3(d, basis.up) / (z * basis.ty);
  return { x: rect.left + (nx + 1) * 0.5 * rect.width, y: rect.top + (1 - ny) * 0.5 * rect.height, depth: z };
}

/* The unit ray through page point (x, y) of the picture rect. */
export function rayAt(basis, rect, x, y) {
  const nx = ((x - rect.left) / rect.width) * 2 - 1, ny = 1 - ((y - rect.top) / rect.height) * 2;
  const tx = basis.ty * (rect.width / rect.height);
  return norm3(add3(basis.fwd, add3(scale3(basis.right, nx * tx), scale3(basis.up, ny * basis.ty))));
}
