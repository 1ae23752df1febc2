#version 460
/* Builds the lights' distance maps (layout: shadow_map.glsl): one closest-hit ray per texel,
 * from the light through the texel's centre up to the light's range, or, for a directional
 * light, from the texel's centre on the square's plane along the light across the scene's
 * bounding sphere. A spot light traces only the texels its cone (widened by two texels, the
 * reach of a lookup's filter) can light and marks the rest far. A light ordered PART re-traces
 * only the texels whose rays cross a box of moved geometry: elsewhere the first surface is the
 * same.
 * Dispatches (params.x): PASS_CUBES traces whole the maps of point and spot lights ordered
 * WHOLE (x: groups over 6 SIDE^2 texels, z: lights [0, z)), PASS_SUNS those of directional
 * lights (x: groups over SUN_SIDE^2 texels); PASS_RECT re-traces a rectangle of a light ordered
 * PART: params.y the light, params.z the face (SUN_FACE: a sun's square), params.w
 * x0 | y0 << 16, buf2 width | height << 32 (renderer/gi/shadow_maps.c picks rectangles around the
 * moved boxes' projections).
 * push: globals, buf0 = the maps buffer, buf1 = pc_counters. */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "shadow_map.glsl"

layout(local_size_x = PC_WG_1D) in;

/* Does the ray (org, dir, up to tmax) cross a box of the header's moved geometry? The same
 * slab test as the traversal's (trace.glsl). */
bool crosses_moved(uint64_t maps, vec3 org, vec3 dir, float tmax)
{
    ShadowMapRef m = ShadowMapRef(maps);
    uint n = min(ShadowMapWordRef(maps).v[PC_SHADOW_MAP_FRAME_WORD + 4u], PC_SHADOW_MAP_BOXES);
    vec3 inv;
    bvec3 neg;
    trace_setup_box(dir, inv, neg);
    for (uint k = 0u; k < n; k++) {
        uint at = PC_SHADOW_MAP_BOX_WORD + 8u * k;
        vec4 lo = vec4(m.v[at], m.v[at + 1u], m.v[at + 2u], 0.0);
        vec4 hi = vec4(m.v[at + 4u], m.v[at + 5u], m.v[at + 6u], 0.0);
        float tn;
        if (trace_box(lo, hi, org, inv, neg, 0.0, tmax, tn)) return true;
    }
    return false;
}

void main()
{
    count_rays_begin();
    pc_globals g = load_globals();
    uint texel = gl_GlobalInvocationID.x, index = gl_WorkGroupID.z;
    const uint face_texels = PC_SHADOW_MAP_SIDE * PC_SHADOW_MAP_SIDE;
    bool region = pc.params.x == PC_SHADOW_MAP_PASS_RECT, inside = true;
    if (region) { /* texel j of the rectangle, as the whole map's texel */
        index = pc.params.y;
        uint w = uint(pc.buf2 & 0xFFFFFFFFul), h = uint(pc.buf2 >> 32u), j = texel;
        bool sun_face = pc.params.z == PC_SHADOW_MAP_SUN_FACE;
        uint side = sun_face ? PC_SHADOW_MAP_SUN_SIDE : PC_SHADOW_MAP_SIDE;
        uint x = (pc.params.w & 0xFFFFu) + j % w, y = (pc.params.w >> 16u) + j / w;
        inside = j < w * h;
        texel = (sun_face ? 0u : pc.params.z * face_texels) + y * side + x;
    }
    uint rays = 0u;
    pc_light l = LightRef(g.scene.lights).v[index];
    bool sun = l.info.x == PC_LIGHT_DIRECTIONAL;
    uint base = ShadowMapWordRef(pc.buf0).v[index];
    uint order = ShadowMapWordRef(pc.buf0).v[PC_SHADOW_MAP_MAX_LIGHTS + index];
    uint texels = sun ? PC_SHADOW_MAP_SUN_SIDE * PC_SHADOW_MAP_SUN_SIDE : 6u * face_texels;
    bool mine = region ? order == PC_SHADOW_MAP_PART && inside
                       : order == PC_SHADOW_MAP_WHOLE && sun == (pc.params.x == PC_SHADOW_MAP_PASS_SUNS);
    if (mine && base != 0u && texel < texels) {
        vec3 org, dir;
        float tmax;
        bool wanted = true;
        if (sun) {
            uint side = PC_SHADOW_MAP_SUN_SIDE;
            vec2 uv = (vec2(texel % side, texel / side) + 0.5) / float(side) * 2.0 - 1.0;
            vec3 c, u, v;
            float r;
            dir = l.direction.xyz;
            shadow_map_sun_frame(pc.buf0, dir, c, r, u, v);
            org = c + (uv.x * u + uv.y * v - dir) * r;
            tmax = 2.0 * r;
        } else {
            uint face = texel / face_texels, at = texel - face * face_texels;
            uint side = PC_SHADOW_MAP_SIDE;
            vec2 uv = (vec2(at % side, at / side) + 0.5) / float(side) * 2.0 - 1.0;
            dir = shadow_map_dir(face, uv);
            org = l.position_range.xyz;
            tmax = l.position_range.w > 0.0 ? l.position_range.w : 1e30;
            if (l.info.x == PC_LIGHT_SPOT) {
                float margin = 4.0 / float(side); /* two texels' angle at a face centre */
                float outer = acos(clamp(l.spot.x, -1.0, 1.0));
                wanted = dot(dir, l.direction.xyz) >= cos(min(outer + margin, PC_PI));
            }
        }
        if (order == PC_SHADOW_MAP_PART) wanted = wanted && crosses_moved(pc.buf0, org, dir, tmax);
        else if (!wanted) ShadowMapRef(pc.buf0).v[base + texel] = SHADOW_MAP_FAR;
        float t = SHADOW_MAP_FAR;
        if (wanted) {
            pc_hit hit;
            rays = 1u;
            if (trace_ray(g.scene, org, dir, 0.0, tmax, 0u, hit)) t = hit.t;
        }
        if (wanted) ShadowMapRef(pc.buf0).v[base + texel] = t;
    }
    count_rays_end(pc.buf1, 6u, rays);
}
