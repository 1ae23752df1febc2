#version 460
/* test_direct.comp: direct light at ray hits, for tests/renderer/test_gpu_direct_light.c. Each
 * thread traces its ray to the closest hit, shades it as a Lambertian (the surface's
 * Lambert-folded albedo, as probe hits are) and writes the all-lights sum (direct_radiance) and
 * the mean of direct_radiance_sampled over params.y stratified numbers u = (k + 1/2) / n, whose
 * limit is the same sum when the one-ray estimator is unbiased.
 * push: globals, buf0 = rays (vec4 origin, vec4 direction), buf1 = results (vec4 exact with
 * w = the summed RGB of the unshadowed terms, -1 for a miss; vec4 mean with w = shadow rays
 * traced), params.x = ray count, params.y = n. */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "shadow_map.glsl"

layout(local_size_x = PC_WG_1D) in;
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer RayRef { vec4 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) writeonly buffer OutRef { vec4 v[]; };

/* W: the summed RGB of every light's unshadowed term at p (the weight choose_light chooses by). */
float light_weight_total(pc_scene_refs s, vec3 p, vec3 n, vec3 ng, vec3 v, pc_brdf b)
{
    float total = 0.0;
    vec3 wi;
    float dist;
    for (uint i = 0u; i < s.counts.y; i++) {
        vec3 f = light_term(s, i, p, n, ng, v, b, wi, dist);
        total += f.r + f.g + f.b;
    }
    return total;
}

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.params.x) return;
    pc_globals g = load_globals();
    vec3 o = RayRef(pc.buf0).v[2u * i].xyz, d = RayRef(pc.buf0).v[2u * i + 1u].xyz;
    pc_hit hit;
    vec4 exact = vec4(0.0, 0.0, 0.0, -1.0), mean = vec4(0.0);
    if (trace_ray(g.scene, o, d, 0.0, 1e30, 0u, hit)) {
        pc_surface sf = surface_at(g.scene, hit, d);
        pc_brdf lambert = brdf_make(brdf_lambert_albedo(surface_brdf(sf)), 0.0, 1.0, 0.0);
        uint rays = 0u;
        float total = light_weight_total(g.scene, sf.position, sf.normal, sf.geom_normal, -d,
                                         lambert);
        exact = vec4(direct_radiance(g.scene, 0ul, 0u, DIRECT_CULLED_RAYS, sf.position, sf.normal,
                                     sf.geom_normal, sf.offset, -d, lambert, rays),
                     total);
        uint n = pc.params.y, sampled = 0u;
        vec3 sum = vec3(0.0);
        for (uint k = 0u; k < n; k++)
            sum += direct_radiance_sampled(g.scene, sf.position, sf.normal, sf.geom_normal,
                                           sf.offset, -d, lambert, (float(k) + 0.5) / float(n),
                                           sampled);
        mean = vec4(sum / float(n), float(sampled));
    }
    OutRef(pc.buf1).v[2u * i] = exact;
    OutRef(pc.buf1).v[2u * i + 1u] = mean;
}
