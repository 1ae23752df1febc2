// refit.comp: one level of a BLAS refit (renderer/accel/gpu_refit.c), deepest level first: each
// node of the level takes the union of its triangles' boxes (a leaf) or of its children's (an
// interior node, whose children sit on deeper levels, already refitted), keeping the topology
// and the w words of pc_bvh_node. One dispatch per level, no atomics.
// Push constants (pc_push): buf0 = the node array the indices count from (pc_bvh_node: a BLAS of
// its own, or a scene's whole blas_nodes, whose child and leaf indices are absolute),
// buf1 = topology (uints: node indices by level, then prim_index: leaf order -> original
// triangle), buf2 = deformed positions (9 floats per triangle, original order);
// params.x = nodes in this level, params.y = its first entry in buf1, params.z = prim_index's
// first entry in buf1, params.w = the BLAS's first triangle (leaf indices minus it index
// prim_index).
#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require

#include "gpu_types.h"

layout(local_size_x = PC_WG_1D) in;

layout(buffer_reference, std430, buffer_reference_align = 16) buffer Nodes
{
    pc_bvh_node n[];
};
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer Uints
{
    uint v[];
};
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer Floats
{
    float v[];
};

layout(push_constant) uniform Push
{
    pc_push pc;
};

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.params.x) return;
    Nodes nodes = Nodes(pc.buf0);
    Uints topo = Uints(pc.buf1);
    uint ni = topo.v[pc.params.y + i];
    pc_bvh_node node = nodes.n[ni];
    uint first = floatBitsToUint(node.bmin.w), count = floatBitsToUint(node.bmax.w);
    vec3 lo = vec3(uintBitsToFloat(0x7f800000u)), hi = -lo;
    if (count == 0) {
        pc_bvh_node a = nodes.n[first], b = nodes.n[first + 1];
        lo = min(a.bmin.xyz, b.bmin.xyz);
        hi = max(a.bmax.xyz, b.bmax.xyz);
    } else {
        Floats p = Floats(pc.buf2);
        for (uint k = 0; k < count; k++) {
            uint t = topo.v[pc.params.z + first - pc.params.w + k];
            for (uint c = 0; c < 3; c++) {
                vec3 v = vec3(p.v[9 * t + 3 * c], p.v[9 * t + 3 * c + 1], p.v[9 * t + 3 * c + 2]);
                lo = min(lo, v);
                hi = max(hi, v);
            }
        }
    }
    nodes.n[ni].bmin.xyz = lo;
    nodes.n[ni].bmax.xyz = hi;
}
