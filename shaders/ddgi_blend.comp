#version 460
/* DDGI probe blend (paper Sec. 4.2, Eq. 1): one workgroup per probe, one thread per interior
 * texel of its octahedral tile. params.x selects the atlas: 0 = irradiance (8x8, weights
 * max(0, cos), perceptual encoding x^(1/5), convergence heuristics), 1 = distance (16x16,
 * weights cos^50, mean and mean square of min(|t|, max distance)). The irradiance blend also
 * classifies the probe: more than params.z back-face hits means it sits inside geometry and
 * is switched off for sampling. Rays are staged through shared memory in chunks.
 * push: globals, params.x = atlas. */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ddgi.glsl"

layout(local_size_x = PC_DDGI_DIST_INTERIOR, local_size_y = PC_DDGI_DIST_INTERIOR) in;

#define CHUNK 256u
shared vec4 s_ray[CHUNK];
shared vec3 s_dir[CHUNK];
shared uint s_backfaces;

void main()
{
    pc_globals g = load_globals();
    pc_ddgi_volume vol = g.ddgi;
    bool irradiance = pc.params.x == 0u;
    uint interior = irradiance ? PC_DDGI_IRR_INTERIOR : PC_DDGI_DIST_INTERIOR;
    uint side = interior + 2u;
    uint probe = gl_WorkGroupID.x;
    uvec2 t = gl_LocalInvocationID.xy;
    bool mine = all(lessThan(t, uvec2(interior)));
    vec3 texel_dir = oct_texel_dir(min(t, uvec2(interior - 1u)), interior);
    /* the classification as the trace saw it (the distance blend runs first, the irradiance
     * blend updates the classification last) */
    bool probe_on = ddgi_probe_active(vol, probe);
    if (!probe_on && !irradiance) return; /* whole workgroup: an off probe keeps its atlas */
    uint n = probe_on ? vol.counts.w : min(vol.counts.w, PC_DDGI_INACTIVE_RAYS);
    if (!probe_on) mine = false;         /* only re-classified, not blended */
    uint lid = gl_LocalInvocationIndex;
    uint threads = gl_WorkGroupSize.x * gl_WorkGroupSize.y;
    if (lid == 0u) s_backfaces = 0u;

    vec3 sum = vec3(0.0);
    float wsum = 0.0;
    float max_dist = vol.origin.w;
    for (uint base = 0u; base < n; base += CHUNK) {
        barrier();
        for (uint i = lid; i < CHUNK && base + i < n; i += threads) {
            s_ray[i] = DdgiRayRef(vol.rays).v[probe * vol.counts.w + base + i];
            s_dir[i] = ddgi_ray_dir(vol, base + i);
        }
        barrier();
        uint count = min(CHUNK, n - base);
        if (irradiance && lid == 0u) /* classification: back faces among the traced rays */
            for (uint i = 0u; i < count; i++) s_backfaces += s_ray[i].w < 0.0 ? 1u : 0u;
        if (!mine) continue;
        for (uint i = 0u; i < count; i++) {
            vec4 r = s_ray[i];
            float c = dot(texel_dir, s_dir[i]);
            if (irradiance) {
                if (r.w < 0.0) continue; /* back face: no irradiance */
                float w = max(0.0, c);
                sum += r.rgb * w;
                wsum += w;
            } else {
                float w = pow(max(0.0, c), 50.0);
                float d = min(abs(r.w), max_dist);
                sum.xy += vec2(d, d * d) * w;
                wsum += w;
            }
        }
    }
    barrier();
    bool first = vol.info.y == 0u;
    float h = first ? 0.0 : vol.params.x;
    if (mine) {
        uint texel = ddgi_texel(probe, side, t.x + 1u, t.y + 1u);
        if (irradiance) {
            float e = vol.params.w;
            vec3 fresh = pow(wsum > 1e-6 ? sum / wsum : vec3(0.0), vec3(1.0 / e));
            DdgiIrradianceRef a = DdgiIrradianceRef(vol.irradiance);
            uvec2 old_packed = a.v[texel];
            vec3 old = vec3(unpackHalf2x16(old_packed.x), unpackHalf2x16(old_packed.y).x);
            bool written = unpackHalf2x16(old_packed.y).y > 0.5;
            if (!written || first) h = 0.0;
            /* convergence heuristics (ddgi-reference.md): large drops converge faster... */
            if (any(greaterThan(old - fresh, vec3(0.25)))) h = max(0.0, h - 0.75);
            vec3 delta = fresh - old;
            vec3 step = (1.0 - h) * delta;
            /* ...large brightness changes are damped against flicker... */
            if (written && abs(luminance(delta)) > 0.10) step *= 0.25;
            /* ...and darkening always progresses by at least 1/1024 */
            for (int c = 0; c < 3; c++)
                if (delta[c] < 0.0) step[c] = max(delta[c], min(step[c], -1.0 / 1024.0));
            vec3 result = (!written || first) ? fresh : old + step;
            if (any(isnan(result)) || any(isinf(result))) result = vec3(0.0);
            a.v[texel] = uvec2(packHalf2x16(result.rg), packHalf2x16(vec2(result.b, 1.0)));
        } else {
            DdgiDistanceRef a = DdgiDistanceRef(vol.distance);
            vec2 fresh = wsum > 1e-6 ? sum.xy / wsum : a.v[texel];
            vec2 result = mix(fresh, a.v[texel], h);
            if (any(isnan(result)) || any(isinf(result))) result = vec2(max_dist, max_dist * max_dist);
            a.v[texel] = result;
        }
    }
    if (irradiance && lid == 0u) {
        bool inside = float(s_backfaces) > vol.params.z * float(n);
        vec4 pd = DdgiProbeRef(vol.probes).v[probe];
        pd.w = float(inside ? 0u : PC_DDGI_PROBE_ACTIVE);
        DdgiProbeRef(vol.probes).v[probe] = pd;
    }
}
