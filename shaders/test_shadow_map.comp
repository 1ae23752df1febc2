#version 460
/* test_shadow_map.comp: a light's visibility from surface points two ways, for
 * tests/renderer/test_gpu_shadow_maps.c: from the world's distance maps (shadow_map_visibility,
 * as probe hits read it) and from a shadow ray (as camera pixels trace it).
 * push: globals (the world's, after an update), buf0 = points (vec4 position in the GPU frame,
 * vec4 unit geometric normal with w = the ray offset of its surface, pc_surface.offset), buf1 =
 * results (vec4: x map visibility, or -2 when the update mapped no light this far, -1 when the
 * map cannot tell; y 1 when the shadow ray reaches the light, else 0; z cosine between the
 * normal and the light; w 1 when view frames cull the light's shadow ray there:
 * shadow_map_hidden), params.x = point count, params.y = the light. */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "shadow_map.glsl"

layout(local_size_x = PC_WG_1D) in;
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer PointRef { vec4 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) writeonly buffer OutRef { vec4 v[]; };

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.params.x) return;
    pc_globals g = load_globals();
    /* the normal and offset as one load: on lavapipe (LLVM 15) a second load of the same vec4
     * for its w alone, after one of its xyz, read 0 */
    vec4 nw = PointRef(pc.buf0).v[2u * i + 1u];
    vec3 p = PointRef(pc.buf0).v[2u * i].xyz, n = nw.xyz;
    float offset = nw.w;
    uint index = pc.params.y;
    pc_light l = LightRef(g.scene.lights).v[index];
    vec3 wi;
    float dist;
    light_incident(l, p, wi, dist);
    float map = -2.0, hidden = 0.0;
    if (index < g.ddgi.control.w) {
        map = shadow_map_visibility(g.ddgi.shadow_maps, index, l, p, n);
        hidden = shadow_map_hidden(g.ddgi.shadow_maps, index, l, p, n) ? 1.0 : 0.0;
    }
    uint rays = 0u;
    bool clear = shadow_ray_clear(g.scene, offset_ray_origin(p, n, offset), wi, dist, rays);
    OutRef(pc.buf1).v[i] = vec4(map, clear ? 1.0 : 0.0, dot(n, wi), hidden);
}
