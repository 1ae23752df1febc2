#version 460
/* video_i420.comp: a view's RGBA8 frame as I420 for the video encoders (renderer/encode/video_i420.h),
 * BT.601 limited range in 16-bit fixed point, bit exact with server/encode/video_encoder.c's
 * srv_video_rgba_to_i420 (the CPU path and the tests' reference):
 *   Y  = (16829 R + 33039 G + 6416 B + (16 << 16) + 32768) >> 16
 *   Cb = (-9714 R - 19070 G + 28784 B + (512 << 16) + 131072) >> 18, R G B sums of a 2x2 block
 *   Cr = (28784 R - 24103 G - 4681 B + (512 << 16) + 131072) >> 18
 * An odd last column or row averages what it has (the block's missing pixels repeat the last
 * column or row, which gives the same sums).
 * One invocation writes 8 x 2 pixels: two words of Y on each of the two rows and one word each
 * of Cb and Cr (4 chroma samples). Planes end to end: Y (y_stride bytes a row, height rows),
 * Cb then Cr (y_stride / 2 bytes a row, (height + 1) / 2 rows each); y_stride is the width
 * rounded up to 8, and the bytes past the width repeat the last column.
 * push (pc_push): buf0 = the frame, one uint a pixel (R in the low byte), buf1 = the planes,
 * params = (width, height, y_stride / 4 (words a Y row), 0). */
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require

#include "gpu_types.h"

layout(local_size_x = 8, local_size_y = 8) in;

layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer I420Pixels { uint v[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) writeonly buffer I420Planes { uint v[]; };

layout(push_constant) uniform Push
{
    pc_push pc;
};

uint luma(uvec3 c)
{
    return (16829u * c.r + 33039u * c.g + 6416u * c.b + (16u << 16) + 32768u) >> 16;
}

void main()
{
    const uint w = pc.params.x, h = pc.params.y, y_words = pc.params.z;
    const uint gx = gl_GlobalInvocationID.x, row = gl_GlobalInvocationID.y; /* chroma row */
    if (gx >= y_words / 2u || row >= (h + 1u) / 2u) return;
    I420Pixels src = I420Pixels(pc.buf0);
    I420Planes dst = I420Planes(pc.buf1);
    const uint y0 = 2u * row, y1 = min(y0 + 1u, h - 1u);
    uvec3 px[2][8];
    for (uint i = 0u; i < 8u; i++) {
        uint x = min(8u * gx + i, w - 1u);
        uint p0 = src.v[y0 * w + x], p1 = src.v[y1 * w + x];
        px[0][i] = uvec3(p0 & 255u, (p0 >> 8) & 255u, (p0 >> 16) & 255u);
        px[1][i] = uvec3(p1 & 255u, (p1 >> 8) & 255u, (p1 >> 16) & 255u);
    }
    for (uint r = 0u; r < 2u; r++) {
        if (r == 1u && y0 + 1u >= h) break;
        for (uint k = 0u; k < 2u; k++) {
            uint word = 0u;
            for (uint b = 0u; b < 4u; b++)
                word |= luma(px[r][4u * k + b]) << (8u * b);
            dst.v[(y0 + r) * y_words + 2u * gx + k] = word;
        }
    }
    const uint c_words = y_words / 2u, c_rows = (h + 1u) / 2u;
    const uint cb_at = h * y_words, cr_at = cb_at + c_rows * c_words;
    uint cb = 0u, cr = 0u;
    for (uint b = 0u; b < 4u; b++) {
        ivec3 s = ivec3(px[0][2u * b] + px[0][2u * b + 1u] + px[1][2u * b] + px[1][2u * b + 1u]);
        int u = (-9714 * s.r - 19070 * s.g + 28784 * s.b + (512 << 16) + 131072) >> 18;
        int v = (28784 * s.r - 24103 * s.g - 4681 * s.b + (512 << 16) + 131072) >> 18;
        cb |= uint(u) << (8u * b);
        cr |= uint(v) << (8u * b);
    }
    dst.v[cb_at + row * c_words + gx] = cb;
    dst.v[cr_at + row * c_words + gx] = cr;
}
