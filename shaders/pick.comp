#version 460
/* Pick pass: ONE camera ray through a picture point, traced like the primary pass's (closest
 * hit with trace_ray, back faces of single-sided materials culled, alpha-masked texels cut
 * out), for POST /v1/views/{id}/pick (renderer/pick.h). One invocation runs.
 * push: globals (the view's camera in g.view), buf0 = pc_pick_result,
 * params.xy = the point (float bits; normalised picture coordinates, y down). */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(local_size_x = 1) in;
layout(buffer_reference, std430, buffer_reference_align = 16) writeonly buffer PickRef { pc_pick_result r; };

void main()
{
    pc_globals g = load_globals();
    vec2 uv = vec2(uintBitsToFloat(pc.params.x), uintBitsToFloat(pc.params.y));
    vec3 dir = camera_dir_at(g.view, uv);
    pc_hit hit;
    pc_pick_result o;
    o.position = vec4(0.0);
    o.normal = vec4(0.0);
    o.info = uvec4(0u);
    if (trace_ray(g.scene, g.view.eye.xyz, dir, 0.0, 1e30, PC_TRACE_CULL_BACKFACES, hit)) {
        pc_surface sf = surface_at(g.scene, hit, dir);
        o.position = vec4(sf.position, hit.t);
        o.normal = vec4(sf.geom_normal, 0.0);
        o.info = uvec4(1u, hit.instance, hit.tri, 0u);
    }
    PickRef(pc.buf0).r = o;
}
