// api.js: the HTTP API v1 (protocol/openapi.yaml) as promises.
//
// Contract: every call resolves to the parsed JSON body (or null for 204 / HEAD / empty bodies)
// or rejects with an ApiError carrying the server's {"error", "message"} (status 0 and code
// "network" when the server cannot be reached). The bearer token lives in sessionStorage; a 401
// asks onUnauthorized() once for a token (concurrent 401s share one prompt) and retries once.

const TOKEN_KEY = 'probecast.token';
const DEFAULT_TIMEOUT_MS = 15000;

export class ApiError extends Error {
  constructor(status, code, message) {
    super(message);
    this.name = 'ApiError';
    this.status = status;
    this.code = code;
  }
}

/* The server answers errors as {"error": code, "message": sentence}; anything else (a proxy's
 * HTML page, a truncated body) becomes a generic sentence with the status. */
function errorFrom(status, text) {
  try {
    const j = JSON.parse(text);
    if (j && typeof j.message === 'string') return new ApiError(status, String(j.error || 'error'), j.message);
  } catch { /* not JSON */ }
  return new ApiError(status, 'http_' + status, `The server answered ${status}${text ? ': ' + text.slice(0, 200) : ''}.`);
}

export class Api {
  /* onUnauthorized(error) -> Promise<string|null>: a new token, or null to give up. */
  constructor({ onUnauthorized = async () => null } = {}) {
    this.onUnauthorized = onUnauthorized;
    this._authWait = null;
    // A token in the address (?token=...) as printed by `probecast serve --token` is moved to
    // sessionStorage and taken out of the visible URL.
    const url = new URL(location.href);
    const t = url.searchParams.get('token');
    if (t) {
      this.token = t;
      url.searchParams.delete('token');
      history.replaceState(null, '', url.pathname + (url.search || '') + url.hash);
    }
  }

  get token() {
    try { return sessionStorage.getItem(TOKEN_KEY) || ''; } catch { return ''; }
  }
  set token(t) {
    try {
      if (t) sessionStorage.setItem(TOKEN_KEY, t);
      else sessionStorage.removeItem(TOKEN_KEY);
    } catch { /* storage disabled: the token lives as long as the prompt answer */ }
  }

  headers(extra = {}) {
    const h = { ...extra };
    const t = this.token;
    if (t) h.Authorization = 'Bearer ' + t;
    return h;
  }

  /* Waits for a token after a 401; all callers that hit 401 meanwhile wait for the same answer. */
  async reauthorize(err) {
    if (!this._authWait) {
      this._authWait = Promise.resolve(this.onUnauthorized(err)).then((t) => {
        if (t) this.token = t;
        return !!t;
      }).finally(() => { this._authWait = null; });
    }
    return this._authWait;
  }

  /* method, path ('/v1/...'), optional JSON body. */
  async request(method, path, body, { timeoutMs = DEFAULT_TIMEOUT_MS, auth = true } = {}) {
    for (let attempt = 0; ; attempt++) {
      const ctl = new AbortController();
      const timer = setTimeout(() => ctl.abort(), timeoutMs);
      let res;
      try {
        res = await fetch(path, {
          method,
          headers: this.headers(body !== undefined ? { 'Content-Type': 'application/json' } : {}),
          body: body !== undefined ? JSON.stringify(body) : undefined,
          signal: ctl.signal,
          cache: 'no-store',
        });
      } catch (e) {
        throw new ApiError(0, 'network', ctl.signal.aborted ? 'The server did not answer in time.'
                                                           : 'The server cannot be reached.');
      } finally {
        clearTimeout(timer);
      }
      const text = method === 'HEAD' ? '' : await res.text().catch(() => '');
      if (res.ok) {
        if (!text) return null;
        try { return JSON.parse(text); } catch { return text; }
      }
      const err = errorFrom(res.status, text);
      if (res.status === 401 && auth && attempt === 0 && (await this.reauthorize(err))) continue;
      throw err;
    }
  }

  /* GET of a binary body (an image): resolves to a Blob; errors like request(). */
  async blob(path, { timeoutMs = DEFAULT_TIMEOUT_MS } = {}) {
    for (let attempt = 0; ; attempt++) {
      const ctl = new AbortController();
      const timer = setTimeout(() => ctl.abort(), timeoutMs);
      let res;
      try {
        res = await fetch(path, { headers: this.headers({}), signal: ctl.signal, cache: 'no-store' });
        if (res.ok) return await res.blob();
      } catch (e) {
        throw new ApiError(0, 'network', ctl.signal.aborted ? 'The server did not answer in time.'
                                                           : 'The server cannot be reached.');
      } finally {
        clearTimeout(timer);
      }
      const err = errorFrom(res.status, await res.text().catch(() => ''));
      if (res.status === 401 && attempt === 0 && (await this.reauthorize(err))) continue;
      throw err;
    }
  }

  /* PUT of a binary body (a file) with its media type; resolves to the JSON answer. */
  async putBytes(path, body, type, { timeoutMs = 120000 } = {}) {
    for (let attempt = 0; ; attempt++) {
      const ctl = new AbortController();
      const timer = setTimeout(() => ctl.abort(), timeoutMs);
      let res;
      try {
        res = await fetch(path, { method: 'PUT', headers: this.headers({ 'Content-Type': type }),
          body, signal: ctl.signal, cache: 'no-store' });
      } catch (e) {
        throw new ApiError(0, 'network', ctl.signal.aborted ? 'The server did not answer in time.'
                                                           : 'The server cannot be reached.');
      } finally {
        clearTimeout(timer);
      }
      const text = await res.text().catch(() => '');
      if (res.ok) {
        try { return text ? JSON.parse(text) : null; } catch { return text; }
      }
      const err = errorFrom(res.status, text);
      if (res.status === 401 && attempt === 0 && (await this.reauthorize(err))) continue;
      throw err;
    }
  }

  get(path, opts) { return this.request('GET', path, undefined, opts); }
  patch(path, body, opts) { return this.request('PATCH', path, body, opts); }
  post(path, body, opts) { return this.request('POST', path, body, opts); }
  put(path, body, opts) { return this.request('PUT', path, body, opts); }
  del(path, opts) { return this.request('DELETE', path, undefined, opts); }

  /* Checks the token against a route that needs it (HEAD /v1/frame.jpg answers 401 before
   * anything else); prompts through onUnauthorized when it is missing or wrong. Resolves true
   * when the server accepts the token. */
  async checkToken() {
    try {
      await this.request('HEAD', '/v1/frame.jpg');
      return true;
    } catch (e) {
      return e.status !== 401 && e.status !== 0;
    }
  }

  /* PUT a File/Blob with upload progress (fetch has none): onProgress(fraction 0..1, phase) with
   * phase 'upload' while bytes go out and 'process' while the server validates the scene.
   * Returns { promise, abort }; the promise settles like request(). */
  upload(path, file, contentType, onProgress = () => {}) {
    let xhr = null;
    let aborted = false;
    const once = () => new Promise((resolve, reject) => {
      xhr = new XMLHttpRequest();
      xhr.open('PUT', path);
      for (const [k, v] of Object.entries(this.headers({ 'Content-Type': contentType }))) xhr.setRequestHeader(k, v);
      xhr.upload.onprogress = (e) => {
        if (e.lengthComputable) onProgress(e.total ? e.loaded / e.total : 1, e.loaded >= e.total ? 'process' : 'upload');
      };
      xhr.upload.onload = () => onProgress(1, 'process');
      xhr.onload = () => {
        if (xhr.status >= 200 && xhr.status < 300) {
          try { resolve(xhr.responseText ? JSON.parse(xhr.responseText) : null); } catch { resolve(null); }
        } else {
          reject(errorFrom(xhr.status, xhr.responseText));
        }
      };
      xhr.onerror = () => reject(new ApiError(0, 'network',
        'The upload was cut off: the server closed the connection (is the file larger than its --max-upload?) or went away.'));
      xhr.onabort = () => reject(new ApiError(0, 'aborted', 'The upload was cancelled.'));
      onProgress(0, 'upload');
      xhr.send(file);
    });
    const promise = (async () => {
      try {
        return await once();
      } catch (e) {
        if (e.status === 401 && !aborted && (await this.reauthorize(e))) return once();
        throw e;
      }
    })();
    return { promise, abort: () => { aborted = true; if (xhr) xhr.abort(); } };
  }
}

/* The Content-Type for a scene file: by extension, then by the browser's guess. */
export function sceneContentType(file) {
  const name = (file.name || '').toLowerCase();
  if (name.endsWith('.glb')) return 'model/gltf-binary';
  if (name.endsWith('.gltf')) return 'model/gltf+json';
  if (file.type === 'model/gltf-binary' || file.type === 'model/gltf+json') return file.type;
  return 'application/octet-stream';
}
