#version 460
/* rtb_trace_wide.comp: the benchmark's "wide" tracer: the renderer's BVHs collapsed to 4-wide
 * nodes (tests/bench/bvh_wide.c, rtb_wide_types.h) over the same triangles, instances and TLAS
 * index, for tests/bench/rt_yardstick.c. Same semantics as rtb_trace.comp (closest hit, no
 * culling, every triangle opaque) and the same box and triangle tests (trace_box's arithmetic
 * on four boxes at once, trace_triangle itself); two levels, one stack, children visited
 * nearest first (a four-element sorting network), popped entries culled against the closest
 * hit. Writes the hit distance per ray, -1 for a miss.
 * push: globals (only .scene is read), buf0 = rays (rtb_rays.comp), buf1 = float t[],
 * buf2 = rtb_wide_refs, params.x = ray count, params.z = threads per row. */
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require

#include "gpu_types.h"
#include "../rtb_wide_types.h"

layout(local_size_x = PC_WG_1D) in;
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer RtbGlobals { pc_globals g; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer RtbRays { vec4 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) writeonly buffer RtbHits { float t[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer WideRefs { rtb_wide_refs r; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer WideNodes { rtb_wide_node n[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer WideRoots { uint i[]; };
layout(push_constant) uniform Push { pc_push pc; };

bool trace_alpha_pass(pc_scene_refs scene, uint tri, float u, float v) { return true; }

#include "trace.glsl"

#define WIDE_ENTRY_INSTANCE 0xfffffffeu /* stack entry count of a waiting instance */

/* Orders two (distance, entry) pairs by distance. */
void wide_order(inout float ta, inout uvec2 ea, inout float tb, inout uvec2 eb)
{
    if (tb < ta) {
        float t = ta;
        ta = tb;
        tb = t;
        uvec2 e = ea;
        ea = eb;
        eb = e;
    }
}

/* Closest hit distance with tmin < t < tmax over the wide BVHs; false for a miss. */
bool wide_trace(pc_scene_refs scene, rtb_wide_refs w, vec3 org, vec3 dir, float tmin, float tmax,
                out float t_hit)
{
    t_hit = tmax;
    if (scene.counts.x == 0u || any(isnan(org)) || any(isinf(org)) || any(isnan(dir)) ||
        any(isinf(dir)))
        return false;
    vec3 winv;
    bvec3 wneg;
    trace_setup_box(dir, winv, wneg);
    vec3 o = org, inv = winv;
    bvec3 neg = wneg;
    uint kx = 0u, ky = 1u, kz = 2u;
    vec3 S = vec3(0.0);
    bool in_blas = false, found = false;
    float t_best = tmax, t_cull = tmax;
    WideNodes nodes = WideNodes(w.nodes);

    /* (first, count) as in rtb_wide_node, count WIDE_ENTRY_INSTANCE for a waiting instance,
     * and the entry distance of its box. */
    uvec2 stack[RTB_WIDE_STACK];
    float stack_t[RTB_WIDE_STACK];
    stack[0] = uvec2(w.info.x, 0u);
    stack_t[0] = tmin;
    int sp = 1, blas_base = 0;
    const float INF = uintBitsToFloat(0x7f800000u);

    for (;;) {
        if (in_blas && sp == blas_base) { /* the instance is done: back to the world ray */
            in_blas = false;
            o = org;
            inv = winv;
            neg = wneg;
            continue;
        }
        if (sp == 0) break;
        sp--;
        uvec2 e = stack[sp];
        if (stack_t[sp] > t_cull) continue;

        if (e.y == 0u) { /* an interior node: test four boxes, push the hits far to near */
            rtb_wide_node n = nodes.n[e.x];
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
            vec4 k = mix(vec4(INF), tnear, hit);
            float ka = k.x, kb = k.y, kc = k.z, kd = k.w;
            uvec2 ea = uvec2(n.child.x, n.count.x), eb = uvec2(n.child.y, n.count.y);
            uvec2 ec = uvec2(n.child.z, n.count.z), ed = uvec2(n.child.w, n.count.w);
            wide_order(ka, ea, kb, eb);
            wide_order(kc, ec, kd, ed);
            wide_order(ka, ea, kc, ec);
            wide_order(kb, eb, kd, ed);
            wide_order(kb, eb, kc, ec);
            int hits = int(hit.x) + int(hit.y) + int(hit.z) + int(hit.w);
            if (hits > 3 && sp < RTB_WIDE_STACK) { stack[sp] = ed; stack_t[sp] = kd; sp++; }
            if (hits > 2 && sp < RTB_WIDE_STACK) { stack[sp] = ec; stack_t[sp] = kc; sp++; }
            if (hits > 1 && sp < RTB_WIDE_STACK) { stack[sp] = eb; stack_t[sp] = kb; sp++; }
            if (hits > 0 && sp < RTB_WIDE_STACK) { stack[sp] = ea; stack_t[sp] = ka; sp++; }
            continue;
        }
        if (e.y != WIDE_ENTRY_INSTANCE) {
            if (in_blas) { /* triangles, as trace_ray tests them */
                TraceTris tris = TraceTris(scene.tris);
                for (uint i = e.x; i < e.x + e.y; i++) {
                    pc_tri tr = tris.t[i];
                    float t, u, v;
                    bool back;
                    if (!trace_triangle(o, kx, ky, kz, S, tr.v0.xyz, tr.v1.xyz, tr.v2.xyz, tmin,
                                        t_best, t, u, v, back))
                        continue;
                    t_best = t;
                    t_cull = t + abs(t) * TRACE_CULL_SLACK;
                    found = true;
                }
            } else { /* a TLAS leaf: its instances wait on the stack, the first on top */
                for (uint k = e.x + e.y; k > e.x; k--) {
                    if (sp < RTB_WIDE_STACK) {
                        stack[sp] = uvec2(k - 1u, WIDE_ENTRY_INSTANCE);
                        stack_t[sp] = tmin;
                        sp++;
                    }
                }
            }
            continue;
        }

        /* Enter an instance: the ray goes to object space through world_to_object. */
        uint inst = TraceIndex(scene.tlas_index).i[e.x];
        pc_instance in_ = TraceInstances(scene.instances).i[inst];
        vec4 wo = vec4(org, 1.0);
        vec3 oo = vec3(dot(in_.world_to_object[0], wo), dot(in_.world_to_object[1], wo),
                       dot(in_.world_to_object[2], wo));
        vec3 d = vec3(dot(in_.world_to_object[0].xyz, dir), dot(in_.world_to_object[1].xyz, dir),
                      dot(in_.world_to_object[2].xyz, dir));
        if (any(isnan(oo)) || any(isinf(oo)) || any(isnan(d)) || any(isinf(d))) continue;
        o = oo;
        trace_setup_box(d, inv, neg);
        trace_setup_shear(d, kx, ky, kz, S);
        in_blas = true;
        blas_base = sp;
        if (sp < RTB_WIDE_STACK) {
            stack[sp] = uvec2(WideRoots(w.mesh_root).i[in_.info.y], 0u);
            stack_t[sp] = tmin;
            sp++;
        }
    }
    t_hit = t_best;
    return found;
}

void main()
{
    uint i = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * pc.params.z;
    if (i >= pc.params.x) return;
    RtbRays rays = RtbRays(pc.buf0);
    vec4 a = rays.v[2u * i], b = rays.v[2u * i + 1u];
    float t;
    bool hit = wide_trace(RtbGlobals(pc.globals).g.scene, WideRefs(pc.buf2).r, a.xyz, b.xyz, a.w,
                          b.w, t);
    RtbHits(pc.buf1).t[i] = hit ? t : -1.0;
}
