#version 460
/* Reference path tracer: one path per pixel per dispatch, accumulated in a float buffer.
 * Unbiased for our material model (glTF metallic-roughness, brdf.glsl; emission; punctual
 * lights): the camera ray goes through the pixel centre (the same point DDGI shades, so
 * errors compare per pixel); every vertex adds emission and next-event estimation of every
 * punctual light with a shadow ray and the full BRDF. Punctual lights are deltas, so NEE is
 * their only strategy; emissive surfaces and the sky have no light-sampling strategy (they are
 * reached only by BSDF sampling), so no MIS between light and BSDF sampling is needed or
 * possible. Directions come from brdf_sample: a mixture of GGX visible-normal sampling and
 * cosine sampling weighted by its mixture pdf (a pure Lambertian takes the cosine sampler
 * alone, with the same random numbers as before). Russian roulette from bounce 3 on with
 * survival max(throughput) capped at 0.95, no clamping. Occlusion maps are ignored: the
 * reference resolves the geometry they stand for. Back faces of single-sided surfaces absorb
 * (the same convention as DDGI's probe rays). Deterministic per seed.
 * push: globals, buf0 = vec4 accumulation[], buf1 = pc_counters,
 *       params.x = sample index, params.y = max bounces (0 = 64). */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "shadow_map.glsl"

layout(local_size_x = PC_WG_2D_X, local_size_y = PC_WG_2D_Y) in;
layout(buffer_reference, std430, buffer_reference_align = 16) buffer AccumRef { vec4 v[]; };

void main()
{
    count_rays_begin();
    pc_globals g = load_globals();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint rays = 0u;
    if (all(lessThan(px, g.view.size.xy))) {
        uint pixel = px.y * g.view.size.x + px.x;
        uint s = pcg(pixel ^ pcg(pc.params.x ^ pcg(g.view.size.w)));
        uint max_bounces = pc.params.y == 0u ? 64u : pc.params.y;
        vec3 org = g.view.eye.xyz, dir = camera_dir(g.view, px);
        vec3 throughput = vec3(1.0), radiance = vec3(0.0);
        uint flags = PC_TRACE_CULL_BACKFACES; /* primary rays see what the camera sees */
        for (uint bounce = 0u; bounce <= max_bounces; bounce++) {
            pc_hit hit;
            rays++;
            if (!trace_ray(g.scene, org, dir, 0.0, 1e30, flags, hit)) {
                radiance += throughput * env_radiance(g.env, dir);
                break;
            }
            flags = 0u;
            pc_surface sf = surface_at(g.scene, hit, dir);
            if (hit.backface) {
                uint tf = floatBitsToUint(TriRef(g.scene.tris).v[hit.tri].v1.w);
                if ((tf & PC_TRI_DOUBLE_SIDED) == 0u) break; /* absorbed */
            }
            radiance += throughput * sf.emission;
            uint shadow = 0u;
            pc_brdf b = surface_brdf(sf);
            vec3 v = -dir;
            radiance += throughput * direct_radiance(g.scene, 0ul, 0u, DIRECT_CULLED_RAYS,
                                                     sf.position, sf.normal, sf.geom_normal,
                                                     sf.offset, v, b, shadow);
            rays += shadow;
            if (bounce == max_bounces) break;
            /* random numbers in the order of the Lambertian-only tracer: roulette, then the
             * direction, then (only with two lobes) the lobe */
            float u_rr = bounce >= 3u ? rnd(s) : 0.0;
            float u1 = rnd(s), u2 = rnd(s);
            float p_spec = brdf_specular_probability(b);
            float u3 = p_spec > 0.0 && p_spec < 1.0 ? rnd(s) : 0.5;
            vec3 weight;
            if (!brdf_sample(b, sf.normal, v, vec3(u1, u2, u3), dir, weight)) break;
            throughput *= weight;
            if (bounce >= 3u) {
                float q = min(0.95, max(throughput.r, max(throughput.g, throughput.b)));
                if (u_rr >= q) break;
                throughput /= q;
            }
            if (all(equal(throughput, vec3(0.0)))) break;
            if (dot(dir, sf.geom_normal) <= 0.0) break; /* below the true surface */
            org = offset_ray_origin(sf.position, sf.geom_normal, sf.offset);
        }
        AccumRef acc = AccumRef(pc.buf0);
        acc.v[pixel] = (pc.params.x == 0u ? vec4(0.0) : acc.v[pixel]) + vec4(radiance, 1.0);
    }
    count_rays_end(pc.buf1, 3u, rays);
}
