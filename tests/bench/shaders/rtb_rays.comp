#version 460
/* rtb_rays.comp: the ray sets of tests/bench/rt_yardstick.c, written once and traced by both
 * tracers: the renderer's own primary rays (camera_dir of common.glsl, one per pixel, row by
 * row) or DDGI probe rays (ddgi_probe_position and ddgi_ray_dir of ddgi.glsl: probe-major,
 * then ray index). Rays are two vec4: (origin, tmin), (direction, tmax).
 * push: globals (view and ddgi as the renderer fills them), buf0 = rays,
 * params.x = ray count, params.y = 0 primary / 1 probe rays, params.z = threads per row. */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ddgi.glsl"

layout(local_size_x = PC_WG_1D) in;
layout(buffer_reference, std430, buffer_reference_align = 16) writeonly buffer RtbRays { vec4 v[]; };

void main()
{
    uint i = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * pc.params.z;
    if (i >= pc.params.x) return;
    pc_globals g = load_globals();
    vec3 o, d;
    if (pc.params.y == 0u) {
        o = g.view.eye.xyz;
        d = camera_dir(g.view, uvec2(i % g.view.size.x, i / g.view.size.x));
    } else {
        uint probe = i / g.ddgi.counts.w;
        o = ddgi_probe_position(g.ddgi, probe);
        d = ddgi_ray_dir(g.ddgi, i % g.ddgi.counts.w);
    }
    RtbRays(pc.buf0).v[2u * i] = vec4(o, 0.0);
    RtbRays(pc.buf0).v[2u * i + 1u] = vec4(d, 1e30);
}
