#version 460
/* Exclusive prefix sum of the probe-hit bins (ddgi_bin.comp) in one workgroup: the counts
 * become each cell's first position in the sorted list, and the list's length the size of the
 * sorted probe-shading dispatch (pc_ddgi_control.shade_args).
 * push: globals, buf0 = uint bins[PC_DDGI_BINS]. */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ddgi.glsl"

layout(local_size_x = PC_WG_1D) in;
layout(buffer_reference, std430, buffer_reference_align = 4) buffer BinRef { uint v[]; };

shared uint partial[PC_WG_1D];

void main()
{
    pc_globals g = load_globals();
    BinRef bins = BinRef(pc.buf0);
    const uint per = (PC_DDGI_BINS + PC_WG_1D - 1u) / PC_WG_1D;
    uint i = gl_LocalInvocationID.x, first = i * per, last = min(first + per, PC_DDGI_BINS);
    uint sum = 0u;
    for (uint k = first; k < last; k++) sum += bins.v[k];
    partial[i] = sum;
    barrier();
    if (i == 0u) { /* 64 partial sums: a sequential scan is as fast as anything here */
        uint run = 0u;
        for (uint k = 0u; k < PC_WG_1D; k++) {
            uint s = partial[k];
            partial[k] = run;
            run += s;
        }
        DdgiControlRef ctrl = DdgiControlRef(g.ddgi.ctrl);
        ctrl.shade_args = uvec4((run + PC_WG_1D - 1u) / PC_WG_1D, 1u, 1u, run);
    }
    barrier();
    uint run = partial[i];
    for (uint k = first; k < last; k++) {
        uint c = bins.v[k];
        bins.v[k] = run;
        run += c;
    }
}
