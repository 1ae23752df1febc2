// deform_tris.comp: a deformed mesh's triangle records written in place in the scene's buffers
// (renderer/accel/gpu_scene_deform.c), one invocation per triangle in the BLAS's leaf order:
// pc_tri positions and pc_tri_attr normals and tangents from deform.comp's per-vertex outputs,
// packed as rd_gpu_scene_fill_mesh (renderer/accel/gpu_scene_prep.c) packs the CPU's. A
// deforming mesh has no local origin, and the records keep their w words (material, flags, the
// original triangle) and UVs: the BLAS's topology, and so its leaf order, is the one they were
// written for (pc_tri.v2.w names the original triangle, whose vertices are read).
// Push constants (pc_push): buf0 = the mesh's first pc_tri, buf1 = its first pc_tri_attr,
// buf2 = the deformed vertices (3 floats per vertex: positions at float 0, vertex v = corner v
// of the expanded triangles); params.x = triangles, params.y = the first normal's float,
// params.z = the first tangent's float (4 per vertex; 0: the mesh has no tangents).
#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require

#include "gpu_types.h"

layout(local_size_x = PC_WG_1D) in;

layout(buffer_reference, std430, buffer_reference_align = 16) buffer Tris
{
    pc_tri t[];
};
layout(buffer_reference, std430, buffer_reference_align = 16) buffer Attrs
{
    pc_tri_attr a[];
};
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer Floats
{
    float v[];
};

layout(push_constant) uniform Push
{
    pc_push pc;
};

vec3 load3(Floats f, uint at)
{
    return vec3(f.v[at], f.v[at + 1], f.v[at + 2]);
}

float clamp01(float x)
{
    return x > 0.0 ? (x < 1.0 ? x : 1.0) : 0.0; // NaN -> 0
}

// pack_octahedral of gpu_scene_prep.c (Cigolle et al., JCGT 2014), packSnorm2x16 bits.
uint pack_octahedral(vec3 v)
{
    float l1 = abs(v.x) + abs(v.y) + abs(v.z);
    float x = l1 > 0.0 ? v.x / l1 : 0.0, y = l1 > 0.0 ? v.y / l1 : 0.0;
    if (v.z < 0.0) {
        float ox = (1.0 - abs(y)) * (x >= 0.0 ? 1.0 : -1.0);
        float oy = (1.0 - abs(x)) * (y >= 0.0 ? 1.0 : -1.0);
        x = ox;
        y = oy;
    }
    int ix = int(roundEven(clamp01(x * 0.5 + 0.5) * 65534.0)) - 32767;
    int iy = int(roundEven(clamp01(y * 0.5 + 0.5) * 65534.0)) - 32767;
    return (uint(ix) & 0xffffu) | (uint(iy) & 0xffffu) << 16;
}

// pack_tangents of gpu_scene_prep.c: zero unless all three tangents are finite and non-zero.
uvec4 pack_tangents(Floats f, uint at)
{
    uint packed[3], flags = PC_TANGENT_PRESENT;
    for (uint k = 0; k < 3; k++) {
        vec4 v = vec4(load3(f, at + 4 * k), f.v[at + 4 * k + 3]);
        float len = sqrt(dot(v.xyz, v.xyz));
        if (!(len > 1e-12) || isinf(len) || isnan(len)) return uvec4(0);
        packed[k] = pack_octahedral(v.xyz / len);
        if (v.w < 0.0) flags |= PC_TANGENT_FLIP << k;
    }
    return uvec4(packed[0], packed[1], packed[2], flags);
}

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.params.x) return;
    Tris tris = Tris(pc.buf0);
    Attrs attrs = Attrs(pc.buf1);
    Floats f = Floats(pc.buf2);
    uint src = floatBitsToUint(tris.t[i].v2.w);
    if (src >= pc.params.x) return; // not a record of this mesh: a broken invariant
    uint p = 9 * src, n = pc.params.y + 9 * src;
    tris.t[i].v0.xyz = load3(f, p);
    tris.t[i].v1.xyz = load3(f, p + 3);
    tris.t[i].v2.xyz = load3(f, p + 6);
    attrs.a[i].n0 = vec4(load3(f, n), 0.0);
    attrs.a[i].n1 = vec4(load3(f, n + 3), 0.0);
    attrs.a[i].n2 = vec4(load3(f, n + 6), 0.0);
    if (pc.params.z != 0) attrs.a[i].tangents = pack_tangents(f, pc.params.z + 12 * src);
}
