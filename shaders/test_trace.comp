// test_trace.comp: traces a list of rays with trace_ray() for tests/renderer/test_gpu_trace.c.
// Push constants (pc_push): globals = pc_globals (only .scene is read);
// buf0 = rays, two vec4 per ray: (origin, tmin), (direction, tmax);
// buf1 = results, two uvec4 per ray: (t, u, v bits, hit), (instance, tri, backface, 0);
// params.x = ray count, params.y = trace flags (PC_TRACE_*).
#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require

#include "gpu_types.h"

layout(local_size_x = PC_WG_1D) in;

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer TestGlobals
{
    pc_globals g;
};
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer TestRays
{
    vec4 v[];
};
layout(buffer_reference, std430, buffer_reference_align = 16) writeonly buffer TestResults
{
    uvec4 v[];
};

layout(push_constant) uniform Push
{
    pc_push pc;
};

// The test's alpha mask: a cut-out that keeps the part of a triangle with u > 0.3.
bool trace_alpha_pass(pc_scene_refs scene, uint tri, float u, float v)
{
    return u > 0.3;
}

#include "trace.glsl"

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.params.x) return;
    pc_scene_refs scene = TestGlobals(pc.globals).g.scene;
    TestRays rays = TestRays(pc.buf0);
    vec4 a = rays.v[2u * i], b = rays.v[2u * i + 1u];
    pc_hit h;
    bool hit = trace_ray(scene, a.xyz, b.xyz, a.w, b.w, pc.params.y, h);
    TestResults r = TestResults(pc.buf1);
    r.v[2u * i] = uvec4(floatBitsToUint(h.t), floatBitsToUint(h.u), floatBitsToUint(h.v),
                        hit ? 1u : 0u);
    r.v[2u * i + 1u] = uvec4(h.instance, h.tri, h.backface ? 1u : 0u, 0u);
}
