#version 460
/* rtb_trace_cwide.comp: the benchmark's compressed 8-wide tracers: the renderer's BVHs collapsed
 * to compressed 8-wide nodes (tests/bench/bvh_cwide.c, rtb_cwide_types.h; Ylitie, Karras, Laine,
 * HPG 2017) over the same triangles, instances and TLAS index, for tests/bench/rt_yardstick.c.
 * Compiled twice: "cwide" as is, "cwide2" with RTB_CWIDE_GROUPS defined.
 * Both, per node: the scale of each axis from its exponent byte; near and far planes picked by
 * the direction's sign on the packed bytes before decoding (the paper's sec. 3.2 swaps them per
 * ray octant the same way); each plane decoded as p + q * scale, the very float box the C side
 * made conservative, then tested with trace_box's arithmetic, four children per vector.
 *
 * cwide: the traversal loop, buffers and main() of rtb_wide_trace.glsl (shared with the 4-wide
 * tracer); the hit children ordered by distance with an eight-input sorting network (19
 * min/max comparators, Knuth, TAOCP vol. 3, sec. 5.3.4) over keys that carry the child's slot
 * in their low bits, and pushed one stack entry each.
 *
 * cwide2 (RTB_CWIDE_GROUPS): the paper's traversal (sec. 3, algorithm 1): stack entries are node
 * groups, a child base index and an 8-bit mask of hit interior children still to visit; the
 * next child is the highest set bit of that mask, whose slot s sits at bit s ^ (7 - octant) so
 * that slots come in the octant order the collapse laid out (bvh_cwide.h), with no sort; its
 * node index is the base plus the interior children in lower slots (a population count of the
 * node's interior mask, kept in the entry). A node's hit leaves (the paper's triangle group)
 * are intersected right after its box tests, in the same order; in the TLAS their instances
 * wait on the stack, as in rtb_wide_trace.glsl. Popped groups are not culled by distance (the
 * children's box tests cull them), as in the paper.
 * push: as rtb_wide_trace.glsl says, buf2 = rtb_cwide_refs. */
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require

#include "gpu_types.h"
#include "../rtb_cwide_types.h"

#define WIDE_REFS rtb_cwide_refs
#define WIDE_STACK RTB_CWIDE_STACK
#ifdef RTB_CWIDE_GROUPS
#define WIDE_OWN_TRACE
#endif
#include "../rtb_wide_trace.glsl"

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer CwideNodes { rtb_cwide_node n[]; };

/* The four bytes of w as floats, byte 0 first. */
vec4 cwide_bytes(uint w)
{
    return vec4((uvec4(w) >> uvec4(0u, 8u, 16u, 24u)) & 0xffu);
}

/* Entry distances (tnear) and hits of four children whose near and far plane bytes per axis
 * are the words qn and qf, before their meta bytes say which slots are used. */
vec4 cwide_slab4(uvec3 qn, uvec3 qf, vec3 p, vec3 s, vec3 o, vec3 inv, float tmin, float t_cull,
                 out bvec4 hit)
{
    vec4 t0x = (cwide_bytes(qn.x) * s.x + p.x - o.x) * inv.x;
    vec4 t1x = (cwide_bytes(qf.x) * s.x + p.x - o.x) * inv.x;
    vec4 t0y = (cwide_bytes(qn.y) * s.y + p.y - o.y) * inv.y;
    vec4 t1y = (cwide_bytes(qf.y) * s.y + p.y - o.y) * inv.y;
    vec4 t0z = (cwide_bytes(qn.z) * s.z + p.z - o.z) * inv.z;
    vec4 t1z = (cwide_bytes(qf.z) * s.z + p.z - o.z) * inv.z;
    vec4 tnear = max(max(t0x, t0y), max(t0z, vec4(tmin)));
    vec4 tfar = min(min(min(t1x, t1y), t1z) * TRACE_TFAR_SCALE, vec4(t_cull));
    hit = lessThanEqual(tnear, tfar);
    return tnear;
}

/* The box tests of node n's eight children: tnear and hits of children 0-3 (a) and 4-7 (b);
 * unused slots are not masked out here. */
void cwide_test(rtb_cwide_node n, vec3 o, vec3 inv, bvec3 neg, float tmin, float t_cull,
                out vec4 ta, out vec4 tb, out bvec4 ha, out bvec4 hb)
{
    uvec3 eb = (uvec3(floatBitsToUint(n.origin.w)) >> uvec3(0u, 8u, 16u)) & 0xffu;
    vec3 s = uintBitsToFloat(eb << 23u);
    vec3 p = n.origin.xyz;
    /* .xy: near planes of children 0-3 and 4-7 (lo, or hi for a negative direction), .zw: far */
    uvec4 qx = neg.x ? n.q_x.zwxy : n.q_x;
    uvec4 qy = neg.y ? n.q_y.zwxy : n.q_y;
    uvec4 qz = neg.z ? n.q_z.zwxy : n.q_z;
    ta = cwide_slab4(uvec3(qx.x, qy.x, qz.x), uvec3(qx.z, qy.z, qz.z), p, s, o, inv, tmin, t_cull,
                     ha);
    tb = cwide_slab4(uvec3(qx.y, qy.y, qz.y), uvec3(qx.w, qy.w, qz.w), p, s, o, inv, tmin, t_cull,
                     hb);
}

/* The four meta bytes of word m, byte 0 first. */
uvec4 cwide_meta4(uint m)
{
    return (uvec4(m) >> uvec4(0u, 8u, 16u, 24u)) & 0xffu;
}

#ifndef RTB_CWIDE_GROUPS
/* Sort keys of four children with entry distances tnear and hits hit (box only), meta their
 * meta bytes (0: an unused slot, never hit), slot the first one's slot: the bits of a hit's
 * entry distance, sign cleared (-0.0 is the only negative one when tmin >= 0, as
 * rtb_rays.comp writes it), with its slot in the three low mantissa bits (after Ylitie et al.,
 * sec. 3.3); a miss's the largest finite float with its slot. As uints they order as the
 * distances do, and integer min/max cannot flush the denormals that keys near 0 are. */
uvec4 cwide_keys4(vec4 tnear, bvec4 box_hit, uint meta, uint slot, out bvec4 hit)
{
    uvec4 used = uvec4(notEqual(cwide_meta4(meta), uvec4(0u)));
    hit = bvec4(uvec4(box_hit) & used);
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
    vec4 ta, tb;
    bvec4 ba, bb, ha, hb;
    cwide_test(n, o, inv, neg, tmin, t_cull, ta, tb, ba, bb);
    uvec4 ka = cwide_keys4(ta, ba, n.refs.z, 0u, ha);
    uvec4 kb = cwide_keys4(tb, bb, n.refs.w, 4u, hb);
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
#else /* RTB_CWIDE_GROUPS */

/* Stack entries: a node group (child_base, hits << 8 | imask): hits the hit interior children
 * still to visit, slot s at bit s ^ x (x = 7 - the ray's octant), imask the node's interior
 * slots, slot s at bit s, never 0 while hits is not; or (TLAS index slot,
 * WIDE_ENTRY_INSTANCE) for a waiting instance. */
uvec2 cwide_stack[RTB_CWIDE_STACK];
int cwide_sp;

/* Pushes an entry; pushes beyond RTB_CWIDE_STACK are dropped rather than written out of
 * bounds. */
void cwide_push(uvec2 e)
{
    if (cwide_sp < RTB_CWIDE_STACK) {
        cwide_stack[cwide_sp] = e;
        cwide_sp++;
    }
}

/* 7 - the octant of a direction whose signs are neg (bit a set: negative on axis a). */
uint cwide_octant_inv(bvec3 neg)
{
    return (neg.x ? 0u : 1u) | (neg.y ? 0u : 2u) | (neg.z ? 0u : 4u);
}

/* The group of one node, the root of a tree: slot 0 of a parent at index root. */
uvec2 cwide_root_group(uint root, uint x)
{
    return uvec2(root, (1u << (8u + x)) | 1u);
}

/* The OR of v's four components. */
uint cwide_or4(uvec4 v)
{
    return (v.x | v.y) | (v.z | v.w);
}

/* Closest hit distance with tmin < t < tmax over the compressed BVHs; false for a miss.
 * Ylitie, Karras, Laine, HPG 2017, algorithm 1, two-level with one stack as in
 * rtb_wide_trace.glsl. */
bool wide_trace(pc_scene_refs scene, rtb_cwide_refs w, vec3 org, vec3 dir, float tmin,
                float tmax, out float t_hit)
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
    uint wx = cwide_octant_inv(wneg), x = wx;
    uint kx = 0u, ky = 1u, kz = 2u;
    vec3 S = vec3(0.0);
    bool in_blas = false, found = false;
    float t_best = tmax, t_cull = tmax;
    cwide_sp = 0;
    int blas_base = 0;
    uvec2 g = cwide_root_group(w.info.x, x); /* the current group */

    for (;;) {
        /* The group is done: the next one, visited in this same iteration (an iteration that
         * only pops leaves its lanes idle while the warp's others visit nodes). */
        if ((g.y & 0xff00u) == 0u) {
            if (in_blas && cwide_sp == blas_base) { /* and the instance: back to the world ray */
                in_blas = false;
                o = org;
                inv = winv;
                neg = wneg;
                x = wx;
            }
            if (cwide_sp == 0) break;
            cwide_sp--;
            g = cwide_stack[cwide_sp];
            if (g.y == WIDE_ENTRY_INSTANCE) {
                /* Enter an instance: the ray goes to object space through world_to_object. */
                uint inst = TraceIndex(scene.tlas_index).i[g.x];
                g = uvec2(0u);
                pc_instance in_ = TraceInstances(scene.instances).i[inst];
                vec4 wo = vec4(org, 1.0);
                vec3 oo = vec3(dot(in_.world_to_object[0], wo), dot(in_.world_to_object[1], wo),
                               dot(in_.world_to_object[2], wo));
                vec3 d = vec3(dot(in_.world_to_object[0].xyz, dir),
                              dot(in_.world_to_object[1].xyz, dir),
                              dot(in_.world_to_object[2].xyz, dir));
                if (any(isnan(oo)) || any(isinf(oo)) || any(isnan(d)) || any(isinf(d)))
                    continue;
                o = oo;
                trace_setup_box(d, inv, neg);
                trace_setup_shear(d, kx, ky, kz, S);
                x = cwide_octant_inv(neg);
                in_blas = true;
                blas_base = cwide_sp;
                g = cwide_root_group(WideUints(w.mesh_root).i[in_.info.y], x);
            }
        }

        /* The group's next child: the highest hit bit, its index the base plus the interior
         * children in lower slots. The rest of the group waits on the stack. */
        uint bit = uint(findMSB(g.y));
        g.y &= ~(1u << bit);
        uint slot = (bit - 8u) ^ x;
        uint node = g.x + uint(bitCount(g.y & ((1u << slot) - 1u)));
        if ((g.y & 0xff00u) != 0u) cwide_push(g);

        rtb_cwide_node n = CwideNodes(w.nodes).n[node];
        vec4 ta, tb;
        bvec4 ha, hb;
        cwide_test(n, o, inv, neg, tmin, t_cull, ta, tb, ha, hb);
        uvec4 ma = cwide_meta4(n.refs.z), mb = cwide_meta4(n.refs.w);
        uvec4 ia = uvec4(greaterThanEqual(ma, uvec4(RTB_CWIDE_INTERIOR)));
        uvec4 ib = uvec4(greaterThanEqual(mb, uvec4(RTB_CWIDE_INTERIOR)));
        uvec4 la = uvec4(notEqual(ma, uvec4(0u))) & (ia ^ 1u);
        uvec4 lb = uvec4(notEqual(mb, uvec4(0u))) & (ib ^ 1u);
        uvec4 pa = uvec4(0u, 1u, 2u, 3u) ^ x, pb = uvec4(4u, 5u, 6u, 7u) ^ x; /* hit mask bits */
        uint ihits = cwide_or4(((uvec4(ha) & ia) << pa) | ((uvec4(hb) & ib) << pb));
        uint lhits = cwide_or4(((uvec4(ha) & la) << pa) | ((uvec4(hb) & lb) << pb));
        uint imask = cwide_or4((ia << uvec4(0u, 1u, 2u, 3u)) | (ib << uvec4(4u, 5u, 6u, 7u)));
        g = uvec2(n.refs.x, (ihits << 8u) | imask);
        if (lhits == 0u) continue;

        if (!in_blas) { /* TLAS leaves: their instances wait on the stack above this group */
            if (ihits != 0u) cwide_push(g);
            g = uvec2(0u);
            while (lhits != 0u) { /* lowest first, so the highest waits on top */
                uint b = uint(findLSB(lhits));
                lhits &= lhits - 1u;
                uint s = b ^ x;
                uint m = ((s < 4u ? n.refs.z : n.refs.w) >> (8u * (s & 3u))) & 0xffu;
                uint first = WideUints(w.leaf_first).i[n.refs.y + (m & 7u)];
                for (uint k = first + (m >> 3u); k > first; k--)
                    cwide_push(uvec2(k - 1u, WIDE_ENTRY_INSTANCE));
            }
            continue;
        }
        /* BLAS leaves (the paper's triangle group), highest bit first, as trace_ray tests
         * triangles */
        TraceTris tris = TraceTris(scene.tris);
        while (lhits != 0u) {
            uint b = uint(findMSB(lhits));
            lhits &= ~(1u << b);
            uint s = b ^ x;
            uint m = ((s < 4u ? n.refs.z : n.refs.w) >> (8u * (s & 3u))) & 0xffu;
            uint first = WideUints(w.leaf_first).i[n.refs.y + (m & 7u)];
            for (uint i = first; i < first + (m >> 3u); i++) {
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
        }
    }
    t_hit = t_best;
    return found;
}
#endif /* RTB_CWIDE_GROUPS */
