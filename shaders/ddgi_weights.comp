#version 460
/* DDGI blend weights of one update (paper Sec. 4.2): one workgroup per interior texel of the
 * two tiles, the irradiance tile's PC_DDGI_IRR_INTERIOR^2 texels first, then the distance
 * tile's. A texel's weight for ray i depends only on the texel's direction and the ray's, and
 * every probe shares the update's rotated ray set, so the weights are the same for all probes:
 * this pass lists, per texel and in increasing ray order, the rays with a weight above zero and
 * their weights (irradiance: max(0, cos); distance: cos^50 where cos > DDGI_DIST_MIN_COS), and
 * the blends (ddgi_blend.glsl) visit only those. Each probe's blend used to test every ray of a
 * band of polar angles around its texel and weigh it itself: the distance blend visited about
 * 4.6 times the rays that count (cos^50 leaves a cap of 37 degrees, a tenth of the sphere), the
 * irradiance blend 1.8 times (a hemisphere). The distance blend always walks the lists (H200,
 * 32 x 8 x 32 probes x 256 rays: 0.40 -> 0.08 ms; lavapipe 2.6x faster); the irradiance blend
 * walks them on a CPU device only (lavapipe 1.7x faster; on a GPU its band loop is faster:
 * ddgi_blend.glsl, tests/bench/results/h200/blend_weights.txt).
 * The workgroup's threads weigh WG rays at a time and place them by a prefix sum over the
 * workgroup (a serial loop per texel cost an H200 0.09 ms per update at 1024 rays); the order,
 * and so every blend's sum, is the same on every run.
 * push: globals. */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ddgi.glsl"

#define WG 64u
layout(local_size_x = WG) in;

shared uint s_scan[WG];

void main()
{
    pc_globals g = load_globals();
    pc_ddgi_volume vol = g.ddgi;
    uint texel = gl_WorkGroupID.x, lid = gl_LocalInvocationIndex;
    bool irradiance = texel < PC_DDGI_IRR_TEXELS;
    uint interior = irradiance ? PC_DDGI_IRR_INTERIOR : PC_DDGI_DIST_INTERIOR;
    uint local = irradiance ? texel : texel - PC_DDGI_IRR_TEXELS;
    vec3 texel_dir = oct_texel_dir(uvec2(local % interior, local / interior), interior);
    uint n = vol.counts.w;
    DdgiWeightRef list = DdgiWeightRef(vol.weights + PC_DDGI_WEIGHT_HEADER);
    uint count = 0u; /* entries so far (the same in every thread) */
    for (uint base = 0u; base < n; base += WG) {
        uint i = base + lid;
        float weight =
            i < n ? ddgi_blend_weight(irradiance, dot(texel_dir, ddgi_ray_dir(vol, i))) : 0.0;
        s_scan[lid] = weight > 0.0 ? 1u : 0u;
        barrier();
        for (uint step = 1u; step < WG; step <<= 1) { /* inclusive prefix sum */
            uint add = lid >= step ? s_scan[lid - step] : 0u;
            barrier();
            s_scan[lid] += add;
            barrier();
        }
        if (weight > 0.0)
            list.v[(count + s_scan[lid] - 1u) * PC_DDGI_WEIGHT_TEXELS + texel] = uvec2(i, floatBitsToUint(weight));
        count += s_scan[WG - 1u];
        barrier(); /* everyone read the total before the next chunk writes */
    }
    if (lid == 0u) DdgiWeightCountRef(vol.weights).v[texel] = count;
}
