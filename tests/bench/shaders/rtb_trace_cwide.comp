#version 460
/* rtb_trace_cwide.comp: the benchmark's "cwide" tracer: the renderer's BVHs collapsed to
 * compressed 8-wide nodes (tests/bench/bvh_cwide.c, rtb_cwide_types.h; Ylitie, Karras, Laine,
 * HPG 2017) over the same triangles, instances and TLAS index, for tests/bench/rt_yardstick.c.
 * The traversal loop, buffers and main() are rtb_wide_trace.glsl's (shared with the 4-wide
 * tracer). Per node: the scale of each axis from its exponent byte; near and far planes picked
 * by the direction's sign on the packed bytes before decoding (the paper's sec. 3.2 swaps them
 * per ray octant the same way); each plane decoded as p + q * scale, the very float box the C
 * side made conservative, then tested with trace_box's arithmetic, four children per vector;
 * the hit children ordered by distance with an eight-input sorting network (19 min/max
 * comparators, Knuth, TAOCP vol. 3, sec. 5.3.4) over keys that carry the child's slot in their
 * low bits, rather than the paper's octant order, and pushed one stack entry each (the paper
 * pushes one node group with a hit mask).
 * push: as rtb_wide_trace.glsl says, buf2 = rtb_cwide_refs. */
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require

#include "gpu_types.h"
#include "../rtb_cwide_types.h"

#define WIDE_REFS rtb_cwide_refs
#define WIDE_STACK RTB_CWIDE_STACK
#include "../rtb_wide_trace.glsl"

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer CwideNodes { rtb_cwide_node n[]; };

/* The four bytes of w as floats, byte 0 first. */
vec4 cwide_bytes(uint w)
{
    return vec4((uvec4(w) >> uvec4(0u, 8u, 16u, 24u)) & 0xffu);
}

/* Sort keys of four children whose near and far plane bytes per axis are the words qn and qf,
 * meta their meta bytes (0: an unused slot, never hit), slot the first one's slot: the bits of
 * a hit's entry distance, sign cleared (-0.0 is the only negative one when tmin >= 0, as
 * rtb_rays.comp writes it), with its slot in the three low mantissa bits (after Ylitie et al.,
 * sec. 3.3); a miss's the largest finite float with its slot. As uints they order as the
 * distances do, and integer min/max cannot flush the denormals that keys near 0 are. */
uvec4 cwide_keys4(uvec3 qn, uvec3 qf, uint meta, uint slot, vec3 p, vec3 s, vec3 o, vec3 inv,
                 float tmin, float t_cull, out bvec4 hit)
{
    vec4 t0x = (cwide_bytes(qn.x) * s.x + p.x - o.x) * inv.x;
    vec4 t1x = (cwide_bytes(qf.x) * s.x + p.x - o.x) * inv.x;
    vec4 t0y = (cwide_bytes(qn.y) * s.y + p.y - o.y) * inv.y;
    vec4 t1y = (cwide_bytes(qf.y) * s.y + p.y - o.y) * inv.y;
    vec4 t0z = (cwide_bytes(qn.z) * s.z + p.z - o.z) * inv.z;
    vec4 t1z = (cwide_bytes(qf.z) * s.z + p.z - o.z) * inv.z;
    vec4 tnear = max(max(t0x, t0y), max(t0z, vec4(tmin)));
    vec4 tfar = min(min(min(t1x, t1y), t1z) * TRACE_TFAR_SCALE, vec4(t_cull));
    uvec4 used = uvec4(notEqual((uvec4(meta) >> uvec4(0u, 8u, 16u, 24u)) & 0xffu, uvec4(0u)));
    hit = bvec4(uvec4(lessThanEqual(tnear, tfar)) & used);
    uvec4 bits = mix(uvec4(0x7f7ffff8u), floatBitsToUint(tnear) & 0x7ffffff8u, hit);
    return bits | (uvec4(slot) + uvec4(0u, 1u, 2u, 3u));
}

/* One comparator of the sorting network: a gets the smaller key. */
void cwide_order(inout uint a, inout uint b)
{
    uint lo = min(a, b);
    b = max(a, b);
    a = lo;
}

/* Pushes the child whose sort key is k: its stack entry from its meta byte ((child_base + r, 0)
 * for an interior child, (leaf_base + r, count) for a leaf; rtb_cwide_types.h) and as entry
 * distance the key with the slot bits cleared, which is no farther than the child's box when
 * tmin >= 0, so culling stays conservative. */
void cwide_push(rtb_cwide_node n, uint k)
{
    uint slot = k & 7u;
    uint m = ((slot < 4u ? n.refs.z : n.refs.w) >> (8u * (slot & 3u))) & 0xffu;
    bool inner = m >= RTB_CWIDE_INTERIOR;
    wide_push(uvec2((inner ? n.refs.x : n.refs.y) + (m & 7u), inner ? 0u : m >> 3u),
              uintBitsToFloat(k & ~7u));
}

/* Tests eight quantised boxes and pushes the hits far to near. */
void wide_visit(rtb_cwide_refs w, uint node, vec3 o, vec3 inv, bvec3 neg, float tmin, float t_cull)
{
    rtb_cwide_node n = CwideNodes(w.nodes).n[node];
    uvec3 eb = (uvec3(floatBitsToUint(n.origin.w)) >> uvec3(0u, 8u, 16u)) & 0xffu;
    vec3 s = uintBitsToFloat(eb << 23u);
    vec3 p = n.origin.xyz;
    /* .xy: near planes of children 0-3 and 4-7 (lo, or hi for a negative direction), .zw: far */
    uvec4 qx = neg.x ? n.q_x.zwxy : n.q_x;
    uvec4 qy = neg.y ? n.q_y.zwxy : n.q_y;
    uvec4 qz = neg.z ? n.q_z.zwxy : n.q_z;
    bvec4 ha, hb;
    uvec4 ka = cwide_keys4(uvec3(qx.x, qy.x, qz.x), uvec3(qx.z, qy.z, qz.z), n.refs.z, 0u, p, s, o,
                          inv, tmin, t_cull, ha);
    uvec4 kb = cwide_keys4(uvec3(qx.y, qy.y, qz.y), uvec3(qx.w, qy.w, qz.w), n.refs.w, 4u, p, s, o,
                          inv, tmin, t_cull, hb);
    uint k0 = ka.x, k1 = ka.y, k2 = ka.z, k3 = ka.w, k4 = kb.x, k5 = kb.y, k6 = kb.z, k7 = kb.w;
    cwide_order(k0, k2);
    cwide_order(k1, k3);
    cwide_order(k4, k6);
    cwide_order(k5, k7);
    cwide_order(k0, k4);
    cwide_order(k1, k5);
    cwide_order(k2, k6);
    cwide_order(k3, k7);
    cwide_order(k0, k1);
    cwide_order(k2, k3);
    cwide_order(k4, k5);
    cwide_order(k6, k7);
    cwide_order(k2, k4);
    cwide_order(k3, k5);
    cwide_order(k1, k4);
    cwide_order(k3, k6);
    cwide_order(k1, k2);
    cwide_order(k3, k4);
    cwide_order(k5, k6);
    uvec4 hc = uvec4(ha) + uvec4(hb);
    uint hits = hc.x + hc.y + hc.z + hc.w;
    if (hits > 7u) cwide_push(n, k7);
    if (hits > 6u) cwide_push(n, k6);
    if (hits > 5u) cwide_push(n, k5);
    if (hits > 4u) cwide_push(n, k4);
    if (hits > 3u) cwide_push(n, k3);
    if (hits > 2u) cwide_push(n, k2);
    if (hits > 1u) cwide_push(n, k1);
    if (hits > 0u) cwide_push(n, k0);
}

uint wide_leaf_first(rtb_cwide_refs w, uint x)
{
    return WideUints(w.leaf_first).i[x];
}

uint wide_mesh_root(rtb_cwide_refs w, uint mesh)
{
    return WideUints(w.mesh_root).i[mesh];
}
