#version 460
/* rtb_trace_cwide.comp: the benchmark's "cwide" tracer: the renderer's BVHs collapsed to
 * compressed 8-wide nodes (tests/bench/bvh_cwide.c, rtb_cwide_types.h; Ylitie, Karras, Laine,
 * HPG 2017) over the same triangles, instances and TLAS index, for tests/bench/rt_yardstick.c.
 * The traversal loop, buffers and main() are rtb_wide_trace.glsl's (shared with the 4-wide
 * tracer). Per node: the scale of each axis from its exponent byte; near and far planes picked
 * by the direction's sign on the packed bytes before decoding (the paper's sec. 3.2 swaps them
 * per ray octant the same way); each plane decoded as p + q * scale, the very float box the C
 * side made conservative, then tested with trace_box's arithmetic, four children per vector;
 * the hit children ordered by distance with an eight-input sorting network (19 comparators,
 * Knuth, TAOCP vol. 3, sec. 5.3.4) rather than the paper's octant order, and pushed one stack
 * entry each (the paper pushes one node group with a hit mask).
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

/* Entry distances of four children (INF where missed) whose near and far plane bytes per axis
 * are the words qn and qf, meta their meta bytes (0: an unused slot, never hit). */
vec4 cwide_boxes4(uvec3 qn, uvec3 qf, uint meta, vec3 p, vec3 s, vec3 o, vec3 inv, float tmin,
                  float t_cull, out bvec4 hit)
{
    vec4 t0x = (cwide_bytes(qn.x) * s.x + p.x - o.x) * inv.x;
    vec4 t1x = (cwide_bytes(qf.x) * s.x + p.x - o.x) * inv.x;
    vec4 t0y = (cwide_bytes(qn.y) * s.y + p.y - o.y) * inv.y;
    vec4 t1y = (cwide_bytes(qf.y) * s.y + p.y - o.y) * inv.y;
    vec4 t0z = (cwide_bytes(qn.z) * s.z + p.z - o.z) * inv.z;
    vec4 t1z = (cwide_bytes(qf.z) * s.z + p.z - o.z) * inv.z;
    vec4 tnear = max(max(t0x, t0y), max(t0z, vec4(tmin)));
    vec4 tfar = min(min(min(t1x, t1y), t1z) * TRACE_TFAR_SCALE, vec4(t_cull));
    uvec4 used = uvec4(notEqual(cwide_bytes(meta), vec4(0.0)));
    hit = bvec4(uvec4(lessThanEqual(tnear, tfar)) & used);
    return mix(vec4(WIDE_INF), tnear, hit);
}

/* Stack entries of four children from their meta bytes: (child_base + r, 0) for an interior
 * child, (leaf_base + r, count) for a leaf (rtb_cwide_types.h). */
void cwide_entries(uint meta, uint child_base, uint leaf_base, out uvec4 x, out uvec4 y)
{
    uvec4 m = (uvec4(meta) >> uvec4(0u, 8u, 16u, 24u)) & 0xffu;
    bvec4 inner = greaterThanEqual(m, uvec4(RTB_CWIDE_INTERIOR));
    x = mix(uvec4(leaf_base), uvec4(child_base), inner) + (m & 7u);
    y = mix(m >> 3u, uvec4(0u), inner);
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
    vec4 ka = cwide_boxes4(uvec3(qx.x, qy.x, qz.x), uvec3(qx.z, qy.z, qz.z), n.refs.z, p, s, o,
                           inv, tmin, t_cull, ha);
    vec4 kb = cwide_boxes4(uvec3(qx.y, qy.y, qz.y), uvec3(qx.w, qy.w, qz.w), n.refs.w, p, s, o,
                           inv, tmin, t_cull, hb);
    uvec4 xa, ya, xb, yb;
    cwide_entries(n.refs.z, n.refs.x, n.refs.y, xa, ya);
    cwide_entries(n.refs.w, n.refs.x, n.refs.y, xb, yb);
    float t0 = ka.x, t1 = ka.y, t2 = ka.z, t3 = ka.w, t4 = kb.x, t5 = kb.y, t6 = kb.z, t7 = kb.w;
    uvec2 e0 = uvec2(xa.x, ya.x), e1 = uvec2(xa.y, ya.y), e2 = uvec2(xa.z, ya.z);
    uvec2 e3 = uvec2(xa.w, ya.w), e4 = uvec2(xb.x, yb.x), e5 = uvec2(xb.y, yb.y);
    uvec2 e6 = uvec2(xb.z, yb.z), e7 = uvec2(xb.w, yb.w);
    wide_order(t0, e0, t2, e2);
    wide_order(t1, e1, t3, e3);
    wide_order(t4, e4, t6, e6);
    wide_order(t5, e5, t7, e7);
    wide_order(t0, e0, t4, e4);
    wide_order(t1, e1, t5, e5);
    wide_order(t2, e2, t6, e6);
    wide_order(t3, e3, t7, e7);
    wide_order(t0, e0, t1, e1);
    wide_order(t2, e2, t3, e3);
    wide_order(t4, e4, t5, e5);
    wide_order(t6, e6, t7, e7);
    wide_order(t2, e2, t4, e4);
    wide_order(t3, e3, t5, e5);
    wide_order(t1, e1, t4, e4);
    wide_order(t3, e3, t6, e6);
    wide_order(t1, e1, t2, e2);
    wide_order(t3, e3, t4, e4);
    wide_order(t5, e5, t6, e6);
    uvec4 hc = uvec4(ha) + uvec4(hb);
    uint hits = hc.x + hc.y + hc.z + hc.w;
    if (hits > 7u) wide_push(e7, t7);
    if (hits > 6u) wide_push(e6, t6);
    if (hits > 5u) wide_push(e5, t5);
    if (hits > 4u) wide_push(e4, t4);
    if (hits > 3u) wide_push(e3, t3);
    if (hits > 2u) wide_push(e2, t2);
    if (hits > 1u) wide_push(e1, t1);
    if (hits > 0u) wide_push(e0, t0);
}

uint wide_leaf_first(rtb_cwide_refs w, uint x)
{
    return WideUints(w.leaf_first).i[x];
}

uint wide_mesh_root(rtb_cwide_refs w, uint mesh)
{
    return WideUints(w.mesh_root).i[mesh];
}
