/* trace.glsl: the one ray traversal every pass uses (primary, shadow, probe and path rays).
 *
 * Include contract. The includer, before `#include "trace.glsl"`:
 *   - enables GL_EXT_buffer_reference, GL_EXT_shader_explicit_arithmetic_types_int64 and
 *     GL_GOOGLE_include_directive, defines PC_GLSL and includes "gpu_types.h";
 *   - defines  bool trace_alpha_pass(pc_scene_refs scene, uint tri, float u, float v)
 *     which is called for candidate hits on triangles flagged PC_TRI_ALPHA_MASK (tri is the
 *     index into scene.tris, u/v the barycentrics of v1/v2); returning false ignores the hit
 *     and traversal goes on. A pass without alpha-masked geometry may return true.
 *
 * Scene layout (see gpu_types.h and renderer/accel/bvh.h): a TLAS over instances (leaves index
 * scene.tlas_index, whose entries are instance indices) and one BLAS node array holding every
 * mesh's BVH with absolute indices (instance.info.x is the mesh's root; leaves index
 * scene.tris). Interior children are adjacent: first and first + 1.
 *
 * Traversal is two-level with one stack: TLAS entries below, the current BLAS's above. The ray
 * enters an instance by the rows of world_to_object; the object-space direction is not
 * normalised, so t stays the world t and hits of different instances compare directly.
 * Nearest child first.
 * Stack: TLAS and BLAS depth are each at most RD_BVH_MAX_DEPTH (48) and a TLAS leaf adds at
 * most RD_BVH_MAX_LEAF - 1 pending instances, so 2 * PC_BVH_STACK_SIZE entries never overflow
 * (pushes beyond it are dropped rather than written out of bounds).
 */
#ifndef PC_TRACE_GLSL
#define PC_TRACE_GLSL

#ifndef PC_MASKED_LANES
#define PC_MASKED_LANES 0 /* the variant for masked lanes: shaders/common.glsl says what it is */
#endif

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer TraceNodes { pc_bvh_node n[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer TraceTris { pc_tri t[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer TraceInstances { pc_instance i[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer TraceIndex { uint i[]; };

struct pc_hit {
    float t;
    float u;        /* barycentric of v1 */
    float v;        /* barycentric of v2 */
    uint instance;  /* index into scene.instances */
    uint tri;       /* index into scene.tris (BVH leaf order; v2.w holds the mesh's own index) */
    bool backface;  /* the ray met the back (counter-clockwise front in object space) */
};

#define TRACE_STACK_SIZE (2 * PC_BVH_STACK_SIZE)
#define TRACE_ENTRY_INSTANCE 0xffffffffu /* stack entry count of a waiting instance */
/* Ize, "Robust BVH Ray Traversal" (JCGT 2013): tfar * (1 + 2 gamma(3)) keeps the float slab
 * test conservative. */
#define TRACE_TFAR_SCALE 1.0000004
/* Boxes are culled against the closest hit plus a relative slack: a triangle's computed t can
 * lie ulps before the entry distance of its own box (coplanar overlapping triangles). */
#define TRACE_CULL_SLACK (1.0 / 65536.0)

/* Reciprocal direction, and the sign per axis that picks the near and far slab planes. A zero
 * component gets +-FLT_MAX (the zero's sign), not +-inf: a ray lying exactly in a slab plane
 * would make 0 * inf = NaN in trace_box, and GLSL's max/min (SPIR-V FMax/FMin) leave NaN
 * operands undefined -- lavapipe, compiled for one invocation, let the NaN reject the box and
 * missed a ray the primary pass hit (a pick aimed at an instance's origin). With FLT_MAX the
 * plane term is 0, i.e. the ray counts as inside the slab on the side its zero's sign leans
 * to, as a ray tilted by an infinitesimal would; any other term is still beyond every tmax
 * or +-inf. (renderer/accel/bvh.c's CPU slab test ignores the NaN instead: both sides.) */
void trace_setup_box(vec3 d, out vec3 inv, out bvec3 neg)
{
    vec3 big = uintBitsToFloat((floatBitsToUint(d) & 0x80000000u) | 0x7f7fffffu);
    inv = mix(1.0 / d, big, equal(d, vec3(0.0)));
    neg = lessThan(inv, vec3(0.0));
}

/* v[k] as explicit selects: dynamic vector indexing may put the vector in scratch memory. */
float trace_comp(vec3 v, uint k)
{
    return k == 0u ? v.x : (k == 1u ? v.y : v.z);
}

/* Per-ray part of the watertight test (Woop, Benthin, Wald 2013, sec. 3): kz is the dominant
 * axis of d, kx and ky swap when d[kz] < 0 to keep the winding, S shears the ray onto +z. */
void trace_setup_shear(vec3 d, out uint kx, out uint ky, out uint kz, out vec3 S)
{
    vec3 a = abs(d);
    kz = a.x >= a.y ? (a.x >= a.z ? 0u : 2u) : (a.y >= a.z ? 1u : 2u);
    kx = kz == 2u ? 0u : kz + 1u;
    ky = kx == 2u ? 0u : kx + 1u;
    float dz = trace_comp(d, kz);
    if (dz < 0.0) {
        uint k = kx;
        kx = ky;
        ky = k;
    }
    S = vec3(trace_comp(d, kx) / dz, trace_comp(d, ky) / dz, 1.0 / dz);
}

/* Slab test with near/far planes chosen by the direction sign (Williams et al. 2005), so the
 * inverted empty boxes [+inf, -inf] of bvh.h are always rejected. A zero direction component
 * can give 0 * inf = NaN only when the origin lies exactly on a box plane; the builder widens
 * every box by an ulp, so nothing inside can be hit then, and dropping or propagating the
 * NaN (GLSL leaves min/max with NaN undefined) is right either way. */
bool trace_box(vec4 bmin, vec4 bmax, vec3 o, vec3 inv, bvec3 neg, float tmin, float tmax,
               out float tnear)
{
    vec3 t0 = (mix(bmin.xyz, bmax.xyz, neg) - o) * inv;
    vec3 t1 = (mix(bmax.xyz, bmin.xyz, neg) - o) * inv;
    tnear = max(max(t0.x, t0.y), max(t0.z, tmin));
    float tfar = min(min(min(t1.x, t1.y), t1.z) * TRACE_TFAR_SCALE, tmax);
    return tnear <= tfar;
}

/* Watertight ray/triangle intersection: Woop, Benthin, Wald, "Watertight Ray/Triangle
 * Intersection", JCGT 2(1), 2013. The same float arithmetic as rd_ray_triangle in
 * renderer/accel/bvh.c (`precise` forbids fused multiply-adds, which would make the edge functions
 * of neighbouring triangles differ); the paper's double-precision recomputation of edge
 * functions that are exactly 0 is omitted on the GPU. Accepts tmin < t < tmax; back is true
 * when det < 0, i.e. dot(d, cross(p1 - p0, p2 - p0)) > 0. */
bool trace_triangle(vec3 o, uint kx, uint ky, uint kz, vec3 S, vec3 p0, vec3 p1, vec3 p2,
                    float tmin, float tmax, out float t, out float u, out float v, out bool back)
{
    precise vec3 A = p0 - o;
    precise vec3 B = p1 - o;
    precise vec3 C = p2 - o;
    float Az = trace_comp(A, kz), Bz = trace_comp(B, kz), Cz = trace_comp(C, kz);
    precise float Ax = trace_comp(A, kx) - S.x * Az;
    precise float Ay = trace_comp(A, ky) - S.y * Az;
    precise float Bx = trace_comp(B, kx) - S.x * Bz;
    precise float By = trace_comp(B, ky) - S.y * Bz;
    precise float Cx = trace_comp(C, kx) - S.x * Cz;
    precise float Cy = trace_comp(C, ky) - S.y * Cz;
    precise float U = Cx * By - Cy * Bx;
    precise float V = Ax * Cy - Ay * Cx;
    precise float W = Bx * Ay - By * Ax;
    t = 0.0;
    u = 0.0;
    v = 0.0;
    back = false;
    if ((U < 0.0 || V < 0.0 || W < 0.0) && (U > 0.0 || V > 0.0 || W > 0.0)) return false;
    precise float det = U + V + W;
    if (det == 0.0 || !(abs(det) <= 3.40282347e38)) return false; /* also NaN/Inf vertices */
    precise float T = U * (S.z * Az) + V * (S.z * Bz) + W * (S.z * Cz);
    float rcp = 1.0 / det;
    t = T * rcp;
    if (!(t > tmin && t < tmax)) return false;
    u = V * rcp;
    v = W * rcp;
    back = det < 0.0;
    return true;
}

/* Closest hit (or, with PC_TRACE_ANY_HIT, the first accepted hit) with tmin < t < tmax.
 * hit is filled only when true is returned (hit.t = tmax, indices PC_INVALID otherwise).
 * Structure: Aila & Laine's "while-while" (HPG 2009): an inner loop walks interior nodes and
 * pops within the current level; leaves, instance entry and the return to the world ray run
 * once per outer iteration, so the rare, heavy code stays out of the hot inner loop (which
 * matters on SIMD-predicated CPUs such as lavapipe as much as on GPUs). */
bool trace_ray(pc_scene_refs scene, vec3 org, vec3 dir, float tmin, float tmax, uint flags,
               out pc_hit hit)
{
    hit.t = tmax;
    hit.u = 0.0;
    hit.v = 0.0;
    hit.instance = PC_INVALID;
    hit.tri = PC_INVALID;
    hit.backface = false;
    /* A non-finite ray could pass every NaN-dropping box test and walk an empty BVH's
     * self-referencing root forever. */
    if (scene.counts.x == 0u || any(isnan(org)) || any(isinf(org)) || any(isnan(dir)) ||
        any(isinf(dir)))
        return false;

    vec3 winv;
    bvec3 wneg;
    trace_setup_box(dir, winv, wneg);
    /* The current ray: world space in the TLAS, object space in a BLAS. */
    vec3 o = org, inv = winv;
    bvec3 neg = wneg;
    uint kx = 0u, ky = 1u, kz = 2u;
    vec3 S = vec3(0.0);
    uint64_t nodes = scene.tlas_nodes;
    bool in_blas = false;
    uint inst = 0u;
    float t_best = tmax, t_cull = tmax; /* t_cull: t_best plus slack, for box tests */
    bool found = false;
#if PC_MASKED_LANES
    /* Masked lanes (common.glsl) would run the alpha test's texture fetch in every triangle test,
     * taken or not: 37% of lavapipe's probe trace, in scenes without a single alpha-masked
     * triangle (builtin:furnace, 114 against 72 ms an update). So the traversal defers the
     * nearest alpha-masked hit and tests it once, after the pass; a hit that fails starts another
     * pass for the next such hit behind it (lo: the failed hit's t, instance and triangle, in
     * that order), until one passes or none is nearer than the nearest opaque hit. */
    float lo_t = -1.0;
    uint lo_inst = 0u, lo_tri = 0u;
    bool lo_set = false;
    for (;;) { /* passes */
    bool cand = false, c_back = false;
    float c_t = 0.0, c_u = 0.0, c_v = 0.0;
    uint c_tri = 0u, c_inst = 0u;
#endif

    /* Entries: (first, count) of a node whose box the ray enters, so a pop needs no load;
     * count == TRACE_ENTRY_INSTANCE marks a TLAS leaf slot whose instance waits. Popped
     * nodes are not re-culled against the closest hit: keeping entry distances on the stack
     * for that measured 12% slower on an H200 (the children's box tests cull them anyway). */
    uvec2 stack[TRACE_STACK_SIZE];
    int sp = 0, blas_base = 0;

    pc_bvh_node root = TraceNodes(nodes).n[0];
    float tn;
    if (!trace_box(root.bmin, root.bmax, o, inv, neg, tmin, t_cull, tn)) return found;
    uint first = floatBitsToUint(root.bmin.w), count = floatBitsToUint(root.bmax.w);
    bool have = true; /* (first, count) describe a node whose box the ray enters */

    for (;;) {
        /* Interior nodes, nearest child first; pops stay within the current level. */
        for (;;) {
            if (have) {
                if (count != 0u) break; /* a leaf */
                TraceNodes nb = TraceNodes(nodes);
                pc_bvh_node c0 = nb.n[first];
                pc_bvh_node c1 = nb.n[first + 1u];
                float t0, t1;
                bool h0 = trace_box(c0.bmin, c0.bmax, o, inv, neg, tmin, t_cull, t0);
                bool h1 = trace_box(c1.bmin, c1.bmax, o, inv, neg, tmin, t_cull, t1);
                if (h0 && h1 && sp < TRACE_STACK_SIZE) {
                    bool far1 = t0 <= t1;
                    stack[sp] = far1 ? uvec2(floatBitsToUint(c1.bmin.w), floatBitsToUint(c1.bmax.w))
                                     : uvec2(floatBitsToUint(c0.bmin.w), floatBitsToUint(c0.bmax.w));
                    sp++;
                }
                bool take1 = h1 && (!h0 || t1 < t0);
                first = floatBitsToUint(take1 ? c1.bmin.w : c0.bmin.w);
                count = floatBitsToUint(take1 ? c1.bmax.w : c0.bmax.w);
                have = h0 || h1;
                if (have) continue;
            }
            if (sp == (in_blas ? blas_base : 0)) break; /* this level is done */
            if (stack[sp - 1].y == TRACE_ENTRY_INSTANCE) break;
            sp--;
            first = stack[sp].x;
            count = stack[sp].y;
            have = true;
        }

        uint enter = PC_INVALID; /* TLAS leaf slot whose instance is entered now */
        if (have) {
            have = false;
            if (in_blas) {
                TraceTris tris = TraceTris(scene.tris);
                for (uint i = first; i < first + count; i++) {
                    pc_tri tr = tris.t[i];
                    float t, u, v;
                    bool back;
                    if (!trace_triangle(o, kx, ky, kz, S, tr.v0.xyz, tr.v1.xyz, tr.v2.xyz, tmin,
                                        t_best, t, u, v, back))
                        continue;
                    uint tf = floatBitsToUint(tr.v1.w);
                    if ((flags & PC_TRACE_CULL_BACKFACES) != 0u && back &&
                        (tf & PC_TRI_DOUBLE_SIDED) == 0u)
                        continue;
#if PC_MASKED_LANES
                    if ((tf & PC_TRI_ALPHA_MASK) != 0u) { /* deferred: the nearest after lo */
                        bool after = !lo_set || t > lo_t ||
                                     (t == lo_t && (inst > lo_inst || (inst == lo_inst && i > lo_tri)));
                        if (after && (!cand || t < c_t)) {
                            cand = true;
                            c_t = t;
                            c_u = u;
                            c_v = v;
                            c_tri = i;
                            c_inst = inst;
                            c_back = back;
                        }
                        continue;
                    }
#else
                    if ((tf & PC_TRI_ALPHA_MASK) != 0u && !trace_alpha_pass(scene, i, u, v))
                        continue;
#endif
                    t_best = t;
                    t_cull = t + abs(t) * TRACE_CULL_SLACK;
                    found = true;
                    hit.t = t;
                    hit.u = u;
                    hit.v = v;
                    hit.instance = inst;
                    hit.tri = i;
                    hit.backface = back;
                    if ((flags & PC_TRACE_ANY_HIT) != 0u) return true;
                }
                continue;
            }
            /* TLAS leaf: the first instance is entered now, the others wait on the stack. */
            for (uint k = first + 1u; k < first + count; k++) {
                if (sp < TRACE_STACK_SIZE) {
                    stack[sp] = uvec2(k, TRACE_ENTRY_INSTANCE);
                    sp++;
                }
            }
            enter = first;
        } else if (in_blas) { /* the instance is done: back to the world ray */
            in_blas = false;
            nodes = scene.tlas_nodes;
            o = org;
            inv = winv;
            neg = wneg;
            continue;
        } else if (sp == 0) {
            break;
        } else {
            enter = stack[--sp].x; /* a waiting instance */
        }

        /* Enter an instance: the ray goes to object space through world_to_object. */
        inst = TraceIndex(scene.tlas_index).i[enter];
        pc_instance in_ = TraceInstances(scene.instances).i[inst];
        vec4 wo = vec4(org, 1.0);
        vec3 oo = vec3(dot(in_.world_to_object[0], wo), dot(in_.world_to_object[1], wo),
                       dot(in_.world_to_object[2], wo));
        vec3 d = vec3(dot(in_.world_to_object[0].xyz, dir), dot(in_.world_to_object[1].xyz, dir),
                      dot(in_.world_to_object[2].xyz, dir));
        vec3 oinv;
        bvec3 oneg;
        trace_setup_box(d, oinv, oneg);
        pc_bvh_node r = TraceNodes(scene.blas_nodes).n[in_.info.x];
        bool finite = !any(isnan(oo)) && !any(isinf(oo)) && !any(isnan(d)) && !any(isinf(d));
        if (finite && trace_box(r.bmin, r.bmax, oo, oinv, oneg, tmin, t_cull, tn)) {
            o = oo;
            inv = oinv;
            neg = oneg;
            trace_setup_shear(d, kx, ky, kz, S);
            nodes = scene.blas_nodes;
            in_blas = true;
            blas_base = sp;
            first = floatBitsToUint(r.bmin.w);
            count = floatBitsToUint(r.bmax.w);
            have = true;
        }
    }
#if PC_MASKED_LANES
    if (!cand || !(c_t < t_best)) break;
    if (trace_alpha_pass(scene, c_tri, c_u, c_v)) {
        hit.t = c_t;
        hit.u = c_u;
        hit.v = c_v;
        hit.instance = c_inst;
        hit.tri = c_tri;
        hit.backface = c_back;
        return true;
    }
    lo_set = true;
    lo_t = c_t;
    lo_inst = c_inst;
    lo_tri = c_tri;
    } /* passes */
#endif
    return found;
}

/* Ray origins off surfaces. A hit's position is rebuilt from its barycentrics in the mesh's
 * (local) frame and carried to the world by its instance's transform; a ray leaving it is carried
 * back into each instance it enters, and the triangle test's t errs with the size of its vertices
 * minus the ray origin. Each step errs by a few ulps of the largest magnitude it handles, so the
 * origin moves along the geometric normal by PC_RAY_OFFSET_REL times the sum of those magnitudes
 * (ray_offset_scale in common.glsl, taken by surface_at): Wächter and Binder's 256 ulps (Ray
 * Tracing Gems, ch. 6), but of the magnitudes the arithmetic met rather than of the world
 * position alone, which near the floating origin is far smaller than vertices baked kilometres
 * out. rd_ray_offset_distance and rd_offset_ray_origin in bvh.c are the CPU twins. */
float ray_offset_distance(float scale)
{
    float d = PC_RAY_OFFSET_REL * scale;
    return d < 3.0e38 ? max(d, PC_RAY_OFFSET_MIN) : 0.0; /* NaN, Inf -> no offset */
}

/* p moved along n (unit, toward the side the new ray leaves from) by offset (world units,
 * ray_offset_distance). */
vec3 offset_ray_origin(vec3 p, vec3 n, float offset)
{
    precise vec3 o = p + n * offset;
    return o;
}

#endif
