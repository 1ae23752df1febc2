// ploc_emit.comp: the output of a GPU PLOC build (renderer/accel/gpu_ploc.c), top-down: one
// dispatch a round, the last round first (a cluster's parent was made in a later round), one
// thread a cluster the round made. A cluster with an output slot (the root has 0; a cluster
// inside a collapsed leaf has none) writes its node there: a collapsed one a leaf over its
// triangles (gathered depth-first, left first, into prim_index from its first), any other an
// interior node whose children take the slots first and first + 1. The children's subtrees are
// laid out depth-first as ploc_ref.c's emit lays them: the left child's descendants from
// first + 2 on, the right child's after them (its output count of nodes below, made by
// ploc_round), their triangles in the same order. A child that is a triangle is written as a leaf
// at once; another learns its slot, its children's slot and its first triangle. The root's thread
// writes the node count and the depth.
// Push constants (pc_push): buf1 = output nodes, buf2 = scratch (shaders/ploc.glsl),
// globals = prim_index; params.x = n, params.y = the PLOC area's word offset, params.z = the
// round.
#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require

#include "gpu_types.h"
#include "ploc.glsl"

layout(local_size_x = PC_WG_1D) in;

layout(buffer_reference, std430, buffer_reference_align = 16) buffer Nodes
{
    pc_bvh_node n[];
};

layout(push_constant) uniform Push
{
    pc_push pc;
};

// The largest leaf (renderer/accel/bvh.h's RD_BVH_MAX_LEAF): a collapsed cluster's subtree has
// at most 2 * 8 - 1 clusters, its depth-first stack at most 8 + 1 entries.
#define PLOC_GATHER_STACK 16

void main()
{
    uint n = pc.params.x, at = pc.params.y, round = pc.params.z, k = lbvh_thread();
    LbvhUints s = LbvhUints(pc.buf2);
    uint log_at = ploc_log_at(at, round);
    if (k >= s.v[log_at + PC_PLOC_LOG_MERGES]) return;
    PlocClusters cl = ploc_clusters(pc.buf2, n, at);
    LbvhUints prim = LbvhUints(pc.globals);
    Nodes nodes = Nodes(pc.buf1);
    uint id = n + s.v[log_at + PC_PLOC_LOG_BASE] + k;
    PlocCluster c = cl.c[id];
    uint slot = c.out_.y;
    if (slot == 0xffffffffu) return;
    pc_bvh_node node;
    node.bmin = vec4(c.lo.xyz, 0.0);
    node.bmax = vec4(c.hi.xyz, 0.0);
    uint tris = c.info.x & PLOC_COUNT_MASK, first_tri = c.out_.w;
    if ((c.info.x & PLOC_COLLAPSED) != 0u) {
        node.bmin.w = uintBitsToFloat(first_tri);
        node.bmax.w = uintBitsToFloat(tris);
        uint stack[PLOC_GATHER_STACK], sp = 0u, m = first_tri;
        stack[sp++] = id;
        while (sp > 0u) {
            uint x = stack[--sp];
            if (x < n) {
                prim.v[m++] = x;
                continue;
            }
            uvec4 info = cl.c[x].info;
            stack[sp++] = info.w;
            stack[sp++] = info.z;
        }
    } else {
        uint base = c.out_.z;
        node.bmin.w = uintBitsToFloat(base);
        node.bmax.w = uintBitsToFloat(0u);
        uint left = c.info.z, right = c.info.w;
        uint left_tris = cl.c[left].info.x & PLOC_COUNT_MASK;
        uvec3 place[2] = {uvec3(base, base + 2u, first_tri),
                          uvec3(base + 1u, base + 2u + cl.c[left].out_.x, first_tri + left_tris)};
        uint child[2] = {left, right};
        for (uint e = 0u; e < 2u; e++) {
            uint x = child[e];
            if (x < n) { // a triangle: its leaf
                pc_bvh_node leaf;
                leaf.bmin = vec4(cl.c[x].lo.xyz, uintBitsToFloat(place[e].z));
                leaf.bmax = vec4(cl.c[x].hi.xyz, uintBitsToFloat(1u));
                nodes.n[place[e].x] = leaf;
                prim.v[place[e].z] = x;
            } else {
                cl.c[x].out_.yzw = place[e];
            }
        }
    }
    nodes.n[slot] = node;
    if (slot == 0u) {
        s.v[LBVH_COUNT_AT] = 1u + c.out_.x;
        s.v[LBVH_DEPTH_AT] = uint(c.hi.w);
    }
}
