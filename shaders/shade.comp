#version 460
/* Shade pass: outgoing radiance toward the camera per pixel =
 *   emission + albedo/pi * (sum over punctual lights of E * cos * visibility)
 * with ray-traced hard shadows (any-hit rays). Misses keep the sky radiance.
 * push: globals, buf0 = pc_gbuffer_texel[], buf1 = pc_counters, buf2 = vec4 radiance[]. */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(local_size_x = PC_WG_2D_X, local_size_y = PC_WG_2D_Y) in;
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer GBufferRef { pc_gbuffer_texel v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) writeonly buffer RadianceRef { vec4 v[]; };

void main()
{
    count_rays_begin();
    pc_globals g = load_globals();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint rays = 0u;
    if (all(lessThan(px, g.view.size.xy))) {
        uint i = px.y * g.view.size.x + px.x;
        pc_gbuffer_texel t = GBufferRef(pc.buf0).v[i];
        vec3 l = t.emission.rgb;
        if (t.position.w >= 0.0) {
            vec3 e = direct_irradiance(g.scene, t.position.xyz, t.normal.xyz, t.geom_normal.xyz, rays);
            l += t.albedo.rgb / PC_PI * e;
        }
        RadianceRef(pc.buf2).v[i] = vec4(l, 1.0);
    }
    count_rays_end(pc.buf1, 1u, rays);
}
