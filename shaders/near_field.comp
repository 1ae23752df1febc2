#version 460
/* Near-field rays of camera pixels (gpu_types.h, PC_NEAR_*): the light the probe field cannot
 * hold because it varies faster than the probe spacing: the darkening in a room's corners and
 * under contacts, the bounce inside a lamp shade. The field interpolates irradiance between
 * probes a spacing apart, so a corner pixel gets about what the open floor gets.
 *
 * Each pixel's irradiance is E(P, n) = integral of L cos over the hemisphere. Split the
 * hemisphere's directions into those whose ray meets a surface within R = PC_NEAR_REACH times
 * the smallest probe spacing and the rest. The first are what the field smooths away: this pass
 * traces them; the rest it takes as the field gives them. With a direction l sampled from the
 * cosine lobe (pdf cos / pi), one sample of the pixel's ratio to the field is
 *   r = pi L(hit) / E_field   when the ray hits within R,
 *   r = 1                     when it leaves (or points below the geometric surface),
 * and E = E_field * mean(r): exact where the far light is what the field says, and the field's
 * own error elsewhere (its E / pi stands in for the radiance of the directions that leave).
 * L(hit) is the path tracer's next vertex, one bounce deep: emission + direct light from one
 * light chosen by its contribution (direct_radiance_sampled, as probe-ray hits do) + occlusion
 * * A(N.V) / pi * the field's irradiance there (brdf_hit_albedo, as at reflection hits); a back
 * face of a single-sided surface absorbs. Per colour channel, the ratio's denominator is kept
 * above 1/64 of the field's brightest channel and r below PC_NEAR_RATIO_MAX.
 *
 * One pixel of each 2x2 block traces per frame (the frame index picks which), and each keeps a
 * running mean of its samples over the frames of the history epoch (params.x; the view starts
 * a new one when the camera, the size or the world change), at most PC_NEAR_HISTORY_MAX
 * samples long, then an exponential average of that length. ddgi_sample.comp filters the
 * means across neighbours on the same surface and multiplies the field's irradiance by them.
 * push: globals, buf0 = pc_gbuffer_texel[], buf1 = pc_counters, buf2 = uvec4 history[]
 *       (xyz: float bits of the mean ratio, w: epoch << 8 | samples, 0 = none),
 *       params.x = history epoch (24 bits). */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ddgi.glsl"

layout(local_size_x = PC_WG_2D_X, local_size_y = PC_WG_2D_Y) in;
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer GBufferRef { pc_gbuffer_texel v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer HistoryRef { uvec4 v[]; };

/* Radiance leaving the first surface along l within reach toward the pixel; false on a miss. */
bool near_radiance(pc_globals g, vec3 origin, vec3 n0, vec3 l, float reach, inout uint s, inout uint rays,
                   out vec3 radiance)
{
    pc_hit hit;
    rays++;
    radiance = vec3(0.0);
    if (!trace_ray(g.scene, origin, l, 0.0, reach, 0u, hit)) return false;
    if (hit.backface) {
        uint flags = floatBitsToUint(TriRef(g.scene.tris).v[hit.tri].v1.w);
        if ((flags & PC_TRI_DOUBLE_SIDED) == 0u) return true;
    }
    pc_surface sf = surface_at(g.scene, hit, l);
    pc_brdf b = surface_brdf(sf);
    vec3 direct = direct_radiance_sampled(g.scene, sf.position, sf.normal, sf.geom_normal,
                                          sf.offset, -l, b, rnd(s), rays);
    vec3 e = ddgi_irradiance_at_hit(g.ddgi, g.scene, false, env_irradiance(g.env, sf.normal),
                                    sf.position, sf.normal, l, hit.t, n0, DDGI_VIS_CLEAR_SIGMAS);
    vec3 a = brdf_hit_albedo(g.brdf_albedo, b, clamp(dot(sf.normal, -l), 0.0, 1.0));
    radiance = sf.emission + direct + sf.occlusion * a / PC_PI * e;
    return true;
}

void main()
{
    count_rays_begin();
    pc_globals g = load_globals();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint rays = 0u;
    if (all(lessThan(px, g.view.size.xy))) {
        uint i = px.y * g.view.size.x + px.x;
        uvec4 old = HistoryRef(pc.buf2).v[i];
        uint epoch = pc.params.x & 0xffffffu;
        uint frames = (old.w >> 8) == epoch ? old.w & 0xffu : 0u;
        /* the 2x2 block's pixels in the order 0, 3, 1, 2: the diagonal first */
        uint cell = (px.x & 1u) | ((px.y & 1u) << 1);
        uint turn = (g.view.size.z % PC_NEAR_INTERLEAVE);
        bool mine = cell == uint[4](0u, 3u, 1u, 2u)[turn];
        pc_gbuffer_texel t = GBufferRef(pc.buf0).v[i];
        if (mine && t.position.w >= 0.0) {
            vec3 p = t.position.xyz, n = t.normal.xyz, ng = t.geom_normal.xyz;
            vec3 v = normalize(g.view.eye.xyz - p);
            float reach = 0.5 * distance(g.view.eye.xyz, p);
            vec3 e = ddgi_irradiance(g.ddgi, g.scene, false, env_irradiance(g.env, n), p, n, v,
                                     reach, DDGI_VIS_CLEAR_SIGMAS);
            uint s = pcg(i ^ pcg(g.view.size.z ^ pcg(g.view.size.w ^ 0x6e3a1f5u)));
            vec3 l = brdf_sample_cosine(n, rnd(s), rnd(s));
            vec3 ratio = vec3(1.0);
            vec3 lh;
            float near =
                PC_NEAR_REACH * min(g.ddgi.spacing.x, min(g.ddgi.spacing.y, g.ddgi.spacing.z));
            if (dot(l, ng) > 0.0 &&
                near_radiance(g, offset_ray_origin(p, ng, t.albedo.w), n, l, near, s, rays, lh)) {
                vec3 floor_e = vec3(max(max3(e) / 64.0, 1e-12));
                ratio = min(PC_PI * lh / max(e, floor_e), vec3(PC_NEAR_RATIO_MAX));
            }
            if (any(isnan(ratio)) || any(isinf(ratio))) ratio = vec3(1.0);
            vec3 mean = frames > 0u ? uintBitsToFloat(old.xyz) : vec3(0.0);
            frames = min(frames + 1u, PC_NEAR_HISTORY_MAX);
            mean += (ratio - mean) / float(frames);
            HistoryRef(pc.buf2).v[i] = uvec4(floatBitsToUint(mean), epoch << 8 | frames);
        } else if (frames == 0u && old.w != 0u) {
            HistoryRef(pc.buf2).v[i] = uvec4(0u); /* an earlier epoch's: no longer valid */
        }
    }
    count_rays_end(pc.buf1, 8u, rays);
}
