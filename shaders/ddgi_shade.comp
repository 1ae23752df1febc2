#version 460
/* DDGI probe-ray shading (paper Sec. 4.1 and 5): radiance leaving each probe ray's hit toward
 * the probe = emission + A/pi * direct irradiance (shadow rays) + occlusion * min(A, 0.9)/pi *
 * the previous update's irradiance at the hit, where A = brdf_lambert_albedo: the hit is
 * shaded as a Lambertian whose albedo folds in the specular lobe's Fresnel-averaged energy
 * (paper: probe hits are shaded diffusely; folding keeps the metals' energy instead of
 * dropping it, and A <= 1 keeps energy conserved). The last term carries light across updates,
 * one more bounce per update; the 0.9 cap guards energy (production practice). Misses see
 * the sky; back faces of single-sided surfaces carry no radiance.
 * Works on the update's probe list, like ddgi_trace.comp.
 * push: globals, buf0 = uvec4 hits[], buf1 = pc_counters, params.y = 1 when the probe field
 * already holds an update (else no indirect term). */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ddgi.glsl"

layout(local_size_x = PC_WG_1D) in;
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer HitRef { uvec4 v[]; };

void main()
{
    count_rays_begin();
    pc_globals g = load_globals();
    pc_ddgi_volume vol = g.ddgi;
    uint ray = ddgi_thread_ray(vol, gl_GlobalInvocationID.x), probe = ddgi_listed_probe(vol, gl_WorkGroupID.y);
    uint shadow_rays = 0u;
    /* off probes are never sampled: nothing to shade */
    if (ray < vol.counts.w && ddgi_probe_active(vol, probe)) {
        uint slot = probe * vol.counts.w + ray;
        vec4 r = DdgiRayRef(vol.rays).v[slot];
        uvec4 rec = HitRef(pc.buf0).v[slot];
        vec3 radiance = vec3(0.0);
        if (rec.x == PC_INVALID) {
            radiance = env_radiance(g.env, ddgi_ray_dir(vol, ray));
        } else if (r.w >= 0.0) {
            pc_hit hit;
            hit.t = r.w;
            hit.tri = rec.x;
            hit.instance = rec.y;
            hit.u = uintBitsToFloat(rec.z);
            hit.v = uintBitsToFloat(rec.w);
            hit.backface = false; /* a front hit, or a back hit of a double-sided surface */
            vec3 dir = ddgi_ray_dir(vol, ray);
            pc_surface sf = surface_at(g.scene, hit, dir);
            vec3 albedo = brdf_lambert_albedo(surface_brdf(sf));
            pc_brdf lambert = brdf_make(albedo, 0.0, 1.0, 0.0); /* f = albedo / pi */
            vec3 direct = direct_radiance(g.scene, sf.position, sf.normal, sf.geom_normal, -dir,
                                          lambert, shadow_rays);
            vec3 indirect = vec3(0.0);
            if (pc.params.y != 0u)
                indirect = ddgi_irradiance(vol, env_irradiance(g.env, sf.normal), sf.position,
                                           sf.normal, -dir);
            radiance = sf.emission + direct +
                       sf.occlusion * min(albedo, vec3(0.9)) / PC_PI * indirect;
        }
        if (any(isnan(radiance)) || any(isinf(radiance))) radiance = vec3(0.0);
        DdgiRayRef(vol.rays).v[slot] = vec4(radiance, r.w);
    }
    count_rays_end(pc.buf1, 4u, shadow_rays);
}
