#version 460
/* Reflection pass: the indirect specular term of glossy pixels (roughness below
 * PC_REFLECT_MAX_ROUGHNESS; rougher ones: ddgi_sample.comp). One ray per pixel and frame in a
 * direction l sampled from the GGX visible normals of the pixel's BRDF (brdf_sample_specular,
 * the sampler the path tracer uses), with weight F G2 / G1: an unbiased one-sample estimate of
 * the specular part of Appendix B's integral against the radiance L arriving along l
 * (the diffuse part, with its (1 - F), comes from direct light and the probe field).
 * L is what the path tracer's next vertex would return, minus its further paths:
 *   miss: env_radiance(l);
 *   hit:  emission + direct light with the hit's full BRDF toward -l, every light's
 *         visibility read from its map where the map's texels agree, a shadow ray elsewhere
 *         (direct_radiance, DIRECT_MAP_VISIBILITY, as probe-ray hits do; camera pixels trace exact rays)
 *         + occlusion * A(N.V) / pi * E(hit), with E the probe field's irradiance
 *         (env_irradiance outside the volume) and A = brdf_hit_albedo toward -l: the hit's
 *         indirect light is taken as diffuse, reflected with the BRDF's own albedo (as at
 *         probe-ray hits; brdf.glsl's header);
 *   a back face of a single-sided surface absorbs, and a direction below the geometric
 *   surface gets nothing (both as in pathtrace.comp).
 * The estimate is demodulated (divided by the pixel's specular albedo, brdf_specular_albedo)
 * so that averaging and filtering across pixels keep texture detail, and accumulated per
 * pixel: a running mean over the frames of this history epoch (params.x; the view starts a
 * new epoch when the camera, the size or the world change), at most PC_REFLECT_HISTORY_MAX
 * frames long. reflect_filter.comp remodulates, filters and adds it to the image.
 * Dispatched indirectly (pc_reflect_control): only frames with a glossy pixel in sight run it.
 * push: globals, buf0 = pc_gbuffer_texel[], buf1 = pc_counters, buf2 = uvec4 history[]
 *       (xyz: float bits of the demodulated mean, w: epoch << 8 | frames, 0 = none),
 *       params.x = history epoch (24 bits). */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ddgi.glsl"
#include "shadow_map.glsl"

layout(local_size_x = PC_WG_2D_X, local_size_y = PC_WG_2D_Y) in;
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer GBufferRef { pc_gbuffer_texel v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer HistoryRef { uvec4 v[]; };

/* Radiance arriving at the pixel's surface along l (see above). */
vec3 incoming(pc_globals g, vec3 origin, vec3 n0, vec3 l, inout uint rays)
{
    pc_hit hit;
    rays++;
    if (!trace_ray(g.scene, origin, l, 0.0, 1e30, 0u, hit)) return env_radiance(g.env, l);
    if (hit.backface) {
        uint flags = floatBitsToUint(TriRef(g.scene.tris).v[hit.tri].v1.w);
        if ((flags & PC_TRI_DOUBLE_SIDED) == 0u) return vec3(0.0);
    }
    pc_surface sf = surface_at(g.scene, hit, l);
    pc_brdf b = surface_brdf(sf);
    vec3 direct = direct_radiance(g.scene, g.ddgi.shadow_maps, g.ddgi.control.w,
                                  DIRECT_MAP_VISIBILITY, sf.position, sf.normal, sf.geom_normal,
                                  sf.offset, -l, b, rays);
    vec3 e = ddgi_irradiance_at_hit(g.ddgi, g.scene, false, env_irradiance(g.env, sf.normal),
                                    sf.position, sf.normal, l, hit.t, n0, 0.0);
    vec3 a = brdf_hit_albedo(g.brdf_albedo, b, clamp(dot(sf.normal, -l), 0.0, 1.0));
    return sf.emission + direct + sf.occlusion * a / PC_PI * e;
}

void main()
{
    count_rays_begin();
    pc_globals g = load_globals();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint rays = 0u;
    if (all(lessThan(px, g.view.size.xy))) {
        uint i = px.y * g.view.size.x + px.x;
        pc_gbuffer_texel t = GBufferRef(pc.buf0).v[i];
        uvec4 h = uvec4(0u);
        if (gbuffer_traces_reflection(t)) {
            vec3 p = t.position.xyz, n = t.normal.xyz, v = normalize(g.view.eye.xyz - p);
            pc_brdf b = gbuffer_brdf(t);
            uint s = pcg(i ^ pcg(g.view.size.z ^ pcg(g.view.size.w ^ 0x52f1ec7u)));
            vec2 u = vec2(rnd(s), rnd(s));
            vec3 l, weight, sample_value = vec3(0.0);
            if (brdf_sample_specular(b, n, v, u, l, weight) && dot(l, t.geom_normal.xyz) > 0.0)
                sample_value = weight * incoming(g, offset_ray_origin(p, t.geom_normal.xyz,
                                                                      t.albedo.w), n, l, rays);
            vec3 albedo = brdf_specular_albedo(g.brdf_albedo, b, clamp(dot(n, v), 0.0, 1.0));
            sample_value /= max(albedo, vec3(1e-4));
            if (any(isnan(sample_value)) || any(isinf(sample_value))) sample_value = vec3(0.0);
            uvec4 old = HistoryRef(pc.buf2).v[i];
            uint epoch = pc.params.x & 0xffffffu;
            uint frames = (old.w >> 8) == epoch ? old.w & 0xffu : 0u;
            vec3 mean = frames > 0u ? uintBitsToFloat(old.xyz) : vec3(0.0);
            frames = min(frames + 1u, PC_REFLECT_HISTORY_MAX);
            mean += (sample_value - mean) / float(frames);
            h = uvec4(floatBitsToUint(mean), epoch << 8 | frames);
        }
        HistoryRef(pc.buf2).v[i] = h;
    }
    count_rays_end(pc.buf1, 5u, rays);
}
