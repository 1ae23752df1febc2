// video.js: the stream's video frames (protocol/stream.md, the "video" message; issue 26),
// decoded with WebCodecs' VideoDecoder into VideoFrames that the canvas draws like decoded JPEGs.
//
// Video packets depend on the ones before them: every packet is decoded, in order, from a key
// frame on (the server never skips one for a video viewer). A packet this side cannot feed the
// decoder (a frame of a view left behind, one before the first key frame) makes the path wait
// for a key frame, which the stream asks for by sending its video request again.

export const FORMAT_JPEG = 0;
export const FORMAT_VP8 = 1;
export const FORMAT_VP9 = 2;
// WebCodecs codec strings: VP9 profile 0, level 4.1 (up to 1080p60), 8 bits.
export const CODECS = {
  vp9: { format: FORMAT_VP9, config: 'vp09.00.41.08' },
  vp8: { format: FORMAT_VP8, config: 'vp8' },
};

/* The first codec (vp9, then vp8) this browser's VideoDecoder supports, or null. */
export async function probeVideoCodec() {
  if (typeof VideoDecoder !== 'function' || typeof EncodedVideoChunk !== 'function') return null;
  for (const name of ['vp9', 'vp8']) {
    try {
      const r = await VideoDecoder.isConfigSupported({ codec: CODECS[name].config, optimizeForLatency: true });
      if (r && r.supported) return name;
    } catch {
      // an unknown codec string throws in some browsers: not supported
    }
  }
  return null;
}

/* VideoPath: one VideoDecoder for one connection's video frames.
 *   onFrame(header, { image: VideoFrame, width, height, close() }): a decoded frame, in order;
 *   onError(error): the decoder failed; the path is closed (the stream falls back to JPEG). */
export class VideoPath {
  constructor(codec, { onFrame, onError }) {
    this.codec = codec;
    this.format = CODECS[codec].format;
    this.onFrame = onFrame;
    this.onError = onError;
    this.headers = new Map(); // frame id (the chunk's timestamp) -> header, until decoded
    this.needKey = true;
    this.closed = false;
    this.decoded = 0;
    this.decoder = new VideoDecoder({ output: (vf) => this.output(vf), error: (e) => this.fail(e) });
    this.decoder.configure({ codec: CODECS[codec].config, optimizeForLatency: true });
  }

  /* Feeds one packet (h: its parsed header; data: the whole message). False when it could not be
   * used (before a key frame, or closed): the caller asks for a key frame. */
  decode(h, data) {
    if (this.closed || h.format !== this.format) return false;
    if (this.needKey && !h.key) return false;
    this.needKey = false;
    this.headers.set(h.frameId, h);
    try {
      this.decoder.decode(new EncodedVideoChunk({
        type: h.key ? 'key' : 'delta',
        timestamp: h.frameId,
        data: new Uint8Array(data, h.headerSize, h.jpegSize),
      }));
    } catch (e) {
      this.fail(e);
      return false;
    }
    return true;
  }

  /* A packet was missed: decode nothing until the next key frame. */
  resync() { this.needKey = true; }

  output(vf) {
    const h = this.headers.get(vf.timestamp);
    for (const id of this.headers.keys()) if (id <= vf.timestamp) this.headers.delete(id);
    if (!h || this.closed) { vf.close(); return; }
    this.decoded++;
    this.onFrame(h, { image: vf, width: h.width, height: h.height, close: () => vf.close() });
  }

  fail(e) {
    if (this.closed) return;
    this.close();
    this.onError(e);
  }

  close() {
    this.closed = true;
    this.headers.clear();
    try {
      if (this.decoder.state !== 'closed') this.decoder.close();
    } catch {
      // already closed
    }
  }
}
