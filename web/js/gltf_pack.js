// gltf_pack.js: turns the files a user chose (several files, or a folder) into the one file
// PUT /v1/scene takes. The server reads a .glb or a self-contained .gltf only (it never fetches
// external URIs), so a .gltf whose buffers or images are separate files is packed here into a
// .glb (glTF 2.0 section 4.4, "GLB File Format Specification"): a 12-byte header, a JSON chunk
// and one BIN chunk. Every buffer's bytes that a bufferView uses are copied into the one
// buffer, and every image with a URI becomes a bufferView of it. A referenced file that was not
// chosen is an error that names it and suggests a .glb. No DOM, no network.

const GLB_MAGIC = 0x46546c67; // 'glTF'
const CHUNK_JSON = 0x4e4f534a; // 'JSON'
const CHUNK_BIN = 0x004e4942; // 'BIN\0'

export class PackError extends Error {
  constructor(message) {
    super(message);
    this.name = 'PackError';
    this.status = 0;
    this.code = 'pack';
  }
}

const IMAGE_TYPES = { png: 'image/png', jpg: 'image/jpeg', jpeg: 'image/jpeg', webp: 'image/webp', ktx2: 'image/ktx2' };
const lower = (s) => String(s || '').toLowerCase();
const ext = (name) => { const m = /\.([^./\\]+)$/.exec(name); return m ? lower(m[1]) : ''; };
const pathOf = (f) => (f.webkitRelativePath || f.relativePath || f.name || '').replace(/\\/g, '/');
const dirOf = (p) => p.slice(0, p.lastIndexOf('/') + 1);
const baseOf = (p) => p.slice(p.lastIndexOf('/') + 1);

/* a/b/../c/./d -> a/c/d */
function normalise(p) {
  const out = [];
  for (const part of p.split('/')) {
    if (part === '' || part === '.') continue;
    if (part === '..') out.pop();
    else out.push(part);
  }
  return out.join('/');
}

/* The bytes of a data: URI, or null when uri is not one. */
function dataUri(uri) {
  const m = /^data:([^,]*?),(.*)$/s.exec(uri);
  if (!m) return null;
  const meta = m[1].split(';');
  const mime = meta[0] || 'application/octet-stream';
  if (meta.includes('base64')) {
    const bin = atob(m[2]);
    const bytes = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    return { bytes, mime };
  }
  return { bytes: new TextEncoder().encode(decodeURIComponent(m[2])), mime };
}

const align4 = (n) => (n + 3) & ~3;

/* Packs a parsed .gltf into GLB bytes. load(uri) resolves an external URI to its bytes
 * (Uint8Array) or rejects with a PackError; data: URIs are decoded here. The JSON is not
 * changed in place. */
export async function packGltf(gltf, load) {
  const doc = JSON.parse(JSON.stringify(gltf));
  if (!doc.asset || typeof doc.asset.version !== 'string') throw new PackError('This is not a glTF file: it has no "asset" with a "version".');
  const buffers = await Promise.all((doc.buffers || []).map(async (b, i) => {
    if (typeof b.uri !== 'string') throw new PackError(`Buffer ${i} of the .gltf has no "uri"; only a .glb may carry a buffer without one.`);
    const d = dataUri(b.uri);
    return d ? d.bytes : load(b.uri);
  }));
  const parts = []; // Uint8Array pieces of the BIN chunk, each at a 4-byte aligned offset
  let size = 0;
  const append = (bytes) => {
    const offset = size;
    parts.push({ offset, bytes });
    size = align4(size + bytes.length);
    return offset;
  };
  for (const [i, v] of (doc.bufferViews || []).entries()) {
    const src = buffers[v.buffer];
    const start = v.byteOffset || 0;
    if (!src || start + v.byteLength > src.length)
      throw new PackError(`bufferView ${i} reaches past the end of buffer ${v.buffer} (${src ? src.length : 0} bytes).`);
    v.byteOffset = append(src.subarray(start, start + v.byteLength));
    v.buffer = 0;
  }
  const views = doc.bufferViews || (doc.bufferViews = []);
  for (const img of await Promise.all((doc.images || []).map(async (im) => {
    if (typeof im.uri !== 'string') return { im };
    const d = dataUri(im.uri);
    const bytes = d ? d.bytes : await load(im.uri);
    return { im, bytes, mime: d ? d.mime : IMAGE_TYPES[ext(im.uri.split('?')[0])] };
  }))) {
    if (!img.bytes) continue;
    views.push({ buffer: 0, byteOffset: append(img.bytes), byteLength: img.bytes.length });
    img.im.bufferView = views.length - 1;
    img.im.mimeType = img.im.mimeType || img.mime || 'image/png';
    delete img.im.uri;
  }
  if (views.length) doc.buffers = [{ byteLength: size }];
  else delete doc.buffers;
  if (!views.length) delete doc.bufferViews;

  const json = new TextEncoder().encode(JSON.stringify(doc));
  const jsonLen = align4(json.length);
  const binLen = views.length ? align4(size) : 0;
  const total = 12 + 8 + jsonLen + (binLen ? 8 + binLen : 0);
  const out = new Uint8Array(total);
  const dv = new DataView(out.buffer);
  dv.setUint32(0, GLB_MAGIC, true);
  dv.setUint32(4, 2, true);
  dv.setUint32(8, total, true);
  dv.setUint32(12, jsonLen, true);
  dv.setUint32(16, CHUNK_JSON, true);
  out.set(json, 20);
  out.fill(0x20, 20 + json.length, 20 + jsonLen); // the JSON chunk is padded with spaces
  if (binLen) {
    const at = 20 + jsonLen;
    dv.setUint32(at, binLen, true);
    dv.setUint32(at + 4, CHUNK_BIN, true);
    for (const p of parts) out.set(p.bytes, at + 8 + p.offset);
  }
  return out;
}

/* Whether a parsed .gltf names a file outside itself (a buffer or image URI that is not data:). */
export function hasExternalUris(gltf) {
  const ext = (x) => typeof x.uri === 'string' && !x.uri.startsWith('data:');
  return (gltf.buffers || []).some(ext) || (gltf.images || []).some(ext);
}

/* What to upload for the files chosen (File objects, or anything with name, arrayBuffer() and
 * text()): { body, type, name } with name the file the user meant (the .glb or .gltf). One .glb
 * goes as it is, and so does a .gltf without external files; a .gltf with them is packed with
 * the other chosen files into a .glb. Throws a PackError with a sentence for the user. */
export async function prepareSceneUpload(files) {
  files = [...files];
  const glbs = files.filter((f) => ext(f.name) === 'glb');
  const gltfs = files.filter((f) => ext(f.name) === 'gltf');
  if (glbs.length + gltfs.length === 0) {
    if (files.length === 1) return { body: files[0], type: 'application/octet-stream', name: files[0].name };
    throw new PackError('None of the chosen files is a .gltf or .glb.');
  }
  if (glbs.length + gltfs.length > 1)
    throw new PackError(`Choose one scene at a time: ${[...glbs, ...gltfs].map((f) => f.name).join(', ')} are all scenes.`);
  if (glbs.length) return { body: glbs[0], type: 'model/gltf-binary', name: glbs[0].name };
  const main = gltfs[0];
  let gltf;
  try {
    gltf = JSON.parse(await main.text());
  } catch (e) {
    throw new PackError(`${main.name} is not valid JSON (${e.message}).`);
  }
  if (!hasExternalUris(gltf)) return { body: main, type: 'model/gltf+json', name: main.name };
  const byPath = new Map(files.map((f) => [normalise(pathOf(f)), f]));
  const byBase = new Map();
  for (const f of files) {
    const b = lower(baseOf(pathOf(f)));
    byBase.set(b, byBase.has(b) ? null : f); // null: two files of this name, ambiguous
  }
  const dir = dirOf(pathOf(main));
  const load = async (uri) => {
    let rel;
    try { rel = decodeURIComponent(uri.split(/[?#]/)[0]); } catch { rel = uri; }
    const f = byPath.get(normalise(dir + rel)) || byBase.get(lower(baseOf(rel)));
    if (!f)
      throw new PackError(`${main.name} needs "${rel}", which is not among the chosen files. ` +
        'Choose it together with the .gltf (or choose the whole folder), or export the scene as one .glb file.');
    return new Uint8Array(await f.arrayBuffer());
  };
  const glb = await packGltf(gltf, load);
  return { body: new Blob([glb], { type: 'model/gltf-binary' }), type: 'model/gltf-binary', name: main.name };
}
