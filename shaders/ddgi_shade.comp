#version 460
/* DDGI probe-ray shading (paper Sec. 4.1 and 5): the radiance leaving each probe ray's hit
 * toward the probe (v = -ray direction). The hit starts a short path: at each vertex, emission +
 * f(v, l) * direct irradiance, then the path samples the BRDF (brdf_sample, as the path tracer
 * does) for vol.path_bounces bounces (the probe_paths setting; 0: the paper's first hit only); its
 * last vertex adds occlusion * min(A(N.V), 0.9)/pi * the
 * previous update's irradiance there, where f is the vertex's full BRDF (brdf_eval) and A =
 * brdf_hit_albedo, the directional albedo of that same f (diffuse part with its (1 - F), plus
 * the specular part's tabulated albedo: brdf.glsl's header gives the split). The direct term
 * comes from one light per vertex, chosen by its unshadowed contribution and divided by the
 * choice's probability (choose_light, unbiased); its visibility is read from the light's
 * distance map where the update has one (lights [0, vol.control.w): shadow_map.glsl) and the map
 * covers the point, else traced by one shadow ray. The field's term carries light across
 * updates, one more bounce per update; the 0.9 cap guards energy (production practice).
 * The paper ends every probe ray at its first hit with the field's irradiance there. Where the
 * field cannot hold the light a hit receives (the inside of a lamp shade lit by its bulb: the
 * field interpolates the room's probes, which see the shade from outside), that loses the
 * near-field bounces: builtin:interior is 26% dark against the path tracer. Three traced
 * bounces (with the linear blend they need, gpu_types.h) bring it to -4..-9%, and the lamp room
 * (tests/bench/lamp_room_gltf.py) from -29% to -7% (NVIDIA H200,
 * tests/bench/results/h200/probe_paths.txt); they cost probe shading 2.5-4.5 times while probes
 * are awake, nothing once they sleep. The default (RD_DDGI_DEFAULT_PATH_BOUNCES), together
 * with near-field rays at camera pixels (near_field.comp), which bring back the corner and
 * contact darkening that the linear blend no longer hides.
 * Two orders (rd_ddgi.sort_hits):
 * - params.z = 1, sorted: one thread per hit of the update's binned list (ddgi_bin.comp, which
 *   already gave misses the sky and back faces nothing), in cell order: a warp shades hits that
 *   lie close together, so their shadow rays run side by side. The list's length comes from
 *   ddgi_scan.comp; dispatched by shade_args.
 * - params.z = 0, when every light has a map: one thread per ray of the listed active probes,
 *   as the trace ran them (dispatched by trace_args); misses and back faces are shaded here.
 * push: globals, buf0 = uvec4 hits[], buf1 = pc_counters, buf2 = uint sorted[] (ray slots;
 * sorted order only), params.y = 1 when the probe field already holds an update (else a path's
 * last vertex adds no field term). */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ddgi.glsl"
#include "shadow_map.glsl"

layout(local_size_x = PC_WG_1D) in;

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer HitRef { uvec4 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer SortedRef { uint v[]; };

void main()
{
    count_rays_begin();
    pc_globals g = load_globals();
    pc_ddgi_volume vol = g.ddgi;
    uint shadow_rays = 0u, path_rays = 0u;
    uint slot = PC_INVALID, ray = 0u;
    if (pc.params.z != 0u) { /* sorted: the binned list of hits */
        uint i = gl_GlobalInvocationID.x;
        if (i < DdgiControlRef(vol.ctrl).shade_args.w) {
            slot = SortedRef(pc.buf2).v[i];
            ray = slot % vol.counts.w;
        }
    } else { /* in the trace's order: every ray of the listed active probes */
        uint probe = ddgi_listed_probe(vol, gl_WorkGroupID.y);
        ray = ddgi_thread_ray(vol, gl_GlobalInvocationID.x);
        if (ray < vol.counts.w && ddgi_probe_active(vol, probe)) slot = probe * vol.counts.w + ray;
    }
    vec4 r = vec4(0.0);
    uvec4 rec = uvec4(PC_INVALID);
    if (slot != PC_INVALID) {
        r = DdgiRayRef(vol.rays).v[slot];
        rec = HitRef(pc.buf0).v[slot];
        if (rec.x == PC_INVALID || r.w < 0.0) { /* only unsorted: the binning shades these */
            DdgiRayRef(vol.rays).v[slot] = vec4(ddgi_miss_radiance(g.env, vol, ray, rec.x), r.w);
            slot = PC_INVALID;
        }
    }
    if (slot != PC_INVALID) {
        pc_hit hit;
        hit.t = r.w;
        hit.tri = rec.x;
        hit.instance = rec.y;
        hit.u = uintBitsToFloat(rec.z);
        hit.v = uintBitsToFloat(rec.w);
        hit.backface = false; /* a front hit, or a back hit of a double-sided surface */
        vec3 dir = ddgi_ray_dir(vol, ray);
        pc_surface sf;
        uint seed = pcg(slot ^ pcg(vol.info.y * 0x9E3779B9u + 0x632BE5ABu));
        vec3 radiance = vec3(0.0), throughput = vec3(1.0), n0 = vec3(0.0);
        /* the field's term at the path's last vertex: one call site, inside the loop, or with
         * masked lanes (common.glsl) after it, where it runs once rather than every iteration */
        vec3 field_weight = vec3(0.0), field_v = vec3(0.0);
        float field_reach = 0.0;
        for (uint depth = 0u;; depth++) {
            /* the vertex: the probe ray's hit, then each continued segment's (one call site) */
            sf = surface_at(g.scene, hit, dir);
            pc_brdf b = surface_brdf(sf);
            vec3 v = -dir;
            vec3 term, wi;
            float dist;
            uint light = choose_light(g.scene, sf.position, sf.normal, sf.geom_normal, v, b,
                                      rnd(seed), term, wi, dist);
            vec3 direct = vec3(0.0);
            if (light != PC_INVALID)
                direct = term * probe_light_visibility(g.scene, vol.shadow_maps, vol.control.w,
                                                       light, sf.position, sf.geom_normal,
                                                       sf.offset, wi, dist, shadow_rays);
            radiance += throughput * (sf.emission + direct);
            if (depth == vol.path_bounces) {
                if (pc.params.y == 0u) break; /* no field yet */
                /* probe-ray hits start at the probe, in free space (no limit on the bias along
                 * v); a continued path's hits, half their segment and the rest along the
                 * previous vertex's normal (ddgi_irradiance_at_hit) */
                field_v = v;
                field_reach = 1e30;
                if (depth != 0u) ddgi_hit_view(vol, dir, hit.t, n0, field_v, field_reach);
                vec3 albedo = brdf_hit_albedo(g.brdf_albedo, b, clamp(dot(sf.normal, v), 0.0, 1.0));
                field_weight = throughput * sf.occlusion * min(albedo, vec3(0.9)) / PC_PI;
#if !PC_MASKED_LANES
                radiance += field_weight * ddgi_irradiance(vol, g.scene, true,
                                                           env_irradiance(g.env, sf.normal),
                                                           sf.position, sf.normal, field_v,
                                                           field_reach, 0.0);
#endif
                break;
            }
            float u1 = rnd(seed), u2 = rnd(seed), u3 = rnd(seed);
            vec3 weight;
            if (!brdf_sample(b, sf.normal, v, vec3(u1, u2, u3), dir, weight)) break;
            if (dot(dir, sf.geom_normal) <= 0.0) break; /* below the true surface */
            throughput *= weight;
            if (all(equal(throughput, vec3(0.0)))) break;
            path_rays++;
            n0 = sf.normal;
            if (!trace_ray(g.scene, offset_ray_origin(sf.position, sf.geom_normal, sf.offset), dir,
                           0.0, 1e30, 0u, hit)) {
                radiance += throughput * env_radiance(g.env, dir);
                break;
            }
            if (hit.backface &&
                (floatBitsToUint(TriRef(g.scene.tris).v[hit.tri].v1.w) & PC_TRI_DOUBLE_SIDED) == 0u)
                break; /* absorbed */
            hit.backface = false;
        }
#if PC_MASKED_LANES
        if (field_reach > 0.0)
            radiance += field_weight * ddgi_irradiance(vol, g.scene, true,
                                                       env_irradiance(g.env, sf.normal),
                                                       sf.position, sf.normal, field_v,
                                                       field_reach, 0.0);
#endif
        if (any(isnan(radiance)) || any(isinf(radiance))) radiance = vec3(0.0);
        DdgiRayRef(vol.rays).v[slot] = vec4(radiance, r.w);
    }
    count_rays_end(pc.buf1, 4u, shadow_rays);
    count_rays_begin();
    count_rays_end(pc.buf1, 7u, path_rays);
}
