// lbvh_sort.comp: an LSD radix sort (Satish, Harris and Garland 2009, "Designing Efficient
// Sorting Algorithms for Manycore GPUs", sec. 4: tile histograms, their scan, a scatter) of the
// LBVH keys (renderer/accel/gpu_lbvh.c): n keys (uvec2: x the payload, the triangle index; y the
// 32-bit code), stable by y, in 4 passes of 8 bits (y >> 0, 8, 16, 24), each from one key
// buffer to the other, so the sorted keys end where they began. As lbvh_morton writes the keys
// in triangle order, the result is ascending by (Morton code, triangle index). Each pass is
// five dispatches (params.w, the kind):
//   0: histogram: a workgroup counts the digits of its tile of PC_LBVH_SORT_TILE keys and writes
//      count(d, tile) at hist[d * tiles + tile] (digit-major, so that an exclusive prefix sum of
//      hist in order gives each (digit, tile)'s first output slot);
//   1: the sum of each block of PC_LBVH_SORT_SCAN_BLOCK hist words to sums[block];
//   2: one workgroup: the exclusive prefix sum of sums, in place;
//   3: each block's exclusive prefix sum of hist, in place, from its sums[block];
//   4: scatter: a workgroup walks its tile in rounds of PC_WG_1D keys in order; a key's slot
//      is its (digit, tile)'s next free slot (shared memory) plus the keys of the same digit
//      before it in its round (a count over the round's digits, packed 4 to a word in shared
//      memory): stable.
// Every dispatch is 1D work in rows (lbvh_group); a group past the work returns whole.
// Push constants (pc_push): buf0 = keys in, buf1 = keys out (0, 4) or sums (1, 2, 3),
// buf2 = hist; params.x = n (0, 4) or hist words (1, 2, 3), params.y = the digit's shift,
// params.z = tiles, params.w = kind. gpu_lbvh.c mirrors PC_LBVH_SORT_TILE and
// PC_LBVH_SORT_SCAN_BLOCK.
#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require

#include "gpu_types.h"
#include "lbvh.glsl"

layout(local_size_x = PC_WG_1D) in;


layout(push_constant) uniform Push
{
    pc_push pc;
};

layout(buffer_reference, std430, buffer_reference_align = 4) buffer RadixUints
{
    uint v[];
};

shared uint g_count[PC_LBVH_SORT_DIGITS]; // a tile's digit counts (0), next free slots (4)
shared uint g_digits[2][PC_WG_1D / 4u]; // a round's digits, 4 a word (4; by round parity)
shared uint g_scan[PC_WG_1D];

// The exclusive prefix sum of v over the workgroup (Hillis and Steele), total its sum; every
// thread of the group calls it.
uint group_exclusive(uint v, out uint total)
{
    uint t = gl_LocalInvocationID.x;
    g_scan[t] = v;
    barrier();
    for (uint o = 1u; o < PC_WG_1D; o <<= 1) {
        uint add = t >= o ? g_scan[t - o] : 0u;
        barrier();
        g_scan[t] += add;
        barrier();
    }
    uint inclusive = g_scan[t];
    total = g_scan[PC_WG_1D - 1u];
    barrier();
    return inclusive - v;
}

uint digit_of(uvec2 key, uint shift)
{
    return (key.y >> shift) & (PC_LBVH_SORT_DIGITS - 1u);
}

void histogram(uint tile, uint t)
{
    LbvhKeys keys = LbvhKeys(pc.buf0);
    uint n = pc.params.x, shift = pc.params.y, tiles = pc.params.z;
    for (uint d = t; d < PC_LBVH_SORT_DIGITS; d += PC_WG_1D)
        g_count[d] = 0u;
    barrier();
    uint base = tile * PC_LBVH_SORT_TILE;
    for (uint r = 0u; r < PC_LBVH_SORT_ROUNDS; r++) {
        uint i = base + r * PC_WG_1D + t;
        if (i < n) atomicAdd(g_count[digit_of(keys.k[i], shift)], 1u);
    }
    barrier();
    RadixUints hist = RadixUints(pc.buf2);
    for (uint d = t; d < PC_LBVH_SORT_DIGITS; d += PC_WG_1D)
        hist.v[d * tiles + tile] = g_count[d];
}

// Bytes of packed that are zero: 0x80 in each (exact, no borrow between bytes).
uint zero_bytes(uint packed)
{
    return ~(((packed & 0x7f7f7f7fu) + 0x7f7f7f7fu) | packed | 0x7f7f7f7fu);
}

void scatter(uint tile, uint t)
{
    LbvhKeys src = LbvhKeys(pc.buf0), dst = LbvhKeys(pc.buf1);
    RadixUints hist = RadixUints(pc.buf2);
    uint n = pc.params.x, shift = pc.params.y, tiles = pc.params.z;
    for (uint d = t; d < PC_LBVH_SORT_DIGITS; d += PC_WG_1D)
        g_count[d] = hist.v[d * tiles + tile];
    if (t < PC_WG_1D / 4u) g_digits[0][t] = 0u;
    barrier();
    uint base = tile * PC_LBVH_SORT_TILE;
    for (uint r = 0u; r < PC_LBVH_SORT_ROUNDS; r++) {
        uint i = base + r * PC_WG_1D + t, buf = r & 1u;
        uvec2 key = i < n ? src.k[i] : uvec2(0u);
        uint d = digit_of(key, shift);
        // the keys past n, at the round's end, stay 0 bytes: no thread before them reads them
        if (i < n) atomicOr(g_digits[buf][t / 4u], d << (8u * (t % 4u)));
        barrier(); // the round's digits, and the slots the last round left
        if (t < PC_WG_1D / 4u) g_digits[buf ^ 1u][t] = 0u; // for the next round
        // the keys of digit d before this one in the round (4 a word)
        uint before = 0u;
        for (uint w = 0u; w < PC_WG_1D / 4u && 4u * w < t; w++) {
            uint lanes = min(t - 4u * w, 4u), mask = lanes == 4u ? ~0u : (1u << (8u * lanes)) - 1u;
            before += bitCount(zero_bytes(g_digits[buf][w] ^ (d * 0x01010101u)) & mask);
        }
        uint slot = g_count[d] + before;
        barrier(); // every thread has read g_count before any moves it on
        if (i < n) {
            dst.k[slot] = key;
            atomicAdd(g_count[d], 1u);
        }
    }
}

void main()
{
    uint kind = pc.params.w, group = lbvh_group(), t = gl_LocalInvocationID.x;
    if (kind == 0u || kind == 4u) {
        if (group >= pc.params.z) return; // past the last tile: the whole group
        if (kind == 0u)
            histogram(group, t);
        else
            scatter(group, t);
        return;
    }
    RadixUints hist = RadixUints(pc.buf2), sums = RadixUints(pc.buf1);
    uint words = pc.params.x;
    uint blocks = (words + PC_LBVH_SORT_SCAN_BLOCK - 1u) / PC_LBVH_SORT_SCAN_BLOCK, total;
    if (kind == 2u) { // one group: sums[0, blocks) in chunks of PC_LBVH_SORT_SCAN_BLOCK
        uint carry = 0u;
        for (uint base = 0u; base < blocks; base += PC_LBVH_SORT_SCAN_BLOCK) {
            uint first = base + t * PC_LBVH_SORT_SCAN_PER_THREAD, own = 0u;
            for (uint k = 0u; k < PC_LBVH_SORT_SCAN_PER_THREAD; k++)
                own += first + k < blocks ? sums.v[first + k] : 0u;
            uint at = carry + group_exclusive(own, total);
            for (uint k = 0u; k < PC_LBVH_SORT_SCAN_PER_THREAD && first + k < blocks; k++) {
                uint v = sums.v[first + k];
                sums.v[first + k] = at;
                at += v;
            }
            carry += total;
        }
        return;
    }
    if (group >= blocks) return; // the whole group
    uint first = group * PC_LBVH_SORT_SCAN_BLOCK + t * PC_LBVH_SORT_SCAN_PER_THREAD, own = 0u;
    for (uint k = 0u; k < PC_LBVH_SORT_SCAN_PER_THREAD; k++)
        own += first + k < words ? hist.v[first + k] : 0u;
    uint at = group_exclusive(own, total);
    if (kind == 1u) {
        if (t == 0u) sums.v[group] = total;
        return;
    }
    at += sums.v[group];
    for (uint k = 0u; k < PC_LBVH_SORT_SCAN_PER_THREAD && first + k < words; k++) {
        uint v = hist.v[first + k];
        hist.v[first + k] = at;
        at += v;
    }
}
