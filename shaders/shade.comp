#version 460
/* Shade pass: outgoing radiance toward the camera per pixel =
 *   emission + sum over punctual lights of f(v, l) * E * cos * visibility
 * with f the glTF metallic-roughness BRDF (brdf.glsl), v toward the camera and ray-traced hard
 * shadows (any-hit rays), none toward lights whose distance maps show the pixel certainly hidden
 * (direct_radiance, shadow_map.glsl). Misses keep the sky radiance.
 * push: globals, buf0 = pc_gbuffer_texel[], buf1 = pc_counters, buf2 = vec4 radiance[]. */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "shadow_map.glsl"

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
            vec3 p = t.position.xyz, v = normalize(g.view.eye.xyz - p);
            pc_brdf b = gbuffer_brdf(t);
            l += direct_radiance(g.scene, g.ddgi.shadow_maps, g.ddgi.control.w, DIRECT_CULLED_RAYS,
                                 p, t.normal.xyz, t.geom_normal.xyz, t.albedo.w, v, b, rays);
        }
        RadianceRef(pc.buf2).v[i] = vec4(l, 1.0);
    }
    count_rays_end(pc.buf1, 1u, rays);
}
