#version 460
/* Test kernel for ddgi.glsl's math (tests/renderer/test_gpu_ddgi.c):
 * params.x = 0: out[i] = oct_decode(oct_encode(in[i])) for params.y directions;
 * params.x = 1: out[i] = ddgi_ray_dir(globals.ddgi, i) for the volume's ray count.
 * push: globals, buf0 = vec4 in[], buf1 = vec4 out[]. */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ddgi.glsl"

layout(local_size_x = PC_WG_1D) in;
layout(buffer_reference, std430, buffer_reference_align = 16) buffer Vec4Ref { vec4 v[]; };

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (pc.params.x == 0u) {
        if (i >= pc.params.y) return;
        vec3 d = Vec4Ref(pc.buf0).v[i].xyz;
        Vec4Ref(pc.buf1).v[i] = vec4(oct_decode(oct_encode(d)), 0.0);
    } else {
        pc_ddgi_volume vol = load_globals().ddgi;
        if (i >= vol.counts.w) return;
        Vec4Ref(pc.buf1).v[i] = vec4(ddgi_ray_dir(vol, i), 0.0);
    }
}
