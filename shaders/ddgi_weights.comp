#version 460
/* DDGI blend weights of one update (paper Sec. 4.2): one thread per interior texel of the two
 * tiles, the irradiance tile's PC_DDGI_IRR_INTERIOR^2 texels first, then the distance tile's.
 * A texel's weight for ray i depends only on the texel's direction and the ray's, and every
 * probe shares the update's rotated ray set, so the weights are the same for all probes: this
 * pass lists, per texel and in increasing ray order, the rays with a weight above zero and their
 * weights (irradiance: max(0, cos); distance: cos^50 where cos > DDGI_DIST_MIN_COS), and the
 * blends (ddgi_blend.glsl) visit only those. Each probe's blend used to test every ray of a
 * band of polar angles around its texel and weigh it itself: the distance blend visited about
 * 4.6 times the rays that count (cos^50 leaves a cap of 37 degrees, a tenth of the sphere), the
 * irradiance blend 1.8 times (a hemisphere), and on lavapipe those loops were the blends' cost.
 * push: globals. */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ddgi.glsl"

layout(local_size_x = PC_WG_1D) in;

void main()
{
    pc_globals g = load_globals();
    pc_ddgi_volume vol = g.ddgi;
    uint texel = gl_GlobalInvocationID.x;
    if (texel >= PC_DDGI_WEIGHT_TEXELS) return;
    bool irradiance = texel < PC_DDGI_IRR_TEXELS;
    uint interior = irradiance ? PC_DDGI_IRR_INTERIOR : PC_DDGI_DIST_INTERIOR;
    uint local = irradiance ? texel : texel - PC_DDGI_IRR_TEXELS;
    vec3 texel_dir = oct_texel_dir(uvec2(local % interior, local / interior), interior);
    uint n = vol.counts.w;
    DdgiWeightRef w = DdgiWeightRef(vol.weights + PC_DDGI_WEIGHT_HEADER);
    uint count = 0u;
    for (uint i = 0u; i < n; i++) {
        float weight = ddgi_blend_weight(irradiance, dot(texel_dir, ddgi_ray_dir(vol, i)));
        if (weight > 0.0) w.v[texel * n + count++] = uvec2(i, floatBitsToUint(weight));
    }
    DdgiWeightCountRef(vol.weights).v[texel] = count;
}
