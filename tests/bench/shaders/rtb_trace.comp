#version 460
/* rtb_trace.comp: our traversal (shaders/trace.glsl) over a ray buffer for
 * tests/bench/rt_yardstick.c: closest hit, no culling, every triangle opaque (as the driver's
 * BLASes are built). Writes the hit distance per ray, -1 for a miss.
 * push: globals (only .scene is read), buf0 = rays (rtb_rays.comp), buf1 = float t[],
 * params.x = ray count, params.z = threads per row. */
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require

#include "gpu_types.h"

layout(local_size_x = PC_WG_1D) in;
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer RtbGlobals { pc_globals g; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer RtbRays { vec4 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) writeonly buffer RtbHits { float t[]; };
layout(push_constant) uniform Push { pc_push pc; };

bool trace_alpha_pass(pc_scene_refs scene, uint tri, float u, float v) { return true; }

#include "trace.glsl"

void main()
{
    uint i = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * pc.params.z;
    if (i >= pc.params.x) return;
    RtbRays rays = RtbRays(pc.buf0);
    vec4 a = rays.v[2u * i], b = rays.v[2u * i + 1u];
    pc_hit h;
    bool hit = trace_ray(RtbGlobals(pc.globals).g.scene, a.xyz, b.xyz, a.w, b.w, 0u, h);
    RtbHits(pc.buf1).t[i] = hit ? h.t : -1.0;
}
