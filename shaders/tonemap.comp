#version 460
/* Tone-map pass: linear radiance * exposure -> filmic curve (ACES fit, Narkowicz 2015) or
 * clamp -> sRGB-encoded RGBA8. Non-finite input becomes magenta so it cannot hide.
 * push: globals, buf0 = vec4 radiance[], buf1 = uint rgba8[]. */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(local_size_x = PC_WG_2D_X, local_size_y = PC_WG_2D_Y) in;
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer RadianceRef { vec4 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) writeonly buffer Rgba8Ref { uint v[]; };

vec3 aces_fit(vec3 x)
{
    return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

void main()
{
    pc_globals g = load_globals();
    uvec2 px = gl_GlobalInvocationID.xy;
    if (any(greaterThanEqual(px, g.view.size.xy))) return;
    uint i = px.y * g.view.size.x + px.x;
    vec4 acc = RadianceRef(pc.buf0).v[i]; /* w: samples accumulated (1 unless path traced) */
    vec3 c = acc.rgb / max(acc.w, 1.0) * g.view.tonemap.x;
    vec3 mapped;
    if (any(isnan(c)) || any(isinf(c))) mapped = vec3(1.0, 0.0, 1.0);
    else if (uint(g.view.tonemap.y) == PC_TONEMAP_CLAMP) mapped = linear_to_srgb(c);
    else mapped = linear_to_srgb(aces_fit(c));
    Rgba8Ref(pc.buf1).v[i] = packUnorm4x8(vec4(mapped, 1.0));
}
