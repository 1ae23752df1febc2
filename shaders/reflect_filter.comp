#version 460
/* Reflection filter: adds each glossy pixel's indirect specular term to its radiance:
 *   radiance += specular albedo(N.V) * (edge-aware spatial mean of the demodulated history
 *               of reflect.comp around the pixel).
 * The filter is a small cross-bilateral box whose radius grows with roughness (0 below 0.1:
 * a mirror's reflection is an image that any blur would smear; PC_REFLECT_FILTER_RADIUS at
 * PC_REFLECT_MAX_ROUGHNESS, where the lobe blurs the reflection anyway) and shrinks as the
 * temporal history gets long (its noise falls as 1/sqrt(frames)). Neighbours count only when
 * they trace reflections in this history epoch and lie on the same surface: weights for the
 * normals' agreement (cos^64), the neighbour's distance from the pixel's tangent plane
 * against the pixel footprint, and similar roughness.
 * Dispatched indirectly after reflect.comp, with the same arguments.
 * push: globals, buf0 = pc_gbuffer_texel[], buf1 = uvec4 history[], buf2 = vec4 radiance[],
 *       params.x = history epoch. */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(local_size_x = PC_WG_2D_X, local_size_y = PC_WG_2D_Y) in;
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer GBufferRef { pc_gbuffer_texel v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer HistoryRef { uvec4 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer RadianceRef { vec4 v[]; };

void main()
{
    pc_globals g = load_globals();
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = ivec2(g.view.size.xy);
    if (any(greaterThanEqual(px, size))) return;
    uint i = uint(px.y * size.x + px.x);
    pc_gbuffer_texel t = GBufferRef(pc.buf0).v[i];
    if (!gbuffer_traces_reflection(t)) return;
    uint epoch = pc.params.x & 0xffffffu;
    uvec4 h = HistoryRef(pc.buf1).v[i];
    if ((h.w >> 8) != epoch || (h.w & 0xffu) == 0u) return; /* not traced (cannot happen) */
    vec3 p = t.position.xyz, n = t.normal.xyz, v = normalize(g.view.eye.xyz - p);
    float rough = t.material.y;
    float frames = float(h.w & 0xffu);
    float scale = clamp((rough - 0.1) / (PC_REFLECT_MAX_ROUGHNESS - 0.1), 0.0, 1.0) *
                  clamp(2.0 / sqrt(frames), 1.0 / 3.0, 1.0);
    int radius = int(float(PC_REFLECT_FILTER_RADIUS) * scale + 0.5);
    /* world size of one pixel at this depth (camera_dir: up spans 2 |up| over the height) */
    float footprint = t.position.w * 2.0 * length(g.view.up.xyz) / float(size.y);
    vec3 sum = uintBitsToFloat(h.xyz);
    float wsum = 1.0;
    for (int dy = -radius; dy <= radius; dy++)
        for (int dx = -radius; dx <= radius; dx++) {
            ivec2 q = px + ivec2(dx, dy);
            if ((dx == 0 && dy == 0) || any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size)))
                continue;
            uint j = uint(q.y * size.x + q.x);
            pc_gbuffer_texel tq = GBufferRef(pc.buf0).v[j];
            uvec4 hq = HistoryRef(pc.buf1).v[j];
            if (!gbuffer_traces_reflection(tq) || (hq.w >> 8) != epoch || (hq.w & 0xffu) == 0u)
                continue;
            float off = length(vec2(dx, dy));
            float plane = abs(dot(n, tq.position.xyz - p)) / (footprint * (1.0 + off) + 1e-6);
            float w = pow(max(dot(n, tq.normal.xyz), 0.0), 64.0) * exp(-plane) *
                      max(0.0, 1.0 - 5.0 * abs(tq.material.y - rough)) *
                      (1.0 - off / (float(radius) + 1.0));
            sum += w * uintBitsToFloat(hq.xyz);
            wsum += w;
        }
    vec3 albedo = brdf_specular_albedo(g.brdf_albedo, gbuffer_brdf(t), clamp(dot(n, v), 0.0, 1.0));
    vec4 r = RadianceRef(pc.buf2).v[i];
    RadianceRef(pc.buf2).v[i] = vec4(r.rgb + albedo * sum / wsum, r.w);
}
