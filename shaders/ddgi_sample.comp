#version 460
/* GI sampling for the camera (paper Sec. 5): adds occlusion * diffuse albedo/pi * E(P, n)
 * from the probe field to each pixel's direct radiance, with v = the direction toward the
 * camera; the diffuse albedo is (1 - metallic) * baseColor (brdf_diffuse_albedo) and the
 * occlusion map darkens only this indirect term (glTF: occlusion applies to indirect light). View modes:
 * PC_VIEW_IRRADIANCE writes E/pi alone (the indirect light as if albedo were 1);
 * PC_VIEW_PROBES draws every probe as a small sphere shaded with its stored irradiance, and
 * its state: sleeping (converged) plain, awake with a yellow rim, off (inside geometry) dark red.
 * With indirect specular on (params.x = 1; rd_view_settings.reflections), the two parts of
 * Appendix B's mix share the indirect light without counting it twice: the diffuse albedo
 * takes the dielectric's (1 - F) (brdf_diffuse_albedo_indirect), and surfaces too rough for
 * reflection rays (roughness >= PC_REFLECT_MAX_ROUGHNESS) get their specular part here,
 * split-sum style: occlusion * specular albedo(N.V) (brdf_specular_albedo: the integral of
 * our BRDF, tabulated by brdf_albedo.comp) * E(P, d) / pi, where d is the lobe's dominant
 * direction and E/pi, the probe field's cosine-weighted average of radiance around d, stands
 * in for the lobe's average radiance (exact for uniform light, smooth for wide lobes). Glossier
 * pixels get theirs from reflect.comp; with params.x = 0 neither happens (the old image).
 * Near-field rays (near_field.comp; buf1 != 0) correct the field's irradiance E(P, n) at
 * scales finer than the probe spacing: E is multiplied by the pixel's mean ratio, filtered
 * across the neighbours that trace them in this history epoch and lie on the same surface
 * (weights for the normals' agreement, cos^32, and the neighbour's distance from the pixel's
 * tangent plane against the pixel footprint, as reflect_filter.comp does). The filter's
 * radius is 2 pixels while the pixel has at most 2 samples (a fresh epoch: one pixel in four
 * has one), then 1. Pixels without any sample in reach keep the field's value.
 * push: globals, buf0 = pc_gbuffer_texel[], buf1 = uvec4 near history[] (0: no near-field
 * rays), buf2 = vec4 radiance[], params.x as above, params.y = the near history's epoch. */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ddgi.glsl"

layout(local_size_x = PC_WG_2D_X, local_size_y = PC_WG_2D_Y) in;
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer GBufferRef { pc_gbuffer_texel v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer RadianceRef { vec4 v[]; };

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer NearRef { uvec4 v[]; };

/* The filtered near-field ratio of pixel px (vec3(1) without one; see above). */
vec3 near_ratio(pc_globals g, ivec2 px, pc_gbuffer_texel t)
{
    if (pc.buf1 == 0ul) return vec3(1.0);
    ivec2 size = ivec2(g.view.size.xy);
    uint epoch = pc.params.y & 0xffffffu;
    uvec4 h = NearRef(pc.buf1).v[px.y * size.x + px.x];
    uint frames = (h.w >> 8) == epoch ? h.w & 0xffu : 0u;
    int radius = frames <= 2u ? 2 : 1;
    vec3 p = t.position.xyz, n = t.normal.xyz;
    float footprint = t.position.w * 2.0 * length(g.view.up.xyz) / float(size.y);
    vec3 sum = vec3(0.0);
    float wsum = 0.0;
    for (int dy = -radius; dy <= radius; dy++)
        for (int dx = -radius; dx <= radius; dx++) {
            ivec2 q = px + ivec2(dx, dy);
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
            uint j = uint(q.y * size.x + q.x);
            uvec4 hq = NearRef(pc.buf1).v[j];
            uint fq = (hq.w >> 8) == epoch ? hq.w & 0xffu : 0u;
            if (fq == 0u) continue;
            pc_gbuffer_texel tq = GBufferRef(pc.buf0).v[j];
            float off = length(vec2(dx, dy));
            float plane = abs(dot(n, tq.position.xyz - p)) / (footprint * (1.0 + off) + 1e-6);
            float w = float(fq) * pow(max(dot(n, tq.normal.xyz), 0.0), 32.0) * exp(-plane) *
                      (1.0 - off / (float(radius) + 1.0));
            sum += w * uintBitsToFloat(hq.xyz);
            wsum += w;
        }
    return wsum > 1e-6 ? sum / wsum : vec3(1.0);
}

void main()
{
    pc_globals g = load_globals();
    uvec2 px = gl_GlobalInvocationID.xy;
    if (any(greaterThanEqual(px, g.view.size.xy))) return;
    uint i = px.y * g.view.size.x + px.x;
    pc_gbuffer_texel t = GBufferRef(pc.buf0).v[i];
    uint view = uint(g.view.tonemap.z);
    vec3 l = RadianceRef(pc.buf2).v[i].rgb;
    if (t.position.w >= 0.0) {
        vec3 p = t.position.xyz;
        vec3 v = normalize(g.view.eye.xyz - p);
        float reach = 0.5 * distance(g.view.eye.xyz, p);
        vec3 e = ddgi_irradiance(g.ddgi, g.scene, false, env_irradiance(g.env, t.normal.xyz), p,
                                 t.normal.xyz, v, reach, DDGI_VIS_CLEAR_SIGMAS) *
                 near_ratio(g, ivec2(px), t);
        pc_brdf b = gbuffer_brdf(t);
        bool specular = pc.params.x != 0u && gbuffer_has_specular(t);
        float nv = clamp(dot(t.normal.xyz, v), 0.0, 1.0);
        vec3 a = (specular ? brdf_diffuse_albedo_indirect(b, nv) : brdf_diffuse_albedo(b)) *
                 t.material.z;
        l = view == PC_VIEW_IRRADIANCE ? e / PC_PI : l + a / PC_PI * e;
        if (specular && !gbuffer_traces_reflection(t) && view != PC_VIEW_IRRADIANCE) {
            vec3 d = brdf_dominant_direction(b, t.normal.xyz, v);
            vec3 ed = ddgi_irradiance(g.ddgi, g.scene, false, env_irradiance(g.env, d), p, d, v,
                                      reach, DDGI_VIS_CLEAR_SIGMAS);
            l += t.material.z * brdf_specular_albedo(g.brdf_albedo, b, nv) * ed / PC_PI;
        }
    } else if (view == PC_VIEW_IRRADIANCE) {
        l = vec3(0.0);
    }
    if (view == PC_VIEW_PROBES) {
        vec3 o = g.view.eye.xyz, d = camera_dir(g.view, px);
        float tmax = t.position.w >= 0.0 ? t.position.w : 1e30;
        float radius = 0.1 * min(g.ddgi.spacing.x, min(g.ddgi.spacing.y, g.ddgi.spacing.z));
        uint n = ddgi_probe_count(g.ddgi), hit = n;
        vec3 nrm = vec3(0.0, 0.0, 1.0);
        for (uint k = 0u; k < n; k++) {
            vec3 c = ddgi_probe_position(g.ddgi, k);
            vec3 oc = o - c;
            float b = dot(oc, d), q = dot(oc, oc) - radius * radius, disc = b * b - q;
            if (disc < 0.0) continue;
            float th = -b - sqrt(disc);
            if (th <= 0.0 || th >= tmax) continue;
            tmax = th;
            hit = k;
            nrm = normalize(o + th * d - c);
        }
        if (hit < n) {
            uint state = ddgi_probe_state(g.ddgi, hit);
            l = state == PC_DDGI_PROBE_OFF ? vec3(0.3, 0.0, 0.0)
                                           : ddgi_sample_irradiance(g.ddgi, hit, nrm);
            if (state == PC_DDGI_PROBE_AWAKE && dot(nrm, -d) < 0.4) l = vec3(1.0, 0.8, 0.0);
        }
    }
    RadianceRef(pc.buf2).v[i] = vec4(l, 1.0);
}
