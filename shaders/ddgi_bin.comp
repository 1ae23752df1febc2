#version 460
/* DDGI probe-hit binning (issue 14: probe shading cost): a counting sort of the update's probe
 * rays by where they ended, so that probe shading (ddgi_shade.comp, sorted mode) runs the shadow
 * rays of neighbouring hits side by side. Shadow rays from hits scattered over the scene were 83%
 * of probe shading and ran at a quarter of the speed of the view's shadow rays (measurements:
 * tests/bench/results/h200/probe_shading.txt). Cells: a 16^3 grid over the probe volume in Morton
 * order. Misses and back faces are not binned: the counting pass shades them (the sky's radiance,
 * or nothing), which also keeps the many misses of an open scene off one contended counter.
 * params.x = 0: shade misses, count hits per cell; 1: scatter the hits' ray slots to their cells'
 * ranges (the bins then hold running offsets, ddgi_scan.comp made them). Dispatched like
 * ddgi_trace.comp: x ray groups, y listed probes; only active probes' rays are shaded, so only
 * they are binned.
 * push: globals, buf0 = uint bins[PC_DDGI_BINS], buf1 = uvec4 hits[], buf2 = uint sorted[]
 * (ray slots). */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ddgi.glsl"

layout(local_size_x = PC_WG_1D) in;
layout(buffer_reference, std430, buffer_reference_align = 4) buffer BinRef { uint v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer HitRef { uvec4 v[]; };

uint spread3(uint v) /* 4 bits -> every third bit */
{
    v &= 15u;
    v = (v | (v << 4u)) & 0x0C3u;
    v = (v | (v << 2u)) & 0x249u;
    return v;
}

void main()
{
    pc_globals g = load_globals();
    pc_ddgi_volume vol = g.ddgi;
    uint ray = gl_GlobalInvocationID.x, probe = ddgi_listed_probe(vol, gl_WorkGroupID.y);
    if (ray >= vol.counts.w || !ddgi_probe_active(vol, probe)) return;
    uint slot = probe * vol.counts.w + ray;
    uvec4 rec = HitRef(pc.buf1).v[slot];
    float t = DdgiRayRef(vol.rays).v[slot].w;
    if (rec.x == PC_INVALID || t < 0.0) { /* a miss sees the sky; a back face carries nothing */
        if (pc.params.x == 0u)
            DdgiRayRef(vol.rays).v[slot] = vec4(ddgi_miss_radiance(g.env, vol, ray, rec.x), t);
        return;
    }
    vec3 p = ddgi_probe_position(vol, probe) + ddgi_ray_dir(vol, ray) * t;
    vec3 size = max(vec3(vol.counts.xyz - 1u) * vol.spacing.xyz, vec3(1e-6));
    uvec3 c = uvec3(clamp(ivec3(floor((p - vol.origin.xyz) / size * float(PC_DDGI_BIN_SIDE))),
                          ivec3(0), ivec3(int(PC_DDGI_BIN_SIDE) - 1)));
    uint cell = spread3(c.x) | (spread3(c.y) << 1u) | (spread3(c.z) << 2u);
    BinRef bins = BinRef(pc.buf0);
    if (pc.params.x == 0u) {
        atomicAdd(bins.v[cell], 1u);
    } else {
        uint at = atomicAdd(bins.v[cell], 1u);
        BinRef(pc.buf2).v[at] = slot;
    }
}
