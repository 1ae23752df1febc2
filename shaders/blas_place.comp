// blas_place.comp: a deforming mesh's BLAS rebuilt by the GPU LBVH (renderer/accel/gpu_lbvh.h)
// put in the mesh's place in the scene's buffers (renderer/accel/gpu_scene_deform.c), as
// rd_gpu_scene_fill_mesh (renderer/accel/gpu_scene_prep.c) places a CPU build. Two modes:
// params.w = 0, the nodes: one thread per node of the build (at most params.x, the build's
// count read from its scratch), copied with an interior node's first child plus the mesh's first
// node (params.y) and a leaf's first triangle plus its first record (params.z);
// buf0 = the build's nodes (indices relative to them), buf1 = the scene's nodes from the mesh's
// first, buf2 = the uint node count the build wrote (RD_GPU_LBVH_COUNT_OFFSET in its scratch).
// params.w = 1, the triangle records in the new leaf order: record i is the mesh's source record
// of triangle prim_index[i] (material, flags, original index in the w words, UVs, tangents;
// deform_tris.comp then writes the posed positions, normals and tangents);
// buf0 = prim_index (params.x uints), buf1 = the source records (params.x pc_tri, then params.x
// pc_tri_attr, the mesh's original order), buf2 = the mesh's first pc_tri in the scene,
// globals = its first pc_tri_attr.
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
layout(buffer_reference, std430, buffer_reference_align = 16) buffer Tris
{
    pc_tri t[];
};
layout(buffer_reference, std430, buffer_reference_align = 16) buffer Attrs
{
    pc_tri_attr a[];
};
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer Uints
{
    uint v[];
};

layout(push_constant) uniform Push
{
    pc_push pc;
};

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (pc.params.w == 0) {
        if (i >= min(pc.params.x, Uints(pc.buf2).v[0])) return;
        pc_bvh_node node = Nodes(pc.buf0).n[i];
        uint first = floatBitsToUint(node.bmin.w), count = floatBitsToUint(node.bmax.w);
        node.bmin.w = uintBitsToFloat(first + (count != 0 ? pc.params.z : pc.params.y));
        Nodes(pc.buf1).n[i] = node;
        return;
    }
    uint n = pc.params.x;
    if (i >= n) return;
    uint src = Uints(pc.buf0).v[i];
    if (src >= n) return; // not a triangle of this mesh: a broken invariant
    Tris tris = Tris(pc.buf1);
    Attrs attrs = Attrs(pc.buf1 + uint64_t(n) * 48u); // n pc_tri of 48 bytes (gpu_types.h)
    Tris(pc.buf2).t[i] = tris.t[src];
    Attrs(pc.globals).a[i] = attrs.a[src];
}
