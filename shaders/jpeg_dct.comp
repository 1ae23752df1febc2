#version 460
/* jpeg_dct.comp: the lossy half of a baseline 4:2:0 JPEG encode, one 16x16 MCU a workgroup
 * (renderer/encode/jpeg_dct.h; the entropy coding follows on the CPU: server/encode/jpeg_coefs.h). Mirrors
 * libjpeg(-turbo) step by step so that the entropy coder on the CPU (jpeg_write_coefficients)
 * writes what one libjpeg encode of the frame would:
 *  - colour: JFIF RGB -> YCbCr in libjpeg's 16-bit fixed point (jccolor.c rgb_ycc_convert),
 *    bit exact;
 *  - edges: pixels past the right and bottom edges replicate the last column and row
 *    (jcsample.c expand_right_edge, jcprepct.c expand_bottom_edge); chroma rows below the
 *    image replicate the last chroma row;
 *  - chroma: 2x2 averages of the 8-bit Cb and Cr with libjpeg's alternating bias 1, 2, 1, 2...
 *    (jcsample.c h2v2_downsample), bit exact;
 *  - DCT: the 8x8 forward DCT-II of ITU-T T.81 A.3.3 on level-shifted samples, in float,
 *    separable (rows, then columns);
 *  - quantisation: F / Q rounded half away from zero (jcdctmgr.c quantize), Q in natural order.
 * push (pc_push): buf0 = the frame, one uint a pixel (R in the low byte, as packUnorm4x8 writes
 * it: the renderer's RGBA8 view buffer), buf1 = coefficients out, buf2 = quantisation tables,
 * 128 uints a quality from quality 1 on (luma, chroma; natural order), globals = the qualities
 * of up to 8 sets, one a byte from the lowest (0 ends the list), params = (width, height, MCU
 * columns, MCU rows). Set i is written at buf1 + i * the bytes of one set: the transform runs
 * once for all of them.
 * Coefficients: three planes of 8x8 blocks, 64 int16 a block in natural order (row = vertical
 * frequency), rows of blocks top to bottom: Y (2 * MCU columns x 2 * MCU rows blocks), then Cb,
 * then Cr (MCU columns x MCU rows each): libjpeg's coefficient arrays (jvirt_barray) end to end.
 * Blocks past the image's last block column or row are written too but never encoded. */
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require

#include "gpu_types.h"

layout(local_size_x = 16, local_size_y = 16) in;

layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer JpegPixels { uint v[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) writeonly buffer JpegCoefs { uint v[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer JpegQuant { uint v[]; };

layout(push_constant) uniform Push
{
    pc_push pc;
};

shared int s_cb[256], s_cr[256]; /* full-resolution chroma of the MCU, 16 x 16 */
shared float s_in[6 * 64];       /* level-shifted samples: Y blocks 0-3 (2x2), Cb, Cr */
shared float s_rows[6 * 64];     /* after the row transform: [block][y][u] */
shared float s_basis[64];        /* [u][x] = C(u) / 2 cos((2x + 1) u pi / 16) */

void main()
{
    const uint w = pc.params.x, h = pc.params.y, mcu_cols = pc.params.z, mcu_rows = pc.params.w;
    const uvec2 l = gl_LocalInvocationID.xy;
    const uint t = gl_LocalInvocationIndex;
    const uvec2 mcu = gl_WorkGroupID.xy;

    if (t < 64u) {
        uint u = t >> 3, x = t & 7u;
        float c = u == 0u ? 0.35355339059327373 : 0.5; /* C(u) / 2, C(0) = 1 / sqrt(2) */
        s_basis[t] = c * cos(float((2u * x + 1u) * u) * 0.19634954084936207);
    }

    /* colour conversion (jccolor.c: FIX(x) = x * 65536 rounded; ONE_HALF = 32768) */
    uvec2 p = min(mcu * 16u + l, uvec2(w - 1u, h - 1u));
    uint px = JpegPixels(pc.buf0).v[p.y * w + p.x];
    int r = int(px & 255u), g = int((px >> 8) & 255u), b = int((px >> 16) & 255u);
    int y = (19595 * r + 38470 * g + 7471 * b + 32768) >> 16;
    const int cbcr_offset = (128 << 16) + 32768 - 1;
    s_cb[t] = (-11059 * r - 21709 * g + 32768 * b + cbcr_offset) >> 16;
    s_cr[t] = (32768 * r - 27439 * g - 5329 * b + cbcr_offset) >> 16;
    s_in[((l.y >> 3) * 2u + (l.x >> 3)) * 64u + (l.y & 7u) * 8u + (l.x & 7u)] = float(y - 128);
    barrier();

    /* 2x2 chroma averages with the bias of h2v2_downsample: 1 in even columns, 2 in odd ones.
     * Below the image libjpeg replicates the last chroma row (jcprepct.c pads the full-resolution
     * rows to one row pair only, then the downsampled rows to the block), while right of it the
     * full-resolution columns are replicated before averaging (as the load above does). */
    if (t < 128u) {
        uint k = t & 63u, cx = k & 7u, cy = min(k >> 3, (h + 1u) / 2u - 1u - mcu.y * 8u);
        uint i = cy * 32u + cx * 2u;
        int bias = int(cx & 1u) + 1;
        int v = t < 64u ? s_cb[i] + s_cb[i + 1u] + s_cb[i + 16u] + s_cb[i + 17u]
                        : s_cr[i] + s_cr[i + 1u] + s_cr[i + 16u] + s_cr[i + 17u];
        s_in[(t < 64u ? 4u : 5u) * 64u + k] = float(((v + bias) >> 2) - 128);
    }
    barrier();

    /* rows: s_rows[b][y][u] = sum_x s_in[b][y][x] basis[u][x] */
    for (uint i = t; i < 6u * 64u; i += 256u) {
        uint row = i >> 3, u = i & 7u;
        float acc = 0.0;
        for (uint x = 0u; x < 8u; x++)
            acc += s_in[row * 8u + x] * s_basis[u * 8u + x];
        s_rows[i] = acc;
    }
    barrier();

    /* columns, quantisation and the store: one thread a pair of neighbouring coefficients */
    if (t < 192u) {
        uint blk = t >> 5, k0 = (t & 31u) * 2u, v = k0 >> 3;
        uint table = blk < 4u ? 0u : 64u;
        float f[2];
        for (uint j = 0u; j < 2u; j++) {
            uint u = (k0 + j) & 7u;
            f[j] = 0.0;
            for (uint yy = 0u; yy < 8u; yy++)
                f[j] += s_rows[blk * 64u + yy * 8u + u] * s_basis[v * 8u + yy];
        }
        uint plane, bw, bx, by;
        if (blk < 4u) {
            plane = 0u;
            bw = 2u * mcu_cols;
            bx = mcu.x * 2u + (blk & 1u);
            by = mcu.y * 2u + (blk >> 1);
        } else {
            plane = (blk == 4u ? 4u : 5u) * mcu_cols * mcu_rows;
            bw = mcu_cols;
            bx = mcu.x;
            by = mcu.y;
        }
        uint word = (plane + by * bw + bx) * 32u + (k0 >> 1);
        uint set_words = 6u * mcu_cols * mcu_rows * 32u;
        /* one set of coefficients a quality, the transform shared */
        for (uint i = 0u; i < 8u; i++) {
            uint quality = uint(pc.globals >> (8u * i)) & 255u;
            if (quality == 0u) break;
            uint base = (quality - 1u) * 128u + table + k0;
            int q[2];
            for (uint j = 0u; j < 2u; j++) {
                float d = f[j] / float(JpegQuant(pc.buf2).v[base + j]);
                q[j] = int(sign(d) * floor(abs(d) + 0.5));
            }
            JpegCoefs(pc.buf1).v[i * set_words + word] = (uint(q[0]) & 0xffffu) | (uint(q[1]) << 16);
        }
    }
}
