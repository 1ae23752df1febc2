#version 460
/* DDGI probe trace (paper Sec. 4.1): one thread per (probe ray, probe). Rays follow the
 * update's randomly rotated spherical Fibonacci directions (ray generation happens here, in
 * registers). Writes per ray: hits[] = (tri, instance, u bits, v bits) and rays[].w = hit
 * distance (1e27 for a miss, -DDGI_BACKFACE_DISTANCE t for a back face of a single-sided
 * surface, which marks a probe that may sit inside geometry). ddgi_shade.comp fills in the radiance.
 * Works on the update's probe list (ddgi_select.comp; dispatched indirectly: x ray groups, y
 * listed probes). Off probes trace only their first PC_DDGI_INACTIVE_RAYS rays (for
 * re-classification).
 * push: globals, buf0 = uvec4 hits[], buf1 = pc_counters. */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ddgi.glsl"

layout(local_size_x = PC_WG_1D) in;
layout(buffer_reference, std430, buffer_reference_align = 16) writeonly buffer HitRef { uvec4 v[]; };

void main()
{
    count_rays_begin();
    pc_globals g = load_globals();
    pc_ddgi_volume vol = g.ddgi;
    uint ray = ddgi_thread_ray(vol, gl_GlobalInvocationID.x), probe = ddgi_listed_probe(vol, gl_WorkGroupID.y);
    uint rays = 0u;
    bool wanted = ray < vol.counts.w &&
                  (ray < PC_DDGI_INACTIVE_RAYS || ddgi_probe_active(vol, probe));
    if (wanted) {
        uint slot = probe * vol.counts.w + ray;
        vec3 org = ddgi_probe_position(vol, probe);
        vec3 dir = ddgi_ray_dir(vol, ray);
        pc_hit hit;
        float t = 1e27;
        uvec4 rec = uvec4(PC_INVALID);
        rays = 1u;
        if (trace_ray(g.scene, org, dir, 0.0, 1e30, 0u, hit)) {
            bool single_sided = (floatBitsToUint(TriRef(g.scene.tris).v[hit.tri].v1.w) & PC_TRI_DOUBLE_SIDED) == 0u;
            t = hit.backface && single_sided ? -DDGI_BACKFACE_DISTANCE * hit.t : hit.t;
            rec = uvec4(hit.tri, hit.instance, floatBitsToUint(hit.u), floatBitsToUint(hit.v));
        }
        HitRef(pc.buf0).v[slot] = rec;
        DdgiRayRef(vol.rays).v[slot] = vec4(0.0, 0.0, 0.0, t);
    }
    count_rays_end(pc.buf1, 2u, rays);
}
