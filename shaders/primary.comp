#version 460
/* Primary pass: one camera ray per pixel, closest hit, writes the G-buffer (surface position,
 * normals (the shading normal normal-mapped), base colour, emission, metallic, roughness,
 * occlusion, specular weight; position.w < 0 for a miss). Back faces of single-sided
 * materials are culled, as a rasteriser would; alpha-masked texels are cut out.
 * It also counts the pixels that trace reflection rays (gbuffer_traces_reflection) into a
 * pc_reflect_control and opens its indirect dispatch when there is one, so that the
 * reflection passes of a frame without a glossy pixel in sight do no work at all.
 * push: globals, buf0 = pc_gbuffer_texel[width*height], buf1 = pc_counters,
 * buf2 = pc_reflect_control (0: reflections off, nothing counted). */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(local_size_x = PC_WG_2D_X, local_size_y = PC_WG_2D_Y) in;
layout(buffer_reference, std430, buffer_reference_align = 16) writeonly buffer GBufferRef { pc_gbuffer_texel v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer ReflectRef { pc_reflect_control c; };

shared uint wg_glossy; /* pixels of this workgroup that trace reflections */

void main()
{
    if (gl_LocalInvocationIndex == 0u) wg_glossy = 0u; /* count_rays_begin's barrier follows */
    count_rays_begin();
    pc_globals g = load_globals();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint rays = 0u;
    bool glossy = false;
    if (all(lessThan(px, g.view.size.xy))) {
        vec3 dir = camera_dir(g.view, px);
        pc_hit hit;
        pc_gbuffer_texel o;
        rays = 1u;
        if (trace_ray(g.scene, g.view.eye.xyz, dir, 0.0, 1e30, PC_TRACE_CULL_BACKFACES, hit)) {
            pc_surface sf = surface_at(g.scene, hit, dir);
            o.position = vec4(sf.position, hit.t);
            o.normal = vec4(sf.normal, uintBitsToFloat(hit.instance));
            o.geom_normal = vec4(sf.geom_normal, uintBitsToFloat(hit.tri));
            o.albedo = vec4(sf.albedo, sf.offset);
            o.emission = vec4(sf.emission, 0.0);
            o.material = vec4(sf.metallic, sf.roughness, sf.occlusion, sf.specular);
        } else {
            o.position = vec4(dir, -1.0);
            o.normal = vec4(0.0);
            o.geom_normal = vec4(0.0);
            o.albedo = vec4(0.0);
            o.emission = vec4(env_radiance(g.env, dir), 0.0);
            o.material = vec4(0.0, 1.0, 1.0, 0.0);
        }
        GBufferRef(pc.buf0).v[px.y * g.view.size.x + px.x] = o;
        glossy = pc.buf2 != 0ul && gbuffer_traces_reflection(o);
    }
    if (glossy) atomicAdd(wg_glossy, 1u);
    count_rays_end(pc.buf1, 0u, rays); /* its barrier also completes wg_glossy */
    if (gl_LocalInvocationIndex == 0u && wg_glossy != 0u) {
        ReflectRef r = ReflectRef(pc.buf2);
        atomicAdd(r.c.args.w, wg_glossy);
        atomicMax(r.c.args.x, gl_NumWorkGroups.x);
    }
}
