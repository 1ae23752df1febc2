/* shadow_map.glsl: lights' distance maps, read for the direct light at probe-ray hits. The DDGI
 * paper shades its probe hits like the camera's G-buffer, shadow maps included (Sec. 5); here a
 * map is traced, not rasterised (shadow_map.comp: one ray per texel through the scene's BVH),
 * and rebuilt only when the lights or the geometry change (renderer/gi/shadow_maps.h), so a probe
 * hit's visibility costs four texel reads instead of a shadow ray (a ray where they disagree:
 * probe_light_visibility; reflection hits too, for every light: direct_radiance with
 * DIRECT_MAP_VISIBILITY). Camera pixels keep exact shadow rays, except toward lights the map shows
 * certainly hidden (direct_radiance with DIRECT_CULLED_RAYS).
 *
 * Layout of the maps buffer (floats and uints of 4 bytes), a header, then the maps:
 * - words [0, MAX_LIGHTS): each light's map offset in words (0: the light has no valid map; its
 *   hits trace shadow rays);
 * - [MAX_LIGHTS, 2 MAX_LIGHTS): the build's order for each light's map (PC_SHADOW_MAP_KEEP,
 *   WHOLE or PART);
 * - PC_SHADOW_MAP_FRAME_WORD: the suns' frame (centre xyz, radius), then the box count;
 *   PC_SHADOW_MAP_BOX_WORD: PC_SHADOW_MAP_BOXES boxes (min xyz, 0, max xyz, 0);
 * - a point or spot light's map: 6 faces of SIDE^2 texels; face f looks along axis f / 2,
 *   toward + for even f, and spans [-1, 1]^2 over the two following axes at distance 1; a
 *   texel holds the distance from the light to the first surface along its centre direction;
 * - a directional light's map: SUN_SIDE^2 texels over a square across the frame's sphere (the
 *   scene's bounding sphere when the suns were last traced whole), seen along the light
 *   (shadow_map_sun_frame); a texel holds the distance from the square's plane, one radius
 *   before the centre, to the first surface along the light.
 * SHADOW_MAP_FAR where nothing is hit within the light's range. */
#ifndef PC_SHADOW_MAP_GLSL
#define PC_SHADOW_MAP_GLSL

layout(buffer_reference, std430, buffer_reference_align = 4) buffer ShadowMapRef { float v[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) buffer ShadowMapWordRef { uint v[]; };

#define SHADOW_MAP_FAR 3e38
/* A hit's lookup point q is moved off its surface along the geometric normal by NORMAL_OFFSET
 * texel widths (normal-offset shadows). A tap reads the distance along a ray up to 1.5 texels
 * (the filter's diagonal) from q's; where the surface is tilted by theta from the light, it
 * lies up to 1.5 tan(theta) texel widths nearer along that ray than at q's foot, while the
 * offset puts q NORMAL_OFFSET / cos(theta) widths before the surface along q's own ray: an
 * offset of 1.5 widths covers every tilt, with no depth bias to scale by slope (a slope-scaled
 * bias let light through walls onto the floors behind them: builtin two-rooms came out 31%
 * brighter). DEPTH_BIAS absorbs rounding. */
#define SHADOW_MAP_NORMAL_OFFSET 1.5
#define SHADOW_MAP_DEPTH_BIAS 0.1

/* Unit direction from the light through the point uv in [-1, 1]^2 of face f. */
vec3 shadow_map_dir(uint face, vec2 uv)
{
    uint a = face >> 1u;
    vec3 d;
    d[a] = (face & 1u) == 0u ? 1.0 : -1.0;
    d[(a + 1u) % 3u] = uv.x;
    d[(a + 2u) % 3u] = uv.y;
    return normalize(d);
}

/* The face a direction d (not zero) falls on and its point uv in [-1, 1]^2 there. */
uint shadow_map_face(vec3 d, out vec2 uv)
{
    vec3 ad = abs(d);
    uint a = ad.x >= ad.y && ad.x >= ad.z ? 0u : (ad.y >= ad.z ? 1u : 2u);
    uv = vec2(d[(a + 1u) % 3u], d[(a + 2u) % 3u]) / ad[a];
    return a * 2u + (d[a] < 0.0 ? 1u : 0u);
}

/* A directional light's map frame: the sphere (centre c, radius r) of the maps' header seen
 * along the light's direction d, with axes u, v across it. */
void shadow_map_sun_frame(uint64_t maps, vec3 d, out vec3 c, out float r, out vec3 u, out vec3 v)
{
    ShadowMapRef m = ShadowMapRef(maps);
    const uint f = PC_SHADOW_MAP_FRAME_WORD;
    c = vec3(m.v[f], m.v[f + 1u], m.v[f + 2u]);
    r = m.v[f + 3u];
    u = normalize(cross(abs(d.y) < 0.9 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0), d));
    v = cross(d, u);
}

/* Percentage-closer filter over the side x side grid at word `base`: the fraction of the four
 * texels around uv in [-1, 1]^2 whose stored distance lies beyond `reach`. */
float shadow_map_pcf(uint64_t maps, uint base, uint side, vec2 uv, float reach)
{
    float fs = float(side);
    vec2 xy = clamp((uv * 0.5 + 0.5) * fs - 0.5, vec2(0.0), vec2(fs - 1.0));
    uvec2 i0 = uvec2(min(floor(xy), vec2(fs - 2.0)));
    vec2 f = xy - vec2(i0);
    uint at = base + i0.y * side + i0.x;
    ShadowMapRef m = ShadowMapRef(maps);
    float v00 = reach >= m.v[at] ? 0.0 : 1.0;
    float v10 = reach >= m.v[at + 1u] ? 0.0 : 1.0;
    float v01 = reach >= m.v[at + side] ? 0.0 : 1.0;
    float v11 = reach >= m.v[at + side + 1u] ? 0.0 : 1.0;
    return mix(mix(v00, v10, f.x), mix(v01, v11, f.x), f.y);
}

/* Where light `index` (l) meets the surface point p (unit geometric normal ng on the light's
 * side), moved off it by `lift` texel widths along ng: the texel grid of its map (*base: the
 * face's or square's first word, *side), p's point uv in [-1, 1]^2 there and the distance
 * `reach` (less `bias` texel widths) that a texel's surface must lie beyond to let the light
 * reach p. False when the map cannot tell (the light has none, or p lies outside a directional
 * light's square). */
bool shadow_map_locate(uint64_t maps, uint index, pc_light l, vec3 p, vec3 ng, float lift,
                       float bias, out uint base, out uint side, out vec2 uv, out float reach)
{
    base = ShadowMapWordRef(maps).v[index];
    side = PC_SHADOW_MAP_SIDE;
    uv = vec2(0.0);
    reach = 0.0;
    if (base == 0u) return false;
    if (l.info.x == PC_LIGHT_DIRECTIONAL) {
        vec3 c, u, v;
        float r;
        vec3 d = l.direction.xyz;
        shadow_map_sun_frame(maps, d, c, r, u, v);
        float texel = 2.0 * r / float(PC_SHADOW_MAP_SUN_SIDE);
        vec3 rel = p + ng * (lift * texel) - c;
        uv = vec2(dot(rel, u), dot(rel, v)) / r;
        side = PC_SHADOW_MAP_SUN_SIDE;
        reach = dot(rel, d) + r - texel * bias;
        return all(lessThanEqual(abs(uv), vec2(1.0)));
    }
    vec3 lpos = l.position_range.xyz;
    float texel = 2.0 * length(p - lpos) / float(PC_SHADOW_MAP_SIDE); /* at most, at p */
    vec3 d = p + ng * (lift * texel) - lpos;
    uint face = shadow_map_face(d, uv);
    base += face * PC_SHADOW_MAP_SIDE * PC_SHADOW_MAP_SIDE;
    reach = length(d) - texel * bias;
    return true;
}

/* Fraction of light `index` (l) that reaches the surface point p with unit geometric normal ng
 * on the light's side, from the light's map; negative when the map cannot tell (the light has
 * none, or p lies outside a directional light's square): the caller then traces a ray. */
float shadow_map_visibility(uint64_t maps, uint index, pc_light l, vec3 p, vec3 ng)
{
    uint base, side;
    vec2 uv;
    float reach;
    if (!shadow_map_locate(maps, index, l, p, ng, SHADOW_MAP_NORMAL_OFFSET, SHADOW_MAP_DEPTH_BIAS,
                           base, side, uv, reach))
        return -1.0;
    return shadow_map_pcf(maps, base, side, uv, reach);
}

/* Whether the map of light `index` shows p certainly hidden from it: the 4 x 4 texels around
 * p's own direction (no normal offset, which shifts a shadow's edge by up to 1.5 texels: lit
 * points beside a slanted sun's shadow read 0 from shadow_map_visibility) all hold a surface
 * nearer than p by SHADOW_MAP_CULL_BIAS texel widths. Where p is lit, its own direction passes
 * the texels' surfaces, and on a receiver flat across a texel one of the four nearest lies at
 * least as far as p; so only openings narrower than a texel, or a receiver curved within one,
 * can make this wrong, and the texels beyond the nearest four (a footprint of three texels)
 * catch most such openings: with the four alone, 126 of builtin:interior's 129600 pixels at
 * 480x270 lost light that reaches the floor between a chair's slats and a table's legs, with
 * these sixteen 75, and with the tilted bias below 6 (mean -0.00%; NVIDIA H200,
 * tests/bench/results/h200/shadow_cull_stop42.txt).
 * PC_SHADOW_CULL_OFF (setting shadow_cull off) traces them all. */
/* The bias grows with the receiver's tilt from the light: across the footprint (texels up to
 * SHADOW_MAP_CULL_REACH widths from p's direction) a tilted receiver lies up to that many widths
 * times tan(tilt) nearer the light than p. At a shadow's edge only the footprint's texels on
 * one side pass the occluder, and on a slanted receiver they may all be the nearer side: with a
 * flat 0.5-texel bias, lit floor at the edge of hard:sun-room's window patch was culled (sun-room
 * +gltf -0.04 -> -0.41% against the path tracer, relMSE 0.0008 -> 0.0014, NVIDIA H200). */
#define SHADOW_MAP_CULL_BIAS 0.5
#define SHADOW_MAP_CULL_REACH 3.0
#define SHADOW_MAP_CULL_MAX_TAN 8.0
bool shadow_map_hidden(uint64_t maps, uint index, pc_light l, vec3 p, vec3 ng)
{
    uint base, side;
    vec2 uv;
    float reach;
    vec3 to_light = l.info.x == PC_LIGHT_DIRECTIONAL ? -l.direction.xyz
                                                     : normalize(l.position_range.xyz - p);
    float c = clamp(dot(ng, to_light), 1e-3, 1.0);
    float tilt = min(sqrt(max(1.0 - c * c, 0.0)) / c, SHADOW_MAP_CULL_MAX_TAN);
    float bias = SHADOW_MAP_CULL_BIAS + SHADOW_MAP_CULL_REACH * tilt;
    if (!shadow_map_locate(maps, index, l, p, ng, 0.0, bias, base, side, uv, reach)) return false;
    float fs = float(side);
    vec2 xy = clamp((uv * 0.5 + 0.5) * fs - 0.5, vec2(0.0), vec2(fs - 1.0));
    ivec2 i0 = ivec2(floor(xy)) - 1;
    ShadowMapRef m = ShadowMapRef(maps);
    for (int y = 0; y < 4; y++) {
        uint row = base + uint(clamp(i0.y + y, 0, int(side) - 1)) * side;
        for (int x = 0; x < 4; x++)
            if (m.v[row + uint(clamp(i0.x + x, 0, int(side) - 1))] >= reach) return false;
    }
    return true;
}

/* How much of light `index` (chosen for a probe hit, or any light at a reflection hit) at p
 * (unit geometric normal ng on the light's side, ray offset `offset`: pc_surface; the light at
 * distance dist along wi) reaches it: from the light's map where the update has one covering p
 * (lights [0, mapped) of the maps at `maps`) and its four texels agree, else from one shadow
 * ray, counted into rays. Where a
 * shadow's edge crosses the filter the map's answer is a blend, shifted by the normal offset
 * (1.5 texels, 7 cm at 3 m from a point light): the strip of floor a point light reaches
 * through builtin:hard:narrow-gap's 25 cm gap came out too narrow, and the dark side dark. A
 * ray at those texels only (probe shading +2%, builtin:interior on an NVIDIA H200) moved
 * narrow-gap+gltf -9.4% -> -8.8% against the path tracer, the other hard cases within noise. */
float probe_light_visibility(pc_scene_refs s, uint64_t maps, uint mapped, uint index, vec3 p,
                             vec3 ng, float offset, vec3 wi, float dist, inout uint rays)
{
    if (index < mapped) {
        float seen = shadow_map_visibility(maps, index, LightRef(s.lights).v[index], p, ng);
        if (seen == 0.0 || seen == 1.0) return seen;
    }
    return shadow_ray_clear(s, offset_ray_origin(p, ng, offset), wi, dist, rays) ? 1.0 : 0.0;
}

/* Radiance reflected toward v by a surface with BRDF b from all punctual lights:
 * sum over lights of f(v, l) * E_i * cos * visibility (lights below the shading or the geometric
 * surface give nothing; shadow rays start on the geometric side, moved by the surface's ray
 * offset, and are counted into rays). The lights' maps are lights [0, mapped) of `maps` (mapped
 * 0: none, as the path tracer passes; views pass mapped only while every map shows the scene as
 * it is, rd_world_fill_view_globals). Two visibilities, by `visibility`:
 *
 * DIRECT_CULLED_RAYS (camera pixels): ray-traced hard shadows, the maps only a cull: a light
 * whose map shows p certainly hidden (shadow_map_hidden) gets no shadow ray; every other light
 * gets its exact ray, so shadow edges, lit surfaces and lights without a map are as without
 * maps. The cull can err only where light passes through an opening narrower than a texel (5 cm
 * at 3 m from a point light: 128 texels a face), which the map does not see. Why: in
 * builtin:interior every pixel traced a ray to every light in front of it, 7.2 a pixel, most of
 * them to lamps in other rooms behind walls (issue 25).
 *
 * DIRECT_MAP_VISIBILITY (reflection hits): every light's visibility from its map where the map's
 * four texels agree (probe_light_visibility, as probe-ray hits take their chosen light's), a
 * shadow ray elsewhere, and exact rays for lights without a map. A reflection is seen through a
 * lobe that blurs it, and the map errs only at openings or occluders narrower than a texel; its
 * rays were most of the reflection pass. NVIDIA H100, builtin:interior 1080p (12 lights):
 * reflect 1.21 -> 0.93 ms; the converged image against the former's relMSE 0.00001 (74 of
 * 129,600 pixels off by 5%), against the path tracer unchanged (-40.52%, relMSE 0.1136);
 * cornell-glossy 0.230 -> 0.209 ms, the same image (tests/bench/results/h100/
 * reflection_hits_stop47.txt). One light chosen by its term instead (direct_radiance_sampled's
 * choice) took 0.85 ms, at the cost of selection noise in mirrors while the camera moves (no
 * history then). */
#define DIRECT_CULLED_RAYS 0u
#define DIRECT_MAP_VISIBILITY 1u
vec3 direct_radiance(pc_scene_refs s, uint64_t maps, uint mapped, uint visibility, vec3 p, vec3 n,
                     vec3 ng, float offset, vec3 v, pc_brdf b, inout uint rays)
{
    vec3 sum = vec3(0.0);
    vec3 origin = offset_ray_origin(p, ng, offset);
    for (uint i = 0u; i < s.counts.y; i++) {
        vec3 wi;
        float dist;
        vec3 f = light_term(s, i, p, n, ng, v, b, wi, dist);
        if (all(equal(f, vec3(0.0)))) continue;
        if (visibility == DIRECT_MAP_VISIBILITY) {
            sum += f * probe_light_visibility(s, maps, mapped, i, p, ng, offset, wi, dist, rays);
            continue;
        }
        if (i < mapped && shadow_map_hidden(maps, i, LightRef(s.lights).v[i], p, ng)) continue;
        if (shadow_ray_clear(s, origin, wi, dist, rays)) sum += f;
    }
    return sum;
}

#endif
