#version 460
/* DDGI border update: every border texel of every probe tile copies its octahedral wrap
 * source (ddgi-reference.md), so that bilinear filtering across a tile edge continues on
 * the sphere. One thread per border texel of each probe of the update's list (x: border texel,
 * workgroup y: list entry); params.x: 0 irradiance atlas, 1 distance atlas.
 * With T texels per side and I = T - 2 interior: corners <- (x > 0 ? 1 : I, y > 0 ? 1 : I);
 * top/bottom rows <- (T-1-x, 1 / I); left/right columns <- (1 / I, T-1-y). */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ddgi.glsl"

layout(local_size_x = PC_WG_1D) in;

uvec2 border_source(uvec2 p, uint side)
{
    uint inner = side - 2u, last = side - 1u;
    bool xb = p.x == 0u || p.x == last, yb = p.y == 0u || p.y == last;
    if (xb && yb) return uvec2(p.x > 0u ? 1u : inner, p.y > 0u ? 1u : inner);
    if (yb) return uvec2(last - p.x, p.y == 0u ? 1u : inner);
    return uvec2(p.x == 0u ? 1u : inner, last - p.y);
}

void main()
{
    pc_globals g = load_globals();
    pc_ddgi_volume vol = g.ddgi;
    bool irradiance = pc.params.x == 0u;
    uint side = irradiance ? vol.info.z : vol.info.w;
    uint per_probe = 4u * (side - 1u);
    uint k = gl_GlobalInvocationID.x;
    if (k >= per_probe) return;
    uint probe = ddgi_listed_probe(vol, gl_WorkGroupID.y);
    /* walk the border: top row, right column, bottom row, left column */
    uint last = side - 1u;
    uvec2 p;
    if (k < last) p = uvec2(k, 0u);
    else if (k < 2u * last) p = uvec2(last, k - last);
    else if (k < 3u * last) p = uvec2(last - (k - 2u * last), last);
    else p = uvec2(0u, last - (k - 3u * last));
    uvec2 s = border_source(p, side);
    uint dst = ddgi_texel(probe, side, p.x, p.y), src = ddgi_texel(probe, side, s.x, s.y);
    if (irradiance) {
        DdgiIrradianceRef a = DdgiIrradianceRef(vol.irradiance);
        a.v[dst] = a.v[src];
    } else {
        DdgiDistanceRef a = DdgiDistanceRef(vol.distance);
        a.v[dst] = a.v[src];
    }
}
