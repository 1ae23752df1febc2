/* rtb_wide_trace.glsl: what the benchmark's two wide tracers share, rtb_trace_wide.comp
 * (4-wide nodes, rtb_wide_types.h) and rtb_trace_cwide.comp (compressed 8-wide nodes,
 * rtb_cwide_types.h): the buffers, the two-level traversal loop and main(). Same semantics as
 * rtb_trace.comp (closest hit, no culling, every triangle opaque) and the same arithmetic
 * (trace.glsl's trace_setup_box, trace_setup_shear and trace_triangle; boxes tested as
 * trace_box tests them); one stack for both levels, children visited nearest first, popped
 * entries culled against the closest hit. Writes the hit distance per ray, -1 for a miss.
 * push: globals (only .scene is read), buf0 = rays (rtb_rays.comp), buf1 = float t[],
 * buf2 = WIDE_REFS, params.x = ray count, params.z = threads per row.
 *
 * Include contract. The includer, before `#include "../rtb_wide_trace.glsl"`, enables the
 * extensions trace.glsl needs, includes gpu_types.h and its node types, and defines
 *   WIDE_REFS   its refs struct (buf2), whose info.x is the TLAS's wide root;
 *   WIDE_STACK  its stack entries (rtb_wide_stack_need(width, depth) must not exceed it);
 * and after it defines the prototypes below:
 *   wide_visit       tests the boxes of node's children against the ray and pushes the hit
 *                    ones with wide_push, farthest first, as (child node, 0) or (leaf, count);
 *   wide_leaf_first  the first primitive of a leaf entry (x, count) it pushed;
 *   wide_mesh_root   the wide root of a mesh's BLAS.
 * An includer that defines WIDE_OWN_TRACE brings its own wide_trace (same contract) instead of
 * the loop below and defines none of the three.
 */
#ifndef RTB_WIDE_TRACE_GLSL
#define RTB_WIDE_TRACE_GLSL

layout(local_size_x = PC_WG_1D) in;
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer RtbGlobals { pc_globals g; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer RtbRays { vec4 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) writeonly buffer RtbHits { float t[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer WideRefs { WIDE_REFS r; };
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer WideUints { uint i[]; };
layout(push_constant) uniform Push { pc_push pc; };

bool trace_alpha_pass(pc_scene_refs scene, uint tri, float u, float v) { return true; }

#include "trace.glsl"

#define WIDE_ENTRY_INSTANCE 0xfffffffeu /* stack entry count of a waiting instance */
#define WIDE_INF uintBitsToFloat(0x7f800000u)

#ifdef WIDE_OWN_TRACE
bool wide_trace(pc_scene_refs scene, WIDE_REFS w, vec3 org, vec3 dir, float tmin, float tmax,
                out float t_hit);
#else

void wide_visit(WIDE_REFS w, uint node, vec3 o, vec3 inv, bvec3 neg, float tmin, float t_cull);
uint wide_leaf_first(WIDE_REFS w, uint x);
uint wide_mesh_root(WIDE_REFS w, uint mesh);

/* (first, count) as wide_visit pushes them, count WIDE_ENTRY_INSTANCE for a waiting instance,
 * and the entry distance of its box. */
uvec2 wide_stack[WIDE_STACK];
float wide_stack_t[WIDE_STACK];
int wide_sp;

/* Pushes an entry; pushes beyond WIDE_STACK are dropped rather than written out of bounds. */
void wide_push(uvec2 e, float t)
{
    if (wide_sp < WIDE_STACK) {
        wide_stack[wide_sp] = e;
        wide_stack_t[wide_sp] = t;
        wide_sp++;
    }
}

/* Orders two (distance, entry) pairs by distance: one comparator of a sorting network. */
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
bool wide_trace(pc_scene_refs scene, WIDE_REFS w, vec3 org, vec3 dir, float tmin, float tmax,
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
    wide_sp = 0;
    wide_push(uvec2(w.info.x, 0u), tmin);
    int blas_base = 0;

    for (;;) {
        if (in_blas && wide_sp == blas_base) { /* the instance is done: back to the world ray */
            in_blas = false;
            o = org;
            inv = winv;
            neg = wneg;
            continue;
        }
        if (wide_sp == 0) break;
        wide_sp--;
        uvec2 e = wide_stack[wide_sp];
        if (wide_stack_t[wide_sp] > t_cull) continue;

        if (e.y == 0u) { /* an interior node */
            wide_visit(w, e.x, o, inv, neg, tmin, t_cull);
            continue;
        }
        if (e.y != WIDE_ENTRY_INSTANCE) {
            uint first = wide_leaf_first(w, e.x);
            if (in_blas) { /* triangles, as trace_ray tests them */
                TraceTris tris = TraceTris(scene.tris);
                for (uint i = first; i < first + e.y; i++) {
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
                for (uint k = first + e.y; k > first; k--)
                    wide_push(uvec2(k - 1u, WIDE_ENTRY_INSTANCE), tmin);
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
        blas_base = wide_sp;
        wide_push(uvec2(wide_mesh_root(w, in_.info.y), 0u), tmin);
    }
    t_hit = t_best;
    return found;
}

#endif /* WIDE_OWN_TRACE */

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

#endif
