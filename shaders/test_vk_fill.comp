// test_vk_fill.comp: y[i] = a * x[i] + i over uints, for tests/renderer/test_gpu_vk.c.
// Push constants (pc_push): buf0 = x, buf1 = y, params.x = element count, params.y = a.
#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require

#include "gpu_types.h"

layout(local_size_x = PC_WG_1D) in;

layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer UintsIn
{
    uint v[];
};
layout(buffer_reference, std430, buffer_reference_align = 4) writeonly buffer UintsOut
{
    uint v[];
};

layout(push_constant) uniform Push
{
    pc_push pc;
};

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.params.x) return;
    UintsIn x = UintsIn(pc.buf0);
    UintsOut y = UintsOut(pc.buf1);
    y.v[i] = pc.params.y * x.v[i] + i;
}
