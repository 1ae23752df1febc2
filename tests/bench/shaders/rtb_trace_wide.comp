#version 460
/* rtb_trace_wide.comp: the benchmark's "wide" tracer: the renderer's BVHs collapsed to 4-wide
 * nodes (tests/bench/bvh_wide.c, rtb_wide_types.h) over the same triangles, instances and TLAS
 * index, for tests/bench/rt_yardstick.c. The traversal loop, buffers and main() are
 * rtb_wide_trace.glsl's (shared with the compressed 8-wide tracer); here: a node's four boxes
 * tested at once with trace_box's arithmetic and ordered by a four-element sorting network.
 * push: as rtb_wide_trace.glsl says, buf2 = rtb_wide_refs. */
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require

#include "gpu_types.h"
#include "../rtb_wide_types.h"

#define WIDE_REFS rtb_wide_refs
#define WIDE_STACK RTB_WIDE_STACK
#include "../rtb_wide_trace.glsl"

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer WideNodes { rtb_wide_node n[]; };

/* Tests four boxes at once and pushes the hits far to near. */
void wide_visit(rtb_wide_refs w, uint node, vec3 o, vec3 inv, bvec3 neg, float tmin, float t_cull)
{
    rtb_wide_node n = WideNodes(w.nodes).n[node];
    vec4 t0x = (mix(n.lo_x, n.hi_x, bvec4(neg.x)) - o.x) * inv.x;
    vec4 t1x = (mix(n.hi_x, n.lo_x, bvec4(neg.x)) - o.x) * inv.x;
    vec4 t0y = (mix(n.lo_y, n.hi_y, bvec4(neg.y)) - o.y) * inv.y;
    vec4 t1y = (mix(n.hi_y, n.lo_y, bvec4(neg.y)) - o.y) * inv.y;
    vec4 t0z = (mix(n.lo_z, n.hi_z, bvec4(neg.z)) - o.z) * inv.z;
    vec4 t1z = (mix(n.hi_z, n.lo_z, bvec4(neg.z)) - o.z) * inv.z;
    vec4 tnear = max(max(t0x, t0y), max(t0z, vec4(tmin)));
    vec4 tfar = min(min(min(t1x, t1y), t1z) * TRACE_TFAR_SCALE, vec4(t_cull));
    bvec4 hit = lessThanEqual(tnear, tfar);
    hit = bvec4(uvec4(hit) & uvec4(notEqual(n.count, uvec4(RTB_WIDE_EMPTY))));
    vec4 k = mix(vec4(WIDE_INF), tnear, hit);
    float ka = k.x, kb = k.y, kc = k.z, kd = k.w;
    uvec2 ea = uvec2(n.child.x, n.count.x), eb = uvec2(n.child.y, n.count.y);
    uvec2 ec = uvec2(n.child.z, n.count.z), ed = uvec2(n.child.w, n.count.w);
    wide_order(ka, ea, kb, eb);
    wide_order(kc, ec, kd, ed);
    wide_order(ka, ea, kc, ec);
    wide_order(kb, eb, kd, ed);
    wide_order(kb, eb, kc, ec);
    int hits = int(hit.x) + int(hit.y) + int(hit.z) + int(hit.w);
    if (hits > 3) wide_push(ed, kd);
    if (hits > 2) wide_push(ec, kc);
    if (hits > 1) wide_push(eb, kb);
    if (hits > 0) wide_push(ea, ka);
}

uint wide_leaf_first(rtb_wide_refs w, uint x)
{
    return x; /* leaves keep (first, count) in the node */
}

uint wide_mesh_root(rtb_wide_refs w, uint mesh)
{
    return WideUints(w.mesh_root).i[mesh];
}
