#version 460
/* DDGI probe trace (paper Sec. 4.1): one thread per (probe ray, probe). Each ray follows the
 * update's rotated spherical Fibonacci direction; a hit is shaded with direct light (shadow
 * rays), emission, and albedo/pi times the previous update's irradiance at the hit (which
 * gives multiple bounces over successive updates; albedo is capped at 0.9 there to guard
 * energy). Misses store the sky radiance; back-face hits store no radiance and a negative,
 * shortened distance (-0.2 t) that marks the probe as possibly inside geometry.
 * push: globals, buf1 = pc_counters. Inactive probes trace too (to wake up if the scene
 * changes), but the blend ignores nothing: classification happens there. */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ddgi.glsl"

layout(local_size_x = PC_WG_1D) in;

void main()
{
    count_rays_begin();
    pc_globals g = load_globals();
    pc_ddgi_volume vol = g.ddgi;
    uint ray = gl_GlobalInvocationID.x, probe = gl_GlobalInvocationID.y;
    uint rays = 0u;
    if (ray < vol.counts.w && probe < ddgi_probe_count(vol)) {
        vec3 org = ddgi_probe_position(vol, probe);
        vec3 dir = ddgi_ray_dir(vol, ray);
        pc_hit hit;
        vec4 result;
        rays = 1u;
        if (!trace_ray(g.scene, org, dir, 0.0, 1e30, 0u, hit)) {
            result = vec4(g.view.sky.rgb, 1e27);
        } else if (hit.backface && (floatBitsToUint(TriRef(g.scene.tris).v[hit.tri].v1.w) & PC_TRI_DOUBLE_SIDED) == 0u) {
            result = vec4(0.0, 0.0, 0.0, -0.2 * hit.t);
        } else {
            pc_surface sf = surface_at(g.scene, hit, dir);
            uint shadow_rays = 0u;
            vec3 e_direct = direct_irradiance(g.scene, sf.position, sf.normal, sf.geom_normal, shadow_rays);
            rays += shadow_rays;
            vec3 e_indirect = ddgi_irradiance(vol, g.view.sky.rgb, sf.position, sf.normal, -dir);
            vec3 radiance = sf.emission + sf.albedo / PC_PI * e_direct +
                            min(sf.albedo, vec3(0.9)) / PC_PI * e_indirect;
            result = vec4(radiance, hit.t);
        }
        DdgiRayRef(vol.rays).v[probe * vol.counts.w + ray] = result;
    }
    count_rays_end(pc.buf1, 2u, rays);
}
